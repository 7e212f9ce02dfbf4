"""S*'s written-out one-direction steps are the general recursion's steps, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

import geomfdi as gf
import geomfdi.geometry.unobservability as unobs
from geomfdi.geometry.conditioned_invariant import min_conditioned_invariant
from geomfdi.geometry.subspace import _extend, _norm2, split_kernel
from geomfdi.tolerance import decision_stage, record_decisions


def _sensor_row(N: int = 12, q: int = 4):
    """The augmented model of a sensor-bank row: sensors 1 … q−1 decoupled, their faults
    made states (W* is then spanned by coordinate axes)."""
    p = gf.mass_spring_chain(N, sensors=q, forces=(N // 3, N - 1), zeta=0.01)
    n, na = p.n, q - 1
    Aa = np.zeros((n + na, n + na))
    Aa[:n, :n] = p.A
    Ca = np.hstack([p.C, np.eye(q)[:, 1:]])
    La = np.vstack([np.zeros((n, na)), np.eye(na)])
    return Aa, Ca, La


def _textbook(A, C, L):
    """The dual recursion with the general functions only (split_kernel, the two
    projections off W*, extend_basis): the reference the fast steps must reproduce.

    V's basis is held as the function holds it, in the first columns of an ``n × n``
    array: the BLAS's products on a contiguous copy may round differently."""
    n = A.shape[0]
    W = min_conditioned_invariant(A, C, L)
    nA, nC = _norm2(A) or 1.0, _norm2(C) or 1.0
    Wb = W.basis
    with record_decisions() as rec, decision_stage("S*"):
        Vb, nv, Y = np.empty((n, n)), 0, np.zeros((n, 0))
        R = np.zeros((n, 0))
        new, noise = _extend(Vb[:, :0], C.T, nC, "Im Cᵀ (Ker C)", 0.0)
        for _ in range(n + 1):
            Y_new, R = split_kernel(np.concatenate((R, new), axis=1), Wb.T, 1.0, "V ∩ W*^⊥")
            Y_new = unobs._project_out(Y_new, Wb)
            Vb[:, nv : nv + new.shape[1]] = new
            nv, Y = nv + new.shape[1], np.hstack([Y, Y_new])
            if not Y_new.shape[1]:
                break
            step = "Im Cᵀ + Aᵀ Z^⊥ (A⁻¹(Z) ∩ Ker C)"
            new, noise = _extend(Vb[:, :nv], A.T @ Y_new, nA, step, noise)
    return Y, [(d.rank, d.tol, d.gap, d.what, d.where) for d in rec]


def _complement(Y, W):
    """S* = Y^⊥ as the function forms it: R^n when Y = 0, W* when Y spans W*^⊥, else the
    last columns of Y's complete QR."""
    n, ny = Y.shape
    if not ny:
        return np.eye(n)
    if ny + W.dim == n:
        return W.basis
    return np.linalg.qr(Y, mode="complete")[0][:, ny:]


@pytest.mark.parametrize("axes", [True, False])
@pytest.mark.parametrize("N, q", [(12, 4), (100, 10)])  # (100, 10): the benchmark's chain
def test_fast_steps_reproduce_the_general_recursion(monkeypatch, axes, N, q):
    A, C, L = _sensor_row(N, q)
    if not axes:  # the general products against W* instead of row selections
        monkeypatch.setattr(unobs, "_axes", lambda W: None)
    else:
        assert unobs._axes(min_conditioned_invariant(A, C, L).basis) is not None
    calls = []
    step = unobs._Steps.step
    monkeypatch.setattr(unobs._Steps, "step", lambda *a: calls.append(1) or step(*a))
    S = gf.min_unobservability_subspace(A, C, L)
    assert len(calls) > 10  # the written-out steps did the work
    Y, ref = _textbook(A, C, L)
    got = [(d.rank, d.tol, d.gap, d.what, d.where) for d in S.decisions[len(S.W.decisions) :]]
    assert got == ref  # the same decisions, singular-value gaps included, bit for bit
    assert S.dim == A.shape[0] - Y.shape[1]
    # S* = Y^⊥, from the same Y bit for bit
    assert np.array_equal(S.basis, _complement(Y, S.W))
    assert np.allclose(Y.T @ S.basis, 0.0, atol=1e-13)


def _spy_paths(monkeypatch):
    """Record the kind of each step: ``"fast"`` (one direction, written out) or
    ``"general"`` (split_kernel on several directions)."""
    kinds = []
    step, split = unobs._Steps.step, unobs.split_kernel
    monkeypatch.setattr(unobs._Steps, "step", lambda *a: kinds.append("fast") or step(*a))
    monkeypatch.setattr(unobs, "split_kernel", lambda *a: kinds.append("general") or split(*a))
    return kinds


def test_fast_and_general_steps_interleave_bit_for_bit(monkeypatch):
    """Dense random plants (W* not made of axes): the written-out steps, the general ones
    and the switches between them (the decisions of the written-out steps are recorded
    in order before the general path's) give the decisions and the basis of the
    reference, bit for bit."""
    kinds = _spy_paths(monkeypatch)
    switched = 0
    for seed in range(40):
        rng = np.random.default_rng(seed)
        n, q, k = (int(v) for v in rng.integers((4, 1, 1), (12, 4, 4)))
        A, C, L = (
            rng.standard_normal((n, n)),
            rng.standard_normal((q, n)),
            rng.standard_normal((n, k)),
        )
        if seed % 3 == 0:
            A[:, :2] = 0.0  # a singular A
        kinds.clear()
        S = gf.min_unobservability_subspace(A, C, L)
        Y, ref = _textbook(A, C, L)
        got = [(d.rank, d.tol, d.gap, d.what, d.where) for d in S.decisions[len(S.W.decisions) :]]
        assert got == ref, seed
        assert S.history[0] == n and S.dim == n - Y.shape[1], seed
        assert np.array_equal(S.basis, _complement(Y, S.W)), seed
        switched += any(
            a == "fast" and b == "general" for a, b in zip(kinds[:-1], kinds[1:], strict=True)
        )
    assert switched >= 3  # the hand-over from written-out to general steps was exercised


def test_axes_are_recognised_exactly():
    W = np.zeros((5, 2))
    W[3, 0], W[1, 1] = -1.0, 1.0
    rows, signs = unobs._axes(W)
    assert rows.tolist() == [3, 1] and signs.tolist() == [-1.0, 1.0]
    W[0, 0] = 1e-300  # one more non-zero entry: not an axis
    assert unobs._axes(W) is None
    assert unobs._axes(np.linalg.qr(np.ones((5, 2)) + np.eye(5, 2))[0]) is None


def _step_case(kind: str, wtype: str, rng: np.random.Generator):
    """Operands of one step: W*'s basis, ``X = [R, new]`` with a null space of ``W*ᵀ X``
    of dimension 1 (``kind="one"``), 2 (``"several"``) or 0 (``"none"``)."""
    n, m = 12, 3
    if wtype == "dense":
        Wb = np.linalg.qr(rng.standard_normal((n, m)))[0]
    else:
        rows = [9, 10, 11] if wtype != "scattered" else [7, 1, 4]
        Wb = np.zeros((n, m))
        signs = [1.0, 1.0, 1.0] if wtype == "positive" else [1.0, -1.0, -1.0]
        Wb[rows, range(m)] = signs
    Wp = np.linalg.qr(np.hstack([Wb, rng.standard_normal((n, n - m))]))[0][:, m:]  # W*^⊥
    if kind == "one":  # R: m directions, W*ᵀ R invertible
        R = rng.standard_normal((n, m))
    elif kind == "several":  # two of R's directions inside W*^⊥
        R = np.hstack([rng.standard_normal((n, m - 2)), Wp[:, :2]])
    else:  # fewer directions than dim W*: W*ᵀ X of full column rank
        R = rng.standard_normal((n, m - 1))
    X = np.linalg.qr(np.hstack([R, rng.standard_normal((n, 1))]))[0]
    return Wb, np.ascontiguousarray(X)


@pytest.mark.parametrize("kind", ["one", "several", "none"])
@pytest.mark.parametrize("wtype", ["signed", "positive", "scattered", "dense"])
def test_written_out_step_is_the_general_operations_bit_for_bit(kind, wtype):
    """One step on constructed operands, every branch of it (a null space of dimension
    1, 2 or 0; W* of signed, positive or scattered coordinate axes, or dense): the
    general functions' decisions (in order), bases and next directions, bit for bit."""
    rng = np.random.default_rng(["one", "several", "none"].index(kind))
    Wb, X = _step_case(kind, wtype, rng)
    n, k = X.shape
    A = rng.standard_normal((n, n))
    nA, noise, nv, ny = _norm2(A), 1e-14, 4, 2
    Vb0 = np.zeros((n, n))
    Vb0[:, :nv] = np.linalg.qr(rng.standard_normal((n, nv)))[0]
    Yb0 = np.zeros((n, n))
    axes = unobs._axes(Wb)
    assert (axes is None) == (wtype == "dense")
    if axes is not None and np.all(axes[1] > 0):
        axes = (axes[0], None)
    # the written-out step
    Vb, Yb, hist = Vb0.copy(), Yb0.copy(), []
    with record_decisions() as got, decision_stage("S*"):
        steps = unobs._Steps(Wb, A.T, nA, axes)
        ny1, nv1, R1, new1, X1, noise1 = steps.step(X.copy(), Vb, Yb, nv, ny, noise, hist)
        steps.flush()
    # the general operations
    Vr, Yr = Vb0.copy(), Yb0.copy()
    with record_decisions() as ref, decision_stage("S*"):
        Y_new, R = split_kernel(X, Wb.T, 1.0, unobs._SPLIT)
        Y_new = unobs._project_out(Y_new, Wb)
        Vr[:, nv] = X[:, -1]
        dy = Y_new.shape[1]
        Yr[:, ny : ny + dy] = Y_new
        new, noise2 = None, noise
        if dy:
            new, noise2 = _extend(Vr[:, : nv + 1], A.T @ Y_new, nA, unobs._STEP, noise)
    assert dy == {"one": 1, "several": 2, "none": 0}[kind]
    assert [(d.rank, d.tol, d.gap, d.what, d.where) for d in got] == [
        (d.rank, d.tol, d.gap, d.what, d.where) for d in ref
    ]
    assert (ny1, nv1, hist) == (ny + dy, nv + 1, [n - ny - dy])
    assert np.array_equal(Vb, Vr) and np.array_equal(Yb, Yr) and np.array_equal(R1, R)
    assert (new1 is None) == (new is None) and noise1 == noise2
    if new is not None:
        assert np.array_equal(new1, new)
        # one new direction: the next [R, new] is ready in a work array, contiguous
        assert (X1 is not None) == (new.shape[1] == 1 and dy == 1)
        if X1 is not None:
            assert X1.flags.c_contiguous and np.array_equal(X1, np.hstack([R, new]))


def test_written_out_step_falls_back_when_the_lapack_call_fails(monkeypatch):
    """A failed direct LAPACK call (``info ≠ 0``) is redone by the general SVD: the same
    step as without the failure."""
    rng = np.random.default_rng(5)
    Wb, X = _step_case("one", "signed", rng)
    n = X.shape[0]
    A = rng.standard_normal((n, n))
    axes = unobs._axes(Wb)

    def run():
        Vb, Yb = np.zeros((n, n)), np.zeros((n, n))
        with record_decisions() as rec, decision_stage("S*"):
            steps = unobs._Steps(Wb, A.T, _norm2(A), axes)
            out = steps.step(X.copy(), Vb, Yb, 0, 0, 0.0, [])
            steps.flush()
        return out, Vb, Yb, [(d.rank, d.tol, d.gap) for d in rec]

    ok = run()
    dgesdd, failed = unobs._DGESDD, []

    def failing(*args, **kw):
        u, s, vt, _ = dgesdd(*args, **kw)
        failed.append(1)
        return u, s * np.nan, vt, 1

    monkeypatch.setattr(unobs, "_DGESDD", failing)
    bad = run()
    assert failed
    assert bad[3] == ok[3]
    for a, b in zip((*ok[0][2:4], ok[1], ok[2]), (*bad[0][2:4], bad[1], bad[2]), strict=True):
        assert np.array_equal(a, b)
