"""Exact rational arithmetic (sympy): subspaces, W*, S* and the generator construction.

The numeric algorithms take rank decisions with a tolerance; here every decision is exact,
so the results prove the numeric ones on systems with rational data.  Bases are rational
(not orthonormal) and put in a canonical form (reduced column echelon form), so that two
equal subspaces have identical bases.

Inputs may be sympy matrices or anything numeric; floats are converted through their
shortest decimal representation (``Rational(repr(x))``), which is exact for the decimals
a user typed.

Use as ``gf.exact.min_unobservability_subspace(A, C, L)``, or pass sympy matrices (or
``exact=True``) to :func:`geomfdi.min_unobservability_subspace`.

Entries may also be rational functions of sympy symbols (a parametric family): W* and S*
are then computed over the field of rational functions of the parameters
(:mod:`geomfdi.geometry.parametric`, generic ranks) and the result carries
``exceptional``: the polynomial conditions on the parameters under which the result does
not hold (the subspace there differs from the generic basis evaluated there, or that
basis is undefined; each checked by redoing the iteration on the specialised family).
See the user guide, *Theory: verification* (``docs/theory/verification.md``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import sympy as sp

from geomfdi.errors import ComplexInputError, DesignError, GeomFDIError, NonFiniteError, ShapeError
from geomfdi.geometry._fixpoint import monotone_fixpoint
from geomfdi.geometry.parametric import real_number

__all__ = [
    "to_rational",
    "ExactSubspace",
    "span",
    "kernel",
    "min_conditioned_invariant",
    "min_unobservability_subspace",
    "measurement_map",
    "friend",
    "right_inverse",
    "place_observer",
]


def _rational_entry(x: Any, name: str) -> sp.Rational:
    if isinstance(x, sp.Basic):
        if x.is_Rational:
            return sp.Rational(x)
        if x.is_Float and x.is_finite:
            return sp.Rational(repr(float(x)))
        if x in (sp.nan, sp.oo, -sp.oo, sp.zoo) or x.is_Float:
            raise NonFiniteError(f"{name}: entries must be finite, got {x}", argument=name)
        if x.is_number and not x.is_real:
            raise ComplexInputError(f"{name}: must be real, got complex entries", argument=name)
        raise GeomFDIError(f"{name}: entries must be rational numbers, got {x}", argument=name)
    if isinstance(x, bool | str | bytes):
        raise GeomFDIError(f"{name}: entries must be numbers, got {x!r}", argument=name)
    if isinstance(x, list | tuple | np.ndarray):
        raise ShapeError(
            f"{name}: cannot be read as a matrix (rows of different lengths or nesting too deep)",
            argument=name,
        )
    return real_number(x, name)


def to_rational(M: Any, name: str = "M", *, rows: int | None = None) -> sp.Matrix:
    """Convert ``M`` to a sympy Matrix of exact rationals (a 1-D input is a column)."""
    if M is None:
        raise GeomFDIError(f"{name}: a value is required, got None", argument=name)
    if isinstance(M, str | bytes):
        raise GeomFDIError(f"{name}: entries must be numbers, got {M!r}", argument=name)
    if isinstance(M, sp.MatrixBase):
        data = M.tolist()
    else:
        arr = np.asarray(M, dtype=object)
        if arr.ndim == 1:
            arr = arr.reshape(-1, 1)
        if arr.ndim != 2:
            raise ShapeError(f"{name}: must be a 2-D matrix, got shape {arr.shape}", argument=name)
        data = arr.tolist()
    out = sp.Matrix([[_rational_entry(x, name) for x in row] for row in data])
    if not data:
        out = sp.zeros(rows or 0, 0)
    if rows is not None and out.rows != rows:
        raise ShapeError(f"{name}: expected {rows} rows, got {out.shape}", argument=name)
    return out


def _canonical(M: sp.Matrix, n: int) -> sp.Matrix:
    """Canonical basis of Im M: the transposed non-zero rows of rref(Mᵀ)."""
    if M.cols == 0:
        return sp.zeros(n, 0)
    R, piv = M.T.rref()
    return R[: len(piv), :].T if piv else sp.zeros(n, 0)


class ExactSubspace:
    """A subspace of Q^n with a canonical rational basis.

    Attributes
    ----------
    basis : sympy.Matrix (n, dim)
        Reduced column echelon basis (identical for equal subspaces).
    history : list of int
        For results of the algorithms: dimensions per step.
    """

    def __init__(self, M: Any, n: int | None = None) -> None:
        M = M if isinstance(M, sp.MatrixBase) else to_rational(M)
        self.n = M.rows if n is None else n
        self.basis = _canonical(sp.Matrix(M), self.n)
        self.history: list[int] = []

    @property
    def dim(self) -> int:
        return self.basis.cols

    def __add__(self, other: ExactSubspace) -> ExactSubspace:
        return ExactSubspace(self.basis.row_join(other.basis), self.n)

    def __and__(self, other: ExactSubspace) -> ExactSubspace:
        if self.dim == 0 or other.dim == 0:
            return ExactSubspace(sp.zeros(self.n, 0), self.n)
        N = _nullspace(self.basis.row_join(-other.basis))
        return ExactSubspace(self.basis * N[: self.dim, :], self.n)

    def contains(self, other: ExactSubspace) -> bool:
        return (self + other).dim == self.dim

    def __eq__(self, other: object) -> bool:
        return isinstance(other, ExactSubspace) and self.basis == other.basis

    __hash__ = None  # type: ignore[assignment]

    def complement_rows(self) -> sp.Matrix:
        """Rows spanning the annihilator of S (a rational basis of S^⊥, as rows)."""
        if self.dim == 0:
            return sp.eye(self.n)
        return _nullspace(self.basis.T).T

    def to_numeric(self) -> np.ndarray:
        """The basis as a float array."""
        return np.array(self.basis.tolist(), dtype=float).reshape(self.n, self.dim)

    def __repr__(self) -> str:
        return f"ExactSubspace(dim={self.dim}, n={self.n}, history={self.history})"


def _nullspace(M: sp.Matrix) -> sp.Matrix:
    vecs = M.nullspace()
    return sp.Matrix.hstack(*vecs) if vecs else sp.zeros(M.cols, 0)


def span(M: Any) -> ExactSubspace:
    """``Im M`` exactly."""
    return ExactSubspace(to_rational(M, "M"))


def kernel(M: Any) -> ExactSubspace:
    """``Ker M`` exactly."""
    M = to_rational(M, "M")
    return ExactSubspace(_nullspace(M), M.cols)


def _intersect_kernel(Z: ExactSubspace, C: sp.Matrix) -> ExactSubspace:
    if Z.dim == 0:
        return Z
    return ExactSubspace(Z.basis * _nullspace(C * Z.basis), Z.n)


def _preimage_in_kernel(A: sp.Matrix, Z: ExactSubspace, C: sp.Matrix) -> ExactSubspace:
    return ExactSubspace(_nullspace(sp.Matrix.vstack(Z.complement_rows() * A, C)), A.rows)


def _prepare(A: Any, C: Any, L: Any) -> tuple[sp.Matrix, sp.Matrix, ExactSubspace]:
    A = to_rational(A, "A")
    if A.rows != A.cols or A.rows == 0:
        raise ShapeError(f"A: must be square and non-empty, got shape {A.shape}", argument="A")
    n = A.rows
    C = to_rational(C, "C")
    if C.cols != n:
        raise ShapeError(f"C: expected {n} columns, got shape {C.shape}", argument="C")
    if isinstance(L, ExactSubspace):
        Ls = L
    else:
        if hasattr(L, "basis") and not isinstance(L, sp.MatrixBase):  # a numeric Subspace
            L = L.basis
        Lm = to_rational(L, "L")
        if Lm.cols == 0:
            Lm = sp.zeros(n, 0)
        elif Lm.rows != n:
            raise ShapeError(f"L: expected {n} rows, got shape {Lm.shape}", argument="L")
        Ls = ExactSubspace(Lm, n)
    return A, C, Ls


def _parametric(which: str, A: Any, C: Any, L: Any) -> ExactSubspace:
    """W* or S* of a parametric family over Q(params), with the exceptional conditions."""
    from geomfdi.geometry import parametric as pm

    if isinstance(L, ExactSubspace):
        L = L.basis
    Am = pm.as_exact_matrix(A, "A")
    n = Am.rows
    if Am.cols != n or n == 0:
        raise ShapeError(f"A: must be square and non-empty, got shape {Am.shape}", argument="A")
    Cm = pm.as_exact_matrix(C, "C", cols=n, vector_as="row")
    Lm = pm.as_exact_matrix(L, "L", rows=n)

    def run(Ax: sp.Matrix, Cx: sp.Matrix, Lx: sp.Matrix) -> tuple[Any, Any]:
        F = pm.field_of(Ax, Cx, Lx)
        fn = (
            pm.generic_unobservability_subspace
            if which == "S"
            else pm.generic_conditioned_invariant
        )
        Lrows = F.matrix(Lx) if Lx.cols else [[] for _ in range(n)]
        res = fn(F, F.matrix(Ax), F.matrix(Cx), Lrows, n, Cx.rows, Lx.cols)
        return F, res

    F, res = run(Am, Cm, Lm)
    conds = []
    for f in F.candidate_factors():
        lin = [x for x in sorted(f.free_symbols, key=str) if sp.degree(f, x) == 1]
        sol = sp.solve(f, lin[0]) if lin else None
        if lin and not sol:
            continue  # cannot vanish under the symbols' assumptions
        if not lin:
            conds.append(f)  # not checked: kept as a candidate
            continue
        sub = {lin[0]: sol[0]}
        spec = [M.subs(sub).applyfunc(sp.cancel) for M in (Am, Cm, Lm)]
        if any(M.has(sp.zoo, sp.nan) for M in spec):
            continue
        _, r2 = run(*spec)
        here = res.to_sympy().subs(sub).applyfunc(sp.cancel)
        if here.has(sp.zoo, sp.nan) or r2.dim != res.dim:
            conds.append(f)  # the generic basis is undefined there, or the dimension changes
            continue
        if r2.dim and sp.Matrix.hstack(r2.to_sympy(), here).rank() != r2.dim:
            conds.append(f)  # same dimension, another subspace
    out = ExactSubspace.__new__(ExactSubspace)
    out.n, out.basis, out.history = n, res.to_sympy(), res.history
    if res.W is not None:
        W = ExactSubspace.__new__(ExactSubspace)
        W.n, W.basis, W.history = n, res.W.to_sympy(), res.W.history
        out.W = W  # type: ignore[attr-defined]
    out.exceptional = conds  # type: ignore[attr-defined]
    out.parameters = F.symbols  # type: ignore[attr-defined]
    return out


def _symbolic(*values: Any) -> bool:
    from geomfdi.geometry.parametric import has_symbols

    return has_symbols(*[v.basis if isinstance(v, ExactSubspace) else v for v in values])


def min_conditioned_invariant(A: Any, C: Any, L: Any) -> ExactSubspace:
    """W* in exact arithmetic: ``Z_0 = L, Z_k = L + A(Z_{k-1} ∩ Ker C)``.

    Hou, Wen & Chen (2011), eq. 14.

    With symbols in the data: generic W* over the rational functions of the parameters,
    with ``exceptional`` (module docstring).
    """
    if _symbolic(A, C, L):
        return _parametric("W", A, C, L)
    A, C, Ls = _prepare(A, C, L)

    def step(Z: ExactSubspace) -> ExactSubspace:
        return Ls + ExactSubspace(A * _intersect_kernel(Z, C).basis, A.rows)

    return monotone_fixpoint(Ls, step, A.rows + 1, grow=True)


def min_unobservability_subspace(A: Any, C: Any, L: Any) -> ExactSubspace:
    """S* in exact arithmetic: ``Z_0 = Q^n, Z_k = W* + A⁻¹(Z_{k-1}) ∩ Ker C`` (eq. 15).

    Returns an :class:`ExactSubspace` with the canonical rational basis, ``history`` and
    ``W`` (the exact W*).

    Examples
    --------
    Hou, Wen & Chen 2011, §4: S* of the signatures ``L_2, L_3`` is spanned by e1 and e3.

    >>> import geomfdi as gf
    >>> A = [[1, 1, 1], [0, 1, 0], [2, 0, 1]]
    >>> C = [[0, 1, 0], [0, 0, 1], [1, 0, 2]]
    >>> S = gf.exact.min_unobservability_subspace(A, C, [[1, -1], [0, 0], [3, -2]])
    >>> S.basis.T, S.history, S.W.history
    (Matrix([
    [1, 0, 0],
    [0, 0, 1]]), [3, 2, 2], [2, 2])

    A parameter ``k`` in the output map ``C = [[k, 1, 0], [1, 0, 1]]`` and the signature
    ``(1, −1, 0)``: S* is the line of the signature for every k except ``k = 1/3``, where
    it is a plane (checked by redoing the iteration there).

    >>> import sympy as sp
    >>> k = sp.Symbol("k")
    >>> Ck = sp.Matrix([[k, 1, 0], [1, 0, 1]])
    >>> Sk = gf.exact.min_unobservability_subspace(A, Ck, [1, -1, 0])
    >>> Sk.basis.T, Sk.exceptional
    (Matrix([[1, -1, 0]]), [k - 1/3])
    >>> gf.exact.min_unobservability_subspace(A, Ck.subs(k, sp.Rational(1, 3)), [1, -1, 0]).dim
    2
    """
    if _symbolic(A, C, L):
        return _parametric("S", A, C, L)
    A, C, Ls = _prepare(A, C, L)
    W = min_conditioned_invariant(A, C, Ls)
    n = A.rows
    Z = monotone_fixpoint(
        ExactSubspace(sp.eye(n), n), lambda Z: W + _preimage_in_kernel(A, Z, C), n + 1, grow=False
    )
    Z.W = W  # type: ignore[attr-defined]
    return Z


# ------------------------------------------------------- construction helpers
def right_inverse(P: sp.Matrix) -> sp.Matrix:
    """``R = Pᵀ (P Pᵀ)⁻¹`` so that ``P R = I`` (P of full row rank)."""
    return P.T * (P * P.T).inv()


def _pinv(M: sp.Matrix) -> sp.Matrix:
    if M.rows == 0 or M.cols == 0:
        return sp.zeros(M.cols, M.rows)
    return M.pinv()


def friend(A: sp.Matrix, C: sp.Matrix, S: ExactSubspace, P: sp.Matrix) -> sp.Matrix:
    """Exact output injection with ``P (A + D0 C) S = 0``: ``D0 = −R P A S (C S)⁺``."""
    Sb = S.basis
    R = right_inverse(P)
    D0 = -R * P * A * Sb * _pinv(C * Sb) if S.dim else sp.zeros(A.rows, C.rows)
    if S.dim and (P * (A + D0 * C) * Sb).applyfunc(sp.nsimplify) != sp.zeros(P.rows, S.dim):
        raise DesignError("S: not (C, A)-conditioned invariant (no friend exists)", argument="S")
    return D0


def measurement_map(C: sp.Matrix, S: ExactSubspace) -> sp.Matrix:
    """Rows spanning ``Im C ∩ (C S)^⊥`` (so that ``Ker(H C) = Ker C + S``), exactly."""
    q = C.rows
    ImC = ExactSubspace(C, q)
    CS = ExactSubspace(C * S.basis, q) if S.dim else ExactSubspace(sp.zeros(q, 0), q)
    perp = ExactSubspace(CS.complement_rows().T, q)
    return (ImC & perp).basis.T


def _exact_pole(p: Any) -> sp.Expr:
    """A pole as an exact Gaussian rational (floats through their shortest decimal)."""
    if isinstance(p, sp.Basic):
        re_, im_ = sp.re(p), sp.im(p)
    else:
        z = complex(p)
        re_, im_ = float(z.real), float(z.imag)
    return _rational_entry(re_, "poles") + sp.I * _rational_entry(im_, "poles")


def _charpoly_coeffs(poles: Sequence[Any]) -> list[sp.Expr]:
    """Exact rational coefficients of ``Π (s − p)`` (the spectrum must be conjugate-closed)."""
    s = sp.Symbol("s")
    poly = sp.Poly(sp.expand(sp.prod([s - _exact_pole(p) for p in poles])), s)
    coeffs = [sp.expand(c) for c in poly.all_coeffs()]
    if any(sp.im(c) != 0 for c in coeffs):
        raise DesignError(
            "poles: the requested spectrum must be closed under conjugation", argument="poles"
        )
    return [sp.Rational(sp.re(c)) for c in coeffs]


def place_observer(A0: sp.Matrix, M: sp.Matrix, poles: Sequence[Any]) -> sp.Matrix:
    """Exact D1 with ``eig(A0 + D1 M) = poles`` (Ackermann on one output combination).

    For several rows of M, the combination ``c = Σ_k k-th prime-weighted rows`` is tried
    until ``(c M, A0)`` is observable (generic).
    """
    k = A0.rows
    if k == 0:
        return sp.zeros(0, M.rows)
    coeffs = _charpoly_coeffs(poles)
    if len(coeffs) - 1 != k:
        raise DesignError(f"poles: expected {k} poles, got {len(poles)}", argument="poles")
    weights_list = [sp.eye(M.rows)[i, :] for i in range(M.rows)]
    weights_list += [sp.Matrix([[sp.Integer(j + 1) ** i for i in range(M.rows)]]) for j in range(4)]
    for w in weights_list:
        c = w * M
        O = sp.Matrix.vstack(*[c * A0**i for i in range(k)])
        if O.rank() < k:
            continue
        # observer Ackermann: l = p(A0) O^{-1} e_k, A0 - l c has the requested spectrum
        pA = sp.zeros(k, k)
        for coef in coeffs:
            pA = pA * A0 + coef * sp.eye(k)
        ek = sp.zeros(k, 1)
        ek[k - 1] = 1
        ell = pA * O.inv() * ek
        return -ell * w
    raise DesignError("M: (M, A0) is not observable; cannot place the poles", argument="M")
