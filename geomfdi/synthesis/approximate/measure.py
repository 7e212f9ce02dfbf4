"""The numbers a gap design reports: β, γ, the gap and the leaks of a generator on a plant.

``β = min_j ‖R_fj‖∞`` over the target fault columns (Varga's ``H∞−`` index used by his
``fdif2ngap``), ``γ = ‖R_w‖∞``, gap ``= β / γ`` (``inf`` when ``γ = 0``); see *Theory:
approximate synthesis* (``docs/theory/approximate-synthesis.md``).  H∞ norms come from
:func:`geomfdi.generators.norms.hinf_norm`, the routine :func:`geomfdi.fault_to_noise_gap`
uses too (the synthesis never imports :mod:`geomfdi.verification`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from geomfdi.generators.generator import ResidualGenerator
from geomfdi.generators.norms import hinf_norm, hminus_index
from geomfdi.synthesis.approximate.nullspace import channel

__all__ = ["hinf", "GapNumbers", "gap_numbers"]


def hinf(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, dt: float) -> float:
    """H∞ norm of a stable ``(A, B, C, D)`` (0 for an empty channel).

    Computed by :func:`geomfdi.generators.norms.hinf_norm` (the two-step Hamiltonian /
    symplectic-pencil algorithm of Bruinsma & Steinbuch 1990), the routine every geomfdi
    gap measurement uses.
    """
    if B.shape[1] == 0 or C.shape[0] == 0:
        return 0.0
    if A.shape[0] == 0 or not (np.any(B) and np.any(C)):
        return float(np.linalg.norm(D, 2))
    return float(hinf_norm(A, B, C, D, dt, tol=1e-8).value)


def _band_index(A, B, C, D, dt: float, band: tuple[float, float]) -> float:
    """``min_{ω∈band} σ_max`` of one fault's channel (0 for an empty channel)."""
    if B.shape[1] == 0 or C.shape[0] == 0:
        return 0.0
    cols = [list(range(B.shape[1]))]
    return float(hminus_index(A, B, C, D, dt, columns=cols, band=band).value)


@dataclass
class GapNumbers:
    """β, γ, gap and leaks of a generator (absolute H∞ norms)."""

    beta: float
    gamma: float
    gap: float
    fault_norms: list[float]
    leak_u: float
    leak_d: float


def gap_numbers(
    g: ResidualGenerator,
    A: np.ndarray,
    Bu: np.ndarray,
    Bd: np.ndarray,
    Bw: np.ndarray,
    C: np.ndarray,
    Du: np.ndarray,
    Dd: np.ndarray,
    Dw: np.ndarray,
    fault_sigs: list[tuple[np.ndarray, np.ndarray]],
    dt: float,
    band: tuple[float, float] | None = None,
) -> GapNumbers:
    """β, γ and the gap of ``g`` for the given target fault signatures, plus its leaks.

    ``band``: β and the per-fault values are the H₋ index over ``[ω₁, ω₂]``
    (:func:`geomfdi.generators.norms.hminus_index`, ``min_ω σ_max`` of each fault's
    columns) instead of the H∞ norms; γ is always the H∞ norm."""
    if band is None:
        norms = [hinf(*channel(g, A, Bf, C, Df), dt) for Bf, Df in fault_sigs]
    else:
        norms = [_band_index(*channel(g, A, Bf, C, Df), dt, band) for Bf, Df in fault_sigs]
    beta = min(norms) if norms else 0.0
    gamma = hinf(*channel(g, A, Bw, C, Dw), dt) if Bw.shape[1] else 0.0
    gap = float("inf") if gamma == 0 else beta / gamma
    leak_u = hinf(*channel(g, A, Bu, C, Du, known_input=True), dt) if Bu.shape[1] else 0.0
    leak_d = hinf(*channel(g, A, Bd, C, Dd), dt) if Bd.shape[1] else 0.0
    return GapNumbers(beta, gamma, gap, norms, leak_u, leak_d)
