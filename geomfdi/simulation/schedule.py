"""A fault list checked once against the plant: :class:`FaultSchedule`.

``simulate`` validates the user's list into a schedule and every later step reads it:
the sensor faults (composed on the readings), the additive faults (extra input channels
of the plant, see :mod:`geomfdi.simulation.input_faults`), and the structure column of
the bank that models each fault (matched by signature).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from geomfdi.errors import GeomFDIError
from geomfdi.model.plant import Plant
from geomfdi.simulation.input_faults import InputFaultSignal
from geomfdi.simulation.signals import FaultSignal, SensorFaultSignal, validate_faults

__all__ = ["FaultSchedule", "fault_schedule", "input_channels", "structure_columns"]

_KINDS = "GainFault, BiasFault, StuckFault, ActuatorGainFault, ActuatorBiasFault, " + (
    "ActuatorStuckFault or AdditiveFault"
)


@dataclass(frozen=True)
class FaultSchedule:
    """The simulated faults of one run, checked against the plant.

    Attributes
    ----------
    faults : tuple of FaultSignal
        Every fault, in the user's order (events are reported in this order).
    sensor : list of SensorFaultSignal
        The sensor faults (composed on the readings in list order).
    inputs : list of InputFaultSignal
        The additive faults (actuator and general).
    """

    faults: tuple[FaultSignal, ...]
    sensor: list[SensorFaultSignal]
    inputs: list[InputFaultSignal]

    @property
    def needs_input(self) -> bool:
        """Some fault depends on the commanded input (gain/stuck actuator)."""
        return any(f.needs_input for f in self.inputs)


def fault_schedule(faults: Any, plant: Plant, *, argument: str = "faults") -> FaultSchedule:
    """Validate a fault list (one signal, a sequence, or None) into a :class:`FaultSchedule`."""
    if isinstance(faults, FaultSignal):
        faults = [faults]
    if faults is None:
        faults = []
    if not isinstance(faults, Sequence) or isinstance(faults, str):
        raise GeomFDIError(
            f"{argument}: must be a list of {_KINDS}, got {type(faults).__name__}",
            argument=argument,
        )
    for k, f in enumerate(faults):
        if not isinstance(f, FaultSignal):
            raise GeomFDIError(
                f"{argument}[{k}]: expected {_KINDS}, got {type(f).__name__}", argument=argument
            )
    from geomfdi.simulation.physical import deviation_faults

    faults = deviation_faults(faults, plant)  # output names; gains on the physical reading
    sensor = validate_faults(
        [f for f in faults if isinstance(f, SensorFaultSignal)], plant.q, argument=argument
    )
    inputs = [f for f in faults if isinstance(f, InputFaultSignal)]
    for k, f in enumerate(faults):
        if isinstance(f, InputFaultSignal):
            try:
                f.signature(plant)
            except GeomFDIError as exc:
                raise GeomFDIError(f"{argument}[{k}]: {exc}", argument=argument) from exc
    return FaultSchedule(tuple(faults), sensor, inputs)


def input_channels(
    schedules: Sequence[FaultSchedule], plant: Plant, t: np.ndarray, u: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The additive faults of several runs as extra plant input channels.

    Faults with the same signature share one channel (a sweep of fault sizes adds one
    channel, not one per run).

    Returns
    -------
    (Bphi, Dphi, phi) or None
        ``Bphi`` (n, k), ``Dphi`` (q, k), ``phi`` (R, k, N) with ``R`` = 1 when every run
        has the same signals; ``None`` without additive faults.
    """
    if not any(s.inputs for s in schedules):
        return None
    keys: dict[bytes, int] = {}
    sigs: list[tuple[np.ndarray, np.ndarray]] = []
    cols: list[list[tuple[int, InputFaultSignal]]] = []
    for s in schedules:
        run = []
        for f in s.inputs:
            Bf, Df = f.signature(plant)
            key = Bf.tobytes() + b"|" + Df.tobytes() + str(Bf.shape).encode()
            if key not in keys:
                keys[key] = sum(b.shape[1] for b, _ in sigs)
                sigs.append((Bf, Df))
            run.append((keys[key], f))
        cols.append(run)
    k = sum(b.shape[1] for b, _ in sigs)
    N = t.shape[0]
    same = all(
        len(c) == len(cols[0])
        and all(a[0] == b[0] and a[1] is b[1] for a, b in zip(c, cols[0], strict=True))
        for c in cols
    )
    runs = cols[:1] if same else cols
    phi = np.zeros((len(runs), k, N))
    for r, run in enumerate(runs):
        for o, f in run:
            v = f.values(t, u)
            phi[r, o : o + v.shape[0]] += v
    Bphi = np.hstack([b for b, _ in sigs])
    Dphi = np.hstack([d for _, d in sigs])
    return Bphi, Dphi, phi


def _same_span(a: np.ndarray, b: np.ndarray) -> bool:
    """Column spaces of ``a`` and ``b`` equal (relative tolerance 1e-9)."""
    if a.shape[1] == 0 or b.shape[1] == 0:
        return False
    scale = max(np.linalg.norm(a), np.linalg.norm(b), 1e-300)
    tol = 1e-9 * scale

    def rank(m: np.ndarray) -> int:
        return int(np.sum(np.linalg.svd(m, compute_uv=False) > tol))

    ra, rb = rank(a), rank(b)
    return ra == rb == rank(np.hstack([a, b])) and ra > 0


def _channel_key(f: FaultSignal, plant: Plant) -> Any:
    """What a fault's structure column depends on (not its size): the sensor, or the
    signature of an input fault (and its design fault, which it matches by identity)."""
    if isinstance(f, SensorFaultSignal):
        return ("sensor", f.sensor)
    if isinstance(f, InputFaultSignal) and getattr(f, "fault", None) is not None:
        return ("fault", id(f.fault))  # an additive fault: its design fault decides
    if isinstance(f, InputFaultSignal) and hasattr(f, "actuator"):
        return ("actuator", f.actuator)  # the input's column of B and D
    if isinstance(f, InputFaultSignal):
        Bf, Df = f.signature(plant)
        sig = (Bf.shape, Bf.tobytes(), Df.shape, Df.tobytes())
        return ("input", id(getattr(f, "fault", None)), *sig)
    return None


def structure_columns(
    faults: Sequence[FaultSignal],
    design_faults: Sequence[Any],
    plant: Plant,
    cache: dict[Any, Any] | None = None,
) -> list[int | None]:
    """The bank's structure column modelling each simulated fault (None when none does).

    A simulated fault matches the design fault with the same signature ``[Bf; Df]`` (equal
    column spaces): a sensor fault on output ``i`` matches ``SensorFault(i)``, an actuator
    fault on input ``i`` an ``ActuatorFault(B[:, i])``, an ``AdditiveFault(f)`` the design
    fault ``f`` itself (or any fault with its signature).

    ``cache`` (a dict kept by the caller for one bank and plant) holds the column of
    each fault channel met (a sensor, an input signature): the runs of a sweep differ
    only in their sizes, and their columns are matched once.
    """
    if not faults:  # nothing to match: the design signatures are not needed
        return []
    if cache is None:
        return _match_columns(faults, design_faults, plant)
    out: list[int | None] = []
    for f in faults:
        k = _channel_key(f, plant)
        if k is None or k not in cache:
            (j,) = _match_columns([f], design_faults, plant)
            if k is not None:
                cache[k] = j
        else:
            j = cache[k]
        out.append(j)
    return out


def _match_columns(
    faults: Sequence[FaultSignal], design_faults: Sequence[Any], plant: Plant
) -> list[int | None]:
    """:func:`structure_columns` by signature match (SVD rank tests)."""
    designs = []
    for df in design_faults:
        try:
            Bf, Df = df.signatures(plant.n, plant.q)
        except (GeomFDIError, AttributeError):
            designs.append(None)
            continue
        designs.append(np.vstack([Bf, Df]))
    out: list[int | None] = []
    for f in faults:
        if isinstance(f, InputFaultSignal):
            Bf, Df = f.signature(plant)
        elif isinstance(f, SensorFaultSignal):
            Bf = np.zeros((plant.n, 1))
            Df = np.zeros((plant.q, 1))
            Df[f.sensor, 0] = 1.0
        else:
            out.append(None)
            continue
        sig = np.vstack([Bf, Df])
        j = None
        for idx, (df, d) in enumerate(zip(design_faults, designs, strict=True)):
            if getattr(f, "fault", None) is df or (d is not None and _same_span(sig, d)):
                j = idx
                break
        out.append(j)
    return out
