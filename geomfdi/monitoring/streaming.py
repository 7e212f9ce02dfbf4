"""Streaming monitoring, one sample at a time (:func:`update`), with rank-1 updates.

See the user guide, *Theory: AR monitoring* (``docs/theory/ar-monitoring.md``).
"""

from __future__ import annotations

import math
import numbers
import warnings
from typing import TYPE_CHECKING

import numpy as np

from geomfdi.errors import ComplexInputError, GeomFDIError
from geomfdi.monitoring._kernels import _RISK, _dense_gram, _gram, _singular
from geomfdi.monitoring.results import ARMonitorWarning, ARStep
from geomfdi.tolerance import get_rtol

if TYPE_CHECKING:
    from geomfdi.monitoring.monitor import ARMonitor

__all__ = ["reset", "update"]


def reset(mon: ARMonitor) -> None:
    """Start a new stream: empty window (or the stored normal data if ``prefill``)."""
    mon._require_fit()
    m, n = mon.window, mon.order
    mon._ring = np.zeros(m + 1)
    mon._head = 0  # next write position
    mon._fill = 0  # samples in the window (<= m)
    mon._nbad = 0
    mon._dirty = True
    mon._since_refit = 0
    mon._removed = 0.0
    mon._counter = 0
    mon._epoch = 0
    mon._was_singular = False
    mon._lags = np.arange(n + 1)
    mon._rtol = get_rtol(n)
    mon._nan_phi = np.full(n, np.nan)
    mon._nan_phi.flags.writeable = False
    mon._A = np.zeros((n, n))
    mon._b = np.zeros(n)
    mon.last = None
    if mon.prefill:
        _load(mon, mon.normal)
    mon._state_ready = True


def _load(mon: ARMonitor, samples: np.ndarray) -> None:
    m = mon.window
    mon._ring[:] = 0.0
    mon._ring[: m - 1] = samples
    mon._head = m - 1
    mon._fill = m - 1
    mon._nbad = int(np.count_nonzero(~np.isfinite(samples)))
    mon._dirty = True


def _window(mon: ARMonitor) -> np.ndarray:
    R = mon.window + 1
    return mon._ring[(mon._head - mon._fill + np.arange(mon._fill)) % R]


def update(mon: ARMonitor, x: float) -> tuple[float, bool]:
    """Process one sample; return ``(statistic, alarm)``.

    ``statistic`` is NaN when no statistic exists (warm-up, non-finite sample in the
    window, rank-deficient regressors); the full outcome is in :attr:`last`
    (:class:`ARStep`).  A non-finite ``x`` is accepted and reported with an
    :class:`ARMonitorWarning`.  The first call after :meth:`fit` or
    :meth:`set_normal` starts a new stream (as :meth:`reset`).
    """
    if isinstance(x, bool | np.bool_) or not isinstance(x, numbers.Real | np.floating):
        try:
            arr = np.asarray(x)
        except (TypeError, ValueError, OverflowError) as exc:
            raise GeomFDIError(f"x: must be one real number, got {x!r:.40}", argument="x") from exc
        if np.iscomplexobj(arr):
            raise ComplexInputError(f"x: must be real, got {x!r}", argument="x")
        if arr.shape not in ((), (1,)) or arr.dtype.kind not in "iuf":
            raise GeomFDIError(f"x: must be one real number, got {x!r}", argument="x")
        x = arr.reshape(-1)[0]
    try:
        v = float(x)
    except OverflowError as exc:
        raise GeomFDIError("x: a number too large for float64", argument="x") from exc
    if not mon._state_ready:
        mon.reset()
    m, n = mon.window, mon.order
    R = m + 1
    was_full = mon._fill == m
    mon._ring[mon._head] = v
    mon._head = (mon._head + 1) % R
    if was_full:
        dropped = mon._ring[mon._head]  # X_{t-m}, just left the window
        mon._nbad -= 0 if math.isfinite(dropped) else 1
    else:
        mon._fill += 1
    if not math.isfinite(v):
        mon._nbad += 1
        warnings.warn(
            f"x: non-finite sample {v} at epoch {mon._epoch}; the statistics of the next "
            f"{m} epochs are invalid",
            ARMonitorWarning,
            stacklevel=2,
        )
    phi = mon._nan_phi
    nonfinite = singular = False
    if mon._fill < m:
        mon._dirty = True
    elif mon._nbad > 0:
        nonfinite = True
        mon._dirty = True
    else:
        if mon._dirty or mon._since_refit >= mon.refit_every:
            mon._A, mon._b = _gram(_window(mon), n)
            mon._dirty = False
            mon._since_refit = 0
            mon._removed = 0.0
        else:
            new = mon._ring[(mon._head - 1 - mon._lags) % R]  # X_t .. X_{t-n}
            old = mon._ring[(mon._head + mon._lags) % R]  # X_{t-m} .. X_{t-m+n}
            r_new, y_new = new[1:], new[0]
            r_old, y_old = old[n - 1 :: -1], old[n]
            mon._A += r_new[:, None] * r_new - r_old[:, None] * r_old
            mon._b += r_new * y_new - r_old * y_old
            mon._since_refit += 1
            mon._removed += y_old * y_old + r_old @ r_old
            if mon._removed > _RISK * mon._A.trace():
                # rows much larger than the window were removed: refit exactly
                mon._A, mon._b = _gram(_window(mon), n)
                mon._since_refit = 0
                mon._removed = 0.0
        A = mon._A
        d = A.diagonal()
        # cheap Gershgorin certificate first; the full rank decision otherwise
        if (2.0 * d - np.abs(A).sum(axis=1)).min() > mon._rtol * d.sum():
            singular = False
        else:
            singular = bool(_singular(_dense_gram(A[..., None], A[:, :1])[0], n)[0])
        if not singular:
            phi = np.linalg.solve(A, mon._b)
    valid = not (nonfinite or singular or mon._fill < m)
    lam = float(((phi[mon.coefficient] - mon.mu) / mon.delta) ** 2) if valid else math.nan
    alarm = bool(valid and lam > mon.threshold)
    if singular and not mon._was_singular:
        warnings.warn(
            f"x: window ending at epoch {mon._epoch} has rank-deficient regressors; "
            "no statistic until it has full rank again",
            ARMonitorWarning,
            stacklevel=2,
        )
    mon._was_singular = singular
    restarted = False
    mon._counter = mon._counter + 1 if alarm else 0
    if mon.reset_after is not None and mon._counter >= mon.reset_after:
        r = mon.reset_keep
        w = _window(mon)
        kept = w[w.size - r :] if r else w[:0]
        _load(mon, np.concatenate([mon.normal[r:], kept]))
        mon._counter = 0
        restarted = True
    mon.last = ARStep(
        epoch=mon._epoch,
        statistic=lam,
        alarm=alarm,
        valid=valid,
        coefficients=phi,
        restarted=restarted,
        nonfinite=nonfinite,
        singular=singular,
    )
    mon._epoch += 1
    return lam, alarm
