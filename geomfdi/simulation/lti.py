"""Fast exact simulation of LTI state-space systems on a uniform time grid.

A continuous system ``x' = A x + B u`` is discretised exactly for a piecewise-linear
(first-order hold, ``"foh"``) or piecewise-constant (zero-order hold, ``"zoh"``) input,
giving the recursion

    x[k+1] = Ad x[k] + B0 u[k] + B1 u[k+1]          (B1 = 0 for "zoh")

which is then solved **without a per-sample Python loop**: with the Schur form
``Ad = Z T Z^H`` (T upper triangular) the transformed state ``z = Z^H x`` obeys

    z_i[k+1] = T_ii z_i[k] + (Z^H f)_i[k] + sum_{j>i} T_ij z_j[k]

so the states are obtained by back-substitution from ``i = n-1`` down to ``0``; each one
is a first-order linear recursion over the whole time axis, evaluated by one call of the
compiled :func:`scipy.signal.lfilter` (and over many Monte-Carlo runs at once, since
``lfilter`` filters every row of an ``(runs, N)`` array).  The cost is ``O(n^2 N)`` flops
in ``n`` compiled calls.  When ``Ad`` has a well-conditioned eigenvector basis
(condition number <= 100) the modal form ``Ad = V Lambda V^-1`` is used instead: the
scalar recursions are then uncoupled (``O(n N)``), at the price of rounding errors at most
that factor larger; defective or nearly defective matrices keep the unitary Schur form.
For many states :func:`block_recursion` runs the recursion on
the *lifted* system (blocks of ``M`` samples), which moves most of the work from
``lfilter`` samples to matrix products.

The ``"foh"`` discretisation is the one of :func:`control.forced_response` for continuous
systems (linear interpolation of the input between samples, the same block matrix
exponential), so both agree to rounding; a discrete system (``dt > 0``) is simulated as
``x[k+1] = A x[k] + B u[k]`` like :func:`scipy.signal.dlsim`.

Array layout: time is the **last** axis (python-control convention); an optional leading
axis holds Monte-Carlo runs: ``u`` is ``(m, N)`` or ``(runs, m, N)``, ``x`` comes back as
``(n, N)`` or ``(runs, n, N)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi._validation import as_choice, as_matrix, as_positive, as_real_array
from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.simulation.discretization import (
    HOLDS,
    Discretization,
    discrete_form,
    discretize,
    uniform_step,
)
from geomfdi.simulation.lifting import Drive, block_recursion, driven_recursion, linear_recursion
from geomfdi.simulation.recursion import schur_form, triangular_recursion

__all__ = [
    "HOLDS",
    "Discretization",
    "discretize",
    "linear_recursion",
    "driven_recursion",
    "block_recursion",
    "Drive",
    "triangular_recursion",
    "schur_form",
    "simulate_lti",
    "uniform_step",
]


def simulate_lti(
    A: Any,
    B: Any,
    C: Any,
    D: Any,
    u: Any,
    t: Any,
    *,
    x0: Any = None,
    dt: float = 0.0,
    hold: str = "foh",
) -> tuple[np.ndarray, np.ndarray]:
    """Simulate ``x' = A x + B u, y = C x + D u`` (or its discrete form) on a uniform grid.

    Parameters
    ----------
    A, B, C, D : array_like
        State-space matrices, (n, n), (n, m), (p, n), (p, m).
    u : array_like, (m, N) or (R, m, N), or None
        Input samples (``None``: zero input); a 1-D array is read as ``(1, N)``.
    t : array_like, (N,)
        Uniform time grid.
    x0 : array_like, (n,) or (R, n), optional
        Initial state(s), zero by default.
    dt : float
        0: continuous system (discretised exactly with ``hold``); > 0: a discrete system
        with that sampling period, which must equal the grid step.
    hold : {"foh", "zoh"}
        Input interpolation for continuous systems.  ``"foh"`` reproduces
        :func:`control.forced_response`.

    Returns
    -------
    x : ndarray, (n, N) or (R, n, N)
    y : ndarray, (p, N) or (R, p, N)
        With a run axis when ``u`` or ``x0`` has one.

    Examples
    --------
    >>> import numpy as np
    >>> from geomfdi.simulation.lti import simulate_lti
    >>> t = np.linspace(0, 5, 501)
    >>> x, y = simulate_lti([[-1.0]], [[1.0]], [[1.0]], [[0.0]], np.ones((1, 501)), t)
    >>> bool(abs(y[0, -1] - (1 - np.exp(-5))) < 1e-12)
    True
    """
    hold = as_choice(hold, "hold", ("foh", "zoh"))
    A = as_matrix(A, "A", square=True)
    n = A.shape[0]
    B = as_matrix(B, "B", rows=n, allow_empty=True, vector_as="column")
    m = B.shape[1]
    C = as_matrix(C, "C", cols=n, allow_empty=True, vector_as="row")
    p = C.shape[0]
    D = np.zeros((p, m)) if D is None else as_matrix(D, "D", rows=p, cols=m, allow_empty=True)
    t, step = uniform_step(t)
    N = t.size
    batched = False
    if u is None:
        u = np.zeros((1, m, N))
    else:
        u = as_real_array(u, "u")
        if u.ndim == 1:
            u = u[None]
        if u.ndim == 3:
            batched = True
        elif u.ndim == 2:
            u = u[None]
        else:
            raise ShapeError(f"u: expected (m, N) or (R, m, N), got shape {u.shape}", argument="u")
        if u.shape[1:] != (m, N):
            raise ShapeError(
                f"u: expected shape ({m}, {N}) per run, got {u.shape[1:]}", argument="u"
            )
    if x0 is None:
        x0 = np.zeros((1, n))
    else:
        x0 = as_real_array(x0, "x0")
        if x0.ndim == 2:
            batched = True
        elif x0.ndim == 1:
            x0 = x0[None]
        if x0.ndim != 2 or x0.shape[1] != n:
            raise ShapeError(
                f"x0: expected length {n} per run, got shape {x0.shape}", argument="x0"
            )
    dt = as_positive(dt, "dt", strict=False)  # 0: continuous; NaN, inf, < 0 refused
    if dt > 0:
        if abs(step - dt) > 1e-6 * dt:
            raise GeomFDIError(
                f"t: the grid step {step:g} must equal the sampling period dt={dt:g}",
                argument="t",
            )
        dis = discrete_form(A, B, dt)
    else:
        dis = discretize(A, B, step, hold)
    x = linear_recursion(dis.Ad, dis.forcing(u), x0)
    y = C @ x + D @ u
    if not batched:
        return x[0], y[0]
    return x, y
