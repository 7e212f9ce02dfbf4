"""Simulation of a nonlinear python-control plant with a bank designed on its linearisation.

``gf.simulate(sys, bank, t, u, faults=...)`` with a :class:`control.NonlinearIOSystem`
``sys`` (``x' = f(t, x, u, p)``, ``y = h(t, x, u, p)``) comes here.  Everything is in
physical units: ``u`` the commanded known inputs (the bank's input names among the
system's inputs; ``u_op`` held when ``None``), ``x0`` the initial state (``x_op`` of the
bank's plant by default), ``d`` the system's other inputs (e.g. a leak flow; zero by
default).  Per sampling interval ``[t_k, t_k+1)``:

* the measured reading ``y_k = faults(h(x_k, u^a_k) + v_k)`` (sensor faults act on the
  physical reading, composed in order; ``v`` measurement noise);
* the commanded input ``u_k = u_ext,k``, ``u_ext,k − K (x_k − x_op)`` (state feedback)
  or ``u_ext,k + C_c x_c + D_c (y_k − y_op)`` (a python-control controller on the
  measured deviation, its state integrated with the plant's);
* the applied input ``u^a_k`` (actuator gain, bias and stuck faults on ``u_k``), held;
* ``x' = f(x, [u^a_k; d_k]) + Bf phi_k + Bw w_k`` (general additive faults
  ``AdditiveFault(Fault(Bf, Df))`` and process noise, held) integrated by the classical
  Runge–Kutta method with ``substeps`` steps.

The bank then evaluates the recorded ``y`` and ``u`` as :func:`geomfdi.evaluate` does (the
operating point subtracted, a continuous bank sampled with a first-order hold, start-up
``"steady"``), with the same thresholds, persistence rule and detection events as
:func:`geomfdi.simulate`.  The loop over samples is a Python loop (a nonlinear plant has no
closed-form step): about 20 µs per sample and state for small systems.

*Divergence.*  A run whose state becomes non-finite or leaves ``|x − x_op| <= bound``
(default ``1e3 (1 + max |x_op|)``) stops there: the remaining samples are ``nan`` (masked:
no alarm, no decision), ``res.info["diverged"]`` is True with the time in
``res.info["diverged_at"]``, and a :class:`DivergenceWarning` says so.  See the user guide,
*Physical plants* (``docs/guide/physical-plants.md``).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from geomfdi.errors import GeomFDIError, ShapeError

__all__ = [
    "simulate_nonlinear",
    "is_nonlinear",
    "design_plant",
    "DivergenceWarning",
    "default_bound",
]


class DivergenceWarning(UserWarning):
    """A simulated run diverged (non-finite state or beyond its bound) and was stopped."""


def is_nonlinear(sys: Any) -> bool:
    """True for a python-control nonlinear I/O system that is not a ``StateSpace``."""
    if type(sys).__module__.split(".")[0] != "control":
        return False
    import control

    return isinstance(sys, control.NonlinearIOSystem) and not isinstance(sys, control.StateSpace)


def default_bound(x_op: np.ndarray) -> float:
    """``1e3 (1 + max |x_op|)``: the state deviation beyond which a run has diverged."""
    return 1e3 * (1.0 + float(np.max(np.abs(x_op), initial=0.0)))


def _signal(value: Any, t: np.ndarray, rows: int, name: str, default: np.ndarray) -> np.ndarray:
    """A (rows, N) signal from an array, a callable of t, or ``None`` (``default`` held)."""
    N = t.size
    if value is None:
        return np.repeat(np.asarray(default, dtype=float).reshape(rows, 1), N, axis=1)
    if callable(value):
        value = value(t)
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 1 and rows == 1 and arr.size == N:
        arr = arr[None]
    if arr.shape != (rows, N):
        raise ShapeError(f"{name}: expected ({rows}, {N}), got {arr.shape}", argument=name)
    return arr


def _channels(sys: Any, sig: dict[str, Any]) -> tuple[list[int], list[int]]:
    """Indices of the bank's known inputs among the system's inputs, and of the others."""
    labels = list(sys.input_labels)
    m = len(sig["inputs"])
    if sig["named"] and set(sig["inputs"]) <= set(labels):
        known = [labels.index(n) for n in sig["inputs"]]
    elif m <= len(labels):
        known = list(range(m))
    else:
        raise ShapeError(f"sys: has {len(labels)} inputs, the bank reads {m}", argument="sys")
    return known, [i for i in range(len(labels)) if i not in known]


def _sensor_program(faults: Sequence[Any], t: np.ndarray) -> list[tuple[Any, ...]]:
    """Per sensor fault: (sensor, active mask, eta, lambda, holds)."""
    out = []
    for f in faults:
        m = f.mask(t)
        eta = np.where(m, f.gain_values(t), 1.0)
        lam = np.where(m, f.bias_values(t), 0.0) if not f.holds_reading else np.zeros(t.size)
        out.append((f.sensor, m, eta, lam, f.holds_reading))
    return out


def _rk4(
    f: Callable[..., np.ndarray],
    tt: float,
    z: np.ndarray,
    h: float,
    n: int,
    ua: np.ndarray,
    extra: np.ndarray,
    ctrl: tuple[Any, Any, np.ndarray],
) -> np.ndarray:
    """One classical Runge–Kutta step of ``[x; x_c]`` with the inputs held."""
    Ac, Bc, ey = ctrl

    def fz(ti: float, zz: np.ndarray) -> np.ndarray:
        dx = f(ti, zz[:n], ua) + extra
        if Ac is None:
            return dx
        return np.concatenate([dx, Ac @ zz[n:] + Bc @ ey])

    k1 = fz(tt, z)
    k2 = fz(tt + h / 2, z + h / 2 * k1)
    k3 = fz(tt + h / 2, z + h / 2 * k2)
    k4 = fz(tt + h, z + h * k3)
    return z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)


def design_plant(sys: Any, bank: Any, params: dict[str, Any] | None = None) -> Any:
    """The linearisation of ``sys`` at the bank's operating point, on the inputs the bank
    reads, with the bank's signal names: the plant that matches simulated faults to the
    bank's structure columns (and gives sizes to a campaign)."""
    from geomfdi.deployment.program import as_bank
    from geomfdi.model.plant import Plant
    from geomfdi.model.signals import bank_signals

    bank = as_bank(bank)
    sig = bank_signals(bank)
    info_sig = (bank.info or {}).get("signals") or {}
    n = sys.nstates
    x_op = np.asarray(info_sig.get("x_op") or np.zeros(n), dtype=float)
    x_op = x_op if x_op.size == n else np.zeros(n)
    known, _ = _channels(sys, sig)
    u_full = np.zeros(sys.ninputs)
    u_full[known] = sig["u_op"]
    lin = Plant.linearize(sys, x_op, u_full, params=params)
    return Plant(lin.A, lin.B[:, known], lin.C, lin.D[:, known], outputs=sig["outputs"],
                 inputs=sig["inputs"], x_op=x_op, u_op=sig["u_op"], y_op=sig["y_op"])  # fmt: skip


def simulate_nonlinear(
    sys: Any,
    bank: Any,
    t: Any,
    u: Any = None,
    *,
    faults: Sequence[Any] = (),
    x0: Any = None,
    d: Any = None,
    noise: Any = None,
    controller: Any = None,
    threshold: Any = None,
    persistence: Any = None,
    detection_window: float | None = None,
    bound: float | None = None,
    substeps: int = 4,
    params: dict[str, Any] | None = None,
) -> Any:
    """Simulate a nonlinear plant with faults and run the bank on its readings.

    Parameters
    ----------
    sys : control.NonlinearIOSystem
        Continuous time; inputs include the bank's known inputs (by name).
    bank : ResidualBank
        Designed on a linearisation (:meth:`geomfdi.Plant.linearize`): its
        ``info["signals"]`` hold the names and the operating point.
    t : array_like (N,)
        Uniform time grid (the sampling of the readings).
    u : array_like (m, N), callable or None
        Commanded known inputs, physical (``None``: ``u_op``).
    faults : sequence of fault signals
        Sensor (:class:`GainFault`, :class:`BiasFault`, :class:`StuckFault`, on the
        physical reading; sensors by index or output name), actuator
        (:class:`ActuatorGainFault`, ...) and :class:`AdditiveFault` signals.
    x0 : array_like (n,), optional
        Physical initial state (default ``x_op``).
    d : array_like (k, N), callable, mapping name -> signal, or None
        The system's inputs the bank does not read (e.g. a leak, or noise inputs), zero
        by default.
    noise : Noise, optional
        Measurement noise on the readings; process noise ``Bw w`` held per interval
        (``Noise(inputs=)`` is refused: the system's noise inputs are given in ``d``).
    controller : None, array (m, n) or python-control StateSpace
        State feedback on ``x − x_op``, or a continuous controller from the measured
        deviation ``y − y_op`` to the commanded deviation added to ``u``.
    threshold, persistence, detection_window
        As for :func:`geomfdi.simulate`.
    bound : float, optional
        Divergence bound on ``max |x − x_op|`` (module docstring).
    substeps : int
        Runge–Kutta steps per sampling interval.
    params : dict, optional
        Parameters of the system's functions.

    Returns
    -------
    SimulationResult
        ``x``, ``y`` (measured), ``y_healthy``, ``u`` (commanded) in physical units;
        ``info["diverged"]``, ``info["diverged_at"]``, ``info["nonlinear"] = True``.
    """
    from geomfdi.deployment.program import as_bank
    from geomfdi.deployment.recorded import evaluate
    from geomfdi.model.plant import Plant
    from geomfdi.model.signals import bank_signals
    from geomfdi.simulation.input_faults import AdditiveFault, InputFaultSignal
    from geomfdi.simulation.physical import deviation_faults
    from geomfdi.simulation.results import SimulationResult
    from geomfdi.simulation.schedule import structure_columns
    from geomfdi.simulation.signals import FaultSignal, SensorFaultSignal

    if not is_nonlinear(sys):
        raise GeomFDIError(
            f"sys: expected a control.NonlinearIOSystem, got {type(sys).__name__}",
            argument="sys",
        )
    if not sys.isctime():
        raise GeomFDIError("sys: a continuous-time nonlinear system is needed", argument="sys")
    bank = as_bank(bank)
    sig = bank_signals(bank)
    info_sig = (bank.info or {}).get("signals") or {}
    n, q = sys.nstates, sys.noutputs
    if q != len(sig["outputs"]):
        raise ShapeError(f"sys: has {q} outputs, the bank reads {len(sig['outputs'])}",
                         argument="sys")  # fmt: skip
    t = np.asarray(t, dtype=float).reshape(-1)
    N = t.size
    if N < 2 or not np.all(np.diff(t) > 0):
        raise GeomFDIError("t: needs an increasing grid of at least 2 samples", argument="t")
    known, other = _channels(sys, sig)
    m = len(known)
    x_op = np.asarray(info_sig.get("x_op") or np.zeros(n), dtype=float)
    if x_op.size != n:
        x_op = np.zeros(n)
    x = x_op.copy() if x0 is None else np.asarray(x0, dtype=float).reshape(-1).copy()
    if x.size != n:
        raise ShapeError(f"x0: expected {n} values, got {x.size}", argument="x0")
    U = _signal(u, t, m, "u", sig["u_op"])
    if isinstance(d, Mapping):
        labels = list(sys.input_labels)
        Dx = np.zeros((len(other), N))
        for name, val in d.items():
            if name not in labels or labels.index(name) not in other:
                raise GeomFDIError(
                    f"d: {name!r} is not one of the system's other inputs "
                    f"{[labels[i] for i in other]}",
                    argument="d",
                )
            Dx[other.index(labels.index(name))] = _signal(val, t, 1, f"d[{name!r}]", [0.0])[0]
    else:
        Dx = _signal(d, t, len(other), "d", np.zeros(len(other)))
    substeps = int(substeps)
    if substeps < 1:
        raise GeomFDIError("substeps: must be >= 1", argument="substeps")
    bound = default_bound(x_op) if bound is None else float(bound)
    design = design_plant(sys, bank, params)
    fl = [faults] if isinstance(faults, FaultSignal) else list(faults or [])
    # names only (faults act on the physical values of a nonlinear plant: no op shift)
    names = Plant(design.A, design.B, design.C, design.D, outputs=design.outputs,
                  inputs=design.inputs)  # fmt: skip
    fl = deviation_faults(fl, names) if fl else []
    sensor = [f for f in fl if isinstance(f, SensorFaultSignal)]
    act = [f for f in fl if isinstance(f, InputFaultSignal) and not isinstance(f, AdditiveFault)]
    add = [f for f in fl if isinstance(f, AdditiveFault)]
    for f in sensor:
        if not 0 <= f.sensor < q:
            raise GeomFDIError(f"faults: sensor {f.sensor} out of range 0..{q - 1}",
                               argument="faults")  # fmt: skip
    sp = _sensor_program(sensor, t)
    act_masks = [f.mask(t) for f in act]
    held_act: dict[int, float] = {}
    Bphi = np.zeros((n, 0))
    Dphi = np.zeros((q, 0))
    phi = np.zeros((0, N))
    if add:
        sigs = [f.fault.signatures(n, q, argument="faults") for f in add]
        Bphi = np.hstack([b for b, _ in sigs])
        Dphi = np.hstack([dd for _, dd in sigs])
        phi = np.vstack([f.values(t, U) for f in add])
    # noise
    Lv = Bw = Lw = None
    zv = zw = None
    if noise is not None:
        if getattr(noise, "inputs", None) is not None:
            raise GeomFDIError(
                "noise.inputs: a nonlinear system's noise inputs are among its other inputs; "
                "give their signals in d= (a mapping from input name to signal)",
                argument="noise.inputs",
            )
        Lv, Bw, Lw = noise.factors(design)
        from geomfdi.simulation.noise import noise_stream

        rows_w = Lw.shape[1] if Lw is not None else 0
        st = noise_stream(noise.source(noise.seed), q if Lv is not None else 0, rows_w, N)
        zv, zw = st.take(0, N)
    V = Lv @ zv if Lv is not None else np.zeros((q, N))
    Wn = (Bw @ (Lw @ zw)) if Lw is not None else np.zeros((n, N))
    # controller
    K = Ac = Bc = Cc = Dc = None
    xc = np.zeros(0)
    if controller is not None:
        if type(controller).__module__.split(".")[0] == "control":
            import control

            ss = control.ss(controller)
            if not ss.isctime():
                raise GeomFDIError("controller: a continuous controller is needed",
                                   argument="controller")  # fmt: skip
            Ac, Bc, Cc, Dc = (np.asarray(M, dtype=float) for M in (ss.A, ss.B, ss.C, ss.D))
            if Bc.shape[1] != q or Cc.shape[0] != m:
                raise ShapeError(f"controller: expected {q} inputs and {m} outputs",
                                 argument="controller")  # fmt: skip
            xc = np.zeros(Ac.shape[0])
        else:
            K = np.asarray(controller, dtype=float)
            if K.shape != (m, n):
                raise ShapeError(f"controller: K must be ({m}, {n}), got {K.shape}",
                                 argument="controller")  # fmt: skip
    p = params

    def f_rhs(tt: float, xx: np.ndarray, uu: np.ndarray) -> np.ndarray:
        return np.asarray(sys.dynamics(tt, xx, uu, p), dtype=float).reshape(-1)

    X = np.full((n, N), np.nan)
    Y = np.full((q, N), np.nan)
    Yh = np.full((q, N), np.nan)
    Uc = np.full((m, N), np.nan)
    y_op = sig["y_op"]
    diverged_at = None
    ua = np.zeros(sys.ninputs)
    for k in range(N):
        X[:, k] = x
        # reading at t_k (the applied input of the previous interval for a feedthrough)
        ua_prev = ua.copy()
        y0 = np.asarray(sys.output(t[k], x, ua_prev, params=p), dtype=float).reshape(-1)
        y0 = y0 + Dphi @ phi[:, k] + V[:, k]
        Yh[:, k] = y0
        y = y0.copy()
        for i, mask, eta, lam, holds in sp:
            if mask[k]:
                if holds:
                    if (i, id(mask)) not in held_act:
                        held_act[(i, id(mask))] = y[i]  # type: ignore[index]
                    y[i] = held_act[(i, id(mask))]  # type: ignore[index]
                else:
                    y[i] = eta[k] * y[i] + lam[k]
        Y[:, k] = y
        uc = U[:, k].copy()
        if K is not None:
            uc = uc - K @ (x - x_op)
        elif Cc is not None:
            uc = uc + Cc @ xc + Dc @ (y - y_op)
        Uc[:, k] = uc
        if k == N - 1:
            break
        ap = uc.copy()
        for f, mask in zip(act, act_masks, strict=True):
            if mask[k]:
                ap[f.actuator] = f._applied(t[k : k + 1], ap[f.actuator : f.actuator + 1])[0]
                if f.kind == "stuck" and getattr(f, "value", 0) is None:
                    key = (-1 - f.actuator, id(mask))
                    held_act.setdefault(key, ap[f.actuator])  # type: ignore[arg-type]
                    ap[f.actuator] = held_act[key]  # type: ignore[index]
        ua = np.zeros(sys.ninputs)
        ua[known] = ap
        ua[other] = Dx[:, k]
        extra = Bphi @ phi[:, k] + Wn[:, k]
        h = (t[k + 1] - t[k]) / substeps
        ey = y - y_op
        z = np.concatenate([x, xc])
        for r in range(substeps):
            z = _rk4(f_rhs, t[k] + r * h, z, h, n, ua, extra, (Ac, Bc, ey))
        x, xc = z[:n], z[n:]
        if not np.all(np.isfinite(x)) or np.max(np.abs(x - x_op)) > bound:
            diverged_at = float(t[k + 1])
            break
    if diverged_at is not None:
        warnings.warn(
            f"the run diverged at t = {diverged_at:g} (state non-finite or beyond "
            f"max |x - x_op| <= {bound:g}); it was stopped there, no decisions after it",
            DivergenceWarning,
            stacklevel=2,
        )
    res = evaluate(
        bank,
        Y,
        Uc,
        t,
        threshold=threshold,
        persistence=persistence,
        detection_window=detection_window,
    )
    from geomfdi.evaluation.decision import detection_events
    from geomfdi.simulation.context import detection_window_of

    cols = structure_columns(fl, bank.faults, design)
    window = detection_window_of(detection_window)
    events = detection_events(t, res.alarms, res.isolated, fl, cols,
                              window=window, suspects=res.suspects)  # fmt: skip
    return SimulationResult(
        t=t,
        x=X,
        y=Y,
        y_healthy=Yh,
        u=Uc,
        residuals=res.residuals,
        residual_vectors=[None] * len(res.residual_labels),
        alarms=res.alarms,
        isolated=res.isolated,
        candidates=res.candidates,
        suspects=res.suspects,
        threshold=res.threshold,
        events=events,
        faults=fl,
        structure=res.structure,
        requested=getattr(bank, "requested", None),
        fault_labels=res.fault_labels,
        residual_labels=res.residual_labels,
        info={
            "nonlinear": True,
            "diverged": diverged_at is not None,
            "diverged_at": diverged_at,
            "bound": bound,
            "substeps": substeps,
            "signals": {**info_sig, "y_op": [0.0] * q, "u_op": [0.0] * m},
        },
        persistence=res.persistence,
        vector_rows=[False] * len(res.residual_labels),
    )
