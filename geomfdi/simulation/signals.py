"""Sensor fault signals for simulation: gain, bias and stuck faults.

The sensor fault model of Hou, Wen & Chen (2011) (eq. 3-5) for the reading of sensor ``i``::

    y_i(t) = eta_i(t) * y_i0(t) + lambda_i(t)

with ``y_i0`` the healthy reading.  A **gain** fault has ``eta != 1`` (abrupt when a
number, time-varying when a function of t), optionally with a bias; a **bias** fault has
``eta = 1, lambda != 0``; a **stuck** sensor has ``eta = 0`` and ``lambda`` the held value
(the paper sets stuck faults aside; they are simulated here).  Every one of them is an
*additive* fault ``phi_i = (eta_i - 1) y_i0 + lambda_i`` on the measured y: the residual
generators never see ``eta`` or ``lambda``, only the measured y (see the user guide,
*Theory: sensor-fault transforms*, ``docs/theory/sensor-fault-transforms.md``, and
*Theory: errata*, ``docs/theory/errata.md``).

Timing: a fault is active on the samples with ``start <= t < end`` (``end=None``: to the
end of the run); sample times are compared with a tolerance of ``1e-9 * max(1, |time|)``
so that a grid point computed as ``8000 * 0.001`` counts as 8.

Several faults may act at once, on different sensors or on the same one; faults on one
sensor compose in list order: with two faults ``y = eta_2 (eta_1 y0 + lambda_1) +
lambda_2``.  A stuck fault with ``value=None`` holds its *input* reading (the healthy
reading passed through the faults listed before it) at its first active sample.

Arrays: time is the last axis, ``y0`` is ``(q, N)`` or ``(runs, q, N)`` (the layout of
:func:`geomfdi.simulate`'s results).
"""

from __future__ import annotations

import numbers
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from geomfdi._validation import as_float, as_index, as_real_array, check_finite
from geomfdi.errors import GeomFDIError, ShapeError

__all__ = [
    "FaultSignal",
    "SensorFaultSignal",
    "GainFault",
    "BiasFault",
    "StuckFault",
    "apply_faults",
    "fault_profile",
    "first_active",
    "activity_span",
    "FaultProfile",
]

Value = float | Callable[[np.ndarray], Any]


def _time_tol(time: float) -> float:
    return 1e-9 * max(1.0, abs(time))


def _check_time(value: Any, name: str, *, allow_none: bool = False) -> float | None:
    if value is None and allow_none:
        return None
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise GeomFDIError(f"{name}: must be a real number (seconds), got {value!r}", argument=name)
    return as_float(value, name)


def _check_value(value: Any, name: str) -> Value:
    if callable(value):
        return value
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise GeomFDIError(
            f"{name}: must be a number or a callable t -> value, got {value!r}", argument=name
        )
    return as_float(value, name)


def _evaluate(value: Value, t: np.ndarray, name: str) -> np.ndarray:
    """A number or a vectorised callable evaluated on the time array ``t``."""
    if not callable(value):
        return np.full(t.shape, float(value))
    try:
        out = value(t)
    except Exception as exc:
        raise GeomFDIError(
            f"{name}: calling it on a time array failed ({type(exc).__name__}: {exc}); "
            "the function must accept a numpy array of times",
            argument=name,
        ) from exc
    out = as_real_array(out, name)
    if out.ndim == 0:
        return np.full(t.shape, float(out))
    if out.shape != t.shape:
        raise ShapeError(
            f"{name}: returned shape {out.shape} for {t.shape[0]} sample times; it must be "
            "vectorised over t",
            argument=name,
        )
    check_finite(out, name)
    return out


class FaultSignal:
    """Base class of every simulated fault signal: an activity window ``start <= t < end``.

    Attributes
    ----------
    start, end : float
        Active for ``start <= t < end`` (``end`` may be ``None``: never ends).
    """

    start: float
    end: float | None
    kind: str = "fault"

    def _init_window(self, start: Any, end: Any) -> None:
        self.start = _check_time(start, "start")
        self.end = _check_time(end, "end", allow_none=True)
        if self.end is not None and self.end <= self.start:
            raise GeomFDIError(
                f"end: must be after start ({self.start}), got {self.end}", argument="end"
            )

    def mask(self, t: np.ndarray) -> np.ndarray:
        """Boolean mask of the samples where the fault is active."""
        t = np.asarray(t, dtype=float)
        m = t >= self.start - _time_tol(self.start)
        if self.end is not None:
            m &= t < self.end - _time_tol(self.end)
        return m

    def label(self) -> str:
        """Short human-readable description."""
        raise NotImplementedError

    def _until(self) -> str:
        end = "" if self.end is None else f" until t={self.end:g}"
        return f"from t={self.start:g}{end}"


def _check_channel(value: Any, name: str) -> Any:
    if isinstance(value, str) and value.strip():  # an output name, resolved with the plant
        return value.strip()
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 0:
        raise GeomFDIError(f"{name}: must be an integer >= 0, got {value!r}", argument=name)
    return int(value)


class SensorFaultSignal(FaultSignal):
    """Base class of the sensor fault signals (not used directly).

    Attributes
    ----------
    sensor : int or str
        Output index (0-based), or the plant's output name (resolved by
        :func:`geomfdi.simulate` with the plant: :mod:`geomfdi.simulation.physical`).
    start, end : float
        Active for ``start <= t < end`` (``end`` may be ``None``: never ends).
    """

    sensor: int

    def _init_common(self, sensor: Any, start: Any, end: Any) -> None:
        self.sensor = _check_channel(sensor, "sensor")
        self._init_window(start, end)

    # ------------------------------------------------------------ interface
    @property
    def time_varying_gain(self) -> bool:
        """True when ``eta`` changes while the fault is active (a callable gain)."""
        return False

    def gain_values(self, t: np.ndarray) -> np.ndarray:
        """``eta(t)`` while active (evaluated on ``t``)."""
        raise NotImplementedError

    def bias_values(self, t: np.ndarray) -> np.ndarray:
        """``lambda(t)`` while active (stuck faults with ``value=None`` use the hold)."""
        raise NotImplementedError

    @property
    def holds_reading(self) -> bool:
        """True for a stuck fault that holds the reading at its start."""
        return False

    def apply(self, t: Any, y0: Any) -> np.ndarray:
        """The faulty readings: this fault applied to the healthy readings ``y0``.

        Parameters
        ----------
        t : array_like, (N,)
        y0 : array_like, (q, N) or (runs, q, N)

        Returns
        -------
        ndarray, same shape as ``y0``
        """
        return apply_faults([self], t, y0)

    def _window(self) -> str:
        return f"sensor {self.sensor} {self._until()}"


def _describe(value: Value) -> str:
    if callable(value):
        return getattr(value, "__name__", "f(t)") + "(t)"
    return f"{value:g}"


class GainFault(SensorFaultSignal):
    """Gain fault ``y_i = eta(t) y_i0 + lambda(t)`` on sensor ``sensor`` from ``start``.

    Every argument after ``sensor`` is keyword-only (``GainFault(0, start=8, gain=1.5)``):
    a positional ``GainFault(0, 1.5, 5.0)`` would silently swap onset and gain.

    Parameters
    ----------
    sensor : int
        Output index (0-based).
    start : float
        Onset time (seconds).
    gain : float or callable
        ``eta``: a number (abrupt change) or a function of time, vectorised over a numpy
        array of times (time-varying gain, e.g. ``lambda t: 1 + 0.1 * (t - 5)``).
    bias : float or callable, default 0
        ``lambda`` added while the fault is active.
    end : float, optional
        The fault disappears at ``end``.

    Notes
    -----
    Hou, Wen & Chen (2011), eq. (3)-(5) with ``eta != 1``.  With a constant gain the
    fault is abrupt and, under output feedback, the closed loop is piecewise LTI
    (simulated exactly); a callable gain makes it time-varying.

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> f = gf.GainFault(0, start=1.0, gain=1.5, bias=0.02)
    >>> f.apply([0.0, 1.0, 2.0], np.ones((1, 3))).round(2).tolist()
    [[1.0, 1.52, 1.52]]
    """

    kind = "gain"

    def __init__(
        self,
        sensor: int,
        *,
        start: float,
        gain: Value,
        bias: Value = 0.0,
        end: float | None = None,
    ) -> None:
        self._init_common(sensor, start, end)
        self.gain = _check_value(gain, "gain")
        self.bias = _check_value(bias, "bias")

    @property
    def time_varying_gain(self) -> bool:
        return callable(self.gain)

    def gain_values(self, t: np.ndarray) -> np.ndarray:
        return _evaluate(self.gain, t, "gain")

    def bias_values(self, t: np.ndarray) -> np.ndarray:
        return _evaluate(self.bias, t, "bias")

    def label(self) -> str:
        b = "" if (not callable(self.bias) and self.bias == 0) else f", bias {_describe(self.bias)}"
        return f"gain {_describe(self.gain)}{b} on {self._window()}"

    def __repr__(self) -> str:
        end = "" if self.end is None else f", end={self.end!r}"
        return (
            f"GainFault({self.sensor}, start={self.start!r}, gain={self.gain!r}, "
            f"bias={self.bias!r}{end})"
        )


class BiasFault(SensorFaultSignal):
    """Bias fault ``y_i = y_i0 + lambda(t)`` (``eta = 1``) on sensor ``sensor`` from ``start``.

    Parameters
    ----------
    sensor : int
    start : float
    bias : float or callable
        ``lambda``: a number (abrupt offset) or a vectorised function of time (drift).
    end : float, optional

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> gf.BiasFault(0, start=1.0, bias=0.5).apply([0.0, 1.0], np.zeros((1, 2))).tolist()
    [[0.0, 0.5]]
    """

    kind = "bias"

    def __init__(self, sensor: int, *, start: float, bias: Value, end: float | None = None) -> None:
        self._init_common(sensor, start, end)
        self.bias = _check_value(bias, "bias")

    def gain_values(self, t: np.ndarray) -> np.ndarray:
        return np.ones(np.shape(t))

    def bias_values(self, t: np.ndarray) -> np.ndarray:
        return _evaluate(self.bias, t, "bias")

    def label(self) -> str:
        return f"bias {_describe(self.bias)} on {self._window()}"

    def __repr__(self) -> str:
        end = "" if self.end is None else f", end={self.end!r}"
        return f"BiasFault({self.sensor}, start={self.start!r}, bias={self.bias!r}{end})"


class StuckFault(SensorFaultSignal):
    """Stuck sensor: ``y_i = value`` (``eta = 0``) from ``start``.

    Parameters
    ----------
    sensor : int
    start : float
    value : float, optional
        The frozen reading.  ``None`` (default): the reading at ``start`` is held (the
        healthy reading, after any fault listed before this one on the same sensor; noise
        included, so every Monte-Carlo run holds its own value).
    end : float, optional

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> y0 = np.array([[1.0, 2.0, 3.0, 4.0]])
    >>> gf.StuckFault(0, start=1.0).apply([0.0, 1.0, 2.0, 3.0], y0).tolist()
    [[1.0, 2.0, 2.0, 2.0]]
    """

    kind = "stuck"

    def __init__(
        self, sensor: int, *, start: float, value: float | None = None, end: float | None = None
    ) -> None:
        self._init_common(sensor, start, end)
        self.value = None if value is None else _check_value(value, "value")
        if callable(self.value):
            raise GeomFDIError(
                "value: a stuck sensor holds a number (or None for the reading at start)",
                argument="value",
            )

    @property
    def holds_reading(self) -> bool:
        return self.value is None

    def gain_values(self, t: np.ndarray) -> np.ndarray:
        return np.zeros(np.shape(t))

    def bias_values(self, t: np.ndarray) -> np.ndarray:
        return np.full(np.shape(t), 0.0 if self.value is None else float(self.value))

    def label(self) -> str:
        v = "held reading" if self.value is None else f"{self.value:g}"
        return f"stuck at {v} on {self._window()}"

    def __repr__(self) -> str:
        end = "" if self.end is None else f", end={self.end!r}"
        return f"StuckFault({self.sensor}, start={self.start!r}, value={self.value!r}{end})"


# ---------------------------------------------------------------- composition
@dataclass
class FaultProfile:
    """Composed ``eta`` and ``lambda`` of a fault list over a time window.

    ``y = eta * y0 + lam`` on the samples of the window.  The ``*_left`` arrays are the
    left limits: sample ``k`` evaluated with the faults active at sample ``k - 1``; a
    simulator uses them at the right end of a sampling interval, so that a fault switching
    at a sample takes effect exactly there instead of being interpolated over the
    preceding interval.

    Attributes
    ----------
    eta, eta_left : ndarray, (q, L)
    lam, lam_left : ndarray, (R, q, L)
        ``R`` is 1 unless a held reading differs between runs.
    holds : dict
        Held values of ``StuckFault(value=None)``, keyed by position in the fault list:
        arrays of shape (R,).
    """

    eta: np.ndarray
    lam: np.ndarray
    eta_left: np.ndarray
    lam_left: np.ndarray
    holds: dict[int, np.ndarray]


def validate_faults(faults: Any, q: int, *, argument: str = "faults") -> list[SensorFaultSignal]:
    """Check a fault list (one signal or a sequence) against ``q`` sensors."""
    if isinstance(faults, SensorFaultSignal):
        faults = [faults]
    if faults is None:
        return []
    if not isinstance(faults, Sequence):
        raise GeomFDIError(
            f"{argument}: must be a list of GainFault / BiasFault / StuckFault, got "
            f"{type(faults).__name__}",
            argument=argument,
        )
    out = []
    for k, f in enumerate(faults):
        if not isinstance(f, SensorFaultSignal):
            raise GeomFDIError(
                f"{argument}[{k}]: expected GainFault, BiasFault or StuckFault, got "
                f"{type(f).__name__}",
                argument=argument,
            )
        as_index(f.sensor, f"{argument}[{k}].sensor", q)
        out.append(f)
    return out


def first_active(fault: FaultSignal, t: np.ndarray) -> int | None:
    """Index of the first sample of the increasing grid ``t`` where ``fault`` is active.

    The activity window ``start <= t < end`` (with the tolerance of :meth:`FaultSignal.mask`)
    is an interval of an increasing grid, so two binary searches find it without a mask of
    the whole record.  ``None``: the fault is never active on the grid.
    """
    t = np.asarray(t, dtype=float)
    if type(fault).mask is not FaultSignal.mask:  # a custom activity rule: ask it
        hit = np.flatnonzero(fault.mask(t))
        return int(hit[0]) if hit.size else None
    k = int(np.searchsorted(t, fault.start - _time_tol(fault.start), side="left"))
    if k >= t.shape[0]:
        return None
    if fault.end is not None and not t[k] < fault.end - _time_tol(fault.end):
        return None
    return k


def activity_span(fault: FaultSignal, t: np.ndarray) -> tuple[int, int] | None:
    """``(ks, ke)``: the fault is active on the samples ``ks .. ke-1`` of the increasing
    grid ``t`` (``None``: never).  The activity window is one interval of the grid."""
    ks = first_active(fault, t)
    if ks is None:
        return None
    t = np.asarray(t, dtype=float)
    if type(fault).mask is not FaultSignal.mask:
        off = np.flatnonzero(~fault.mask(t[ks:]))
        return ks, ks + int(off[0]) if off.size else t.shape[0]
    if fault.end is None:
        return ks, t.shape[0]
    return ks, int(np.searchsorted(t, fault.end - _time_tol(fault.end), side="left"))


def fault_profile(
    faults: Sequence[SensorFaultSignal],
    t: np.ndarray,
    y0: np.ndarray | None,
    *,
    q: int,
    k0: int = 0,
    k1: int | None = None,
    holds: dict[int, np.ndarray] | None = None,
    last_left: bool = False,
    sensors: Sequence[int] | None = None,
    y0_start: int = 0,
) -> FaultProfile:
    """Compose ``faults`` on the samples ``k0 <= k < k1`` of the grid ``t``.

    Parameters
    ----------
    faults : sequence of SensorFaultSignal
        Validated against ``q`` (see :func:`validate_faults`).
    t : ndarray, (N,)
        The full time grid (activity masks are computed on it, so that the left limit at
        ``k0`` sees sample ``k0 - 1``).
    y0 : ndarray, (R, q, L0) or None
        Healthy readings from sample ``y0_start`` on; needed only at the first active
        sample of stuck faults that hold the reading (a simulator that fills ``y0``
        progressively, or passes one time chunk, provides it there).
    q : int
        Number of sensors.
    k0, k1 : int
        Window (``k1=None``: to the end).
    holds : dict, optional
        Held values computed for earlier windows (updated in place).
    last_left : bool
        Only the left limit is wanted at the last sample of the window (a simulator's
        segment end): ``eta``/``lam`` there then ignore faults starting at that sample,
        whose held readings are not known yet.
    sensors : sequence of int, optional
        Compute the rows of these sensors only (in this order; every fault must be on one
        of them): the other rows are ``eta = 1, lam = 0`` and need no memory.
    y0_start : int
        Grid index of ``y0[..., 0]`` (0: ``y0`` covers the grid from its start).

    Only the samples ``k0 - 1 .. k1 - 1`` of the grid are read (the activity masks of
    the window and the left limit at ``k0``), so a long record can be composed window by
    window (with ``holds`` carried from one window to the next) in memory proportional
    to the window.

    Returns
    -------
    FaultProfile
        With ``len(sensors)`` rows instead of ``q`` when ``sensors`` is given.
    """
    N = t.shape[0]
    k1 = N if k1 is None else k1
    L = k1 - k0
    holds = {} if holds is None else holds
    rows = list(range(q)) if sensors is None else [int(i) for i in sensors]
    where = {s: j for j, s in enumerate(rows)}
    if any(f.sensor not in where for f in faults):
        raise GeomFDIError(f"sensors: {rows} must include every faulty sensor", argument="sensors")
    nq = len(rows)
    eta = np.ones((nq, L))
    eta_l = np.ones((nq, L))
    lam = np.zeros((1, nq, L))
    lam_l = np.zeros((1, nq, L))
    tw = t[k0:k1]
    lo = max(k0 - 1, 0)
    for pos, f in enumerate(faults):
        mw = f.mask(t[lo:k1])  # the window and the sample before it (left limit at k0)
        m = mw[k0 - lo :].copy()
        if last_left and L:
            m[-1] = False
        prev = mw[:-1] if k0 > 0 else np.concatenate([mw[:1], mw[:-1]])
        on = m | prev
        if not on.any():
            continue
        # work on the span of samples the fault touches (views, in-place masked updates)
        a = int(np.argmax(on))
        b = L - int(np.argmax(on[::-1]))
        sl = slice(a, b)
        m, prev, on = m[sl], prev[sl], on[sl]
        i = where[f.sensor]
        if on.all():
            g = f.gain_values(tw[sl])
            bias = f.bias_values(tw[sl])
        else:
            g = np.ones(b - a)
            bias = np.zeros(b - a)
            g[on] = f.gain_values(tw[sl][on])
            bias[on] = f.bias_values(tw[sl][on])
        g = np.broadcast_to(g, (b - a,))
        if f.holds_reading:
            if pos not in holds:
                ks = first_active(f, t)
                ks = k0 if ks is None else ks
                if not k0 <= ks < k1 or y0 is None or not 0 <= ks - y0_start < y0.shape[-1]:
                    raise GeomFDIError(
                        f"faults[{pos}]: the reading held by the stuck fault at t={t[ks]:g} "
                        "is not available",
                        argument="faults",
                    )
                j = ks - k0
                holds[pos] = eta[i, j] * y0[:, f.sensor, ks - y0_start] + lam[:, i, j]
            hold = holds[pos]
            if hold.shape[0] > lam.shape[0]:
                lam = np.broadcast_to(lam, (hold.shape[0], nq, L)).copy()
                lam_l = np.broadcast_to(lam_l, (hold.shape[0], nq, L)).copy()
            bias = bias[None, :] + hold[:, None]
        else:
            bias = np.broadcast_to(bias, (1, b - a))
        for ek, lk, mk in ((eta, lam, m), (eta_l, lam_l, prev)):
            # eta <- g eta and lam <- g lam + bias where the fault is active
            np.multiply(ek[i, sl], g, out=ek[i, sl], where=mk)
            np.multiply(lk[:, i, sl], g, out=lk[:, i, sl], where=mk)
            np.add(lk[:, i, sl], bias, out=lk[:, i, sl], where=mk)
    return FaultProfile(eta, lam, eta_l, lam_l, holds)


def apply_faults(faults: Any, t: Any, y0: Any) -> np.ndarray:
    """Apply any number of sensor faults to healthy readings, vectorised over samples.

    Parameters
    ----------
    faults : SensorFaultSignal or sequence of them
        Composed in list order (see the module docstring).
    t : array_like, (N,)
        Sample times (need not be uniform).
    y0 : array_like, (q, N) or (runs, q, N)
        Healthy readings.

    Returns
    -------
    ndarray, same shape as ``y0``
        ``eta * y0 + lambda`` (Hou, Wen & Chen 2011, eq. 3-5).

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> y0 = np.ones((2, 3))
    >>> fs = [
    ...     gf.GainFault(0, start=1.0, gain=2.0),
    ...     gf.BiasFault(0, start=2.0, bias=0.5),
    ...     gf.StuckFault(1, start=1.0, value=7.0),
    ... ]
    >>> gf.apply_faults(fs, [0.0, 1.0, 2.0], y0).tolist()
    [[1.0, 2.0, 2.5], [1.0, 7.0, 7.0]]
    """
    t = as_real_array(t, "t")
    if t.ndim != 1:
        raise ShapeError(f"t: must be a 1-D time vector, got shape {t.shape}", argument="t")
    y = as_real_array(y0, "y0")
    single = y.ndim == 2
    if single:
        y = y[None]
    if y.ndim != 3 or y.shape[-1] != t.shape[0]:
        raise ShapeError(
            f"y0: expected (q, {t.shape[0]}) or (runs, q, {t.shape[0]}), got shape {np.shape(y0)}",
            argument="y0",
        )
    q = y.shape[1]
    fl = validate_faults(faults, q)
    prof = fault_profile(fl, t, y, q=q)
    out = prof.eta[None] * y + prof.lam
    return out[0] if single else out
