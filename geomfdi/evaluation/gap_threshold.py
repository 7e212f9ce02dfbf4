"""Thresholds from the fault-to-noise gap: bounded noise, worst case (no statistics).

For a residual ``r = R_f f + R_w w`` (a correct design: u, d and the non-target faults
decoupled) and noise of bounded size ``‖w‖ ≤ δ`` (Varga 2017, §3.6; Ding 2008):

* **energy** (``‖w‖₂ ≤ δ``, the L2 norm over the time axis or an evaluation window):
  ``‖R_w w‖₂ ≤ γ δ`` with ``γ = ‖R_w‖∞``, so the threshold ``J_th = γ δ`` on the
  evaluation ``J = ‖r‖₂`` gives no false alarm for any such noise.  On a sampled record
  the windowed sum of squares of :class:`geomfdi.evaluation.statistics.ChiSquareTest`
  is ``S = Σ ‖r[k]‖² ≈ J² / h`` (step ``h``; ``J² = S`` in discrete time), so
  ``S_th = J_th² / h``.
* **peak** (``|w_j(t)| ≤ δ`` for every component and time): ``|r_i(t)| ≤ g_i δ`` with the
  peak-to-peak (L1) gains ``g_i`` of ``R_w`` (:func:`geomfdi.generators.norms.peak_gain`),
  so ``J_th = sqrt(Σ_i g_i²) δ`` on ``J = sup_t ‖r(t)‖`` (the ``|r|`` rows of
  :func:`geomfdi.simulate`).  The H∞ norm does not bound peaks; this bound does.

**Smallest guaranteed-detectable fault** (Varga 2017, §3.6): ``‖r‖ ≥ ‖R_f f‖ − ‖R_w w‖ ≥
‖R_f f‖ − J_th``, so a fault is detected whenever ``‖R_f f‖ > 2 J_th``; with
``‖R_f f‖ ≥ β ‖f‖`` this holds for every fault of size

    ‖f‖ > 2 J_th / β = 2 δ γ / β = 2 δ / gap.

``‖R_f f‖ ≥ β ‖f‖`` holds for every fault signal when β is the smallest singular value over
all frequencies (``fault_to_noise_gap(..., band=(0, ω_max), measure="singular")``, p ≥ m);
with the default β (the smallest target column's H∞ norm) it holds for a single fault whose
energy lies at the frequency where its column peaks (``beta_frequency``: a step fault for
0), and in the peak case for the steady-state amplitude of a persistent sinusoid or step
at that frequency.

The **stochastic route** is the other one: Gaussian noise with a covariance
(:class:`geomfdi.Noise`), the residual's noise model
(:func:`geomfdi.evaluation.covariance.residual_noise_model`) and an exact χ² threshold for
a chosen false-alarm rate (:meth:`ChiSquareTest.design
<geomfdi.evaluation.statistics.ChiSquareTest.design>`).  The gap threshold never raises a
false alarm for noise inside the bound, at the price of being conservative for noise that
is random rather than worst-case.  See the user guide, *Evaluation and decisions*
(``docs/guide/evaluation.md``) and *Theory: approximate synthesis*
(``docs/theory/approximate-synthesis.md``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from geomfdi._validation import as_choice, as_float
from geomfdi.errors import GeomFDIError

__all__ = ["GapThreshold", "gap_threshold"]


@dataclass(frozen=True)
class GapThreshold:
    """Thresholds and guaranteed-detectable fault sizes per bank row.

    Attributes
    ----------
    threshold : ndarray (rows,)
        ``J_th = γ δ`` (energy) or ``J_th = g δ`` (peak).
    min_fault : ndarray (rows,)
        ``2 J_th / β``: faults larger than this are detected (module docstring); ``inf``
        where β = 0, 0 where ``J_th = 0``.
    delta : float
    norm : str
        ``"energy"`` or ``"peak"``.
    """

    threshold: np.ndarray
    min_fault: np.ndarray
    delta: float
    norm: str

    def sum_of_squares(self, step: float) -> np.ndarray:
        """``J_th² / step``: the same threshold on a windowed sum of squares of samples
        ``step`` apart (energy norm only; ``step = 1`` in discrete time)."""
        if self.norm != "energy":
            raise GeomFDIError(
                "norm: a sum-of-squares threshold needs the energy norm", argument="norm"
            )
        step = as_float(step, "step")
        if not step > 0:
            raise GeomFDIError(f"step: must be > 0, got {step}", argument="step")
        return self.threshold**2 / step


def gap_threshold(gap: Any, delta: float, *, norm: str = "energy") -> GapThreshold:
    """Threshold ``J_th`` and smallest guaranteed-detectable fault ``2 J_th / β``.

    Parameters
    ----------
    gap : FaultToNoiseGap
        From :func:`geomfdi.fault_to_noise_gap` (with ``peak=True`` for ``norm="peak"``).
    delta : float
        The noise bound ``δ >= 0``: ``‖w‖₂ ≤ δ`` (energy) or ``|w_j(t)| ≤ δ`` (peak).
    norm : {"energy", "peak"}
        Energy: ``J_th = γ δ`` with ``γ`` the H∞ gain; peak: the peak-to-peak gain.

    Returns
    -------
    GapThreshold

    Notes
    -----
    Varga (2017), §3.6 (threshold selection for bounded noise); the module docstring
    states when the fault-size guarantee holds.

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> p = gf.Plant([[-1.0]], None, [[1.0], [1.0]], Bw=[[1.0]], Dw=[[0.0], [0.1]])
    >>> g = gf.ResidualGenerator(np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((0, 0)),
    ...                          np.zeros((1, 0)), [[1.0, -1.0]], np.zeros((1, 0)),
    ...                          target=(0, 1))
    >>> r = gf.fault_to_noise_gap(g, p, [gf.SensorFault(0), gf.SensorFault(1)])
    >>> th = gf.gap_threshold(r, delta=0.5)
    >>> round(float(th.threshold[0]), 12), round(float(th.min_fault[0]), 12)
    (0.05, 0.1)
    """
    norm = as_choice(norm, "norm", ("energy", "peak"))
    delta = as_float(delta, "delta")
    if not (np.isfinite(delta) and delta >= 0):
        raise GeomFDIError(f"delta: must be finite and >= 0, got {delta}", argument="delta")
    beta = np.asarray(getattr(gap, "beta", None), dtype=float)
    if beta.ndim != 1:
        raise GeomFDIError(
            "gap: expected the result of fault_to_noise_gap (beta, gamma per row)",
            argument="gap",
        )
    if norm == "energy":
        gain = np.asarray(gap.gamma, dtype=float)
    else:
        if getattr(gap, "gamma_peak", None) is None:
            raise GeomFDIError(
                "gap: the peak norm needs the peak-to-peak gains; compute the gap with "
                "fault_to_noise_gap(..., peak=True)",
                argument="gap",
            )
        gain = np.asarray(gap.gamma_peak, dtype=float)
    thr = gain * delta
    with np.errstate(divide="ignore", invalid="ignore"):
        fmin = np.where(thr == 0, 0.0, np.where(beta > 0, 2.0 * thr / beta, np.inf))
    return GapThreshold(thr, fmin, delta, norm)
