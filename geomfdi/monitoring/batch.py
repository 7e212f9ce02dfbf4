"""Batch monitoring of whole streams (:func:`run`), with the reset strategy.

See the user guide, *Theory: AR monitoring* (``docs/theory/ar-monitoring.md``).
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from geomfdi._validation import as_real_array
from geomfdi.errors import ShapeError
from geomfdi.monitoring._kernels import _normal_equations, _run_lengths, _solve
from geomfdi.monitoring._records import ARNull, ARSettings
from geomfdi.monitoring.results import ARMonitorResult, ARMonitorWarning

__all__ = ["run"]

#: Largest number of epochs computed in one vectorised pass (bounds memory).
_CHUNK_MAX = 1 << 16


def _as_stream(value: Any, name: str) -> np.ndarray:
    """Real float array of 1 or 2 dimensions; non-finite entries are allowed (reported)."""
    arr = as_real_array(value, name, allow_nonfinite=True)
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim not in (1, 2) or arr.shape[-1] == 0:
        raise ShapeError(
            f"{name}: expected a 1-D stream or a 2-D array of streams (rows), got shape "
            f"{arr.shape}",
            argument=name,
        )
    return arr


# --------------------------------------------------------------------------------------
# results
# --------------------------------------------------------------------------------------


def run(cfg: ARSettings, null: ARNull, stream: Any) -> ARMonitorResult:
    """Monitor a whole stream (or a batch of streams) from a fresh state.

    Parameters
    ----------
    cfg : ARSettings
        Settings of the monitor.
    null : ARNull
        Its learnt ``mu``, ``delta`` and stored normal innovations.
    stream : array_like, (L,) or (B, L)
        Innovations; non-finite samples are allowed and reported (see Notes of
        :class:`ARMonitor`).  Rows of a 2-D array are independent streams.

    Returns
    -------
    ARMonitorResult
        Equal, to rounding, to feeding the samples one by one to :meth:`update`
        after :meth:`reset`.

    Notes
    -----
    Without the reset strategy all epochs are computed in vectorised passes of up to
    65536 epochs (rows of a batch together).  With it, the stream is processed in
    vectorised chunks that start small after each restart and double while no
    restart occurs; only the restart decisions are sequential.
    """
    x = _as_stream(stream, "stream")
    one = x.ndim == 1
    X = x[None, :] if one else x
    B, L = X.shape
    n = cfg.order
    stat = np.full((B, L), np.nan)
    phi = np.full((B, L, n), np.nan)
    valid = np.zeros((B, L), dtype=bool)
    nonfin = np.zeros((B, L), dtype=bool)
    sing = np.zeros((B, L), dtype=bool)
    restarted = np.zeros((B, L), dtype=bool)
    outs = (stat, phi, valid, nonfin, sing, restarted)
    if cfg.reset_after is None:
        _run_rows(cfg, null, X, outs, slice(None))
    else:
        for i in range(B):
            _run_rows(cfg, null, X[i : i + 1], outs, slice(i, i + 1))
    alarm = valid & (np.where(valid, stat, 0.0) > cfg.threshold)
    bad_in = ~np.isfinite(X)
    if np.any(bad_in) or np.any(sing):
        msg = []
        if np.any(bad_in):
            first = np.argwhere(bad_in)[0]
            msg.append(
                f"{int(bad_in.sum())} non-finite sample(s) (first at index "
                f"{tuple(int(i) for i in first) if not one else int(first[1])}) "
                f"invalidate {int(nonfin.sum())} statistic(s) (see .nonfinite)"
            )
        if np.any(sing):
            msg.append(
                f"{int(sing.sum())} window(s) with rank-deficient regressors (see .singular)"
            )
        warnings.warn("stream: " + "; ".join(msg), ARMonitorWarning, stacklevel=2)
    if one:
        stat, phi, valid, nonfin, sing, restarted, alarm = (
            a[0] for a in (stat, phi, valid, nonfin, sing, restarted, alarm)
        )
    return ARMonitorResult(
        statistic=stat,
        alarm=alarm,
        valid=valid,
        coefficients=phi,
        restarted=restarted,
        nonfinite=nonfin,
        singular=sing,
        threshold=cfg.threshold,
        info={
            "mu": null.mu,
            "delta": null.delta,
            "order": n,
            "window": cfg.window,
            "coefficient": cfg.coefficient,
            "pfa": cfg.pfa,
            "reset_after": cfg.reset_after,
            "reset_keep": cfg.reset_keep,
            "prefill": cfg.prefill,
            "restarts": int(restarted.sum()),
        },
    )


def _segment(
    cfg: ARSettings, hist: np.ndarray, xs: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """Coefficients for the epochs of ``xs`` given the ``hist`` samples before them.

    Returns ``phi (B, c', n)``, ``nonfinite``, ``singular`` (B, c') for the epochs
    ``c - c' .. c - 1`` of the segment whose window is full, and ``c - c'``.
    """
    m, n = cfg.window, cfg.order
    z = np.concatenate([hist, xs], axis=-1)
    h, c = hist.shape[-1], xs.shape[-1]
    first = max(m - 1 - h, 0)
    if h + c < m:
        empty = np.zeros((xs.shape[0], 0))
        return np.zeros((*empty.shape, n)), empty.astype(bool), empty.astype(bool), c
    gram, bad = _normal_equations(z, n, m)
    phi, sing = _solve(gram, n, skip=bad)
    return phi, bad, sing, first


def _run_rows(cfg: ARSettings, null: ARNull, X: np.ndarray, outs: tuple, rows: slice) -> None:
    stat, phi_o, valid, nonfin, sing_o, restarted = outs
    m, k, r = cfg.window, cfg.reset_after, cfg.reset_keep
    B, L = X.shape
    normal = np.broadcast_to(null.normal, (B, m - 1))
    hist = normal.copy() if cfg.prefill else np.zeros((B, 0))
    c_min = max(4 * (k or 1), 64)
    size = max(_CHUNK_MAX // B, 4 * m) if k is None else c_min  # bounds the memory
    counter = 0
    t = 0
    while t < L:
        c = min(size, L - t)
        xs = X[:, t : t + c]
        phi, bad, sing, first = _segment(cfg, hist, xs)
        lam = null.statistic(phi, cfg.coefficient)
        ok = ~bad & ~sing
        alarm = ok & (np.where(ok, lam, 0.0) > cfg.threshold)
        hit = None
        if k is not None:
            full_alarm = np.zeros(c, dtype=bool)
            full_alarm[first:] = alarm[0]
            runs = _run_lengths(full_alarm, counter)
            hits = np.flatnonzero(runs >= k)
            if hits.size:
                hit = int(hits[0])
            else:
                counter = int(runs[-1])
        used = c if hit is None else hit + 1
        nf = max(used - first, 0)
        sl = slice(t + first, t + used)
        stat[rows, sl] = np.where(ok, lam, np.nan)[:, :nf]
        phi_o[rows, sl] = phi[:, :nf]
        valid[rows, sl] = ok[:, :nf]
        nonfin[rows, sl] = bad[:, :nf]
        sing_o[rows, sl] = sing[:, :nf]
        z = np.concatenate([hist, xs[:, :used]], axis=-1)
        if hit is None:
            hist = z[:, -(m - 1) :]
            size = min(2 * size, max(_CHUNK_MAX // B, 4 * m))
        else:
            restarted[rows, t + hit] = True
            kept = z[:, z.shape[1] - r :] if r else z[:, :0]
            hist = np.concatenate([normal[:, r:], kept], axis=-1)
            counter = 0
            size = c_min
        t += used
