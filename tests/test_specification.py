"""Achievable signatures, least orders and isolability against Varga's published examples.

Model data and expected results are transcribed from the test suite of Varga's
FaultDetectionTools (fdigenspec / fdichkspec / efdisyn tests) and the book (A. Varga,
*Solving Fault Diagnosis Problems*, Springer 2017): Yuan et al. (1997), Example 5.4,
Niemann (1998), Xiong & Saif (2000, examples 1 and 2), the linearised Boeing 747 (Varga
2007) and the lecture examples with poles and zeros on the imaginary axis.  Transfer
function models are entered by hand-made minimal realisations.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.errors import GeomFDIError, ShapeError


def rows(S) -> set[str]:
    """Rows of a bool matrix as bit strings (fault 1 first), e.g. ``{"011", "110"}``."""
    return {"".join(str(int(v)) for v in r) for r in np.asarray(S)}


def all_rows(nf: int) -> np.ndarray:
    """Every non-zero row, in increasing binary value (Varga's ``dec2binmat(1:2^nf-1)``)."""
    return np.array([[int(b) for b in np.binary_repr(k, nf)] for k in range(1, 2**nf)])


# ----------------------------------------------------------------------------- models
def yuan():
    A = [[-1, 1, 0, 0], [1, -2, 1, 0], [0, 1, -2, 1], [0, 0, 1, -2]]
    Bf = np.array(
        [
            [1, 0, 0, 0, 1, 0, 0, 0],
            [0, 1, 0, 0, -1, 1, 0, 0],
            [0, 0, 1, 0, 0, -1, 1, 0],
            [0, 0, 0, 1, 0, 0, -1, 1],
        ],
        dtype=float,
    )
    C = [[1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
    plant = gf.Plant(A, [[1], [0], [0], [0]], C)
    return plant, [gf.ActuatorFault(Bf[:, j], name=f"f{j + 1}") for j in range(8)]


def example_5_4():
    # Gu = [(s+1)/(s-2); (s+2)/(s-3)], Gd = [(s-1)/(s+2); 0]; f1 enters as u, f2 on y2
    A = np.diag([2.0, 3.0, -2.0])
    B, D = np.array([[1.0], [1.0], [0.0]]), np.array([[1.0], [1.0]])
    plant = gf.Plant(
        A, B, [[3, 0, -3], [0, 5, 0]], D, Bd=[[0], [0], [1]], Dd=np.array([[1.0], [0.0]])
    )
    return plant, [gf.Fault(B, D), gf.SensorFault(1)]


def niemann():
    a = 1000 * np.array(
        [
            [-0.0782, 0.2939, 0.0220, 0.0208, -0.0291],
            [0.0077, -0.0278, 0.0015, -0.0015, 0.0026],
            [-1.3251, 5.32608, -0.5263, 0.2214, -0.4777],
            [1.0809, -4.4452, 0.3770, -0.4631, 0.4032],
            [2.1532, -8.6386, 0.7811, -0.5745, 0.7816],
        ]
    )
    bd = 1000 * np.array([[0.0443], [-0.0042], [0.7910], [-0.6598], [-1.2881]])
    bu = np.array(
        [
            [-0.007197, 0.003005],
            [0.003473, 0.000284],
            [1.218502, -0.032866],
            [1.322502, 0.020147],
            [-0.082265, 0.024388],
        ]
    )
    return gf.Plant(a, bu, np.eye(5), Bd=bd), [gf.ActuatorFault(bu[:, j]) for j in range(2)]


def xiong_saif_1():
    a = [
        [-9.9477, -0.7476, 0.2632, -5.0337],
        [52.1659, 2.7452, 5.5532, -24.4221],
        [26.0922, 2.6361, -4.1975, -19.2774],
        [0.0, 0.0, 1.0, 0.0],
    ]
    bu = np.array([[0.4422, 0.1761], [3.5446, -7.5922], [-5.52, 4.49], [0.0, 0.0]])
    bd = [[0, 0], [0, 1], [1, 0], [0, 0]]
    c = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 1, 1, 1]]
    return gf.Plant(a, bu, c, Bd=bd), [gf.ActuatorFault(bu[:, 0]), gf.SensorFault(2)]


def xiong_saif_2():
    a = [
        [0, 0, -0.0034, 0, 0],
        [0, -0.041, 0.0013, 0, 0],
        [0, 0, -1.1471, 0, 0],
        [0, 0, -0.0036, 0, 0],
        [0, 0.094, 0.0057, 0, -0.051],
    ]
    bu = np.array([[-1, 0, 0], [0, 0, 0], [0, 0, 0.948], [0.916, -1, 0], [-0.598, 0, 0]])
    bd = [[0, 1], [0.062, -0.132], [0, -7.189], [0, 0], [0, 0]]
    c = [[1, 0, 0, 0, 0], [0, 0, 1, 0, 0], [0, 0, 0, 1, 0]]
    return gf.Plant(a, bu, c, Bd=bd), [gf.ActuatorFault(bu[:, j]) for j in range(2)]


def boeing_747():
    A = [
        [-0.4861, 0.000317, -0.5588, 0, -2.04e-6],
        [0, -0.0199, 3.0796, -9.8048, 8.98e-5],
        [1.0053, -0.0021, -0.5211, 0, 9.30e-6],
        [1, 0, 0, 0, 0],
        [0, 0, -92.6, 92.6, 0],
    ]
    Bu = np.zeros((5, 9))
    Bu[0] = [-0.1455, -0.1455, -0.1494, -0.1494, -1.2860, 0.0013, 0.0035, 0.0035, 0.0013]
    Bu[1] = [0, 0, 0, 0, -0.3122, 0.1999, 0.1999, 0.1999, 0.1999]
    Bu[2] = [-0.0071, -0.0071, -0.0074, -0.0074, -0.0676, -0.0004, -0.0004, -0.0004, -0.0004]
    C = [
        [0, 0, 1, 0, 0],
        [0, -0.0199, 3.0796, -9.8048, 8.98e-5],
        [0, 0, 0, 1, 0],
        [1, 0, 0, 0, 0],
        [0, 0, -92.6, 92.6, 0],
        [0, 0, 0, 0, 1],
    ]
    Du = np.zeros((6, 9))
    Du[1] = Bu[1]
    return gf.Plant(A, Bu, C, Du), [gf.Fault(Bu[:, j], Du[:, j]) for j in range(5)]


def lecture_6():
    # Gu = [1/s; 1/s], Gd = [0; s/(s+3)], Gf = [(s+1)/(s+2); 1/(s+2)]
    A = np.diag([0.0, -3.0, -2.0])
    C = [[1, 0, -1], [1, -3, 1]]
    plant = gf.Plant(A, [[1], [0], [0]], C, Bd=[[0], [1], [0]], Dd=np.array([[0.0], [1.0]]))
    return plant, [gf.Fault([0.0, 0.0, 1.0], [1.0, 0.0])]


def imaginary_poles():
    # [1/(s^2+1), 1/s]: one output, two faults
    A = [[0, 1, 0], [-1, 0, 0], [0, 0, 0]]
    plant = gf.Plant(A, None, [[1, 0, 1]])
    return plant, [gf.ActuatorFault([0.0, 1.0, 0.0]), gf.ActuatorFault([0.0, 0.0, 1.0])]


def common_imaginary_poles():
    # [1/(s(s^2+1)), 1/(s(s^2+1)(s+2))]
    A = np.zeros((4, 4))
    A[0, 1] = A[1, 2] = A[2, 3] = 1.0
    A[2, 1], A[3, 3] = -1.0, -2.0
    plant = gf.Plant(A, None, [[1, 0, 0, 0]])
    return plant, [gf.ActuatorFault([0.0, 0.0, 1.0, 0.0]), gf.ActuatorFault([0.0, 0.0, 0.0, 1.0])]


def imaginary_zeros():
    # Gf = [s/(s+1), 0; (s^2+4)/(s+3)^2, 1]
    A = [[-1, 0, 0], [0, 0, 1], [0, -9, -6]]
    plant = gf.Plant(A, None, [[-1, 0, 0], [0, -5, -6]])
    return plant, [gf.Fault([1.0, 0.0, 1.0], [1.0, 1.0]), gf.SensorFault(1)]


YUAN_WEAK = {
    "00010011", "01101110", "01111101", "01111111", "10101110", "10111101",
    "10111111", "11001100", "11011111", "11100110", "11101010", "11101110",
    "11110101", "11110111", "11111001", "11111011", "11111101", "11111111",
}  # fmt: skip
YUAN_STRONG = {
    "00010011", "01101110", "01111101", "01111111", "10101110", "10111101",
    "10111111", "11001100", "11011111", "11101110", "11111101", "11111111",
}  # fmt: skip


# ------------------------------------------------------------------ signatures
def test_yuan_weak_and_strong_sets():
    plant, faults = yuan()
    res = gf.achievable_signatures(plant, faults, frequencies=[0, 1])
    assert len(res.weak) == 18 and rows(res.weak) == YUAN_WEAK
    assert len(res.strong) == 12 and rows(res.strong) == YUAN_STRONG
    assert rows(gf.achievable_structures(plant, faults)) == YUAN_WEAK
    # Varga's recursion: far fewer quotients than the 255 candidate rows
    assert res.evaluations < 100


def test_yuan_least_orders():
    # efdisyn at least order: weak rows four of order 1 and fourteen of order 2; strong
    # rows (FDfreq = 0) four of order 1 and eight of order 2
    plant, faults = yuan()
    res = gf.achievable_signatures(plant, faults, frequencies=[0])
    weak = gf.structure_orders(plant, faults, res.weak)
    strong = gf.structure_orders(plant, faults, res.strong)
    assert sorted(weak.tolist()) == [1] * 4 + [2] * 14
    assert sorted(strong.tolist()) == [1] * 4 + [2] * 8
    assert rows(res.strong) == YUAN_STRONG


def test_example_5_4():
    plant, faults = example_5_4()
    assert rows(gf.achievable_structures(plant, faults)) == {"11"}
    assert rows(gf.achievable_structures(plant, faults, frequencies=[0, 1])) == {"11"}
    assert gf.structure_orders(plant, faults, all_rows(2)).tolist() == [-1, -1, 1]


@pytest.mark.parametrize(
    ("model", "orders"),
    [(niemann, [1, 1, 1]), (xiong_saif_1, [1, 2, 1]), (xiong_saif_2, [1, 1, 1])],
)
def test_two_fault_examples(model, orders):
    plant, faults = model()
    expected = {"11", "01", "10"}
    assert rows(gf.achievable_structures(plant, faults)) == expected
    assert rows(gf.achievable_structures(plant, faults, frequencies=[0, 1])) == expected
    assert gf.structure_orders(plant, faults, all_rows(2)).tolist() == orders


def test_boeing_747():
    plant, faults = boeing_747()
    weak = gf.achievable_structures(plant, faults)
    assert rows(weak) == {"00001", "00110", "00111", "11000", "11001", "11110", "11111"}
    strong = gf.achievable_structures(plant, faults, frequencies=[0, 1], gain_tol=1e-5)
    assert rows(strong) == {"11111", "00111", "11001", "11110"}
    # least orders of the feasible rows among all 31, in increasing binary value
    orders = gf.structure_orders(plant, faults, all_rows(5))
    assert orders[orders >= 0].tolist() == [1, 2, 1, 2, 1, 1, 1]
    assert rows(all_rows(5)[orders >= 0]) == rows(weak)
    strong_rows = np.array(sorted(rows(strong)), dtype=object)
    S = np.array([[int(c) for c in r] for r in strong_rows])
    assert gf.structure_orders(plant, faults, S).tolist() == [1, 1, 1, 1]


def test_poles_on_the_imaginary_axis():
    plant, faults = lecture_6()
    assert rows(gf.achievable_structures(plant, faults)) == {"1"}
    assert gf.achievable_structures(plant, faults, frequencies=[0, 1]).shape == (0, 1)
    plant, faults = imaginary_poles()
    assert rows(gf.achievable_structures(plant, faults)) == {"11"}
    assert gf.achievable_structures(plant, faults, frequencies=[0, 1]).shape == (0, 2)
    assert gf.achievable_structures(plant, faults, frequencies=[1]).shape == (0, 2)
    plant, faults = common_imaginary_poles()
    assert rows(gf.achievable_structures(plant, faults)) == {"11"}
    assert rows(gf.achievable_structures(plant, faults, frequencies=[0, 1])) == {"11"}


def test_zeros_on_the_imaginary_axis():
    plant, faults = imaginary_zeros()
    weak = {"11", "10", "01"}
    assert rows(gf.achievable_structures(plant, faults)) == weak
    assert rows(gf.achievable_structures(plant, faults, frequencies=[0])) == {"11"}
    assert rows(gf.achievable_structures(plant, faults, frequencies=[2])) == weak
    assert rows(gf.achievable_structures(plant, faults, frequencies=[0, 2])) == {"11"}
    res = gf.achievable_signatures(plant, faults, frequencies=[0, 2])
    i = [k for k, r in enumerate(res.rows) if rows([r.pattern]) == {"10"}][0]
    assert "not strong" in res.explain(i) and "ω = 0" in res.explain(i)


def test_static_plants():
    rng = np.random.default_rng(3)
    D = rng.standard_normal((4, 4))
    plant = gf.Plant(np.zeros((0, 0)), None, np.zeros((4, 0)))
    faults = [gf.Fault(None, D[:, j]) for j in range(4)]
    res = gf.achievable_signatures(plant, faults, frequencies=[0, 1])
    assert len(res.weak) == 15 and rows(res.strong) == rows(res.weak)
    assert np.all(gf.structure_orders(plant, faults, res.weak) == 0)
    # two outputs, three faults: a residual must decouple one, and sees the other two
    faults3 = [gf.Fault(None, D[:2, j]) for j in range(3)]
    plant2 = gf.Plant(np.zeros((0, 0)), None, np.zeros((2, 0)))
    assert rows(gf.achievable_structures(plant2, faults3)) == {"111", "011", "101", "110"}
    # the design functions need states: a clean refusal naming the plant
    with pytest.raises(GeomFDIError) as exc:
        gf.design_bank(plant2, faults3, [[1, 1, 0], [0, 1, 1]])
    assert exc.value.argument == "plant" and "static" in str(exc.value)


def test_random_plant_without_inputs():
    rng = np.random.default_rng(5)
    A = np.diag([-1.0, -3.0]) + 0.1 * rng.standard_normal((2, 2))
    plant = gf.Plant(A, None, rng.standard_normal((4, 2)))
    faults = [gf.Fault(rng.standard_normal(2), rng.standard_normal(4)) for _ in range(4)]
    res = gf.achievable_signatures(plant, faults, frequencies=[0, 1])
    assert len(res.weak) == 15 and rows(res.strong) == rows(res.weak)
    assert np.all(gf.structure_orders(plant, faults, res.weak) <= 2)


def test_scaling_does_not_change_the_answer():
    plant, faults = yuan()
    T = np.diag(10.0 ** np.array([-4, 2, 5, -1]))
    Ti = np.linalg.inv(T)
    units = 10.0 ** np.array([-5, 3, 0, 4, -2, 6, -6, 1])
    scaled = gf.Plant(Ti @ plant.A @ T, 1e4 * Ti @ plant.B, 1e-3 * plant.C @ T)
    sfaults = [
        gf.ActuatorFault(u * Ti @ f.signatures(4, 3)[0]) for u, f in zip(units, faults, strict=True)
    ]
    a = gf.achievable_signatures(plant, faults, frequencies=[0, 1])
    b = gf.achievable_signatures(scaled, sfaults, frequencies=[0, 1])
    assert rows(a.weak) == rows(b.weak) and rows(a.strong) == rows(b.strong)
    some = a.weak[::3]
    assert gf.structure_orders(scaled, sfaults, some).tolist() == (
        gf.structure_orders(plant, faults, some).tolist()
    )


def test_disturbances_are_decoupled():
    # a disturbance on the same channel as a fault hides it
    A = np.diag([-1.0, -2.0])
    plant = gf.Plant(A, None, np.eye(2), Bd=[[1.0], [0.0]])
    faults = [gf.ActuatorFault([2.0, 0.0]), gf.ActuatorFault([0.0, 1.0])]
    assert rows(gf.achievable_structures(plant, faults)) == {"01"}


def test_bad_input():
    plant, faults = niemann()
    with pytest.raises(GeomFDIError) as exc:
        gf.achievable_structures(plant, faults, frequencies=[-1.0])
    assert exc.value.argument == "frequencies"
    with pytest.raises(GeomFDIError) as exc:
        gf.achievable_structures(plant, faults, frequencies=[0], gain_tol=2.0)
    assert exc.value.argument == "gain_tol"
    with pytest.raises(ShapeError) as exc:
        gf.structure_orders(plant, faults, [[1, 0, 1]])
    assert exc.value.argument == "S"
    with pytest.raises(GeomFDIError) as exc:
        gf.structure_orders(plant, faults, [[1, 2]])
    assert exc.value.argument == "S"
    with pytest.raises(GeomFDIError) as exc:
        gf.achievable_structures(plant, [gf.Fault(np.zeros(5))])
    assert exc.value.argument == "faults"
    assert gf.structure_orders(plant, faults, [[0, 0]]).tolist() == [-1]


# ------------------------------------------------------------------ isolability
def test_isolability_classes_and_suggestion():
    plant, faults = yuan()
    rep = gf.isolability_analysis(plant, faults)
    assert rep.classes == [(3, 7)]  # f4 and f8 enter by the same column of Bf
    assert rep.isolable.tolist() == [True] * 3 + [False] + [True] * 3 + [False]
    S = rep.suggested.structure
    assert rows(S) <= YUAN_WEAK and rep.optimal
    cols = {tuple(S[:, j]) for j in range(8) if j not in (3, 7)}
    assert len(cols) == 6 and all(any(c) for c in cols)
    assert np.array_equal(S[:, 3], S[:, 7]) and tuple(S[:, 3]) not in cols
    assert rep.suggested.total_order == int(gf.structure_orders(plant, faults, S).sum())
    assert rep.suggested.total_order == _brute_force_least_total(rep)
    assert rep.schemes["generalised observer scheme"].orders is None


def _brute_force_least_total(rep):
    """Least total order over every set of achievable rows that isolates as
    ``rep.suggested`` must: all subsets, cut only when their cost reaches the best found
    (an independent check of the branch and bound; every order here is at least 1)."""
    S, orders = rep.S, [int(o) for o in rep.orders]
    assert min(orders) >= 1
    cls = {j: min(c) for c in rep.classes for j in c}
    det = np.flatnonzero(rep.detectable)
    pairs = [(a, b) for a in det for b in det if a < b and cls.get(a, a) != cls.get(b, b)]

    def isolates(sig):
        return all(sig[a] for a in det) and all(sig[a] != sig[b] for a, b in pairs)

    best = [sum(orders) + 1]

    def walk(start, sig, cost):  # sig[j]: column j of the chosen rows, as bits
        if cost and isolates(sig):
            best[0] = min(best[0], cost)
            return
        for i in range(start, len(S)):
            if cost + orders[i] < best[0]:
                walk(i + 1, [2 * v + int(S[i, j]) for j, v in enumerate(sig)], cost + orders[i])

    walk(0, [0] * S.shape[1], 0)
    return best[0]


def test_isolability_boeing_classes():
    plant, faults = boeing_747()
    rep = gf.isolability_analysis(plant, faults)
    assert sorted(rep.classes) == [(0, 1), (2, 3)]
    assert rep.suggested.isolates and rep.suggested.total_order == 2


def test_suggestion_beats_the_observer_schemes():
    plant, faults = niemann()
    rep = gf.isolability_analysis(plant, faults)
    gos = rep.schemes["generalised observer scheme"]
    dos = rep.schemes["dedicated observer scheme"]
    assert gos.total_order == 2 and dos.total_order == 2
    assert rep.suggested.total_order <= min(gos.total_order, dos.total_order)
    assert "every fault is isolable" in rep.summary()


def test_three_tank_analysis():
    plant, faults = gf.three_tank_model()
    rep = gf.isolability_analysis(
        plant, faults, frequencies=[0], structure=[[1, 1, 1, 0, 1, 1], [1, 1, 0, 1, 1, 0]]
    )
    assert rep.detectable.all() and rep.isolable.all() and not rep.classes
    S = rep.suggested.structure
    assert rep.suggested.isolates and len({tuple(S[:, j]) for j in range(6)}) == 6
    assert rows(S) <= rows(rep.achievable.weak)
    # strong at DC: every suggested row sees its faults in steady state
    assert rows(S) <= rows(rep.achievable.strong)
    assert rep.suggested.total_order <= rep.schemes["generalised observer scheme"].total_order
    assert rep.suggested.total_order == _brute_force_least_total(rep) == 3
    # the requested structure gives the leak and the level-3 sensor the same column
    assert any("'leak 3', 'level 3'" in n for n in rep.notes)
    assert not rep.schemes["requested"].isolates


def test_design_bank_warns_on_identical_columns():
    plant, faults = niemann()
    with pytest.warns(gf.IsolabilityWarning, match="identical columns"):
        gf.design_bank(plant, faults, [[1, 1], [1, 1]])
    with warnings.catch_warnings():
        warnings.simplefilter("error", gf.IsolabilityWarning)
        gf.design_bank(plant, faults, [[1, 1]])  # detection only: no isolation requested
        gf.design_bank(plant, faults, [[1, 0], [0, 1]])


def test_discrete_plant_zero_at_dc():
    # G_f(z) = (z − 1)/(z − 0.5): a constant fault is seen during its transient only
    plant = gf.Plant([[0.5]], None, [[-0.5]], dt=0.1)
    faults = [gf.Fault([1.0], [1.0])]
    assert rows(gf.achievable_structures(plant, faults)) == {"1"}
    assert gf.achievable_structures(plant, faults, frequencies=[0.0]).shape == (0, 1)
    assert rows(gf.achievable_structures(plant, faults, frequencies=[10.0])) == {"1"}
    assert gf.structure_orders(plant, faults, [[1]]).tolist() == [1]  # an observer of x


def test_fault_with_several_columns():
    # faults 1 and 2 of Yuan et al. as one two-column fault: its column is the union
    plant, faults = yuan()
    B = np.hstack([f.signatures(4, 3)[0] for f in faults])
    merged = [gf.ActuatorFault(B[:, :2]), *faults[2:]]
    S = gf.achievable_structures(plant, merged)
    assert rows(S) == {f"{int(r[0]) | int(r[1])}{r[2:]}" for r in YUAN_WEAK}


def test_requested_rows_weak_only_are_named():
    plant, faults = boeing_747()
    rep = gf.isolability_analysis(
        plant, faults, frequencies=[0, 1], structure=[[1, 1, 0, 0, 0], [0, 0, 0, 0, 1]]
    )
    note = rep.schemes["requested"].note
    assert rep.schemes["requested"].orders is None
    assert "rows [0, 1] achievable in the weak sense only" in note


def test_three_tank_in_other_units():
    # states in km, cm and µm, sensors in mm, hm and m, flows in l/s, sensor faults in cm
    plant, faults = gf.three_tank_model()
    T = np.diag([1e-3, 1e2, 1e4])
    Ti, O = np.linalg.inv(T), np.diag([1e3, 1e-2, 1.0])
    other = gf.Plant(Ti @ plant.A @ T, 1e-3 * Ti @ plant.B, O @ plant.C @ T)
    flows = [1e-3 * Ti @ f.signatures(3, 3)[0][:, 0] for f in faults[:3]]
    ofaults = [gf.ActuatorFault(b) for b in flows] + [
        gf.Fault(None, 1e-2 * O[:, i]) for i in range(3)
    ]
    a = gf.achievable_signatures(plant, faults, frequencies=[0.0])
    b = gf.achievable_signatures(other, ofaults, frequencies=[0.0])
    assert rows(a.weak) == rows(b.weak) and rows(a.strong) == rows(b.strong)
    assert len(b.strong) == 18
