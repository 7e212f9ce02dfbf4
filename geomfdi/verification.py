"""Verification of residual generators on the physical model (math.md §5).

The composite of plant and generator (faults ``x' = … + Bf f``, ``y = … + Df f``)::

    [x; w]' = [[A, 0], [−E C, F]] [x; w] + [[B, Bd, Bf], [G − E D, −E Dd, −E Df]] [u; d; f]
    r       = [−H C, M] [x; w] + [K − H D, −H Dd, −H Df] [u; d; f]

A transfer is "identically zero" when its relative gain — ``‖T(s)‖`` over
``‖C_c‖ ‖(sI − A_c)⁻¹ B_c‖ + ‖D_c‖`` — stays at rounding level at ``order + 2``
random complex points (default), or when the output map annihilates the orthonormal
Krylov (reachable) subspace (``method="krylov"``).  :func:`verify_symbolic` redoes the
design in exact rational arithmetic and proves the zeros.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg

from .errors import GeomFDIError
from .faults import Fault, SensorFault, fault_matrices
from .generator import ResidualBank, ResidualGenerator
from .plant import Plant
from .realization import reachable_subspace
from .subspace import _norm2

__all__ = [
    "verify",
    "verify_symbolic",
    "VerificationReport",
    "SymbolicReport",
    "fault_gains",
    "LEAK_TOL",
]

LEAK_TOL = 1e-8
"""Relative gain below which a transfer counts as identically zero."""


class _Composite:
    """Plant + generator interconnection, Schur-factored once for fast evaluations.

    ``A_c = [[A, 0], [−E C, F]]``, ``C_c = [−H C, M]``; an input entering the plant as
    ``(Bx, Dy)`` (and the generator directly through ``(Gx, Kx)``) has
    ``B_c = [Bx; −E Dy + Gx]``, ``D_c = −H Dy + Kx``.  The complex Schur form
    ``A_c = U T Uᴴ`` turns every ``(sI − A_c)⁻¹ B`` into a triangular solve, so the
    ``order + 2`` evaluation points cost O(N²) each.
    """

    def __init__(self, g: ResidualGenerator, plant: Plant) -> None:
        n, k = plant.n, g.order
        self.g, self.plant = g, plant
        self.Ac = np.block([[plant.A, np.zeros((n, k))], [-g.E @ plant.C, g.F]])
        self.Cc = np.hstack([-g.H @ plant.C, g.M])
        self.N = self.Ac.shape[0]
        self.T, self.U = scipy.linalg.schur(self.Ac.astype(complex), output="complex")
        self.CU = self.Cc @ self.U
        self.nC = _norm2(self.Cc)
        self.points = _points(self.Ac, self.N + 2)
        v = np.random.default_rng(7).standard_normal(self.N)
        self.probe = v / max(np.linalg.norm(v), 1e-300)

    def channel(self, Bx, Dy, Gx=None, Kx=None):
        """``(B_c, D_c, b, d)``: the channel and the norms its rounding is judged against.

        ``b = ‖Bx‖ + ‖E‖ ‖Dy‖ (+ ‖Gx‖)`` and ``d = ‖H‖ ‖Dy‖ (+ ‖Kx‖)``: the size the
        transfer would have if the generator did not cancel this input.
        """
        g = self.g
        Bw = -g.E @ Dy
        Dc = -g.H @ Dy
        b = _norm2(Bx) + _norm2(g.E) * _norm2(Dy)
        d = _norm2(g.H) * _norm2(Dy)
        if Gx is not None:
            Bw, Dc = Bw + Gx, Dc + Kx
            b += _norm2(Gx)
            d += _norm2(Kx)
        return np.vstack([Bx, Bw]), Dc, b, d

    def _solve(self, s: complex, B: np.ndarray) -> np.ndarray:
        return scipy.linalg.solve_triangular(s * np.eye(self.N) - self.T, B)

    def relative_gain(self, Bc, Dc, b: float, d: float, method: str = "points") -> float:
        """max over the points of ``‖T(s)‖ / (‖C_c‖ ‖(sI − A_c)⁻¹‖ b + d)``.

        ``‖(sI − A_c)⁻¹‖`` is estimated by its action on a fixed random unit vector.
        """
        if Bc.shape[1] == 0 or self.Cc.shape[0] == 0 or (b == 0 and d == 0):
            return 0.0
        if method == "krylov":
            V = reachable_subspace(self.Ac, Bc).basis
            num = _norm2(self.Cc @ V) * _norm2(Bc) if V.size else 0.0
            return max(num / (self.nC * b + 1e-300), _norm2(Dc) / (d + self.nC * b + 1e-300))
        if self.N == 0:
            return float(np.linalg.norm(Dc) / max(d, 1e-300))
        Uh = self.U.conj().T
        UB, Uv = Uh @ Bc, Uh @ self.probe
        best = 0.0
        for s in self.points:
            T = self.CU @ self._solve(s, UB) + Dc
            scale = self.nC * np.linalg.norm(self._solve(s, Uv)) * b + d
            if scale > 0:
                best = max(best, float(np.linalg.norm(T) / scale))
        return best

    def dc_gain(self, Bc, Dc) -> float:
        """‖T(0)‖ (continuous) or ‖T(1)‖ (discrete); ``inf`` when the channel integrates."""
        if Bc.shape[1] == 0:
            return 0.0
        if self.N == 0:
            return float(np.linalg.norm(Dc))
        s0 = 1.0 if self.plant.dt > 0 else 0.0
        UB = self.U.conj().T @ Bc
        diag = np.abs(s0 - np.diag(self.T))
        scale = max(_norm2(self.Ac), 1.0)
        if diag.min() > 1e-9 * scale:
            return float(np.linalg.norm(self.CU @ self._solve(s0, UB) + Dc))
        # a pole at s0 in A_c: it may cancel in this channel; probe the limit
        e1, e2 = 1e-5 * scale, 1e-7 * scale
        v1 = np.linalg.norm(self.CU @ self._solve(s0 + e1, UB) + Dc)
        v2 = np.linalg.norm(self.CU @ self._solve(s0 + e2, UB) + Dc)
        if v2 > 10 * max(v1, 1e-300) and v2 > 1e-6:
            return float("inf")
        return float(v2)


def _points(Ac: np.ndarray, count: int, seed: int = 12345) -> np.ndarray:
    """Random points in the upper half-plane at the scale of the spectrum."""
    rng = np.random.default_rng(seed)
    rad = max(1.0, _norm2(Ac)) if Ac.size else 1.0
    r = rad * rng.uniform(0.3, 1.5, count)
    th = rng.uniform(0.15, np.pi - 0.15, count)
    return r * np.exp(1j * th)


def fault_gains(
    g: ResidualGenerator, plant: Plant, faults: Sequence[Fault], *, method: str = "points"
) -> tuple[np.ndarray, np.ndarray]:
    """Relative gain and DC gain from each fault to the residual, on the physical model."""
    sigs = fault_matrices(faults, plant.n, plant.q)
    comp = _Composite(g, plant)
    gains, dcs = [], []
    for Bf, Df in sigs:
        Bc, Dc, b, d = comp.channel(Bf, Df)
        gains.append(comp.relative_gain(Bc, Dc, b, d, method))
        dcs.append(comp.dc_gain(Bc, Dc))
    return np.array(gains), np.array(dcs)


def _input_gain(g: ResidualGenerator, plant: Plant, method: str) -> float:
    comp = _Composite(g, plant)
    out = 0.0
    if plant.m:
        out = max(out, comp.relative_gain(*comp.channel(plant.B, plant.D, g.G, g.K), method))
    if plant.nd:
        out = max(out, comp.relative_gain(*comp.channel(plant.Bd, plant.Dd), method))
    return out


@dataclass
class VerificationReport:
    """Numeric verification of a bank (or one generator) on the physical model.

    Attributes
    ----------
    gain : ndarray (rows, faults)
        Relative gain from every fault to every residual (0 for missing rows).
    leakage : ndarray (rows, faults)
        ``gain`` where the design asks for zero, 0 elsewhere.
    target_gain : ndarray (rows, faults)
        ``gain`` where the design asks for a response, 0 elsewhere.
    input_leakage : ndarray (rows,)
        Relative gain from u and d (must be zero).
    dc_gain : ndarray (rows, faults)
        DC gain (``inf`` at an integrating channel).
    identities : list of dict
        Relative residuals of the construction identities per row (empty if missing).
    missing : list of int
        Rows without a generator (not counted in ``ok``).
    tol : float
        Threshold for "zero".
    ok : bool
        Every decoupling holds, no input leaks, every target is seen (existing rows).
    """

    gain: np.ndarray
    leakage: np.ndarray
    target_gain: np.ndarray
    input_leakage: np.ndarray
    dc_gain: np.ndarray
    identities: list[dict[str, float]]
    missing: list[int]
    tol: float
    ok: bool
    method: str = "points"
    details: list[str] = field(default_factory=list)

    def __repr__(self) -> str:
        return (
            f"VerificationReport(ok={self.ok}, max leakage={np.max(self.leakage, initial=0):.3g}, "
            f"max input leakage={np.max(self.input_leakage, initial=0):.3g}, "
            f"missing={self.missing})"
        )


def _unpack(obj: Any, plant: Plant, faults: Any):
    if isinstance(obj, ResidualBank):
        gens = obj.generators
        faults = obj.faults if faults is None else list(faults)
        req = obj.requested
    elif isinstance(obj, ResidualGenerator):
        gens = [obj]
        if faults is None:
            faults = obj.info.get("faults") or [SensorFault(i) for i in range(plant.q)]
        faults = list(faults)
        req = np.zeros((1, len(faults)), dtype=bool)
        req[0, list(obj.target)] = True
        if not obj.target and not obj.decoupled:
            req[0] = True
    else:
        raise GeomFDIError(
            f"bank_or_generator: expected a ResidualBank or ResidualGenerator, got "
            f"{type(obj).__name__}",
            argument="bank_or_generator",
        )
    if not isinstance(plant, Plant):
        raise GeomFDIError(
            f"plant: expected a gf.Plant, got {type(plant).__name__}", argument="plant"
        )
    if req.shape[1] != len(faults):
        raise GeomFDIError(
            f"faults: the design has {req.shape[1]} faults, got {len(faults)}", argument="faults"
        )
    for g in gens:
        if g is not None and (g.q != plant.q or g.m != plant.m):
            raise GeomFDIError(
                f"plant: generator reads {g.q} outputs and {g.m} inputs, the plant has "
                f"{plant.q} and {plant.m}",
                argument="plant",
            )
    return gens, faults, req


def verify(
    bank_or_generator: ResidualBank | ResidualGenerator,
    plant: Plant,
    faults: Sequence[Fault] | None = None,
    *,
    method: str = "points",
    tol: float = LEAK_TOL,
) -> VerificationReport:
    """Check every generator's decouplings and detections on the physical model.

    Parameters
    ----------
    bank_or_generator : ResidualBank or ResidualGenerator
    plant : Plant
    faults : list of Fault, optional
        Default: the bank's faults (or the generator's design faults).
    method : {"points", "krylov"}
        Random-point evaluation of the transfer (default) or orthonormal Krylov test.
    tol : float
        Relative gain counted as zero.

    Returns
    -------
    VerificationReport

    Notes
    -----
    math.md §5, items 1–3.  The transfer from sensor i is
    ``−M (sI − F)⁻¹ E e_i − H e_i`` composed with the plant; from u and d it must vanish.
    Unlike the paper's check on its pseudo-actuator model, this one uses the measured y,
    so the paper design's transient leakage (Erratum 2) is visible.
    """
    if method not in ("points", "krylov"):
        raise GeomFDIError(
            f"method: must be 'points' or 'krylov', got {method!r}", argument="method"
        )
    gens, faults, req = _unpack(bank_or_generator, plant, faults)
    rows, nf = req.shape
    gain = np.zeros((rows, nf))
    dc = np.zeros((rows, nf))
    inp = np.zeros(rows)
    idents: list[dict[str, float]] = []
    missing, details = [], []
    for r, g in enumerate(gens):
        if g is None:
            missing.append(r)
            idents.append({})
            continue
        gain[r], dc[r] = fault_gains(g, plant, faults, method=method)
        inp[r] = _input_gain(g, plant, method)
        idents.append(dict(g.info.get("identities", {})))
    leak = np.where(req, 0.0, gain)
    tgain = np.where(req, gain, 0.0)
    ok = True
    for r, g in enumerate(gens):
        if g is None:
            continue
        for j in range(nf):
            if not req[r, j] and gain[r, j] > tol:
                ok = False
                details.append(f"row {r}: leaks fault {j} (relative gain {gain[r, j]:.3g})")
            if req[r, j] and gain[r, j] <= tol:
                ok = False
                details.append(f"row {r}: does not see fault {j}")
        if inp[r] > tol:
            ok = False
            details.append(f"row {r}: input leakage {inp[r]:.3g}")
        if any(v > 1e-8 for v in idents[r].values()):
            ok = False
            details.append(f"row {r}: identities {idents[r]}")
    return VerificationReport(gain, leak, tgain, inp, dc, idents, missing, tol, ok, method, details)


# ----------------------------------------------------------------- exact
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
        re = sp.Rational(float(v.real)).limit_denominator(10**6)
        im = sp.Rational(abs(float(v.imag))).limit_denominator(10**6)
        out.append(re + sp.I * im * (1 if v.imag >= 0 else -1) if im != 0 else re)
    return out


def _exact_design(g: ResidualGenerator, plant: Plant, faults: list[Fault]) -> dict[str, Any]:
    """Redo the construction of math.md §4 in exact arithmetic for g's options."""
    import sympy as sp

    from . import exact as ex

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
        a = sp.Rational(float(a)).limit_denominator(10**6)
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
    else:
        Ad, Bdm, Cd, Du, a, raw, filt = A, B, C, D, None, list(range(q)), []
        Cp = C.pinv()

        def move(Bf, Df):
            if Df.is_zero_matrix:
                return Bf
            f = Cp * Df
            if not (C * f - Df).is_zero_matrix:
                raise GeomFDIError("faults: C f = Df has no exact solution", argument="faults")
            sig = Bf - A * f
            return sig.row_join(f) if g.method == "mvw" else sig

        Ls = [move(Bf, Df) for Bf, Df in sigs]
        Ldist = move(Bd, Dd) if Bd.cols else Bd
    nd_ = Ad.rows
    cols = [Ls[j] for j in g.decoupled] + ([Ldist] if Ldist.cols else [])
    L = sp.Matrix.hstack(*cols) if cols else sp.zeros(nd_, 0)
    S = ex.min_unobservability_subspace(Ad, Cd, L)
    P = S.complement_rows()
    R = ex.right_inverse(P)
    D0 = ex.friend(Ad, Cd, S, P)
    H = ex.measurement_map(Cd, S)
    M = H * Cd * R
    A0 = P * (Ad + D0 * Cd) * R
    cons = g.info.get("construction", {})
    quotient_poles = np.linalg.eigvals(cons["F"]) if "F" in cons else g.poles
    D1 = ex.place_observer(A0, M, _exact_poles(quotient_poles))
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
    :mod:`geomfdi.exact`; the transfer matrices from faults and inputs to the residual
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
