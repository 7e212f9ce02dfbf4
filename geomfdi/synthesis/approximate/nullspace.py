"""Exact decoupling basis ``Q1`` and the channels it leaves (Varga 2017, §5.3, step 1).

``Q1`` is a stable proper rational basis of the left nullspace of
``[G_u G_d G_fdec; I 0 0]``: every residual that ignores the known input, the disturbances
and the non-target faults is ``Q = Q2 Q1``.  geomfdi realises it with its least-order
machinery as a generator of ``ρ`` rows linearly independent over the rational functions
(``residual_dim = ρ``, ``ρ = q − normal rank [G_d G_fdec]``; see *Theory: least-order
synthesis*, ``docs/theory/least-order.md``).  The approximate design optimises over this
``ρ``-dimensional space (*Theory: approximate synthesis*,
``docs/theory/approximate-synthesis.md``).
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from geomfdi.errors import NotIsolableError
from geomfdi.generators.generator import ResidualGenerator
from geomfdi.generators.realization import minimal_realization
from geomfdi.model.faults import Fault
from geomfdi.model.plant import Plant
from geomfdi.tolerance import CloseRankWarning

__all__ = [
    "normal_rank",
    "decoupling_basis",
    "channel",
    "transfer_on_grid",
    "frequency_grid",
    "noise_channel",
    "quiet_minimal",
]

_PROBES = (0.7071 + 0.3183j, 1.618 + 2.7183j, 0.5772 - 1.4142j)


def quiet_minimal(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C, D)`` of the minimal realisation, close rank decisions not warned.

    The channels and generators of the approximate design only feed norms, the
    factorisation and the delivered minimal form; a close decision there is no news to
    the user (:func:`~geomfdi.generators.realization.minimal_realization`).
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CloseRankWarning)
        mr = minimal_realization(A, B, C, D)
    return mr.A, mr.B, mr.C, mr.D


def noise_channel(plant: Plant) -> tuple[np.ndarray, np.ndarray]:
    """``(Bw, Dw)`` of the plant (empty when it has no noise inputs)."""
    Bw = getattr(plant, "Bw", None)
    Dw = getattr(plant, "Dw", None)
    if Bw is None:
        return np.zeros((plant.n, 0)), np.zeros((plant.q, 0))
    return np.asarray(Bw, dtype=float), np.asarray(Dw, dtype=float)


def frequency_grid(A: np.ndarray, dt: float, count: int = 160) -> np.ndarray:
    """Points on the boundary (``jω`` or ``e^{jθ}``) spread over the plant's time scales."""
    if dt > 0:
        th = np.concatenate([[0.0], np.logspace(-4, 0, count - 1) * np.pi])
        return np.exp(1j * th)
    ev = np.abs(np.linalg.eigvals(A)) if A.size else np.ones(1)
    ev = ev[ev > 0]
    lo = float(ev.min()) if ev.size else 1.0
    hi = float(ev.max()) if ev.size else 1.0
    w = np.logspace(np.log10(lo) - 3, np.log10(hi) + 3, count - 1)
    return 1j * np.concatenate([[0.0], w])


def transfer_on_grid(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, points: np.ndarray
) -> np.ndarray:
    """``C (λ I − A)⁻¹ B + D`` at every complex ``λ`` of ``points``: shape (k, p, m), batched."""
    pts = np.asarray(points, dtype=complex).ravel()
    n = A.shape[0]
    if n == 0:
        return np.broadcast_to(D.astype(complex), (pts.size, *D.shape)).copy()
    lam, V = np.linalg.eig(A)
    if np.linalg.cond(V) < 1e6:  # diagonalisable and well conditioned: O(k n) per point
        CV = C @ V
        VB = np.linalg.solve(V, B)
        return np.einsum("pi,ki,im->kpm", CV, 1.0 / (pts[:, None] - lam[None, :]), VB) + D
    # otherwise the complex Schur form: one triangular back substitution over all points
    # (on the transposed system when there are fewer outputs than inputs)
    import scipy.linalg as sla

    from geomfdi.generators.gains import _tri_solve_many

    T, U = sla.schur(A.astype(complex), output="complex")
    UhB, CU = U.conj().T @ B, C @ U
    if C.shape[0] < B.shape[1]:  # Gᵀ = (U*B)ᵀ (λI − Tᵀ)⁻¹ (CU)ᵀ, Tᵀ reversed is upper
        X = _tri_solve_many(np.ascontiguousarray(T.T[::-1, ::-1]), pts, CU.T[::-1].copy())
        return np.matmul(UhB.T[:, ::-1], X).transpose(0, 2, 1) + D
    return np.matmul(CU, _tri_solve_many(T, pts, UhB)) + D


def normal_rank(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, dt: float) -> int:
    """Normal rank of ``C (λI − A)⁻¹ B + D``: the largest rank at three generic points.

    The points are scaled to the spectral radius of ``A`` (and placed off the unit circle in
    discrete time); ranks are decided relative to the largest singular value at each point.
    """
    if B.shape[1] == 0 or C.shape[0] == 0:
        return 0
    rad = max(float(np.max(np.abs(np.linalg.eigvals(A)))) if A.size else 0.0, 1.0)
    pts = np.array(_PROBES) * (1.0 if dt > 0 else rad) + (1.5 if dt > 0 else 0.0)
    G = transfer_on_grid(A, B, C, D, pts)
    best = 0
    for Gk in G:
        s = np.linalg.svd(Gk, compute_uv=False)
        if s.size and s[0] > 0:
            best = max(best, int(np.sum(s > 1e-9 * s[0])))
    return best


def decoupling_basis(
    plant: Plant,
    faults: list[Fault],
    sigs: list[tuple[np.ndarray, np.ndarray]],
    target: tuple[int, ...],
    decouple: tuple[int, ...],
    *,
    poles: Any = None,
) -> ResidualGenerator:
    """``Q1``: ``ρ`` independent rows decoupling ``u``, ``d`` and the faults ``decouple``.

    Raises
    ------
    NotIsolableError
        ``ρ = 0`` (nothing is left after the decoupling) or no row sees every target.
    """

    n, q = plant.n, plant.q
    Bdec = np.hstack([plant.Bd, *[sigs[j][0] for j in decouple]]).reshape(n, -1)
    Ddec = np.hstack([plant.Dd, *[sigs[j][1] for j in decouple]]).reshape(q, -1)
    rho = q - normal_rank(plant.A, Bdec, plant.C, Ddec, plant.dt)
    if rho <= 0:
        raise NotIsolableError(
            "target: decoupling the disturbances and the faults "
            f"{list(decouple)} leaves no residual (normal rank of their channel is {q})",
            argument="target",
        )
    from geomfdi.generators.gains import PlantFactor
    from geomfdi.synthesis.build import build_least_order
    from geomfdi.synthesis.least_order.search import plant_scale
    from geomfdi.synthesis.multirow import build_multirow

    omega = plant_scale(plant.A, plant.dt)
    factor = PlantFactor(plant)
    kw: dict[str, Any] = dict(poles=poles, omega=omega, row="the decoupling basis", factor=factor)
    tgt, dec = tuple(target), tuple(decouple)
    if rho == 1:
        g = build_least_order(plant, faults, sigs, tgt, dec, **kw)
    else:
        g = build_multirow(plant, faults, sigs, tgt, dec, residual_dim=rho, **kw)
    g.info["nullspace_dim"] = rho
    return g


def _error_coordinates(g: ResidualGenerator, A: np.ndarray, C: np.ndarray) -> np.ndarray | None:
    """``T`` with ``F T − T A = E C`` and ``M T ≈ H C`` (relative 1e-9), else ``None``."""
    import scipy.linalg as sla

    n, nw = A.shape[0], g.order
    if n == 0:
        return np.zeros((nw, 0))
    if nw == 0:
        T = np.zeros((0, n))
    else:
        try:
            T = sla.solve_sylvester(g.F, -A, g.E @ C)
        except (np.linalg.LinAlgError, ValueError):
            return None
        if not np.all(np.isfinite(T)):
            return None
        # the Sylvester residual itself (close spectra of F and A make T unreliable)
        res = np.linalg.norm(g.F @ T - T @ A - g.E @ C)
        if res > 1e-9 * (
            np.linalg.norm(g.F) * np.linalg.norm(T) + np.linalg.norm(g.E @ C) + 1e-300
        ):
            return None
    scale = np.linalg.norm(g.M) * np.linalg.norm(T) + np.linalg.norm(g.H @ C) + 1e-300
    if np.linalg.norm(g.M @ T - g.H @ C) > 1e-9 * scale:
        return None
    return T


def channel(
    g: ResidualGenerator,
    A: np.ndarray,
    Bx: np.ndarray,
    C: np.ndarray,
    Dx: np.ndarray,
    *,
    known_input: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Minimal realisation of the transfer from a plant input ``x`` to the residual of ``g``.

    ``known_input=True``: ``x`` is the known input ``u``, read by the generator as well
    (``+ G u`` in the state equation, ``+ K u`` in the output), so the result is the leak
    ``Q [G_u; I]``.

    The series connection (plant states, generator states)::

        [x; ξ]' = [[A, 0], [−E C, F]] [x; ξ] + [Bx; −E Dx] v,   r = [−H C, M] [x; ξ] − H Dx v

    followed by the removal of unreachable and unobservable states (the plant's own modes
    are unobservable in a decoupling residual).

    When ``g`` is a residual generator of this plant — ``T`` solving the Sylvester equation
    ``F T − T A = E C`` gives ``M T = H C``, so that the error ``e = ξ − T x`` obeys
    ``e' = F e − (E Dx + T Bx) v`` and ``r = M e − H Dx v`` — the channel is realised in those
    coordinates directly: only the generator's states, none of the plant's (exact for an
    unstable plant, and cheaper).  Otherwise (a model the generator was not designed on)
    the composite above is used.
    """
    n, nw = A.shape[0], g.order
    short = _error_coordinates(g, A, C)
    if short is not None:
        T = short
        Bc = -(g.E @ Dx + T @ Bx) + (g.G if known_input else 0.0)
        Dc = -g.H @ Dx + (g.K if known_input else 0.0)
        return quiet_minimal(g.F, np.reshape(Bc, (nw, Dc.shape[1])), g.M, Dc)
    Ac = np.block([[A, np.zeros((n, nw))], [-g.E @ C, g.F]])
    Bc = np.vstack([Bx, -g.E @ Dx + (g.G if known_input else 0.0)])
    Cc = np.hstack([-g.H @ C, g.M])
    Dc = -g.H @ Dx + (g.K if known_input else 0.0)
    return quiet_minimal(Ac, Bc, Cc, Dc)
