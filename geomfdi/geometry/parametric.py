"""Linear algebra over the field of rational functions of the plant's parameters.

A plant whose entries contain sympy symbols (a mass ``m``, a gain ``k1``) describes a
family.  Its subspaces (W*, S*, ...) are computed over the field ``K = Q(p_1, ..., p_k)``
of rational functions of the parameters: every rank is the **generic** rank, the rank for
all parameter values except those on an algebraic set.  Each elimination records its pivots;
the irreducible factors of their numerators and denominators are the candidates for that
**exceptional set** (where a pivot vanishes a rank may drop).  Candidates are confirmed by
the callers (see :mod:`geomfdi.synthesis.exact.design`), who redo the computation on the
specialised family.

Arithmetic uses sympy's sparse polynomial fields (``QQ.frac_field``): far faster than
``sympy.Matrix`` with expression simplification, and always in canonical (cancelled) form.
Matrices here are plain lists of rows of field elements; :func:`to_sympy` converts back.

See the user guide, *Theory: verification* (``docs/theory/verification.md``), section
"Parametric plants".
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from fractions import Fraction
from typing import Any

import numpy as np
import sympy as sp

from geomfdi.errors import ComplexInputError, GeomFDIError, NonFiniteError, ShapeError
from geomfdi.geometry._fixpoint import monotone_fixpoint

__all__ = [
    "ParametricField",
    "as_exact_matrix",
    "has_symbols",
    "field_of",
    "GenericSubspace",
    "generic_conditioned_invariant",
    "generic_unobservability_subspace",
]

Mat = list[list[Any]]


# ----------------------------------------------------------------- conversion
def has_symbols(*values: Any) -> bool:
    """True when any entry of the values is a sympy expression with free symbols."""
    for v in values:
        if v is None:
            continue
        if isinstance(v, sp.Basic):
            if v.free_symbols:
                return True
            continue
        if isinstance(v, sp.MatrixBase):
            if v.free_symbols:
                return True
            continue
        if isinstance(v, list | tuple | np.ndarray):
            arr = np.asarray(v, dtype=object)
            if any(isinstance(x, sp.Basic) and x.free_symbols for x in arr.flat):
                return True
    return False


def real_number(x: Any, name: str) -> sp.Rational:
    """A Python or numpy real number as an exact rational (binary floats exactly);
    a named error for complex, non-finite or non-numeric ``x``."""
    if isinstance(x, int | np.integer):
        return sp.Integer(int(x))
    if isinstance(x, complex | np.complexfloating):
        raise ComplexInputError(f"{name}: must be real, got complex entries", argument=name)
    try:
        f = float(x)
    except (TypeError, ValueError) as exc:
        raise GeomFDIError(f"{name}: entries must be numbers, got {x!r}", argument=name) from exc
    if not np.isfinite(f):
        raise NonFiniteError(f"{name}: entries must be finite, got {f}", argument=name)
    return sp.Rational(repr(f))


def exact_scalar(x: Any, name: str) -> sp.Expr:
    """One exact scalar option (a pole, a filter parameter): never evaluates code.

    Accepted: Python/numpy real numbers (binary floats exactly), sympy expressions that are
    rational functions of symbols, and strings that are plain number literals (``"-1/2"``,
    ``"0.25"``, ``"1e-3"``, parsed by :class:`fractions.Fraction`).  Any other string is
    refused: strings are never handed to ``sympify``, which would execute them.
    """
    if isinstance(x, str):
        try:
            fr = Fraction(x.strip())
        except (ValueError, ZeroDivisionError) as exc:
            raise GeomFDIError(
                f"{name}: strings must be plain numbers such as '-1/2' or '0.25' (they are "
                f"never evaluated); give a number or a sympy expression, got {x!r:.60}",
                argument=name,
            ) from exc
        return sp.Rational(fr.numerator, fr.denominator)
    return _exact_entry(x, name)


#: Largest degree of an exact entry in its parameters (numerator plus denominator, as
#: written, before any expansion).  Exact elimination multiplies these degrees: an entry
#: of degree 32 already takes tens of seconds, ``k**100000`` would exhaust the memory.
MAX_EXACT_DEGREE = 32


def degree_bound(x: sp.Basic) -> int:
    """An upper bound of the total degree (numerator plus denominator) of the rational
    function ``x``, read from the expression tree without expanding it: a symbol has
    degree 1, a sum the largest degree of its terms, a product the sum, an integer power
    ``b**n`` ``|n|`` times the degree of ``b``."""
    if not x.free_symbols:
        return 0
    if x.is_Symbol:
        return 1
    if x.is_Pow and x.exp.is_Integer:
        return abs(int(x.exp)) * degree_bound(x.base)
    if x.is_Add:
        return max(degree_bound(a) for a in x.args)
    # a product (and anything else a rational function is made of): degrees add up
    return sum(degree_bound(a) for a in x.args)


def check_degree(x: sp.Basic, name: str) -> None:
    """Refuse an exact entry above :data:`MAX_EXACT_DEGREE` before any work is done."""
    deg = degree_bound(x)
    if deg > MAX_EXACT_DEGREE:
        from geomfdi.errors import ResourceLimitError

        raise ResourceLimitError(
            f"{name}: an entry has degree {deg} in the parameters; exact and parametric "
            f"design are limited to degree {MAX_EXACT_DEGREE} per entry "
            "(geomfdi.geometry.parametric.MAX_EXACT_DEGREE): the elimination multiplies "
            "degrees and would not finish",
            limit="max_exact_degree",
            argument=name,
        )


def _exact_entry(x: Any, name: str) -> sp.Expr:
    if isinstance(x, sp.Basic):
        if x.is_Float:
            if not x.is_finite:
                raise NonFiniteError(f"{name}: entries must be finite, got {x}", argument=name)
            return sp.Rational(repr(float(x)))
        if x.has(sp.nan, sp.oo, -sp.oo, sp.zoo):
            raise NonFiniteError(f"{name}: entries must be finite, got {x}", argument=name)
        if x.has(sp.I):
            raise ComplexInputError(f"{name}: must be real, got {x}", argument=name)
        x = sp.nsimplify(x, rational=True) if x.has(sp.Float) else x
        if not x.is_rational_function(*x.free_symbols):
            raise GeomFDIError(
                f"{name}: entries must be rational functions of symbols (no sqrt, sin, ...), "
                f"got {x}",
                argument=name,
            )
        check_degree(x, name)
        return sp.sympify(x)
    if isinstance(x, bool | str | bytes) or x is None:
        raise GeomFDIError(f"{name}: entries must be numbers or symbols, got {x!r}", argument=name)
    return real_number(x, name)


def as_exact_matrix(
    M: Any,
    name: str,
    *,
    rows: int | None = None,
    cols: int | None = None,
    vector_as: str = "column",
) -> sp.Matrix:
    """``M`` as a sympy Matrix of rationals and rational functions of symbols.

    Floats are read through their shortest decimal representation (``0.1 → 1/10``),
    integers exactly; sympy expressions must be rational functions of their symbols.
    A 1-D input is a column (``vector_as="column"``) or a row.
    """
    if M is None:
        raise GeomFDIError(f"{name}: a value is required, got None", argument=name)
    if isinstance(M, sp.MatrixBase):
        data = M.tolist()
        if M.rows == 0 or M.cols == 0:
            return sp.zeros(
                rows if rows is not None else M.rows, cols if cols is not None else M.cols
            )
    else:
        arr = np.asarray(M, dtype=object)
        if arr.ndim == 0:
            arr = arr.reshape(1, 1)
        elif arr.ndim == 1:
            arr = arr.reshape(-1, 1) if vector_as == "column" else arr.reshape(1, -1)
        if arr.ndim != 2:
            raise ShapeError(f"{name}: must be a 2-D matrix, got shape {arr.shape}", argument=name)
        if arr.size == 0:
            return sp.zeros(
                rows if rows is not None else arr.shape[0],
                cols if cols is not None else arr.shape[1],
            )
        data = arr.tolist()
    out = sp.Matrix([[_exact_entry(x, name) for x in row] for row in data])
    if rows is not None and out.rows != rows:
        raise ShapeError(f"{name}: expected {rows} rows, got shape {out.shape}", argument=name)
    if cols is not None and out.cols != cols:
        raise ShapeError(f"{name}: expected {cols} columns, got shape {out.shape}", argument=name)
    return out


# ---------------------------------------------------------------------- field
@dataclass
class ParametricField:
    """``Q(p_1, ..., p_k)`` (or ``Q`` without parameters) with a pivot recorder.

    Attributes
    ----------
    symbols : tuple of sympy.Symbol
        The parameters, sorted by name.
    K : sympy domain
        ``QQ.frac_field(*symbols)`` or ``QQ``.
    pivots : set
        Numerators and denominators of every pivot used by the eliminations (polynomials
        of ``K``'s ring); their irreducible factors are the candidate exceptional set.
    """

    symbols: tuple[Any, ...]
    K: Any = None
    pivots: set[Any] = field(default_factory=set)

    def __post_init__(self) -> None:
        from sympy import QQ

        self.K = QQ.frac_field(*self.symbols) if self.symbols else QQ

    @property
    def parametric(self) -> bool:
        return bool(self.symbols)

    def elem(self, x: Any) -> Any:
        return self.K.from_sympy(sp.sympify(x))

    def matrix(self, M: sp.Matrix) -> Mat:
        return [[self.elem(x) for x in M.row(i)] for i in range(M.rows)]

    def to_sympy(self, X: Mat, rows: int | None = None, cols: int | None = None) -> sp.Matrix:
        if not X:
            return sp.zeros(rows or 0, cols or 0)
        return sp.Matrix([[self.K.to_sympy(x) for x in row] for row in X])

    def record(self, x: Any) -> None:
        if self.parametric:
            for p in (x.numer, x.denom):
                if not p.is_ground:
                    self.pivots.add(p.monic())

    def candidate_factors(self) -> list[sp.Expr]:
        """Irreducible non-constant factors of all recorded pivots (as sympy expressions)."""
        out: dict[Any, sp.Expr] = {}
        for p in self.pivots:
            for f, _ in p.factor_list()[1]:
                if f.is_ground:
                    continue
                f = f.monic()
                out[f] = f.as_expr()
        return sorted(out.values(), key=sp.default_sort_key)


def field_of(*matrices: sp.Matrix, extra: Iterable[Any] = ()) -> ParametricField:
    """The field generated over Q by the symbols of ``matrices`` (and ``extra``)."""
    syms: set[Any] = set()
    for M in matrices:
        syms |= M.free_symbols
    for x in extra:
        syms |= sp.sympify(x).free_symbols
    return ParametricField(tuple(sorted(syms, key=lambda s: s.name)))


# ------------------------------------------------------------ dense elimination
def _cost(x: Any) -> int:
    n = getattr(x, "numer", None)
    if n is None:  # a rational
        return x.numerator.bit_length() + x.denominator.bit_length()
    d = x.denom
    deg = max(sum(mo) for mo in n.monoms()) + max(sum(mo) for mo in d.monoms())
    return 64 * deg + len(n.terms()) + len(d.terms())


def rref(F: ParametricField, X: Mat, ncols: int) -> tuple[Mat, list[int]]:
    """Reduced row echelon form over ``K`` (pivots recorded); returns ``(R, pivot columns)``."""
    K = F.K
    R = [list(row) for row in X]
    piv: list[int] = []
    r = 0
    for c in range(ncols):
        cand = [i for i in range(r, len(R)) if R[i][c] != K.zero]
        if not cand:
            continue
        i = min(cand, key=lambda i: _cost(R[i][c]))
        R[r], R[i] = R[i], R[r]
        p = R[r][c]
        F.record(p)
        inv = K.one / p
        R[r] = [x * inv for x in R[r]]
        for i2 in range(len(R)):
            if i2 != r and R[i2][c] != K.zero:
                f = R[i2][c]
                R[i2] = [a - f * b for a, b in zip(R[i2], R[r], strict=True)]
        piv.append(c)
        r += 1
        if r == len(R):
            break
    return R[:r], piv


def transpose(X: Mat, rows: int, cols: int) -> Mat:
    return [[X[i][j] for i in range(rows)] for j in range(cols)]


def matmul(F: ParametricField, X: Mat, Y: Mat, inner: int, cols: int) -> Mat:
    K = F.K
    out = []
    for row in X:
        acc = [K.zero] * cols
        for k in range(inner):
            a = row[k]
            if a == K.zero:
                continue
            yk = Y[k]
            for j in range(cols):
                if yk[j] != K.zero:
                    acc[j] += a * yk[j]
        out.append(acc)
    return out


def nullspace(F: ParametricField, X: Mat, ncols: int) -> Mat:
    """Columns spanning ``Ker X`` (as an ``ncols × k`` matrix)."""
    K = F.K
    R, piv = rref(F, X, ncols)
    free = [c for c in range(ncols) if c not in piv]
    cols = []
    for fc in free:
        v = [K.zero] * ncols
        v[fc] = K.one
        for r, pc in enumerate(piv):
            v[pc] = -R[r][fc]
        cols.append(v)
    return transpose(cols, len(cols), ncols) if cols else [[] for _ in range(ncols)]


def inverse(F: ParametricField, X: Mat, n: int, what: str) -> Mat:
    K = F.K
    aug = [list(X[i]) + [K.one if j == i else K.zero for j in range(n)] for i in range(n)]
    R, piv = rref(F, aug, 2 * n)
    if piv[:n] != list(range(n)) or len(piv) < n:
        raise GeomFDIError(f"{what}: singular for generic parameter values", argument="plant")
    return [row[n:] for row in R]


def rank(F: ParametricField, X: Mat, ncols: int) -> int:
    return len(rref(F, X, ncols)[1])


# ------------------------------------------------------------------ subspaces
class GenericSubspace:
    """A subspace of ``K^n`` with its canonical basis (reduced column echelon form).

    Attributes
    ----------
    basis : list of rows (n × dim) of field elements
    history : list of int
        Dimensions per step (for the results of the algorithms).
    """

    def __init__(self, F: ParametricField, M: Mat, n: int, ncols: int | None = None) -> None:
        self.F = F
        self.n = n
        ncols = len(M[0]) if M and ncols is None else (ncols or 0)
        if ncols == 0 or n == 0:
            self.basis: Mat = [[] for _ in range(n)]
        else:
            R, _ = rref(F, transpose(M, n, ncols), n)
            self.basis = transpose(R, len(R), n) if R else [[] for _ in range(n)]
        self.history: list[int] = []
        self.W: GenericSubspace | None = None

    @property
    def dim(self) -> int:
        return len(self.basis[0]) if self.n else 0

    def hstack(self, other: Mat, ocols: int) -> GenericSubspace:
        M = [self.basis[i] + other[i] for i in range(self.n)]
        return GenericSubspace(self.F, M, self.n, self.dim + ocols)

    def __add__(self, other: GenericSubspace) -> GenericSubspace:
        return self.hstack(other.basis, other.dim)

    def complement_rows(self) -> Mat:
        """Rows spanning the annihilator of the subspace."""
        K = self.F.K
        if self.dim == 0:
            return [[K.one if i == j else K.zero for j in range(self.n)] for i in range(self.n)]
        N = nullspace(self.F, transpose(self.basis, self.n, self.dim), self.n)
        k = len(N[0])
        return transpose(N, self.n, k)

    def to_sympy(self) -> sp.Matrix:
        return self.F.to_sympy(self.basis, self.n, self.dim) if self.dim else sp.zeros(self.n, 0)

    def __repr__(self) -> str:
        return f"GenericSubspace(dim={self.dim}, n={self.n}, history={self.history})"


def _intersect_kernel(Z: GenericSubspace, C: Mat, q: int) -> GenericSubspace:
    F = Z.F
    if Z.dim == 0:
        return Z
    CZ = matmul(F, C, Z.basis, Z.n, Z.dim)
    N = nullspace(F, CZ, Z.dim)
    k = len(N[0]) if N else 0
    if k == 0:
        return GenericSubspace(F, [[] for _ in range(Z.n)], Z.n, 0)
    return GenericSubspace(F, matmul(F, Z.basis, N, Z.dim, k), Z.n, k)


def generic_conditioned_invariant(
    F: ParametricField, A: Mat, C: Mat, L: Mat, n: int, q: int, ncols: int
) -> GenericSubspace:
    """W* over ``K``: ``Z_0 = L, Z_k = L + A (Z_{k−1} ∩ Ker C)``."""
    Ls = GenericSubspace(F, L, n, ncols)

    def step(Z: GenericSubspace) -> GenericSubspace:
        Kz = _intersect_kernel(Z, C, q)
        return Ls.hstack(matmul(F, A, Kz.basis, n, Kz.dim), Kz.dim) if Kz.dim else Ls

    return monotone_fixpoint(Ls, step, n + 1, grow=True)


def generic_unobservability_subspace(
    F: ParametricField, A: Mat, C: Mat, L: Mat, n: int, q: int, ncols: int
) -> GenericSubspace:
    """S* over ``K``: ``Z_0 = K^n, Z_k = W* + A⁻¹(Z_{k−1}) ∩ Ker C``; ``.W`` holds W*."""
    W = generic_conditioned_invariant(F, A, C, L, n, q, ncols)
    K = F.K

    def step(Z: GenericSubspace) -> GenericSubspace:
        stacked = matmul(F, Z.complement_rows(), A, n, n) + [list(r) for r in C]
        N = nullspace(F, stacked, n)
        k = len(N[0]) if N else 0
        return W.hstack(N, k) if k else GenericSubspace(F, W.basis, n, W.dim)

    eye = [[K.one if i == j else K.zero for j in range(n)] for i in range(n)]
    Z = monotone_fixpoint(GenericSubspace(F, eye, n, n), step, n + 1, grow=False)
    Z.W = W
    return Z


def poly_coeffs_from_roots(roots: Sequence[Any], var: Any) -> list[sp.Expr]:
    """Coefficients (highest first) of ``Π (var − p)`` for numeric or symbolic ``p``."""
    poly = sp.Poly(sp.expand(sp.prod([var - sp.nsimplify(p) for p in roots])), var)
    return [sp.expand(c) for c in poly.all_coeffs()]


def block_transfer_is_zero(Ac: Any, Bc: Any, Cc: Any, Dc: Any) -> bool:
    """Whether ``Cc (sI − Ac)⁻¹ Bc + Dc`` is identically zero (exact, DomainMatrix data).

    Zero iff ``Dc = 0`` and every Markov parameter ``Cc Ac^k Bc``, ``k < N``, vanishes
    (Cayley–Hamilton; N = order of Ac).  Works over ``Q`` and over ``Q(p)``.
    """
    if Dc.shape[0] and Dc.shape[1] and not Dc.is_zero_matrix:
        return False
    if Bc.shape[1] == 0 or Cc.shape[0] == 0:
        return True
    V = Bc
    for _ in range(Ac.shape[0]):
        if not (Cc * V).is_zero_matrix:
            return False
        V = Ac * V
        if V.is_zero_matrix:
            break
    return True
