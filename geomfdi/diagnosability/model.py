"""The window model :class:`WindowModel` (a small object over plain functions).

A discrete plant with additive faults and Gaussian noise (Li, Wang & Liu 2015, eq. 1)::

    x(k+1) = A x(k) + B u(k) + Bf f(k) + Bw w(k)
    y(k)   = C x(k) + D u(k) + Df f(k) + Dv v(k),     w ~ N(0, Qw),  v ~ N(0, Rv)

is stacked over a window of ``s`` samples (:mod:`~geomfdi.diagnosability.stacking`); the
indices are in :mod:`~geomfdi.diagnosability.indices`, the tables in
:mod:`~geomfdi.diagnosability.tables`, the Theorems 1-2 report in
:mod:`~geomfdi.diagnosability.applicability`.  See the user guide, *Theory:
diagnosability* (``docs/theory/diagnosability.md``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi._threads import limit_blas_threads
from geomfdi._validation import (
    as_int,
    as_labels,
    as_matrix,
    as_sequence_of,
)
from geomfdi.diagnosability import applicability as _applicability
from geomfdi.diagnosability import indices as _indices
from geomfdi.diagnosability import stacking as _stacking
from geomfdi.diagnosability import tables as _tables
from geomfdi.diagnosability._linalg import _as_channel, _as_covariance
from geomfdi.diagnosability._records import (
    CosineConvention,
    NullSpaceMethod,
    TableMethod,
    WindowData,
    WindowSizes,
    nullspace_choice,
)
from geomfdi.diagnosability.results import (
    ApplicabilityReport,
    DiagnosabilityTable,
    StackedWindow,
)
from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.limits import check_allocation

__all__ = ["WindowModel"]


class WindowModel(WindowSizes):
    """Discrete plant with faults and noise, stacked over a window (Li, Wang & Liu 2015).

    Sizes follow Li, Wang & Liu (2015), eqs. 1-3: ``n`` states, ``m`` outputs, ``q`` known
    inputs, ``p`` scalar faults, ``l`` process and ``t`` measurement noises
    (:class:`~geomfdi.Plant` calls the outputs ``q`` and the inputs ``m``).

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
    Dw : array_like, (m, l), optional
        Feedthrough of the process noise to the outputs (zero by default): a noise that
        enters both the state and the output, e.g. the measurement noise of a residual
        generator driven by the plant's outputs (:func:`bank_diagnosability`).
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
    square root), and ``q_i = Gamma N_H F_i theta`` .  A singular projected
    noise covariance raises :class:`~geomfdi.errors.RankDeficientError`.

    References
    ----------
    Li W.-B., Wang D.-Y., Liu C.-R., Quantitative evaluation of actual fault
    diagnosability for dynamic systems, Acta Automatica Sinica 41(3), 2015 (Li, Wang & Liu (2015)),
    eqs. (1)-(3).

    Examples
    --------
    Model (23) of Li, Wang & Liu (2015) (Table 1, first row):

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
        Dw: Any = None,
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
        lw = self.Bw.shape[1]
        self.Dw = np.zeros((m, lw)) if Dw is None else _as_channel(Dw, "Dw", m, lw)
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
        self.nullspace = nullspace_choice(nullspace, "nullspace")
        for arr in (self.A, self.B, self.C, self.D, self.Bf, self.Df, self.Bw, self.Dv, self.Dw):
            arr.setflags(write=False)
        self.Qw.setflags(write=False)
        self.Rv.setflags(write=False)
        self._data = WindowData(
            A=self.A,
            B=self.B,
            C=self.C,
            D=self.D,
            Bf=self.Bf,
            Df=self.Df,
            Bw=self.Bw,
            Dv=self.Dv,
            Dw=self.Dw,
            Qw=self.Qw,
            Rv=self.Rv,
            window=self.window,
            fault_names=self.fault_names,
            nullspace=self.nullspace,
        )

    @property
    def data(self) -> WindowData:
        """The model's matrices as a frozen ``WindowData`` record: what the stacking,
        index and table functions take."""
        return self._data

    # ------------------------------------------------------------------ sizes
    @property
    def residual_dim(self) -> int:
        """``d = m s - rank O_s``: the dimension of the left null space of ``H``."""
        if "rank_O" not in self._data.cache:
            _stacking._observability_null(self._data)
        return self.m * self.window - self._data.cache["rank_O"]

    def __repr__(self) -> str:
        return (
            f"WindowModel(n={self.n}, m={self.m}, p={self.p}, window={self.window}, "
            f"nullspace={self.nullspace!r})"
        )

    # stacking, indices and reports: the model passes its record to the module functions
    def stacked(self) -> StackedWindow:
        """The matrices ``L, H, F, E`` of eq. (2); see :func:`.stacking.stacked`."""
        return _stacking.stacked(self._data)

    def observability_matrix(self) -> np.ndarray:
        """Extended observability matrix ``O_s = [C; C A; ...; C A^{s-1}]``."""
        return _stacking.observability_matrix(self._data)

    def left_null_basis(self, method: NullSpaceMethod | None = None) -> np.ndarray:
        """Orthonormal ``N_H`` (rows); see :func:`.stacking.left_null_basis`."""
        return _stacking.left_null_basis(self._data, method)

    def residual_generator(self, *, method: NullSpaceMethod | None = None) -> np.ndarray:
        """Whitened parity residual ``R = Gamma N_H L`` (:func:`.stacking.residual_generator`)."""
        return _stacking.residual_generator(self._data, method=method)

    def fault_matrix(self, i: int, *, method: NullSpaceMethod | None = None) -> np.ndarray:
        """``Phi_i = Gamma N_H F_i`` (d x s); see :func:`.stacking.fault_matrix`."""
        return _stacking.fault_matrix(self._data, i, method=method)

    def fault_vector(
        self, i: int, theta: Any, *, method: NullSpaceMethod | None = None
    ) -> np.ndarray:
        """``q_i = Gamma N_H F_i theta``; see :func:`.stacking.fault_vector`."""
        return _stacking.fault_vector(self._data, i, theta, method=method)

    def kl_detectability(
        self, i: int, theta: Any, *, method: NullSpaceMethod | None = None
    ) -> float:
        """KL detectability ``1/2 ||q_i||^2``; see :func:`.indices.kl_detectability`."""
        return _indices.kl_detectability(self._data, i, theta, method=method)

    def kl_isolability(
        self, i: int, j: int, theta: Any, *, method: NullSpaceMethod | None = None
    ) -> float:
        """KL isolability of ``f_i`` from ``f_j``; see :func:`.indices.kl_isolability`."""
        return _indices.kl_isolability(self._data, i, j, theta, method=method)

    def directional_detectability(
        self, i: int, theta: Any, *, method: NullSpaceMethod | None = None
    ) -> float:
        """Li-Wang-Liu eq. (17); see :func:`.indices.directional_detectability`."""
        return _indices.directional_detectability(self._data, i, theta, method=method)

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
        """Li-Wang-Liu eq. (22); see :func:`.indices.directional_isolability`."""
        return _indices.directional_isolability(
            self._data, i, j, theta, kappa, theta_j=theta_j, cosine=cosine, method=method
        )

    def detection_probability(
        self, i: int, theta: Any, alpha: float = 0.01, *, method: NullSpaceMethod | None = None
    ) -> float:
        """``P_D`` of the chi-square test; see :func:`.indices.detection_probability`."""
        return _indices.detection_probability(self._data, i, theta, alpha, method=method)

    def isolation_probability(
        self,
        i: int,
        j: int,
        theta: Any,
        alpha: float = 0.01,
        *,
        method: NullSpaceMethod | None = None,
    ) -> float:
        """``P_I`` of ``f_i`` against ``f_j``; see :func:`.indices.isolation_probability`."""
        return _indices.isolation_probability(self._data, i, j, theta, alpha, method=method)

    def probabilistic_detectability(
        self, i: int, theta: Any, alpha: float = 0.01, *, method: NullSpaceMethod | None = None
    ) -> float:
        """``(P_D - alpha) / (1 - alpha)``; see :func:`.indices.probabilistic_detectability`."""
        return _indices.probabilistic_detectability(self._data, i, theta, alpha, method=method)

    def probabilistic_isolability(
        self,
        i: int,
        j: int,
        theta: Any,
        alpha: float = 0.01,
        *,
        method: NullSpaceMethod | None = None,
    ) -> float:
        """``(P_I - alpha) / (1 - alpha)``; see :func:`.indices.probabilistic_isolability`."""
        return _indices.probabilistic_isolability(self._data, i, j, theta, alpha, method=method)

    @limit_blas_threads
    def table(self, theta: Any, method: TableMethod = "kl", **options: Any) -> DiagnosabilityTable:
        """Shortcut for :func:`diagnosability_table` on this model."""
        return _tables.diagnosability_table(self, theta, method, **options)

    def applicability(self, theta: Any = None) -> ApplicabilityReport:
        """Theorems 1-2 of Li, Wang & Liu (2015); see :func:`.applicability.applicability`."""
        return _applicability.applicability(self._data, theta)
