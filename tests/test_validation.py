"""Bad input raises a GeomFDIError naming the argument; Plant <-> python-control.

One parametrised case per (entry point, defect).  Each case states the exact exception
class expected and the argument the error must name (in ``.argument`` and the message).
"""

from __future__ import annotations

import re

import control
import numpy as np
import pytest
import sympy as sp

import geomfdi as gf
from geomfdi.errors import (
    ComplexInputError,
    DesignError,
    GeomFDIError,
    NonFiniteError,
    ShapeError,
)
from geomfdi.geometry.unobservability import measurement_map

NAN, INF = float("nan"), float("inf")
A3 = np.eye(3) + np.diag([1.0, 1.0], 1)
C3 = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
L3 = np.array([[0.0], [0.0], [1.0]])
E1 = np.array([[1.0], [0.0], [0.0]])  # (C3, A3)-conditioned invariant (meets Ker C3 in 0)
RAGGED = [[1.0, 2.0, 3.0], [1.0, 2.0], [1.0, 2.0, 3.0]]


def with_entry(M: np.ndarray, value) -> np.ndarray:
    out = np.array(M, dtype=complex if isinstance(value, complex) else float)
    out[0, 0] = value
    return out


# Matrix defects shared by every matrix argument: (id, bad value for a 3 x 3 slot, class).
SQUARE_DEFECTS = [
    ("nan", with_entry(A3, NAN), NonFiniteError),
    ("inf", with_entry(A3, INF), NonFiniteError),
    ("-inf", with_entry(A3, -INF), NonFiniteError),
    ("complex", with_entry(A3, 1 + 2j), ComplexInputError),
    ("non-square", np.ones((3, 2)), ShapeError),
    ("empty", np.zeros((0, 0)), ShapeError),
    ("ragged", RAGGED, ShapeError),
    ("string", "eye(3)", GeomFDIError),
    ("strings", [["1", "0", "0"], ["0", "1", "0"], ["0", "0", "1"]], GeomFDIError),
    ("3-D", np.ones((3, 3, 1)), ShapeError),
    ("1-D", np.ones(3), ShapeError),
    ("None", None, GeomFDIError),
    ("objects", [[1.0, None, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], GeomFDIError),
]

CASES: list = []


def case(name: str, call, exc: type, argument: str) -> None:
    CASES.append(pytest.param(call, exc, argument, id=name))


# ----------------------------------------------------------------------------- Plant
for tag, bad, exc in SQUARE_DEFECTS:
    case(f"Plant-A-{tag}", lambda bad=bad: gf.Plant(bad, None, C3), exc, "A")
case("Plant-B-rows", lambda: gf.Plant(A3, np.ones((2, 1)), C3), ShapeError, "B")
case("Plant-B-nan", lambda: gf.Plant(A3, [[NAN], [0], [0]], C3), NonFiniteError, "B")
case("Plant-B-complex", lambda: gf.Plant(A3, [[1j], [0], [0]], C3), ComplexInputError, "B")
case("Plant-C-missing", lambda: gf.Plant(A3, None), GeomFDIError, "C")
case("Plant-Bw-rows", lambda: gf.Plant(A3, None, C3, Bw=np.ones((2, 1))), ShapeError, "Bw")
case("Plant-Dw-nan", lambda: gf.Plant(A3, None, C3, Dw=[[NAN], [0], [0]]), NonFiniteError, "Dw")
case(
    "Plant-Dw-width",
    lambda: gf.Plant(A3, None, C3, Bw=np.ones((3, 1)), Dw=np.ones((3, 2))),
    ShapeError,
    "Dw",
)
case("hinf_norm-A-nan", lambda: gf.hinf_norm(with_entry(A3, NAN), E1, C3), NonFiniteError, "A")
case("hinf_norm-dt", lambda: gf.hinf_norm(-np.eye(3), E1, C3, dt=-1.0), GeomFDIError, "dt")
case("hinf_norm-tol", lambda: gf.hinf_norm(-np.eye(3), E1, C3, tol=0.5), GeomFDIError, "tol")
case(
    "hminus_index-measure",
    lambda: gf.hminus_index(-np.eye(3), E1, C3, measure="rows"),
    GeomFDIError,
    "measure",
)
case(
    "hminus_index-frequencies",
    lambda: gf.hminus_index(-np.eye(3), E1, C3, frequencies=[-1.0]),
    GeomFDIError,
    "frequencies",
)
case(
    "hminus_index-columns",
    lambda: gf.hminus_index(-np.eye(3), E1, C3, columns=[[5]]),
    ShapeError,
    "columns",
)
case("gap_threshold-delta", lambda: gf.gap_threshold(None, -1.0), GeomFDIError, "delta")
case("gap_threshold-gap", lambda: gf.gap_threshold(object(), 1.0), GeomFDIError, "gap")
case("Plant-C-cols", lambda: gf.Plant(A3, None, np.ones((2, 2))), ShapeError, "C")
case("Plant-C-empty", lambda: gf.Plant(A3, None, np.zeros((0, 3))), ShapeError, "C")
case("Plant-C-inf", lambda: gf.Plant(A3, None, with_entry(C3, INF)), NonFiniteError, "C")
case("Plant-C-ragged", lambda: gf.Plant(A3, None, [[1, 0, 0], [1, 0]]), ShapeError, "C")
case("Plant-D-shape", lambda: gf.Plant(A3, L3, C3, np.ones((2, 2))), ShapeError, "D")
case("Plant-D-nan", lambda: gf.Plant(A3, L3, C3, [[NAN], [0]]), NonFiniteError, "D")
case("Plant-Bd-rows", lambda: gf.Plant(A3, None, C3, Bd=np.ones((2, 1))), ShapeError, "Bd")
case("Plant-Dd-rows", lambda: gf.Plant(A3, None, C3, Dd=np.ones((3, 1))), ShapeError, "Dd")
case(
    "Plant-Dd-cols",
    lambda: gf.Plant(A3, None, C3, Bd=np.ones((3, 2)), Dd=np.ones((2, 1))),
    ShapeError,
    "Dd",
)
for tag, dt in [("negative", -0.1), ("nan", NAN), ("inf", INF), ("bool", True)]:
    case(f"Plant-dt-{tag}", lambda dt=dt: gf.Plant(A3, None, C3, dt=dt), GeomFDIError, "dt")
for tag, dt in [("None", None), ("string", "0.1"), ("complex", 0.1j)]:
    case(f"Plant-dt-{tag}", lambda dt=dt: gf.Plant(A3, None, C3, dt=dt), GeomFDIError, "dt")
case("from_statespace-type", lambda: gf.Plant.from_statespace(A3), GeomFDIError, "sys")
case(
    "from_statespace-dt-True",
    lambda: gf.Plant.from_statespace(control.ss(A3, L3, C3, 0, True)),
    GeomFDIError,
    "sys",
)
for tag, k in [("too-many", 2), ("negative", -1), ("float", 1.0)]:
    case(
        f"from_statespace-n_disturbances-{tag}",
        lambda k=k: gf.Plant.from_statespace(control.ss(A3, L3, C3, 0), n_disturbances=k),
        GeomFDIError,
        "n_disturbances",
    )

# --------------------------------------------------------------------------- faults
case("SensorFault-negative", lambda: gf.SensorFault(-1), GeomFDIError, "i")
case("SensorFault-float", lambda: gf.SensorFault(1.0), GeomFDIError, "i")
case("ActuatorFault-nan", lambda: gf.ActuatorFault([NAN, 0, 0]), NonFiniteError, "b")
case("ActuatorFault-complex", lambda: gf.ActuatorFault([1j, 0, 0]), ComplexInputError, "b")
case("Fault-nothing", lambda: gf.Fault(), GeomFDIError, "Bf")
case("Fault-columns", lambda: gf.Fault(np.ones((3, 2)), np.ones((2, 1))), ShapeError, "Df")
case(
    "Fault-signature-rows",
    lambda: gf.Fault(np.ones((4, 1))).signatures(3, 2),
    ShapeError,
    "fault",
)
case("SensorFault-index", lambda: gf.SensorFault(5).signatures(3, 2), GeomFDIError, "fault.i")

# ------------------------------------------------------------------------ subspaces
SUBSPACE_DEFECTS = [
    ("nan", with_entry(L3, NAN), NonFiniteError),
    ("inf", with_entry(L3, INF), NonFiniteError),
    ("complex", with_entry(L3, 1j), ComplexInputError),
    ("ragged", RAGGED, ShapeError),
    ("string", "span", GeomFDIError),
    ("3-D", np.ones((3, 1, 1)), ShapeError),
    ("no-rows", np.zeros((0, 2)), ShapeError),
    ("None", None, GeomFDIError),
]
for tag, bad, exc in SUBSPACE_DEFECTS:
    case(f"Subspace-M-{tag}", lambda bad=bad: gf.Subspace(bad), exc, "M")
    case(f"image-M-{tag}", lambda bad=bad: gf.image(bad), exc, "M")
    case(f"contains-other-{tag}", lambda bad=bad: gf.Subspace(L3).contains(bad), exc, "other")
    case(f"preimage-S-{tag}", lambda bad=bad: gf.preimage(A3, bad), exc, "S")
    case(f"principal_angles-T-{tag}", lambda bad=bad: gf.principal_angles(L3, bad), exc, "T")
for tag, bad, exc in SQUARE_DEFECTS[:4] + [SQUARE_DEFECTS[6], SQUARE_DEFECTS[7]]:
    case(f"kernel-M-{tag}", lambda bad=bad: gf.kernel(bad), exc, "M")
    case(f"preimage-A-{tag}", lambda bad=bad: gf.preimage(bad, gf.Subspace(L3)), exc, "A")
    case(f"apply-A-{tag}", lambda bad=bad: gf.apply(bad, gf.Subspace(L3)), exc, "A")
case("kernel-M-no-columns", lambda: gf.kernel(np.zeros((2, 0))), ShapeError, "M")
case("kernel-M-3-D", lambda: gf.kernel(np.zeros((2, 2, 2))), ShapeError, "M")
case("preimage-A-rows", lambda: gf.preimage(np.ones((2, 3)), gf.Subspace(L3)), ShapeError, "A")
case("preimage-A-no-columns", lambda: gf.preimage(np.ones((3, 0)), L3), ShapeError, "A")
case("apply-A-cols", lambda: gf.apply(np.ones((3, 2)), gf.Subspace(L3)), ShapeError, "A")
case("apply-S-nan", lambda: gf.apply(A3, with_entry(L3, NAN)), NonFiniteError, "S")
case("sum-other-array", lambda: gf.Subspace(L3) + L3, GeomFDIError, "other")
case("intersection-other-n", lambda: gf.Subspace(L3) & gf.Subspace.full(2), ShapeError, "other")
case(
    "principal_angles-S-nan",
    lambda: gf.principal_angles(with_entry(L3, NAN), L3),
    NonFiniteError,
    "S",
)
case(
    "principal_angles-T-n",
    lambda: gf.principal_angles(gf.Subspace(L3), gf.Subspace.full(2)),
    ShapeError,
    "T",
)

# --------------------------------------------------------------- W*, S*, friends
ALGORITHMS = [
    ("W*", gf.min_conditioned_invariant),
    ("S*", gf.min_unobservability_subspace),
    ("exact-W*", gf.exact.min_conditioned_invariant),
    ("exact-S*", gf.exact.min_unobservability_subspace),
]
for alg, fn in ALGORITHMS:
    numeric = not alg.startswith("exact")
    defects = SQUARE_DEFECTS if numeric else [d for d in SQUARE_DEFECTS if d[0] != "1-D"]
    for tag, bad, exc in defects:
        case(f"{alg}-A-{tag}", lambda fn=fn, bad=bad: fn(bad, C3, L3), exc, "A")
    case(f"{alg}-C-cols", lambda fn=fn: fn(A3, np.ones((2, 2)), L3), ShapeError, "C")
    case(f"{alg}-C-nan", lambda fn=fn: fn(A3, with_entry(C3, NAN), L3), NonFiniteError, "C")
    case(f"{alg}-C-complex", lambda fn=fn: fn(A3, with_entry(C3, 1j), L3), ComplexInputError, "C")
    case(f"{alg}-C-ragged", lambda fn=fn: fn(A3, [[1, 0, 0], [0, 1]], L3), ShapeError, "C")
    case(f"{alg}-L-rows", lambda fn=fn: fn(A3, C3, np.ones((2, 1))), ShapeError, "L")
    case(f"{alg}-L-nan", lambda fn=fn: fn(A3, C3, with_entry(L3, NAN)), NonFiniteError, "L")
    case(f"{alg}-L-complex", lambda fn=fn: fn(A3, C3, with_entry(L3, 1j)), ComplexInputError, "L")
    case(f"{alg}-L-string", lambda fn=fn: fn(A3, C3, [["a"], ["b"], ["c"]]), GeomFDIError, "L")
    case(f"{alg}-L-ragged", lambda fn=fn: fn(A3, C3, [[1, 0], [0], [1, 1]]), ShapeError, "L")
    if numeric:
        case(f"{alg}-C-empty", lambda fn=fn: fn(A3, np.zeros((0, 3)), L3), ShapeError, "C")
        case(
            f"{alg}-L-subspace-n",
            lambda fn=fn: fn(A3, C3, gf.Subspace.full(2)),
            ShapeError,
            "L",
        )
case(
    "exact-A-not-rational-function",  # symbols are parameters; sin(a) is not rational
    lambda: gf.exact.min_conditioned_invariant(sp.Matrix([[sp.sin(sp.Symbol("a"))]]), [[1]], [[1]]),
    GeomFDIError,
    "A",
)
case("exact-to_rational-sympy-nan", lambda: gf.exact.to_rational([[sp.nan]]), NonFiniteError, "M")
case("exact-to_rational-sympy-I", lambda: gf.exact.to_rational([[sp.I]]), ComplexInputError, "M")
case("exact-kernel-nan", lambda: gf.exact.kernel([[NAN, 1.0]]), NonFiniteError, "M")
case("exact-span-complex", lambda: gf.exact.span([[1j], [1.0]]), ComplexInputError, "M")
case("exact-span-3-D", lambda: gf.exact.span(np.ones((2, 2, 2))), ShapeError, "M")

case(
    "is_conditioned_invariant-W-rows",
    lambda: gf.is_conditioned_invariant(A3, C3, np.ones((2, 1))),
    ShapeError,
    "W",
)
case(
    "is_conditioned_invariant-A-nan",
    lambda: gf.is_conditioned_invariant(with_entry(A3, NAN), C3, L3),
    NonFiniteError,
    "A",
)
case(
    "is_unobservability_subspace-S-nan",
    lambda: gf.is_unobservability_subspace(A3, C3, with_entry(L3, NAN)),
    NonFiniteError,
    "S",
)
case(
    "is_unobservability_subspace-C-cols",
    lambda: gf.is_unobservability_subspace(A3, np.ones((1, 2)), L3),
    ShapeError,
    "C",
)
case("friends-S-rows", lambda: gf.friends(A3, C3, np.ones((4, 1))), ShapeError, "S")
case(
    "friend-not-invariant",
    lambda: gf.friend(A3, [[0.0, 0.0, 1.0]], [[0.0], [1.0], [0.0]]),
    DesignError,
    "S",
)
case(
    "FriendSet-member-X",
    lambda: gf.friends(A3, C3, E1).member(np.ones(5), np.zeros(2)),
    ShapeError,
    "X",
)
case(
    "FriendSet-member-Y-nan",
    lambda: gf.friends(A3, C3, E1).member(np.zeros(2), [NAN, 0.0]),
    NonFiniteError,
    "Y",
)
case(
    "FriendSet-contains-D",
    lambda: gf.friends(A3, C3, E1).contains(A3, C3, np.ones((3, 3))),
    ShapeError,
    "D",
)
case("measurement_map-C-nan", lambda: measurement_map(with_entry(C3, NAN), L3), NonFiniteError, "C")
case(
    "unobservable_subspace-A-non-square",
    lambda: gf.unobservable_subspace(np.ones((3, 2)), C3),
    ShapeError,
    "A",
)


@pytest.mark.parametrize(("call", "exc", "argument"), CASES)
def test_bad_input_raises_naming_the_argument(call, exc, argument):
    with pytest.raises(GeomFDIError) as err:
        call()
    assert type(err.value) is exc, f"expected {exc.__name__}, got {type(err.value).__name__}"
    assert isinstance(err.value, ValueError)
    assert err.value.argument == argument
    assert re.search(rf"(^|\W){re.escape(argument)}\b", str(err.value)), str(err.value)


def test_case_ids_are_unique():
    ids = [p.id for p in CASES]
    assert len(ids) == len(set(ids)) and len(ids) > 150


# ----------------------------------------------------------------- accepted inputs
def test_accepted_input_forms():
    """Nested lists, integers, booleans-free numeric arrays, sympy matrices and vectors."""
    p = gf.Plant([[0, 1], [-2, -3]], [0, 1], [1, 0])  # 1-D B is a column, 1-D C a row
    assert (p.n, p.m, p.q, p.nd) == (2, 1, 1, 0)
    assert p.A.dtype == np.float64 and not p.A.flags.writeable
    assert gf.Subspace(sp.Matrix([[1], [2]])).dim == 1
    assert gf.min_conditioned_invariant(A3, C3, np.zeros((3, 0))).dim == 0
    assert gf.min_conditioned_invariant(A3, C3, gf.Subspace(L3)).contains(gf.Subspace(L3))


# ------------------------------------------------------- Plant <-> python-control
def example_plant(dt: float) -> gf.Plant:
    rng = np.random.default_rng(0)
    return gf.Plant(
        rng.standard_normal((4, 4)),
        rng.standard_normal((4, 2)),
        rng.standard_normal((3, 4)),
        rng.standard_normal((3, 2)),
        Bd=rng.standard_normal((4, 1)),
        Dd=rng.standard_normal((3, 1)),
        dt=dt,
    )


@pytest.mark.parametrize("dt", [0.0, 0.05])
def test_statespace_round_trip(dt):
    p = example_plant(dt)
    sys = p.to_statespace()
    assert isinstance(sys, control.StateSpace)
    assert sys.dt == dt and control.isdtime(sys, strict=True) == (dt > 0)
    assert sys.ninputs == p.m + p.nd and sys.noutputs == p.q and sys.nstates == p.n
    assert sys.input_labels == ["u[0]", "u[1]", "d[0]"]
    assert np.array_equal(sys.B, np.hstack([p.B, p.Bd]))
    assert np.array_equal(sys.D, np.hstack([p.D, p.Dd]))
    q = gf.Plant.from_statespace(sys, n_disturbances=1)
    for name in ("A", "B", "C", "D", "Bd", "Dd"):
        assert np.array_equal(getattr(q, name), getattr(p, name)), name
    assert q.dt == p.dt and q.is_discrete == (dt > 0)
    # without n_disturbances every input is a known input
    r = gf.Plant.from_statespace(sys)
    assert (r.m, r.nd) == (3, 0) and np.array_equal(r.B, sys.B)


def test_from_statespace_splits_the_last_inputs_as_disturbances():
    sys = control.ss([[-1.0, 0.0], [1.0, -2.0]], [[1, 0, 2], [0, 1, 3]], [[1.0, 1.0]], [[0, 0, 5]])
    p = gf.Plant.from_statespace(sys, n_disturbances=2)
    assert (p.m, p.nd) == (1, 2)
    assert np.array_equal(p.B, [[1], [0]]) and np.array_equal(p.Bd, [[0, 2], [1, 3]])
    assert np.array_equal(p.D, [[0]]) and np.array_equal(p.Dd, [[0, 5]])
    assert p.dt == 0 and not p.is_discrete


def test_dt_conventions():
    assert gf.Plant(A3, None, C3).dt == 0.0
    assert not gf.Plant(A3, None, C3, dt=0).is_discrete
    assert gf.Plant(A3, None, C3, dt=0.1).is_discrete
    sys_none = control.ss(A3, L3, C3, 0, None)  # unspecified timebase: read as continuous
    assert gf.Plant.from_statespace(sys_none).dt == 0.0
    sysd = control.ss(A3, L3, C3, 0, 0.25)
    assert gf.Plant.from_statespace(sysd).dt == 0.25
    assert "dt=0.25" in repr(gf.Plant.from_statespace(sysd))


def test_plant_without_inputs_round_trips():
    p = gf.Plant(A3, None, C3, dt=0.1)
    sys = p.to_statespace()
    assert sys.ninputs == 0 and sys.dt == 0.1
    q = gf.Plant.from_statespace(sys)
    assert (q.m, q.nd) == (0, 0) and np.array_equal(q.A, p.A)


def test_disturbance_only_on_one_side():
    p = gf.Plant(A3, None, C3, Dd=[[1.0], [0.0]])
    assert p.nd == 1 and np.array_equal(p.Bd, np.zeros((3, 1)))
    p = gf.Plant(A3, None, C3, Bd=L3)
    assert p.nd == 1 and np.array_equal(p.Dd, np.zeros((2, 1)))


def test_statespace_accepted_by_design_verify_and_simulate():
    import control

    A = [[1, 1, 1], [0, 1, 0], [2, 0, 1]]
    B = [[1, 0, 1], [0, 1, 1], [0, 1, 0]]
    C = [[0, 1, 0], [0, 0, 1], [1, 0, 2]]
    sys = control.ss(A, B, C, 0)
    plant = gf.Plant(A, B, C)
    bank = gf.design_sensor_bank(sys)
    assert gf.verify(bank, sys).ok == gf.verify(bank, plant).ok
    assert gf.verify_symbolic(bank, sys).ok
    t = np.linspace(0, 1, 101)
    r_ss = gf.simulate(sys, bank, t, x0=[0.1, 0, 0]).residuals
    r_p = gf.simulate(plant, bank, t, x0=[0.1, 0, 0]).residuals
    np.testing.assert_array_equal(r_ss, r_p)
    with pytest.raises(gf.errors.GeomFDIError, match="plant"):
        gf.verify(bank, "not a plant")
