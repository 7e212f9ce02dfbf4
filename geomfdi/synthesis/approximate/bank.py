"""Front end of the approximate synthesis: one AFD row, an AFDI bank, several models.

Called by :func:`geomfdi.design_residual_generator` and :func:`geomfdi.design_bank` with
``objective="gap"`` (the default when the plant has noise inputs, ``plant.nw > 0``).  See
the user guide, *Approximate synthesis* (``docs/guide/approximate-synthesis.md``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from geomfdi.errors import DesignError, GeomFDIError, NotIsolableError, ShapeError
from geomfdi.generators.generator import ResidualBank, ResidualGenerator
from geomfdi.model.faults import Fault, fault_matrices
from geomfdi.model.plant import Plant
from geomfdi.synthesis.approximate.gap_design import gap_design
from geomfdi.synthesis.approximate.measure import hinf
from geomfdi.synthesis.approximate.multimodel import robust_gap_design
from geomfdi.synthesis.approximate.nullspace import channel, noise_channel

__all__ = ["noise_channel", "gap_residual_generator", "gap_bank", "fault_norms"]

STRUCTURE_TOL = 1e-8


def fault_norms(
    g: ResidualGenerator, plant: Plant, sigs: list[tuple[np.ndarray, np.ndarray]]
) -> np.ndarray:
    """``‖R_fj‖∞`` for every fault ``j`` of the design."""
    return np.array([hinf(*channel(g, plant.A, Bf, plant.C, Df), plant.dt) for Bf, Df in sigs])


def _indices(target: Any, decouple: Any, nf: int) -> tuple[tuple[int, ...], tuple[int, ...]]:
    from geomfdi.synthesis.construction import target_decouple

    return target_decouple(target, decouple, nf)


def gap_residual_generator(
    plant: Plant,
    faults: Sequence[Fault],
    target: Any,
    *,
    decouple: Any = None,
    poles: Any = None,
    residual_dim: int | None = None,
    regularization: float | None = None,
    models: Sequence[Plant] | None = None,
    band: Any = None,
) -> ResidualGenerator:
    """One AFD row (see :func:`geomfdi.design_residual_generator` with ``objective="gap"``)."""
    faults = list(faults)
    tgt, dec = _indices(target, decouple, len(faults))
    if models is not None:
        if band is not None:
            raise DesignError(
                "band: the multi-model design maximises the H∞ gap; give no band with models",
                argument="band",
            )
        fam = check_models(models, plant)
        fam = [plant, *[m for m in fam if m is not plant]]
        return robust_gap_design(
            fam,
            faults,
            tgt,
            dec,
            poles=poles,
            residual_dim=residual_dim,
            regularization=regularization,
        )
    Bw, Dw = noise_channel(plant)
    sigs = fault_matrices(faults, plant.n, plant.q)
    return gap_design(
        plant,
        faults,
        sigs,
        tgt,
        dec,
        Bw,
        Dw,
        poles=poles,
        residual_dim=residual_dim,
        regularization=regularization,
        band=band,
    )


def check_models(models: Any, plant: Plant | None) -> list[Plant]:
    """The model list: plants of equal dimensions and sampling period."""
    if isinstance(models, Plant) or not isinstance(models, Sequence) or not models:
        raise GeomFDIError("models: give a non-empty list of plants", argument="models")
    ms = list(models)
    ref = plant if plant is not None else ms[0]
    for k, m in enumerate(ms):
        if not isinstance(m, Plant):
            raise GeomFDIError(f"models: entry {k} is not a Plant", argument="models")
        dims = (m.n, m.m, m.q, m.nd, noise_channel(m)[0].shape[1], m.dt)
        want = (ref.n, ref.m, ref.q, ref.nd, noise_channel(ref)[0].shape[1], ref.dt)
        if dims != want:
            raise ShapeError(
                f"models: entry {k} has (n, m, q, nd, nw, dt) = {dims}, expected {want}",
                argument="models",
            )
    return ms


def gap_bank(
    plant: Plant,
    faults: Sequence[Fault],
    structure: Any,
    *,
    poles: Any = None,
    residual_dim: Any = None,
    regularization: float | None = None,
    models: Sequence[Plant] | None = None,
    band: Any = None,
) -> ResidualBank:
    """AFDI: one gap-maximising row per structure row (Varga 2017, §5.5, Procedure AFDI).

    Row ``r`` sees the faults with ``structure[r, j] = 1`` and decouples the others exactly;
    ``generators[r].info["gap"]`` is its gap, ``bank.info["gaps"]`` the list.  With
    ``models``, every row is the robust design of
    :func:`~geomfdi.synthesis.approximate.multimodel.robust_gap_design` and
    ``bank.info["model_gaps"]`` holds the gap per row and model.
    """
    faults = list(faults)
    nf = len(faults)
    req = np.atleast_2d(np.asarray(structure))
    if req.ndim != 2 or req.shape[1] != nf:
        raise ShapeError(
            f"structure: expected shape (rows, {nf}), got {np.shape(structure)}",
            argument="structure",
        )
    req = req.astype(bool)
    rows = req.shape[0]
    if (
        poles is not None
        and isinstance(poles, Sequence)
        and poles
        and all(p is None or (isinstance(p, Sequence) and not isinstance(p, str)) for p in poles)
        and len(poles) == rows
    ):
        per_row = list(poles)
    else:
        per_row = [poles] * rows
    dims = residual_dim if isinstance(residual_dim, Sequence) else [residual_dim] * rows
    if len(dims) != rows:
        raise DesignError(
            f"residual_dim: expected one entry per row ({rows}), got {len(dims)}",
            argument="residual_dim",
        )
    if models is not None:
        models = check_models(models, plant)
    sigs = fault_matrices(faults, plant.n, plant.q)
    gens: list[ResidualGenerator | None] = []
    diags: list[str] = []
    achieved = np.zeros_like(req)
    for r in range(rows):
        tgt = tuple(int(j) for j in np.flatnonzero(req[r]))
        dec = tuple(int(j) for j in np.flatnonzero(~req[r]))
        if not tgt:
            gens.append(None)
            diags.append("missing: the row requests no fault")
            continue
        try:
            g = gap_residual_generator(
                plant,
                faults,
                tgt,
                decouple=dec,
                poles=per_row[r],
                residual_dim=dims[r],
                regularization=regularization,
                models=models,
                band=band,
            )
        except (NotIsolableError, DesignError) as exc:
            if getattr(exc, "argument", None) in ("poles", "regularization", "band"):
                raise
            gens.append(None)
            diags.append(f"missing: {exc}")
            continue
        norms = np.zeros(nf)
        norms[list(dec)] = fault_norms(g, plant, [sigs[j] for j in dec])
        if models is None:
            norms[list(tgt)] = g.info["fault_norms"]
        else:
            norms[list(tgt)] = fault_norms(g, plant, [sigs[j] for j in tgt])
        achieved[r] = norms > STRUCTURE_TOL * max(float(norms.max()), 1e-300)
        gens.append(g)
        diags.append("ok")
    cols = [tuple(achieved[:, j]) for j in range(nf)]
    isolable = np.array(
        [any(cols[j]) and all(cols[j] != cols[i] for i in range(nf) if i != j) for j in range(nf)]
    )
    info: dict[str, Any] = {
        "objective": "gap",
        "gaps": [None if g is None else g.info["gap"] for g in gens],
        "total_order": sum(g.order for g in gens if g is not None),
        "signals": plant.signal_info(),  # names and operating point for deployment
    }
    if models is not None:
        info["model_gaps"] = [None if g is None else g.info["model_gaps"] for g in gens]
        info["nominal_model_gaps"] = [
            None if g is None else g.info["nominal_model_gaps"] for g in gens
        ]
    return ResidualBank(gens, req, achieved, isolable, diags, faults, plant.dt, "gap", info)
