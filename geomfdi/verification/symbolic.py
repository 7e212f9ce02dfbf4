"""Exact proof of the delivered generator: fault and input transfers in rational arithmetic.

For each residual generator ``(F, E, G, M, H, K)`` on the plant, the closed loop from a
fault ``(Bf, Df)`` to the residual is ``Cc (sI − Ac)⁻¹ Bc + Dc`` with::

    Ac = [[A, 0], [−E C, F]],   Bc = [Bf; −E Df],   Cc = [−H C, M],   Dc = −H Df

(inputs: ``Bc = [B; G − E D]``, ``Dc = K − H D``).  The **delivered** matrices are
converted exactly: a binary float is a dyadic rational (``x = p / 2^e``), so no rounding
happens in the proof.  The transfer is identically zero iff ``Dc = 0`` and every Markov
parameter ``Cc Ac^k Bc`` (``k < order of Ac``) vanishes (Cayley–Hamilton).  Each Markov
parameter is computed exactly and measured against the magnitudes it is made of::

    ρ = max_k |Cc Ac^k b| / (‖c‖ ‖Ac‖^k w0)   (and |Dc| / (g ‖Df‖) for the feedthrough)

with ``g`` the largest ∞-norm of the generator's E, H, G, K, ``w0 = max(‖Bf‖, g ‖Df‖)``
and ``‖c‖ = max(‖M_o‖, ‖H_o‖ ‖C‖)``: each coefficient relative to the magnitudes it is made
of, before any cancellation.

``ρ = 0``: a **structural zero** (exact); ``0 < ρ ≤ rtol``: a **rounding-level**
coefficient, the cancellation the construction promises, left over by floating-point
rounding (the largest such ``ρ`` is reported); ``ρ > rtol``: a genuine transfer.  A
residual with several components (a row block) sees a target when any component does.

Generators of an exact design (:func:`geomfdi.synthesis.exact.design.design_bank_exact`,
rationals or rational functions of parameters) are checked in exact arithmetic over the
field of rational functions: there every zero is structural.

See the user guide, *Theory: verification* (``docs/theory/verification.md``).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from geomfdi._validation import as_int, as_positive, as_sequence_of
from geomfdi.errors import GeomFDIError
from geomfdi.generators.exact import ExactResidualBank, ExactResidualGenerator
from geomfdi.generators.generator import ResidualBank, ResidualGenerator
from geomfdi.model.faults import Fault, SensorFault, fault_matrices
from geomfdi.model.plant import Plant, as_plant

__all__ = ["SymbolicReport", "verify_symbolic", "SYMBOLIC_MAX_ORDER", "ROUNDING_RTOL"]

SYMBOLIC_MAX_ORDER = 64
"""Default cap on the closed-loop order ``n + order(generator)`` of :func:`verify_symbolic`
(checked before any work; raise it with ``max_order=``).  Cost grows like the cube of the
order times the bit length of the exact Markov parameters."""

ROUNDING_RTOL = 1e-9
"""Default relative size ``ρ`` up to which a Markov parameter counts as rounding level."""


@dataclass
class SymbolicReport:
    """Exact verification of the delivered generators.

    Attributes
    ----------
    transfer : sympy.Matrix (residual outputs, faults)
        Readable transfers in ``s`` (continuous) or ``z`` (discrete): 0 where the entry is
        zero (structurally or to rounding level); otherwise the transfer with near-common
        poles and zeros cancelled, the coefficients normalised per residual output and
        shown as simple rationals (``nsimplify`` with a relative tolerance 1e-9).  For an
        exact (parametric) generator, the exact cancelled rational function.  Vector faults:
        the first component.
    zero : ndarray of bool
        Entry is zero (all Markov parameters and the feedthrough vanish, up to ``rtol``).
    structural : ndarray of bool
        Entry is exactly zero (no rounding at all).
    leak : ndarray of float
        ``ρ`` of each entry (module docstring); 0 for structural zeros.  For exact
        generators 0 (zero) or 1 (non-zero).
    rounding_level : float
        Largest ``ρ`` among the entries that must vanish (decoupled faults and inputs) and
        are not structural zeros: the size of the rounding left in the delivered generator.
    input_transfer : sympy.Matrix
        Readable transfers from ``[u; d]`` (0 where zero, as above).
    input_zero : ndarray of bool
    generators : list of dict
        The delivered matrices (F, E, G, M, H, K) as exact sympy matrices (None where missing).
    rows : list of int
        Bank row of each line of ``transfer``.
    ok : bool
        Every decoupled entry and every input entry is zero, and every row block sees each
        of its targets.
    variable : sympy.Symbol
    details : list of str
    rtol : float
    seconds : float
    """

    transfer: Any
    zero: np.ndarray
    structural: np.ndarray
    leak: np.ndarray
    rounding_level: float
    input_transfer: Any
    input_zero: np.ndarray
    generators: list[dict[str, Any] | None]
    rows: list[int]
    ok: bool
    variable: Any
    details: list[str] = field(default_factory=list)
    rtol: float = ROUNDING_RTOL
    seconds: float = 0.0

    def summary(self) -> str:
        """One line: ``"proven (structural zeros; rounding level 3e-16)"`` or the failure."""
        if not self.ok:
            return "fails: " + "; ".join(self.details[:3])
        if self.rounding_level > 0:
            return f"proven (rounding-level coefficients ≤ {self.rounding_level:.1e} relative)"
        return "proven (structural zeros)"

    def _repr_latex_(self) -> str:
        import sympy as sp

        return (
            f"Exact proof: {self.summary()}<br>"
            f"$\\displaystyle T({sp.latex(self.variable)}) = {sp.latex(self.transfer)}$"
        )


# ------------------------------------------------------------------ exact data
def _qq_matrix(X: Any) -> Any:
    """A float array or sympy Matrix as a DomainMatrix over QQ (binary floats exactly)."""
    import sympy as sp
    from sympy import QQ
    from sympy.polys.matrices import DomainMatrix

    if isinstance(X, sp.MatrixBase):
        rows = [
            [QQ.from_sympy(sp.nsimplify(x) if x.is_Float else x) for x in X.row(i)]
            for i in range(X.rows)
        ]
        shape = X.shape
    else:
        arr = np.asarray(X, dtype=float)
        rows = [[QQ(*float(x).as_integer_ratio()) for x in r] for r in arr]
        shape = arr.shape
    if shape[0] == 0 or shape[1] == 0:
        return DomainMatrix.zeros(shape, QQ)
    return DomainMatrix(rows, shape, QQ)


def _blocks(K: Any, A, C, E, F, H, M):
    from sympy.polys.matrices import DomainMatrix

    n, k = A.shape[0], F.shape[0]
    top = A.hstack(DomainMatrix.zeros((n, k), K)) if k else A
    Ac = top.vstack((-(E * C)).hstack(F)) if k else top
    Cc = (-(H * C)).hstack(M) if k else -(H * C)
    return Ac, Cc


def _abs(X: Any) -> Any:
    from sympy.polys.matrices import DomainMatrix

    if X.shape[0] == 0 or X.shape[1] == 0:
        return X
    return DomainMatrix([[abs(x) for x in r] for r in X.to_list()], X.shape, X.domain)


def _rho_numeric(
    Ac: Any,
    Bc: Any,
    Cc: Any,
    Dc: Any,
    Dscale: np.ndarray,
    anorm: float,
    w0: np.ndarray,
    cnorm: np.ndarray,
) -> np.ndarray:
    """ρ per (output, column) (module docstring): exact Markov parameters over their scale.

    ``ρ_k = |c Ac^k b| / (‖c‖ ‖Ac‖^k w0)`` and, for the feedthrough, ``|d| / Dscale``,
    with ``w0 = max(‖Bf‖, g ‖Df‖)`` (inputs: ``max(‖B‖, g ‖D‖) + ‖G‖``),
    ``‖c‖ = max(‖M_o‖, ‖H_o‖ ‖C‖)`` and ``g`` the largest ∞-norm of E, H, G, K: the size of
    each coefficient relative to the magnitudes it is made of, before any cancellation
    (rounding in a delivered matrix is relative to the generator's overall magnitude).
    The scales are floats; the Markov parameters are exact (columns rescaled by exact
    powers of two to bound their bit length).
    """
    from sympy import QQ

    nout, ncol = Cc.shape[0], Bc.shape[1]
    rho = np.zeros((nout, ncol))
    if nout == 0 or ncol == 0:
        return rho

    def fl(x: Any) -> float:
        return float(QQ.to_sympy(x)) if x != 0 else 0.0

    Dl = Dc.to_list()
    for o in range(nout):
        for c in range(ncol):
            if Dl[o][c] != 0:
                rho[o, c] = abs(fl(Dl[o][c])) / max(Dscale[o, c], 1e-300)
    lw = np.log2(np.maximum(np.asarray(w0, dtype=float), 1e-300))  # log2 of the scale
    la = np.log2(max(anorm, 1e-300))
    V = Bc
    for _ in range(Ac.shape[0]):
        if V.is_zero_matrix:
            break
        h = (Cc * V).to_list()
        for o in range(nout):
            for c in range(ncol):
                if h[o][c] != 0:
                    val = abs(fl(h[o][c])) * 2.0 ** (-lw[c]) / max(cnorm[o], 1e-300)
                    rho[o, c] = max(rho[o, c], val)
        V = Ac * V
        lw = lw + la
        cols = V.to_list()
        for c in range(ncol):  # divide column c and its scale by 2^e (exact)
            e = int(np.floor(lw[c]))
            if e:
                f = QQ(2) ** abs(e)
                for i in range(len(cols)):
                    cols[i][c] = cols[i][c] / f if e > 0 else cols[i][c] * f
                lw[c] -= e
        V = type(V)(cols, V.shape, V.domain)
    return rho


# --------------------------------------------------------------- readable output
def _cancel_roots(num: np.ndarray, den: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    zs, ps = list(np.roots(num)), list(np.roots(den))
    keep_z = []
    for z in zs:
        j = next((i for i, p in enumerate(ps) if abs(z - p) <= 1e-6 * max(1.0, abs(p))), None)
        if j is None:
            keep_z.append(z)
        else:
            ps.pop(j)
    lead = num[np.flatnonzero(np.abs(num) > 0)[0]] if np.any(num) else 0.0
    return lead * np.atleast_1d(np.real(np.poly(keep_z))), np.atleast_1d(np.real(np.poly(ps)))


def _readable(num: np.ndarray, den: np.ndarray, scale: float, var: Any) -> Any:
    """``num / den`` with simple rational coefficients where they are (else 6 digits)."""
    import sympy as sp

    simple = True

    def coef(x: float) -> Any:
        nonlocal simple
        q = sp.nsimplify(x, rational=True, tolerance=1e-9 * abs(x))
        if q.q > 10**4 or abs(q.p) > 10**9:  # not a simple rational: 6 significant digits
            simple = False
            return sp.Float(float(f"{x:.6g}"), 6)
        return q

    def poly(c: np.ndarray) -> Any:
        big = np.max(np.abs(c)) if c.size else 0.0
        return sp.Add(
            *[coef(float(x)) * var**i for i, x in enumerate(c[::-1]) if abs(x) > 1e-9 * big]
        )

    expr = poly(num / scale) / poly(den / den[0])
    return sp.cancel(expr) if simple else expr


def _float_tf(
    Ac: np.ndarray, b: np.ndarray, c: np.ndarray, d: float
) -> tuple[np.ndarray, np.ndarray]:
    """Numerator and denominator of ``c (sI − Ac)⁻¹ b + d`` (descending powers).

    ``den = det(sI − Ac)`` and ``num = det(sI − Ac + b c) + (d − 1) den`` (the matrix
    determinant lemma), both from eigenvalues (:func:`numpy.poly`).
    """
    if Ac.shape[0] == 0:
        return np.array([d]), np.array([1.0])
    Ac = np.asarray(Ac, dtype=float)
    b, c = np.asarray(b, dtype=float).reshape(-1), np.asarray(c, dtype=float).reshape(-1)
    den = np.poly(Ac)
    num = np.poly(Ac - np.outer(b, c)) + (float(d) - 1.0) * den
    num = np.trim_zeros(num, "f")
    return (num if num.size else np.array([0.0])), den


# ----------------------------------------------------------------- the checks
def _unpack(obj: Any, plant: Plant, faults: Any):
    if isinstance(obj, ExactResidualBank):
        return obj.generators, (obj.faults if faults is None else list(faults)), obj.requested
    if isinstance(obj, ExactResidualGenerator):
        faults = [SensorFault(i) for i in range(plant.q)] if faults is None else list(faults)
        req = np.zeros((1, len(faults)), dtype=bool)
        req[0, list(obj.target)] = True
        return [obj], faults, req
    from geomfdi.verification.numeric import _unpack as numeric_unpack

    return numeric_unpack(obj, plant, faults)


def _check_size(plant: Plant, gens: list[Any], max_order: int) -> int:
    orders = [g.F.shape[0] for g in gens if g is not None]
    N = plant.n + max(orders, default=0)
    if N > max_order:
        raise GeomFDIError(
            f"max_order: the exact proof needs closed loops of order n + order(generator) = {N} "
            f"(n = {plant.n}, largest generator order {max(orders)}), above the cap "
            f"max_order = {max_order}; its cost grows like the cube of the order (about "
            f"{2e-4 * N**3 * len(orders):.0f} s here); pass a larger max_order to run it",
            argument="max_order",
        )
    return N


def _exact_tf(Ac: Any, b: Any, c: Any, d: Any, var: Any) -> Any:
    """``c (var I − Ac)⁻¹ b + d`` over ``K``: charpoly ``Σ a_i var^(N−i)`` and Markov
    parameters ``h_k = c Ac^k b`` give the numerator ``Σ_j (Σ_{i≤j} a_i h_{j−i}) var^(N−1−j)``.
    """
    import sympy as sp

    K = Ac.domain
    N = Ac.shape[0]
    dd = K.to_sympy(d.to_list()[0][0])
    if N == 0:
        return sp.factor(dd)
    a = Ac.charpoly()
    h, V = [], b
    for _ in range(N):
        h.append((c * V).to_list()[0][0])
        V = Ac * V
    num = [sum((a[i] * h[j - i] for i in range(j + 1)), K.zero) for j in range(N)]
    nexpr = sp.Add(*[K.to_sympy(x) * var ** (N - 1 - j) for j, x in enumerate(num)])
    dexpr = sp.Add(*[K.to_sympy(x) * var ** (N - i) for i, x in enumerate(a)])
    return sp.factor(sp.cancel(nexpr / dexpr + dd))


def _exact_row(ctx: Any, g: Any, sigs, var) -> dict[str, Any]:
    """Parametric / rational generator: exact zero tests and cancelled transfers."""
    import sympy as sp

    from geomfdi.geometry import parametric as pm

    F_ = ctx["F"]
    K = F_.K
    dm = {k: ctx["dm"](getattr(g, k)) for k in "FEGMHK"}
    P = ctx["plant"]
    Ac, Cc = _blocks(K, P["A"], P["C"], dm["E"], dm["F"], dm["H"], dm["M"])
    nout = dm["M"].shape[0]
    cols = [(Bf, Df, None, None) for Bf, Df in sigs]
    cols_in = [(P["B"], P["D"], dm["G"], dm["K"]), (P["Bd"], P["Dd"], None, None)]

    def channel(Bx, Dy, Gx, Kx):
        Bw, Dc = -(dm["E"] * Dy), -(dm["H"] * Dy)
        if Gx is not None:
            Bw, Dc = Bw + Gx, Dc + Kx
        return Bx.vstack(Bw) if Bw.shape[0] else Bx, Dc

    def entry(Bc, Dc, o, c):
        b = Bc.extract(list(range(Bc.shape[0])), [c])
        co = Cc.extract([o], list(range(Cc.shape[1])))
        d = Dc.extract([o], [c])
        if pm.block_transfer_is_zero(Ac, b, co, d):
            return True, sp.Integer(0)
        return False, _exact_tf(Ac, b, co, d, var)

    zero, tr = np.ones((nout, len(cols)), dtype=bool), [[None] * len(cols) for _ in range(nout)]
    for j, (Bf, Df, _, _) in enumerate(cols):
        Bc, Dc = channel(Bf, Df, None, None)
        for o in range(nout):
            zs = [entry(Bc, Dc, o, c) for c in range(Bf.shape[1])] or [(True, sp.Integer(0))]
            zero[o, j] = all(z for z, _ in zs)
            tr[o][j] = zs[0][1]
    ins, izero = [[] for _ in range(nout)], [[] for _ in range(nout)]
    for Bx, Dy, Gx, Kx in cols_in:
        if Bx.shape[1] == 0:
            continue
        Bc, Dc = channel(Bx, Dy, Gx, Kx)
        for o in range(nout):
            for c in range(Bx.shape[1]):
                z, t = entry(Bc, Dc, o, c)
                izero[o].append(z)
                ins[o].append(t)
    return {
        "zero": zero,
        "structural": zero.copy(),
        "leak": (~zero).astype(float),
        "transfer": tr,
        "input_zero": izero,
        "input_transfer": ins,
        "input_leak": [[0.0 if z else 1.0 for z in r] for r in izero],
        "exact": {k: ctx["F"].to_sympy(dm[k].to_list(), *dm[k].shape) for k in "FEGMHK"},
    }


def _numeric_row(
    P: dict[str, Any],
    Pf: dict[str, np.ndarray],
    g: ResidualGenerator,
    sigs,
    fsigs,
    rtol: float,
    var,
) -> dict[str, Any]:
    """Delivered float generator: exact ρ per entry, readable transfers from the floats."""
    import sympy as sp
    from sympy import QQ

    dm = {k: _qq_matrix(getattr(g, k)) for k in "FEGMHK"}
    Ac, Cc = _blocks(QQ, P["A"], P["C"], dm["E"], dm["F"], dm["H"], dm["M"])
    nout = g.n_outputs

    # rounding in a delivered matrix is relative to the generator's overall magnitude
    gnorm = max(
        (float(np.abs(X).sum(axis=1).max()) for X in (g.E, g.H, g.G, g.K) if X.size),
        default=0.0,
    )
    hn = np.full(g.n_outputs, gnorm)
    enorm = gnorm

    def channel(Bx, Dy, Gx=None, Kx=None, Bxf=None, Dyf=None, Gxf=None, Kxf=None):
        Bw, Dc = -(dm["E"] * Dy), -(dm["H"] * Dy)
        ncol = Dyf.shape[1]
        dmax = np.abs(Dyf).max(axis=0) if Dyf.size else np.zeros(ncol)
        Dscale = np.outer(hn, dmax)
        w0 = enorm * dmax
        if Bxf.size:
            w0 = np.maximum(w0, np.abs(Bxf).max(axis=0))
        if Gx is not None:
            Bw, Dc = Bw + Gx, Dc + Kx
            Dscale = Dscale + np.abs(Kxf)
            w0 = w0 + (np.abs(Gxf).max(axis=0) if Gxf.size else 0.0)
        return (Bx.vstack(Bw) if Bw.shape[0] else Bx), Dc, Dscale, w0

    Acf = (
        np.block([[Pf["A"], np.zeros((Pf["A"].shape[0], g.order))], [-g.E @ Pf["C"], g.F]])
        if g.order
        else Pf["A"]
    )
    Ccf = np.hstack([-g.H @ Pf["C"], g.M])
    anorm = float(np.abs(Acf).sum(axis=1).max()) if Acf.size else 0.0
    cnorm_plant = float(np.abs(Pf["C"]).sum(axis=1).max()) if Pf["C"].size else 0.0
    mn = np.abs(g.M).sum(axis=1) if g.M.size else np.zeros(g.n_outputs)
    cn = np.maximum(mn, np.abs(g.H).sum(axis=1) * cnorm_plant)

    def readable(Bxf, Dyf, Gxf, Kxf, o, c):
        Bw, Dc = -g.E @ Dyf, -g.H @ Dyf
        if Gxf is not None:
            Bw, Dc = Bw + Gxf, Dc + Kxf
        b = np.concatenate([Bxf[:, c], Bw[:, c]])
        return _cancel_roots(*_float_tf(Acf, b, Ccf[o], float(Dc[o, c])))

    out: dict[str, Any] = {"exact": {k: dm[k].to_Matrix() for k in "FEGMHK"}}
    nf = len(sigs)
    rho = np.zeros((nout, nf))
    struct = np.ones((nout, nf), dtype=bool)
    tfs: list[list[Any]] = [[None] * nf for _ in range(nout)]
    for j, ((Bf, Df), (Bff, Dff)) in enumerate(zip(sigs, fsigs, strict=True)):
        Bc, Dc, Dscale, W0 = channel(Bf, Df, Bxf=Bff, Dyf=Dff)
        r = _rho_numeric(Ac, Bc, Cc, Dc, Dscale, anorm, W0, cn)
        rho[:, j] = r.max(axis=1) if r.size else 0.0
        struct[:, j] = ~np.any(r > 0, axis=1) if r.size else True
        for o in range(nout):
            tfs[o][j] = readable(Bff, Dff, None, None, o, 0) if rho[o, j] > rtol else None
    irho, itf = [[] for _ in range(nout)], [[] for _ in range(nout)]
    for (Bx, Dy, Gx, Kx), (Bxf, Dyf, Gxf, Kxf) in (
        ((P["B"], P["D"], dm["G"], dm["K"]), (Pf["B"], Pf["D"], g.G, g.K)),
        ((P["Bd"], P["Dd"], None, None), (Pf["Bd"], Pf["Dd"], None, None)),
    ):
        if Bx.shape[1] == 0:
            continue
        Bc, Dc, Dscale, W0 = channel(Bx, Dy, Gx, Kx, Bxf, Dyf, Gxf, Kxf)
        r = _rho_numeric(Ac, Bc, Cc, Dc, Dscale, anorm, W0, cn)
        for o in range(nout):
            for c in range(Bx.shape[1]):
                irho[o].append(float(r[o, c]))
                itf[o].append(readable(Bxf, Dyf, Gxf, Kxf, o, c) if r[o, c] > rtol else None)
    # one normalisation per residual output: the first non-zero numerator's leading coefficient
    for o in range(nout):
        lead = next(
            (
                t[0][np.flatnonzero(t[0])[0]]
                for t in tfs[o] + itf[o]
                if t is not None and np.any(t[0])
            ),
            1.0,
        )
        tfs[o] = [sp.Integer(0) if t is None else _readable(t[0], t[1], lead, var) for t in tfs[o]]
        itf[o] = [sp.Integer(0) if t is None else _readable(t[0], t[1], lead, var) for t in itf[o]]
    zero = rho <= rtol
    out.update(
        zero=zero,
        structural=struct,
        leak=rho,
        transfer=tfs,
        input_zero=[[x <= rtol for x in r] for r in irho],
        input_transfer=itf,
        input_leak=irho,
    )
    return out


def verify_symbolic(
    bank_or_generator: ResidualBank | ResidualGenerator | ExactResidualBank,
    plant: Plant,
    faults: Sequence[Fault] | None = None,
    *,
    rtol: float = ROUNDING_RTOL,
    max_order: int = SYMBOLIC_MAX_ORDER,
    time_limit: float | None = None,
    progress: bool | None = None,
) -> SymbolicReport:
    """Exact proof that the delivered generators decouple what they must.

    Parameters
    ----------
    bank_or_generator : ResidualBank, ResidualGenerator, ExactResidualBank or
        ExactResidualGenerator
        The generators as delivered (float matrices are converted exactly).
    plant : Plant or control.StateSpace
        The plant (may be parametric for exact generators).
    faults : list of Fault, optional
        Default: the bank's faults.
    rtol : float
        Relative size ``ρ`` (module docstring) up to which a Markov parameter of a float
        generator counts as rounding level (default :data:`ROUNDING_RTOL`).
    max_order : int
        Cap on the closed-loop order ``n + order(generator)``, checked before any work
        (default :data:`SYMBOLIC_MAX_ORDER`).
    time_limit : float, optional
        Seconds; checked after each row, raising :class:`~geomfdi.errors.GeomFDIError`
        (argument ``"time_limit"``) when exceeded.
    progress : bool, optional
        Show a progress bar (stderr) over the rows; default when the closed-loop order
        exceeds 20.

    Returns
    -------
    SymbolicReport

    Raises
    ------
    GeomFDIError
        Bad arguments (named), a closed loop above ``max_order``, or ``time_limit`` exceeded.

    Notes
    -----
    Hou, Wen & Chen (2011), eq. 23 gives the generator; the transfer from a fault to the
    residual is formed on the physical model.  Proof of zero: Cayley–Hamilton on the exact
    Markov parameters; the rounding level is computed exactly, not estimated.
    """
    import sympy as sp

    rtol = as_positive(rtol, "rtol")
    if not rtol < 1:
        raise GeomFDIError(f"rtol: must be below 1, got {rtol}", argument="rtol")
    max_order = as_int(max_order, "max_order", minimum=1)
    if time_limit is not None:
        time_limit = as_positive(time_limit, "time_limit")
    exact_obj = isinstance(bank_or_generator, ExactResidualBank | ExactResidualGenerator)
    if faults is not None:
        faults = as_sequence_of(faults, "faults", Fault)
    plant = as_plant(plant, parametric=exact_obj)
    gens, faults, req = _unpack(bank_or_generator, plant, faults)
    N = _check_size(plant, gens, max_order)
    var = sp.Symbol("z" if plant.dt > 0 else "s")
    t0 = time.perf_counter()
    fm = fault_matrices(faults, plant.n, plant.q)
    ctx: dict[str, Any] = {}
    if exact_obj:
        from sympy.polys.matrices import DomainMatrix

        from geomfdi.geometry import parametric as pm

        mats = {
            k: pm.as_exact_matrix(
                getattr(plant, k),
                k,
                rows=getattr(plant, k).shape[0],
                cols=getattr(plant, k).shape[1],
            )
            for k in ("A", "B", "C", "D", "Bd", "Dd")
        }
        gm = [getattr(g, k) for g in gens if g is not None for k in "FEGMHK"]
        Fld = pm.field_of(*mats.values(), *gm)

        def dmk(X: Any) -> Any:
            X = pm.as_exact_matrix(X, "generator", rows=X.shape[0], cols=X.shape[1])
            if X.rows == 0 or X.cols == 0:
                return DomainMatrix.zeros(X.shape, Fld.K)
            return DomainMatrix(Fld.matrix(X), X.shape, Fld.K)

        ctx = {"F": Fld, "dm": dmk, "plant": {k: dmk(v) for k, v in mats.items()}}
        sigs = [(dmk(b), dmk(d)) for b, d in fm]
    else:
        P = {k: _qq_matrix(getattr(plant, k)) for k in ("A", "B", "C", "D", "Bd", "Dd")}
        Pf = {k: np.asarray(getattr(plant, k), dtype=float) for k in P}
        sigs = [(_qq_matrix(b), _qq_matrix(d)) for b, d in fm]
    show = (N > 20) if progress is None else bool(progress)
    it = list(enumerate(gens))
    if show:
        from tqdm.auto import tqdm

        it = tqdm(it, desc="exact proof", unit="row", file=sys.stderr)
    lines, zrows, srows, lrows, in_lines, in_zero, rows, exact_gens, details = (
        [] for _ in range(9)
    )
    ok = True
    worst = 0.0
    for r, g in it:
        if g is None:
            exact_gens.append(None)
            continue
        if exact_obj:
            res = _exact_row(ctx, g, sigs, var)
        else:
            res = _numeric_row(P, Pf, g, sigs, fm, rtol, var)
        exact_gens.append(res["exact"])
        zero, struct, leak = res["zero"], res["structural"], res["leak"]
        for o in range(zero.shape[0]):
            lines.append(res["transfer"][o])
            zrows.append(zero[o])
            srows.append(struct[o])
            lrows.append(leak[o])
            in_lines.append(res["input_transfer"][o])
            in_zero.append(res["input_zero"][o])
            rows.append(r)
            for j in range(len(faults)):
                if not req[r, j] and not zero[o, j]:
                    ok = False
                    details.append(f"row {r}: fault {j} is not decoupled: {res['transfer'][o][j]}")
                if not req[r, j] and zero[o, j] and not struct[o, j]:
                    worst = max(worst, float(leak[o, j]))
            for c, z in enumerate(res["input_zero"][o]):
                if not z:
                    ok = False
                    details.append(f"row {r}: input {c} reaches the residual")
                elif not exact_obj and res["input_leak"][o][c] > 0:
                    worst = max(worst, float(res["input_leak"][o][c]))
        for j in np.flatnonzero(req[r]):
            if np.all(zero[:, j]):  # the row block sees j when any component does
                ok = False
                details.append(f"row {r}: target fault {j} has a zero transfer")
        if time_limit is not None and time.perf_counter() - t0 > time_limit:
            raise GeomFDIError(
                f"time_limit: the exact proof exceeded {time_limit:g} s after row {r} of "
                f"{len(gens)} (closed-loop order up to {N})",
                argument="time_limit",
            )
    nf = len(faults)
    transfer = sp.Matrix(lines) if lines else sp.zeros(0, nf)
    width = max((len(x) for x in in_lines), default=0)
    itransfer = sp.Matrix(in_lines) if width else sp.zeros(len(lines), 0)
    return SymbolicReport(
        transfer=transfer,
        zero=np.array(zrows, dtype=bool).reshape(len(lines), nf),
        structural=np.array(srows, dtype=bool).reshape(len(lines), nf),
        leak=np.array(lrows, dtype=float).reshape(len(lines), nf),
        rounding_level=worst,
        input_transfer=itransfer,
        input_zero=np.array(in_zero, dtype=bool).reshape(len(lines), width),
        generators=exact_gens,
        rows=rows,
        ok=ok,
        variable=var,
        details=details,
        rtol=rtol,
        seconds=time.perf_counter() - t0,
    )
