"""Exact and parametric residual-generator synthesis (``design_bank(..., exact=True)``).

The construction of :mod:`geomfdi.synthesis.design` (Hou, Wen & Chen 2011, eq. 17–23, with
the exact sensor-fault transform) carried out over the field ``K = Q(p_1, ..., p_k)`` of
rational functions of the plant's parameters (``K = Q`` for a plant of rationals):

* design model of the exact transform: output filter ``z' = −a z + a y_F`` on the channels
  touched by decoupled output parts (discrete ``z⁺ = a z + (1 − a) y_F``);
* ``S = S*(Σ_{j decoupled} Im L_j + Im L_d)`` over ``K`` (generic ranks);
* ``P`` = rows spanning the annihilator of S, ``R`` a right inverse (``P R = I``, built on
  pivot columns — any right inverse works, the identities below do not depend on it);
* ``D0 = −R P A S_π X⁻`` with ``S_π`` the columns of S whose images ``X = C S_π`` are
  independent and ``X⁻`` a left inverse of ``X``; then ``P (A + D0 C) S = 0``;
* ``H`` = rows spanning ``Im C ∩ (C S)^⊥`` (plus the parity rows of ``(Im C)^⊥`` that see
  a target's direct part), ``M = H C R``, ``A0 = P (A + D0 C) R``;
* ``D1`` by Ackermann's formula on one combination of the rows of ``M`` (the first one
  for which ``(c M, A0)`` is observable): ``eig(A0 + D1 M)`` = the requested poles;
* ``F = A0 + D1 M``, ``E = P (D0 + R D1 H)``, ``G = P B + E Du``, ``K = H Du``.

The delivered generator is **not** reduced to a minimal realisation (its order is the
quotient order ``n_design − dim S*``).  The decoupling and the visibility of every target
are then checked exactly on the physical model (Markov parameters over ``K``).

Every pivot of every elimination is recorded; the irreducible factors of the pivots and
of the delivered denominators are candidates for the **exceptional set** (where a pivot
vanishes, a rank of the construction may drop).  A candidate linear in some parameter is
checked on the family specialised to it: the delivered generator is evaluated there and
its transfers are recomputed exactly on the specialised plant.  If an entry has a pole
there it is a ``"formula"`` condition; if a target becomes invisible or a decoupling is
lost, a ``"fails"`` condition; otherwise it is an artefact of the chosen bases and
dropped.  A candidate that cannot vanish under the symbols' assumptions (``k + 1`` with
``k > 0``) is dropped; one not linear in any parameter is kept as an unchecked
``"candidate"``.

See the user guide, *Theory: verification* (``docs/theory/verification.md``), section
"Parametric plants".
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np
import sympy as sp
from sympy.polys.matrices import DomainMatrix

from geomfdi.errors import DesignError, GeomFDIError, NotIsolableError
from geomfdi.generators.exact import (
    ExactResidualBank,
    ExactResidualGenerator,
    ExceptionalCondition,
)
from geomfdi.geometry import parametric as pm
from geomfdi.model.faults import Fault, SensorFault, fault_matrices
from geomfdi.model.plant import Plant, as_plant
from geomfdi.synthesis.construction import design_dims, row_poles, row_split, target_decouple

__all__ = ["design_bank_exact", "design_sensor_bank_exact", "default_exact_poles"]

MAX_EXACT_ORDER = 16
"""Largest design-model order accepted by the exact design (checked up front)."""


def default_exact_poles(k: int, dt: float) -> list[sp.Rational]:
    """Default quotient spectrum of the exact design: ``−1, −2, …, −k`` (discrete ``2^−i``)."""
    if dt > 0:
        return [sp.Rational(1, 2**i) for i in range(1, k + 1)]
    return [sp.Integer(-i) for i in range(1, k + 1)]


class _Ctx:
    """The field, the plant data over it and the fault signatures."""

    def __init__(
        self,
        mats: dict[str, sp.Matrix],
        sigs: list[tuple[sp.Matrix, sp.Matrix]],
        dt: float,
        extra: Sequence[Any],
    ) -> None:
        self.F = pm.field_of(*mats.values(), *[x for s in sigs for x in s], extra=extra)
        self.mats = mats
        self.sigs = sigs
        self.dt = dt
        K = self.F.K
        self.dm = {k: self._dm(v) for k, v in mats.items()}
        self.dsigs = [(self._dm(b), self._dm(d)) for b, d in sigs]
        self.K = K

    def _dm(self, M: sp.Matrix) -> DomainMatrix:
        return DomainMatrix(self.F.matrix(M), M.shape, self.F.K)

    def elem(self, x: Any) -> Any:
        return self.F.elem(x)


def _lst(X: DomainMatrix) -> list[list[Any]]:
    return X.to_list()


def _dmz(K: Any, r: int, c: int) -> DomainMatrix:
    return DomainMatrix.zeros((r, c), K)


def _from(K: Any, rows: list[list[Any]], r: int, c: int) -> DomainMatrix:
    return DomainMatrix(rows, (r, c), K) if r and c else _dmz(K, r, c)


def _rows(X: DomainMatrix, idx: Sequence[int]) -> DomainMatrix:
    return X.extract(list(idx), list(range(X.shape[1]))) if idx else _dmz(X.domain, 0, X.shape[1])


def _hstack(K: Any, r: int, *blocks: DomainMatrix) -> DomainMatrix:
    blocks = tuple(b for b in blocks if b.shape[1])
    if not blocks:
        return _dmz(K, r, 0)
    return blocks[0].hstack(*blocks[1:]) if len(blocks) > 1 else blocks[0]


def _vstack(K: Any, c: int, *blocks: DomainMatrix) -> DomainMatrix:
    blocks = tuple(b for b in blocks if b.shape[0])
    if not blocks:
        return _dmz(K, 0, c)
    return blocks[0].vstack(*blocks[1:]) if len(blocks) > 1 else blocks[0]


def _subspace_dm(S: pm.GenericSubspace) -> DomainMatrix:
    return _from(S.F.K, S.basis, S.n, S.dim)


def _annihilator(F: pm.ParametricField, X: DomainMatrix) -> DomainMatrix:
    """Rows spanning ``{h : h X = 0}`` (X of shape (q, k))."""
    q, k = X.shape
    if k == 0:
        return DomainMatrix.eye(q, F.K)
    N = pm.nullspace(F, _lst(X.transpose()), q)
    d = len(N[0]) if N else 0
    return _from(F.K, N, q, d).transpose()


def _intersection_rows(F: pm.ParametricField, U: DomainMatrix, V: DomainMatrix) -> DomainMatrix:
    """Rows (as a (d, q) matrix) spanning ``Im U ∩ Im V`` (columns of U, V in K^q)."""
    q = U.shape[0]
    if U.shape[1] == 0 or V.shape[1] == 0:
        return _dmz(F.K, 0, q)
    N = pm.nullspace(F, _lst(U.hstack(-V)), U.shape[1] + V.shape[1])
    d = len(N[0]) if N else 0
    if d == 0:
        return _dmz(F.K, 0, q)
    Nu = _from(F.K, N, U.shape[1] + V.shape[1], d).extract(list(range(U.shape[1])), list(range(d)))
    S = pm.GenericSubspace(F, _lst(U * Nu), q, d)
    return _subspace_dm(S).transpose()


def _right_inverse(F: pm.ParametricField, P: DomainMatrix) -> DomainMatrix:
    """``R`` with ``P R = I`` from the pivot columns of P (full row rank)."""
    k, n = P.shape
    _, piv = pm.rref(F, _lst(P), n)
    if len(piv) < k:
        raise GeomFDIError("P: not of full row rank", argument="plant")
    Pp = P.extract(list(range(k)), piv)
    inv = _from(F.K, pm.inverse(F, _lst(Pp), k, "P"), k, k)
    R = _dmz(F.K, n, k)
    rows = _lst(R)
    invl = _lst(inv)
    for a, c in enumerate(piv):
        rows[c] = invl[a]
    return _from(F.K, rows, n, k)


def _friend(F: pm.ParametricField, A, C, Sd, P, R) -> DomainMatrix:
    n, q = A.shape[0], C.shape[0]
    if Sd.shape[1] == 0:
        return _dmz(F.K, n, q)
    CS = C * Sd
    _, pc = pm.rref(F, _lst(CS.transpose()), q)  # independent rows of C S
    _, pcols = pm.rref(F, _lst(CS), Sd.shape[1])  # independent columns of C S
    if not pcols:
        return _dmz(F.K, n, q)
    X = CS.extract(list(range(q)), pcols)
    Xr = X.extract(pc, list(range(len(pcols))))
    r = len(pcols)
    inv = pm.inverse(F, _lst(Xr), r, "C S")
    Xl = [[F.K.zero] * q for _ in range(r)]
    for a in range(r):
        for b, row in enumerate(pc):
            Xl[a][row] = inv[a][b]
    Xminus = _from(F.K, Xl, r, q)
    Spi = Sd.extract(list(range(n)), pcols)
    return -(R * (P * (A * Spi))) * Xminus


def _place(F: pm.ParametricField, A0, Mobs, poles: Sequence[Any], s: Any) -> DomainMatrix:
    """Ackermann: D1 with ``det(sI − A0 − D1 Mobs) = Π (s − p)``."""
    K = F.K
    k, nm = A0.shape[0], Mobs.shape[0]
    if k == 0:
        return _dmz(K, 0, nm)
    coeffs = [F.elem(c) for c in pm.poly_coeffs_from_roots(poles, s)]
    weights = [[K.one if i == j else K.zero for i in range(nm)] for j in range(nm)]
    weights += [[K.convert(j + 1) ** i for i in range(nm)] for j in range(4)]
    for w in weights:
        wd = _from(K, [w], 1, nm)
        c = wd * Mobs
        rows = []
        v = c
        for _ in range(k):
            rows.append(_lst(v)[0])
            v = v * A0
        if pm.rank(F, rows, k) < k:
            continue
        Oinv = _from(K, pm.inverse(F, rows, k, "observability matrix"), k, k)
        pA = _dmz(K, k, k)
        eye = DomainMatrix.eye(k, K)
        for coef in coeffs:
            pA = pA * A0 + eye * coef
        ek = _dmz(K, k, 1)
        ekl = _lst(ek)
        ekl[k - 1][0] = K.one
        ell = pA * (Oinv * _from(K, ekl, k, 1))
        return -(ell * wd)
    raise NotIsolableError(
        "M: the quotient (M, A0) is not observable for generic parameters; the poles cannot "
        "be placed",
        reason="quotient not observable",
    )


def _design_row(
    ctx: _Ctx, target: tuple[int, ...], decouple: tuple[int, ...], poles: Any, a: Any
) -> dict[str, Any]:
    """The exact construction for one row over ``ctx.F`` (see the module docstring)."""
    F, K = ctx.F, ctx.K
    A, B, C, D, Bd, Dd = (ctx.dm[k] for k in ("A", "B", "C", "D", "Bd", "Dd"))
    n, q, m = A.shape[0], C.shape[0], B.shape[1]
    sigs = ctx.dsigs
    touched = [
        i
        for i in range(q)
        if any(not _rows(sigs[j][1], [i]).is_zero_matrix for j in decouple)
        or (Dd.shape[1] and not _rows(Dd, [i]).is_zero_matrix)
    ]
    filt, raw = touched, [i for i in range(q) if i not in touched]
    nz = len(filt)
    if nz:
        ae = F.elem(a)
        gg = K.one - ae if ctx.dt > 0 else ae
        Azz = DomainMatrix.eye(nz, K) * (ae if ctx.dt > 0 else -ae)
        Ad = _vstack(
            K, n + nz, _hstack(K, n, A, _dmz(K, n, nz)), _hstack(K, nz, _rows(C, filt) * gg, Azz)
        )
        Bdm = _vstack(K, m, B, _rows(D, filt) * gg)
        Cd = _vstack(
            K,
            n + nz,
            _hstack(K, len(raw), _rows(C, raw), _dmz(K, len(raw), nz)),
            _hstack(K, nz, _dmz(K, nz, n), DomainMatrix.eye(nz, K)),
        )
        Du = _vstack(K, m, _rows(D, raw), _dmz(K, nz, m))
        Ls = [_vstack(K, Bf.shape[1], Bf, _rows(Df, filt) * gg) for Bf, Df in sigs]
        Ldist = _vstack(K, Bd.shape[1], Bd, _rows(Dd, filt) * gg)
        direct = [
            _vstack(
                K, sigs[j][1].shape[1], _rows(sigs[j][1], raw), _dmz(K, nz, sigs[j][1].shape[1])
            )
            for j in target
        ]
    else:
        Ad, Bdm, Cd, Du = A, B, C, D
        Ls = [Bf for Bf, _ in sigs]
        Ldist = Bd
        direct = [sigs[j][1] for j in target]
    nD, qD = Ad.shape[0], Cd.shape[0]
    L = _hstack(K, nD, *[Ls[j] for j in decouple], Ldist)
    S = pm.generic_unobservability_subspace(
        F,
        _lst(Ad),
        _lst(Cd),
        _lst(L) if L.shape[1] else [[] for _ in range(nD)],
        nD,
        qD,
        L.shape[1],
    )
    Sd = _subspace_dm(S)
    P = _from(K, S.complement_rows(), nD - S.dim, nD) if S.dim < nD else _dmz(K, 0, nD)
    kq = P.shape[0]
    R = _right_inverse(F, P) if kq else _dmz(K, nD, 0)
    D0 = _friend(F, Ad, Cd, Sd, P, R) if kq else _dmz(K, nD, qD)
    CS = Cd * Sd if S.dim else _dmz(K, qD, 0)
    Hobs = _intersection_rows(F, Cd, _annihilator(F, CS).transpose())
    # parity rows: (Im C)^⊥ rows reading a target's direct output part
    X = _hstack(K, qD, *direct)
    Nb = _annihilator(F, Cd)
    if X.shape[1] and Nb.shape[0] and not (Nb * X).is_zero_matrix:
        Nbt = Nb.transpose()
        G_ = _from(
            K, pm.inverse(F, _lst(Nb * Nbt), Nb.shape[0], "parity Gram"), Nb.shape[0], Nb.shape[0]
        )
        proj = Nbt * (G_ * (Nb * X))
        Hpar = _subspace_dm(pm.GenericSubspace(F, _lst(proj), qD, proj.shape[1])).transpose()
    else:
        Hpar = _dmz(K, 0, qD)
    if Hobs.shape[0] + Hpar.shape[0] == 0:
        raise NotIsolableError(
            f"{design_dims(nD, n)} and no parity relation reads the targets: decoupling faults "
            f"{list(decouple)} leaves nothing",
            reason="dim S* = n",
        )
    Mobs = Hobs * (Cd * R) if kq else _dmz(K, Hobs.shape[0], 0)
    A0 = P * ((Ad + D0 * Cd) * R) if kq else _dmz(K, 0, 0)
    s = sp.Symbol("s")
    pl = default_exact_poles(kq, ctx.dt) if poles is None else list(poles)
    if len(pl) != kq:
        raise DesignError(
            f"poles: expected {kq} poles for this row (its quotient order), got {len(pl)}",
            argument="poles",
        )
    D1obs = _place(F, A0, Mobs, pl, s) if kq else _dmz(K, 0, Hobs.shape[0])
    npar = Hpar.shape[0]
    H = _vstack(K, qD, Hobs, Hpar)
    Mq = _vstack(K, kq, Mobs, _dmz(K, npar, kq))
    D1 = _hstack(K, kq, D1obs, _dmz(K, kq, npar))
    Fq = A0 + D1 * Mq if kq else A0
    E = P * (D0 + R * (D1 * H)) if kq else _dmz(K, 0, qD)
    G = P * Bdm + E * Du if kq else _dmz(K, 0, m)
    Kf = H * Du
    if nz:  # the filter becomes part of the generator, which then reads y
        nr = len(raw)
        ER, Ez = (
            E.extract(list(range(kq)), list(range(nr))),
            E.extract(list(range(kq)), list(range(nr, nr + nz))),
        )
        HR, Hz = (
            H.extract(list(range(H.shape[0])), list(range(nr))),
            H.extract(list(range(H.shape[0])), list(range(nr, nr + nz))),
        )
        Fn = _vstack(K, kq + nz, _hstack(K, kq, Fq, -Ez), _hstack(K, nz, _dmz(K, nz, kq), Azz))
        En = _lst(_dmz(K, kq + nz, q))
        Hn = _lst(_dmz(K, H.shape[0], q))
        ERl, HRl = _lst(ER), _lst(HR)
        for c_, i in enumerate(raw):
            for r_ in range(kq):
                En[r_][i] = ERl[r_][c_]
            for r_ in range(H.shape[0]):
                Hn[r_][i] = HRl[r_][c_]
        for c_, i in enumerate(filt):
            En[kq + c_][i] = -gg
        Gn = _vstack(K, m, G, _dmz(K, nz, m))
        Mn = _hstack(K, H.shape[0], Mq, -Hz)
        Fq, E, H, G, Mq = Fn, _from(K, En, kq + nz, q), _from(K, Hn, H.shape[0], q), Gn, Mn
    return {
        "F": Fq,
        "E": E,
        "G": G,
        "M": Mq,
        "H": H,
        "K": Kf,
        "profile": (tuple(S.W.history), tuple(S.history), Hobs.shape[0], npar, kq),
        "S_dim": S.dim,
        "S_history": S.history,
        "W_history": S.W.history,
        "quotient_order": kq,
        "poles": pl,
        "filtered_channels": filt,
    }


def _seen(ctx: _Ctx, g: dict[str, Any]) -> tuple[list[bool], bool]:
    """Per fault: is the row block's transfer non-zero; and whether [u; d] reach r."""
    K = ctx.K
    A, B, C, D, Bd, Dd = (ctx.dm[k] for k in ("A", "B", "C", "D", "Bd", "Dd"))
    F_, E, G, M, H, Kf = (g[k] for k in ("F", "E", "G", "M", "H", "K"))
    n, k = A.shape[0], F_.shape[0]
    Ac = _vstack(K, n + k, _hstack(K, n, A, _dmz(K, n, k)), _hstack(K, k, -(E * C), F_))
    Cc = _hstack(K, M.shape[0], -(H * C), M)

    def zero(Bx, Dy, Gx=None, Kx=None):
        Bw, Dc = -(E * Dy), -(H * Dy)
        if Gx is not None:
            Bw, Dc = Bw + Gx, Dc + Kx
        return pm.block_transfer_is_zero(Ac, _vstack(K, Bx.shape[1], Bx, Bw), Cc, Dc)

    seen = [not zero(Bf, Df) for Bf, Df in ctx.dsigs]
    inputs_zero = zero(B, D, G, Kf) and zero(Bd, Dd)
    return seen, inputs_zero


def _specialise(mats, sigs, poles, a, sym, val):
    sub = {sym: val}
    m2 = {k: v.subs(sub).applyfunc(sp.cancel) for k, v in mats.items()}
    s2 = [(b.subs(sub), d.subs(sub)) for b, d in sigs]
    p2 = None if poles is None else [sp.sympify(p).subs(sub) for p in poles]
    a2 = sp.sympify(a).subs(sub)
    return m2, s2, p2, a2


def _holds_at(spec, dt, gen: dict[str, sp.Matrix], sub, generic) -> str | None:
    """Does the generic generator, evaluated at ``sub``, still do its job on the family there?

    ``"formula"``: a delivered entry has a pole there; ``"fails"``: defined, but a target
    becomes invisible or a decoupling is lost; ``None``: it holds.
    """
    ev = {k: M.subs(sub).applyfunc(sp.cancel) for k, M in gen.items()}
    if any(M.has(sp.zoo, sp.nan, sp.oo) for M in ev.values()):
        return "formula"
    mats, sigs = spec[0], spec[1]
    ctx = _Ctx(mats, sigs, dt, [x for M in ev.values() for x in M])
    g = {k: ctx._dm(M) for k, M in ev.items()}
    seen, inz = _seen(ctx, g)
    return None if (tuple(seen), inz) == generic else "fails"


def _classify(cands, mats, sigs, dt, poles, a, gen, generic, deadline):
    """Sort candidate factors into ``"fails"`` / ``"formula"`` / ``"candidate"`` (or drop)."""
    out: list[tuple[sp.Expr, str]] = []
    for f in cands:
        syms = sorted(f.free_symbols, key=lambda x: x.name)
        lin = [x for x in syms if sp.degree(f, x) == 1 and not sp.diff(f, x).free_symbols & {x}]
        if not lin or time.monotonic() > deadline:
            out.append((f, "candidate"))
            continue
        x = lin[0]
        sol = sp.solve(f, x)
        if not sol:  # cannot vanish under the symbols' assumptions (e.g. k + 1, k > 0)
            continue
        sub = {x: sol[0]}
        try:
            spec = _specialise(mats, sigs, poles, a, x, sol[0])
        except (ZeroDivisionError, ValueError):
            out.append((f, "fails"))
            continue
        if any(M.has(sp.zoo, sp.nan) for M in spec[0].values()):
            continue  # the plant itself is undefined there: not a point of the family
        kind = _holds_at(spec, dt, gen, sub, generic)
        if kind is not None:
            out.append((f, kind))
    return out


def _listed(poles: Any) -> Any:
    """A row's poles as a list (``None`` kept: the row's default)."""
    return None if poles is None else list(poles)


def _exact_poles(poles: Any, dt: float, row: int, rows: int) -> list[sp.Expr]:
    """A row's poles as exact scalars (never evaluated as code); numeric ones must be stable."""
    where = "poles" if rows == 1 else f"poles (row {row})"
    if isinstance(poles, str | bytes) or not isinstance(poles, list | tuple | np.ndarray):
        raise DesignError(
            f"{where}: expected a list of numbers, got {poles!r:.60}", argument="poles"
        )
    try:
        out = [pm.exact_scalar(p, where) for p in poles]
    except GeomFDIError as exc:
        exc.argument = "poles"
        raise
    bad = [p for p in out if not p.free_symbols and not (abs(p) < 1 if dt > 0 else p < 0)]
    if bad:
        region = "inside the unit circle" if dt > 0 else "in the open left half-plane"
        raise DesignError(
            f"{where}: every numeric pole must lie {region}; got {[str(p) for p in bad]}",
            argument="poles",
        )
    return out


def _exact_filter_pole(value: Any, dt: float) -> sp.Expr:
    """The output-filter parameter ``a`` (filter pole −a, or a for discrete time), exactly."""
    a = pm.exact_scalar(value, "filter_pole")
    if not a.free_symbols and not (0 < a < 1 if dt > 0 else a > 0):
        raise DesignError(
            "filter_pole: expected "
            + ("0 < filter_pole < 1 for a discrete plant" if dt > 0 else "filter_pole > 0")
            + f" (a stable output filter), got {a}",
            argument="filter_pole",
        )
    return a


def _plant_mats(plant: Plant) -> dict[str, sp.Matrix]:
    return {
        k: pm.as_exact_matrix(
            getattr(plant, k), k, rows=getattr(plant, k).shape[0], cols=getattr(plant, k).shape[1]
        )
        for k in ("A", "B", "C", "D", "Bd", "Dd")
    }


def design_bank_exact(
    plant: Plant,
    faults: Sequence[Fault],
    structure: Any,
    *,
    poles: Any = None,
    filter_pole: Any = None,
    exceptional: bool = True,
    time_limit: float = 120.0,
) -> ExactResidualBank:
    """Exact (parametric) residual bank: one generator per row of ``structure``.

    Parameters
    ----------
    plant : Plant
        Numeric or parametric (entries rational functions of sympy symbols).
    faults : list of Fault
    structure : array_like of 0/1, (rows, len(faults))
    poles : sequence or list of sequences, optional
        Quotient spectrum, numbers or sympy expressions; one list for every row or one per
        row.  Default :func:`default_exact_poles` (``−1, …, −k``; discrete ``1/2, …, 2^−k``).
    filter_pole : number or sympy expression, optional
        ``a`` of the output filter; default 1 (continuous) or 1/2 (discrete).
    exceptional : bool
        Compute and classify the exceptional set (default True).
    time_limit : float
        Seconds after which the classification of the remaining candidate conditions is
        skipped (they are reported as ``"candidate"``).

    Returns
    -------
    ExactResidualBank
        ``generators[r]`` an :class:`ExactResidualGenerator` (or None with the reason in
        ``diagnostics[r]``), the generically achieved ``structure`` and ``exceptional``.

    Raises
    ------
    DesignError
        Bad options, or a design model larger than ``MAX_EXACT_ORDER`` states.
    """
    plant = as_plant(plant, parametric=True)
    faults = [faults] if isinstance(faults, Fault) else list(faults)
    if not faults or not all(isinstance(f, Fault) for f in faults):
        raise GeomFDIError("faults: expected a non-empty list of faults", argument="faults")
    from geomfdi._validation import as_real_array

    req = np.atleast_2d(as_real_array(structure, "structure"))
    if req.shape[1] != len(faults) or not np.all((req == 0) | (req == 1)):
        raise GeomFDIError(
            f"structure: expected 0/1 entries and {len(faults)} columns, got shape {req.shape}",
            argument="structure",
        )
    req = req.astype(bool)
    if plant.n + plant.q > MAX_EXACT_ORDER:
        raise DesignError(
            f"plant: the exact design is limited to n + q ≤ {MAX_EXACT_ORDER} "
            f"(geomfdi.synthesis.exact.design.MAX_EXACT_ORDER), got n = {plant.n}, q = {plant.q}",
            argument="plant",
        )
    a = (
        (sp.Rational(1, 2) if plant.dt > 0 else sp.Integer(1))
        if filter_pole is None
        else _exact_filter_pole(filter_pole, plant.dt)
    )
    mats = _plant_mats(plant)
    sigs = [
        (
            pm.as_exact_matrix(Bf, "faults", rows=plant.n, cols=Bf.shape[1]),
            pm.as_exact_matrix(Df, "faults", rows=plant.q, cols=Df.shape[1]),
        )
        for Bf, Df in fault_matrices(faults, plant.n, plant.q)
    ]
    per_row = [
        None if rp is None else _exact_poles(rp, plant.dt, r, req.shape[0])
        for r, rp in enumerate(row_poles(poles, req.shape[0], _listed))
    ]
    deadline = time.monotonic() + float(time_limit)
    gens: list[ExactResidualGenerator | None] = []
    diags: list[str] = []
    achieved = np.zeros_like(req)
    conds: dict[Any, tuple[str, set[int]]] = {}
    params: set[Any] = set()
    t0 = time.perf_counter()
    for r in range(req.shape[0]):
        tgt, dec = row_split(req[r])
        if not tgt:
            gens.append(None)
            diags.append("missing: the row requests no fault")
            continue
        rp = per_row[r]
        ctx = _Ctx(mats, sigs, plant.dt, [a, *(rp or [])])
        params |= set(ctx.F.symbols)
        try:
            g = _design_row(ctx, tgt, dec, rp, a)
            seen, inputs_zero = _seen(ctx, g)
        except NotIsolableError as exc:
            gens.append(None)
            diags.append(f"missing: {exc.reason}")
            continue
        unseen = [j for j in tgt if not seen[j]]
        leaks = [j for j in dec if seen[j]]
        if leaks or not inputs_zero:  # a theorem violated: never deliver it
            raise DesignError(
                f"row {r}: the exact construction leaks faults {leaks} (inputs reach: "
                f"{not inputs_zero}); please report this plant",
                argument="plant",
            )
        if unseen:
            gens.append(None)
            diags.append(
                f"missing: faults {unseen} not isolable from faults {list(dec)} (transfer "
                "identically zero for generic parameters)"
            )
            continue
        achieved[r] = seen
        mats_out = {k: ctx.F.to_sympy(_lst(g[k]), *g[k].shape) for k in "FEGMHK"}
        if ctx.F.parametric and exceptional:
            denoms = set()
            for M in mats_out.values():
                for x in M:
                    dn = sp.denom(sp.together(x))
                    if dn.free_symbols:
                        denoms |= {f for f, _ in sp.factor_list(dn)[1]}
            cands = list(
                {
                    *ctx.F.candidate_factors(),
                    *[sp.Poly(d, *d.free_symbols).monic().as_expr() for d in denoms],
                }
            )
            generic = (tuple(seen), inputs_zero)
            for f, kind in _classify(
                sorted(cands, key=sp.default_sort_key),
                mats,
                sigs,
                plant.dt,
                rp,
                a,
                mats_out,
                generic,
                deadline,
            ):
                old = conds.get(f)
                rank = {"fails": 2, "formula": 1, "candidate": 0}
                k2 = kind if old is None or rank[kind] > rank[old[0]] else old[0]
                conds[f] = (k2, (old[1] if old else set()) | {r})
        gens.append(
            ExactResidualGenerator(
                **mats_out,
                dt=plant.dt,
                target=tgt,
                decoupled=dec,
                parameters=tuple(sorted(ctx.F.symbols, key=lambda x: x.name)),
                info={
                    "S_dim": g["S_dim"],
                    "S_history": g["S_history"],
                    "W_history": g["W_history"],
                    "quotient_order": g["quotient_order"],
                    "poles": g["poles"],
                    "filter_pole": a if g["filtered_channels"] else None,
                    "filtered_channels": g["filtered_channels"],
                },
            )
        )
        diags.append("ok")
    exc_list = [ExceptionalCondition(f, k, tuple(sorted(rows))) for f, (k, rows) in conds.items()]
    exc_list.sort(
        key=lambda c: (
            {"fails": 0, "formula": 1, "candidate": 2}[c.kind],
            sp.default_sort_key(c.expr),
        )
    )
    return ExactResidualBank(
        generators=gens,
        requested=req,
        structure=achieved,
        diagnostics=diags,
        faults=faults,
        parameters=tuple(sorted(params, key=lambda x: x.name)),
        exceptional=exc_list,
        dt=plant.dt,
        info={"filter_pole": a, "seconds": time.perf_counter() - t0, "n": plant.n},
    )


def design_sensor_bank_exact(plant: Plant, **kwargs: Any) -> ExactResidualBank:
    """One exact residual per sensor, decoupled from every other sensor (``S_FDI = I``)."""
    plant = as_plant(plant, parametric=True)
    faults = [SensorFault(i) for i in range(plant.q)]
    return design_bank_exact(plant, faults, np.eye(plant.q), **kwargs)


def exact_dispatch(
    kind: str,
    plant: Any,
    faults: Any,
    *,
    structure: Any = None,
    target: Any = None,
    decouple: Any = None,
    poles: Any = None,
    method: str = "exact",
    filter_pole: Any = None,
) -> ExactResidualBank | ExactResidualGenerator:
    """The ``exact=True`` branch of the three design functions (one row, a bank, sensors)."""

    if method != "exact":
        raise DesignError(
            f"method: the exact design uses the exact sensor-fault transform; got {method!r}",
            argument="method",
        )
    if kind == "sensor":
        return design_sensor_bank_exact(plant, poles=poles, filter_pole=filter_pole)
    if kind == "bank":
        return design_bank_exact(plant, faults, structure, poles=poles, filter_pole=filter_pole)
    faults = [faults] if isinstance(faults, Fault) else list(faults)
    nf = len(faults)
    tgt, dec = target_decouple(target, decouple, nf)
    row = np.zeros((1, nf))
    row[0, list(tgt)] = 1
    keep = sorted(set(tgt) | set(dec))  # faults neither seen nor decoupled are ignored
    bank = design_bank_exact(
        plant,
        [faults[j] for j in keep],
        row[:, keep],
        poles=None if poles is None else [list(poles)],
        filter_pole=filter_pole,
    )
    g = bank.generators[0]
    if g is None:
        raise NotIsolableError(
            "the residual: no residual exists: " + bank.diagnostics[0].removeprefix("missing: "),
            reason=bank.diagnostics[0],
        )
    remap = {i: j for i, j in enumerate(keep)}
    g.target = tuple(remap[i] for i in g.target)
    g.decoupled = tuple(remap[i] for i in g.decoupled)
    g.info["exceptional"] = bank.exceptional
    return g
