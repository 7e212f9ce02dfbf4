"""Exact (sympy) verification: transfers from every fault to every residual in s (or z).

See the user guide, *Theory: verification* (``docs/theory/verification.md``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from geomfdi._validation import as_sequence_of
from geomfdi.errors import GeomFDIError
from geomfdi.model.faults import Fault, fault_matrices
from geomfdi.model.plant import Plant, as_plant
from geomfdi.synthesis.generator import ResidualBank, ResidualGenerator
from geomfdi.verification.numeric import _unpack


@dataclass
class SymbolicReport:
    """Exact verification (sympy, rational arithmetic).

    Attributes
    ----------
    transfer : sympy.Matrix (residual outputs, faults)
        Transfer from each fault to each residual on the physical model, in ``s``
        (continuous) or ``z`` (discrete), for the exactly re-derived generators.
    zero : ndarray of bool
        Entries that are exactly 0 (all Markov parameters and the feedthrough vanish).
    input_transfer : sympy.Matrix
        Transfer from ``[u; d]`` (must be exactly 0).
    generators : list of dict
        The exact generator matrices (F, E, G, M, H, K) per row (None where missing).
    rows : list of int
        Bank row of each line of ``transfer``.
    ok : bool
        Every decoupled entry and every input entry is exactly 0 and every target entry
        is not.
    variable : sympy.Symbol
    """

    transfer: Any
    zero: np.ndarray
    input_transfer: Any
    generators: list[dict[str, Any] | None]
    rows: list[int]
    ok: bool
    variable: Any
    details: list[str] = field(default_factory=list)


def _exact_poles(values: np.ndarray) -> list[Any]:
    import sympy as sp

    out = []
    for v in np.asarray(values, dtype=complex):
        re = sp.Rational(float(v.real)).limit_denominator(10**3)
        im = sp.Rational(abs(float(v.imag))).limit_denominator(10**3)
        out.append(re + sp.I * im * (1 if v.imag >= 0 else -1) if im != 0 else re)
    return out


def _exact_parity_rows(C: Any, direct: list[Any]) -> Any:
    """Exact counterpart of ``synthesis._parity_rows``: rows of ``(Im C)^⊥`` seeing ``direct``."""
    import sympy as sp

    q = C.rows
    X = sp.Matrix.hstack(*direct) if direct else sp.zeros(q, 0)
    vecs = C.T.nullspace()
    if X.cols == 0 or X.is_zero_matrix or not vecs:
        return sp.zeros(0, q)
    N = sp.Matrix.hstack(*vecs)
    proj = N * (N.T * N).inv() * N.T * X
    cols = proj.columnspace()
    return sp.Matrix.hstack(*cols).T if cols else sp.zeros(0, q)


def _exact_design(g: ResidualGenerator, plant: Plant, faults: list[Fault]) -> dict[str, Any]:
    """Redo the construction of math.md §4 in exact arithmetic for g's options."""
    import sympy as sp

    from geomfdi.geometry import exact as ex

    A = ex.to_rational(plant.A, "A")
    B = ex.to_rational(plant.B, "B", rows=plant.n)
    C = ex.to_rational(plant.C, "C")
    D = ex.to_rational(plant.D, "D", rows=plant.q)
    Bd = ex.to_rational(plant.Bd, "Bd", rows=plant.n)
    Dd = ex.to_rational(plant.Dd, "Dd", rows=plant.q)
    sigs = [
        (ex.to_rational(Bf, "Bf"), ex.to_rational(Df, "Df"))
        for Bf, Df in fault_matrices(faults, plant.n, plant.q)
    ]
    n, q, m = plant.n, plant.q, plant.m
    a = g.info.get("filter_pole")
    filt = list(g.info.get("filtered_channels", ()))
    raw = [i for i in range(q) if i not in filt]
    if g.method == "exact" and a is not None and filt:
        a = sp.Rational(float(a)).limit_denominator(10**3)
        nz = len(filt)
        gg, Azz = ((1 - a), a * sp.eye(nz)) if plant.dt > 0 else (a, -a * sp.eye(nz))

        def rows_of(X, idx):
            return X.extract(idx, list(range(X.cols))) if idx else sp.zeros(0, X.cols)

        Ad = sp.BlockMatrix([[A, sp.zeros(n, nz)], [gg * rows_of(C, filt), Azz]]).as_explicit()
        Bdm = B.col_join(gg * rows_of(D, filt))
        Cd = sp.BlockMatrix(
            [[rows_of(C, raw), sp.zeros(len(raw), nz)], [sp.zeros(nz, n), sp.eye(nz)]]
        ).as_explicit()
        Du = rows_of(D, raw).col_join(sp.zeros(nz, m))
        Ls = [Bf.col_join(gg * rows_of(Df, filt)) for Bf, Df in sigs]
        Ldist = Bd.col_join(gg * rows_of(Dd, filt))
        direct = [
            rows_of(sigs[j][1], raw).col_join(sp.zeros(nz, sigs[j][1].cols)) for j in g.target
        ]
    elif g.method == "exact":  # no decoupled output part: the plant itself, raw outputs
        Ad, Bdm, Cd, Du, a, raw, filt = A, B, C, D, None, list(range(q)), []
        Ls = [Bf for Bf, _ in sigs]
        Ldist = Bd
        direct = [sigs[j][1] for j in g.target]
    else:
        Ad, Bdm, Cd, Du, a, raw, filt = A, B, C, D, None, list(range(q)), []
        Cp = C.pinv()

        def move(Bf, Df):
            if Df.is_zero_matrix:
                return Bf
            f = Cp * Df
            if not (C * f - Df).is_zero_matrix:
                raise GeomFDIError("faults: C f = Df has no exact solution", argument="faults")
            sig = Bf - A * f + (f if plant.dt > 0 else sp.zeros(*f.shape))
            return sig.row_join(f) if g.method == "mvw" else sig

        Ls = [move(Bf, Df) for Bf, Df in sigs]
        Ldist = move(Bd, Dd) if Bd.cols else Bd
        direct = []
    nd_ = Ad.rows
    cols = [Ls[j] for j in g.decoupled] + ([Ldist] if Ldist.cols else [])
    L = sp.Matrix.hstack(*cols) if cols else sp.zeros(nd_, 0)
    S = ex.min_unobservability_subspace(Ad, Cd, L)
    if S.dim < nd_:
        P = S.complement_rows()
        R = ex.right_inverse(P)
        D0 = ex.friend(Ad, Cd, S, P)
    else:
        P, R, D0 = sp.zeros(0, nd_), sp.zeros(nd_, 0), sp.zeros(nd_, Cd.rows)
    Hobs = ex.measurement_map(Cd, S)
    Hpar = _exact_parity_rows(Cd, direct)
    Mobs = Hobs * Cd * R
    A0 = P * (Ad + D0 * Cd) * R
    cons = g.info.get("construction", {})
    quotient_poles = np.linalg.eigvals(cons["F"]) if "F" in cons else g.poles
    D1obs = ex.place_observer(A0, Mobs, _exact_poles(quotient_poles))
    H = Hobs.col_join(Hpar)
    M = Mobs.col_join(sp.zeros(Hpar.rows, A0.rows))
    D1 = D1obs.row_join(sp.zeros(A0.rows, Hpar.rows))
    F = A0 + D1 * M
    E = P * (D0 + R * D1 * H)
    G = P * Bdm + E * Du
    K = H * Du
    if a is not None:
        k, nr, nz = F.rows, len(raw), len(filt)
        gg, Azz = ((1 - a), a * sp.eye(nz)) if plant.dt > 0 else (a, -a * sp.eye(nz))
        ER, Ez = E[:, :nr], E[:, nr:]
        HR, Hz = H[:, :nr], H[:, nr:]
        Fn = sp.BlockMatrix([[F, -Ez], [sp.zeros(nz, k), Azz]]).as_explicit()
        En = sp.zeros(k + nz, q)
        Hn = sp.zeros(M.rows, q)
        for c_, i in enumerate(raw):
            En[:k, i] = ER[:, c_]
            Hn[:, i] = HR[:, c_]
        for c_, i in enumerate(filt):
            En[k + c_, i] = -gg
        G = G.col_join(sp.zeros(nz, m))
        M = M.row_join(-Hz)
        F, E, H = Fn, En, Hn
    return {
        "F": F,
        "E": E,
        "G": G,
        "M": M,
        "H": H,
        "K": K,
        "S_dim": S.dim,
        "A": A,
        "B": B,
        "C": C,
        "D": D,
        "Bd": Bd,
        "Dd": Dd,
        "sigs": sigs,
    }


def _exact_channel(E, H, Bx, Dy, Gx=None, Kx=None):
    """Exact ``(B_c, D_c)`` of an input entering the plant as (Bx, Dy)."""
    Bw, Dc = -E * Dy, -H * Dy
    if Gx is not None:
        Bw, Dc = Bw + Gx, Dc + Kx
    return Bx.col_join(Bw), Dc


def _krylov(Ac, b):
    import sympy as sp

    vecs: list[Any] = []
    v = b
    for _ in range(Ac.rows + 1):
        cand = sp.Matrix.hstack(*vecs, v) if vecs else v
        if cand.rank() == len(vecs):
            break
        vecs.append(v)
        v = Ac * v
    return sp.Matrix.hstack(*vecs) if vecs else sp.zeros(Ac.rows, 0)


def _siso_transfer(Ac, b, c, d, var):
    """Exact ``c (var I − Ac)⁻¹ b + d`` and whether it is identically zero."""
    import sympy as sp

    K = _krylov(Ac, b)
    cK = c * K if K.cols else sp.zeros(1, 0)
    if cK.is_zero_matrix and d == 0:
        return sp.Integer(0), True
    if K.cols == 0:
        return sp.nsimplify(d), d == 0
    # Ar: Ac K = K Ar (exact, K has full column rank)
    Ar = (K.T * K).inv() * K.T * Ac * K
    br = sp.zeros(K.cols, 1)
    br[0] = 1
    den = Ar.charpoly(var).as_expr()
    num = (Ar - br * cK).charpoly(var).as_expr() - den
    return sp.cancel(num / den + d), False


def verify_symbolic(
    bank_or_generator: ResidualBank | ResidualGenerator,
    plant: Plant,
    faults: Sequence[Fault] | None = None,
) -> SymbolicReport:
    """Exact proof of the decouplings: re-derive each generator with rationals.

    The design of each row (same transform, decoupled set, filter pole and — rounded to
    nearby rationals — the same quotient poles) is carried out in exact arithmetic with
    :mod:`geomfdi.geometry.exact`; the transfer matrices from faults and inputs to the residual
    on the physical model are then formed exactly.  A decoupled entry is exactly 0 iff
    all its Markov parameters and its feedthrough vanish (checked on the exact Krylov
    basis); other entries are returned as cancelled rational functions of ``s``
    (continuous) or ``z`` (discrete).

    Notes
    -----
    math.md §5, item 4.  Decoupling is a structural property of S*: it does not depend on
    the pole values, so rounding the poles to rationals proves the numeric design's zero
    pattern.  The plant data are converted with :func:`geomfdi.exact.to_rational`.
    Cost grows quickly with the order (sympy); intended for n ≲ 10.
    """
    import sympy as sp

    if faults is not None:
        faults = as_sequence_of(faults, "faults", Fault)
    plant = as_plant(plant)
    gens, faults, req = _unpack(bank_or_generator, plant, faults)
    var = sp.Symbol("z" if plant.dt > 0 else "s")
    lines, zero_rows, in_lines, rows, exact_gens, details = [], [], [], [], [], []
    ok = True
    for r, g in enumerate(gens):
        if g is None:
            exact_gens.append(None)
            continue
        ed = _exact_design(g, plant, faults)
        exact_gens.append({k: ed[k] for k in "FEGMHK"})
        A, C = ed["A"], ed["C"]
        F, E, G, M, H, K = (ed[k] for k in "FEGMHK")
        n, k = A.rows, F.rows
        Ac = sp.BlockMatrix([[A, sp.zeros(n, k)], [-E * C, F]]).as_explicit()
        Cc = (-H * C).row_join(M)

        for o in range(M.rows):
            row_t, row_z = [], []
            for Bf, Df in ed["sigs"]:
                Bc, Dc = _exact_channel(E, H, Bf, Df)
                t, z = _siso_transfer(Ac, Bc[:, 0], Cc[o, :], Dc[o, 0], var)
                if Bf.cols > 1:  # vector fault: zero only if every component is
                    for c_ in range(1, Bf.cols):
                        t2, z2 = _siso_transfer(Ac, Bc[:, c_], Cc[o, :], Dc[o, c_], var)
                        z = z and z2
                row_t.append(t)
                row_z.append(z)
            ins = []
            if plant.m:
                Bc, Dc = _exact_channel(E, H, ed["B"], ed["D"], G, K)
                for c_ in range(plant.m):
                    ins.append(_siso_transfer(Ac, Bc[:, c_], Cc[o, :], Dc[o, c_], var)[0])
            if plant.nd:
                Bc, Dc = _exact_channel(E, H, ed["Bd"], ed["Dd"])
                for c_ in range(plant.nd):
                    ins.append(_siso_transfer(Ac, Bc[:, c_], Cc[o, :], Dc[o, c_], var)[0])
            lines.append(row_t)
            zero_rows.append(row_z)
            in_lines.append(ins)
            rows.append(r)
            for j in range(len(faults)):
                if req[r, j] and row_z[j]:
                    ok = False
                    details.append(f"row {r}: target fault {j} has an exactly zero transfer")
                if not req[r, j] and not row_z[j]:
                    ok = False
                    details.append(f"row {r}: fault {j} is not decoupled: {row_t[j]}")
            if any(sp.simplify(t) != 0 for t in ins):
                ok = False
                details.append(f"row {r}: inputs reach the residual")
    transfer = sp.Matrix(lines) if lines else sp.zeros(0, len(faults))
    width = max((len(x) for x in in_lines), default=0)
    itransfer = sp.Matrix(in_lines) if width else sp.zeros(len(lines), 0)
    return SymbolicReport(
        transfer,
        np.array(zero_rows, dtype=bool).reshape(len(lines), -1),
        itransfer,
        exact_gens,
        rows,
        ok,
        var,
        details,
    )
