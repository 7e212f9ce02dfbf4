"""Quantitative fault diagnosability over a time window (seed 002, math.md §7).

A discrete plant with additive faults and Gaussian noise (seed 002, eq. 1)::

    x(k+1) = A x(k) + B u(k) + Bf f(k) + Bw w(k)
    y(k)   = C x(k) + D u(k) + Df f(k) + Dv v(k),     w ~ N(0, Qw),  v ~ N(0, Rv)

is stacked over a window of ``s`` samples into eq. (2), ``L z_s = H x_s + F f_s + E e_s``.
Projecting onto the left null space of ``H`` removes the unknown states (eq. 3); whitening
the projected noise turns the window into the static model ``r = q + e``, ``e ~ N(0, I_d)``,
in which each fault profile ``theta`` is a vector ``q_i = Gamma N_H F_i theta``.  Every index
here is a function of these vectors:

* Kullback-Leibler indices (Eriksson-Frisk-Krysander 2013; seed 002, eq. 8);
* directional-similarity indices (seed 002, eqs. 17, 21, 22);
* detection and isolation probabilities of the generalised-likelihood-ratio chi-square
  tests at a false-alarm rate ``alpha`` (the principled alternative of math.md §7).

:class:`WindowModel` holds the model; :func:`diagnosability_table` builds the paper's tables
(fault x [FD, FI...]); :meth:`WindowModel.applicability` reports Theorems 1-2 of seed 002;
:func:`plot_isolability` draws the isolability table as a heat map.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from scipy import stats

from geomfdi._validation import (
    as_bool,
    as_index,
    as_int,
    as_labels,
    as_matrix,
    as_positive,
    as_probability,
    as_real_array,
    as_sequence_of,
    as_vector,
)
from geomfdi.errors import DesignError, GeomFDIError, RankDeficientError, ShapeError
from geomfdi.limits import check_allocation
from geomfdi.tolerance import get_rtol, rank_decision

__all__ = [
    "WindowModel",
    "StackedWindow",
    "DiagnosabilityTable",
    "FaultApplicability",
    "ApplicabilityReport",
    "diagnosability_table",
    "plot_isolability",
]

NullSpaceMethod = Literal["structured", "direct"]
CosineConvention = Literal["absolute", "signed"]
TableMethod = Literal["kl", "directional", "probability", "probability_index"]

_NULLSPACE_METHODS = ("structured", "direct")
_COSINES = ("absolute", "signed")
_TABLE_METHODS = ("kl", "directional", "probability", "probability_index")


# --------------------------------------------------------------------------- helpers
def _as_covariance(value: Any, name: str, size: int) -> np.ndarray:
    """A symmetric positive semidefinite ``size x size`` covariance.

    A scalar means ``value * I``, a vector of length ``size`` the diagonal (the paper
    gives variances ``N(0, sigma^2)``), a matrix is used as it is.
    """
    arr = as_real_array(value, name)
    if arr.ndim == 0:
        cov = float(arr) * np.eye(size)
    elif arr.ndim == 1 or (arr.ndim == 2 and size > 1 and 1 in arr.shape):
        vec = arr.reshape(-1)
        if vec.size != size:
            raise ShapeError(
                f"{name}: expected {size} variances (or a {size}x{size} matrix), "
                f"got shape {arr.shape}",
                argument=name,
            )
        cov = np.diag(vec)
    elif arr.ndim == 2:
        if arr.shape != (size, size):
            raise ShapeError(
                f"{name}: expected a {size}x{size} covariance, got shape {arr.shape}",
                argument=name,
            )
        cov = arr
    else:
        raise ShapeError(
            f"{name}: must be a scalar, vector or matrix, got shape {arr.shape}", argument=name
        )
    scale = float(np.max(np.abs(cov))) if cov.size else 0.0
    tol = get_rtol(max(size, 1)) * max(scale, np.finfo(float).tiny)
    if np.max(np.abs(cov - cov.T), initial=0.0) > tol:
        raise GeomFDIError(f"{name}: a covariance must be symmetric", argument=name)
    cov = 0.5 * (cov + cov.T)
    if size:
        lam_min = float(np.linalg.eigvalsh(cov)[0])
        if lam_min < -tol:
            raise GeomFDIError(
                f"{name}: covariance is not positive semidefinite "
                f"(smallest eigenvalue {lam_min:.3g})",
                argument=name,
            )
    return cov


def _as_channel(value: Any, name: str, rows: int, cols: int | None = None) -> np.ndarray:
    """A signature matrix with ``rows`` rows; a 1-D input is a column (a row if ``rows = 1``)."""
    return as_matrix(value, name, rows=rows, cols=cols, vector_as="row" if rows == 1 else "column")


def _times_kron(X: np.ndarray, K: np.ndarray) -> np.ndarray:
    """``X @ kron(I_s, K)`` without forming the Kronecker product."""
    rows = X.shape[0]
    s = X.shape[1] // K.shape[0]
    return (X.reshape(rows, s, K.shape[0]) @ K).reshape(rows, s * K.shape[1])


def _block_toeplitz(markov: np.ndarray) -> np.ndarray:
    """Lower block-Toeplitz matrix with block ``markov[j]`` on block sub-diagonal ``j``.

    ``markov`` has shape ``(s, r, c)``; the result is ``(s r, s c)`` with block
    ``(k, t) = markov[k - t]`` for ``k >= t`` and zero above the diagonal.
    """
    s, r, c = markov.shape
    out = np.zeros((s, r, s, c))
    for j in range(s):
        k = np.arange(j, s)
        out[k, :, k - j, :] = markov[j]
    return out.reshape(s * r, s * c)


def _left_null_rows(X: np.ndarray, what: str) -> tuple[np.ndarray, int]:
    """Orthonormal rows spanning the left null space of ``X`` (by a full SVD)."""
    U, sv, _ = np.linalg.svd(X, full_matrices=True)
    scale = float(sv[0]) if sv.size else 0.0
    rank = rank_decision(sv, scale, X.shape[0], what=what).rank
    return U[:, rank:].T.copy(), rank


def _sym_inv_sqrt(M: np.ndarray, what: str) -> np.ndarray:
    """``M^(-1/2)`` of a symmetric positive definite matrix (eigen-decomposition)."""
    w, V = np.linalg.eigh(0.5 * (M + M.T))
    scale = float(w[-1]) if w.size else 0.0
    dec = rank_decision(w[::-1].clip(min=0.0), scale, M.shape[0], what=what, warn=False)
    if dec.rank < M.shape[0]:
        raise RankDeficientError(
            f"Rv: the projected noise covariance N_H E Sigma_e E^T N_H^T ({what}) is singular "
            f"(rank {dec.rank} < {M.shape[0]}): some parity directions carry no noise, so the "
            "indices would be infinite; give Qw/Rv (and Bw/Dv) that excite every residual",
            argument="Rv",
        )
    return (V / np.sqrt(w)) @ V.T


def _rref(X: np.ndarray, tol: float) -> np.ndarray:
    """Reduced row echelon form with partial pivoting; entries below ``tol`` are zero."""
    R = np.array(X, dtype=float)
    rows, cols = R.shape
    r = 0
    for c in range(cols):
        if r == rows:
            break
        piv = r + int(np.argmax(np.abs(R[r:, c])))
        if abs(R[piv, c]) <= tol:
            R[r:, c] = 0.0
            continue
        R[[r, piv]] = R[[piv, r]]
        R[r] /= R[r, c]
        others = np.arange(rows) != r
        R[others] -= np.outer(R[others, c], R[r])
        R[others, c] = 0.0
        r += 1
    R[np.abs(R) <= tol] = 0.0
    return R


def _chi2_power(dof: int, noncentrality: float, alpha: float) -> float:
    """``P(chi2_dof(lambda) > chi2_{dof, 1-alpha})``; ``alpha`` when ``dof = 0``."""
    if dof == 0 or noncentrality <= 0.0:  # no test, or the null distribution itself
        return alpha
    return float(stats.ncx2.sf(stats.chi2.isf(alpha, dof), dof, noncentrality))


# --------------------------------------------------------------------------- records
@dataclass(frozen=True)
class StackedWindow:
    """The stacked window model eq. (2) of seed 002: ``L z_s = H x_s + F f_s + E e_s``.

    Attributes
    ----------
    L : ndarray, ((n + m) s, (m + q) s)
        Acts on ``z_s = [y(k-s+1); ...; y(k); u(k-s+1); ...; u(k)]``.
    H : ndarray, ((n + m) s, n (s + 1))
        Acts on ``x_s = [x(k-s+1); ...; x(k+1)]``.
    F : ndarray, ((n + m) s, p s)
        Acts on ``f_s = [f(k-s+1); ...; f(k)]``; fault ``i`` owns columns ``i, i+p, ...``.
    E : ndarray, ((n + m) s, (l + t) s)
        Acts on ``e_s = [w(k-s+1); ...; w(k); v(k-s+1); ...; v(k)]``.
    Sigma : ndarray, ((l + t) s, (l + t) s)
        Covariance of ``e_s``: ``blockdiag(I_s (x) Qw, I_s (x) Rv)``.
    """

    L: np.ndarray
    H: np.ndarray
    F: np.ndarray
    E: np.ndarray
    Sigma: np.ndarray


@dataclass(frozen=True)
class _Reduced:
    """Whitened fault-to-residual maps ``Phi = Gamma N_H F`` (all faults side by side)."""

    basis: np.ndarray  # N_H (direct, d x (n+m)s) or N_O (structured, d x m s)
    gamma: np.ndarray  # (d, d) whitening Gamma
    nf: np.ndarray  # (d, p s): N_H F (direct) or N_O T_f (structured)
    phi: np.ndarray  # (d, p s): Gamma N_H F
    f_norms: np.ndarray  # (p,) ||F_i|| (or ||T_f,i||): the data producing N_H F_i
    scales: np.ndarray  # (p,) ||Gamma|| ||F_i||: the data producing Phi_i
    method: str
    images: dict[int, np.ndarray] = field(default_factory=dict)  # orthonormal bases of Im Phi_j


@dataclass(frozen=True)
class DiagnosabilityTable:
    """A paper-like diagnosability table (seed 002, Tables 1-4).

    Attributes
    ----------
    values : ndarray, (p, p + 1)
        Column 0: detectability of each fault; column ``1 + j``: isolability of the row
        fault from fault ``j``.
    method : str
        ``"kl"``, ``"directional"``, ``"probability"`` or ``"probability_index"``.
    fault_names : tuple of str
    options : dict
        The options behind the numbers (``kappa``, ``cosine``, ``alpha``, null-space path).
    text : str
        The table formatted like the paper's.
    """

    values: np.ndarray
    method: str
    fault_names: tuple[str, ...]
    options: dict = field(default_factory=dict)
    text: str = ""

    @property
    def detectability(self) -> np.ndarray:
        """Column ``FD`` (length p)."""
        return self.values[:, 0]

    @property
    def isolability(self) -> np.ndarray:
        """The ``p x p`` block ``FI(f_i, f_j)`` (row ``i``, column ``j``)."""
        return self.values[:, 1:]

    def __str__(self) -> str:
        return self.text


@dataclass(frozen=True)
class FaultApplicability:
    """Theorem 1 of seed 002 for one fault, with the exact rank facts beside it.

    Attributes
    ----------
    index, name
        The fault.
    rref_row_nonzeros : tuple of int
        Non-zeros in each non-zero row of ``rref(N_H F_i)``.
    theorem1 : bool
        The paper's criterion: every non-zero row has exactly one non-zero.
    rank : int
        ``rank(N_H F_i)`` (at most the window ``s``).
    window : int
        Number of columns of ``N_H F_i`` (the window length ``s``).
    undetectable_dim : int
        ``s - rank``: dimension of the profiles ``theta != 0`` with ``N_H F_i theta = 0``.
    theta_detectable : bool or None
        Whether the given profile has ``q_i != 0`` (``None`` when no profile was given).
    isolation_dof : int
        ``d - rank``: dimension of the left null space of ``[H F_i]``; the KL isolability of
        any fault from ``f_i`` is 0 when it is 0.
    """

    index: int
    name: str
    rref_row_nonzeros: tuple[int, ...]
    theorem1: bool
    rank: int
    window: int
    undetectable_dim: int
    theta_detectable: bool | None
    isolation_dof: int


@dataclass(frozen=True)
class ApplicabilityReport:
    """When the KL (distance-similarity) indices apply: Theorems 1-2 of seed 002.

    Attributes
    ----------
    faults : tuple of FaultApplicability
    outputs : int
        Number of outputs ``m``.
    residual_dim : int
        ``d = dim`` of the left null space of ``H``.
    theorem1 : bool
        Theorem 1 (paper's criterion) holds for every fault.
    theorem2 : bool
        Theorem 2: more than one output (``m > 1``).
    kl_detectability : bool
        The paper's verdict for KL detectability (Theorem 1).
    kl_isolability : bool
        The paper's verdict for KL isolability (Theorems 1 and 2).
    reasons : tuple of str
        One sentence per finding, including where the paper's criterion and the exact rank
        condition disagree.
    """

    faults: tuple[FaultApplicability, ...]
    outputs: int
    residual_dim: int
    theorem1: bool
    theorem2: bool
    kl_detectability: bool
    kl_isolability: bool
    reasons: tuple[str, ...]

    def __str__(self) -> str:
        lines = [
            f"Theorem 1 (rref rows with one non-zero): {'holds' if self.theorem1 else 'fails'}",
            f"Theorem 2 (more than one output, m = {self.outputs}): "
            f"{'holds' if self.theorem2 else 'fails'}",
            f"KL detectability applicable: {self.kl_detectability}; "
            f"KL isolability applicable: {self.kl_isolability}",
        ]
        lines += [f"  - {r}" for r in self.reasons]
        return "\n".join(lines)


# --------------------------------------------------------------------------- the model
class WindowModel:
    """Discrete plant with faults and noise, stacked over a window (seed 002, eqs. 1-3).

    Sizes follow seed 002: ``n`` states, ``m`` outputs, ``q`` known inputs, ``p`` scalar
    faults, ``l`` process and ``t`` measurement noises (:class:`~geomfdi.Plant` calls the
    outputs ``q`` and the inputs ``m``).

    Parameters
    ----------
    A : array_like, (n, n)
    B : array_like, (n, q) or None
        Known inputs (``None``: none).  Inputs do not affect any index; they enter ``L``.
    C : array_like, (m, n)
    D : array_like, (m, q), optional
        Feedthrough (zero by default).
    Bf : array_like, (n, p)
        State-side fault signatures, one column per scalar fault.
    Df : array_like, (m, p), optional
        Output-side fault signatures (zero by default).
    Bw : array_like, (n, l), optional
        Process-noise input matrix (identity by default, ``l = n``).
    Dv : array_like, (m, t), optional
        Measurement-noise matrix (identity by default, ``t = m``).
    Qw : float, array_like (l,) or (l, l)
        Process-noise covariance: a scalar (times ``I``), the variances, or the matrix.
        Must be symmetric positive semidefinite.
    Rv : float, array_like (t,) or (t, t)
        Measurement-noise covariance, same forms as ``Qw``.
    window : int, optional
        Window length ``s`` (default ``n + 1`` as in the paper).
    fault_names : sequence of str, optional
        Labels for tables and plots (default ``f1 ... fp``).
    nullspace : {"structured", "direct"}
        How ``N_H`` is obtained.  ``"direct"``: full SVD of the stacked ``H``
        (``(n+m)s x n(s+1)``).  ``"structured"`` (default): the left null space of ``H`` is
        ``{[G^T b; b] : b^T O_s = 0}`` with ``O_s`` the extended observability matrix, so
        only the ``m s x n`` matrix ``O_s`` is decomposed (see Notes).

    Notes
    -----
    *Stacking (eq. 2).*  Row block ``t`` of the state part of ``H`` is
    ``[... A -I ...]`` (``x(t+1) = A x(t) + ...``), row block ``t`` of the output part is
    ``[... C ...]``; ``F`` and ``E`` repeat ``Bf, Df`` and ``Bw, Dv`` block-diagonally
    (:meth:`stacked`).  ``rank H = n s + rank O_s`` so ``d = m s - rank O_s``.

    *Structured null space.*  Writing a left null vector of ``H`` as ``[a; b]`` (state and
    output rows), the column blocks of ``H`` give ``a_{s-1} = 0``,
    ``a_{t-1}^T = a_t^T A + b_t^T C`` and ``b^T O_s = 0``, so ``a_t^T = sum_{k>t} b_k^T C
    A^{k-t-1}``, i.e. ``[a; b] = [G^T; I] b`` with ``G`` the strictly lower block-Toeplitz
    matrix of ``C A^j``.  Then ``N F = N_O T_f`` and ``N E = N_O T_e`` with ``T_f``,
    ``T_e`` the block-Toeplitz Markov matrices of the fault and noise channels: the
    classical parity-space form.  The indices depend on ``N_H`` only through
    ``N_H^T (N_H E Sigma E^T N_H^T)^{-1} N_H``, which is the same for every basis of the
    left null space, so both paths give identical indices; the fault vectors ``q_i`` of the
    two paths differ by an orthogonal transformation of ``R^d``.  The structured path costs
    ``O((m s)^2 n)`` for the SVD of ``O_s``, ``O((m s)^2 (p + l) s)`` for the projected
    Toeplitz maps and ``O(d^3)`` for the whitening, instead of the ``O(((n+m) s)^3)`` SVD of
    ``H`` (``benchmarks/bench_diagnosability.py``).
    :meth:`left_null_basis` returns the orthonormal ``N_H`` of either path (the structured
    one orthonormalises ``[G^T; I] N_O^T`` by a thin QR).

    *Window.*  The paper's ``x_s`` runs from ``x(k-n)`` to ``x(k+1)`` (``s + 1`` states) and
    ``f_s``, ``e_s``, ``z_s`` from ``k - n`` to ``k`` (``s`` samples); the last state
    ``x(k+1)`` appears only in the last state equation, so ``Bf f(k)`` never reaches the
    residual (for model (23) the actuator faults reach it only through ``f(k-2)``).

    *Whitening.*  After projection, ``Gamma = (N_H E Sigma E^T N_H^T)^{-1/2}`` (symmetric
    square root), and ``q_i = Gamma N_H F_i theta`` (math.md §7).  A singular projected
    noise covariance raises :class:`~geomfdi.errors.RankDeficientError`.

    References
    ----------
    Li W.-B., Wang D.-Y., Liu C.-R., Quantitative evaluation of actual fault
    diagnosability for dynamic systems, Acta Automatica Sinica 41(3), 2015 (seed 002),
    eqs. (1)-(3).

    Examples
    --------
    Model (23) of seed 002 (Table 1, first row):

    >>> import geomfdi as gf
    >>> dm = gf.WindowModel([[1, 1], [-1, 1]], [[0], [1]], [[1, 0], [1, 0]],
    ...                     Bf=[[0, 0, 0, 0], [1, 1, 0, 0]], Df=[[0, 0, 1, 0], [0, 0, 0, 1]],
    ...                     Bw=[[0], [1]], Qw=0.1, Rv=[1, 0.5])
    >>> round(dm.kl_detectability(0, [1, 1, 1]), 4), round(dm.kl_isolability(0, 2, [1, 1, 1]), 4)
    (0.1613, 0.1087)
    """

    def __init__(
        self,
        A: Any,
        B: Any = None,
        C: Any = None,
        D: Any = None,
        *,
        Bf: Any,
        Df: Any = None,
        Bw: Any = None,
        Dv: Any = None,
        Qw: Any = None,
        Rv: Any = None,
        window: int | None = None,
        fault_names: Any = None,
        nullspace: NullSpaceMethod = "structured",
    ) -> None:
        self.A = as_matrix(A, "A", square=True)
        n = self.A.shape[0]
        if C is None:
            raise GeomFDIError("C: the output matrix is required", argument="C")
        self.C = as_matrix(C, "C", cols=n, vector_as="row")
        m = self.C.shape[0]
        self.B = np.zeros((n, 0)) if B is None else _as_channel(B, "B", n)
        nu = self.B.shape[1]
        if D is None:
            self.D = np.zeros((m, nu))
        elif nu == 0:
            self.D = as_matrix(D, "D", rows=m, cols=0, allow_empty=True)
        else:
            self.D = _as_channel(D, "D", m, nu)
        self.Bf = _as_channel(Bf, "Bf", n)
        p = self.Bf.shape[1]
        self.Df = np.zeros((m, p)) if Df is None else _as_channel(Df, "Df", m, p)
        self.Bw = np.eye(n) if Bw is None else _as_channel(Bw, "Bw", n)
        self.Dv = np.eye(m) if Dv is None else _as_channel(Dv, "Dv", m)
        if Qw is None:
            raise GeomFDIError("Qw: the process-noise covariance is required", argument="Qw")
        if Rv is None:
            raise GeomFDIError("Rv: the measurement-noise covariance is required", argument="Rv")
        self.Qw = _as_covariance(Qw, "Qw", self.Bw.shape[1])
        self.Rv = _as_covariance(Rv, "Rv", self.Dv.shape[1])
        self.window = n + 1 if window is None else as_int(window, "window", minimum=1)
        s = self.window
        check_allocation(s * s * m * (n + m + p), argument="window", what="stacked window model")
        if fault_names is None:
            self.fault_names = tuple(f"f{i + 1}" for i in range(p))
        else:
            names = tuple(str(x) for x in as_sequence_of(fault_names, "fault_names", object))
            as_labels(names, "fault_names")
            if len(names) != p:
                raise ShapeError(
                    f"fault_names: expected {p} names (one per column of Bf), got {len(names)}",
                    argument="fault_names",
                )
            self.fault_names = names
        if not isinstance(nullspace, str) or nullspace not in _NULLSPACE_METHODS:
            raise GeomFDIError(
                f"nullspace: must be one of {_NULLSPACE_METHODS}, got {nullspace!r}",
                argument="nullspace",
            )
        self.nullspace = nullspace
        for arr in (self.A, self.B, self.C, self.D, self.Bf, self.Df, self.Bw, self.Dv):
            arr.setflags(write=False)
        self.Qw.setflags(write=False)
        self.Rv.setflags(write=False)
        self._cache: dict[str, _Reduced] = {}
        self._rank_O: int | None = None

    # ------------------------------------------------------------------ sizes
    @property
    def n(self) -> int:
        """Number of states."""
        return self.A.shape[0]

    @property
    def m(self) -> int:
        """Number of outputs."""
        return self.C.shape[0]

    @property
    def p(self) -> int:
        """Number of (scalar) faults."""
        return self.Bf.shape[1]

    @property
    def residual_dim(self) -> int:
        """``d = m s - rank O_s``: the dimension of the left null space of ``H``."""
        if self._rank_O is None:
            self._observability_null()
        assert self._rank_O is not None
        return self.m * self.window - self._rank_O

    def __repr__(self) -> str:
        return (
            f"WindowModel(n={self.n}, m={self.m}, p={self.p}, window={self.window}, "
            f"nullspace={self.nullspace!r})"
        )

    # ------------------------------------------------------------------ stacking
    def stacked(self) -> StackedWindow:
        """The matrices ``L, H, F, E`` of eq. (2) and the covariance of ``e_s``."""
        n, m, s = self.n, self.m, self.window
        nu = self.B.shape[1]
        I_s = np.eye(s)
        H = np.zeros(((n + m) * s, n * (s + 1)))
        Hv = H[: n * s].reshape(s, n, s + 1, n)
        t = np.arange(s)
        Hv[t, :, t, :] = self.A
        Hv[t, :, t + 1, :] = -np.eye(n)
        H[n * s :].reshape(s, m, s + 1, n)[t, :, t, :] = self.C
        L = np.zeros(((n + m) * s, (m + nu) * s))
        L[: n * s, m * s :] = -np.kron(I_s, self.B)
        L[n * s :, : m * s] = np.eye(m * s)
        L[n * s :, m * s :] = -np.kron(I_s, self.D)
        F = np.vstack([np.kron(I_s, self.Bf), np.kron(I_s, self.Df)])
        l, tv = self.Bw.shape[1], self.Dv.shape[1]
        E = np.zeros(((n + m) * s, (l + tv) * s))
        E[: n * s, : l * s] = np.kron(I_s, self.Bw)
        E[n * s :, l * s :] = np.kron(I_s, self.Dv)
        Sigma = np.zeros(((l + tv) * s, (l + tv) * s))
        Sigma[: l * s, : l * s] = np.kron(I_s, self.Qw)
        Sigma[l * s :, l * s :] = np.kron(I_s, self.Rv)
        return StackedWindow(L=L, H=H, F=F, E=E, Sigma=Sigma)

    def observability_matrix(self) -> np.ndarray:
        """Extended observability matrix ``O_s = [C; C A; ...; C A^{s-1}]``."""
        return self._markov(np.eye(self.n)).reshape(self.m * self.window, self.n)

    def _markov(self, X: np.ndarray) -> np.ndarray:
        """``[C X, C A X, ..., C A^{s-1} X]`` as an ``(s, m, cols)`` array."""
        out = np.empty((self.window, self.m, X.shape[1]))
        Y = X
        for j in range(self.window):
            out[j] = self.C @ Y
            if j + 1 < self.window:
                Y = self.A @ Y
        return out

    def _toeplitz(self, Bx: np.ndarray, Dx: np.ndarray) -> np.ndarray:
        """Block-Toeplitz map of a channel ``(Bx, Dx)`` over the window: ``D, CB, CAB, ...``."""
        s = self.window
        markov = np.zeros((s, self.m, Bx.shape[1]))
        markov[0] = Dx
        if s > 1:
            markov[1:] = self._markov(Bx)[: s - 1]
        return _block_toeplitz(markov)

    def _observability_null(self) -> np.ndarray:
        O = self.observability_matrix()
        N_O, rank = _left_null_rows(O, "extended observability matrix O_s")
        self._rank_O = rank
        if N_O.shape[0] == 0:
            raise DesignError(
                f"window: a window of {self.window} samples gives no parity relation "
                f"(m s = {self.m * self.window} <= rank O_s = {rank}); lengthen the window",
                argument="window",
            )
        return N_O

    def left_null_basis(self, method: NullSpaceMethod | None = None) -> np.ndarray:
        """Orthonormal basis ``N_H`` (rows) of the left null space of the stacked ``H``.

        Parameters
        ----------
        method : {"structured", "direct"}, optional
            Default: the model's ``nullspace``.  The two bases differ by a rotation; the
            projector ``N_H^T N_H`` is the same.

        Returns
        -------
        ndarray, (d, (n + m) s)
        """
        method = self._method(method)
        if method == "direct":
            N, rank = _left_null_rows(self.stacked().H, "stacked H")
            self._rank_O = rank - self.n * self.window
            if N.shape[0] == 0:
                self._observability_null()  # raises the DesignError
            return N
        n, m, s = self.n, self.m, self.window
        N_O = self._observability_null()
        markov = np.zeros((s, m, n))
        if s > 1:
            markov[1:] = self._markov(np.eye(n))[: s - 1]
        G = _block_toeplitz(markov)  # (m s, n s), block (k, t) = C A^{k-t-1}
        W = np.vstack([G.T @ N_O.T, N_O.T])  # columns span the left null space
        Q, _ = np.linalg.qr(W)
        return Q.T

    def _method(self, method: str | None) -> str:
        if method is None:
            return self.nullspace
        if not isinstance(method, str) or method not in _NULLSPACE_METHODS:
            raise GeomFDIError(
                f"method: must be one of {_NULLSPACE_METHODS}, got {method!r}", argument="method"
            )
        return method

    def _reduced(self, method: str | None = None) -> _Reduced:
        method = self._method(method)
        if method in self._cache:
            return self._cache[method]
        p, s = self.p, self.window
        if method == "direct":
            N = self.left_null_basis("direct")
            Nx, Ny = N[:, : self.n * s], N[:, self.n * s :]
            NF = _times_kron(Nx, self.Bf) + _times_kron(Ny, self.Df)
            NW, NV = _times_kron(Nx, self.Bw), _times_kron(Ny, self.Dv)
            # ||F_i||_2: the columns of F_i are orthogonal, each of norm ||[Bf_i; Df_i]||
            f_norms = np.hypot(np.linalg.norm(self.Bf, axis=0), np.linalg.norm(self.Df, axis=0))
        else:
            N_O = self._observability_null()
            Tf = self._toeplitz(self.Bf, self.Df)
            NF = N_O @ Tf
            NW = N_O @ self._toeplitz(self.Bw, np.zeros((self.m, self.Bw.shape[1])))
            NV = _times_kron(N_O, self.Dv)
            f_norms = np.array([np.linalg.norm(Tf[:, i::p], 2) for i in range(p)])
        M = _times_kron(NW, self.Qw) @ NW.T + _times_kron(NV, self.Rv) @ NV.T
        Gamma = _sym_inv_sqrt(M, f"{method} path")
        red = _Reduced(
            basis=N if method == "direct" else N_O,
            gamma=Gamma,
            nf=NF,
            phi=Gamma @ NF,
            f_norms=f_norms,
            scales=float(np.linalg.norm(Gamma, 2)) * f_norms,
            method=method,
        )
        self._cache[method] = red
        return red

    def residual_generator(self, *, method: NullSpaceMethod | None = None) -> np.ndarray:
        """The whitened parity residual over the window, ``R = Gamma N_H L`` (eq. 3).

        ``r = R z_s`` with ``z_s = [y(k-s+1); ...; y(k); u(k-s+1); ...; u(k)]`` does not
        depend on the states; without fault ``r ~ N(0, I_d)`` and with fault ``f_i`` of
        profile ``theta``, ``r ~ N(q_i, I_d)`` in the same basis as :meth:`fault_vector`.

        Returns
        -------
        ndarray, (d, (m + q) s)
        """
        red = self._reduced(method)
        if red.method == "direct":
            return red.gamma @ (red.basis @ self.stacked().L)
        Tu = self._toeplitz(self.B, self.D)
        return red.gamma @ np.hstack([red.basis, -(red.basis @ Tu)])

    # ------------------------------------------------------------------ fault vectors
    def _fault(self, i: Any, name: str = "i") -> int:
        return as_index(i, name, self.p)

    def _theta(self, theta: Any, name: str = "theta") -> np.ndarray:
        return as_vector(theta, name, length=self.window)

    def fault_matrix(self, i: int, *, method: NullSpaceMethod | None = None) -> np.ndarray:
        """``Phi_i = Gamma N_H F_i`` (``d x s``): whitened map from the profile of ``f_i``.

        Defined up to a left orthogonal factor (the choice of basis ``N_H``).
        """
        i = self._fault(i)
        return self._reduced(method).phi[:, i :: self.p].copy()

    def fault_vector(
        self, i: int, theta: Any, *, method: NullSpaceMethod | None = None
    ) -> np.ndarray:
        """``q_i = Gamma N_H F_i theta`` for the profile ``theta`` (length ``window``)."""
        i = self._fault(i)
        theta = self._theta(theta)
        return self._reduced(method).phi[:, i :: self.p] @ theta

    def _q(self, i: int, theta: np.ndarray, method: str | None) -> tuple[np.ndarray, float]:
        red = self._reduced(method)
        q = red.phi[:, i :: self.p] @ theta
        zero_tol = get_rtol(q.size) * float(red.scales[i]) * float(np.linalg.norm(theta))
        if np.linalg.norm(q) <= zero_tol:  # rounding level: the profile is undetectable
            q = np.zeros_like(q)
        return q, zero_tol

    def _complement_residual(
        self, q: np.ndarray, j: int, method: str | None, tol: float
    ) -> tuple[np.ndarray, int]:
        """``N_{Phi_j} q`` (component outside ``Im Phi_j``; zero below ``tol``) and
        ``d - rank Phi_j``."""
        red = self._reduced(method)
        Ur = red.images.get(j)
        if Ur is None:
            Phi = red.phi[:, j :: self.p]
            U, sv, _ = np.linalg.svd(Phi, full_matrices=False)
            r = rank_decision(
                sv, float(red.scales[j]), Phi.shape[0], what=f"image of fault {self.fault_names[j]}"
            ).rank
            Ur = red.images[j] = U[:, :r]
        res = q - Ur @ (Ur.T @ q)
        if np.linalg.norm(res) <= tol:
            res = np.zeros_like(res)
        return res, q.size - Ur.shape[1]

    # ------------------------------------------------------------------ KL indices
    def kl_detectability(
        self, i: int, theta: Any, *, method: NullSpaceMethod | None = None
    ) -> float:
        """KL detectability ``FD(f_i) = 1/2 ||q_i||^2`` (seed 002, eq. 8, upper).

        Parameters
        ----------
        i : int
            Fault index (0-based column of ``Bf``/``Df``).
        theta : array_like, (window,)
            Profile of ``f_i`` over the window (``f_si`` of the paper).
        method : {"structured", "direct"}, optional
            Null-space path (default: the model's).

        Returns
        -------
        float
            ``min KL(p_i, p_0)``: the divergence between the residual distributions with and
            without the fault.  0 exactly when the profile is undetectable.

        Notes
        -----
        Eriksson-Frisk-Krysander (2013) convention: the residual is whitened after the
        projection, ``q_i = Gamma N_H F_i theta`` (math.md §7).  Reproduces Table 1.
        """
        i = self._fault(i)
        q, _ = self._q(i, self._theta(theta), method)
        return 0.5 * float(q @ q)

    def kl_isolability(
        self, i: int, j: int, theta: Any, *, method: NullSpaceMethod | None = None
    ) -> float:
        """KL isolability ``FI(f_i, f_j) = 1/2 ||N_{Gamma N_H F_j} q_i||^2`` (eq. 8, lower).

        Parameters
        ----------
        i, j : int
            The fault present (``i``) and the fault it must be told from (``j``).
        theta : array_like, (window,)
            Profile of ``f_i``.  The minimum runs over all profiles of ``f_j``.

        Returns
        -------
        float
            ``min over theta_j of KL(p_i, p_j(theta_j))``: half the squared distance from
            ``q_i`` to the image of ``Gamma N_H F_j``.  Not symmetric in ``(i, j)``.

        Notes
        -----
        The paper writes ``N_[H F_j] F_i f_si`` without whitening; the whitened form here is
        the one of Eriksson-Frisk-Krysander (2013) and reproduces Table 1 exactly.  The
        projection uses the rank of ``Gamma N_H F_j`` decided by :mod:`geomfdi.tolerance`.
        """
        i = self._fault(i)
        j = self._fault(j, "j")
        q, tol = self._q(i, self._theta(theta), method)
        res, _ = self._complement_residual(q, j, method, tol)
        return 0.5 * float(res @ res)

    # ------------------------------------------------------------------ directional
    def directional_detectability(
        self, i: int, theta: Any, *, method: NullSpaceMethod | None = None
    ) -> float:
        """Directional detectability ``FD(f_i) = 1/(p(q_i) + 1)`` (seed 002, eq. 17).

        ``p`` is the ``N(0, I_d)`` density, ``p(q) = (2 pi)^{-d/2} exp(-||q||^2 / 2)``.

        Returns
        -------
        float
            In ``(0, 1)``; reproduces the FD columns of Tables 2-4.

        Notes
        -----
        **Flaw** (math.md §7): an undetectable fault (``q_i = 0``) gets
        ``1 / ((2 pi)^{-d/2} + 1)`` (0.7148 for ``d = 1``, Table 3), not 0, and every index
        tends to 1 as ``d`` grows whatever the fault.  Use
        :meth:`probabilistic_detectability` for an index that is 0 exactly when the fault
        is undetectable.
        """
        i = self._fault(i)
        q, _ = self._q(i, self._theta(theta), method)
        d = q.size
        log_p = -0.5 * d * math.log(2.0 * math.pi) - 0.5 * float(q @ q)
        return 1.0 / (math.exp(log_p) + 1.0)

    def directional_isolability(
        self,
        i: int,
        j: int,
        theta: Any,
        kappa: float = 3.0,
        *,
        theta_j: Any = None,
        cosine: CosineConvention = "absolute",
        method: NullSpaceMethod | None = None,
    ) -> float:
        """Directional isolability ``FI(f_i, f_j) = 1/(||q_i||_c + 1)`` (seed 002, eq. 22).

        Parameters
        ----------
        i, j : int
            The two faults.
        theta : array_like, (window,)
            Profile of ``f_i``.
        kappa : float
            Norm of the worst-case noise in eq. (21) (3: a 3-sigma noise).
        theta_j : array_like, optional
            Profile of ``f_j`` (default: ``theta``, as in the paper's tables).
        cosine : {"absolute", "signed"}
            ``"absolute"``: ``c = |n_i . n_j|`` (the harder of the two cases of eq. 21);
            reproduces Table 2.  ``"signed"``: ``c = n_i . n_j`` (the first case of eq. 21
            with the signed cosine), needed for Table 4's 0.25 where the two fault vectors
            point in opposite directions (``c = -1``).
        method : {"structured", "direct"}, optional

        Returns
        -------
        float
            ``1 / (kappa sqrt(2 / (1 - c)) + 1)``: eq. (21) evaluated at the noise of norm
            ``kappa`` along ``n_j - n_i``, ``||q_i||_c = kappa ||n_j - n_i|| / (1 - c)``.
            0 when the vectors are collinear (``c = 1``) or when either fault vector is
            zero (an undetectable fault cannot be isolated; Table 3).

        Notes
        -----
        Symmetric in ``(i, j)`` when both use the same profile.  ``1 - c`` is computed as the
        squared smaller singular value of ``[n_i, n_j]`` (and ``1 + |c|`` as the larger one)
        to keep nearly collinear pairs accurate; collinearity is a rank decision of
        :mod:`geomfdi.tolerance`.
        """
        i = self._fault(i)
        j = self._fault(j, "j")
        kappa = float(as_positive(kappa, "kappa"))
        if not isinstance(cosine, str) or cosine not in _COSINES:
            raise GeomFDIError(
                f"cosine: must be one of {_COSINES}, got {cosine!r}", argument="cosine"
            )
        theta = self._theta(theta)
        theta_j = theta if theta_j is None else self._theta(theta_j, "theta_j")
        qi, tol_i = self._q(i, theta, method)
        qj, tol_j = self._q(j, theta_j, method)
        ni, nj = float(np.linalg.norm(qi)), float(np.linalg.norm(qj))
        if ni <= tol_i or nj <= tol_j:
            return 0.0
        pair = (qi / ni, qj / nj) if i <= j else (qj / nj, qi / ni)  # exactly symmetric
        one_minus_c = _one_minus_cosine(*pair, cosine)
        if one_minus_c == 0.0:
            return 0.0
        return 1.0 / (kappa * math.sqrt(2.0 / one_minus_c) + 1.0)

    # ------------------------------------------------------------------ probabilities
    def detection_probability(
        self, i: int, theta: Any, alpha: float = 0.01, *, method: NullSpaceMethod | None = None
    ) -> float:
        """Detection probability ``P_D = 1 - F_{chi2_d(||q_i||^2)}(chi2_{d,1-alpha})``.

        The test is ``||r||^2 > chi2_{d,1-alpha}`` on the whitened residual ``r = Gamma N_H L
        z_s ~ N(q_i, I_d)``; it has false-alarm rate ``alpha`` and, with the fault, a
        non-central chi-square statistic with ``d`` degrees of freedom and non-centrality
        ``||q_i||^2 = 2 FD_KL``.

        Returns
        -------
        float
            In ``[alpha, 1)``; equals ``alpha`` for an undetectable fault.
        """
        i = self._fault(i)
        alpha = as_probability(alpha, "alpha")
        q, _ = self._q(i, self._theta(theta), method)
        return _chi2_power(q.size, float(q @ q), alpha)

    def isolation_probability(
        self,
        i: int,
        j: int,
        theta: Any,
        alpha: float = 0.01,
        *,
        method: NullSpaceMethod | None = None,
    ) -> float:
        """Probability of rejecting "only ``f_j`` (any profile) or no fault" when ``f_i`` acts.

        The test projects the whitened residual on the orthogonal complement of
        ``Im(Gamma N_H F_j)`` (dimension ``d_j = d - rank Gamma N_H F_j``) and rejects when
        ``||N_{Gamma N_H F_j} r||^2 > chi2_{d_j, 1-alpha}``.  Under ``f_j`` with any profile
        the statistic is central ``chi2_{d_j}`` (false-isolation rate exactly ``alpha``);
        under ``f_i`` with profile ``theta`` it is non-central with
        ``lambda = ||N_{Gamma N_H F_j} q_i||^2 = 2 FI_KL(f_i, f_j)``.

        Returns
        -------
        float
            ``1 - F_{chi2_{d_j}(lambda)}(chi2_{d_j,1-alpha})``; ``alpha`` when
            ``lambda = 0`` and when ``d_j = 0`` (no test exists; the randomised level-alpha
            test is the best one).
        """
        i = self._fault(i)
        j = self._fault(j, "j")
        alpha = as_probability(alpha, "alpha")
        q, tol = self._q(i, self._theta(theta), method)
        res, dof = self._complement_residual(q, j, method, tol)
        return _chi2_power(dof, float(res @ res), alpha)

    def probabilistic_detectability(
        self, i: int, theta: Any, alpha: float = 0.01, *, method: NullSpaceMethod | None = None
    ) -> float:
        """``(P_D - alpha) / (1 - alpha)``: 0 exactly for an undetectable fault, -> 1 as
        ``||q_i||`` grows (see :meth:`detection_probability`)."""
        alpha = as_probability(alpha, "alpha")
        pd = self.detection_probability(i, theta, alpha, method=method)
        return max(pd - alpha, 0.0) / (1.0 - alpha)

    def probabilistic_isolability(
        self,
        i: int,
        j: int,
        theta: Any,
        alpha: float = 0.01,
        *,
        method: NullSpaceMethod | None = None,
    ) -> float:
        """``(P_I - alpha) / (1 - alpha)`` of :meth:`isolation_probability`; 0 when ``f_i``
        cannot be told from ``f_j``."""
        alpha = as_probability(alpha, "alpha")
        pi = self.isolation_probability(i, j, theta, alpha, method=method)
        return max(pi - alpha, 0.0) / (1.0 - alpha)

    # ------------------------------------------------------------------ tables, reports
    def table(self, theta: Any, method: TableMethod = "kl", **options: Any) -> DiagnosabilityTable:
        """Shortcut for :func:`diagnosability_table` on this model."""
        return diagnosability_table(self, theta, method, **options)

    def applicability(self, theta: Any = None) -> ApplicabilityReport:
        """Theorems 1-2 of seed 002 as a report (when the KL indices apply).

        Parameters
        ----------
        theta : array_like, (window,) or (p, window), optional
            Fault profile(s); when given, the report says whether each is detectable.

        Returns
        -------
        ApplicabilityReport

        Notes
        -----
        Theorem 1 (paper): KL detectability applies when every non-zero row of
        ``rref(N_H F_i)`` has exactly one non-zero.  The rref depends only on the row space
        of ``N_H F_i``, hence not on the basis ``N_H``.  The exact condition for "every
        non-zero profile is detectable" is ``rank N_H F_i = s``; the paper's criterion also
        holds when ``N_H F_i`` has zero columns (a fault whose last samples do not reach the
        window's outputs), in which case profiles supported on those samples are
        undetectable: the report says so.  Theorem 2 (paper): KL isolability needs ``m > 1``;
        the exact quantity is ``d - rank N_H F_j``, the dimension of the left null space of
        ``[H F_j]`` beyond ``H``'s, which is reported per fault.
        """
        p, s = self.p, self.window
        thetas = None if theta is None else _profiles(theta, p, s)
        red = self._reduced()
        d = red.nf.shape[0]
        faults = []
        reasons: list[str] = []
        for i in range(p):
            X = red.nf[:, i::p]
            _, sv, Vt = np.linalg.svd(X, full_matrices=False)
            dec = rank_decision(
                sv, float(red.f_norms[i]), d, what=f"N_H F_i of fault {self.fault_names[i]}"
            )
            # rref depends only on the row space: eliminate on an orthonormal basis of it
            R = _rref(Vt[: dec.rank], get_rtol(s))
            counts = tuple(int(c) for c in np.count_nonzero(R, axis=1) if c > 0)
            thm1 = all(c == 1 for c in counts)
            det = None
            if thetas is not None:
                q, tol = self._q(i, thetas[i], None)
                det = bool(np.linalg.norm(q) > tol)
            fa = FaultApplicability(
                index=i,
                name=self.fault_names[i],
                rref_row_nonzeros=counts,
                theorem1=thm1,
                rank=dec.rank,
                window=s,
                undetectable_dim=s - dec.rank,
                theta_detectable=det,
                isolation_dof=d - dec.rank,
            )
            faults.append(fa)
            nm = fa.name
            if not thm1:
                reasons.append(
                    f"{nm}: Theorem 1 fails, rref(N_H F_i) has rows with {list(counts)} "
                    "non-zeros; some non-zero profiles are undetectable"
                )
            elif fa.undetectable_dim > 0:
                reasons.append(
                    f"{nm}: Theorem 1 holds, but rank N_H F_i = {fa.rank} < s = {s}: "
                    f"profiles in a {fa.undetectable_dim}-dimensional subspace (zero columns of "
                    "N_H F_i) are still undetectable"
                )
            if det is False:
                reasons.append(f"{nm}: the given profile is undetectable (q_i = 0)")
            if fa.isolation_dof == 0:
                reasons.append(
                    f"{nm}: Gamma N_H F_i spans the whole residual space (d = {d}); no fault "
                    f"can be KL-isolated from {nm}"
                )
        thm1_all = all(f.theorem1 for f in faults)
        thm2 = self.m > 1
        if not thm2:
            reasons.append(f"Theorem 2 fails: one output (m = {self.m}); KL isolability is 0")
        return ApplicabilityReport(
            faults=tuple(faults),
            outputs=self.m,
            residual_dim=d,
            theorem1=thm1_all,
            theorem2=thm2,
            kl_detectability=thm1_all,
            kl_isolability=thm1_all and thm2,
            reasons=tuple(reasons),
        )


def _one_minus_cosine(ni: np.ndarray, nj: np.ndarray, cosine: str) -> float:
    """``1 - c`` for unit vectors, ``c = |ni.nj|`` or ``ni.nj``; 0 when collinear."""
    sv = np.linalg.svd(np.column_stack([ni, nj]), compute_uv=False)
    dec = rank_decision(sv, 1.0, ni.size, what="fault directions", warn=False)
    small = 0.0 if dec.rank < 2 else float(sv[1]) ** 2  # 1 - |c|
    large = float(sv[0]) ** 2  # 1 + |c|
    if cosine == "signed" and float(ni @ nj) < 0.0:
        return large
    return small


def _profiles(theta: Any, p: int, s: int, name: str = "theta") -> np.ndarray:
    """One profile for all faults (length ``s``) or one per fault (``p x s``)."""
    arr = as_real_array(theta, name)
    if arr.ndim == 2 and arr.shape != (1, s) and arr.shape != (s, 1):
        if arr.shape != (p, s):
            raise ShapeError(
                f"{name}: expected length {s} or shape ({p}, {s}), got shape {arr.shape}",
                argument=name,
            )
        return arr
    vec = as_vector(arr, name, length=s)
    return np.tile(vec, (p, 1))


# --------------------------------------------------------------------------- tables
def diagnosability_table(
    model: WindowModel,
    theta: Any,
    method: TableMethod = "kl",
    *,
    kappa: float = 3.0,
    cosine: CosineConvention = "absolute",
    alpha: float = 0.01,
    nullspace: NullSpaceMethod | None = None,
    digits: int = 4,
) -> DiagnosabilityTable:
    """The paper's table: each fault's detectability and its isolability from every fault.

    Parameters
    ----------
    model : WindowModel
    theta : array_like, (window,) or (p, window)
        One profile for every fault (the paper's tables) or one per fault.
    method : {"kl", "directional", "probability", "probability_index"}
        ``"kl"``: :meth:`WindowModel.kl_detectability` / ``kl_isolability`` (Table 1).
        ``"directional"``: eqs. (17), (22) with ``kappa`` and ``cosine`` (Tables 2-4;
        Table 2 with ``cosine="absolute"``, Table 4 with ``cosine="signed"``).
        ``"probability"``: detection / isolation probabilities at false-alarm rate ``alpha``.
        ``"probability_index"``: the same rescaled to ``(P - alpha) / (1 - alpha)``.
    kappa, cosine
        Options of the directional method.
    alpha : float
        False-alarm rate of the probability methods.
    nullspace : {"structured", "direct"}, optional
        Null-space path (default: the model's).
    digits : int
        Decimals in the formatted text.

    Returns
    -------
    DiagnosabilityTable
        ``values[i, 0] = FD(f_i)``, ``values[i, 1 + j] = FI(f_i, f_j)``, with the profile of
        each row's fault (for the directional method the column fault uses its own profile).

    References
    ----------
    Seed 002, Tables 1-4; Eriksson, Frisk, Krysander, Automatica 49(6), 2013.
    """
    if not isinstance(model, WindowModel):
        raise GeomFDIError(
            f"model: expected a WindowModel, got {type(model).__name__}", argument="model"
        )
    if not isinstance(method, str) or method not in _TABLE_METHODS:
        raise GeomFDIError(
            f"method: must be one of {_TABLE_METHODS}, got {method!r}", argument="method"
        )
    p, s = model.p, model.window
    thetas = _profiles(theta, p, s)
    ns = model._method(nullspace)
    digits = as_int(digits, "digits", minimum=0, maximum=30)
    kappa, alpha = as_positive(kappa, "kappa"), as_probability(alpha, "alpha")
    if not isinstance(cosine, str) or cosine not in _COSINES:
        raise GeomFDIError(
            f"cosine: must be one of {_COSINES}, got {cosine!r:.40}", argument="cosine"
        )
    vals = np.zeros((p, p + 1))
    opts: dict[str, Any] = {"nullspace": ns}
    if method == "kl":
        for i in range(p):
            vals[i, 0] = model.kl_detectability(i, thetas[i], method=ns)
            for j in range(p):
                vals[i, 1 + j] = model.kl_isolability(i, j, thetas[i], method=ns)
    elif method == "directional":
        opts.update(kappa=float(as_positive(kappa, "kappa")), cosine=cosine)
        for i in range(p):
            vals[i, 0] = model.directional_detectability(i, thetas[i], method=ns)
            for j in range(p):
                vals[i, 1 + j] = model.directional_isolability(
                    i, j, thetas[i], kappa, theta_j=thetas[j], cosine=cosine, method=ns
                )
    else:
        alpha = as_probability(alpha, "alpha")
        opts["alpha"] = alpha
        det = (
            model.detection_probability
            if method == "probability"
            else model.probabilistic_detectability
        )
        iso = (
            model.isolation_probability
            if method == "probability"
            else model.probabilistic_isolability
        )
        for i in range(p):
            vals[i, 0] = det(i, thetas[i], alpha, method=ns)
            for j in range(p):
                vals[i, 1 + j] = iso(i, j, thetas[i], alpha, method=ns)
    text = _format_table(vals, model.fault_names, digits)
    return DiagnosabilityTable(
        values=vals, method=method, fault_names=model.fault_names, options=opts, text=text
    )


def _format_table(vals: np.ndarray, names: tuple[str, ...], digits: int) -> str:
    width = max(digits + 4, *(len(nm) + 1 for nm in names))
    head = " " * width + "".join(f"{h:>{width}}" for h in ("FD", *names))
    rows = [
        f"{nm:<{width}}" + "".join(f"{v:>{width}.{digits}f}" for v in row)
        for nm, row in zip(names, vals, strict=True)
    ]
    return "\n".join([head, *rows])


# --------------------------------------------------------------------------- plotting
def plot_isolability(
    table: DiagnosabilityTable,
    *,
    ax: Any = None,
    cmap: str = "viridis",
    annotate: bool = True,
    title: str | None = None,
) -> Any:
    """Heat map of the isolability block ``FI(f_i, f_j)`` of a table.

    Parameters
    ----------
    table : DiagnosabilityTable
    ax : matplotlib Axes, optional
        Draw into it (default: a new figure).
    cmap : str
        Colour map.
    annotate : bool
        Write each value in its cell.
    title : str, optional
        Default: the method and its options.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if not isinstance(table, DiagnosabilityTable):
        raise GeomFDIError(
            f"table: expected a DiagnosabilityTable, got {type(table).__name__}",
            argument="table",
        )
    import matplotlib
    import matplotlib.pyplot as plt

    annotate = as_bool(annotate, "annotate")
    try:
        cmap = matplotlib.colormaps[cmap] if isinstance(cmap, str) else cmap
        if not isinstance(cmap, matplotlib.colors.Colormap):
            raise TypeError(type(cmap).__name__)
    except (KeyError, TypeError) as exc:
        raise GeomFDIError(
            f"cmap: must be a matplotlib colormap or its name, got {cmap!r:.40}", argument="cmap"
        ) from exc

    fi = table.isolability
    p = fi.shape[0]
    if ax is None:
        fig, ax = plt.subplots(figsize=(1.2 * p + 2.5, 1.0 * p + 1.8))
    else:
        fig = ax.figure
    top = float(np.max(fi)) if fi.size else 0.0
    im = ax.imshow(fi, cmap=cmap, vmin=0.0, vmax=top if top > 0 else 1.0)
    fig.colorbar(im, ax=ax, label="FI(row, column)")
    ax.set_xticks(range(p), labels=list(table.fault_names))
    ax.set_yticks(range(p), labels=list(table.fault_names))
    ax.set_xlabel("isolated from")
    ax.set_ylabel("fault present")
    if annotate:
        for (r, c), v in np.ndenumerate(fi):
            color = "black" if top > 0 and v > 0.6 * top else "white"
            ax.text(c, r, f"{v:.4g}", ha="center", va="center", color=color, fontsize=9)
    if title is None:
        extra = ", ".join(f"{k}={v}" for k, v in table.options.items() if k != "nullspace")
        title = f"isolability ({table.method}{', ' + extra if extra else ''})"
    ax.set_title(title)
    return fig
