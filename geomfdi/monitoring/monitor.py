"""The AR-model innovation monitor :class:`ARMonitor` (a small object over functions).

The monitor fits an AR(n) model by least squares to a sliding window of the last ``m``
innovations and tests one coefficient ``phi_c`` against its fault-free distribution
learnt from normal data (Jin, Ding & Cong)::

    lambda_t = ((phi_c(t) - mu) / delta)**2  ~  chi2(1),   alarm when lambda_t > T,

with ``T = chi2.isf(pfa, 1)`` (``pfa = 1e-4`` gives ``T = 15.1367``).  Training is in
:mod:`~geomfdi.monitoring.training`, batch runs in :mod:`~geomfdi.monitoring.batch`, the
streaming API in :mod:`~geomfdi.monitoring.streaming`, baselines on the same data in
:mod:`~geomfdi.monitoring.baselines`.  See the user guide, *Theory: AR monitoring*
(``docs/theory/ar-monitoring.md``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi._validation import as_index, as_int, as_probability, as_real_array
from geomfdi.errors import GeomFDIError, ResourceLimitError, ShapeError
from geomfdi.monitoring import batch as _batch
from geomfdi.monitoring import streaming as _streaming
from geomfdi.monitoring import training as _training
from geomfdi.monitoring._records import ARNull, ARSettings
from geomfdi.monitoring.results import ARMonitorResult, ARStep

__all__ = ["ARMonitor"]

#: Largest AR order, window (samples) and their product (the entries of one window's
#: regression, 8 bytes each) an :class:`ARMonitor` accepts: checked before anything is
#: allocated, so ``ARMonitor(order=10**9, window=10**10)`` is refused, not attempted.
MAX_ORDER = 1_000
MAX_WINDOW = 10_000_000
MAX_WINDOW_ENTRIES = 100_000_000


class ARMonitor:
    """AR-model parameter-change detector for innovation sequences (Jin, Ding & Cong).

    Parameters
    ----------
    order : int
        AR order ``n`` (paper: 5).
    window : int
        Window length ``m`` in samples (paper: 60); ``m - n`` regression equations, so
        ``window >= 2 * order`` is required.
    coefficient : int
        0-based index ``c`` of the tested coefficient ``phi_{c+1}`` (paper: ``phi_1``).
    pfa : float
        False-alarm probability of the chi-square(1) test.
    reset_after : int or None
        Reset strategy: restart the window from the stored normal innovations after this
        many consecutive alarms (paper: 10).  ``None`` disables it.
    reset_keep : int
        Number of the most recent (faulty) samples kept in the restarted window (see
        Notes; 0 is the literal "restart from the stored normal data").
    prefill : bool
        Start every stream (and :meth:`reset`) with the window holding the stored normal
        innovations, so that a statistic exists from the first sample (the paper's
        "pre-stored innovations").  If False, the first ``m - 1`` epochs are a warm-up
        with invalid statistics.
    refit_every : int, optional
        Streaming API: recompute the normal equations exactly from the window every this
        many updates (default ``window``), which bounds the drift of the rank-1 updates.

    Attributes
    ----------
    mu, delta : float
        Mean and standard deviation of ``phi_c`` over the training windows.
    threshold : float
        ``chi2.isf(pfa, 1)``.
    normal : ndarray, (window - 1,)
        Stored normal innovations used by ``prefill`` and the reset strategy.
    training_coefficients : ndarray, (N, order)
        AR coefficients of the training windows.
    training_model : ndarray, (order,)
        AR coefficients of one least-squares fit pooled over all training data: the
        fitted null model the joint ``T^2`` test is calibrated on
        (:func:`~geomfdi.monitoring.baselines.coefficient_t2`).

    Notes
    -----
    **Model.**  ``X_t = sum_{k=1}^{n} phi_k X_{t-k} + e_t`` without intercept, fitted by
    ordinary least squares to the ``m - n`` equations ``t = s+n, ..., s+m-1`` of the
    window ``X_s, ..., X_{s+m-1}`` (the paper's model; innovations of a consistent
    filter are zero-mean).  No intercept is deliberate: a bias fault then shows as a
    change of the coefficients.

    **Test.**  ``lambda = ((phi_c - mu) / delta)**2`` against ``T = chi2.isf(pfa, 1)``.
    The chi-square(1) law is an approximation: for ``n = 5, m = 60`` on Gaussian
    innovations the realised false-alarm rate per window is 0.050 at ``pfa = 0.05`` and
    0.011 at 0.01, but about 1.8e-4 at 1e-4 (heavier tails than the normal law).
    Statistics of overlapping windows are strongly correlated: alarms come in bursts.

    **Power.**  A bias step in the last samples pulls ``phi_1`` towards +1; once the
    step fills the window the fitted model is again an ordinary AR model and the alarm
    dies out (about ``m`` epochs after the onset).

    **Reset strategy (exact semantics).**  Let ``k = reset_after``, ``r = reset_keep``.
    When ``k`` consecutive valid alarms have been raised at epoch ``t``, the window is
    restarted: its last ``m - 1`` samples become ``normal[r:]`` followed by
    ``X_{t-r+1..t}``; the counter restarts and ``restarted[t]`` is set.  The stored
    normal data are never refreshed while monitoring (change them with
    :meth:`set_normal`).

    **What the reset achieves -- measured, not the paper's claim.**  The paper states
    that with the reset the alarm "keeps being raised" while the fault persists.  It
    does not in general: after a restart the window holds ``r`` faulty samples, and
    the statistic must exceed the threshold ``k`` times in a row again before the next
    restart; in between the alarm may be off, and how often depends on the stored
    normal buffer.  ``examples/ar_innovation_monitor.py`` measures it: AR(1)
    innovations (a = -0.3), 5-sigma step, ``k = 10``, ``r = 1``, 24 stored buffers x 50
    streams: the alarm is on for a median of 59 % of the faulty epochs with the reset
    (5-95 % over buffers: 15-85 %, worse than no reset for 3 of 24 buffers) against 16 %
    without it; on the same streams the chi-square test of the normalised innovation
    (:func:`~geomfdi.monitoring.baselines.innovation_chi2`) alarms on 87 % and the GLR of
    the innovation mean on 99.9 %.  For a persistent indication,
    :func:`~geomfdi.monitoring.baselines.latch_alarms` (98 % there) is the simple
    alternative, at the price of holding false alarms too.

    References
    ----------
    Jin, Ding & Cong, "AR-model parameter based fault detection for navigation
    systems" (Beihang University): AR(5) on 60-sample windows of GPS pseudorange
    innovations, chi-square(1) test of phi_1, Pfa = 1e-4 -> T = 15.1367, reset after 10
    consecutive alarms.  See the user guide, *Theory: AR monitoring*
    (``docs/theory/ar-monitoring.md``).

    Examples
    --------
    >>> import geomfdi as gf
    >>> mon = gf.ARMonitor(order=5, window=60, reset_after=None)
    >>> _ = mon.fit(gf.synthetic_innovations(60, ar=[-0.3], n_series=500, rng=0))
    >>> round(mon.threshold, 4)
    15.1367
    >>> x = gf.synthetic_innovations(300, ar=[-0.3], fault="step", size=5, start=200, rng=0)
    >>> out = mon.run(x)
    >>> out.statistic.shape, out.first_alarm
    ((300,), 203)
    """

    def __init__(
        self,
        order: int = 5,
        window: int = 60,
        coefficient: int = 0,
        pfa: float = 1e-4,
        reset_after: int | None = 10,
        *,
        reset_keep: int = 1,
        prefill: bool = False,
        refit_every: int | None = None,
    ) -> None:
        self.order = as_int(order, "order", minimum=1, maximum=MAX_ORDER)
        self.window = as_int(window, "window", minimum=2, maximum=MAX_WINDOW)
        if self.order * self.window > MAX_WINDOW_ENTRIES:
            raise ResourceLimitError(
                f"window: a window of {self.window} samples for AR({self.order}) holds "
                f"{self.order * self.window:.3g} regression entries (at most "
                f"{MAX_WINDOW_ENTRIES:.0e}, 800 MB); use a shorter window or a lower order",
                limit="max_memory",
                argument="window",
            )
        if self.order >= self.window:
            raise GeomFDIError(
                f"order: must be smaller than window = {self.window}, got {self.order}",
                argument="order",
            )
        if self.window < 2 * self.order:
            raise GeomFDIError(
                f"order: AR({self.order}) needs a window of at least {2 * self.order} samples "
                f"(window - order >= order equations), got window = {self.window}",
                argument="order",
            )
        self.coefficient = as_index(coefficient, "coefficient", self.order)
        self.pfa = as_probability(pfa, "pfa")
        if reset_after is None:
            self.reset_after: int | None = None
        else:
            self.reset_after = as_int(reset_after, "reset_after", minimum=1)
        self.reset_keep = as_int(reset_keep, "reset_keep", minimum=0)
        if self.reset_keep > self.window - 1:
            raise GeomFDIError(
                f"reset_keep: must be <= window - 1 = {self.window - 1}, got {self.reset_keep}",
                argument="reset_keep",
            )
        if not isinstance(prefill, bool | np.bool_):
            raise GeomFDIError(
                f"prefill: must be True or False, got {prefill!r}", argument="prefill"
            )
        self.prefill = bool(prefill)
        self.refit_every = (
            self.window if refit_every is None else as_int(refit_every, "refit_every", minimum=1)
        )
        from scipy.stats import chi2

        self.threshold = float(chi2.isf(self.pfa, 1))
        self.mu: float | None = None
        self.delta: float | None = None
        self.normal: np.ndarray | None = None
        self.training_coefficients: np.ndarray | None = None
        self.training_model: np.ndarray | None = None
        self._t2_null: dict = {}  # bootstrap T^2 samples of the joint test, per (n_draws, rng)
        self.last: ARStep | None = None
        self._stream: _streaming.ARStreamState | None = None
        self._state_ready = False

    def __repr__(self) -> str:
        trained = (
            f"mu={self.mu:.4g}, delta={self.delta:.4g}" if self.mu is not None else "untrained"
        )
        return (
            f"ARMonitor(order={self.order}, window={self.window}, coefficient="
            f"{self.coefficient}, pfa={self.pfa:g}, reset_after={self.reset_after}; {trained})"
        )

    def set_normal(self, normal: Any) -> None:
        """Replace the stored normal innovations (``window - 1`` finite samples)."""
        v = as_real_array(normal, "normal").reshape(-1)
        if v.shape[0] != self.window - 1:
            raise ShapeError(
                f"normal: expected {self.window - 1} samples (window - 1), got {v.shape[0]}",
                argument="normal",
            )
        self.normal = v.copy()
        self._state_ready = False

    def _require_fit(self) -> None:
        if self.mu is None or self.delta is None or self.normal is None:
            raise GeomFDIError(
                "training: the monitor is not trained; call fit(training) first",
                argument="training",
            )

    def _settings(self) -> ARSettings:
        return ARSettings(
            order=self.order,
            window=self.window,
            coefficient=self.coefficient,
            pfa=self.pfa,
            threshold=self.threshold,
            reset_after=self.reset_after,
            reset_keep=self.reset_keep,
            prefill=self.prefill,
            refit_every=self.refit_every,
        )

    def _null(self) -> ARNull:
        self._require_fit()
        return ARNull(mu=self.mu, delta=self.delta, normal=self.normal)  # type: ignore[arg-type]

    def statistic_of(self, coefficients: Any) -> np.ndarray:
        """``((phi_c - mu) / delta)**2`` for coefficient vectors (..., order)."""
        return self._null().statistic(coefficients, self.coefficient)

    # training, batch runs and streaming: the monitor passes its settings and null model
    # (small records) to the module functions and keeps their results
    def window_coefficients(self, windows: Any) -> np.ndarray:
        """AR(order) coefficients of each row; see :func:`.training.window_coefficients`."""
        return _training.window_coefficients(self.order, windows)

    def fit(self, training: Any, *, step: int = 1, normal: Any = None) -> ARMonitor:
        """Learn ``mu`` and ``delta`` of ``phi_c`` from fault-free innovations.

        Parameters
        ----------
        training : array_like, (N, window) or (L,)
            ``N >= 2`` normal windows (rows), or one long normal sequence whose windows
            (every ``step``-th one) are used.  Must be finite.
        step : int
            Spacing of the windows taken from a 1-D sequence (1: all sliding windows;
            ``window``: non-overlapping, independent windows as in the paper).
        normal : array_like, (window - 1,), optional
            Normal innovations stored for ``prefill`` and the reset strategy (default: the
            last ``window - 1`` training samples).

        Returns
        -------
        ARMonitor
            ``self``, trained; see :func:`.training.fit`.
        """
        tr = _training.fit(self.order, self.window, self.coefficient, training, step=step)
        self.mu, self.delta = tr.mu, tr.delta
        self.training_coefficients = tr.coefficients
        self.training_model = tr.model
        self._t2_null.clear()
        self.set_normal(tr.normal if normal is None else normal)
        return self

    def run(self, stream: Any) -> ARMonitorResult:
        """Monitor whole streams from a fresh state; see :func:`.batch.run`."""
        return _batch.run(self._settings(), self._null(), stream)

    def reset(self) -> None:
        """Start a new stream: empty window (or the stored normal data if ``prefill``)."""
        self._stream = _streaming.reset(self._settings(), self._null())
        self.last = None
        self._state_ready = True

    def update(self, x: float) -> tuple[float, bool]:
        """Process one sample; return ``(statistic, alarm)``.

        ``statistic`` is NaN when no statistic exists (warm-up, non-finite sample in the
        window, rank-deficient regressors); the full outcome is in :attr:`last`
        (:class:`ARStep`).  A non-finite ``x`` is accepted and reported with an
        :class:`ARMonitorWarning`.  The first call after :meth:`fit` or
        :meth:`set_normal` starts a new stream (as :meth:`reset`).  See
        :func:`.streaming.update`.
        """
        v = _streaming.as_sample(x)
        if not self._state_ready:
            self.reset()
        lam, alarm, self.last = _streaming.update(
            self._settings(),
            self._null(),
            self._stream,
            v,  # type: ignore[arg-type]
        )
        return lam, alarm
