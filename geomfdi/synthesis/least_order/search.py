"""Least-order scalar residual generators from the geometric quotient.

See the user guide, *Theory: least-order synthesis* (``docs/theory/least-order.md``).

**Quotient.**  The decoupled quotient ``(A0, M)`` of the row, with its inputs
``B_qy, B_qu`` and targets, comes from :mod:`geomfdi.synthesis.least_order.quotient` (S*, decoupled
feedthrough made states, so that static rows come out of order 0).

**Degree-ν parity space by resolvents.**  For distinct stable poles λ_1 … λ_ν not in
spec(A0), the rows ``x = (x_0, x_1, …, x_ν)`` with::

    x_0 M + Σ_i x_i M (λ_i I − A0)⁻¹ = 0

are, by partial fractions, exactly the polynomial rows ``v(s)`` of degree ν with
``v(s) M (sI − A0)⁻¹`` polynomial, divided by ``d(s) = Π (s − λ_i)`` (the rational
Krylov space has the dimension of the monomial one; no powers of A0 are formed).  Each
such x is realised as a functional observer of order ν::

    ζ' = Λ ζ + G_s z + T (B_qy y + B_qu u),   r = c ζ + h z,
    T A0 − Λ T = G_s M,   c T + h M = 0,      t_i = x_i M (λ_i I − A0)⁻¹,  g_i = −x_i, h = x_0

so that ``ε = ζ − T ξ`` obeys ``ε' = Λ ε + (G_s H D_f − T B_fq) f`` and ``r = c ε + h H D_f f``.
The least order is the smallest ν whose parity space holds a vector seeing every target
(a real vector space is no finite union of proper subspaces, so it suffices that each
target is seen by some basis vector); the certificate lists, for ν − 1, a target that the
whole degree-(ν − 1) space does not see.  Within the least-order space the direction
maximising the smallest normalised target gain is chosen.

**Dimensions from the observer staircase.**  The dimension of every degree-ν space,
``(ν + 1) ρ − Σ_{j ≤ ν+1} ρ_j``, comes from the block sizes ``ρ_j`` of the orthogonal
observer staircase of ``(A0, M)`` (:func:`geomfdi.geometry.staircase.observer_staircase`,
one rank decision per small block); the null space of the stacked resolvent blocks is
taken with that dimension, degrees with an empty space are skipped, and the search stops
at the largest observability index.  Above ``NU_PF_MAX`` the partial-fraction basis is
not used: only the top degree is decided, on the quotient's own target transfers
(:func:`quotient_target_gains`), and the row is returned unrealised (``F is None``) for
the quotient-observer realisation of :mod:`geomfdi.synthesis.least_order.quotient_observer`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from geomfdi.errors import DesignError
from geomfdi.geometry.staircase import Staircase, observer_staircase
from geomfdi.geometry.subspace import _norm2
from geomfdi.synthesis.least_order.parity_spaces import (
    clear_of_spectrum,
    onb_parity_space,
    realise_onb,
    spectral_pole_set,
)
from geomfdi.synthesis.least_order.poles import (
    _check_poles,
    default_pole_sequence,
    plant_scale,
    validate_poles,
)
from geomfdi.synthesis.least_order.quotient import Quotient, quotient_model
from geomfdi.tolerance import rank_decision

__all__ = [
    "Quotient",
    "quotient_model",
    "default_pole_sequence",
    "plant_scale",
    "least_order_row",
    "LeastOrderRow",
    "quotient_target_gains",
    "NU_PF_MAX",
    "parity_basis_row",
]

SEE_TOL = 1e-8
"""Relative gain above which a target counts as seen by a parity space."""

NU_PF_MAX = 12
"""Largest degree whose parity space is computed in the partial-fraction basis; above it
the basis is too ill-conditioned (distinct poles over two decades) and only the top
degree (the largest observability index, where the space holds every residual) is
decided, on the quotient's own transfer."""

ONB_CHECK_FROM = 2
"""Degree from which a target the partial-fraction basis misses is checked again in the
orthonormal basis (:func:`_onb_spectral`)."""

SEE_OVERRIDE = 1e-6
"""Relative gain a target needs in the orthonormal basis to override a miss of the
partial-fraction basis (a margin of 100 over ``SEE_TOL``)."""

ONB_GAP_MIN = 1e6
"""Singular-value gap of a high-degree parity space (orthonormal basis) above which a
target it misses counts as unseen at that degree (for the least-order certificate)."""


# ------------------------------------------------------------------ parity space
def _fresh(st: Staircase, nu: int) -> int:
    """Vectors of degree ν in a minimal polynomial basis of the parity space.

    The degree-ν space holds the multiples ``a(s) v(s)`` of the degree-(ν − 1) space
    (dimension ``2 d_{ν−1} − d_{ν−2}``); the rest, ``d_ν − 2 d_{ν−1} + d_{ν−2}``, are new
    minimal-basis vectors (their degrees are the observability indices of the quotient,
    Varga 2017, Section 10.4).  A degree with none sees no target its predecessor misses.
    """
    dims = [st.parity_dim(v) if v >= 0 else 0 for v in (nu, nu - 1, nu - 2)]
    return dims[0] - 2 * dims[1] + dims[2]


def _blocks(Qm: Quotient, poles: np.ndarray) -> tuple[list[np.ndarray], list[tuple[str, int]]]:
    """Real row blocks of the degree-ν parity condition, each normalised to unit norm.

    Real pole: ``M (λ − A0)⁻¹``; conjugate pair (listed once, Im λ > 0): real and
    imaginary parts of ``M (λ − A0)⁻¹``.  Returns the blocks and their kinds.
    """
    k = Qm.k
    out = [Qm.M]
    kinds: list[tuple[str, int]] = [("h", -1)]
    i = 0
    while i < len(poles):
        lam = poles[i]
        R = np.linalg.solve((lam * np.eye(k) - Qm.A0).T, Qm.M.T).T if k else Qm.M[:, :0]
        if abs(lam.imag) > 0:
            out += [R.real, R.imag]
            kinds += [("re", i), ("im", i)]
            i += 2
        else:
            out.append(R.real)
            kinds.append(("r", i))
            i += 1
    return out, kinds


def _null_rows(blocks: list[np.ndarray], dim: int | None = None) -> tuple[np.ndarray, int, float]:
    """Real left null space of the stacked normalised blocks.

    ``dim``: its dimension, known from the observer staircase (no rank decision on the
    stacked matrix); ``None``: decided by the tolerance policy.  Returns (basis with
    orthonormal columns in the *normalised* coordinates, rank, singular-value gap at
    the rank).
    """
    norms = [_bnorm(b) for b in blocks]
    R = np.vstack([b / s for b, s in zip(blocks, norms, strict=True)])
    rows, k = R.shape
    if k == 0:
        return np.eye(rows), 0, np.inf
    U, s, _ = np.linalg.svd(R, full_matrices=True)
    if dim is None:
        dec = rank_decision(s, 1.0, max(rows, k), what="degree-ν parity space", warn=False)
        return U[:, dec.rank :], dec.rank, dec.gap
    rank = rows - dim
    kept = float(s[rank - 1]) if rank > 0 else 1.0
    dropped = float(s[rank]) if rank < s.size else 0.0
    return U[:, rank:], rank, kept / max(dropped, np.finfo(float).eps)


def _bnorm(b: np.ndarray) -> float:
    nb = _norm2(b)
    return nb if nb > 0 else 1.0


def _unnormalise(X: np.ndarray, blocks: list[np.ndarray]) -> np.ndarray:
    norms = np.concatenate([np.full(b.shape[0], _bnorm(b)) for b in blocks])
    return X / norms[:, None]


def _points(Qm: Quotient, poles: np.ndarray, omega: float, count: int = 3) -> np.ndarray:
    rng = np.random.default_rng(2024)
    eig = np.concatenate([Qm.eigenvalues if Qm.k else np.zeros(0), poles])
    rad = max(float(np.max(np.abs(eig))) if eig.size else 0.0, omega, 1e-300)
    r = rad * rng.uniform(0.5, 1.5, count)
    th = rng.uniform(0.3, np.pi - 0.3, count)
    return r * np.exp(1j * th)


def _target_maps(
    Qm: Quotient, poles: np.ndarray, kinds: list[tuple[str, int]], s: complex
) -> list[np.ndarray]:
    """Per target j, the complex matrix W_j(s) with response ``x W_j(s)`` (x: real coords).

    ``r_f(s) = x_0 D_f − Σ_i x_i (D_f + M (λ_i − A0)⁻¹ B_f) / (s − λ_i)``; a pair with
    ``x_p = (α − iβ)/2`` contributes ``−(α/2)(U + V) + (iβ/2)(U − V)``, with U, V the
    terms of λ and λ̄.
    """
    k = Qm.k
    out = []
    Bfall = np.hstack(Qm.Bf) if Qm.Bf else np.zeros((k, 0))
    Dfall = np.hstack(Qm.Df) if Qm.Df else np.zeros((Qm.rho, 0))
    widths = [b.shape[1] for b in Qm.Bf]
    res: dict[int, np.ndarray] = {}
    rows = []
    for kind, i in kinds:
        if kind == "h":
            rows.append(Dfall.astype(complex))
            continue
        lam = poles[i]
        if i not in res:
            Rl = np.linalg.solve((lam * np.eye(k) - Qm.A0).T, Qm.M.T).T if k else Qm.M[:, :0]
            U = (Dfall + Rl @ Bfall) / (s - lam)
            Rc = Rl.conj()
            V = (Dfall + Rc @ Bfall) / (s - np.conj(lam))
            res[i] = (U, V)  # type: ignore[assignment]
        U, V = res[i]  # type: ignore[misc]
        if kind == "r":
            rows.append(-U)
        elif kind == "re":
            rows.append(-(U + V) / 2)
        else:
            rows.append(1j * (U - V) / 2)
    Wall = np.vstack(rows)
    edges = np.cumsum([0, *widths])
    for j in range(len(widths)):
        out.append(Wall[:, edges[j] : edges[j + 1]])
    return out


def _target_grams(
    Qm: Quotient,
    poles: np.ndarray,
    kinds: list[tuple[str, int]],
    X: np.ndarray,
    points: np.ndarray,
    blocks: list[np.ndarray],
) -> tuple[list[np.ndarray], np.ndarray]:
    """Gram matrices of the targets' responses on the null space (normalised coords).

    Returns (per target ``G_j = Re(Γ_j Γ_jᴴ)``, relative gain of each target on the
    space: ``‖Γ_j‖ / ‖W_j‖``).
    """
    Xu = _unnormalise(X, blocks)
    norms = np.concatenate([np.full(b.shape[0], _bnorm(b)) for b in blocks])
    nt = len(Qm.Bf)
    gam: list[list[np.ndarray]] = [[] for _ in range(nt)]
    full: list[list[np.ndarray]] = [[] for _ in range(nt)]
    for s in points:
        Ws = _target_maps(Qm, poles, kinds, s)
        for j in range(nt):
            gam[j].append(Xu.T @ Ws[j])
            full[j].append(Ws[j] / norms[:, None])
    grams, rel = [], np.zeros(nt)
    for j in range(nt):
        Gj = np.hstack(gam[j]) if gam[j] else np.zeros((X.shape[1], 0))
        Fj = np.hstack(full[j])
        ref = _norm2(Fj)
        rel[j] = _norm2(Gj) / ref if ref > 0 else 0.0
        grams.append((Gj @ Gj.conj().T).real / max(_norm2(Gj) ** 2, 1e-300))
    return grams, rel


def _maxmin_direction(grams: list[np.ndarray]) -> tuple[np.ndarray, float]:
    """Unit real α maximising ``min_j αᵀ G_j α`` (each G_j normalised to norm 1).

    Candidates: every target's own best direction, signed sums of them and a few
    random directions; the best is refined by ascent on the currently weakest target
    (``α ← α + G_j α / 2``, normalised); the best iterate is kept.
    """
    d = grams[0].shape[0]
    if d == 1:
        a = np.ones(1)
        return a, float(min(float(G[0, 0]) for G in grams))

    def value(a: np.ndarray) -> float:
        return float(min(a @ G @ a for G in grams))

    tops = [np.linalg.eigh(G)[1][:, -1] for G in grams]
    rng = np.random.default_rng(11)
    cands = list(tops)
    for _ in range(8):  # signed sums of the targets' own best directions
        signs = rng.choice([-1.0, 1.0], len(tops))
        cands.append(sum(sg * t for sg, t in zip(signs, tops, strict=True)))
    cands += list(rng.standard_normal((16, d)))
    cands = [c / max(np.linalg.norm(c), 1e-300) for c in cands]
    best, bval = cands[0], value(cands[0])
    for a in cands:
        v = value(a)
        if v > bval:
            best, bval = a, v
    a = best.copy()
    for _ in range(100):  # ascent on the currently weakest target
        g = np.array([a @ G @ a for G in grams])
        j = int(np.argmin(g))
        a = a + 0.5 * grams[j] @ a
        a /= max(np.linalg.norm(a), 1e-300)
        v = value(a)
        if v > bval:
            best, bval = a.copy(), v
    return best / np.linalg.norm(best), bval


def quotient_target_gains(Qm: Quotient, points: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
    """Gram matrices of the quotient's target transfers and each target's relative size.

    ``G_j(s) = M (sI − A0)⁻¹ B_fj + H D_fj`` (ρ × m_j): every residual of the row is
    ``v(s) G_j(s)`` on target j, so target j is seen by some residual iff ``G_j ≢ 0``.
    Returns ``grams[j] = Re Σ_s G_j G_jᴴ`` normalised to norm 1 and
    ``size[j] = ‖[G_j(s_1) …]‖ / ((1 + max_s ‖M (sI − A0)⁻¹‖) max(‖B_fj‖, ‖H D_fj‖))``,
    the target's size relative to the quotient's own transfer (rounding counts as 0).
    """
    rho = Qm.rho
    nt = len(Qm.Bf)
    cols: list[list[np.ndarray]] = [[] for _ in range(nt)]
    ref = 1.0
    for R in Qm.resolvent_rows(points):
        ref = max(ref, _norm2(R) + 1.0)
        for j in range(nt):
            cols[j].append(R @ Qm.Bf[j] + Qm.Df[j])
    grams, size = [], np.zeros(nt)
    for j in range(nt):
        Gj = np.hstack(cols[j]) if cols[j] else np.zeros((rho, 0))
        scale = max(_norm2(Qm.Bf[j]), _norm2(Qm.Df[j]), 1e-300)
        nG = _norm2(Gj)
        size[j] = nG / (ref * scale)
        grams.append((Gj @ Gj.conj().T).real / max(nG**2, 1e-300))
    return grams, size


@dataclass
class LeastOrderRow:
    """One scalar least-order row: realisation on the quotient and its certificate."""

    order: int
    F: np.ndarray | None
    Gs: np.ndarray | None
    T: np.ndarray | None
    c: np.ndarray | None
    h: np.ndarray | None
    poles: np.ndarray
    certificate: dict[str, Any]
    direct: dict[str, Any] | None = None
    """A realisation reading y and u directly (no ``(G_s, T)``): ``E``, ``G`` and its
    ``identities`` (:mod:`geomfdi.synthesis.least_order.orthonormal_row`)."""

    @property
    def realised(self) -> bool:
        """False when the degree search ended above ``NU_PF_MAX``: the row is to be
        realised as the quotient observer
        (:mod:`geomfdi.synthesis.least_order.quotient_observer`)."""
        return self.F is not None


def _realise(
    Qm: Quotient,
    poles: np.ndarray,
    kinds: list[tuple[str, int]],
    x: np.ndarray,
    sizes: list[int],
    blocks: list[np.ndarray] | None = None,
) -> tuple[np.ndarray, ...]:
    """Functional observer ``(Λ, G_s, T, c, h)`` of the real null vector x (module Notes);
    ``blocks``: those of :func:`_blocks` at these poles (``M (λ − A0)⁻¹``, not solved again)."""
    nu = len(poles)
    rho, k = Qm.rho, Qm.k
    edges = np.cumsum([0, *sizes])
    part = [x[edges[b] : edges[b + 1]] for b in range(len(sizes))]
    F = np.zeros((nu, nu))
    Gs = np.zeros((nu, rho))
    T = np.zeros((nu, k))
    c = np.zeros(nu)
    h = part[0]
    b = 1
    for pos, (kind, i) in enumerate(kinds):
        if kind in ("h", "im"):
            continue
        lam = poles[i]
        if blocks is not None:
            R = blocks[pos] + 1j * blocks[pos + 1] if kind == "re" else blocks[pos]
        elif k:
            R = np.linalg.solve((lam * np.eye(k) - Qm.A0).T, Qm.M.T).T
        else:
            R = Qm.M[:, :0]
        if kind == "r":
            xi = part[b]
            F[i, i] = lam.real
            T[i] = xi @ R.real
            Gs[i] = -xi
            c[i] = 1.0
            b += 1
        else:  # pair (λ, λ̄): x_p = (α − iβ)/2, states (Re ζ, Im ζ)
            alpha, beta = part[b], part[b + 1]
            xp = (alpha - 1j * beta) / 2
            t = xp @ R
            a_, w_ = lam.real, lam.imag
            F[i : i + 2, i : i + 2] = [[a_, -w_], [w_, a_]]
            T[i], T[i + 1] = t.real, t.imag
            Gs[i], Gs[i + 1] = (-xp).real, (-xp).imag
            c[i], c[i + 1] = 2.0, 0.0
            b += 2
    return F, Gs, T, c, h


def least_order_row(
    Qm: Quotient,
    *,
    poles: Any = None,
    omega: float = 1.0,
    dt: float = 0.0,
    min_order: int = 0,
    prefix: bool = False,
    dc: bool = False,
) -> LeastOrderRow:
    """Least-order scalar row of the quotient that sees every target.

    Parameters
    ----------
    Qm : Quotient
    poles : sequence, optional
        Generator poles; the row of order ν uses the first ν.  Default:
        :func:`default_pole_sequence`.
    omega, dt : float
        Plant scale and sampling period for the default poles.
    min_order : int
        Search from this degree on (used for extra rows).
    prefix : bool
        Accept more poles than the order and use the first ν (a bank with common poles);
        otherwise exactly ν poles are required.
    dc : bool
        Choose the direction by the targets' gains at DC (s = 0, or z = 1) when every
        target has a non-zero DC gain on the space (strong detectability); otherwise,
        and by default, by the gains at the random points.

    Raises
    ------
    DesignError
        ``argument="faults"`` with ``reason`` when no degree sees every target (the
        certificate names the unseen targets), ``argument="poles"`` for bad poles.
    """
    k, rho = Qm.k, Qm.rho
    nt = len(Qm.Bf)
    if rho == 0:
        why = "no measurement combination is blind to the decoupled signals"
        if k == 0:
            n_plant, extra = Qm.P.shape[1], Qm.n_aug - Qm.P.shape[1]
            dims = (
                f"dim S* = n_d = {Qm.n_aug} (the design model's dimension: plant n = "
                f"{n_plant} + {extra} states of decoupled faults on the outputs)"
                if extra
                else f"dim S* = n = {n_plant} (the plant's state dimension)"
            )
            why = f"{dims} and {why}"
        raise _Infeasible(why, {})
    user = None if poles is None else validate_poles(poles, dt)
    st = observer_staircase(Qm.A0, Qm.M) if k else Staircase(Qm.A0, Qm.M, np.eye(0), [])
    top = st.max_index
    dims, ranks, history = [], [], []
    nu = max(0, min_order)
    pool = default_pole_sequence(min(k, NU_PF_MAX) + 2, omega, dt)
    if Qm.k:  # keep default poles clear of the quotient's spectrum
        pool = clear_of_spectrum(pool, Qm.eigenvalues, omega).real
    unseen_at: dict[int, list[int]] = {}
    undecided: list[int] = []
    staircase = {"blocks": st.blocks, "gaps": st.gaps, "indices": st.indices}

    def infeasible(unseen: list[int]) -> _Infeasible:
        return _Infeasible(
            "the targets "
            + str(unseen)
            + " are not seen by any residual that decouples the other signals "
            f"(their transfer vanishes on the whole parity space of degree {nu})",
            {"unseen": unseen, "history": history},
        )

    while True:
        dim = st.parity_dim(nu)
        dims.append(dim)
        ranks.append((nu + 1) * rho - dim)
        if dim == 0:  # the staircase says: no residual of this degree
            history.append({"order": nu, "dim": 0, "rank": ranks[-1], "gap": np.inf})
            unseen_at[nu] = list(range(nt))
            nu += 1
            continue
        if nu > min_order and nu - 1 in unseen_at and _fresh(st, nu) == 0:
            # no minimal-basis vector of degree ν: the space is the polynomial multiples
            # of the degree-(ν − 1) one and sees exactly the targets that one sees; what
            # a basis computed here would add is rounding
            history.append({"order": nu, "dim": dim, "rank": ranks[-1], "gap": np.inf})
            unseen_at[nu] = list(unseen_at[nu - 1])
            if nu >= top:
                raise infeasible(unseen_at[nu])
            nu += 1
            continue
        if nu > NU_PF_MAX and user is None:
            # a row of one output combination at its top degree is the whole quotient:
            # realised by geomfdi.synthesis.least_order.orthonormal_row, not as a parity vector
            onb = _onb_degree(Qm, nu, dim, omega, dt) if Qm.rho > 1 or nu < top else None
            if onb is not None:
                space, cand = onb
                seen = space["rel"] > SEE_TOL
                if np.all(seen) and nt:
                    history.append(
                        {"order": nu, "dim": dim, "rank": ranks[-1], "gap": space["gap"]}
                    )
                    return _onb_row(
                        Qm, nu, space, cand, dims, ranks, history, staircase, unseen_at, undecided
                    )
                if space["gap"] >= ONB_GAP_MIN:  # a clear space: its unseen targets count
                    history.append(
                        {"order": nu, "dim": dim, "rank": ranks[-1], "gap": space["gap"]}
                    )
                    unseen_at[nu] = [int(j) for j in np.flatnonzero(~seen)]
                    if nu < top:
                        nu += 1
                        continue
                    history.pop()  # the top degree is decided below, on the quotient itself
            if nu < top:  # the partial-fraction basis is too ill-conditioned to decide
                history.append({"order": nu, "dim": dim, "rank": ranks[-1], "gap": None})
                undecided.append(nu)
                nu += 1
                continue
            _, size = quotient_target_gains(Qm, _points(Qm, np.zeros(0), omega, count=4))
            history.append({"order": nu, "dim": dim, "rank": ranks[-1], "gap": None})
            if not np.all(size > SEE_TOL) or not nt:
                raise infeasible([int(j) for j in np.flatnonzero(~(size > SEE_TOL))])
            cert = _high_certificate(
                nu,
                dims,
                ranks,
                history,
                staircase,
                unseen_at,
                undecided,
                size,
                f"least order between {undecided[0] if undecided else nu} (no residual of "
                f"lower degree, by the observer staircase) and {nu} (the largest "
                "observability index)",
            )
            return LeastOrderRow(nu, None, None, None, None, None, np.zeros(0), cert)
        cand = _check_poles(pool[:nu].astype(complex), Qm.A0, dt, Qm.eigenvalues)
        blocks, kinds = _blocks(Qm, cand)
        X, rank, gap = _null_rows(blocks, dim)
        pts = _points(Qm, cand, omega)
        grams, rel = _target_grams(Qm, cand, kinds, X, pts, blocks)
        seen = rel > SEE_TOL
        history.append({"order": nu, "dim": X.shape[1], "rank": rank, "gap": gap})
        if np.all(seen) and nt:
            break
        if nt and nu >= ONB_CHECK_FROM and user is None and min_order == 0:
            # the partial-fraction basis loses weakly seen targets as ν grows: a target
            # counts as missed only if the orthonormal basis on the quotient's own
            # frequencies misses it too (or sees it only at rounding level)
            sp = _onb_spectral(Qm, nu, X.shape[1], omega, dt)
            if sp is not None and np.min(sp[0]["rel"]) > SEE_OVERRIDE:
                return _onb_row(
                    Qm, nu, sp[0], sp[1], dims, ranks, history, staircase, unseen_at, []
                )
        unseen_at[nu] = [int(j) for j in np.flatnonzero(~seen)]
        if nu >= top:
            raise infeasible(unseen_at[nu])
        nu += 1
    if user is not None:  # the space does not depend on the poles: redo it at the user's
        if user.size != nu and not (prefix and user.size > nu):
            raise DesignError(
                f"poles: expected {nu} poles (the least order of this residual), got {user.size}",
                argument="poles",
            )
        cand = user[:nu]
        if np.count_nonzero(cand.imag > 0) != np.count_nonzero(cand.imag < 0):
            raise DesignError(
                f"poles: the first {nu} poles split a conjugate pair", argument="poles"
            )
        cand = _check_poles(cand, Qm.A0, dt, Qm.eigenvalues)
        blocks, kinds = _blocks(Qm, cand)
        X, rank, gap = _null_rows(blocks, st.parity_dim(nu))
        grams, rel = _target_grams(Qm, cand, kinds, X, _points(Qm, cand, omega), blocks)
        if X.shape[1] == 0 or not np.all(rel > SEE_TOL):
            raise DesignError(
                "poles: the requested poles make the parity space ill-conditioned; choose others",
                argument="poles",
            )
    if dc:
        s0 = np.array([1.0 if dt > 0 else 0.0], dtype=complex)
        grams_dc, rel_dc = _target_grams(Qm, cand, kinds, X, s0, blocks)
        if np.all(rel_dc > SEE_TOL):
            grams = grams_dc
    alpha, val = _maxmin_direction(grams)
    x = _unnormalise(X, blocks) @ alpha
    sizes = [b.shape[0] for b in blocks]
    F, Gs, T, c, h = _realise(Qm, cand, kinds, x, sizes, blocks)
    edges = np.cumsum([0, *sizes])
    cert = {
        "order": nu,
        "row_in_y": [x[edges[b] : edges[b + 1]] @ Qm.H for b in range(len(sizes))],
        "blocks": [kind for kind, _ in kinds],
        "parity_dims": dims,
        "ranks": ranks,
        "history": history,
        "staircase": staircase,
        "realisation": "partial fractions",
        "unseen_below": {int(a): b for a, b in unseen_at.items()},
        "min_target_gain": float(np.sqrt(max(val, 0.0))),
        "target_gain_on_space": rel.tolist(),
        "statement": (
            f"order {nu} is least: "
            + (
                "order 0 is the minimum"
                if nu == 0
                else f"the degree-{nu - 1} parity space does not see targets "
                f"{unseen_at.get(nu - 1, [])}"
            )
        ),
    }
    return LeastOrderRow(nu, F, Gs, T, c, h, cand, cert)


def _onb_spectral(
    Qm: Quotient, nu: int, dim: int, omega: float, dt: float
) -> tuple[dict[str, Any], np.ndarray] | None:
    """The degree-ν space in the orthonormal basis with poles on the quotient's
    frequencies, or ``None`` when it cannot be computed."""
    poles = spectral_pole_set(Qm.A0, nu, omega, dt)
    try:
        return onb_parity_space(Qm, nu, dim, poles, dt, _points(Qm, poles, omega)), poles
    except (np.linalg.LinAlgError, ValueError):
        return None


def _onb_degree(
    Qm: Quotient, nu: int, dim: int, omega: float, dt: float
) -> tuple[dict[str, Any], np.ndarray] | None:
    """The degree-ν space in the orthonormal basis
    (:mod:`geomfdi.synthesis.least_order.parity_spaces`)
    with poles on the quotient's frequencies (:func:`spectral_pole_set`); a space that
    misses a target is computed again with the default pole sequence, and a target
    counts as missed only when both miss it.  ``None`` when it cannot be computed (then
    the quotient observer is the fallback)."""
    best = None
    for kind in ("spectral", "default"):
        if kind == "spectral":
            got = _onb_spectral(Qm, nu, dim, omega, dt)
            if got is None:
                continue
            space, poles = got
        else:
            eig = Qm.eigenvalues if Qm.k else np.zeros(0)
            poles = clear_of_spectrum(default_pole_sequence(nu, omega, dt), eig, omega)
            try:
                space = onb_parity_space(Qm, nu, dim, poles, dt, _points(Qm, poles, omega))
            except (np.linalg.LinAlgError, ValueError):
                continue
        if np.all(space["rel"] > SEE_TOL):
            return space, poles
        if best is None:
            best = (space, poles)
        else:  # missed by both bases
            both = np.maximum(space["rel"], best[0]["rel"])
            space["rel"] = best[0]["rel"]
            # a target one basis sees and the other misses is not decided either way
            seen_by_one = both > SEE_TOL
            space["gap"] = (
                0.0
                if np.any(seen_by_one & ~(space["rel"] > SEE_TOL))
                else min(space["gap"], best[0]["gap"])
            )
            best = (space, poles)
    return best


def _onb_realise(space: dict[str, Any], rho: int) -> tuple[Any, ...]:
    """``(Λ, G_s, T, c, h, value)`` of the space's max–min direction (section 4)."""
    grams = [(W @ W.conj().T).real / max(_norm2(W) ** 2, 1e-300) for W in space["W"]]
    alpha, val = _maxmin_direction(grams)
    return (*realise_onb(space, space["X"] @ alpha, rho), val)


def _high_certificate(
    nu: int,
    dims: list[int],
    ranks: list[int],
    history: list[dict[str, Any]],
    staircase: dict[str, Any],
    unseen_at: dict[int, list[int]],
    undecided: list[int],
    gains: np.ndarray,
    undecided_statement: str,
) -> dict[str, Any]:
    """Certificate of a row found above the partial-fraction degrees."""
    return {
        "order": nu if not undecided else None,
        "bounds": (undecided[0] if undecided else nu, nu),
        "parity_dims": dims,
        "ranks": ranks,
        "history": history,
        "staircase": staircase,
        "unseen_below": {int(a): b for a, b in unseen_at.items()},
        "target_gain_on_space": np.asarray(gains).tolist(),
        "statement": (
            f"order {nu} is least: the degree-{nu - 1} parity space does not see targets "
            f"{unseen_at.get(nu - 1, [])}"
            if not undecided
            else undecided_statement
        ),
    }


def _onb_row(
    Qm: Quotient,
    nu: int,
    space: dict[str, Any],
    cand: np.ndarray,
    dims: list[int],
    ranks: list[int],
    history: list[dict[str, Any]],
    staircase: dict[str, Any],
    unseen_at: dict[int, list[int]],
    undecided: list[int],
) -> LeastOrderRow:
    """The least-order row of a degree above ``NU_PF_MAX`` (orthonormal basis)."""
    F, Gs, T, c, h, val = _onb_realise(space, Qm.rho)
    low = undecided[0] if undecided else nu
    cert = _high_certificate(
        nu,
        dims,
        ranks,
        history,
        staircase,
        unseen_at,
        undecided,
        space["rel"],
        f"order {nu}: no residual of degree < {low} (observer staircase); degrees "
        f"{undecided} were not decided",
    )
    cert["realisation"] = "orthonormal parity basis"
    cert["min_target_gain"] = float(np.sqrt(max(val, 0.0)))
    return LeastOrderRow(nu, F, Gs, T, c, h, cand, cert)


def parity_basis_row(Qm: Quotient, lo: LeastOrderRow, *, omega: float, dt: float) -> LeastOrderRow:
    """The least-order row ``lo`` (found in partial fractions) realised again in the
    orthonormal parity basis of :mod:`geomfdi.synthesis.least_order.parity_spaces`.

    Used when the partial-fraction realisation fails its checks on the plant: the same
    degree, a well-conditioned basis, instead of the quotient observer of order k.

    Raises
    ------
    numpy.linalg.LinAlgError
        Degree 0 (nothing to realise dynamically), or the space misses a target.
    """
    nu = lo.order
    if nu == 0 or Qm.k == 0:
        raise np.linalg.LinAlgError("orthonormal parity basis: nothing to realise")
    blocks = lo.certificate.get("staircase", {}).get("blocks")
    if blocks is None:
        dim = observer_staircase(Qm.A0, Qm.M).parity_dim(nu)
    else:  # the staircase of the search: (ν + 1) ρ − Σ_{j ≤ ν+1} ρ_j
        dim = (nu + 1) * Qm.rho - int(sum(blocks[: nu + 1]))
    onb = _onb_degree(Qm, nu, dim, omega, dt) if dim > 0 else None
    if onb is None or not np.all(onb[0]["rel"] > SEE_TOL):
        raise np.linalg.LinAlgError("orthonormal parity basis: the space misses a target")
    space, cand = onb
    F, Gs, T, c, h, val = _onb_realise(space, Qm.rho)
    cert = dict(lo.certificate)
    cert["realisation"] = "orthonormal parity basis"
    cert["min_target_gain"] = float(np.sqrt(max(val, 0.0)))
    return LeastOrderRow(nu, F, Gs, T, c, h, cand, cert)


class _Infeasible(Exception):
    def __init__(self, reason: str, data: dict[str, Any]) -> None:
        super().__init__(reason)
        self.reason = reason
        self.data = data


def realise_on_plant(Qm: Quotient, row: LeastOrderRow, Du: np.ndarray) -> dict[str, np.ndarray]:
    """The row as ``(F, E, G, M, H, K)`` reading the measured y and u.

    ``ζ' = Λ ζ + (G_s H + T B_qy) y + (T B_qu − G_s H D_u) u``, ``r = c ζ + h H y − h H D_u u``.
    """
    F, Gs, T, c, h = row.F, row.Gs, row.T, row.c, row.h
    H = Qm.H
    if row.direct is not None:
        return {
            "F": F,
            "E": row.direct["E"],
            "G": row.direct["G"],
            "M": c.reshape(1, -1),
            "H": -(h @ H).reshape(1, -1),
            "K": -(h @ H @ Du).reshape(1, -1),
            "identities": dict(row.direct["identities"]),
        }
    E = -(Gs @ H + T @ Qm.Bqy)
    G = T @ Qm.Bqu - Gs @ H @ Du
    Mg = c.reshape(1, -1)
    Hg = -(h @ H).reshape(1, -1)
    Kg = -(h @ H @ Du).reshape(1, -1)
    nT, nA0, nM = _norm2(T), Qm.norm("A0"), Qm.norm("M")
    scale = max(nT * nA0, _norm2(F) * nT, _norm2(Gs) * nM, 1e-300)
    ident = {
        "T A0 − Λ T = G_s M": float(_norm2(T @ Qm.A0 - F @ T - Gs @ Qm.M) / scale)
        if T.size
        else 0.0,
        "c T + h M = 0": float(
            _norm2(c @ T + h @ Qm.M) / max(_norm2(c) * nT, _norm2(h) * nM, 1e-300)
        ),
    }
    return {"F": F, "E": E, "G": G, "M": Mg, "H": Hg, "K": Kg, "identities": ident}
