"""Multi-row residuals: ``p`` independent least-order rows stacked (``residual_dim=p``).

See the user guide, *Theory: least-order synthesis* (``docs/theory/least-order.md``).

Every row ``w(s)`` acting on the decoupled quotient output ``z`` (rows of
``w(s) M (sI − A0)⁻¹`` polynomial after clearing the denominator) decouples the
disturbances and the decoupled faults; these rows form a rational vector space of
dimension ``ρ = rank H`` (the number of independent measurement combinations blind to the
decoupled signals), the left annihilator of the decoupled channels.  A residual with ``p``
components is built greedily, like a minimal polynomial basis:

1. row 1 is the scalar least-order row (it sees every target, order ``ν_1``;
   :func:`geomfdi.synthesis.build.build_least_order`);
2. row ``i > 1`` is a row of the least degree ``ν`` whose degree-``ν`` parity space holds a
   row independent (over the rational functions) of rows ``1 … i−1``: with ``W(s)`` the
   earlier rows and ``Z(s)`` the candidate rows (one per basis vector of the parity space),
   the direction ``α`` maximising ``‖α Z(s) (I − W(s)⁺ W(s))‖`` over a few random points
   ``s`` is taken (the top singular vector); the degree is the least one where that
   maximum exceeds ``SEE_TOL`` relative to ``‖Z‖``.  The degree-``ν`` parity spaces are
   nested (rows of degree ``ν`` are rows of degree ``ν + 1``: the poles are prefixes of one
   sequence), so a degree that adds nothing independent of rows ``1 … i−1`` adds nothing
   independent of rows ``1 … i`` either: the search for row ``i + 1`` starts at the degree
   of row ``i`` (rows ``2 … p`` have non-decreasing degrees).

Each row keeps every decoupling (it is a row of the left annihilator), the stack sees every
target (row 1 does), and the stacked transfer has normal rank ``p``, checked on the physical
plant at random points.  Rows of degree ``ν`` use the first ``ν`` poles of one common
sequence, so the stack has a joint minimal realisation of order ``max ν_i`` or a little
more; it is delivered when it passes the leakage check, else the block-diagonal stack.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi.errors import DesignError
from geomfdi.generators.gains import LEAK_TOL, Composite, PlantFactor, _gains
from geomfdi.generators.generator import ResidualGenerator
from geomfdi.generators.realization import minimal_realization
from geomfdi.geometry.balancing import state_scaling
from geomfdi.geometry.subspace import _norm2
from geomfdi.model.plant import Plant
from geomfdi.synthesis.build import build_least_order, check_angles
from geomfdi.synthesis.construction import IDENTITY_TOL, _NumericalDesignError
from geomfdi.synthesis.least_order.quotient import adaptive_quotient_model
from geomfdi.synthesis.least_order.search import (
    SEE_TOL,
    LeastOrderRow,
    Quotient,
    _blocks,
    _check_poles,
    _null_rows,
    _realise,
    _unnormalise,
    default_pole_sequence,
    realise_on_plant,
    validate_poles,
)

__all__ = ["build_multirow", "check_residual_dim", "ResidualDimError"]


class ResidualDimError(DesignError):
    """More independent residual rows were asked for than the decoupling leaves."""


def check_residual_dim(value: Any) -> int:
    """``residual_dim`` validated: an integer ``≥ 1`` (``None`` reads as 1)."""
    if value is None:
        return 1
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise DesignError(
            f"residual_dim: must be an integer >= 1, got {value!r:.40}", argument="residual_dim"
        )
    if int(value) < 1:
        raise DesignError(
            f"residual_dim: must be an integer >= 1, got {int(value)}", argument="residual_dim"
        )
    return int(value)


def _quotient(
    plant: Plant,
    sigs: list[tuple[np.ndarray, np.ndarray]],
    target: tuple[int, ...],
    decouple: tuple[int, ...],
    d: np.ndarray,
) -> Quotient:
    """The row's quotient on the state scaled by ``d`` (as in the scalar design)."""
    Ab = plant.A * d[None, :] / d[:, None]
    Bb, Cb = plant.B / d[:, None], plant.C * d[None, :]
    Bw = np.hstack([plant.Bd / d[:, None], *[sigs[j][0] / d[:, None] for j in decouple]])
    Dw = np.hstack([plant.Dd, *[sigs[j][1] for j in decouple]])
    tg = [(sigs[j][0] / d[:, None], sigs[j][1]) for j in target]
    return adaptive_quotient_model(Ab, Bb, Cb, plant.D, Bw, Dw, tg)


def _y_rows(mats: dict[str, np.ndarray], points: np.ndarray) -> np.ndarray:
    """``G_y(s) = −M (sI − F)⁻¹ E − H`` of a realised row at each point, stacked (pts × q)."""
    F, E, M, H = mats["F"], mats["E"], mats["M"], mats["H"]
    nu = F.shape[0]
    out = []
    for s in points:
        val = -H.astype(complex)
        if nu:
            val = val - M @ np.linalg.solve(s * np.eye(nu) - F, E)
        out.append(val[0])
    return np.array(out)


def _points(Qm: Quotient, pool: np.ndarray, omega: float, count: int = 3) -> np.ndarray:
    rng = np.random.default_rng(97)
    eig = np.concatenate([np.linalg.eigvals(Qm.A0) if Qm.k else np.zeros(0), pool])
    rad = max(float(np.max(np.abs(eig))) if eig.size else 0.0, omega, 1e-300)
    return rad * rng.uniform(0.5, 1.5, count) * np.exp(1j * rng.uniform(0.3, np.pi - 0.3, count))


def _normalised(mats: dict[str, np.ndarray], omega: float) -> dict[str, np.ndarray]:
    """Unit residual scale: ``‖H‖ = 1``, or ``‖M‖ ‖[E G]‖ / max(‖F‖, ω) = 1`` if H = 0."""
    F, E, G, M, H, K = (mats[x] for x in "FEGMHK")
    size = _norm2(H)
    if size <= 1e-12 * max(_norm2(M) * _norm2(np.hstack([E, G])), 1e-300):
        size = _norm2(M) * _norm2(np.hstack([E, G])) / max(_norm2(F), omega, 1e-300)
    size = size if size > 0 else 1.0
    return {**mats, "E": E / size, "G": G / size, "H": H / size, "K": K / size}


def _independent_row(
    Qm: Quotient,
    cand: np.ndarray,
    Du: np.ndarray,
    prev: np.ndarray,
    points: np.ndarray,
) -> tuple[np.ndarray, float, Any, list[int]] | None:
    """The direction of the parity space at poles ``cand`` most independent of ``prev``.

    ``prev``: (rows, points, q) values of the earlier rows' ``G_y``.  Returns
    ``(x, relative independence, kinds, sizes)`` or None when the space adds no
    independent row.
    """
    blocks, kinds = _blocks(Qm, cand)
    X, _, _ = _null_rows(blocks)
    if X.shape[1] == 0:
        return None
    Xu = _unnormalise(X, blocks)
    sizes = [b.shape[0] for b in blocks]
    Z = []  # (dim, points, q): each basis vector realised and evaluated
    for col in Xu.T:
        F, Gs, T, c, h = _realise(Qm, cand, kinds, col, sizes, blocks)
        row = LeastOrderRow(len(cand), F, Gs, T, c, h, cand, {})
        Z.append(_y_rows(realise_on_plant(Qm, row, Du), points))
    Zc = np.array(Z)
    proj = []
    for p in range(points.size):
        W = prev[:, p, :]
        U, s, Vh = np.linalg.svd(W, full_matrices=False)
        V = Vh[s > 1e-10 * max(s[0], 1e-300)] if s.size else Vh[:0]
        Zp = Zc[:, p, :]
        proj.append(Zp - (Zp @ V.conj().T) @ V)
    Y = np.hstack(proj)
    Yr = np.hstack([Y.real, Y.imag])
    ref = max(
        np.linalg.norm(np.hstack([Zc.reshape(len(Z), -1).real, Zc.reshape(len(Z), -1).imag]), 2),
        1e-300,
    )
    U, s, _ = np.linalg.svd(Yr, full_matrices=False)
    if not s.size or s[0] <= SEE_TOL * ref:
        return None
    return Xu @ U[:, 0], float(s[0] / ref), kinds, sizes


def build_multirow(
    plant: Plant,
    faults: list[Any],
    sigs: list[tuple[np.ndarray, np.ndarray]],
    target: tuple[int, ...],
    decouple: tuple[int, ...],
    *,
    residual_dim: int,
    poles: Any,
    omega: float,
    row: str,
    factor: PlantFactor | None = None,
    prefix: bool = False,
) -> ResidualGenerator:
    """A ``residual_dim``-row residual: the least-order row plus independent rows (Notes).

    Raises
    ------
    ResidualDimError
        ``residual_dim`` exceeds ``ρ``, the number of independent rows that decouple
        every signal to be decoupled (``argument="residual_dim"``).
    NotIsolableError
        No row sees every target.
    DesignError
        Bad poles, or (the private numerical-failure subclass) a row or the stack failed
        its numerical checks.
    """
    p = residual_dim
    n = plant.n
    Ball = np.hstack([plant.B, plant.Bd, *[Bf for Bf, _ in sigs]]) if n else np.zeros((0, 0))
    d = state_scaling(plant.A, Ball.reshape(n, -1), plant.C)
    Qm = _quotient(plant, sigs, target, decouple, d)
    if p > Qm.rho:
        raise ResidualDimError(
            f"residual_dim: {row} admits at most {Qm.rho} independent residual rows (the "
            f"measurement combinations blind to the decoupled signals), got {p}",
            argument="residual_dim",
        )
    g1 = build_least_order(
        plant,
        faults,
        sigs,
        target,
        decouple,
        poles=poles,
        omega=omega,
        row=row,
        factor=factor,
        prefix=prefix or poles is not None,
    )
    if not np.allclose(g1.info["state_scaling"], d):
        raise _NumericalDesignError(f"{row}: the scalar row used another state scaling")
    sc = float(g1.info.get("pole_scale", 1.0))
    k = Qm.k
    if poles is None:
        pool = default_pole_sequence(k + 2, omega * sc, plant.dt)
        if k:
            eig = Qm.eigenvalues
            for t in range(pool.size):  # clear of the quotient's spectrum
                for _ in range(20):
                    if np.min(np.abs(eig - pool[t])) > 1e-6 * max(omega, 1e-300):
                        break
                    pool[t] *= 1.0 + 1e-3
        pool = pool.astype(complex)
    else:
        pool = validate_poles(poles, plant.dt)
    points = _points(Qm, pool, omega)
    mats = [{x: getattr(g1, x) for x in "FEGMHK"}]
    orders = [g1.order]
    independence = [1.0]
    prev = _y_rows(mats[0], points)[None]
    start = 0  # the degree of the previous extra row (Notes, step 2)
    for i in range(1, p):
        found = None
        for nu in range(start, min(k + 1, pool.size) + 1):
            cand = pool[:nu]
            if np.count_nonzero(cand.imag > 0) != np.count_nonzero(cand.imag < 0):
                continue  # the prefix splits a conjugate pair
            found = _independent_row(
                Qm, _check_poles(cand, Qm.A0, plant.dt, Qm.eigenvalues), plant.D, prev, points
            )
            if found is not None:
                break
        if found is None and poles is not None and pool.size <= k:
            raise DesignError(
                f"poles: {row}: no row independent of rows 0..{i - 1} uses at most "
                f"{pool.size} poles; give more poles (rows of a residual_dim > 1 residual use "
                "the first poles of one list, up to the quotient's order "
                f"{k})",
                argument="poles",
            )
        if found is None:
            raise _NumericalDesignError(
                f"{row}: no residual row independent of rows 0..{i - 1} found within the "
                f"available poles (residual_dim={p})",
                argument="plant",
            )
        x, indep, kinds, sizes = found
        start = nu
        F, Gs, T, c, h = _realise(
            Qm, _check_poles(pool[:nu], Qm.A0, plant.dt, Qm.eigenvalues), kinds, x, sizes
        )
        lo = LeastOrderRow(nu, F, Gs, T, c, h, pool[:nu], {})
        mi = realise_on_plant(Qm, lo, plant.D)
        bad = {key: v for key, v in mi["identities"].items() if v > IDENTITY_TOL}
        if bad:
            raise _NumericalDesignError(
                f"{row}: extra row {i} is ill-conditioned ({bad})", argument="plant"
            )
        mi = _normalised(mi, omega * sc)
        mats.append(mi)
        orders.append(nu)
        independence.append(indep)
        prev = np.concatenate([prev, _y_rows(mi, points)[None]], axis=0)
    g = _stack(mats, plant, target, decouple, g1.info)
    _check_stack(g, plant, sigs, factor, row, p, points)
    block = sum(orders)
    if g.order > max(orders):
        gm = _joint_minimal(g)
        if gm is not None and gm.order < g.order:
            try:
                _check_stack(gm, plant, sigs, factor, row, p, points)
                g = gm
            except _NumericalDesignError:
                pass
    comp = Composite(g, plant, factor)
    gains, dc = _gains(comp, sigs, "points")
    g.info.update(
        poles=g.poles,
        residual_dim=p,
        row_orders=orders,
        block_order=block,
        stacked_order=g.order,
        row_independence=independence,
        max_residual_dim=Qm.rho,
        fault_gain=gains,
        dc_gain=dc,
    )
    unseen = [j for j in target if not gains[j] > LEAK_TOL]
    if unseen:  # row 0 sees every target; this only fires on a numerical breakdown
        raise _NumericalDesignError(
            f"{row}: the stacked residual lost targets {unseen}", argument="plant"
        )
    return g


def _stack(
    mats: list[dict[str, np.ndarray]],
    plant: Plant,
    target: tuple[int, ...],
    decouple: tuple[int, ...],
    info: dict[str, Any],
) -> ResidualGenerator:
    """Block-diagonal stack of scalar rows ``(F_i, E_i, G_i, M_i, H_i, K_i)``."""
    nw = sum(m["F"].shape[0] for m in mats)
    p, q, mu = len(mats), plant.q, plant.m
    F, E, G = np.zeros((nw, nw)), np.zeros((nw, q)), np.zeros((nw, mu))
    M, H, K = np.zeros((p, nw)), np.zeros((p, q)), np.zeros((p, mu))
    i = 0
    for r, m in enumerate(mats):
        o = m["F"].shape[0]
        F[i : i + o, i : i + o] = m["F"]
        E[i : i + o], G[i : i + o] = m["E"], m["G"]
        M[r, i : i + o] = m["M"][0]
        H[r], K[r] = m["H"][0], m["K"][0]
        i += o
    # row 0's own numbers that do not describe the stack (its quotient map, poles and
    # first Markov parameter) are dropped; the stack's gains are set by the caller
    new_info = {key: v for key, v in info.items() if key not in ("P", "poles", "markov_gain")}
    return ResidualGenerator(
        F,
        E,
        G,
        M,
        H,
        K,
        dt=plant.dt,
        target=target,
        decoupled=decouple,
        method="exact",
        info=new_info,
    )


def _joint_minimal(g: ResidualGenerator) -> ResidualGenerator | None:
    mr = minimal_realization(g.F, np.hstack([-g.E, g.G]), g.M, np.hstack([-g.H, g.K]))
    k = mr.A.shape[0]
    if k >= g.order:
        return None
    return ResidualGenerator(
        mr.A,
        -mr.B[:, : g.q],
        mr.B[:, g.q :],
        mr.C,
        g.H.copy(),
        g.K.copy(),
        dt=g.dt,
        target=g.target,
        decoupled=g.decoupled,
        method=g.method,
        info=dict(g.info),
    )


def _check_stack(
    g: ResidualGenerator,
    plant: Plant,
    sigs: list,
    factor: PlantFactor | None,
    row: str,
    p: int,
    points: np.ndarray,
) -> None:
    """Leakage (angle measure), stability, and normal rank ``p`` of the stacked transfer."""
    check_angles(g, plant, sigs, factor, row)
    lam = np.linalg.eigvals(g.F) if g.order else np.zeros(0)
    if lam.size and not np.all(np.abs(lam) < 1 if plant.dt > 0 else lam.real < 0):
        raise _NumericalDesignError(f"{row}: the stacked residual is not stable", argument="plant")
    mats = {x: getattr(g, x) for x in "FEGMHK"}
    F, E, M, H = mats["F"], mats["E"], mats["M"], mats["H"]
    rank = 0
    for s in points:
        Gy = -H.astype(complex)
        if g.order:
            Gy = Gy - M @ np.linalg.solve(s * np.eye(g.order) - F, E)
        Gy = Gy / np.maximum(np.linalg.norm(Gy, axis=1, keepdims=True), 1e-300)
        sv = np.linalg.svd(Gy, compute_uv=False)
        rank = max(rank, int(np.count_nonzero(sv > SEE_TOL * max(sv[0], 1e-300))))
    if rank < p:
        raise _NumericalDesignError(
            f"{row}: the stacked residual has rank {rank} < residual_dim {p}", argument="plant"
        )
