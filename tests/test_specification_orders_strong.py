"""Least orders for strong fault detection at given frequencies (``structure_orders``).

Published numbers: Yuan et al. (1997) with ω = 0 (Varga's ``efdisyn(…; FDfreq = 0)``:
four rows of order 1 and eight of order 2), the lecture examples with poles and zeros on
the imaginary axis and Examples 5.3 and 5.4 of Varga (2017), whose strong signatures are
Varga's ``fdigenspec(…; FDfreq)``.  The hand-built cases check the principle itself: a row
strong only above its weak order, and rows no order makes strong.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_specification import (
    YUAN_STRONG,
    all_rows,
    boeing_747,
    common_imaginary_poles,
    example_5_4,
    imaginary_poles,
    imaginary_zeros,
    lecture_6,
    niemann,
    rows,
    xiong_saif_1,
    yuan,
)

import geomfdi as gf
from geomfdi.errors import GeomFDIError
from geomfdi.synthesis.specification.model import spec_model
from geomfdi.synthesis.specification.orders import row_orders


def fault_response(g, plant, fault, s):
    """The fault-to-residual transfer of generator g on the plant at the point s (from the
    interconnection, independently of the design's own gain records)."""
    Bf, Df = fault.signatures(plant.n, plant.q)
    n, nw = plant.n, g.F.shape[0]
    Ac = np.block([[plant.A, np.zeros((n, nw))], [-g.E @ plant.C, g.F]])
    Bc = np.vstack([Bf, -g.E @ Df])
    Cc = np.hstack([-g.H @ plant.C, g.M])
    return (Cc @ np.linalg.solve(s * np.eye(n + nw) - Ac, Bc) - g.H @ Df)[0, 0]


def washout_plant(a=1.0, w2=1.0, z=1.0, dt=0.0):
    """y1 sees the fault through the washout −s/(s + a) (a zero at s = 0), y2 through the
    second-order lag ``z/(s² + z s + w2)`` ... (continuous); in discrete time the washout
    is ``(z − 1)/(z − a)`` on y1.  Weak order 1 (the residual ``(s + a) y1``), strong at DC
    only at order 2 (the fresh minimal-basis vector on y2)."""
    if dt > 0:
        A = np.array([[a, 0, 0], [0, 0, 1], [0, -w2, z]])
        return gf.Plant(A, None, [[a - 1.0, 0, 0], [0, 1, 0]], dt=dt), gf.Fault(
            [1.0, 0, 1.0], [1.0, 0]
        )
    A = np.array([[-a, 0, 0], [0, 0, 1], [0, -w2, -z]])
    return gf.Plant(A, None, [[1.0, 0, 0], [0, 1, 0]]), gf.Fault([1.0, 0, 1.0], [-1.0 / a, 0])


# ------------------------------------------------------------------ published examples
def test_yuan_strong_orders_at_dc():
    # efdisyn(…; FDfreq = 0) on the 12 strong rows: four of order 1, eight of order 2
    plant, faults = yuan()
    res = gf.achievable_signatures(plant, faults, frequencies=[0])
    assert rows(res.strong) == YUAN_STRONG
    weak = gf.structure_orders(plant, faults, res.weak)
    strong = gf.structure_orders(plant, faults, res.weak, frequencies=[0])
    is_strong = np.array([r.strong for r in res.rows])
    # exactly the strong signatures have a strong order, never below the weak one
    assert np.array_equal(strong >= 0, is_strong)
    assert np.all(strong[is_strong] >= weak[is_strong])
    assert sorted(strong[is_strong].tolist()) == [1] * 4 + [2] * 8


def test_frequencies_none_is_the_weak_order():
    for model, published in ((niemann, [1, 1, 1]), (xiong_saif_1, [1, 2, 1])):
        plant, faults = model()
        S = all_rows(2)
        assert gf.structure_orders(plant, faults, S, frequencies=None).tolist() == published
        assert gf.structure_orders(plant, faults, S, gain_tol=0.5).tolist() == published


@pytest.mark.parametrize("freqs", [[0.0], [1.0], [0.0, 1.0]])
def test_strong_orders_agree_with_strong_signatures(freqs):
    # every row of every example: a strong order exists iff the row is a strong signature
    for model in (
        lecture_6,
        imaginary_poles,
        common_imaginary_poles,
        imaginary_zeros,
        example_5_4,
        xiong_saif_1,
    ):
        plant, faults = model()
        S = all_rows(len(faults))
        strong = gf.structure_orders(plant, faults, S, frequencies=freqs)
        weak = gf.structure_orders(plant, faults, S)
        expected = rows(gf.achievable_structures(plant, faults, frequencies=freqs))
        assert rows(S[strong >= 0]) == expected, model.__name__
        assert np.all(strong[strong >= 0] >= weak[strong >= 0]), model.__name__


def test_lecture_examples_on_the_imaginary_axis():
    # [1/(s²+1), 1/s]: f1's stable residual has a zero at 0, f2's at ±i
    plant, faults = imaginary_poles()
    assert gf.structure_orders(plant, faults, [[1, 1]]).tolist() == [3]
    for freqs in ([0, 1], [1], [0]):
        assert gf.structure_orders(plant, faults, [[1, 1]], frequencies=freqs).tolist() == [-1]
    # common poles on the axis cancel: strong at 0 and 1 at the weak order
    plant, faults = common_imaginary_poles()
    weak = gf.structure_orders(plant, faults, [[1, 1]])
    assert gf.structure_orders(plant, faults, [[1, 1]], frequencies=[0, 1]).tolist() == [4]
    assert weak.tolist() == [4]
    # Gf = [s/(s+1), 0; (s²+4)/(s+3)², 1] at ω ∈ {0, 2}: only "11" is strong
    plant, faults = imaginary_zeros()
    S = np.array([[1, 1], [1, 0], [0, 1]])
    assert gf.structure_orders(plant, faults, S, frequencies=[0, 2]).tolist()[1:] == [-1, -1]
    assert np.all(gf.structure_orders(plant, faults, S, frequencies=[2]) >= 0)
    # Gf = [1/s; 1/(s²+4)] (Varga's efdsyn test: strong at ω ∈ {0, 2}): s·y1 sees the
    # fault with the gain 1 at every frequency, order 1
    A = np.array([[0.0, 0, 0], [0, 0, 1], [0, -4, 0]])
    plant = gf.Plant(A, None, [[1.0, 0, 0], [0, 1, 0]])
    fault = gf.ActuatorFault([1.0, 0, 1.0])
    assert gf.structure_orders(plant, [fault], [[1]], frequencies=[0, 2]).tolist() == [1]


def test_example_5_3_strong_at_dc():
    # Varga (2017), Example 5.3: Gu = [(s+1)/(s+2); (s+2)/(s+3)], Gd = [(s−1)/(s+2); 0],
    # f1 acts as u, f2 on y2; efdsyn's residual is strong at DC for both faults
    plant = gf.Plant(
        np.diag([-2.0, -3.0]),
        [[1.0], [1.0]],
        [[-1.0, 0.0], [0.0, -1.0]],
        [[1.0], [1.0]],
        Bd=[[3.0], [0.0]],
        Dd=np.array([[1.0], [0.0]]),
    )
    faults = [gf.Fault([1.0, 1.0], [1.0, 1.0]), gf.SensorFault(1)]
    assert rows(gf.achievable_structures(plant, faults, frequencies=[0])) == {"11"}
    weak = gf.structure_orders(plant, faults, [[1, 1]])
    assert gf.structure_orders(plant, faults, [[1, 1]], frequencies=[0]).tolist() == [1]
    assert weak.tolist() == [1]


# ------------------------------------------------------------------ hand-built cases
@pytest.mark.parametrize(("a", "w2", "z"), [(1.0, 1.0, 1.0), (0.3, 4.0, 0.5), (5.0, 0.2, 2.0)])
def test_strong_at_dc_only_above_the_weak_order(a, w2, z):
    plant, fault = washout_plant(a, w2, z)
    assert gf.structure_orders(plant, [fault], [[1]]).tolist() == [1]
    assert gf.structure_orders(plant, [fault], [[1]], frequencies=[0]).tolist() == [2]
    # at a frequency away from the washout's zero the least weak order is strong
    assert gf.structure_orders(plant, [fault], [[1]], frequencies=[1.0]).tolist() == [1]
    assert gf.structure_orders(plant, [fault], [[1]], frequencies=[0, 1.0]).tolist() == [2]
    # the design (strength="strong": strong at DC) delivers that order, with a DC gain;
    # strength="weak" the order-1 washout residual, blind to a constant fault
    strong = gf.design_bank(plant, [fault], [[1]], strength="strong").generators[0]
    weak = gf.design_bank(plant, [fault], [[1]], strength="weak").generators[0]
    assert strong.F.shape[0] == 2 and weak.F.shape[0] == 1
    mid = abs(fault_response(strong, plant, fault, 1j * np.sqrt(w2)))
    assert abs(fault_response(strong, plant, fault, 0.0)) > 1e-3 * mid
    assert abs(fault_response(weak, plant, fault, 0.0)) < 1e-9 * abs(
        fault_response(weak, plant, fault, 1j)
    )
    (ro,) = row_orders(spec_model(plant, [fault]), np.array([[True]]), frequencies=[0])
    assert "degree-1 parity space has no response" in ro.statement and "ω = 0" in ro.statement


def test_discrete_washout_needs_order_2_at_dc():
    plant, fault = washout_plant(0.5, 0.3, 0.6, dt=0.1)
    assert gf.structure_orders(plant, [fault], [[1]]).tolist() == [1]
    assert gf.structure_orders(plant, [fault], [[1]], frequencies=[0]).tolist() == [2]
    assert gf.structure_orders(plant, [fault], [[1]], frequencies=[10.0]).tolist() == [1]


def test_infeasible_at_dc():
    # a fault seen through −s/(s+1) only: weak order 1, never strong at DC
    plant = gf.Plant([[-1.0]], None, [[1.0]])
    fault = gf.Fault([1.0], [-1.0])
    assert gf.structure_orders(plant, [fault], [[1]]).tolist() == [1]
    assert gf.structure_orders(plant, [fault], [[1]], frequencies=[0]).tolist() == [-1]
    assert gf.structure_orders(plant, [fault], [[1]], frequencies=[3.0]).tolist() == [1]
    (ro,) = row_orders(spec_model(plant, [fault]), np.array([[True]]), frequencies=[0, 3])
    assert ro.order == -1 and "gain_tol" in ro.statement and "ω = 0" in ro.statement
    # after decoupling: the washout plant's y2-fault hides the second channel
    plant, fault = washout_plant()
    faults = [fault, gf.ActuatorFault([0.0, 0.0, 1.0])]
    S = [[1, 0], [1, 1]]
    assert gf.structure_orders(plant, faults, S).tolist()[0] == 1
    strong = gf.structure_orders(plant, faults, S, frequencies=[0])
    assert strong[0] == -1 and strong[1] >= 1
    # the discrete (z − 1)/(z − 0.5) of the specification tests
    plant = gf.Plant([[0.5]], None, [[-0.5]], dt=0.1)
    fault = gf.Fault([1.0], [1.0])
    assert gf.structure_orders(plant, [fault], [[1]], frequencies=[0.0]).tolist() == [-1]
    assert gf.structure_orders(plant, [fault], [[1]], frequencies=[10.0]).tolist() == [1]


def test_boeing_strong_rows_at_order_1():
    # the four strong rows (gain_tol 1e-5) are all of order 1, as their weak orders
    plant, faults = boeing_747()
    S = all_rows(5)
    strong = gf.structure_orders(plant, faults, S, frequencies=[0, 1], gain_tol=1e-5)
    assert rows(S[strong >= 0]) == {"11111", "00111", "11001", "11110"}
    assert np.all(strong[strong >= 0] == 1)


def test_bad_frequencies_and_gain_tol():
    plant, faults = niemann()
    with pytest.raises(GeomFDIError) as exc:
        gf.structure_orders(plant, faults, [[1, 1]], frequencies=[-1.0])
    assert exc.value.argument == "frequencies"
    with pytest.raises(GeomFDIError) as exc:
        gf.structure_orders(plant, faults, [[1, 1]], frequencies=[0], gain_tol=1.5)
    assert exc.value.argument == "gain_tol"
    assert gf.structure_orders(plant, faults, [[0, 0]], frequencies=[0]).tolist() == [-1]


def test_isolability_costs_rows_at_their_strong_orders():
    plant, fault = washout_plant()
    assert gf.isolability_analysis(plant, [fault]).orders.tolist() == [1]
    rep = gf.isolability_analysis(plant, [fault], frequencies=[0])
    assert rep.orders.tolist() == [2] and rep.suggested.total_order == 2


def chain_plant(k, a=1.0):
    """The washout on y1 (order 1, blind at DC) beside a k-th order lag observed by y2:
    strong at DC only at order k (the minimal-basis vector of degree k)."""
    n = 1 + k
    A = np.zeros((n, n))
    A[0, 0] = -a
    for i in range(1, k):
        A[i, i + 1] = 1.0
    A[k, 1:] = -np.poly(-np.linspace(0.5, 2.0, k))[1:][::-1]
    C = np.zeros((2, n))
    C[0, 0] = C[1, 1] = 1.0
    Bf = np.zeros(n)
    Bf[0] = Bf[k] = 1.0
    return gf.Plant(A, None, C), gf.Fault(Bf, [-1.0 / a, 0.0])


@pytest.mark.parametrize("k", [2, 3, 4, 6])
def test_strong_order_is_the_lag_order(k):
    plant, fault = chain_plant(k)
    assert gf.structure_orders(plant, [fault], [[1]]).tolist() == [1]
    assert gf.structure_orders(plant, [fault], [[1]], frequencies=[0]).tolist() == [k]
    if k <= 4:  # the design raises a weak row by at most three degrees
        g = gf.design_bank(plant, [fault], [[1]]).generators[0]
        assert g.F.shape[0] == k
        assert abs(fault_response(g, plant, fault, 0.0)) > 1e-3 * abs(
            fault_response(g, plant, fault, 1j)
        )
