"""Repeated simulations of one bank reuse its set-up: same results, info and warnings."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from test_simulation import K_FB, X0, paper_generator, v_ext

import geomfdi as gf
from geomfdi.simulation import open_loop
from geomfdi.simulation.initial_state import state_scaling

T = np.arange(0, 4.0005, 1e-3)


def _info(res):
    keys = ("init_mismatch", "init_residual", "initial_state", "w0", "channels")
    return {k: res.info.get(k) for k in keys}


def _equal(a, b):
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(_equal(a[k], b[k]) for k in a)
    return bool(np.array_equal(np.asarray(a), np.asarray(b)))


def test_second_call_hits_the_cache_and_agrees(seed001):
    bank = gf.ResidualBank(
        [paper_generator(seed001, j) for j in range(3)],
        np.eye(3, dtype=bool),
        np.eye(3, dtype=bool),
        np.ones(3, bool),
        ["ok"] * 3,
        [gf.SensorFault(i) for i in range(3)],
    )
    open_loop._SETUPS.clear()
    kw = dict(x0=X0, controller=K_FB, faults=[gf.BiasFault(1, start=2.0, bias=0.05)])
    a = gf.simulate(seed001, bank, T, v_ext, **kw)
    assert len(open_loop._SETUPS) == 1
    b = gf.simulate(seed001, bank, T, v_ext, **kw)
    assert len(open_loop._SETUPS) == 1  # reused, not rebuilt
    np.testing.assert_array_equal(a.residuals, b.residuals)
    assert _equal(_info(a), _info(b))
    # another initial state: the same set-up, its own consistent start (residual ~ 0)
    c = gf.simulate(seed001, bank, T, v_ext, **{**kw, "x0": -2 * X0})
    assert len(open_loop._SETUPS) == 1
    assert np.max(np.abs(c.residuals[:, : int(2.0 / 1e-3)])) < 1e-9
    assert not np.allclose(c.info["w0"][0], a.info["w0"][0])
    # another bank (a changed matrix): a new set-up
    g = paper_generator(seed001, 0)
    other = gf.ResidualGenerator(g.F * 1.5, g.E, g.G, g.M, g.H, g.K)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gf.InitialStateWarning)  # no longer decoupled
        gf.simulate(seed001, other, T, v_ext)
    assert len(open_loop._SETUPS) == 2


def test_set_up_warnings_are_replayed(seed001):
    g = paper_generator(seed001, 1)
    bad = gf.ResidualGenerator(g.F, g.E, g.G + 0.1, g.M, g.H, g.K)  # not decoupled from u
    open_loop._SETUPS.clear()
    for _ in range(2):  # the second call hits the cache and still warns
        with pytest.warns(gf.InitialStateWarning, match="generator 0"):
            res = gf.simulate(seed001, bad, T[::50], v_ext, x0=X0, controller=K_FB)
        assert res.info["initial_state"][0] == "zero"
    with warnings.catch_warnings():
        warnings.simplefilter("error", gf.InitialStateWarning)
        gf.simulate(seed001, g, T[::50], v_ext, x0=X0, controller=K_FB)  # a good one: silent


def test_a_generator_changed_in_place_is_checked_and_balanced_again(seed001):
    """The bank's checks and balancing are kept by the values of its matrices: an
    in-place change is seen (a non-finite entry is refused, a finite one simulated as
    a fresh generator with those matrices would be)."""
    A, B, C = seed001.A, seed001.B, seed001.C
    Ci = np.linalg.inv(C)
    F = np.array([[-2.0, 1e4], [0.0, -3.0]])  # badly scaled states: balanced
    P = np.array([[1.0, -2.0, 0.5], [0.3, 1.0, -1.0]]) * np.array([[1e3], [1e-1]])
    Mw = np.array([[1.0, 2.0]])
    g = gf.ResidualGenerator(F, (F @ P - P @ A) @ Ci, P @ B, Mw, Mw @ P @ Ci, np.zeros((1, 3)))
    assert not np.all(state_scaling(g.F) == 1.0)
    f = [gf.BiasFault(1, start=2.0, bias=0.05)]
    a = gf.simulate(seed001, g, T, v_ext, x0=X0, faults=f)
    assert g.F.flags.writeable and g.E.flags.writeable  # the user's arrays untouched
    g.E *= 1.1  # no longer decoupled: the residual changes
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", gf.InitialStateWarning)
        b = gf.simulate(seed001, g, T, v_ext, x0=X0, faults=f)
        fresh = gf.ResidualGenerator(g.F.copy(), g.E.copy(), g.G, g.M, g.H, g.K)
        c = gf.simulate(seed001, fresh, T, v_ext, x0=X0, faults=f)
    assert not np.allclose(a.residuals, b.residuals)
    np.testing.assert_array_equal(b.residuals, c.residuals)
    g.F[0, 0] = np.nan
    with pytest.raises(gf.errors.NonFiniteError, match="generator 0 has a non-finite entry in F"):
        gf.simulate(seed001, g, T, v_ext, x0=X0, faults=f)
