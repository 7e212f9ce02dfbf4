"""Reachable / unobservable subspaces and minimal realizations (orthonormal Krylov).

Used to deliver residual generators without redundant states (the filter states of the
exact transform of ``docs/theory/sensor-fault-transforms.md`` are removed where they are
unobservable or unreachable) and to test transfers for being identically zero.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geomfdi._validation import as_matrix
from geomfdi.geometry.subspace import Subspace, _norm2, invariant_closure, kernel
from geomfdi.geometry.unobservability import max_invariant_in

__all__ = ["reachable_subspace", "minimal_realization", "MinimalRealization"]


def reachable_subspace(A: np.ndarray, B: np.ndarray) -> Subspace:
    """``<A | Im B>``: the smallest A-invariant subspace containing Im B.

    Orthonormal Krylov iteration ``V_0 = Im B, V_{k+1} = Im B + A V_k`` on the new
    directions of each step (:func:`geomfdi.geometry.subspace.invariant_closure`, ``O(n³)``
    in all), with every rank decision on the un-normalised product ``A V / ‖A‖``
    (tolerance policy of :mod:`geomfdi.tolerance`).
    """
    A = as_matrix(A, "A", square=True)
    B = as_matrix(B, "B", rows=A.shape[0], allow_empty=True, vector_as="column")
    n = A.shape[0]
    if B.size == 0:
        return Subspace.zero(n)
    ImB = Subspace(B)
    if ImB.dim in (0, n):
        return ImB
    An = A / (_norm2(A) or 1.0)
    return Subspace.from_orthonormal(invariant_closure(An, ImB.basis, what="reachable subspace"))


@dataclass
class MinimalRealization:
    """``(A, B, C, D)`` of a minimal realization and the map from the original state.

    Attributes
    ----------
    A, B, C, D : ndarray
    T : ndarray, (order, n_original)
        Orthonormal rows: the minimal state is ``T x`` for a state ``x`` of the original
        realization lying in its reachable subspace.
    removed : int
        Number of states removed.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    T: np.ndarray
    removed: int


def minimal_realization(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray
) -> MinimalRealization:
    """Remove unreachable then unobservable states (Kalman decomposition, orthonormal).

    Notes
    -----
    1. ``Vr`` = orthonormal basis of ``<A | Im B>``; ``(Vrᵀ A Vr, Vrᵀ B, C Vr)``.
    2. ``N`` = unobservable subspace of that pair (largest invariant subspace in
       ``Ker C``); with ``Q`` an orthonormal basis of ``N^⊥`` the quotient realization
       is ``(Qᵀ A Q, Qᵀ B, C Q)`` — exact because N is invariant and ``C N = 0``.
    The transfer function is unchanged; the result is controllable and observable up
    to the tolerance policy.
    """
    A = as_matrix(A, "A", square=True, allow_empty=True)
    B = as_matrix(B, "B", rows=A.shape[0], allow_empty=True, vector_as="column")
    C = as_matrix(C, "C", cols=A.shape[0], allow_empty=True, vector_as="row")
    D = as_matrix(D, "D", rows=C.shape[0], cols=B.shape[1], allow_empty=True)
    n = A.shape[0]
    if n == 0:
        return MinimalRealization(A, B, C, D, np.zeros((0, 0)), 0)
    Vr = reachable_subspace(A, B).basis
    Ar, Br, Cr = Vr.T @ A @ Vr, Vr.T @ B, C @ Vr
    k = Ar.shape[0]
    if k == 0:
        return MinimalRealization(
            np.zeros((0, 0)),
            np.zeros((0, B.shape[1])),
            np.zeros((C.shape[0], 0)),
            D,
            np.zeros((0, n)),
            n,
        )
    if Cr.size and _norm2(Cr) > 0:
        N = max_invariant_in(Ar, kernel(Cr))
    else:
        N = Subspace.full(k)
    Q = N.complement().basis
    T = Q.T @ Vr.T
    return MinimalRealization(Q.T @ Ar @ Q, Q.T @ Br, Cr @ Q, D, T, n - Q.shape[1])
