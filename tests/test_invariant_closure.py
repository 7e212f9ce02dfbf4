"""Reachable and unobservable subspaces of larger systems with a known answer (the Krylov
recursion grows by the new directions only)."""

from __future__ import annotations

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.geometry.subspace import Subspace, invariant_closure, principal_angles


def _hidden(n: int, n1: int, seed: int):
    """``A = T diag(A1, A2) T⁻¹``, ``B = T [B1; 0]``, ``C = [C1, 0] T⁻¹``: the first n1
    coordinates of T are the reachable subspace, the last n − n1 the unobservable one
    (four inputs and outputs: a Krylov depth of about n1 / 4, well conditioned)."""
    rng = np.random.default_rng(seed)
    T = rng.standard_normal((n, n)) + n * np.eye(n)
    A1 = rng.standard_normal((n1, n1)) / np.sqrt(n1) - 2 * np.eye(n1)
    A2 = rng.standard_normal((n - n1, n - n1)) / np.sqrt(n - n1) - 3 * np.eye(n - n1)
    Ad = np.block([[A1, np.zeros((n1, n - n1))], [np.zeros((n - n1, n1)), A2]])
    A = T @ Ad @ np.linalg.inv(T)
    B = T @ np.vstack([rng.standard_normal((n1, 4)), np.zeros((n - n1, 4))])
    C = np.hstack([rng.standard_normal((4, n1)), np.zeros((4, n - n1))]) @ np.linalg.inv(T)
    return A, B, C, T


@pytest.mark.parametrize(("n", "n1"), [(12, 5), (60, 23), (120, 31)])
def test_reachable_and_unobservable_subspaces_of_a_hidden_split(n, n1):
    A, B, C, T = _hidden(n, n1, n)
    R = gf.reachable_subspace(A, B)
    assert R.dim == n1
    assert np.max(principal_angles(R, Subspace(T[:, :n1]))) < 1e-6
    N = gf.unobservable_subspace(A, C)
    assert N.dim == n - n1
    assert np.max(principal_angles(N, Subspace(T[:, n1:]))) < 1e-6
    mr = gf.minimal_realization(A, B, C, np.zeros((4, 4)))
    assert mr.A.shape == (n1, n1)
    s = 0.7j
    G = C @ np.linalg.solve(s * np.eye(n) - A, B)
    Gm = mr.C @ np.linalg.solve(s * np.eye(n1) - mr.A, mr.B)
    assert np.allclose(G, Gm, rtol=1e-8, atol=1e-10 * np.abs(G).max())


def test_closure_of_an_invariant_subspace_is_itself_and_of_a_cyclic_vector_everything():
    rng = np.random.default_rng(3)
    A = rng.standard_normal((30, 30))
    A /= np.linalg.norm(A, 2)
    Q, _ = np.linalg.qr(rng.standard_normal((30, 1)))
    V = invariant_closure(A, Q, what="test")
    assert V.shape == (30, 30)
    assert np.allclose(V.T @ V, np.eye(30), atol=1e-10)
    # an eigenvector's span is invariant: nothing is added
    w, X = np.linalg.eig(A + A.T)
    v = X[:, :1] / np.linalg.norm(X[:, :1])
    assert invariant_closure((A + A.T) / 2, v, what="test").shape == (30, 1)
