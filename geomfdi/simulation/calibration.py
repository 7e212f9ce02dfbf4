"""Thresholds calibrated on noise-only simulations (:func:`calibrate_threshold`).

Lives with the simulator (it simulates); the quantile itself is
:meth:`geomfdi.evaluation.decision.Threshold.from_residuals`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi._threads import limit_blas_threads
from geomfdi._validation import as_float
from geomfdi.errors import GeomFDIError
from geomfdi.evaluation.decision import Threshold
from geomfdi.limits import check_runs
from geomfdi.simulation.batch import simulate_batch

__all__ = ["calibrate_threshold"]


@limit_blas_threads
def calibrate_threshold(
    plant: Any,
    bank: Any,
    t: Any,
    *,
    noise: Any,
    false_alarm_rate: float,
    runs: int = 1,
    statistic: str = "abs",
    window: int = 1,
    per: str = "residual",
    skip: float = 0.0,
    **simulate_options: Any,
) -> Threshold:
    """Thresholds from noise-only simulations at a chosen false-alarm rate.

    Runs :func:`geomfdi.simulation.simulate_batch` without faults (``runs`` seeds
    derived from ``noise.seed``) and calls :meth:`Threshold.from_residuals`.

    Parameters
    ----------
    plant, bank, t
        As for :func:`geomfdi.simulate`.
    noise : Noise
        Must contain measurement, process or noise-input noise.
    false_alarm_rate : float
        Per-sample false-alarm rate ``alpha``.
    runs : int
        Number of noise-only runs pooled.
    statistic, window, per
        See :meth:`Threshold.from_residuals`.
    skip : float
        Seconds at the start of each run left out of the quantile.
    **simulate_options
        Passed on (``u``, ``controller``, ``x0``, ``d``, ``hold``).

    Returns
    -------
    Threshold
    """
    if all(getattr(noise, k, None) is None for k in ("measurement", "process", "inputs")):
        raise GeomFDIError(
            "noise: a noise-only calibration needs a geomfdi Noise with measurement, "
            f"process or input noise, got {noise!r:.60}",
            argument="noise",
        )
    runs = check_runs(runs)
    skip = as_float(skip, "skip", minimum=0.0)
    batch = simulate_batch(
        plant,
        bank,
        t,
        runs=runs,
        noise=noise,
        store="residuals",
        progress=False,
        **simulate_options,
    )
    k_skip = int(np.searchsorted(batch.t - batch.t[0], float(skip) - 1e-12))
    if k_skip >= batch.t.size:
        raise GeomFDIError(
            f"skip: {skip:g} s leaves no sample of a run of {batch.t[-1] - batch.t[0]:g} s",
            argument="skip",
        )
    if batch.residuals is not None and not np.any(batch.residuals[:, :, k_skip:]):
        raise GeomFDIError(
            "noise: the noise-only residuals are identically zero (zero noise, or noise no "
            "residual sees): every threshold would be +inf, a detector that never alarms",
            argument="noise",
        )
    return Threshold.from_residuals(
        batch.residuals,
        false_alarm_rate,
        statistic=statistic,
        window=window,
        per=per,
        skip=k_skip,
    )
