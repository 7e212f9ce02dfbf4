"""Streaming monitoring, one sample at a time (:func:`update`), with rank-1 updates.

See the user guide, *Theory: AR monitoring* (``docs/theory/ar-monitoring.md``).
"""

from __future__ import annotations

import math
import numbers
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from geomfdi.errors import ComplexInputError, GeomFDIError
from geomfdi.monitoring._kernels import _RISK, _dense_gram, _gram, _singular
from geomfdi.monitoring._records import ARNull, ARSettings
from geomfdi.monitoring.results import ARMonitorWarning, ARStep
from geomfdi.tolerance import get_rtol

__all__ = ["ARStreamState", "as_sample", "reset", "update"]


@dataclass(eq=False)
class ARStreamState:
    """The window of a stream: a ring buffer of the last ``window`` samples, the normal
    equations ``A phi = b`` kept by rank-1 updates, and the counters of the reset
    strategy (changed in place by :func:`update`)."""

    ring: np.ndarray
    head: int  # next write position
    fill: int  # samples in the window (<= m)
    nbad: int
    dirty: bool
    since_refit: int
    removed: float
    counter: int
    epoch: int
    was_singular: bool
    lags: np.ndarray
    rtol: float
    nan_phi: np.ndarray
    A: np.ndarray
    b: np.ndarray


def reset(cfg: ARSettings, null: ARNull) -> ARStreamState:
    """A new stream: empty window (or the stored normal data if ``prefill``)."""
    m, n = cfg.window, cfg.order
    nan_phi = np.full(n, np.nan)
    nan_phi.flags.writeable = False
    st = ARStreamState(
        ring=np.zeros(m + 1),
        head=0,
        fill=0,
        nbad=0,
        dirty=True,
        since_refit=0,
        removed=0.0,
        counter=0,
        epoch=0,
        was_singular=False,
        lags=np.arange(n + 1),
        rtol=get_rtol(n),
        nan_phi=nan_phi,
        A=np.zeros((n, n)),
        b=np.zeros(n),
    )
    if cfg.prefill:
        _load(st, m, null.normal)
    return st


def _load(st: ARStreamState, m: int, samples: np.ndarray) -> None:
    st.ring[:] = 0.0
    st.ring[: m - 1] = samples
    st.head = m - 1
    st.fill = m - 1
    st.nbad = int(np.count_nonzero(~np.isfinite(samples)))
    st.dirty = True


def _window(st: ARStreamState, m: int) -> np.ndarray:
    R = m + 1
    return st.ring[(st.head - st.fill + np.arange(st.fill)) % R]


def as_sample(x: Any) -> float:
    """One real number as a float (non-finite values are accepted)."""
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
    return v


def update(
    cfg: ARSettings, null: ARNull, st: ARStreamState, v: float
) -> tuple[float, bool, ARStep]:
    """Process one sample ``v`` (see :func:`as_sample`); return ``(statistic, alarm, step)``.

    ``statistic`` is NaN when no statistic exists (warm-up, non-finite sample in the
    window, rank-deficient regressors); the full outcome is ``step`` (:class:`ARStep`).
    A non-finite ``v`` is accepted and reported with an :class:`ARMonitorWarning`.
    ``st`` is advanced in place.
    """
    m, n = cfg.window, cfg.order
    R = m + 1
    was_full = st.fill == m
    st.ring[st.head] = v
    st.head = (st.head + 1) % R
    if was_full:
        dropped = st.ring[st.head]  # X_{t-m}, just left the window
        st.nbad -= 0 if math.isfinite(dropped) else 1
    else:
        st.fill += 1
    if not math.isfinite(v):
        st.nbad += 1
        warnings.warn(
            f"x: non-finite sample {v} at epoch {st.epoch}; the statistics of the next "
            f"{m} epochs are invalid",
            ARMonitorWarning,
            stacklevel=2,
        )
    phi = st.nan_phi
    nonfinite = singular = False
    if st.fill < m:
        st.dirty = True
    elif st.nbad > 0:
        nonfinite = True
        st.dirty = True
    else:
        if st.dirty or st.since_refit >= cfg.refit_every:
            st.A, st.b = _gram(_window(st, m), n)
            st.dirty = False
            st.since_refit = 0
            st.removed = 0.0
        else:
            new = st.ring[(st.head - 1 - st.lags) % R]  # X_t .. X_{t-n}
            old = st.ring[(st.head + st.lags) % R]  # X_{t-m} .. X_{t-m+n}
            r_new, y_new = new[1:], new[0]
            r_old, y_old = old[n - 1 :: -1], old[n]
            st.A += r_new[:, None] * r_new - r_old[:, None] * r_old
            st.b += r_new * y_new - r_old * y_old
            st.since_refit += 1
            st.removed += y_old * y_old + r_old @ r_old
            if st.removed > _RISK * st.A.trace():
                # rows much larger than the window were removed: refit exactly
                st.A, st.b = _gram(_window(st, m), n)
                st.since_refit = 0
                st.removed = 0.0
        A = st.A
        d = A.diagonal()
        # cheap Gershgorin certificate first; the full rank decision otherwise
        if (2.0 * d - np.abs(A).sum(axis=1)).min() > st.rtol * d.sum():
            singular = False
        else:
            singular = bool(_singular(_dense_gram(A[..., None], A[:, :1])[0], n)[0])
        if not singular:
            phi = np.linalg.solve(A, st.b)
    valid = not (nonfinite or singular or st.fill < m)
    lam = float(((phi[cfg.coefficient] - null.mu) / null.delta) ** 2) if valid else math.nan
    alarm = bool(valid and lam > cfg.threshold)
    if singular and not st.was_singular:
        warnings.warn(
            f"x: window ending at epoch {st.epoch} has rank-deficient regressors; "
            "no statistic until it has full rank again",
            ARMonitorWarning,
            stacklevel=2,
        )
    st.was_singular = singular
    restarted = False
    st.counter = st.counter + 1 if alarm else 0
    if cfg.reset_after is not None and st.counter >= cfg.reset_after:
        r = cfg.reset_keep
        w = _window(st, m)
        kept = w[w.size - r :] if r else w[:0]
        _load(st, m, np.concatenate([null.normal[r:], kept]))
        st.counter = 0
        restarted = True
    step = ARStep(
        epoch=st.epoch,
        statistic=lam,
        alarm=alarm,
        valid=valid,
        coefficients=phi,
        restarted=restarted,
        nonfinite=nonfinite,
        singular=singular,
    )
    st.epoch += 1
    return lam, alarm, step
