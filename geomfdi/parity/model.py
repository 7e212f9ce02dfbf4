"""The parity-space model :class:`ParityFDI` (a small object over plain functions).

Measurement model ``Z = H x + D f + F eps``, ``eps ~ N(0, sigma^2 I)``, with ``H``
(m x n) of full column rank and m > n; by default ``D = F = I``.  A parity matrix ``V``
((m - n) x m, ``V H = 0``, ``V V^T = I``) removes the unknown ``x``: ``p = V Z``.  The
statistics live in :mod:`~geomfdi.parity.glt`, :mod:`~geomfdi.parity.opt`,
:mod:`~geomfdi.parity.multiple`, the decisions in :mod:`~geomfdi.parity.decision`,
sequential and windowed tests in :mod:`~geomfdi.parity.sequential` and the estimate
after exclusion in :mod:`~geomfdi.parity.estimation`; the methods of
:class:`ParityFDI` delegate to them.

References
----------
Zhang, Chen & Liu (2005), "Is OPT better than GLT in fault diagnosis of redundant sensor
system?"; Qin & Niu (1999), soft fault detection and isolation for a strapdown inertial
navigation system; Potter & Suman (1977), thresholdless redundancy management; Jin &
Zhang (1999), optimal parity vector sensitive to designated sensor fault.  See the user
guide, *Theory: parity space* (``docs/theory/parity-space.md``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from scipy import linalg as sla

from geomfdi._validation import as_int, as_matrix, as_positive, as_real_array, as_sequence_of
from geomfdi.errors import DesignError, GeomFDIError, RankDeficientError, ShapeError
from geomfdi.parity import capability as _capability
from geomfdi.parity import decision as _decision
from geomfdi.parity import estimation as _estimation
from geomfdi.parity import glt as _glt
from geomfdi.parity import multiple as _multiple
from geomfdi.parity import opt as _opt
from geomfdi.parity import sequential as _sequential
from geomfdi.parity.results import ConfigurationCapability, ParityDiagnosis
from geomfdi.tolerance import get_rtol, rank_decision

__all__ = ["ParityFDI"]

# Rows per block in diagnose: the block product (statistics x m) @ (m x rows) is kept at
# <= 2**19 multiply-adds, small enough for the cache and below OpenBLAS's threshold for
# threading a GEMM.
_CHUNK_FLOPS = 1 << 19
# Leading block of W used by the Potter-Suman construction must have its smallest singular
# value above this, otherwise the columns are pivoted (conditioning guard, not a rank
# decision: a nearly dependent leading block would make the QR span inaccurate).
_POTTER_MIN_SV = 1e-6


def _potter_suman(W: np.ndarray, s: int) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormalise the first ``s`` columns (= rows) of the projector ``W``.

    Returns ``V`` ((s, m), rows orthonormal, ``V^T V = W``) and the sensor order used.
    ``V[:, order[:s]]`` is upper triangular with a positive diagonal: the explicit
    Potter-Suman form.  If the first ``s`` columns are (nearly) dependent, QR with
    column pivoting chooses the columns instead.
    """
    m = W.shape[0]
    Q, R = np.linalg.qr(W[:, :s])
    # sigma_min(lead) = sigma_min(R) >= 1 / (sqrt(s) ||R^-1||_1); LAPACK's trcon estimates
    # ||R^-1||_1 in O(s^2) (an SVD of the m x s block would cost as much as the QR)
    rcond = float(sla.lapack.dtrcon(R, norm="1", uplo="U", diag="N")[0]) if s else 1.0
    norm1 = float(np.abs(R).sum(axis=0).max()) if s else 1.0
    if rcond * norm1 / np.sqrt(max(s, 1)) > _POTTER_MIN_SV:
        order = np.arange(m)
    else:
        Qf, Rf, order = sla.qr(W, pivoting=True)
        Q, R = Qf[:, :s], Rf[:s, :s]
    signs = np.sign(np.diag(R))
    signs[signs == 0] = 1.0
    return (Q * signs).T.copy(), np.asarray(order)


def _sensor_labels(sensors: Any, m: int) -> np.ndarray:
    """Distinct non-negative integer labels, one per sensor (default ``0..m-1``)."""
    if sensors is None:
        return np.arange(m)
    arr = as_real_array(sensors, "sensors").reshape(-1)
    if arr.shape != (m,):
        raise ShapeError(f"sensors: expected {m} labels, got {arr.size}", argument="sensors")
    if np.any(arr != np.round(arr)) or np.any(arr < 0) or np.any(arr > np.iinfo(np.intp).max):
        raise GeomFDIError("sensors: labels must be non-negative integers", argument="sensors")
    labels = arr.astype(np.intp)
    uniq, counts = np.unique(labels, return_counts=True)
    if np.any(counts > 1):
        raise GeomFDIError(
            f"sensors: labels must be distinct, {uniq[counts > 1].tolist()} repeated",
            argument="sensors",
        )
    return labels


class ParityFDI:
    """Parity-space FDI for ``Z = H x + D f + F eps``, ``eps ~ N(0, sigma^2 I)``.

    Parameters
    ----------
    H : array_like, shape (m, n)
        Measurement (installation) matrix, full column rank, ``m > n``.
    sigma : float
        Noise standard deviation (> 0).
    D : array_like, shape (m, k), optional
        Fault input matrix; column ``i`` is the signature of fault ``i``.  Default
        ``I_m``: fault ``i`` is an additive fault on sensor ``i``.
    F : array_like, shape (m, q), optional
        Noise input matrix (default ``I_m``).  ``V F F^T V^T`` must be nonsingular.
    basis : {"potter", "svd"} or array_like, shape (m - n, m)
        Parity matrix: ``"potter"`` (default) orthonormalises the leading rows of ``W``
        (Potter-Suman); ``"svd"`` takes the left singular vectors of ``H`` beyond its
        rank; an array is used as given after checking ``V H = 0`` and ``V V^T = I``.
        All choices give identical statistics.
    chunk_size : int, optional
        Rows processed at a time by :meth:`diagnose` (cache blocking); default: the power
        of two keeping a block product near ``2**19`` multiply-adds (8192 for m = 6).
    sensors : array_like of int, optional
        Labels of the sensors (default ``0..m-1``); :meth:`reduced` passes the original
        indices.

    Attributes
    ----------
    H, sigma, D, F : ndarray / float
        The model (``D``, ``F`` are ``None`` for the identity).
    V : ndarray, shape (m - n, m)
        Parity matrix, ``V H = 0``, ``V V^T = I``, ``V^T V = W``.
    W : ndarray, shape (m, m)
        ``I - H (H^T H)^{-1} H^T`` (computed from an orthonormal basis of range H).
    m, n, s, k : int
        Sensors, unknowns, parity dimension ``m - n``, fault hypotheses.
    sensors : ndarray of int
        Labels of the sensors (their indices in the configuration this one was reduced
        from; ``0..m-1`` for a new configuration).
    potter_order : ndarray of int or None
        Sensor order of the Potter-Suman construction (identity unless pivoted).
    detectable, isolable : ndarray of bool, shape (k,)
        A single fault reaches the parity space / is distinguishable from every other.

    Notes
    -----
    GLT (Zhang, Chen & Liu 2005, eq. 2-5): ``FD = ||q||^2 / sigma^2 ~ chi2(m - n)``
    without fault, ``FI(i) = (q^T G_i)^2 / (sigma^2 G_i^T G_i)``, isolate
    ``argmax FI(i)``; ``q = L^{-1} p`` with ``L L^T = V F F^T V^T`` and whitened fault
    signatures ``G = L^{-1} V D``.  OPT, corrected OPT, Qin & Niu's two-fault statistics,
    the k-fault GLR and the reduced configuration (``FD_reduced = FD - GLR_S``) are
    described in the modules named above and in the user guide, *Theory: parity space*
    (``docs/theory/parity-space.md``).  Construction costs ``O(m^3)`` (a QR and an SVD
    of m x m matrices and one Gram product); pair and subset tables are built on first
    use.

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> pf = gf.ParityFDI(gf.parity.dodecahedron(), sigma=0.01)
    >>> Z = np.zeros((2, 6)); Z[1, 4] = 0.2          # sample 1: fault on sensor 4
    >>> res = pf.diagnose(Z, pfa=1e-3)
    >>> res.detected.tolist(), res.isolated.tolist()
    ([False, True], [-1, 4])
    """

    def __init__(
        self,
        H: Any,
        sigma: float = 1.0,
        *,
        D: Any = None,
        F: Any = None,
        basis: Any = "potter",
        chunk_size: int | None = None,
        sensors: Any = None,
    ) -> None:
        H = as_matrix(H, "H", vector_as="column")
        m, n = H.shape
        if m <= n:
            raise ShapeError(
                f"H: a parity space needs more sensors than unknowns (m > n), got shape {H.shape}",
                argument="H",
            )
        sv = np.linalg.svd(H, compute_uv=False)
        dec = rank_decision(sv, float(sv[0]), m, what="H: full column rank")
        if dec.rank < n:
            raise RankDeficientError(
                f"H: must have full column rank {n}, numerical rank is {dec.rank} "
                f"(singular values {np.array2string(sv, precision=3)})",
                argument="H",
            )
        self.H = H
        self.m, self.n = m, n
        self.s = m - n
        self.sigma = as_positive(sigma, "sigma")
        if chunk_size is None:
            per_row = (m + self.s) * m  # (k + m - n) statistics per row, k = m by default
            chunk_size = 1 << max(10, min(16, (_CHUNK_FLOPS // per_row).bit_length() - 1))
        self.chunk_size = as_int(chunk_size, "chunk_size", minimum=1)
        self.sensors = _sensor_labels(sensors, m)

        Qh = np.linalg.qr(H)[0]
        W = np.eye(m) - Qh @ Qh.T
        self.W = (W + W.T) / 2.0

        self.potter_order: np.ndarray | None = None
        if isinstance(basis, str):
            if basis == "potter":
                V, self.potter_order = _potter_suman(self.W, self.s)
            elif basis == "svd":
                U = np.linalg.svd(H, full_matrices=True)[0]
                V = U[:, n:].T.copy()
            else:
                raise GeomFDIError(
                    f"basis: expected 'potter', 'svd' or an (m-n) x m matrix, got {basis!r}",
                    argument="basis",
                )
            self.basis = basis
        else:
            V = as_matrix(basis, "basis", rows=self.s, cols=m)
            tol = 1e-8
            err_h = np.linalg.norm(V @ H, 2) / max(np.linalg.norm(H, 2), 1.0)
            err_o = np.linalg.norm(V @ V.T - np.eye(self.s), 2)
            if err_h > tol or err_o > tol:
                raise DesignError(
                    f"basis: must satisfy V H = 0 and V V^T = I (errors {err_h:.2g}, {err_o:.2g})",
                    argument="basis",
                )
            self.basis = "given"
        self.V = V

        # noise model: whitening of the parity vector
        if F is None:
            self.F = None
            self._Sigma = None
            T = V.copy()
        else:
            Fm = as_matrix(F, "F", rows=m, vector_as="column")
            self.F = Fm
            self._Sigma = Fm @ Fm.T
            Sp = V @ self._Sigma @ V.T
            Sp = (Sp + Sp.T) / 2.0
            ev = np.clip(np.linalg.eigvalsh(Sp)[::-1], 0.0, None)
            fnorm = float(np.linalg.norm(Fm, 2))
            d2 = rank_decision(np.sqrt(ev), fnorm, m, what="F: noise in parity space")
            if d2.rank < self.s:
                raise DesignError(
                    "F: the noise must reach every parity direction (V F F^T V^T is "
                    f"singular, rank {d2.rank} < {self.s})",
                    argument="F",
                )
            L = np.linalg.cholesky(Sp)
            T = sla.solve_triangular(L, V, lower=True)
        self._T = T  # whitened parity map, q = T Z

        # fault model
        if D is None:
            self.D = None
            Dm = np.eye(m)
        else:
            Dm = as_matrix(D, "D", rows=m, vector_as="column")
            self.D = Dm
        self._Dm = Dm
        self.k = Dm.shape[1]
        plain = D is None and F is None  # V^T V = W: skip the m x m x m products
        G = T if D is None else T @ Dm
        self._G = G
        self._Omega = self.W if plain else G.T @ G
        norm_t = 1.0 if F is None else float(np.linalg.norm(T, 2))
        norm_d = 1.0 if D is None else float(np.linalg.norm(Dm, 2))
        self._scaleG = max(norm_t * norm_d, 1e-300)
        gnorm = np.linalg.norm(G, axis=0)
        tolG = get_rtol(m) * self._scaleG
        self.detectable = gnorm > tolG
        w = np.where(self.detectable, gnorm**2, 0.0)
        self._w = w
        TtG = self.W if plain else T.T @ G
        self._B = TtG / self.sigma  # Z @ _B = a, a_i = q^T G_i / sigma
        self._Bn = np.zeros((m, self.k))  # Z @ _Bn = sqrt(FI) with sign
        self._Bn[:, self.detectable] = self._B[:, self.detectable] / np.sqrt(w[self.detectable])
        self._subset_cache: dict[int, dict[str, np.ndarray]] = {}
        self._reduced_cache: dict[tuple[int, ...], ParityFDI] = {}
        self._opt: dict[str, np.ndarray] | None = None
        self._sequential_thresholds: dict[tuple, Any] = {}
        self.isolable = self.detectable & ~_multiple._subset_info(self, 1)["ambiguous"]
        self._lut = np.where(self.isolable, np.arange(self.k), -1).astype(np.intp)

    @property
    def w(self) -> np.ndarray:
        """``w_ii`` (diag ``W`` for ``D = F = I``; in general ``||G_i||^2``), shape (k,)."""
        return self._w.copy()

    @property
    def fault_signatures(self) -> np.ndarray:
        """Whitened parity-space fault signatures ``G = L^{-1} V D``, shape (m - n, k)."""
        return self._G.copy()

    def __repr__(self) -> str:
        extra = "" if self.D is None and self.F is None else ", general D/F"
        return (
            f"ParityFDI(m={self.m}, n={self.n}, sigma={self.sigma:g}, basis={self.basis!r}{extra})"
        )

    def detection_threshold(self, pfa: float, dof: int | None = None) -> float:
        """``chi2`` threshold for the detection function (``dof`` default ``m - n``)."""
        return _glt.detection_threshold(self, pfa, dof)

    # the statistics and decisions: thin delegations to the functions of the modules
    def parity(self, Z: Any) -> np.ndarray:
        """Parity vectors ``p = V Z``, shape (N, m - n); see :func:`.glt.parity`."""
        return _glt.parity(self, Z)

    def detection_statistic(self, Z: Any) -> np.ndarray:
        """GLT detection function ``FD``, shape (N,); see :func:`.glt.detection_statistic`."""
        return _glt.detection_statistic(self, Z)

    def isolation_statistics(self, Z: Any) -> np.ndarray:
        """GLT isolation functions ``FI(i)``, (N, k); see :func:`.glt.isolation_statistics`."""
        return _glt.isolation_statistics(self, Z)

    def min_detectable_fault(self, pfa: float, pd: float = 0.9) -> np.ndarray:
        """Smallest fault detected with probability ``pd`` (:func:`.glt.min_detectable_fault`)."""
        return _glt.min_detectable_fault(self, pfa, pd)

    @property
    def opt_vectors(self) -> np.ndarray:
        """Unit optimal parity vectors (m, k); see :func:`.opt.opt_vectors`."""
        return _opt.opt_vectors(self)

    @property
    def opt_performance(self) -> np.ndarray:
        """Maximised OPT index ``S_i`` (k,); see :func:`.opt.opt_performance`."""
        return _opt.opt_performance(self)

    @property
    def opt_dof(self) -> int:
        """Degrees of freedom of :meth:`opt_detection_statistic`."""
        return _opt.opt_dof(self)

    def opt_statistics(self, Z: Any) -> np.ndarray:
        """Standardised OPT residuals ``d_i``, (N, k); see :func:`.opt.opt_statistics`."""
        return _opt.opt_statistics(self, Z)

    def opt_detection_statistic(self, Z: Any) -> np.ndarray:
        """Corrected OPT ``FD_OPT``, (N,); see :func:`.opt.opt_detection_statistic`."""
        return _opt.opt_detection_statistic(self, Z)

    def pair_statistics(self, Z: Any) -> tuple[np.ndarray, np.ndarray]:
        """Qin & Niu's ``(D+, D-)``, each (N, k, k); see :func:`.multiple.pair_statistics`."""
        return _multiple.pair_statistics(self, Z)

    def two_fault_glr(self, Z: Any) -> np.ndarray:
        """Two-fault GLR for every pair, (N, k, k); see :func:`.multiple.two_fault_glr`."""
        return _multiple.two_fault_glr(self, Z)

    def glr_statistics(self, Z: Any, n_faults: int) -> tuple[np.ndarray, np.ndarray]:
        """k-fault GLR of every subset; see :func:`.multiple.glr_statistics`."""
        return _multiple.glr_statistics(self, Z, n_faults)

    def capability(self) -> ConfigurationCapability:
        """Isolation-capability figures; see :func:`.capability.capability`."""
        return _capability.capability(self)

    def diagnose(
        self,
        Z: Any,
        pfa: float = 0.01,
        *,
        method: str = "glt",
        max_faults: int | None = None,
        window: int = 100,
        shift: float = 0.5,
        beta: float = 0.1,
        threshold: float | None = None,
    ) -> ParityDiagnosis:
        """Detect and isolate faults in every sample (or epoch of a time series).

        ``method`` in ``"glt", "opt", "opt-uncorrected", "search", "glr"`` treats the rows
        of ``Z`` as independent samples (:func:`.decision.diagnose`, ``max_faults``);
        ``"windowed"`` (moving-average GLT over ``window`` samples), ``"cusum"``
        (window-limited), ``"sprt"`` (Wald's repeated SPRT: cumulative log-likelihood
        ratio of a bias of ``shift * sigma`` per sensor and sign, restarted on accepting
        "no fault" -- lower boundary ``log(beta / (1 - alpha))`` -- and after each alarm)
        and ``"sprt-window"`` (the window-limited restart variant) treat them as
        consecutive samples, ``Z`` of shape ``(N, m)`` or ``(R, N, m)``, with a per-epoch
        false-alarm rate ``pfa``: exact for ``"windowed"``, calibrated by Monte-Carlo for
        the others unless ``threshold`` is given (for ``"sprt"``: the upper boundary
        ``A``).  See :mod:`.sequential` and :mod:`.sprt`.
        """
        if isinstance(method, str) and method in _sequential.SEQUENTIAL_METHODS:
            return _sequential.diagnose_sequential(
                self, Z, pfa, method, window=window, shift=shift, beta=beta, threshold=threshold
            )
        return _decision.diagnose(self, Z, pfa, method=method, max_faults=max_faults)

    def estimate_faults(self, Z: Any, faults: Any) -> _estimation.FaultEstimate:
        """ML fault sizes of the hypotheses ``faults``; see :func:`.estimation.estimate_faults`."""
        return _estimation.estimate_faults(self, Z, faults)

    def estimate_state(self, Z: Any, exclude: Any = ()) -> _estimation.StateEstimate:
        """State estimate without the excluded sensors; see :func:`.estimation.estimate_state`."""
        return _estimation.estimate_state(self, Z, exclude)

    def reduced(self, remove: int | Sequence[int]) -> ParityFDI:
        """The configuration without the sensors ``remove``; see :func:`reduced_configuration`."""
        return reduced_configuration(self, remove)


def reduced_configuration(pf: ParityFDI, remove: int | Sequence[int]) -> ParityFDI:
    """The configuration without the sensors ``remove`` (re-detection after isolation).

    Parameters
    ----------
    remove : int or sequence of int
        Sensor indices of *this* configuration (0-based).

    Returns
    -------
    ParityFDI
        ``H`` (and ``F``) without those rows, same ``sigma`` and basis kind;
        :attr:`sensors` keeps the original labels.

    Raises
    ------
    DesignError
        ``D`` is not the identity, or no redundancy would remain (``m - r <= n``).
    RankDeficientError
        The remaining rows do not determine ``x``.
    """
    if pf.D is not None:
        raise DesignError(
            "remove: a reduced configuration needs D = I (faults are sensor faults)",
            argument="remove",
        )
    if isinstance(remove, int | np.integer):
        rem = [as_int(remove, "remove")]
    else:
        rem = [int(as_int(r, "remove")) for r in as_sequence_of(remove, "remove", object)]
    for r in rem:
        if not 0 <= r < pf.m:
            raise GeomFDIError(f"remove: index {r} out of range 0..{pf.m - 1}", argument="remove")
    key = tuple(sorted(set(rem)))
    if key in pf._reduced_cache:
        return pf._reduced_cache[key]
    keep = np.setdiff1d(np.arange(pf.m), key)
    if keep.size <= pf.n:
        raise DesignError(
            f"remove: removing {len(key)} sensor(s) leaves {keep.size} <= n = {pf.n}: "
            "no redundancy left",
            argument="remove",
        )
    basis = pf.basis if pf.basis in ("potter", "svd") else "potter"
    red = ParityFDI(
        pf.H[keep],
        pf.sigma,
        F=None if pf.F is None else pf.F[keep],
        basis=basis,
        chunk_size=None,
        sensors=pf.sensors[keep],
    )
    pf._reduced_cache[key] = red
    return red
