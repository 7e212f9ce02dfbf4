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
