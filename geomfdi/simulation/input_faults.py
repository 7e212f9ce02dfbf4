"""Fault signals that enter the plant additively: actuator faults and general faults.

Every one of them is an additive signal ``phi(t)`` with a signature ``(Bphi, Dphi)``::

    x' = A x + B u + Bd d + Bphi phi,        y0 = C x + D u + Dd d + Dphi phi

* **actuator faults** on input ``i`` (``Bphi = B[:, i]``, ``Dphi = D[:, i]``): the applied
  input is ``u_i^a = eta(t) u_i + lambda(t)`` where ``u_i`` is the commanded input (what
  the residual generators read): a *gain* (loss of effectiveness, ``eta < 1``), a *bias*
  (``eta = 1``) or a *stuck* actuator (``eta = 0``, ``lambda`` the frozen value), so
  ``phi = (eta - 1) u_i + lambda``;
* **general additive faults** ``Fault(Bf, Df)`` (the design object of
  :class:`geomfdi.Fault`) driven by a signal: a step of a given size, a ramp, or any
  vectorised function of ``t``.

Gain and stuck actuator faults depend on the commanded input.  In open loop it is known
beforehand and ``phi`` is exogenous.  Under feedback (state or output) the commanded input
comes from the controller and the fault changes the loop itself: the applied input is
``u^a = Gamma(t) u + lambda^a(t)`` with ``Gamma = diag(eta)`` piecewise constant between
fault events, so the loop is a switched linear system simulated segment by segment
(:func:`actuator_profile` gives ``Gamma`` and ``lambda^a`` per sample; see
:mod:`geomfdi.simulation.closed_loop`).  The residual generators read the commanded ``u``
in every mode.  Actuator bias and general faults are exogenous in every mode.  See the
user guide, *Theory: evaluation* (``docs/theory/evaluation.md``).
"""

from __future__ import annotations

import numbers
from typing import Any

import numpy as np

from geomfdi._validation import as_real_array, check_finite
from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.model.faults import Fault
from geomfdi.model.plant import Plant
from geomfdi.simulation.signals import (
    FaultProfile,
    FaultSignal,
    Value,
    _check_channel,
    _check_value,
    _describe,
    _evaluate,
    activity_span,
)

__all__ = [
    "InputFaultSignal",
    "ActuatorGainFault",
    "ActuatorBiasFault",
    "ActuatorStuckFault",
    "AdditiveFault",
    "actuator_profile",
]


class InputFaultSignal(FaultSignal):
    """Base class of the additive fault signals (not used directly).

    Attributes
    ----------
    needs_input : bool
        The signal depends on the commanded input (gain and stuck actuators).
    """

    needs_input: bool = False

    def signature(self, plant: Plant) -> tuple[np.ndarray, np.ndarray]:
        """``(Bphi, Dphi)``: (n, k) and (q, k), checked against ``plant``."""
        raise NotImplementedError

    def values(self, t: np.ndarray, u: np.ndarray) -> np.ndarray:
        """``phi`` on the grid, (k, N); zero where the fault is inactive.

        ``u`` is the commanded input (m, N) (used by gain and stuck actuator faults).
        """
        raise NotImplementedError


class _ActuatorFault(InputFaultSignal):
    actuator: int

    def _init_actuator(self, actuator: Any, start: Any, end: Any) -> None:
        self.actuator = _check_channel(actuator, "actuator")
        self._init_window(start, end)

    def signature(self, plant: Plant) -> tuple[np.ndarray, np.ndarray]:
        i = self.actuator
        if i >= plant.m:
            raise GeomFDIError(
                f"actuator: index {i} out of range for a plant with {plant.m} inputs",
                argument="actuator",
            )
        return plant.B[:, i : i + 1], plant.D[:, i : i + 1]

    def _applied(self, t: np.ndarray, ui: np.ndarray) -> np.ndarray:
        """The applied input ``u_i^a`` on the active samples ``t`` (commanded ``ui``)."""
        raise NotImplementedError

    def values(self, t: np.ndarray, u: np.ndarray) -> np.ndarray:
        m = self.mask(t)
        phi = np.zeros((1, t.shape[0]))
        if m.any():
            ui = u[self.actuator, m]
            phi[0, m] = self._applied(t[m], ui) - ui
        return phi

    def _window(self) -> str:
        return f"actuator {self.actuator} {self._until()}"


class ActuatorGainFault(_ActuatorFault):
    """Loss of effectiveness: applied input ``u_i^a = gain(t) u_i + bias(t)`` from ``start``.

    Parameters
    ----------
    actuator : int
        Input index (0-based).
    start : float
        Onset (seconds); keyword-only like every argument after ``actuator``.
    gain : float or callable
        ``eta``: 1 is healthy, 0.6 a 40 % loss of effectiveness; a vectorised function of
        time for a progressive loss (under feedback the loop is then stepped sample by
        sample with the gain frozen over each interval; a constant gain is exact).
    bias : float or callable, default 0
    end : float, optional

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> f = gf.ActuatorGainFault(0, start=1.0, gain=0.5)
    >>> f.values(np.array([0.0, 1.0, 2.0]), np.full((1, 3), 2.0)).tolist()
    [[0.0, -1.0, -1.0]]
    """

    kind = "actuator gain"
    needs_input = True

    def __init__(
        self,
        actuator: int,
        *,
        start: float,
        gain: Value,
        bias: Value = 0.0,
        end: float | None = None,
    ) -> None:
        self._init_actuator(actuator, start, end)
        self.gain = _check_value(gain, "gain")
        self.bias = _check_value(bias, "bias")

    def _applied(self, t: np.ndarray, ui: np.ndarray) -> np.ndarray:
        return _evaluate(self.gain, t, "gain") * ui + _evaluate(self.bias, t, "bias")

    @property
    def time_varying_gain(self) -> bool:
        """The gain is a function of time (the loop is not piecewise constant)."""
        return callable(self.gain)

    def gain_bias(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(eta, lambda)`` of ``u^a = eta u + lambda`` on the samples ``t``."""
        return _evaluate(self.gain, t, "gain"), _evaluate(self.bias, t, "bias")

    def label(self) -> str:
        b = "" if (not callable(self.bias) and self.bias == 0) else f", bias {_describe(self.bias)}"
        return f"gain {_describe(self.gain)}{b} on {self._window()}"

    def __repr__(self) -> str:
        return f"ActuatorGainFault({self.actuator}, start={self.start!r}, gain={self.gain!r})"


class ActuatorBiasFault(_ActuatorFault):
    """Actuator bias: applied input ``u_i^a = u_i + bias(t)`` from ``start``.

    Parameters
    ----------
    actuator : int
    start : float
    bias : float or callable
    end : float, optional
    """

    kind = "actuator bias"

    def __init__(
        self, actuator: int, *, start: float, bias: Value, end: float | None = None
    ) -> None:
        self._init_actuator(actuator, start, end)
        self.bias = _check_value(bias, "bias")

    def values(self, t: np.ndarray, u: np.ndarray) -> np.ndarray:
        m = self.mask(t)
        phi = np.zeros((1, t.shape[0]))
        if m.any():
            phi[0, m] = _evaluate(self.bias, t[m], "bias")
        return phi

    def label(self) -> str:
        return f"bias {_describe(self.bias)} on {self._window()}"

    def __repr__(self) -> str:
        return f"ActuatorBiasFault({self.actuator}, start={self.start!r}, bias={self.bias!r})"


class ActuatorStuckFault(_ActuatorFault):
    """Stuck actuator: applied input ``u_i^a = value`` from ``start``.

    Parameters
    ----------
    actuator : int
    start : float
    value : float, optional
        The frozen input; ``None`` (default): the commanded input at ``start`` is held
        (under feedback: its value just before the fault, the left limit at ``start``).
    end : float, optional
    """

    kind = "actuator stuck"
    needs_input = True

    def __init__(
        self,
        actuator: int,
        *,
        start: float,
        value: float | None = None,
        end: float | None = None,
    ) -> None:
        self._init_actuator(actuator, start, end)
        self.value = None if value is None else _check_value(value, "value")
        if callable(self.value):
            raise GeomFDIError(
                "value: a stuck actuator holds a number (or None for the input at start)",
                argument="value",
            )

    def _applied(self, t: np.ndarray, ui: np.ndarray) -> np.ndarray:
        held = ui[0] if self.value is None else float(self.value)
        return np.full(ui.shape, held)

    time_varying_gain = False

    @property
    def holds_input(self) -> bool:
        """The held value is the commanded input at the onset."""
        return self.value is None

    def gain_bias(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(eta, lambda) = (0, value)`` (``lambda = 0`` when the input is held)."""
        v = 0.0 if self.value is None else float(self.value)
        return np.zeros(t.shape), np.full(t.shape, v)

    def label(self) -> str:
        v = "held input" if self.value is None else f"{self.value:g}"
        return f"stuck at {v} on {self._window()}"

    def __repr__(self) -> str:
        return f"ActuatorStuckFault({self.actuator}, start={self.start!r}, value={self.value!r})"


def actuator_profile(
    faults: Any,
    t: np.ndarray,
    *,
    m: int,
    k0: int,
    k1: int,
    u_start: np.ndarray | None,
    holds: dict[int, np.ndarray],
    last_left: bool = False,
) -> FaultProfile:
    """Composed actuator gains of gain and stuck faults on the samples ``k0 <= k < k1``.

    The applied input is ``u^a = eta * u + lam`` (commanded ``u``); faults on one actuator
    compose in list order (``eta <- g eta``, ``lam <- g lam + b``), a stuck actuator has
    ``g = 0`` and ``b`` its value.  As for sensor faults (:class:`FaultProfile`), the
    ``*_left`` arrays are left limits (faults active at the previous sample).

    Parameters
    ----------
    faults : sequence of ActuatorGainFault / ActuatorStuckFault
    t : ndarray, (N,)
        The full grid.
    m : int
        Number of inputs.
    k0, k1 : int
        Window.
    u_start : ndarray, (R, m) or None
        Commanded input at sample ``k0`` (its left limit): the value held by a stuck
        actuator (``value=None``) whose onset is ``k0``.
    holds : dict
        Held values of earlier windows, keyed by position in ``faults`` (updated).
    last_left : bool
        Only the left limit is wanted at the last sample (a segment end).
    """
    L = k1 - k0
    eta = np.ones((m, L))
    eta_l = np.ones((m, L))
    lam = np.zeros((1, m, L))
    lam_l = np.zeros((1, m, L))
    tw = t[k0:k1]
    kk = np.arange(k0, k1)
    for pos, f in enumerate(faults):
        span = activity_span(f, t)  # no mask of the whole record
        if span is None:
            continue
        ks, ke = span
        act = (kk >= ks) & (kk < ke)
        if last_left and L:
            act[-1] = False
        kp = np.maximum(kk - 1, 0)  # the previous sample (sample 0: itself)
        prev = (kp >= ks) & (kp < ke)
        if not (act.any() or prev.any()):
            continue
        i = f.actuator
        g, b = f.gain_bias(tw)
        b = b[None, :]
        if getattr(f, "holds_input", False):
            if pos not in holds:
                if ks != k0 or u_start is None:
                    raise GeomFDIError(
                        f"faults[{pos}]: the input held by the stuck actuator at t={t[ks]:g} "
                        "is not available",
                        argument="faults",
                    )
                holds[pos] = np.array(u_start[:, i], dtype=float)
            hold = holds[pos]
            if hold.shape[0] > lam.shape[0]:
                lam = np.broadcast_to(lam, (hold.shape[0], m, L)).copy()
                lam_l = np.broadcast_to(lam_l, (hold.shape[0], m, L)).copy()
            b = b + hold[:, None]
        for ek, lk, mk in ((eta, lam, act), (eta_l, lam_l, prev)):
            np.multiply(ek[i], g, out=ek[i], where=mk)
            np.multiply(lk[:, i], g, out=lk[:, i], where=mk)
            np.add(lk[:, i], b, out=lk[:, i], where=mk)
    return FaultProfile(eta, lam, eta_l, lam_l, holds)


def _magnitude(value: Any, name: str) -> np.ndarray:
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        out = np.array([float(value)])
    else:
        out = as_real_array(value, name)
        if out.ndim != 1:
            raise ShapeError(f"{name}: a number or a vector, got shape {out.shape}", argument=name)
    check_finite(out, name)
    return out


class AdditiveFault(InputFaultSignal):
    """A general additive fault ``Fault(Bf, Df)`` driven by a signal from ``start``.

    ``phi(t) = size + slope (t - start)`` (a step, a ramp, or both) or ``signal(t)``.

    Parameters
    ----------
    fault : geomfdi.Fault
        Where the fault enters (``SensorFault`` / ``ActuatorFault`` / ``Fault(Bf, Df)``);
        the structure column of a bank designed for this object is matched by its
        signature.
    start : float
    size : float or (k,), default 1
        Step height (per component of a multi-component fault).
    slope : float or (k,), default 0
        Ramp rate (per second).
    signal : callable, optional
        A vectorised function of time returning (N,) or (k, N); replaces size and slope.
    end : float, optional

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> f = gf.AdditiveFault(gf.Fault(Bf=[[1.0], [0.0]]), start=1.0, size=0.5, slope=1.0)
    >>> f.values(np.array([0.0, 1.0, 2.0]), np.zeros((0, 3))).tolist()
    [[0.0, 0.5, 1.5]]
    """

    kind = "additive"

    def __init__(
        self,
        fault: Fault,
        *,
        start: float,
        size: Any = 1.0,
        slope: Any = 0.0,
        signal: Any = None,
        end: float | None = None,
    ) -> None:
        if not isinstance(fault, Fault):
            raise GeomFDIError(
                f"fault: expected a geomfdi Fault, got {type(fault).__name__}", argument="fault"
            )
        self._init_window(start, end)
        self.fault = fault
        k = fault.k
        self.size = _magnitude(size, "size")
        self.slope = _magnitude(slope, "slope")
        for name, arr in (("size", self.size), ("slope", self.slope)):
            if arr.shape[0] not in (1, k):
                raise ShapeError(
                    f"{name}: expected 1 or {k} values for a {k}-component fault, got "
                    f"{arr.shape[0]}",
                    argument=name,
                )
        if signal is not None and not callable(signal):
            raise GeomFDIError("signal: must be a callable t -> phi(t)", argument="signal")
        self.signal = signal

    def signature(self, plant: Plant) -> tuple[np.ndarray, np.ndarray]:
        return self.fault.signatures(plant.n, plant.q, argument="fault")

    def values(self, t: np.ndarray, u: np.ndarray) -> np.ndarray:
        k = self.fault.k
        m = self.mask(t)
        phi = np.zeros((k, t.shape[0]))
        if not m.any():
            return phi
        tm = t[m]
        if self.signal is None:
            phi[:, m] = self.size[:, None] + self.slope[:, None] * (tm - self.start)[None]
            return phi
        try:
            out = self.signal(tm)
        except Exception as exc:
            raise GeomFDIError(
                f"signal: calling it on a time array failed ({type(exc).__name__}: {exc})",
                argument="signal",
            ) from exc
        out = as_real_array(out, "signal")
        if out.ndim == 1 and out.shape[0] == tm.shape[0]:
            out = np.broadcast_to(out, (k, tm.shape[0]))
        if out.shape != (k, tm.shape[0]):
            raise ShapeError(
                f"signal: returned shape {out.shape}; expected ({tm.shape[0]},) or "
                f"({k}, {tm.shape[0]}) (vectorised over t)",
                argument="signal",
            )
        check_finite(out, "signal")
        phi[:, m] = out
        return phi

    def label(self) -> str:
        if self.signal is not None:
            shape = getattr(self.signal, "__name__", "f") + "(t)"
        else:
            shape = f"step {self.size.tolist()}" if not np.any(self.slope) else "ramp"
        return f"{self.fault.name}: {shape} {self._until()}"

    def __repr__(self) -> str:
        return f"AdditiveFault({self.fault!r}, start={self.start!r})"
