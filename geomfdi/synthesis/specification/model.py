"""The model every specification analysis works on: checked, column-normalised, with quotients.

See the user guide, *Theory: achievable signatures* (``docs/theory/achievable-signatures.md``).

A residual's fault signature does not change when a fault signal, a disturbance or a
measurement is given in other units: each output row of ``[C D Dd Df]`` (on the balanced
state) and then each fault's signature ``[B_f; D_f]`` and each disturbance column
``[B_d; D_d]`` are scaled to unit norm here, and the state is balanced as in the design's
quotient step (:func:`quotient_of`), so that a badly scaled plant and a well-scaled one
meet the same rank decisions and the same strong gains.  Every decision of the analysis is taken on
the quotient of the decoupled signals (S*), as in the design (Varga 2017, §3.5: the
normal-rank conditions of fault detectability; here in their geometric form).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from geomfdi.errors import GeomFDIError
from geomfdi.geometry.balancing import state_scaling
from geomfdi.geometry.subspace import _norm2
from geomfdi.model.faults import Fault, fault_matrices
from geomfdi.model.plant import Plant, as_plant
from geomfdi.synthesis.construction import fault_list

__all__ = ["SpecModel", "spec_model", "quotient_of", "IDENTITY_TOL"]

IDENTITY_TOL = 1e-8
"""Largest relative residual of the quotient identities accepted (the design's bound)."""


@dataclass(frozen=True)
class SpecModel:
    """A plant and its faults prepared for the specification analyses."""

    plant: Plant
    """The plant with unit-norm disturbance columns."""
    faults: list[Fault]
    sigs: list[tuple[np.ndarray, np.ndarray]]
    """``(B_f, D_f)`` of each fault, scaled to ``‖[B_f; D_f]‖₂ = 1``."""
    omega: float
    """The plant's frequency scale (:func:`geomfdi.synthesis.least_order.plant_scale`)."""

    @property
    def nf(self) -> int:
        return len(self.sigs)

    @property
    def names(self) -> list[str]:
        """The faults' names, with their index appended where two names coincide."""
        raw = [f.name for f in self.faults]
        return [f"{n} #{j}" if raw.count(n) > 1 else n for j, n in enumerate(raw)]


def _unit_columns(B: np.ndarray, D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    if B.shape[1] == 0:
        return B, D
    nrm = np.linalg.norm(np.vstack([B, D]), axis=0)
    nrm[nrm == 0] = 1.0
    return B / nrm, D / nrm


def _unit_block(B: np.ndarray, D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    nrm = _norm2(np.vstack([B, D]))
    return (B / nrm, D / nrm) if nrm > 0 else (B, D)


def spec_model(plant: Any, faults: Any) -> SpecModel:
    """Check ``plant`` and ``faults`` and return the column-normalised :class:`SpecModel`.

    Raises
    ------
    GeomFDIError
        ``argument="plant"`` or ``"faults"`` for bad input (an empty fault list, a fault
        whose signature does not fit the plant, a fault with a zero signature).
    """
    from geomfdi.synthesis.least_order.search import plant_scale

    plant = as_plant(plant, static=True)
    flist = fault_list(faults)
    raw = fault_matrices(flist, plant.n, plant.q)
    for k, (Bf, Df) in enumerate(raw):
        if not np.any(Bf) and not np.any(Df):
            raise GeomFDIError(
                f"faults[{k}]: the fault {flist[k].name!r} has a zero signature (Bf = 0, Df = 0)",
                argument="faults",
            )
    # outputs in comparable units: each row of [C D Dd Df] (state balanced) to unit norm
    n = plant.n
    cols = [M for M in (plant.B, plant.Bd, *[Bf for Bf, _ in raw]) if M.size]
    d = state_scaling(plant.A, np.hstack(cols) if cols else np.zeros((n, 0)), plant.C)
    rows = np.hstack([plant.C * d[None, :], plant.D, plant.Dd, *[Df for _, Df in raw]])
    w = np.linalg.norm(rows, axis=1)
    w[~(w > 0)] = 1.0
    sigs = [_unit_block(Bf, Df / w[:, None]) for Bf, Df in raw]
    Bd, Dd = _unit_columns(plant.Bd, plant.Dd / w[:, None])
    scaled = Plant(
        plant.A, plant.B, plant.C / w[:, None], plant.D / w[:, None], plant.dt, Bd=Bd, Dd=Dd
    )
    return SpecModel(scaled, flist, sigs, plant_scale(plant.A, plant.dt))


def quotient_of(model: SpecModel, target: tuple[int, ...], decouple: tuple[int, ...]) -> Any:
    """The decoupled quotient of the row seeing ``target`` and ignoring ``decouple`` (and the
    disturbances), formed as the design forms it: the state balanced over every input-side
    column (:func:`geomfdi.geometry.balancing.state_scaling`), then
    :func:`geomfdi.synthesis.least_order.quotient.quotient_model`.  ``None`` when the
    quotient's identities fail (the rank decisions behind S* are ill-conditioned)."""
    from geomfdi.synthesis.least_order.quotient import quotient_model

    p, sigs = model.plant, model.sigs
    n = p.n
    cols = [M for M in (p.B, p.Bd, *[Bf for Bf, _ in sigs]) if M.size]
    d = state_scaling(p.A, np.hstack(cols) if cols else np.zeros((n, 0)), p.C)
    Ab = p.A * d[None, :] / d[:, None]
    Bw = np.hstack([p.Bd / d[:, None], *[sigs[j][0] / d[:, None] for j in decouple]])
    Dw = np.hstack([p.Dd, *[sigs[j][1] for j in decouple]])
    tg = [(sigs[j][0] / d[:, None], sigs[j][1]) for j in target]
    Qm = quotient_model(Ab, p.B / d[:, None], p.C * d[None, :], p.D, Bw, Dw, tg)
    if any(v > IDENTITY_TOL for v in Qm.identities.values()):
        return None
    return Qm
