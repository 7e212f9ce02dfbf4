"""Strength of detection in units that do not matter: fault reference sizes.

See the user guide, *Synthesis* (``docs/guide/synthesis.md``, "Strength and reference
sizes").

A residual "sees a target weakly" (strong detectability, Varga 2017, Section 3.5) when its
DC gain from that target is below ``FD_GAIN_TOL`` times its largest gain from any fault.
Gains per unit fault compare faults in different units (a pump flow in m³/s against a
level sensor in m): the verdict would change with the units.  Each fault j therefore
carries a **reference size** ``σ_j`` (``Fault(..., size=...)``), and the verdict compares
``σ_j ‖T_j‖``:

* state-side or general faults without a size: the sizes that balance their peak
  effects ``P_ij = max_ω |G_ij(iω)|`` on the measurements
  (``G_j(s) = C (sI − A)⁻¹ B_fj + D_fj``): ``σ_j = e^{γ_j}`` with ``ρ_i + γ_j ≈ −log P_ij``
  in the least-squares sense (changing the fault's unit by c changes ``σ_j`` by 1/c, an
  output's unit changes nothing);
* a sensor fault on output i without a size: the **sensor's scale**, the typical
  (geometric-mean) effect on ``y_i`` of the other faults at their reference sizes (1
  when none reaches it): changing the unit of ``y_i`` by c changes it by c.

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
    state = bool(n) and bool(np.any(Bf))  # pure sensor faults: G = Df, nothing to solve
    for w in omegas:
        s = np.exp(1j * w) if plant.dt > 0 else 1j * w
        if state:
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
    """Reference size ``σ_j`` of every fault: the given ``size`` or the default.

    With ``P_ij = max_ω |G_ij(iω)|`` (fault j's peak effect on output i) over the faults
    that are not pure sensor faults, the defaults solve the log-balancing least-squares
    problem ``ρ_i + γ_j ≈ −log P_ij`` (over the non-zero entries) and take
    ``σ_j = e^{γ_j}``; a sensor fault on output i gets the sensor's scale
    ``σ = geomean_j(σ_j P_ij)`` (the typical effect of those faults on ``y_i``; 1 when
    none reaches it).  Changing the unit of a fault by b or of an output by a changes
    the balancing solution by ``1/b`` and ``a`` (up to one common factor of every size,
    which no verdict sees), so verdicts built on ``σ_j ‖T_j‖`` do not depend on units.
    """
    from geomfdi.model.faults import SensorFault

    peaks = _fault_peaks(plant, sigs, strength_frequencies(omega, plant.dt))
    nf = len(sigs)
    sensor = np.array([isinstance(f, SensorFault) for f in faults], dtype=bool)
    given = [getattr(f, "size", None) for f in faults]
    sizes = np.ones(nf)
    act = np.flatnonzero(~sensor)
    P = peaks[act].T  # outputs × state-side faults
    top = float(np.max(P, initial=0.0))
    mask = P > 1e-12 * top if top > 0 else np.zeros(P.shape, dtype=bool)
    if np.any(mask):
        q = P.shape[0]
        ii, jj = np.nonzero(mask)
        X = np.zeros((ii.size, q + act.size))
        X[np.arange(ii.size), ii] = 1.0
        X[np.arange(ii.size), q + jj] = 1.0
        sol = np.linalg.lstsq(X, -np.log(P[ii, jj]), rcond=None)[0]
        gamma = sol[q:]
        seen = np.any(mask, axis=0)
        sizes[act[seen]] = np.exp(gamma[seen] - np.mean(gamma[seen]))
    for j in act:
        if given[j] is not None:
            sizes[j] = float(given[j])
    for j in np.flatnonzero(sensor):
        if given[j] is not None:
            sizes[j] = float(given[j])
            continue
        eff = sizes[act] * peaks[act, faults[j].i] if act.size else np.zeros(0)
        eff = eff[eff > 1e-12 * max(float(np.max(eff, initial=0.0)), 1e-300)]
        sizes[j] = float(np.exp(np.mean(np.log(eff)))) if eff.size else 1.0
    return sizes
