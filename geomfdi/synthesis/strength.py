"""Strength of detection in units that do not matter: fault reference sizes.

See the user guide, *Synthesis* (``docs/guide/synthesis.md``, "Strength and reference
sizes").

A residual "sees a target weakly" (strong detectability, Varga 2017, Section 3.5) when its
DC gain from that target is below ``FD_GAIN_TOL`` times its largest gain from any fault.
Gains per unit fault compare faults in different units (a pump flow in m³/s against a
level sensor in m): the verdict would change with the units.  Each fault j therefore
carries a **reference size** ``σ_j`` (``Fault(..., size=...)``), and the verdict compares
``σ_j ‖T_j‖``:

* a state-side or general fault without a size: ``σ_j = 1 / max_ω ‖G_j(iω)‖``, with
  ``G_j(s) = C (sI − A)⁻¹ B_fj + D_fj`` its transfer to the measurements: a fault whose
  largest effect on y is 1 (changing the fault's unit by c changes ``σ_j`` by 1/c);
* a sensor fault on output i without a size: the **sensor's scale**, the largest effect
  on ``y_i`` of the other (non-sensor) faults at their reference sizes (1 when there is
  none): changing the unit of ``y_i`` by c changes it by c.

So ``σ_j ‖T_j‖`` does not change when a fault's or a sensor's unit changes: the same bank
gives the same weak/strong verdicts whatever the units of the model.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi.model.plant import Plant

__all__ = ["reference_sizes", "strength_frequencies"]


def strength_frequencies(omega: float, dt: float) -> np.ndarray:
    """The frequency grid of the strength verdicts: 31 points over ``ω·[1e-3, 1e3]``
    (continuous, ω the plant's time scale) or ``π·[1e-3, 1]`` (discrete)."""
    base = np.pi if dt > 0 else omega
    return base * np.logspace(-3, 0 if dt > 0 else 3, 31)


def _fault_peaks(plant: Plant, sigs: list, omegas: np.ndarray) -> np.ndarray:
    """``max_ω |G_j(iω)|`` per fault and output: shape (faults, q)."""
    n, q = plant.n, plant.q
    out = np.zeros((len(sigs), q))
    if not sigs:
        return out
    Bf = np.hstack([b for b, _ in sigs]) if n else np.zeros((0, sum(d.shape[1] for _, d in sigs)))
    Df = np.hstack([d for _, d in sigs])
    widths = np.cumsum([0, *[d.shape[1] for _, d in sigs]])
    eye = np.eye(n)
    for w in omegas:
        s = np.exp(1j * w) if plant.dt > 0 else 1j * w
        if n:
            try:
                G = plant.C @ np.linalg.solve(s * eye - plant.A, Bf) + Df
            except np.linalg.LinAlgError:
                continue
        else:
            G = Df.astype(complex)
        if not np.all(np.isfinite(G)):
            continue
        for j in range(len(sigs)):
            blk = np.abs(G[:, widths[j] : widths[j + 1]])
            out[j] = np.maximum(out[j], np.max(blk, axis=1) if blk.size else 0.0)
    return out


def reference_sizes(plant: Plant, faults: list[Any], sigs: list, omega: float) -> np.ndarray:
    """Reference size ``σ_j`` of every fault (module Notes): the given ``size`` or the
    default (unit largest effect on y; a sensor fault: its sensor's scale)."""
    from geomfdi.model.faults import SensorFault

    peaks = _fault_peaks(plant, sigs, strength_frequencies(omega, plant.dt))
    sizes = np.ones(len(sigs))
    sensor = [isinstance(f, SensorFault) for f in faults]
    for j, f in enumerate(faults):
        if getattr(f, "size", None) is not None:
            sizes[j] = float(f.size)
        elif not sensor[j]:
            top = float(np.max(peaks[j], initial=0.0))
            sizes[j] = 1.0 / top if top > 0 else 1.0
    for j, f in enumerate(faults):
        if sensor[j] and getattr(f, "size", None) is None:
            effect = [sizes[i] * peaks[i, f.i] for i in range(len(faults)) if not sensor[i]]
            top = max(effect, default=0.0)
            sizes[j] = top if top > 0 else 1.0
    return sizes
