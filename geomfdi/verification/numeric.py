"""Verification of residual generators on the physical model.

See the user guide, *Theory: verification* (``docs/theory/verification.md``).

**Leakage** (every decoupled fault, the known input u and the disturbances d) is the
coordinate-free angle measure

    ‖Q(s) V_x(s)‖ / (‖Q(s)‖ ‖V_x(s)‖),   Q(s) = [G_y(s), G_u(s)],   V_x = [G_x(s); I_x]

at random frequencies (``s = iω`` with ω at the scale of the spectra of plant and
generator; ``z = e^{iθ}`` in discrete time; ``I_x = I`` for u, 0 otherwise): the cosine
between the residual's row space and the channel's response in ``[y; u]``, i.e. the
leakage of the frequency response a residual shows in time.  (Off the stability
boundary a row that moves many unstable eigenvalues through one output is exponentially
small, so rounding of any realisation would read as leakage there.)  It does not change
under any change of the plant's or the generator's state coordinates or a scaling of
the residual, so a badly scaled realisation cannot hide a leak; a design fails above ``tol`` (1e-9).
**Stability**: the generator's poles are stable and the plant's unstable invariant
eigenvalues are unobservable from r (``‖G_y(μ) C v‖ / (‖G_y(μ)‖ ‖C v‖)`` = 0 for every
unstable eigenpair (μ, v), i.e. the residue of the pole μ vanishes).
**Targets**: the relative gain of :mod:`geomfdi.generators.gains` (random points, with
the orthonormal Krylov test as second opinion).  :func:`verify_symbolic` converts the
delivered matrices exactly (binary floats are rationals) and proves the zeros.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from geomfdi._threads import limit_blas_threads
from geomfdi._validation import as_choice, as_float, as_sequence_of
from geomfdi.errors import GeomFDIError
from geomfdi.generators.gains import LEAK_TOL, Composite, PlantFactor, _gains, fault_gains
from geomfdi.generators.generator import ResidualBank, ResidualGenerator
from geomfdi.model.faults import Fault, SensorFault, fault_matrices
from geomfdi.model.plant import Plant, as_plant

VERIFY_TOL = 1e-9
"""Largest leakage angle accepted by :func:`verify`."""

UNSTABLE_TOL = 1e-6
"""Largest relative residue of an unstable plant pole in the residual.  The residue is
evaluated at the pole itself, where a correct generator has a transmission zero: rounding
there is amplified by the zero's conditioning, so this bound is looser than
``VERIFY_TOL`` (a true unstable leak gives a residue of order 1)."""

__all__ = [
    "VERIFY_TOL",
    "verify",
    "VerificationReport",
    "fault_gains",
    "LEAK_TOL",
]


@dataclass
class VerificationReport:
    """Numeric verification of a bank (or one generator) on the physical model.

    Attributes
    ----------
    gain : ndarray (rows, faults)
        Relative gain from every fault to every residual (0 for missing rows).
    leakage : ndarray (rows, faults)
        ``gain`` where the design asks for zero, 0 elsewhere.
    target_gain : ndarray (rows, faults)
        ``gain`` where the design asks for a response, 0 elsewhere.
    input_leakage : ndarray (rows,)
        Relative gain from u and d (must be zero).
    dc_gain : ndarray (rows, faults)
        DC gain (``inf`` at an integrating channel).
    identities : list of dict
        Relative residuals of the construction identities per row (empty if missing).
    missing : list of int
        Requested rows without a generator.
    tol : float
        Threshold for "zero" (leakage; a target must be seen above it, see Notes of
        :func:`verify`).
    ok : bool
        **The requested structure is achieved**: no requested row is missing
        (:attr:`complete`) and every delivered row is correct (:attr:`rows_ok`).
    rows_ok : bool
        Every decoupling holds, no input leaks, every target is seen above rounding
        level — over the rows whose generator exists.
    target_angle : ndarray (rows, faults)
        The angle measure of the leakage applied to the targets (0 elsewhere): a target
        whose response on the frequency response is at or below ``tol`` is not seen.
    """

    gain: np.ndarray
    leakage: np.ndarray
    target_gain: np.ndarray
    input_leakage: np.ndarray
    dc_gain: np.ndarray
    identities: list[dict[str, float]]
    missing: list[int]
    tol: float
    ok: bool
    method: str = "points"
    details: list[str] = field(default_factory=list)
    stable: np.ndarray | None = None
    unstable_leakage: np.ndarray | None = None
    rows_ok: bool = True
    target_angle: np.ndarray | None = None

    @property
    def complete(self) -> bool:
        """No requested row is missing (part of :attr:`ok`)."""
        return not self.missing

    def __repr__(self) -> str:
        return (
            f"VerificationReport(ok={self.ok}, max leakage={np.max(self.leakage, initial=0):.3g}, "
            f"max input leakage={np.max(self.input_leakage, initial=0):.3g}, "
            f"missing={self.missing})"
        )


def _unpack(obj: Any, plant: Plant, faults: Any):
    if isinstance(obj, ResidualBank):
        gens = obj.generators
        faults = obj.faults if faults is None else list(faults)
        req = obj.requested
    elif isinstance(obj, ResidualGenerator):
        gens = [obj]
        if faults is None:
            faults = obj.info.get("faults") or [SensorFault(i) for i in range(plant.q)]
        faults = list(faults)
        req = np.zeros((1, len(faults)), dtype=bool)
        req[0, list(obj.target)] = True
        if not obj.target and not obj.decoupled:
            req[0] = True
    else:
        raise GeomFDIError(
            f"bank_or_generator: expected a ResidualBank or ResidualGenerator, got "
            f"{type(obj).__name__}",
            argument="bank_or_generator",
        )
    plant = as_plant(plant)
    if req.shape[1] != len(faults):
        raise GeomFDIError(
            f"faults: the design has {req.shape[1]} faults, got {len(faults)}", argument="faults"
        )
    for g in gens:
        if g is not None and (g.q != plant.q or g.m != plant.m):
            raise GeomFDIError(
                f"plant: generator reads {g.q} outputs and {g.m} inputs, the plant has "
                f"{plant.q} and {plant.m}",
                argument="plant",
            )
    return gens, faults, req


def _row_measures(
    g: ResidualGenerator,
    plant: Plant,
    factor: PlantFactor,
    faults: Sequence[Fault],
    sigs: list[tuple[np.ndarray, np.ndarray]],
    req: np.ndarray,
    method: str,
    r: int,
    gain: np.ndarray,
    dc: np.ndarray,
    inp: np.ndarray,
    unst: np.ndarray,
    tang: np.ndarray,
) -> None:
    """Fault gains, input leakage, unstable-mode angle and target angles of row ``r``
    (in place)."""
    comp = Composite(g, plant, factor)
    gain[r], dc[r] = _gains(comp, sigs, method)
    for j in np.flatnonzero(req & (gain[r] <= LEAK_TOL)):
        # a target at rounding level under the random-point measure (a badly scaled
        # generator): second opinion from the orthonormal Krylov test, as in the design
        gain[r, j] = max(
            gain[r, j], fault_gains(g, plant, [faults[j]], method="krylov", factor=factor)[0][0]
        )
    ang = comp.angle_gains([(Bf, Df, False) for Bf, Df in sigs])
    tang[r] = np.where(req, ang, 0.0)
    gain[r] = np.where(req, gain[r], ang)
    chans = []
    if plant.m:
        chans.append((plant.B, plant.D, True))
    if plant.nd:
        chans.append((plant.Bd, plant.Dd, False))
    inp[r] = float(np.max(comp.angle_gains(chans))) if chans else 0.0
    unst[r] = comp.unstable_angle(factor)


@limit_blas_threads
def verify(
    bank_or_generator: ResidualBank | ResidualGenerator,
    plant: Plant,
    faults: Sequence[Fault] | None = None,
    *,
    method: str = "points",
    tol: float = VERIFY_TOL,
) -> VerificationReport:
    """Check every generator's decouplings and detections on the physical model.

    Parameters
    ----------
    bank_or_generator : ResidualBank or ResidualGenerator
    plant : Plant
    faults : list of Fault, optional
        Default: the bank's faults (or the generator's design faults).
    method : {"points", "krylov"}
        Random-point evaluation of the transfer (default) or orthonormal Krylov test.
        A target whose random-point gain is at rounding level gets the Krylov test as
        a second opinion (its relative gain is then the larger of the two).
    tol : float
        Relative gain counted as zero.

    Returns
    -------
    VerificationReport
        ``leakage`` and ``input_leakage`` are the angle measure (module Notes);
        ``stable[r]``: the generator is stable; ``unstable_leakage[r]``: angle between
        the residual and the plant's unstable modes (must be 0).  Any generator gives a
        report: one whose transfer cannot be evaluated (singular, or beyond float range)
        gets ``nan`` measures, ``ok = False`` and the reason in ``details``; an unstable
        one ``stable[r] = False``.

    Notes
    -----
    See the user guide, *Theory: verification* (``docs/theory/verification.md``).
    ``ok`` means "the requested structure is achieved": a bank with a missing row is
    never ``ok`` (``rows_ok`` tells whether the delivered rows are correct).  A target
    is seen when its random-point gain is above rounding **and** its angle on the
    frequency response (the leakage measure) is above ``tol``: a response that small
    would count as zero on a decoupled channel, so it cannot count as detection (a
    row blind to its targets is never ``ok``, whatever the rank tolerance of the
    design).  The transfer from sensor i is
    ``−M (sI − F)⁻¹ E e_i − H e_i`` composed with the plant; from u and d it must vanish.
    Unlike the paper's check on its pseudo-actuator model, this one uses the measured y,
    so the paper design's transient leakage (Erratum 2) is visible.
    """
    tol = as_float(tol, "tol")
    if not 0 < tol < 1:
        raise GeomFDIError(f"tol: must be a number in (0, 1), got {tol!r}", argument="tol")
    method = as_choice(method, "method", ("points", "krylov"))
    if faults is not None:
        faults = as_sequence_of(faults, "faults", Fault)
    plant = as_plant(plant)
    gens, faults, req = _unpack(bank_or_generator, plant, faults)
    rows, nf = req.shape
    gain = np.zeros((rows, nf))
    dc = np.zeros((rows, nf))
    inp = np.zeros(rows)
    stable = np.ones(rows, dtype=bool)
    unst = np.zeros(rows)
    tang = np.zeros((rows, nf))
    idents: list[dict[str, float]] = []
    missing, details = [], []
    unusable: dict[int, str] = {}  # rows whose measures could not be computed
    factor = PlantFactor(plant)
    sigs = fault_matrices(faults, plant.n, plant.q)
    for r, g in enumerate(gens):
        if g is None:
            missing.append(r)
            idents.append({})
            continue
        try:
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                _row_measures(g, plant, factor, faults, sigs, req[r], method, r,
                              gain, dc, inp, unst, tang)  # fmt: skip
        except np.linalg.LinAlgError as exc:  # a generator pole on a plant pole, say
            gain[r], dc[r], inp[r], unst[r] = np.nan, np.nan, np.nan, np.nan
            unusable[r] = f"singular transfer ({exc})"
        if r not in unusable and not (
            np.isfinite(gain[r]).all() and np.isfinite(inp[r]) and np.isfinite(unst[r])
        ):
            unusable[r] = "its transfer overflows (entries too large to evaluate)"
        try:
            lam = g.poles
        except np.linalg.LinAlgError:  # eigenvalues did not converge: not shown stable
            lam = np.array([np.nan])
        stable[r] = bool(np.all(np.abs(lam) < 1) if plant.dt > 0 else np.all(lam.real < 0))
        idents.append(dict(g.info.get("identities", {})))
    leak = np.where(req, 0.0, gain)
    tgain = np.where(req, gain, 0.0)
    ok = True
    for r, g in enumerate(gens):
        if g is None:
            continue
        if r in unusable:
            ok = False
            details.append(f"row {r}: not verified: {unusable[r]}")
        for j in range(nf):
            if not req[r, j] and gain[r, j] > tol:
                ok = False
                details.append(f"row {r}: leaks fault {j} (relative gain {gain[r, j]:.3g})")
            if req[r, j] and gain[r, j] <= LEAK_TOL:
                ok = False
                details.append(f"row {r}: does not see fault {j}")
            elif req[r, j] and tang[r, j] <= tol:
                ok = False
                details.append(
                    f"row {r}: sees fault {j} only at rounding level (angle {tang[r, j]:.2g} "
                    f"<= {tol:g} on the frequency response)"
                )
        if inp[r] > tol:
            ok = False
            details.append(f"row {r}: input leakage {inp[r]:.3g}")
        if not stable[r]:
            ok = False
            details.append(f"row {r}: unstable generator (poles {g.poles.tolist()})")
        if unst[r] > UNSTABLE_TOL:
            ok = False
            details.append(f"row {r}: unstable plant modes reach the residual ({unst[r]:.3g})")
        if any(v > 1e-8 for v in idents[r].values()):
            ok = False
            details.append(f"row {r}: identities {idents[r]}")
    for r in missing:
        details.append(f"row {r}: missing (requested, not delivered)")
    return VerificationReport(
        gain,
        leak,
        tgain,
        inp,
        dc,
        idents,
        missing,
        tol,
        ok and not missing,
        method,
        details,
        stable,
        unst,
        rows_ok=ok,
        target_angle=tang,
    )


# ----------------------------------------------------------------- exact
