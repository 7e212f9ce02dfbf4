"""Diagonal state scaling of (A, B, C) before rank decisions (SLICOT TB01ID style).

See the user guide, *Theory: least-order synthesis* (``docs/theory/least-order.md``).

A change of state coordinates ``x = T x̃`` leaves every transfer function, hence every
residual generator reading y and u, unchanged; but rank decisions on a badly scaled
realisation (e.g. ``T = diag(10^k)``) are taken between numbers of wildly different size.
The system matrix ``[[A, B], [C, 0]]`` is balanced by a diagonal similarity on the
state only, with powers of 2 (exact in floating point)::

    Ã = D⁻¹ A D,   B̃ = D⁻¹ B,   C̃ = C D

chosen by LAPACK's balancing (``scipy.linalg.matrix_balance``, no permutation) of the
square matrix ``[[A, B], [C, 0]]`` padded with zeros; only the state part of the scaling
is applied.  A design on the balanced model maps back through ``x̃ = D⁻¹ x`` (e.g. the
quotient map ``P → P D⁻¹``); generators reading y and u need no change.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

__all__ = ["state_scaling"]


def state_scaling(A: np.ndarray, B: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Diagonal ``d`` (powers of 2) balancing ``[[D⁻¹ A D, D⁻¹ B], [C D, 0]]``, D = diag(d).

    Parameters
    ----------
    A : ndarray, (n, n)
    B : ndarray, (n, m)
        Every input-side matrix (inputs, disturbances, fault signatures), stacked.
    C : ndarray, (q, n)

    Returns
    -------
    ndarray, (n,)
        Positive scaling factors; ones when the data are already balanced.
    """
    n = A.shape[0]
    if n == 0:
        return np.ones(0)
    m, q = B.shape[1], C.shape[0]
    p = max(m, q)
    Z = np.zeros((n + p, n + p))
    Z[:n, :n] = np.abs(A)
    Z[:n, n : n + m] = np.abs(B)
    Z[n : n + q, :n] = np.abs(C)
    if not np.all(np.isfinite(Z)) or not np.any(Z):
        return np.ones(n)
    _, (scale, _) = scipy.linalg.matrix_balance(Z, permute=False, separate=True)
    d = np.asarray(scale[:n], dtype=float)
    # the input/output part of the scaling is not applied: renormalise so that the state
    # scaling is centred (a common factor of D does not change the balanced transfer
    # but changes ‖B̃‖ and ‖C̃‖ against each other)
    c = 2.0 ** np.round(np.mean(np.log2(d)))
    return d / c
