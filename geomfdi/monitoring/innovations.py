"""Synthetic GPS pseudorange innovations for the AR-model monitor (Jin, Ding & Cong).

Innovations of a well-tuned navigation filter are zero-mean Gaussian; the seed paper
uses a pseudorange noise standard deviation ``sigma = 6 m`` and injects faults of
``5 sigma``.  :func:`synthetic_innovations` draws such sequences, white or coloured by
a stationary AR filter, and adds a step or ramp fault of a chosen size (in units of
``sigma``) from a chosen epoch; :func:`innovation_fault` returns the fault profile
alone.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi._validation import as_int, as_positive, as_real_array, as_seed
from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.limits import check_allocation

__all__ = ["synthetic_innovations", "innovation_fault"]

_FAULT_KINDS = ("none", "step", "ramp")


def _as_ar(ar: Any) -> np.ndarray:
    if ar is None:
        return np.zeros(0)
    a = as_real_array(ar, "ar")
    if a.ndim == 0:
        a = a.reshape(1)
    if a.ndim != 1:
        raise ShapeError(
            f"ar: must be a vector of AR coefficients, got shape {a.shape}", argument="ar"
        )
    if a.size:
        # e_t = sum_k a_k e_{t-k} + w_t is stationary iff the companion matrix is stable
        F = np.zeros((a.size, a.size))
        F[0, :] = a
        F[1:, :-1] = np.eye(a.size - 1)
        rho = float(np.max(np.abs(np.linalg.eigvals(F))))
        if rho >= 1.0 - 1e-9:
            raise GeomFDIError(
                f"ar: the AR filter must be stationary (all roots inside the unit circle), "
                f"got spectral radius {rho:.6g}",
                argument="ar",
            )
    return a


def _stationary_state_cov(a: np.ndarray) -> np.ndarray:
    """Covariance of (e_{t-1}, ..., e_{t-p}) for unit driving noise (discrete Lyapunov)."""
    from scipy.linalg import solve_discrete_lyapunov

    p = a.size
    F = np.zeros((p, p))
    F[0, :] = a
    F[1:, :-1] = np.eye(p - 1)
    Q = np.zeros((p, p))
    Q[0, 0] = 1.0
    P = solve_discrete_lyapunov(F, Q)
    return 0.5 * (P + P.T)


def innovation_fault(
    n_samples: int,
    *,
    kind: str = "step",
    size: float = 5.0,
    start: int = 0,
    stop: int | None = None,
    sigma: float = 6.0,
) -> np.ndarray:
    """Additive fault profile on an innovation sequence.

    Parameters
    ----------
    n_samples : int
        Length of the sequence.
    kind : {"step", "ramp", "none"}
        ``"step"``: constant ``size * sigma`` on ``start <= t < stop``.  ``"ramp"``:
        grows linearly on ``start <= t < stop`` and reaches ``size * sigma`` at the last
        faulty sample, ``f_t = size * sigma * (t - start + 1) / (stop - start)``.
        ``"none"``: zeros.
    size : float
        Fault magnitude in units of ``sigma`` (the seed paper uses 5).  May be negative.
    start : int
        First faulty epoch (0-based).
    stop : int, optional
        One past the last faulty epoch (default: end of the sequence).
    sigma : float
        Innovation standard deviation in metres (default 6 m, Jin, Ding & Cong).

    Returns
    -------
    ndarray, shape (n_samples,)
        The fault in metres.
    """
    n = as_int(n_samples, "n_samples", minimum=1)
    check_allocation(n, argument="n_samples", what="innovation_fault")
    if not isinstance(kind, str) or kind not in _FAULT_KINDS:
        raise GeomFDIError(f"kind: must be one of {_FAULT_KINDS}, got {kind!r}", argument="kind")
    sigma = as_positive(sigma, "sigma")
    size_arr = as_real_array(size, "size")
    if size_arr.ndim != 0:
        raise ShapeError(f"size: must be a scalar, got shape {size_arr.shape}", argument="size")
    size_v = float(size_arr)
    start = as_int(start, "start", minimum=0)
    stop = n if stop is None else as_int(stop, "stop", minimum=0)
    if stop > n:
        raise GeomFDIError(f"stop: must be <= n_samples = {n}, got {stop}", argument="stop")
    f = np.zeros(n)
    if kind == "none":
        return f
    if start >= stop:
        raise GeomFDIError(
            f"start: the fault interval [start, stop) = [{start}, {stop}) is empty",
            argument="start",
        )
    if kind == "step":
        f[start:stop] = size_v * sigma
    else:
        f[start:stop] = size_v * sigma * np.arange(1, stop - start + 1) / (stop - start)
    return f


def synthetic_innovations(
    n_samples: int,
    *,
    sigma: float = 6.0,
    ar: Any = None,
    fault: str = "none",
    size: float = 5.0,
    start: int = 0,
    stop: int | None = None,
    n_series: int | None = None,
    rng: int | np.random.Generator | None = None,
) -> np.ndarray:
    """Gaussian pseudorange innovations, white or AR-coloured, with an optional fault.

    The fault-free part is a zero-mean stationary Gaussian process ``e_t`` with standard
    deviation ``sigma``: white noise, or the AR process
    ``e_t = sum_k ar[k-1] e_{t-k} + w_t`` with the driving-noise variance scaled so that
    ``var(e_t) = sigma**2`` and the initial state drawn from the stationary distribution
    (no burn-in transient).  A fault from :func:`innovation_fault` is added to it.

    Parameters
    ----------
    n_samples : int
        Samples per series (one per second in the seed paper).
    sigma : float
        Standard deviation of the fault-free innovations, metres (default 6 m).
    ar : array_like, optional
        AR coefficients ``(a_1, ..., a_p)`` of the colouring filter; must be stationary.
        ``None`` (default): white innovations.
    fault : {"none", "step", "ramp"}
        Fault kind (see :func:`innovation_fault`).
    size : float
        Fault size in units of ``sigma`` (default 5, as in the paper).
    start, stop : int
        Faulty epochs ``start <= t < stop`` (``stop`` defaults to the end).
    n_series : int, optional
        Draw this many independent series, returned as rows of an
        ``(n_series, n_samples)`` array (the same fault in each).  ``None``: one 1-D
        series.
    rng : int or numpy.random.Generator, optional
        Seed or generator.

    Returns
    -------
    ndarray, shape (n_samples,) or (n_series, n_samples)
        Innovations in metres.

    Notes
    -----
    The stationary state covariance of the AR filter is the solution of the discrete
    Lyapunov equation ``P = F P F^T + e_1 e_1^T`` of its companion matrix ``F``.

    References
    ----------
    Jin, Ding & Cong: GPS pseudorange innovations, ``sigma = 6 m``, faults of
    ``5 sigma`` in the last 2, 10 or 30 samples of 60-sample windows, or from 61 s on.

    Examples
    --------
    >>> import geomfdi as gf
    >>> x = gf.synthetic_innovations(60, fault="step", start=50, rng=1)
    >>> x.shape
    (60,)
    """
    n = as_int(n_samples, "n_samples", minimum=1)
    batch = 1 if n_series is None else as_int(n_series, "n_series", minimum=1)
    check_allocation(
        n, batch, argument="n_samples", runs_argument="n_series", what="synthetic_innovations"
    )
    if not isinstance(fault, str) or fault not in _FAULT_KINDS:
        raise GeomFDIError(
            f"fault: must be one of {_FAULT_KINDS}, got {fault!r:.40}", argument="fault"
        )
    if not isinstance(rng, np.random.Generator):
        rng = as_seed(rng, "rng")
    sigma = as_positive(sigma, "sigma")
    a = _as_ar(ar)
    f = innovation_fault(n, kind=fault, size=size, start=start, stop=stop, sigma=sigma)
    batch = 1 if n_series is None else as_int(n_series, "n_series", minimum=1)
    gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    w = gen.standard_normal((batch, n))
    if a.size:
        from scipy.signal import lfilter

        P = _stationary_state_cov(a)  # state cov for unit driving noise; var(e) = P[0, 0]
        L = np.linalg.cholesky(P)
        past = gen.standard_normal((batch, a.size)) @ L.T  # (e_{-1}, ..., e_{-p})
        # initial conditions of lfilter (direct form II transposed, b = [1]):
        # zi[m] = sum_{i=m+1}^{p} a_i e_{-(i-m)}
        p = a.size
        zi = np.zeros((batch, p))
        for m in range(p):
            for i in range(m + 1, p + 1):
                zi[:, m] += a[i - 1] * past[:, i - m - 1]
        e = lfilter([1.0], np.concatenate(([1.0], -a)), w, axis=1, zi=zi)[0]
        e *= sigma / np.sqrt(P[0, 0])
    else:
        e = sigma * w
    out = e + f
    return out[0] if n_series is None else out
