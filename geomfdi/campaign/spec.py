"""What a Monte-Carlo campaign varies: fault scenarios (sizes, onsets) and plant models."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from geomfdi._validation import as_int, as_positive
from geomfdi.errors import GeomFDIError

__all__ = ["Scenario", "Uncertainty"]


def _numbers(values: Any, name: str) -> tuple[float, ...]:
    arr = np.atleast_1d(np.asarray(values, dtype=float))
    if arr.ndim != 1 or arr.size == 0 or not np.all(np.isfinite(arr)):
        raise GeomFDIError(f"{name}: expected a non-empty list of finite numbers", argument=name)
    return tuple(float(v) for v in arr)


class _SensorFaults:
    """``(size, onset) -> [fault]`` for one sensor fault kind (picklable)."""

    def __init__(self, kind: str, sensor: int) -> None:
        self.kind, self.sensor = kind, sensor

    def __call__(self, size: float, onset: float) -> list[Any]:
        from geomfdi.simulation.signals import BiasFault, GainFault

        if self.kind == "bias":
            return [BiasFault(self.sensor, start=onset, bias=size)]
        return [GainFault(self.sensor, start=onset, gain=1.0 + size)]


class _SizedFaults:
    """``(size, onset) -> [fault]`` of one fault kind on one channel (picklable).

    Sensor and actuator ``gain``: ``gain = 1 + size``; ``bias``: ``bias = size``;
    ``stuck``: held at ``value = size`` (size 0: no fault); ``additive``: the design fault
    ``fault`` as a step of height ``size`` (size 0: no fault).
    """

    KINDS = ("gain", "bias", "stuck", "actuator gain", "actuator bias", "actuator stuck",
             "additive")  # fmt: skip

    def __init__(self, kind: str, channel: Any, fault: Any = None) -> None:
        self.kind, self.channel, self.fault = kind, channel, fault

    def __call__(self, size: float, onset: float) -> list[Any]:
        from geomfdi.simulation import input_faults as inf
        from geomfdi.simulation import signals as sig

        k, c = self.kind, self.channel
        if k in ("stuck", "actuator stuck", "additive") and size == 0:
            return []
        if k == "additive":
            return [inf.AdditiveFault(self.fault, start=onset, size=size)]
        if k == "stuck":
            return [sig.StuckFault(c, start=onset, value=size)]
        if k == "actuator stuck":
            return [inf.ActuatorStuckFault(c, start=onset, value=size)]
        if k == "actuator gain":
            return [inf.ActuatorGainFault(c, start=onset, gain=1.0 + size)]
        if k == "actuator bias":
            return [inf.ActuatorBiasFault(c, start=onset, bias=size)]
        return _SensorFaults(k, c)(size, onset)


@dataclass
class Scenario:
    """One fault scenario of a campaign, swept over fault sizes and onset times.

    Parameters
    ----------
    name : str
    faults : callable ``(size, onset) -> list of fault signals``
        Builds the faults of one run (any fault signal :func:`geomfdi.simulate_batch`
        accepts).  Size 0 should give a fault-free run (it measures the false-alarm
        probability over the detection window).
    sizes : sequence of float
    onsets : sequence of float

    Examples
    --------
    >>> import geomfdi as gf
    >>> sc = gf.Scenario.sensor("bias", 1, sizes=[0.0, 0.05], onsets=[4.0])
    >>> sc.faults(0.05, 4.0)[0].bias
    0.05
    """

    name: str
    faults: Callable[[float, float], list[Any]]
    sizes: Sequence[float] = (1.0,)
    onsets: Sequence[float] = (0.0,)

    def __post_init__(self) -> None:
        if not callable(self.faults):
            raise GeomFDIError(
                "faults: must be a callable (size, onset) -> list", argument="faults"
            )
        self.sizes = _numbers(self.sizes, "sizes")
        self.onsets = _numbers(self.onsets, "onsets")

    @classmethod
    def sensor(
        cls,
        kind: str,
        sensor: int,
        sizes: Sequence[float],
        onsets: Sequence[float],
        name: str | None = None,
    ) -> Scenario:
        """A sensor bias (``bias = size``) or gain (``gain = 1 + size``) fault."""
        if kind not in ("bias", "gain"):
            raise GeomFDIError(f"kind: must be 'bias' or 'gain', got {kind!r}", argument="kind")
        s = as_int(sensor, "sensor", minimum=0)
        return cls(name or f"{kind} on sensor {s}", _SensorFaults(kind, s), sizes, onsets)

    @classmethod
    def of_kind(
        cls,
        kind: str,
        channel: Any,
        sizes: Sequence[float],
        onsets: Sequence[float],
        name: str | None = None,
    ) -> Scenario:
        """A scenario of any fault kind, swept over ``size`` (picklable, for workers).

        ``kind``: ``"gain"``, ``"bias"``, ``"stuck"`` on sensor ``channel`` (an index or
        the plant's output name); ``"actuator gain"``, ``"actuator bias"``,
        ``"actuator stuck"`` on input ``channel``; ``"additive"`` with ``channel`` a design
        :class:`~geomfdi.Fault` driven by a step of height ``size``.  Gains are
        ``1 + size``, biases ``size``, stuck values ``size`` (a stuck or additive fault of
        size 0 is no fault).
        """
        if kind not in _SizedFaults.KINDS:
            raise GeomFDIError(
                f"kind: one of {list(_SizedFaults.KINDS)}, got {kind!r}", argument="kind"
            )
        fault = channel if kind == "additive" else None
        label = getattr(channel, "name", channel)
        return cls(name or f"{kind} on {label}", _SizedFaults(kind, channel, fault), sizes,
                   onsets)  # fmt: skip


@dataclass
class Uncertainty:
    """Plant models of a campaign: random entry-wise perturbations or a given list.

    Parameters
    ----------
    relative : float
        Each entry of the matrices named in ``matrices`` is multiplied by ``1 + relative u``
        with ``u`` uniform on ``[-1, 1]`` (zero entries stay zero).
    samples : int
        Number of perturbed models (model ``i`` drawn from child ``i`` of
        ``SeedSequence(seed)``).
    matrices : tuple of str
        Among ``"A", "B", "C", "D", "Bd", "Dd"``.
    models : list of Plant, optional
        Linearised models to use instead (the bank stays the one designed on the nominal
        plant).
    seed : int
    """

    relative: float = 0.0
    samples: int = 1
    matrices: tuple[str, ...] = ("A", "B")
    models: list[Any] | None = None
    seed: int = 0
    _allowed: tuple[str, ...] = field(
        default=("A", "B", "C", "D", "Bd", "Dd", "Bw", "Dw"), repr=False
    )

    def __post_init__(self) -> None:
        from geomfdi.limits import check_runs

        as_positive(self.relative, "relative", strict=False)
        as_int(self.samples, "samples", minimum=1)
        check_runs(self.samples, argument="samples")  # (a model is at least one run)
        for mname in self.matrices:
            if mname not in self._allowed:
                raise GeomFDIError(
                    f"matrices: unknown matrix {mname!r} (one of {self._allowed})",
                    argument="matrices",
                )

    def plants(self, nominal: Any) -> list[Any]:
        """The campaign's plant models (perturbations of ``nominal`` or ``models``)."""
        from geomfdi.model.plant import Plant, as_plant

        nominal = as_plant(nominal)
        if self.models is not None:
            out = [as_plant(m, f"models[{i}]") for i, m in enumerate(self.models)]
            for i, m in enumerate(out):
                if (m.n, m.m, m.q, m.nd, m.dt) != (
                    nominal.n,
                    nominal.m,
                    nominal.q,
                    nominal.nd,
                    nominal.dt,
                ):
                    raise GeomFDIError(
                        f"models[{i}]: dimensions or dt differ from the nominal plant",
                        argument="models",
                    )
            return out
        root = np.random.SeedSequence(self.seed)
        out = []
        for i in range(self.samples):
            rng = np.random.default_rng(root.spawn(self.samples)[i])
            mats = {}
            for mname in ("A", "B", "C", "D", "Bd", "Dd", "Bw", "Dw"):
                M = np.array(getattr(nominal, mname), dtype=float)
                if mname in self.matrices and M.size:
                    M = M * (1.0 + self.relative * rng.uniform(-1.0, 1.0, M.shape))
                mats[mname] = M
            out.append(
                Plant(
                    mats["A"],
                    mats["B"] if nominal.m else None,
                    mats["C"],
                    mats["D"] if nominal.m else None,
                    Bd=mats["Bd"] if nominal.nd else None,
                    Dd=mats["Dd"] if nominal.nd else None,
                    Bw=mats["Bw"] if nominal.nw else None,
                    Dw=mats["Dw"] if nominal.nw else None,
                    dt=nominal.dt,
                )
            )
        return out
