"""Approximate fault detection (AFD) synthesis: the fault-to-noise gap maximised.

Varga, *Solving Fault Diagnosis Problems*, 2017, §5.3 (AFDP) and Procedure AFD (§7):

1. ``Q1``: the exact decoupling basis of ``u``, ``d`` and the non-target faults
   (:func:`~geomfdi.synthesis.approximate.nullspace.decoupling_basis`, ``ρ`` rows).
   If some combination also decouples the noise and still sees every target, the problem
   is solved exactly (gap ``∞``).
2. ``R_w = Q1 [G_w; 0]`` and ``R_f = Q1 [G_f; 0]``.
3. ``R_w = R_wo R_wi`` (quasi-co-outer–co-inner,
   :func:`~geomfdi.synthesis.approximate.factorization.co_outer_factor`).
4. ``Q = M R_wo⁻¹ Q1``: ``γ = ‖M R_wi‖∞ = 1`` for ``M`` with orthonormal rows, and
   ``β = min_j ‖M R_wo⁻¹ R_fj‖∞``.  With ``M = I`` (all ``ρ`` rows) the gap is the optimum
   ``min_j ‖R_wo⁻¹ R_fj‖∞``; fewer rows (``residual_dim``) choose the orthonormal ``M``
   that maximises ``β`` on a frequency grid (singular directions, then a local search).
5. A minimal realisation; β, γ and the gap measured on the plant by H∞ norms.

See *Theory: approximate synthesis* (``docs/theory/approximate-synthesis.md``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import scipy.optimize as sopt

from geomfdi.errors import DesignError, NotIsolableError
from geomfdi.generators.generator import ResidualGenerator
from geomfdi.model.faults import Fault, fault_matrices
from geomfdi.model.plant import Plant
from geomfdi.synthesis.approximate.factorization import co_outer_factor
from geomfdi.synthesis.approximate.measure import gap_numbers, hinf
from geomfdi.synthesis.approximate.nullspace import (
    channel,
    decoupling_basis,
    frequency_grid,
    quiet_minimal,
    transfer_on_grid,
)

__all__ = ["gap_design", "series", "choose_rows", "finish", "combine_rows", "require_stable"]


def series(g: ResidualGenerator, Ai, Bi, Ci, Di) -> ResidualGenerator:
    """``(Ai, Bi, Ci, Di) · g``: a filter applied to the residual of ``g``.

    ``η' = Ai η + Bi r1``, ``r = Ci η + Di r1`` with ``r1 = M ξ − H y + K u``.
    """
    n1, n2 = g.order, Ai.shape[0]
    F = np.block([[g.F, np.zeros((n1, n2))], [Bi @ g.M, Ai]])
    E = np.vstack([g.E, Bi @ g.H])
    G = np.vstack([g.G, Bi @ g.K])
    M = np.hstack([Di @ g.M, Ci])
    return ResidualGenerator(
        F, E, G, M, Di @ g.H, Di @ g.K, dt=g.dt, target=g.target, decoupled=g.decoupled
    )


def whiten(
    Q1: ResidualGenerator,
    A: np.ndarray,
    Bw: np.ndarray,
    C: np.ndarray,
    Dw: np.ndarray,
    Rw: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    dt: float,
    scale: float,
    regularization: float | None,
) -> tuple[ResidualGenerator, Any]:
    """``R_wo⁻¹ Q1`` and the factor, of the order of ``Q1`` where possible.

    In the error coordinates of ``Q1`` (:func:`~geomfdi.synthesis.approximate.nullspace.channel`)
    the noise channel shares ``Q1``'s ``(F, M)``: ``R_w = (F, B_w', M, D_w')``.  The factor
    then has the form ``R_wo = (I + M (λI − F)⁻¹ K) R̃^{1/2}`` and

        R_wo⁻¹ Q1 = R̃^{-1/2} [M (λI − F + K M)⁻¹ (B1 − K D1) + D1]

    (``B1 = [−E, G]``, ``D1 = [−H, K]``): an observer-like update of ``Q1`` with no new
    state.  Otherwise (no error coordinates) the series connection ``R_wo⁻¹ · Q1``.
    """
    from geomfdi.synthesis.approximate.nullspace import _error_coordinates

    T = _error_coordinates(Q1, A, C)
    if T is not None and Q1.order:
        Bwe = -(Q1.E @ Dw + T @ Bw)
        Dwe = -Q1.H @ Dw
        try:
            fac = co_outer_factor(
                Q1.F, Bwe, Q1.M, Dwe, dt, scale=scale, regularization=regularization
            )
        except DesignError:
            fac = None
        if fac is not None:  # the factor keeps the given (F, M)
            K = fac.B @ np.linalg.inv(fac.D)  # R_wo = (F, K R^{1/2}, M, R^{1/2})
            Rhi = fac.Di
            Qt = ResidualGenerator(
                Q1.F - K @ Q1.M,
                Q1.E - K @ Q1.H,
                Q1.G - K @ Q1.K,
                Rhi @ Q1.M,
                Rhi @ Q1.H,
                Rhi @ Q1.K,
                dt=Q1.dt,
                target=Q1.target,
                decoupled=Q1.decoupled,
            )
            return Qt, fac
    fac = co_outer_factor(*Rw, dt, scale=scale, regularization=regularization)
    return series(Q1, fac.Ai, fac.Bi, fac.Ci, fac.Di), fac


def _beta_grid(M: np.ndarray, Gf: list[np.ndarray]) -> float:
    """``min_j max_ω ‖M G_j(ω)‖`` on the grid (``Gf[j]``: (k, ρ, kj))."""
    if M.shape[0] == 1:  # one row: the spectral norm is the vector norm
        return min(float(np.max(np.linalg.norm(M[0] @ G, axis=-1))) for G in Gf)
    return min(float(np.max(np.linalg.norm(M @ G, ord=2, axis=(1, 2)))) for G in Gf)


def _beta_band(M: np.ndarray, Gf: list[np.ndarray]) -> float:
    """``min_j min_ω ‖M G_j(ω)‖`` on the band's grid (the H₋ index over a band)."""
    if M.shape[0] == 1:
        return min(float(np.min(np.linalg.norm(M[0] @ G, axis=-1))) for G in Gf)
    return min(float(np.min(np.linalg.norm(M @ G, ord=2, axis=(1, 2)))) for G in Gf)


def band_grid(band: Any, dt: float, count: int = 121) -> tuple[tuple[float, float], np.ndarray]:
    """The checked band ``(ω₁, ω₂)`` (rad/s) and boundary points on it (linear and
    logarithmic spacing)."""
    try:
        w1, w2 = (float(x) for x in band)
    except (TypeError, ValueError) as exc:
        raise DesignError(
            f"band: expected (w1, w2) in rad/s, got {band!r:.60}", argument="band"
        ) from exc
    top = np.pi / dt if dt > 0 else np.inf
    if not (np.isfinite(w1) and np.isfinite(w2) and 0 <= w1 < w2 <= top):
        where = f"0 <= w1 < w2 <= pi/dt = {top:.6g}" if dt > 0 else "0 <= w1 < w2 < inf"
        raise DesignError(f"band: expected {where}, got ({w1}, {w2})", argument="band")
    lo = max(w1, w2 * 1e-4)
    w = np.unique(np.concatenate([np.linspace(w1, w2, count), np.geomspace(lo, w2, count)]))
    pts = np.exp(1j * w * dt) if dt > 0 else 1j * w
    return (w1, w2), pts


def choose_rows(
    Gf: list[np.ndarray], rdim: int, beta: Any = _beta_grid
) -> tuple[np.ndarray, float]:
    """Orthonormal ``M`` (rdim × ρ) maximising ``min_j max_ω ‖M G_j(ω)‖`` on the grid.

    Candidates: coordinate rows, the leading left singular vectors of every target column
    at its peak frequency, and their normalised sum; the best one is refined by a
    Nelder–Mead search over the unit sphere (one row) — a heuristic: the optimum over all
    ``M`` (``rdim = ρ``, ``M = I``) is exact.  ``beta``: the objective on the grid
    (:func:`_beta_grid`, or :func:`_beta_band` for the H₋ index over a band).
    """
    rho = Gf[0].shape[1]
    if rdim >= rho:
        return np.eye(rho), beta(np.eye(rho), Gf)
    cands = []
    for i in range(rho - rdim + 1):
        cands.append(np.eye(rho)[i : i + rdim])
    dirs = []
    for G in Gf:
        k = int(np.argmax(np.linalg.norm(G, ord=2, axis=(1, 2))))
        U, _, _ = np.linalg.svd(G[k])
        dirs.append(U[:, 0])
    D = np.array(dirs)
    Dr = np.abs(D.real) + np.abs(D.imag)
    for row in D:
        v = np.abs(row)
        cands.append(v[None, :] / np.linalg.norm(v))
    Dm = np.hstack([D.real.T, D.imag.T]) if np.any(D.imag) else Dr.T
    U, _, _ = np.linalg.svd(Dm, full_matrices=True)
    cands.append(U[:, :rdim].T)
    s = Dr.sum(axis=0)
    if np.linalg.norm(s) > 0 and rdim == 1:
        cands.append(s[None, :] / np.linalg.norm(s))
    cands = [np.linalg.qr(c.T)[0].T for c in cands]
    vals = [beta(c, Gf) for c in cands]
    best = int(np.argmax(vals))
    M, val = cands[best], vals[best]
    if rdim == 1:

        def neg(x: np.ndarray) -> float:
            nx = np.linalg.norm(x)
            return 0.0 if nx == 0 else -beta(x[None, :] / nx, Gf)

        res = sopt.minimize(
            neg, M[0], method="Nelder-Mead", options={"xatol": 1e-6, "maxiter": 400}
        )
        if -res.fun > val:
            M, val = res.x[None, :] / np.linalg.norm(res.x), -res.fun
    return M, val


def finish(g: ResidualGenerator) -> ResidualGenerator:
    """Minimal realisation of a generator (inputs ``[y; u]``)."""
    A, B, C, D = quiet_minimal(g.F, np.hstack([-g.E, g.G]), g.M, np.hstack([-g.H, g.K]))
    q = g.q
    return ResidualGenerator(
        A,
        -B[:, :q],
        B[:, q:],
        C,
        -D[:, :q],
        D[:, q:],
        dt=g.dt,
        target=g.target,
        decoupled=g.decoupled,
        method="gap",
        info=dict(g.info),
    )


def combine_rows(
    Q: ResidualGenerator,
    rows: np.ndarray | int,
    dt: float,
    target: tuple[int, ...] = (),
    decouple: tuple[int, ...] = (),
) -> ResidualGenerator:
    """``finish(T Q)``: the residual ``T r_Q`` realised minimally.

    ``rows`` is the matrix ``T`` (one column per output of ``Q``), or an integer ``k``
    for the first ``k`` outputs of ``Q`` as they are.
    """
    if isinstance(rows, int):
        M, H, K = Q.M[:rows], Q.H[:rows], Q.K[:rows]
    else:
        M, H, K = rows @ Q.M, rows @ Q.H, rows @ Q.K
    return finish(
        ResidualGenerator(Q.F, Q.E, Q.G, M, H, K, dt=dt, target=target, decoupled=decouple)
    )


def require_stable(
    g: ResidualGenerator, dt: float, message: str, argument: str | None = None
) -> np.ndarray:
    """The poles of ``g``; :class:`DesignError` (``message``) when one is not stable."""
    poles = g.poles
    stable = bool(np.all(np.abs(poles) < 1)) if dt > 0 else bool(np.all(poles.real < 0))
    if not stable:
        raise DesignError(message, argument=argument)
    return poles


def _noise_decoupled_info(num: Any, *, measured: bool) -> dict[str, Any]:
    """``info`` of a design that decouples the noise exactly (gap ``∞``, ``γ = 0``)."""
    info = {"gap": float("inf"), "beta": num.beta, "gamma": 0.0}
    if measured:
        info["gamma_measured"] = num.gamma
    info.update(
        fault_norms=num.fault_norms,
        leak_u=num.leak_u,
        leak_d=num.leak_d,
        noise_decoupled=True,
        regularization=0.0,
        standard=True,
    )
    return info


def _exact_noise_decoupling(plant, faults, target, decouple, Bw, Dw, poles):
    """The exact design with the noise decoupled too, or ``None`` when it cannot see the targets."""
    from geomfdi.generators.gains import PlantFactor
    from geomfdi.synthesis.build import build_least_order
    from geomfdi.synthesis.least_order.search import plant_scale

    if not Bw.shape[1]:
        return None
    fl = [*faults, Fault(Bw, Dw, name="noise")]
    sigs = fault_matrices(fl, plant.n, plant.q)
    try:
        g = build_least_order(
            plant,
            fl,
            sigs,
            tuple(target),
            (*decouple, len(faults)),
            poles=poles,
            omega=plant_scale(plant.A, plant.dt),
            row="the residual",
            factor=PlantFactor(plant),
        )
    except (NotIsolableError, DesignError):
        return None
    g.decoupled = tuple(decouple)
    return g


def gap_design(
    plant: Plant,
    faults: list[Fault],
    sigs: list[tuple[np.ndarray, np.ndarray]],
    target: tuple[int, ...],
    decouple: tuple[int, ...],
    Bw: np.ndarray,
    Dw: np.ndarray,
    *,
    poles: Any = None,
    residual_dim: int | None = None,
    regularization: float | None = None,
    measure: bool = True,
    band: Any = None,
) -> ResidualGenerator:
    """One AFD/AFDI row: the generator maximising the fault-to-noise gap (module docstring).

    Returns a :class:`ResidualGenerator` with ``method="gap"`` and ``info`` holding
    ``gap``, ``beta``, ``gamma`` (measured on the plant), ``fault_norms`` (per target),
    ``leak_u``, ``leak_d``, ``nullspace_dim`` (``ρ``), ``regularization`` (ε, 0 in the
    standard case), ``standard`` and ``noise_decoupled`` (the exact case, gap ``inf``).
    ``measure=False`` skips the H∞ measurement (β, γ, gap and leaks are then absent; the
    multi-model design measures on every model itself).

    ``band=(ω₁, ω₂)`` (rad/s): β is the H₋ index over the band,
    ``min_j min_{ω₁≤ω≤ω₂} ‖R_fj(jω)‖`` (Varga 2017, §3.3; FDITOOLS ``afdsyn`` with a
    frequency set), both when the rows are chosen (``residual_dim`` below ``ρ``; with all
    rows the design is the same) and in the reported ``beta`` and ``gap`` (``γ`` stays the
    full H∞ norm); ``info["band"]`` holds the band.
    """
    if band is not None:
        band, band_pts = band_grid(band, plant.dt)
    A, C, dt = plant.A, plant.C, plant.dt
    tsigs = [sigs[j] for j in target]

    def numbers(g: ResidualGenerator) -> Any:  # β, γ, gap and leaks measured on the plant
        return gap_numbers(
            g, A, plant.B, plant.Bd, Bw, C, plant.D, plant.Dd, Dw, tsigs, dt, band=band
        )

    g = _exact_noise_decoupling(plant, faults, target, decouple, Bw, Dw, poles)
    if g is not None:
        g.method = "gap"
        g.info.update(_noise_decoupled_info(numbers(g), measured=True))
        return g
    Q1 = decoupling_basis(plant, faults, sigs, target, decouple, poles=poles)
    rho = Q1.n_outputs
    rdim = rho if residual_dim is None else int(residual_dim)
    if rdim < 1 or rdim > rho:
        raise DesignError(
            f"residual_dim: must be between 1 and {rho} (the dimension of the decoupling "
            f"basis), got {residual_dim!r}",
            argument="residual_dim",
        )
    Aw, Bw1, Cw, Dw1 = channel(Q1, A, Bw, C, Dw)
    scale = hinf(Aw, Bw1, Cw, Dw1, dt)
    if scale == 0:  # no noise, or none reaches the decoupling basis: the exact design
        g = combine_rows(Q1, rdim, dt, target, decouple)
        g.info.update(_noise_decoupled_info(numbers(g), measured=False))
        g.info.update(
            nullspace_dim=rho,
            residual_dim=rdim,
            poles=g.poles,
        )
        return g
    Qt, fac = whiten(Q1, A, Bw, C, Dw, (Aw, Bw1, Cw, Dw1), dt, scale, regularization)
    pts = frequency_grid(A, dt) if band is None else band_pts
    Gf = [transfer_on_grid(*channel(Qt, A, Bf, C, Df), pts) for Bf, Df in tsigs]
    Mrow, _ = choose_rows(Gf, rdim, _beta_grid if band is None else _beta_band)
    g = combine_rows(Qt, Mrow, dt, target, decouple)
    poles_g = require_stable(
        g, dt, "plant: the gap design produced an unstable generator", argument="plant"
    )
    if measure:
        num = numbers(g)
        g.info.update(
            gap=num.gap,
            beta=num.beta,
            gamma=num.gamma,
            fault_norms=num.fault_norms,
            leak_u=num.leak_u,
            leak_d=num.leak_d,
        )
    if band is not None:
        g.info["band"] = band
    g.info.update(
        nullspace_dim=rho,
        residual_dim=rdim,
        design_rows=Mrow,
        regularization=fac.regularization,
        standard=fac.regularization == 0,
        noise_decoupled=False,
        nullspace_order=Q1.order,
        poles=poles_g,
    )
    return g
