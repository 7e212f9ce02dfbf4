"""Exact discretisation of a continuous LTI system for a held input (zero- or first-order hold).

``x' = A x + B u`` sampled with step ``dt`` becomes ``x[k+1] = Ad x[k] + B0 u[k] + B1 u[k+1]``
(``B1 = 0`` for a zero-order hold); the first-order hold is the convention of
:func:`control.forced_response`.  Also the check of a uniform time grid.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg

from geomfdi._validation import as_real_array
from geomfdi.errors import GeomFDIError, ShapeError

__all__ = ["HOLDS", "Discretization", "discretize", "discrete_form", "uniform_step"]

HOLDS = ("foh", "zoh")


@dataclass(frozen=True)
class Discretization:
    """Exact sampled form ``x[k+1] = Ad x[k] + B0 u[k] + B1 u[k+1]`` of an LTI system.

    Attributes
    ----------
    Ad : ndarray, (n, n)
    B0, B1 : ndarray, (n, m)
        ``B1`` is zero for a zero-order hold and for discrete-time systems.
    dt : float
        The sampling step.
    hold : str
        ``"foh"``, ``"zoh"`` or ``"discrete"`` (the system was already discrete).
    """

    Ad: np.ndarray
    B0: np.ndarray
    B1: np.ndarray
    dt: float
    hold: str

    def forcing(self, u: np.ndarray) -> np.ndarray:
        """``B0 u[k] + B1 u[k+1]`` for ``k = 0 .. N-2``; ``u`` is ``(..., m, N)``."""
        f = self.B0 @ u[..., :-1]
        if self.hold == "foh":
            f = f + self.B1 @ u[..., 1:]
        return f


def _check_hold(hold: str) -> str:
    if hold not in HOLDS:
        raise GeomFDIError(f"hold: must be one of {HOLDS}, got {hold!r}", argument="hold")
    return hold


def discretize(A: Any, B: Any, dt: float, hold: str = "foh") -> Discretization:
    """Exact discretisation of ``x' = A x + B u`` for a held input.

    Parameters
    ----------
    A : array_like, (n, n)
    B : array_like, (n, m)
        May have zero columns.
    dt : float
        Sampling step (> 0).
    hold : {"foh", "zoh"}
        ``"foh"``: ``u`` linear between samples (the convention of
        :func:`control.forced_response`); ``"zoh"``: ``u`` constant between samples.

    Returns
    -------
    Discretization
        ``Ad = e^{A dt}``; for ``"zoh"`` ``B0 = int_0^dt e^{A s} ds B``, ``B1 = 0``; for
        ``"foh"`` the weights of ``u[k]`` and ``u[k+1]``.

    Notes
    -----
    Both holds use one matrix exponential of a block matrix (Van Loan's method).  For the
    first-order hold, with ``M = [[A dt, B dt, 0], [0, 0, I], [0, 0, 0]]`` and
    ``e^M = [[Ad, G0, G1], ...]``: ``B1 = G1`` and ``B0 = G0 - G1`` (the same formula as
    ``control.forced_response``).
    """
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float).reshape(A.shape[0], -1)
    hold = _check_hold(hold)
    key = (A.shape, B.shape, A.tobytes(), B.tobytes(), float(dt), hold)
    hit = _RECENT.get(key)
    if hit is None:  # the same model on the same grid (repeated simulations): once
        hit = _discretize(A, B, dt, hold)
        for a in (hit.Ad, hit.B0, hit.B1):
            a.setflags(write=False)
        if len(_RECENT) >= 64:
            _RECENT.clear()
        _RECENT[key] = hit
    return hit


_RECENT: dict[tuple, Discretization] = {}


def _discretize(A: np.ndarray, B: np.ndarray, dt: float, hold: str) -> Discretization:
    n, m = B.shape
    if hold == "zoh":
        Mz = np.zeros((n + m, n + m))
        Mz[:n, :n] = A * dt
        Mz[:n, n:] = B * dt
        ez = scipy.linalg.expm(Mz)
        return Discretization(ez[:n, :n], ez[:n, n:], np.zeros((n, m)), float(dt), "zoh")
    Mf = np.block(
        [
            [A * dt, B * dt, np.zeros((n, m))],
            [np.zeros((m, n + m)), np.identity(m)],
            [np.zeros((m, n + 2 * m))],
        ]
    )
    ef = scipy.linalg.expm(Mf)
    Ad = ef[:n, :n]
    B1 = ef[:n, n + m :]
    B0 = ef[:n, n : n + m] - B1
    return Discretization(Ad, B0, B1, float(dt), "foh")


def discrete_form(A: np.ndarray, B: np.ndarray, dt: float) -> Discretization:
    return Discretization(A, B, np.zeros_like(B), float(dt), "discrete")


def uniform_step(t: Any, name: str = "t") -> tuple[np.ndarray, float]:
    """Validate a uniform, increasing time grid; return it and its step.

    The step is ``(t[-1] - t[0]) / (N - 1)``; every difference must match it to a relative
    ``1e-6`` (python-control accepts ``np.allclose``).
    """
    t = as_real_array(t, name)
    if t.ndim != 1:
        raise ShapeError(f"{name}: must be a 1-D time vector, got shape {t.shape}", argument=name)
    if t.size < 2:
        raise ShapeError(f"{name}: needs at least 2 samples, got {t.size}", argument=name)
    step = (t[-1] - t[0]) / (t.size - 1)
    if not step > 0:
        raise GeomFDIError(f"{name}: must be increasing", argument=name)
    dt = np.diff(t)
    if max(float(dt.max()) - step, step - float(dt.min())) > 1e-6 * step:
        raise GeomFDIError(f"{name}: time values must be equally spaced", argument=name)
    return t, float(step)
