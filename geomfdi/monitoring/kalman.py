"""Innovations of a steady-state Kalman filter in the loop (the data the AR monitor sees).

For ``x(k+1) = A x(k) + G w(k)``, ``y(k) = C x(k) + v(k)`` with ``w ~ N(0, Q)``,
``v ~ N(0, R)``, python-control's ``dlqe`` returns the *predictor* gain ``L`` and the
covariance ``P`` of the one-step prediction.  The filter form used here updates with the
filter gain ``K = P C^T S^{-1}``, ``S = C P C^T + R``::

    x_pred(k) = A x_filt(k-1),   nu(k) = y(k) - C x_pred(k),   x_filt(k) = x_pred(k) + K nu(k)

(``L = A K``).  Without fault ``nu ~ N(0, S)`` is white.  A step fault ``b`` on the
measurements enters the innovation fully at its onset and is then *absorbed* by the state
estimate: for a random walk observed directly the innovation mean decays as
``b (1 - K)^j`` after ``j`` samples, so every innovation test sees the fault only for a
while.  See the user guide, *Theory: AR monitoring* (``docs/theory/ar-monitoring.md``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from geomfdi._validation import as_matrix, as_real_array, as_vector
from geomfdi.errors import GeomFDIError, ShapeError

__all__ = ["KalmanInnovations", "kalman_innovations"]


@dataclass(frozen=True)
class KalmanInnovations:
    """Output of :func:`kalman_innovations`.

    Attributes
    ----------
    innovations : ndarray, (N, p) or (R, N, p)
        ``nu(k) = y(k) - C x_pred(k)``.
    normalized : ndarray, same shape
        ``S^{-1/2} nu``: ``N(0, I)`` without fault in steady state.
    gain : ndarray, (n, p)
        Filter gain ``K = P C^T S^{-1}``.
    predictor_gain : ndarray, (n, p)
        ``dlqe``'s gain ``L = A K``.
    S : ndarray, (p, p)
        Innovation covariance ``C P C^T + R``.
    """

    innovations: np.ndarray
    normalized: np.ndarray
    gain: np.ndarray
    predictor_gain: np.ndarray
    S: np.ndarray


def kalman_innovations(
    A: Any, C: Any, Q: Any, R: Any, y: Any, *, G: Any = None, x0: Any = None
) -> KalmanInnovations:
    """Run the steady-state Kalman filter (filter form) on ``y`` and return its innovations.

    Parameters
    ----------
    A, C : array_like
        Discrete model, (n, n) and (p, n).
    Q, R : array_like
        Process and measurement noise covariances, (g, g) and (p, p) (scalars allowed).
    y : array_like, (N, p) or (R, N, p), or (N,) for one output
        Measurements.
    G : array_like, (n, g), optional
        Process-noise input matrix (default the identity).
    x0 : array_like, (n,), optional
        Initial filtered state (default 0).

    Returns
    -------
    KalmanInnovations

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> y = np.cumsum(rng.standard_normal(5000)) * 0.1 + rng.standard_normal(5000)
    >>> res = kalman_innovations([[1.0]], [[1.0]], 0.01, 1.0, y)
    >>> round(float(res.gain[0, 0]), 4), round(float(res.normalized[100:].std()), 1)
    (0.0951, 1.0)
    """
    import control

    from geomfdi.simulation.lti import simulate_lti

    Am = as_matrix(A, "A", square=True)
    n = Am.shape[0]
    Cm = as_matrix(C, "C", cols=n, vector_as="row")
    p = Cm.shape[0]
    Gm = np.eye(n) if G is None else as_matrix(G, "G", rows=n, vector_as="column")
    Qm = np.atleast_2d(as_real_array(Q, "Q")) * (np.eye(Gm.shape[1]) if np.ndim(Q) == 0 else 1)
    Rm = np.atleast_2d(as_real_array(R, "R")) * (np.eye(p) if np.ndim(R) == 0 else 1)
    if Qm.shape != (Gm.shape[1],) * 2 or Rm.shape != (p, p):
        raise ShapeError("Q, R: covariances of the sizes of G's columns and of y", argument="Q")
    try:
        L, P, _ = control.dlqe(Am, Gm, Cm, Qm, Rm)
    except Exception as exc:  # python-control raises several types for a bad model
        raise GeomFDIError(f"A: no steady-state Kalman filter ({exc})", argument="A") from exc
    P = np.asarray(P)
    S = Cm @ P @ Cm.T + Rm
    S = (S + S.T) / 2.0
    K = np.linalg.solve(S, Cm @ P).T
    Y = as_real_array(y, "y")
    if Y.ndim == 1 and p == 1:
        Y = Y[:, None]
    if Y.ndim not in (2, 3) or Y.shape[-1] != p:
        raise ShapeError(f"y: expected (N, {p}) or (R, N, {p}), got {Y.shape}", argument="y")
    # y -> nu is LTI: x_pred(k+1) = A (I - K C) x_pred(k) + A K y(k), nu = y - C x_pred
    Af = Am @ (np.eye(n) - K @ Cm)
    Bf = Am @ K
    u = np.moveaxis(Y, -1, -2)  # (..., p, N)
    N = Y.shape[-2]
    x_start = None if x0 is None else Am @ as_vector(x0, "x0", length=n)
    _, nu = simulate_lti(Af, Bf, -Cm, np.eye(p), u, np.arange(N, dtype=float), x0=x_start, dt=1.0)
    nu = np.moveaxis(nu, -2, -1)
    w, V = np.linalg.eigh(S)
    S_isqrt = (V / np.sqrt(w)) @ V.T
    return KalmanInnovations(nu, nu @ S_isqrt, K, np.asarray(L), S)
