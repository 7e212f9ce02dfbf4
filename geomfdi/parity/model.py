"""The parity-space model :class:`ParityFDI` (a small object over plain functions).

Measurement model ``Z = H x + D f + F eps``, ``eps ~ N(0, sigma^2 I)``, with ``H``
(m x n) of full column rank and m > n; by default ``D = F = I``.  A parity matrix ``V``
((m - n) x m, ``V H = 0``, ``V V^T = I``) removes the unknown ``x``: ``p = V Z``.  The
statistics live in :mod:`~geomfdi.parity.glt`, :mod:`~geomfdi.parity.opt`,
:mod:`~geomfdi.parity.multiple`, the decisions in :mod:`~geomfdi.parity.decision`,
sequential and windowed tests in :mod:`~geomfdi.parity.sequential` and the estimate
after exclusion in :mod:`~geomfdi.parity.estimation`; the construction (parity matrix,
whitening, signatures) is in :mod:`~geomfdi.parity._construction`.  The object holds a
frozen record of the model (:attr:`ParityFDI.data`) and passes it to those functions.

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

from geomfdi.parity import capability as _capability
from geomfdi.parity import diagnosis as _diagnosis
from geomfdi.parity import estimation as _estimation
from geomfdi.parity import glt as _glt
from geomfdi.parity import multiple as _multiple
from geomfdi.parity import opt as _opt
from geomfdi.parity._construction import build_data, reduced_data
from geomfdi.parity._records import ParityData
from geomfdi.parity.results import ConfigurationCapability, ParityDiagnosis

__all__ = ["ParityFDI"]


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
    data : ParityData
        The model and its derived matrices as a frozen record: what the statistic,
        decision and Monte-Carlo functions of :mod:`geomfdi.parity` take.
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
        self._set(build_data(H, sigma, D, F, basis, chunk_size, sensors))

    def _set(self, data: ParityData) -> None:
        self._data = data
        self.H, self.sigma, self.D, self.F = data.H, data.sigma, data.D, data.F
        self.m, self.n, self.s, self.k = data.m, data.n, data.s, data.k
        self.chunk_size, self.sensors = data.chunk_size, data.sensors
        self.W, self.V, self.basis, self.potter_order = (
            data.W,
            data.V,
            data.basis,
            data.potter_order,
        )
        self.detectable, self.isolable = data.detectable, data.isolable
        self._reduced: dict[int, ParityFDI] = {}  # by id of the cached reduced record

    @classmethod
    def _from_data(cls, data: ParityData) -> ParityFDI:
        obj = cls.__new__(cls)
        obj._set(data)
        return obj

    @property
    def data(self) -> ParityData:
        """The model as a frozen record (what the module functions take)."""
        return self._data

    @property
    def w(self) -> np.ndarray:
        """``w_ii`` (diag ``W`` for ``D = F = I``; in general ``||G_i||^2``), shape (k,)."""
        return self._data.w.copy()

    @property
    def fault_signatures(self) -> np.ndarray:
        """Whitened parity-space fault signatures ``G = L^{-1} V D``, shape (m - n, k)."""
        return self._data.G.copy()

    def __repr__(self) -> str:
        extra = "" if self.D is None and self.F is None else ", general D/F"
        return (
            f"ParityFDI(m={self.m}, n={self.n}, sigma={self.sigma:g}, basis={self.basis!r}{extra})"
        )

    def detection_threshold(self, pfa: float, dof: int | None = None) -> float:
        """``chi2`` threshold for the detection function (``dof`` default ``m - n``)."""
        return _glt.detection_threshold(self._data, pfa, dof)

    # the statistics and decisions: thin delegations to the functions of the modules
    def parity(self, Z: Any) -> np.ndarray:
        """Parity vectors ``p = V Z``, shape (N, m - n); see :func:`.glt.parity`."""
        return _glt.parity(self._data, Z)

    def detection_statistic(self, Z: Any) -> np.ndarray:
        """GLT detection function ``FD``, shape (N,); see :func:`.glt.detection_statistic`."""
        return _glt.detection_statistic(self._data, Z)

    def isolation_statistics(self, Z: Any) -> np.ndarray:
        """GLT isolation functions ``FI(i)``, (N, k); see :func:`.glt.isolation_statistics`."""
        return _glt.isolation_statistics(self._data, Z)

    def min_detectable_fault(self, pfa: float, pd: float = 0.9) -> np.ndarray:
        """Smallest fault detected with probability ``pd`` (:func:`.glt.min_detectable_fault`)."""
        return _glt.min_detectable_fault(self._data, pfa, pd)

    @property
    def opt_vectors(self) -> np.ndarray:
        """Unit optimal parity vectors (m, k); see :func:`.opt.opt_vectors`."""
        return _opt.opt_vectors(self._data)

    @property
    def opt_performance(self) -> np.ndarray:
        """Maximised OPT index ``S_i`` (k,); see :func:`.opt.opt_performance`."""
        return _opt.opt_performance(self._data)

    @property
    def opt_dof(self) -> int:
        """Degrees of freedom of :meth:`opt_detection_statistic`."""
        return _opt.opt_dof(self._data)

    def opt_statistics(self, Z: Any) -> np.ndarray:
        """Standardised OPT residuals ``d_i``, (N, k); see :func:`.opt.opt_statistics`."""
        return _opt.opt_statistics(self._data, Z)

    def opt_detection_statistic(self, Z: Any) -> np.ndarray:
        """Corrected OPT ``FD_OPT``, (N,); see :func:`.opt.opt_detection_statistic`."""
        return _opt.opt_detection_statistic(self._data, Z)

    def pair_statistics(self, Z: Any) -> tuple[np.ndarray, np.ndarray]:
        """Qin & Niu's ``(D+, D-)``, each (N, k, k); see :func:`.multiple.pair_statistics`."""
        return _multiple.pair_statistics(self._data, Z)

    def two_fault_glr(self, Z: Any) -> np.ndarray:
        """Two-fault GLR for every pair, (N, k, k); see :func:`.multiple.two_fault_glr`."""
        return _multiple.two_fault_glr(self._data, Z)

    def glr_statistics(self, Z: Any, n_faults: int) -> tuple[np.ndarray, np.ndarray]:
        """k-fault GLR of every subset; see :func:`.multiple.glr_statistics`."""
        return _multiple.glr_statistics(self._data, Z, n_faults)

    def capability(self) -> ConfigurationCapability:
        """Isolation-capability figures; see :func:`.capability.capability`."""
        return _capability.capability(self._data)

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
        return _diagnosis.diagnose(
            self._data,
            Z,
            pfa,
            method=method,
            max_faults=max_faults,
            window=window,
            shift=shift,
            beta=beta,
            threshold=threshold,
        )

    def estimate_faults(self, Z: Any, faults: Any) -> _estimation.FaultEstimate:
        """ML fault sizes of the hypotheses ``faults``; see :func:`.estimation.estimate_faults`."""
        return _estimation.estimate_faults(self._data, Z, faults)

    def estimate_state(self, Z: Any, exclude: Any = ()) -> _estimation.StateEstimate:
        """State estimate without the excluded sensors; see :func:`.estimation.estimate_state`."""
        return _estimation.estimate_state(self._data, Z, exclude)

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
        :attr:`sensors` keeps the original labels.  The same object for the same sensors.

    Raises
    ------
    DesignError
        ``D`` is not the identity, or no redundancy would remain (``m - r <= n``).
    RankDeficientError
        The remaining rows do not determine ``x``.
    """
    data = reduced_data(pf.data, remove)
    obj = pf._reduced.get(id(data))
    if obj is None:
        obj = pf._reduced[id(data)] = ParityFDI._from_data(data)
    return obj
