"""Parametric plants: exact design over Q(k, m), exceptional set, substitution, Plant API."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import geomfdi as gf
from geomfdi.errors import DesignError, GeomFDIError, ShapeError
from geomfdi.synthesis.design import FD_GAIN_TOL

k, m = sp.symbols("k m", positive=True)
s = sp.Symbol("s")
# the Hou-Wen-Chen (2011) example with two entries made parameters
# (k = 2, m = 2 is the paper's plant)
A = sp.Matrix([[1, 1, 1], [0, 1, 0], [k, 0, 1]])
B = sp.Matrix([[1, 0, 1], [0, 1, 1], [0, 1, 0]])
C = sp.Matrix([[0, 1, 0], [0, 0, 1], [1, 0, m]])


@pytest.fixture(scope="module")
def plant():
    return gf.Plant(A, B, C)


@pytest.fixture(scope="module")
def ebank(plant):
    return gf.design_sensor_bank(plant, exact=True)


def _tf(g, z):
    n = g.order
    X = np.linalg.solve(z * np.eye(n) - g.F, np.hstack([-g.E, g.G])) if n else np.zeros((0, 1))
    return (g.M @ X if n else 0) + np.hstack([-g.H, g.K])


# ------------------------------------------------------------------ Plant API
def test_positional_scalar_after_c_is_d_not_dt_and_explained():
    A2, B2, C2 = [[0, 1], [-2, -3]], [[0], [1]], [[1, 0], [0, 1]]
    with pytest.raises(ShapeError) as info:
        gf.Plant(A2, B2, C2, 0.1)
    assert info.value.argument == "D"
    assert "dt=0.1" in str(info.value) and "ss(A, B, C, D, dt)" in str(info.value)
    p = gf.Plant(A2, B2, C2, 0, 0.1)  # python-control's positional order
    assert p.dt == 0.1 and np.array_equal(p.D, np.zeros((2, 1)))
    assert gf.Plant(A2, B2, C2, dt=0.1).dt == 0.1
    siso = gf.Plant(A2, B2, [[1, 0]], 0.5)  # one output, one input: a scalar D is D
    assert siso.D.tolist() == [[0.5]] and siso.dt == 0


def test_parametric_plant_holds_symbols_and_substitutes(plant):
    assert plant.is_parametric and plant.parameters == (k, m)
    assert "parameters=[k, m]" in repr(plant)
    p2 = plant.subs({"k": 2, m: 2.0})
    assert not p2.is_parametric
    np.testing.assert_array_equal(p2.A, [[1, 1, 1], [0, 1, 0], [2, 0, 1]])
    with pytest.raises(GeomFDIError) as info:
        plant.subs({k: 1.0})
    assert info.value.argument == "values" and "m" in str(info.value)


def test_numeric_functions_ask_for_subs(plant):
    with pytest.raises(GeomFDIError) as info:
        gf.design_sensor_bank(plant)
    assert info.value.argument == "plant" and "subs" in str(info.value)
    with pytest.raises(GeomFDIError, match="exact=True"):
        gf.verify(gf.design_sensor_bank(plant.subs({k: 2, m: 2})), plant)


def test_non_rational_entries_are_refused():
    with pytest.raises(GeomFDIError, match="rational functions"):
        gf.Plant(sp.Matrix([[sp.sqrt(k)]]), None, [[1]])


# ------------------------------------------------------------- exact design
def test_parametric_sensor_bank_decouples_identically(plant, ebank):
    assert isinstance(ebank, gf.ExactResidualBank)
    assert ebank.parameters == (k, m)
    assert ebank.diagnostics == ["ok"] * 3
    np.testing.assert_array_equal(ebank.structure, np.eye(3, dtype=bool))
    for g in ebank.generators:
        assert g.F.free_symbols <= {k, m} and (g.E.free_symbols | g.M.free_symbols) <= {k, m}
    # independent check of one decoupled entry with sympy Matrix arithmetic: every Markov
    # parameter of the transfer from sensor fault 0 to residual 1 cancels to 0
    g = ebank.generators[1]
    Ac = sp.BlockMatrix([[A, sp.zeros(3, g.order)], [-g.E * C, g.F]]).as_explicit()
    Cc = (-g.H * C).row_join(g.M)
    v = sp.zeros(3, 1).col_join(-g.E[:, 0])  # sensor fault 0 enters through y only
    assert g.H[0, 0] == 0
    for _ in range(Ac.rows):
        assert sp.cancel((Cc * v)[0, 0]) == 0
        v = (Ac * v).applyfunc(sp.cancel)
    rep = gf.verify_symbolic(ebank, plant)
    assert rep.ok, rep.details
    for r in range(3):
        for j in range(3):
            assert (rep.transfer[r, j] == 0) == (r != j)
            assert rep.structural[r, j] == (r != j)
    assert rep.input_transfer.is_zero_matrix


def test_exceptional_set_is_where_the_rank_drops(plant, ebank):
    cond = [c for c in ebank.exceptional if c.kind in ("fails", "formula")]
    exprs = [sp.expand(c.expr) for c in cond]
    assert sp.expand(k * m**2 - 1) in exprs, ebank.exceptional
    # on it: the design of row 2 redone at that point has a different S* (or is missing)
    on = {k: sp.Rational(1, 4), m: 2}
    assert ebank.on_exceptional_set(on)
    with pytest.raises(DesignError) as info:
        ebank.subs(on)
    assert info.value.argument == "values"
    at = gf.design_sensor_bank(gf.Plant(A.subs(on), B, C.subs(on)), exact=True)
    g_at, g_gen = at.generators[2], ebank.generators[2]
    assert g_at is None or g_at.info["S_history"] != g_gen.info["S_history"]
    # off it: the generic formulas hold, numerically and exactly
    off = {k: 2, m: 2}
    assert not ebank.on_exceptional_set(off)
    nb = ebank.subs(off)
    p_off = plant.subs(off)
    assert gf.verify(nb, p_off).ok
    rep = gf.verify_symbolic(nb, p_off)
    assert rep.ok and rep.rounding_level < 1e-12


@pytest.mark.slow
def test_subs_equals_numeric_design_at_random_points(plant, ebank):
    poles = [[float(p) for p in g.info["poles"]] for g in ebank.generators]
    rng = np.random.default_rng(7)
    pts = (0.3 + 1j, -0.7 + 2j, 1.5, 4j)
    checked = 0
    while checked < 20:
        vals = {k: float(rng.uniform(0.2, 4)), m: float(rng.uniform(0.2, 4))}
        if ebank.on_exceptional_set(vals):
            continue
        nb = ebank.subs(vals)
        num = gf.design_sensor_bank(plant.subs(vals), method="full", filter_pole=1.0, poles=poles)
        # strong detectability: "ok" exactly where the exact design's DC gain from its
        # target is at least FD_GAIN_TOL of its largest sensor-fault gain over frequency
        # (near k = 1 the DC gain of rows 1 and 2 vanishes, so "weak" is right there)
        omega = float(np.max(np.abs(np.linalg.eigvals(plant.subs(vals).A))))
        ws = omega * np.logspace(-3, 3, 31)
        for r, ge in enumerate(nb.generators):
            Ty = [np.linalg.norm(_tf(ge, 1j * w)[:, :3], axis=0) for w in ws]
            dc = float(np.linalg.norm(_tf(ge, 0.0)[:, r]))
            top = max(dc, *(float(np.max(T)) for T in Ty))
            want_ok = dc >= FD_GAIN_TOL * top
            assert (num.diagnostics[r] == "ok") == want_ok, (vals, r, dc / top)
            assert want_ok or num.diagnostics[r].startswith("weak: ")
        np.testing.assert_array_equal(nb.structure, num.structure)
        for ge, gn in zip(nb.generators, num.generators, strict=True):
            T1 = np.concatenate([_tf(ge, z).ravel() for z in pts])
            T2 = np.concatenate([_tf(gn, z).ravel() for z in pts])
            c = (T2.conj() @ T1) / (T2.conj() @ T2)  # residuals are defined up to a factor
            assert np.linalg.norm(T1 - c * T2) <= 1e-9 * np.linalg.norm(T1)
        checked += 1


def test_symbolic_poles_and_single_residual():
    p = sp.Symbol("p", positive=True)
    plant = gf.Plant(A.subs(k, 2), B, C)  # one parameter m; the pole is a symbol too
    faults = [gf.SensorFault(i) for i in range(3)]
    g = gf.design_residual_generator(plant, faults, 0, exact=True, poles=[-p])
    assert isinstance(g, gf.ExactResidualGenerator)
    assert g.target == (0,) and g.decoupled == (1, 2)
    assert set(g.parameters) == {m, p}
    # quotient pole -p, two output-filter states at -a = -1
    charpoly = (s * sp.eye(g.order) - g.F).det()
    assert sp.expand(charpoly - (s + p) * (s + 1) ** 2) == 0
    num = g.subs({m: 2, p: 3})
    np.testing.assert_allclose(np.sort(np.linalg.eigvals(num.F).real), [-3, -1, -1], atol=1e-7)
    assert gf.verify(num, plant.subs({m: 2}), faults).ok
    assert "\\displaystyle" in g._repr_latex_()


def test_exact_design_options_are_validated(plant):
    with pytest.raises(DesignError) as info:
        gf.design_sensor_bank(plant, exact=True, method="paper")
    assert info.value.argument == "method"
    with pytest.raises(DesignError) as info:
        gf.design_sensor_bank(plant, exact=True, poles=[[-1], [-1], [-1]])
    assert info.value.argument == "poles"


def test_exact_geometry_accepts_symbols_with_exceptional_set():
    kr = sp.Symbol("k")  # any real k (no positivity assumed)
    A0 = sp.Matrix([[1, 1, 1], [0, 1, 0], [2, 0, 1]])
    Ck = sp.Matrix([[kr, 1, 0], [1, 0, 1]])
    L = [1, -1, 0]
    S = gf.exact.min_unobservability_subspace(A0, Ck, L)
    assert S.dim == 1 and S.exceptional == [kr - sp.Rational(1, 3)]
    # on the condition S* is a plane; off it (k = 2) it is the generic line
    on = gf.exact.min_unobservability_subspace(A0, Ck.subs(kr, sp.Rational(1, 3)), L)
    off = gf.exact.min_unobservability_subspace(A0, Ck.subs(kr, 2), L)
    assert on.dim == 2 and off.dim == 1
    assert off.basis == S.basis.subs(kr, 2)
    # with k > 0 assumed, k - 1/3 still can vanish; with k < 0 it cannot
    kn = sp.Symbol("kn", negative=True)
    Sn = gf.exact.min_unobservability_subspace(A0, Ck.subs(kr, kn), L)
    assert Sn.dim == 1 and Sn.exceptional == []
    W = gf.exact.min_conditioned_invariant(A0, Ck, L)
    assert S.W.history == W.history and W.basis == S.W.basis
