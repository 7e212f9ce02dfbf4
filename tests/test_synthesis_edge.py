"""Synthesis edge cases: redundant and rank-deficient sensors, integrators, bad input,
discrete time.

Each case checks the outcome (which residuals exist, their orders, their transfers) and
the diagnostic a user sees.
"""

from __future__ import annotations

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.errors import DesignError, GeomFDIError, NotIsolableError, ShapeError

SEED_A = [[1, 1, 1], [0, 1, 0], [2, 0, 1]]
SEED_B = [[1, 0, 1], [0, 1, 1], [0, 1, 0]]
SEED_C = [[0, 1, 0], [0, 0, 1], [1, 0, 2]]


def _tf(g, pt):
    """Generator transfer ``[y; u] -> r`` at ``pt`` from its matrices."""
    if g.order == 0:
        return np.hstack([-g.H, g.K]).astype(complex)
    X = np.linalg.solve(pt * np.eye(g.order) - g.F, np.hstack([-g.E, g.G]))
    return g.M @ X + np.hstack([-g.H, g.K])


def _assert_exact_bank(bank, plant):
    rep = gf.verify(bank, plant)
    assert rep.ok, rep.details
    assert rep.leakage.max() < 1e-10 and rep.input_leakage.max() < 1e-10
    return rep


# ------------------------------------------------------------ redundant sensors
@pytest.fixture(scope="module")
def redundant():
    """q = 4 > n = 2: C = [I; 1 1; 1 −1]."""
    return gf.Plant([[0, 1], [-2, -3]], [[0], [1]], [[1, 0], [0, 1], [1, 1], [1, -1]])


def test_more_sensors_than_states_exact_isolates_all(redundant):
    bank = gf.design_sensor_bank(redundant)
    assert bank.isolable.tolist() == [True] * 4
    assert bank.diagnostics == ["ok"] * 4
    assert all(g.order <= 2 for g in bank.generators)
    _assert_exact_bank(bank, redundant)
    sym = gf.verify_symbolic(bank, redundant)
    assert sym.ok, sym.details


def test_more_sensors_than_states_paper_refuses(redundant):
    with pytest.raises(DesignError) as info:
        gf.design_sensor_bank(redundant, method="paper")
    assert info.value.argument == "faults"
    msg = str(info.value)
    assert "faults[" in msg and "Im C" in msg and "method='exact'" in msg


def test_static_parity_residual_when_state_fully_decoupled():
    # n = 1, three sensors of the same state; decoupling a fault acting on the state
    # leaves S* = R^1: the residual is a static parity relation N y with N C = 0
    p = gf.Plant([[-1.0]], None, [[1.0], [2.0], [2.0]])
    faults = [gf.SensorFault(0), gf.SensorFault(1), gf.ActuatorFault([1.0])]
    g = gf.design_residual_generator(p, faults, [0, 1])
    assert g.order == 0
    assert np.abs(g.H @ p.C).max() < 1e-12
    rep = gf.verify(g, p)
    assert rep.ok and rep.leakage[0, 2] < 1e-12
    assert rep.target_gain[0, 0] > 0.1 and rep.target_gain[0, 1] > 0.1
    sym = gf.verify_symbolic(g, p)
    assert sym.ok and sym.transfer[:, 2].is_zero_matrix
    # the control-system view of a static generator
    sysg = g.to_statespace()
    assert sysg.nstates == 0
    np.testing.assert_allclose(sysg(1j), -g.H, atol=1e-14)


# --------------------------------------------------------- rank-deficient C
def test_two_identical_sensor_rows():
    A = [[0, 1, 0], [0, 0, 1], [-1, -2, -3]]
    p = gf.Plant(A, [[0], [0], [1]], [[1, 0, 0], [1, 0, 0], [0, 1, 0]])
    bank = gf.design_sensor_bank(p)
    assert bank.isolable.tolist() == [True, True, True]
    _assert_exact_bank(bank, p)
    # the paper transform needs C f = e_i: impossible for the duplicated rows
    with pytest.raises(DesignError) as info:
        gf.design_sensor_bank(p, method="paper")
    assert info.value.argument == "faults" and "faults[0]" in str(info.value)


def test_zero_sensor_row_gives_static_residual():
    A = [[0, 1, 0], [0, 0, 1], [-1, -2, -3]]
    p = gf.Plant(A, [[0], [0], [1]], [[1, 0, 0], [0, 0, 0], [0, 1, 0]])
    bank = gf.design_sensor_bank(p)
    assert bank.isolable.tolist() == [True, True, True]
    g = bank.generators[1]
    # y2 = m2: the residual is ±y2, nothing else
    assert g.order == 0
    T = _tf(g, 0.7j)
    assert abs(abs(T[0, 1]) - 1.0) < 1e-12
    assert np.abs(np.delete(T, 1, axis=1)).max() < 1e-12
    _assert_exact_bank(bank, p)
    with pytest.raises(DesignError) as info:
        gf.design_sensor_bank(p, method="paper")
    assert "faults[1]" in str(info.value) and "Im C" in str(info.value)


# --------------------------------------------------------------- integrator
@pytest.fixture(scope="module")
def integrator():
    """x1' = u (a pure integrator read by sensor 1), x2' = −x2 + u."""
    return gf.Plant([[0, 0], [0, -1]], [[1], [1]], [[1, 0], [0, 1]])


def test_integrator_paper_reports_invisible_sensor(integrator):
    bank = gf.design_sensor_bank(integrator, method="paper")
    assert bank.generators[0] is None
    d = bank.diagnostics[0]
    assert d.startswith("missing") and "not isolable" in d
    assert "A f_0 = 0" in d and "integrator" in d and "method='exact'" in d
    assert not bank.isolable[0]
    # the transform really gives a zero signature
    model = gf.pseudo_actuator_model(integrator, [gf.SensorFault(0), gf.SensorFault(1)], "paper")
    assert np.all(model.signatures[0] == 0)
    with pytest.raises(NotIsolableError) as info:
        gf.design_residual_generator(integrator, [gf.SensorFault(0)], 0, method="paper")
    assert "integrator" in info.value.reason


def test_integrator_exact_handles_it(integrator):
    bank = gf.design_sensor_bank(integrator)
    assert bank.isolable.tolist() == [True, True]
    # a constant bias on an integrator's sensor looks like another initial state: the
    # exact residual sees it only transiently, and says so
    assert bank.diagnostics == ["weak: zero DC gain from fault 0", "ok"]
    rep = _assert_exact_bank(bank, integrator)
    assert rep.dc_gain[0, 0] < 1e-9 and rep.target_gain[0, 0] > 1e-3
    assert rep.dc_gain[1, 1] > 1e-3
    sym = gf.verify_symbolic(bank, integrator)
    s = sym.variable
    assert sym.ok and sym.transfer[0, 1] == 0 and sym.transfer[1, 0] == 0
    assert sym.transfer[0, 0] != 0 and sym.transfer[0, 0].subs(s, 0) == 0
    assert sym.transfer[1, 1].subs(s, 0) != 0
    for g in bank.generators:
        assert np.all(g.poles.real <= -1 + 1e-9)


def test_discrete_integrator_paper_is_invisible_too():
    # discrete counterpart: x1[k+1] = x1[k] + u, so (A − I) f_0 = 0
    p = gf.Plant([[1, 0], [0, 0.5]], [[1], [1]], [[1, 0], [0, 1]], dt=0.1)
    bank = gf.design_sensor_bank(p, method="paper")
    assert bank.generators[0] is None and "(A − I) f_0 = 0" in bank.diagnostics[0]
    assert gf.design_sensor_bank(p).isolable.tolist() == [True, True]


# --------------------------------------------------------------- bad input
@pytest.fixture(scope="module")
def seed():
    return gf.Plant(SEED_A, SEED_B, SEED_C)


FAULTS = [gf.SensorFault(i) for i in range(3)]


@pytest.mark.parametrize(
    ("call", "argument", "words"),
    [
        (lambda p: gf.design_bank(p, FAULTS, np.eye(3)[:, :2]), "structure", "3 columns"),
        (lambda p: gf.design_bank(p, FAULTS, [[1, 1, 1, 0]]), "structure", "3 columns"),
        (lambda p: gf.design_bank(p, FAULTS, [[1, 0, 2]]), "structure", "0 or 1"),
        (lambda p: gf.design_residual_generator(p, FAULTS, 3), "target", "out of range"),
        (lambda p: gf.design_residual_generator(p, FAULTS, -1), "target", "out of range"),
        (lambda p: gf.design_residual_generator(p, FAULTS, 0, decouple=[5]), "decouple", "range"),
        (lambda p: gf.design_residual_generator(p, FAULTS, 0, decouple=0), "decouple", "targets"),
        (lambda p: gf.design_residual_generator(p, FAULTS, 0, poles=[-1, -2]), "poles", "1 poles"),
        (lambda p: gf.design_residual_generator(p, FAULTS, 0, poles=[1.0]), "poles", "left half"),
        (lambda p: gf.design_residual_generator(p, FAULTS, 0, poles=[0.0]), "poles", "left half"),
        (
            lambda p: gf.design_residual_generator(p, FAULTS, 1, poles=[-1 + 1j, -2 + 1j, -3]),
            "poles",
            "conjugate",
        ),
        (lambda p: gf.design_residual_generator(p, FAULTS, 0, poles=[np.nan]), "poles", "finite"),
        (lambda p: gf.design_sensor_bank(p, poles=[[-1], [-2]]), "poles", "3 entries"),
        (lambda p: gf.design_sensor_bank(p, poles=[-2]), "poles", "3 poles"),
        (lambda p: gf.design_sensor_bank(p, method="kalman"), "method", "one of"),
        (lambda p: gf.design_bank(p, [], np.zeros((1, 0))), "faults", "at least one"),
        (lambda p: gf.design_residual_generator(p, FAULTS, 0, filter_pole=-1), "filter_pole", ">"),
        (lambda p: gf.verify(gf.design_sensor_bank(p), p, FAULTS[:2]), "faults", "3 faults"),
    ],
)
def test_bad_input_names_the_argument(seed, call, argument, words):
    with pytest.raises(GeomFDIError) as info:
        call(seed)
    assert info.value.argument == argument
    assert argument in str(info.value) and words in str(info.value)


def test_bad_input_error_types(seed):
    with pytest.raises(ShapeError):
        gf.design_bank(seed, FAULTS, np.ones((2, 4)))
    with pytest.raises(DesignError):
        gf.design_residual_generator(seed, FAULTS, 0, poles=[-1, -2])
    with pytest.raises(GeomFDIError) as info:
        gf.design_sensor_bank("not a plant")
    assert info.value.argument == "plant"


def test_discrete_poles_must_be_inside_unit_circle():
    p = gf.Plant(np.diag([0.5, 0.2]), None, np.eye(2), dt=0.1)
    with pytest.raises(DesignError) as info:
        gf.design_residual_generator(p, [gf.SensorFault(0), gf.SensorFault(1)], 0, poles=[1.5])
    assert info.value.argument == "poles" and "unit circle" in str(info.value)


# ---------------------------------------------------------------- discrete time
@pytest.fixture(scope="module")
def sampled():
    """The Hou-Wen-Chen plant sampled with dt = 0.1 (two eigenvalues outside the unit circle)."""
    import scipy.linalg

    dt = 0.1
    A = np.array(SEED_A, float)
    M = scipy.linalg.expm(np.block([[A, np.array(SEED_B, float)], [np.zeros((3, 6))]]) * dt)
    return gf.Plant(M[:3, :3], M[:3, 3:], SEED_C, dt=dt)


def test_discrete_default_poles_within_margin(sampled):
    assert np.max(np.abs(np.linalg.eigvals(sampled.A))) > 1  # unstable plant
    bank = gf.design_sensor_bank(sampled, method="full")
    assert bank.isolable.tolist() == [True, True, True]
    assert [g.order for g in bank.generators] == [1, 3, 3]
    for g in bank.generators:
        assert g.is_discrete and g.dt == 0.1
        # moved poles are mirrored inside |z| = 0.5; kept ones already were (to 1e-3)
        assert np.all(np.abs(g.poles) <= 0.5 * (1 + 1e-3))
        pinfo = g.info["placement"]
        assert pinfo["kept"] + pinfo["moved"] == g.info["quotient_order"]
    _assert_exact_bank(bank, sampled)
    sym = gf.verify_symbolic(bank, sampled)
    assert str(sym.variable) == "z" and sym.ok


def test_discrete_requested_poles(sampled):
    faults = [gf.SensorFault(i) for i in range(3)]
    g = gf.design_residual_generator(
        sampled, faults, 1, poles=[0.1, 0.2 + 0.1j, 0.2 - 0.1j], method="full"
    )
    np.testing.assert_allclose(
        np.sort_complex(np.linalg.eigvals(g.info["construction"]["F"])),
        np.sort_complex([0.1, 0.2 - 0.1j, 0.2 + 0.1j]),
        atol=1e-8,
    )
    assert np.all(np.abs(g.poles) < 1)
    rep = gf.verify(g, sampled)
    assert rep.ok and rep.leakage.max() < 1e-10


def test_discrete_paper_leak_has_zero_dc_gain(sampled):
    # discrete analogue of the paper's transform, L = −(A − I) f: leaks vanish at z = 1
    bank = gf.design_sensor_bank(sampled, method="paper")
    rep = gf.verify(bank, sampled)
    for r, js in ((1, (0, 2)), (2, (0, 1))):
        for j in js:
            assert rep.leakage[r, j] > 1e-3
            assert rep.dc_gain[r, j] < 1e-10
    assert "zero DC gain" in bank.diagnostics[1]


def test_stable_discrete_plant_keeps_its_poles():
    # every quotient eigenvalue already meets |z| <= 0.5: nothing is moved
    p = gf.Plant(np.diag([0.3, -0.2, 0.1]), [[1], [1], [1]], [[1, 1, 0], [0, 1, 1]], dt=1.0)
    bank = gf.design_sensor_bank(p, method="full")
    for g in bank.generators:
        assert g.info["placement"]["moved"] == 0
        assert g.info["placement"].get("gain_norm", 0.0) == 0.0
        assert np.all(np.abs(g.poles) <= 0.5 + 1e-12)
    _assert_exact_bank(bank, p)
