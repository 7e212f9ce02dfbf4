"""Fault descriptions for design: where a fault enters the plant.

A fault is an additive signal ``f`` entering as ``x' = ... + Bf f`` and
``y = ... + Df f``.  A sensor fault on output ``i`` (0-based) is ``Bf = 0``,
``Df = e_i``: every gain, bias or stuck fault is such an additive output fault
``phi_i = (eta_i - 1) C_i x + lambda_i`` on the *measured* y, since a residual generator
only sees the measured y (the first correction to Hou, Wen & Chen 2011 in the user guide,
*Theory: errata*, ``docs/theory/errata.md``; see also *Theory: sensor-fault transforms*,
``docs/theory/sensor-fault-transforms.md``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi._validation import as_index, as_matrix, as_name, as_positive
from geomfdi.errors import GeomFDIError, ShapeError

__all__ = ["Fault", "SensorFault", "ActuatorFault", "fault_matrices", "bind_faults"]


def _fault_size(size: Any) -> float | None:
    """A fault's reference size: ``None`` (default, see :class:`Fault`) or a number > 0."""
    return None if size is None else as_positive(size, "size")


def _fault_name(name: Any, default: str) -> str:
    """A fault's label: ``default`` for ``None`` or ``""``, else checked text."""
    if name is None or (isinstance(name, str) and not name):
        return default
    return as_name(name, "name")


class Fault:
    """General additive fault ``x' = ... + Bf f``, ``y = ... + Df f``.

    Parameters
    ----------
    Bf : array_like, (n, k) or None
        State-side signature (``None``: zero).
    Df : array_like, (q, k) or None
        Output-side signature (``None``: zero).
    name : str, optional
        Label used in reports and plots.
    size : float, optional
        Reference size of the fault signal, in its own units (e.g. the smallest fault to
        be detected): strength verdicts ("weak") compare the residual's responses to
        faults of these sizes, so they do not depend on units.  Default (``None``): the
        sizes that balance the faults' peak effects on the measurements over frequency
        (:func:`geomfdi.synthesis.strength.reference_sizes`).
    """

    size: float | None = None

    def __init__(
        self, Bf: Any = None, Df: Any = None, *, name: str | None = None, size: Any = None
    ) -> None:
        if Bf is None and Df is None:
            raise GeomFDIError("Bf, Df: at least one must be given", argument="Bf")
        self._Bf = None if Bf is None else as_matrix(Bf, "Bf", vector_as="column")
        self._Df = None if Df is None else as_matrix(Df, "Df", vector_as="column")
        if self._Bf is not None and self._Df is not None and self._Bf.shape[1] != self._Df.shape[1]:
            raise ShapeError(
                f"Df: expected {self._Bf.shape[1]} columns (as many as Bf), got {self._Df.shape}",
                argument="Df",
            )
        self.name = _fault_name(name, "fault")
        self.size = _fault_size(size)

    @property
    def k(self) -> int:
        """Number of fault signal components."""
        return (self._Bf if self._Bf is not None else self._Df).shape[1]

    def signatures(
        self, n: int, q: int, *, argument: str = "fault"
    ) -> tuple[np.ndarray, np.ndarray]:
        """``(Bf, Df)`` as (n, k) and (q, k) arrays, checked against the plant's sizes."""
        k = self.k
        Bf = np.zeros((n, k)) if self._Bf is None else self._Bf
        Df = np.zeros((q, k)) if self._Df is None else self._Df
        if Bf.shape[0] != n:
            raise ShapeError(
                f"{argument}: state signature has {Bf.shape[0]} rows, the plant has {n} states",
                argument=argument,
            )
        if Df.shape[0] != q:
            raise ShapeError(
                f"{argument}: output signature has {Df.shape[0]} rows, the plant has {q} outputs",
                argument=argument,
            )
        return Bf, Df

    @property
    def has_output_part(self) -> bool:
        return self._Df is not None and bool(np.any(self._Df != 0))

    def __repr__(self) -> str:
        return f"Fault(name={self.name!r}, k={self.k})"


class SensorFault(Fault):
    """Additive fault on sensor (output) ``i``: ``Bf = 0``, ``Df = e_i``.

    ``i`` is a 0-based index or an output name of the plant (``SensorFault("level 1")``);
    a name is resolved when the fault meets the plant (:func:`bind_faults`, done by the
    design functions), and the fault is then named after the output unless ``name`` is
    given.  ``size``: reference size in the sensor's units; default: the sensor's scale
    (the typical effect on output ``i`` of the other faults at their reference sizes, see
    :func:`geomfdi.synthesis.strength.reference_sizes`).
    """

    def __init__(self, i: int | str, *, name: str | None = None, size: Any = None) -> None:
        self._given_name = name is not None and name != ""
        self.size = _fault_size(size)
        if isinstance(i, str):
            if not i.strip():
                raise GeomFDIError("i: an output name must not be empty", argument="i")
            self.i: int | None = None
            self.output: str | None = i.strip()
            self.name = _fault_name(name, self.output)
            self._Bf = None
            self._Df = None
            return
        if isinstance(i, bool) or not isinstance(i, int | np.integer) or i < 0:
            raise GeomFDIError(
                f"i: sensor index must be an integer >= 0 or an output name, got {i!r}",
                argument="i",
            )
        self.i = int(i)
        self.output = None
        self.name = _fault_name(name, f"sensor {self.i}")
        self._Bf = None
        self._Df = None

    def __eq__(self, other: object) -> bool:
        return isinstance(other, SensorFault) and other.i == self.i and other.output == self.output

    def __hash__(self) -> int:
        return hash(("SensorFault", self.i, self.output))

    @property
    def k(self) -> int:
        return 1

    def signatures(
        self, n: int, q: int, *, argument: str = "fault"
    ) -> tuple[np.ndarray, np.ndarray]:
        if self.i is None:
            raise GeomFDIError(
                f"{argument}: the sensor fault on output {self.output!r} is not bound to a "
                "plant; design with the plant (or gf.bind_faults(plant, faults)) so that its "
                "name is resolved",
                argument=argument,
            )
        as_index(self.i, f"{argument}.i", q)
        Df = np.zeros((q, 1))
        Df[self.i, 0] = 1.0
        return np.zeros((n, 1)), Df

    @property
    def has_output_part(self) -> bool:
        return True

    def __repr__(self) -> str:
        return f"SensorFault({self.i if self.i is not None else self.output!r})"


class ActuatorFault(Fault):
    """Additive state-side fault with signature ``b`` ((n,) or (n, k)); ``size`` as in
    :class:`Fault`."""

    def __init__(self, b: Any, *, name: str | None = None, size: Any = None) -> None:
        super().__init__(
            as_matrix(b, "b", vector_as="column"),
            None,
            name=_fault_name(name, "actuator"),
            size=size,
        )

    def __repr__(self) -> str:
        return f"ActuatorFault(k={self.k}, name={self.name!r})"


def _fault_items(faults: Any, argument: str) -> list[Any]:
    """``faults`` as a list (one fault alone is a list of one)."""
    if isinstance(faults, Fault):
        return [faults]
    try:
        return list(faults)
    except TypeError as exc:
        raise GeomFDIError(
            f"{argument}: must be a list of SensorFault / ActuatorFault / Fault", argument=argument
        ) from exc


def fault_matrices(
    faults: Any, n: int, q: int, *, argument: str = "faults"
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Validate a list of faults and return their ``(Bf, Df)`` signatures."""
    items = _fault_items(faults, argument)
    out = []
    for k, f in enumerate(items):
        if not isinstance(f, Fault):
            raise GeomFDIError(
                f"{argument}[{k}]: expected SensorFault, ActuatorFault or Fault, got "
                f"{type(f).__name__}",
                argument=argument,
            )
        out.append(f.signatures(n, q, argument=f"{argument}[{k}]"))
    return out


def bind_faults(plant: Any, faults: Any, *, argument: str = "faults") -> list[Fault]:
    """``faults`` with every sensor fault resolved against ``plant``'s output names.

    A :class:`SensorFault` given by output name gets its index; on a plant with named
    outputs a sensor fault without its own ``name`` is named after its output.  Other
    faults are returned as they are.  Raises :class:`GeomFDIError` naming the fault for an
    unknown output name.
    """
    items = _fault_items(faults, argument)
    outputs = getattr(plant, "outputs", None)
    named = bool(getattr(plant, "named", False))
    out: list[Fault] = []
    for k, f in enumerate(items):
        if not isinstance(f, SensorFault) or outputs is None or (f.i is not None and not named):
            out.append(f)
            continue
        i = f.i if f.i is not None else plant.output_index(f.output, f"{argument}[{k}]")
        if f._given_name or i >= len(outputs):
            label = f.name
        else:
            label = outputs[i]
        out.append(SensorFault(i, name=label, size=f.size))
    return out
