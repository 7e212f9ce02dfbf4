"""The fault-to-noise gap of residual generators, measured on the physical model.

A generator in series with the plant has the internal form (Varga 2017, §3.1)

    r = R_f(λ) f + R_w(λ) w        (+ R_u u + R_d d, zero for a correct design)

with the transfers of the composite of :class:`geomfdi.generators.gains.Composite` (the
same realisation that :func:`geomfdi.verify` evaluates)::

    A_c = [[A, 0], [−E C, F]],   C_c = [−H C, M],
    R_f:  B_c = [B_f; −E D_f],   D_c = −H D_f        R_w:  B_f, D_f → B_w, D_w.

For each row ``i`` of a bank (one generator, possibly with several residual components)
with target faults ``T_i`` (the requested structure) and the others ``N_i``:

    β_i = H₋ index of R_f,T_i          (min over the target faults of ‖R_f,j‖∞, or over
                                        a frequency list / band: :func:`hminus_index`)
    γ_i = ‖[R_f,N_i  R_w]‖∞            (Varga's ``fdif2ngap`` with a structure matrix)
    gap_i = β_i / γ_i                  (``inf`` when γ_i = 0, 0 when β_i = 0)

For a design that decouples the non-target faults exactly (every geomfdi design),
``R_f,N_i`` is zero to rounding and γ_i is ``‖R_w‖∞``: a non-target transfer below
``LEAK_TOL`` relative to β_i is not counted (its size is reported in ``nontarget``).  γ is
always the full H∞ norm, also when β is taken over frequencies: a threshold must bound the
noise at every frequency (:func:`geomfdi.gap_threshold`).

The H∞ norms are computed by :func:`geomfdi.hinf_norm` (two-step Hamiltonian / symplectic
pencil algorithm), so the gap is measured independently of how a generator was designed.
See the user guide, *Theory: approximate synthesis* (``docs/theory/approximate-synthesis.md``).

References
----------
Varga (2017), *Solving Fault Diagnosis Problems*, Springer, §3.3 (H₋ index), §5.3 (the
fault-to-noise gap), and FDITOOLS ``fdif2ngap``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from geomfdi._threads import limit_blas_threads
from geomfdi._validation import as_bool, as_choice, as_sequence_of
from geomfdi.generators.norms import UnstableSystemError, hinf_norm, hminus_index
from geomfdi.model.faults import Fault, fault_matrices
from geomfdi.model.plant import Plant, as_plant

__all__ = ["FaultToNoiseGap", "fault_to_noise_gap", "LEAK_TOL"]

LEAK_TOL = 1e-9
"""Non-target fault transfer (relative to β) counted as zero in γ."""


@dataclass(frozen=True)
class FaultToNoiseGap:
    """Fault-to-noise gaps of a bank (one entry per row; module docstring).

    Attributes
    ----------
    beta : ndarray (rows,)
        H₋ index of the target-fault transfer.
    gamma : ndarray (rows,)
        ``‖[R_f,non-target  R_w]‖∞`` (``‖R_w‖∞`` for an exact design).
    gap : ndarray (rows,)
        ``beta / gamma`` (``inf`` for ``gamma = 0``).
    beta_frequency, gamma_frequency : ndarray (rows,)
        Where β (the weakest target's peak, or the minimum over the frequencies) and γ
        (the peak) are attained, rad/s (``inf``: the feedthrough, continuous time).
    weakest : ndarray of int (rows,)
        Index (into ``faults``) of the target fault that attains β (``-1``: none, or
        ``measure="singular"``).
    nontarget : ndarray (rows,)
        ``‖R_f,non-target‖∞`` (0 when every non-target fault is decoupled exactly).
    noise_gamma : ndarray (rows,)
        ``‖R_w‖∞`` alone.
    faults : list of Fault
    missing : list of int
        Rows without a generator (all values 0 there).
    measure : str
        How β is taken: ``"columns"`` or ``"singular"`` (:func:`geomfdi.hminus_index`).
    frequencies : ndarray or None
    band : tuple or None
    gamma_peak : ndarray (rows,) or None
        With ``peak=True``: the peak-to-peak gain from ``w`` (each component bounded by
        δ) to the Euclidean norm of the row's residual, ``sqrt(Σ_i g_i²)`` with ``g_i``
        the L1 gains of :func:`geomfdi.generators.norms.peak_gain`.
    """

    beta: np.ndarray
    gamma: np.ndarray
    gap: np.ndarray
    beta_frequency: np.ndarray
    gamma_frequency: np.ndarray
    weakest: np.ndarray
    nontarget: np.ndarray
    noise_gamma: np.ndarray
    faults: list[Any]
    missing: list[int] = field(default_factory=list)
    measure: str = "columns"
    frequencies: np.ndarray | None = None
    band: tuple[float, float] | None = None
    gamma_peak: np.ndarray | None = None

    @property
    def min_gap(self) -> float:
        """The smallest gap over the rows that exist (the bank's weakest row)."""
        ok = [r for r in range(self.gap.size) if r not in self.missing]
        return float(np.min(self.gap[ok])) if ok else 0.0

    def __repr__(self) -> str:
        rows = ", ".join(f"{g:.4g}" for g in self.gap)
        return f"FaultToNoiseGap(gap=[{rows}], missing={self.missing})"


def _stack(chans: list[tuple[np.ndarray, np.ndarray]], nc: int, p: int):
    """Channels ``(B_c, D_c)`` side by side, and the column groups of each."""
    if not chans:
        return np.zeros((nc, 0)), np.zeros((p, 0)), []
    widths = [Bc.shape[1] for Bc, _ in chans]
    edges = np.cumsum([0, *widths])
    groups = [list(range(edges[k], edges[k + 1])) for k in range(len(chans))]
    return np.hstack([Bc for Bc, _ in chans]), np.hstack([Dc for _, Dc in chans]), groups


@limit_blas_threads
def fault_to_noise_gap(
    generator_or_bank: Any,
    plant: Plant,
    faults: Sequence[Fault] | None = None,
    *,
    frequencies: Any = None,
    band: Any = None,
    measure: str = "columns",
    peak: bool = False,
) -> FaultToNoiseGap:
    """β, γ and the fault-to-noise gap β/γ of a generator or of each row of a bank.

    Parameters
    ----------
    generator_or_bank : ResidualGenerator or ResidualBank
    plant : Plant
        The physical plant, with its noise inputs ``Bw, Dw`` (none: γ = 0, gap ``inf``).
    faults : list of Fault, optional
        Default: the bank's faults (or the generator's design faults).
    frequencies : array_like, optional
        β as the minimum over these frequencies (rad/s) instead of the H∞ norms.
    band : (w1, w2), optional
        β as the minimum over this band (rad/s).
    measure : {"columns", "singular"}
        With ``frequencies`` or ``band``: the smallest target-fault column norm
        (FDITOOLS ``fdhinfminus``) or the smallest singular value (Ding 2008).
    peak : bool
        Also the peak-to-peak gain from the noise inputs (``gamma_peak``, for thresholds
        under a peak bound on ``w``: :func:`geomfdi.gap_threshold`).

    Returns
    -------
    FaultToNoiseGap

    Raises
    ------
    UnstableSystemError
        Naming ``generator_or_bank`` when a generator's internal form is unstable.

    Notes
    -----
    Varga (2017), §5.3; FDITOOLS ``fdif2ngap`` with the structure matrix (module
    docstring).  Continuous and discrete time (``z = e^{iω dt}``).

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> p = gf.Plant([[-1.0]], None, [[1.0], [1.0]], Bw=[[1.0]], Dw=[[0.0], [0.1]])
    >>> g = gf.ResidualGenerator(np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((0, 0)),
    ...                          np.zeros((1, 0)), [[1.0, -1.0]], np.zeros((1, 0)),
    ...                          target=(0, 1))
    >>> r = gf.fault_to_noise_gap(g, p, [gf.SensorFault(0), gf.SensorFault(1)])
    >>> round(float(r.beta[0]), 12), round(float(r.gamma[0]), 12)
    (1.0, 0.1)
    """
    from geomfdi.generators.gains import Composite, PlantFactor
    from geomfdi.generators.norms import peak_gain
    from geomfdi.verification.numeric import _unpack

    peak = as_bool(peak, "peak")

    measure = as_choice(measure, "measure", ("columns", "singular"))
    if faults is not None:
        faults = as_sequence_of(faults, "faults", Fault)
    plant = as_plant(plant)
    gens, faults, req = _unpack(generator_or_bank, plant, faults)
    rows = req.shape[0]
    out = {
        k: np.zeros(rows) for k in ("beta", "gamma", "gap", "bf", "gf", "nontarget", "noise_gamma")
    }
    weakest = np.full(rows, -1, dtype=int)
    gpeak = np.zeros(rows) if peak else None
    missing: list[int] = []
    factor = PlantFactor(plant)
    sigs = fault_matrices(faults, plant.n, plant.q)
    dt = plant.dt
    for r, g in enumerate(gens):
        if g is None:
            missing.append(r)
            continue
        comp = Composite(g, plant, factor)
        Ac, Cc = comp._composite()["Ac"], comp._composite()["Cc"]
        nc, p = Ac.shape[0], Cc.shape[0]
        fch = [comp.channel(Bf, Df)[:2] for Bf, Df in sigs]
        tgt = [j for j in range(len(sigs)) if req[r, j]]
        non = [j for j in range(len(sigs)) if not req[r, j]]
        try:
            if tgt:
                Bt, Dt, groups = _stack([fch[j] for j in tgt], nc, p)
                hm = hminus_index(
                    Ac, Bt, Cc, Dt, dt,
                    columns=groups, frequencies=frequencies, band=band, measure=measure,
                )  # fmt: skip
                out["beta"][r], out["bf"][r] = hm.value, hm.frequency
                weakest[r] = tgt[hm.column] if hm.column >= 0 else -1
            wch = [comp.channel(plant.Bw, plant.Dw)[:2]] if plant.nw else []
            Bw, Dw, _ = _stack(wch, nc, p)
            nw = hinf_norm(Ac, Bw, Cc, Dw, dt) if Bw.shape[1] else None
            Bn, Dn, _ = _stack([fch[j] for j in non], nc, p)
            nt = hinf_norm(Ac, Bn, Cc, Dn, dt) if Bn.shape[1] else None
            if gpeak is not None and Bw.shape[1]:
                gpeak[r] = float(np.linalg.norm(peak_gain(Ac, Bw, Cc, Dw, dt)))
        except UnstableSystemError as exc:
            raise UnstableSystemError(
                f"generator_or_bank: row {r}: the internal form is unstable ({exc})",
                argument="generator_or_bank",
            ) from exc
        out["noise_gamma"][r] = nw.value if nw is not None else 0.0
        out["nontarget"][r] = nt.value if nt is not None else 0.0
        gamma, gfreq = out["noise_gamma"][r], nw.frequency if nw is not None else 0.0
        if nt is not None and nt.value > LEAK_TOL * max(out["beta"][r], gamma):
            both = hinf_norm(Ac, np.hstack([Bn, Bw]), Cc, np.hstack([Dn, Dw]), dt)
            gamma, gfreq = both.value, both.frequency
        out["gamma"][r], out["gf"][r] = gamma, gfreq
        beta = out["beta"][r]
        out["gap"][r] = np.inf if gamma == 0 and beta > 0 else (beta / gamma if beta else 0.0)
    freqs = None if frequencies is None else np.atleast_1d(np.asarray(frequencies, dtype=float))
    return FaultToNoiseGap(
        beta=out["beta"],
        gamma=out["gamma"],
        gap=out["gap"],
        beta_frequency=out["bf"],
        gamma_frequency=out["gf"],
        weakest=weakest,
        nontarget=out["nontarget"],
        noise_gamma=out["noise_gamma"],
        faults=list(faults),
        missing=missing,
        measure=measure,
        frequencies=freqs,
        band=None if band is None else (float(band[0]), float(band[1])),
        gamma_peak=gpeak,
    )
