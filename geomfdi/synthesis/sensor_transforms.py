"""Sensor fault → pseudo-actuator fault: the three transforms of
``docs/theory/sensor-fault-transforms.md``.

The geometric algorithms act on state-side signatures ``L``.  A fault with an output
part ``Df`` (sensor faults, general faults, disturbances with ``Dd``) must first be
moved into the state equation:

``"paper"`` (Hou, Wen & Chen 2011, eq. 7–10)
    solve ``C f = Df`` (minimum-norm f; refuse when ``Df ∉ Im C``), ``L = Bf − A f``
    (discrete time: ``L = Bf − (A − I) f``, the same steady-state argument for
    ``x[k+1]``).  Decouples only constant faults in steady state (erratum 2 of Hou, Wen &
    Chen 2011 in ``docs/theory/errata.md``).
``"mvw"`` (Massoumnia–Verghese–Willsky 1989)
    two columns per component ``[Bf − A f, f]`` (the signal and its derivative; in
    discrete time its next sample): exact but conservative.
``"exact"`` (default)
    output filter ``z' = −a z + a y_F`` (discrete ``z⁺ = a z + (1 − a) y_F``) appended
    to the plant on the channels F that carry the output part of a fault to be
    decoupled or of a disturbance; the generator measures ``z`` instead of ``y_F`` (the
    filter becomes part of the generator) and the output part of a fault becomes the
    actuator signature ``[Bf; a Df_F]``.  The other channels R are read raw, so a
    target fault's output part on them stays a direct feedthrough ``Df_R``.  Filtering
    only F keeps the delivered order minimal (e.g. order 1 for sensor 1 of the example of
    Hou, Wen & Chen 2011).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from geomfdi._validation import as_choice, as_float
from geomfdi.errors import DesignError
from geomfdi.geometry.subspace import _norm2, pinv
from geomfdi.model.faults import fault_matrices
from geomfdi.model.plant import Plant, as_plant
from geomfdi.tolerance import get_rtol

__all__ = ["DesignModel", "pseudo_actuator_model", "METHODS", "default_filter_pole"]

METHODS = ("exact", "paper", "mvw")


def default_filter_pole(plant: Plant) -> float:
    """Default output-filter parameter ``a``.

    Continuous: ``a = max(1, rho(A))`` (rho: spectral radius), so the filter is not
    slower than the plant; discrete: ``a = 0.5``.
    """
    if plant.is_discrete:
        return 0.5
    rho = float(np.max(np.abs(np.linalg.eigvals(plant.A)))) if plant.n else 0.0
    return max(1.0, rho)


@dataclass
class DesignModel:
    """The model the geometry runs on: state-side signatures only.

    Attributes
    ----------
    A, B, C, Du : ndarray
        Dynamics, input, measured output and input feedthrough of the design model
        (augmented with the filter states for the exact transform).
    signatures : list of ndarray
        One ``(n_design, k_j)`` state signature per fault.
    disturbance : ndarray, (n_design, kd)
        Signature of the disturbances (always decoupled).
    method : str
    filter_pole : float or None
        ``a`` of the output filter when the plant was augmented, else None.
    n_plant : int
        Number of plant states (the first ``n_plant`` design states).
    notes : list of str
        What the transform chose (e.g. minimum-norm f_i when Ker C ≠ 0).
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    Du: np.ndarray
    signatures: list[np.ndarray]
    disturbance: np.ndarray
    method: str
    filter_pole: float | None
    n_plant: int
    dt: float
    notes: list[str] = field(default_factory=list)
    preimages: list[np.ndarray | None] = field(default_factory=list)

    feedthrough: list[np.ndarray] = field(default_factory=list)
    raw: tuple[int, ...] = ()
    filtered: tuple[int, ...] = ()

    @property
    def n(self) -> int:
        return self.A.shape[0]

    @property
    def augmented(self) -> bool:
        return self.filter_pole is not None and len(self.filtered) > 0


def _solve_output(C: np.ndarray, Df: np.ndarray, what: str) -> tuple[np.ndarray, bool]:
    """Minimum-norm f with ``C f = Df``; second value: True if f is not unique."""
    scale = _norm2(C)
    f = pinv(C, scale, what="C⁺") @ Df
    resid = np.linalg.norm(C @ f - Df, 2)
    if resid > get_rtol(max(C.shape)) * max(scale * _norm2(f), _norm2(Df), 1e-300) * 10:
        raise DesignError(
            f"{what}: its output signature is not in Im C, so C f = Df has no solution and the "
            "'paper'/'mvw' transform does not exist (use method='exact')",
            argument="faults",
        )
    s = np.linalg.svd(C, compute_uv=False)
    rank = int(np.count_nonzero(s > get_rtol(max(C.shape)) * scale))
    return f, rank < C.shape[1]


def _state_signature(A: np.ndarray, Bf: np.ndarray, f: np.ndarray, discrete: bool) -> np.ndarray:
    """``Bf − A f`` (discrete time: ``Bf − (A − I) f``), rounding-level columns set to 0.

    Continuous: ``x̄ = x + f m`` gives ``x̄' = A x̄ + (Bf − A f) m + f m'``; discrete:
    ``x̄[k+1] = A x̄[k] + (Bf − A f) m[k] + f m[k+1]``, i.e. ``(Bf − (A − I) f) m[k]`` plus
    ``f (m[k+1] − m[k])``.  The paper keeps the first term (exact for constant m); in
    discrete time the constant-fault term is ``f m[k]``, so the signature of the
    continuous formula applied to a sampled plant would not even decouple constant
    faults.  A column at rounding level (relative to ``‖Bf‖ + ‖A‖ ‖f‖``) is set to 0:
    ``A f = 0`` (a sensor on an integrator; discrete: ``A f = f``) must give an exactly
    invisible fault, not a direction made of rounding.
    """
    Aeff = A - np.eye(A.shape[0]) if discrete else A
    sig = Bf - Aeff @ f
    scale = np.linalg.norm(Bf, axis=0) + max(_norm2(A), 1.0 if discrete else 0.0) * np.linalg.norm(
        f, axis=0
    )
    tiny = np.linalg.norm(sig, axis=0) <= get_rtol(max(A.shape[0], 1)) * scale
    sig[:, tiny] = 0.0
    return sig


def pseudo_actuator_model(
    plant: Plant,
    faults: Any,
    method: str = "exact",
    *,
    decouple: Any = None,
    filter_pole: float | None = None,
) -> DesignModel:
    """Move the output part of faults into the state equation.

    See ``docs/theory/sensor-fault-transforms.md``.

    Parameters
    ----------
    plant : Plant
    faults : list of Fault
    method : {"exact", "paper", "mvw"}
    decouple : sequence of int, optional
        Faults to be decoupled; with the exact method only the output channels they
        (and the disturbances) touch are filtered.  Default: every fault.
    filter_pole : float, optional
        ``a`` of the output filter (exact method); default :func:`default_filter_pole`.

    Returns
    -------
    DesignModel
    """
    plant = as_plant(plant)
    method = as_choice(method, "method", METHODS)
    filter_pole = as_float(filter_pole, "filter_pole", allow_none=True)
    sigs = fault_matrices(faults, plant.n, plant.q)
    A, B, C, D = (np.array(plant.A), np.array(plant.B), np.array(plant.C), np.array(plant.D))
    Bd, Dd = np.array(plant.Bd), np.array(plant.Dd)
    notes: list[str] = []
    preimages: list[np.ndarray | None] = []
    n, q = plant.n, plant.q
    if method == "exact":
        dec = range(len(sigs)) if decouple is None else decouple
        touched = np.zeros(q, dtype=bool)
        for j in dec:
            touched |= np.any(sigs[j][1] != 0, axis=1)
        touched |= np.any(Dd != 0, axis=1) if Dd.size else False
        filt = tuple(int(i) for i in np.flatnonzero(touched))
        raw = tuple(int(i) for i in np.flatnonzero(~touched))
        if not filt:
            return DesignModel(
                A,
                B,
                C,
                D,
                [Bf for Bf, _ in sigs],
                Bd,
                method,
                None,
                n,
                plant.dt,
                ["no decoupled fault or disturbance has an output part: no filter needed"],
                [None] * len(sigs),
                [Df for _, Df in sigs],
                tuple(range(q)),
                (),
            )
        a = default_filter_pole(plant) if filter_pole is None else float(filter_pole)
        nf_ = len(filt)
        if plant.is_discrete:
            if not 0.0 <= a < 1.0:
                raise DesignError(
                    f"filter_pole: must lie in [0, 1) for a discrete plant, got {a}",
                    argument="filter_pole",
                )
            g, Azz = 1.0 - a, a * np.eye(nf_)
        else:
            if not a > 0 or not np.isfinite(a):
                raise DesignError(
                    f"filter_pole: must be > 0 for a continuous plant, got {a}",
                    argument="filter_pole",
                )
            g, Azz = a, -a * np.eye(nf_)
        fi, ri = list(filt), list(raw)
        Aa = np.block([[A, np.zeros((n, nf_))], [g * C[fi], Azz]])
        Ba = np.vstack([B, g * D[fi]])
        Ca = np.block([[C[ri], np.zeros((len(ri), nf_))], [np.zeros((nf_, n)), np.eye(nf_)]])
        Du = np.vstack([D[ri], np.zeros((nf_, plant.m))])
        La = [np.vstack([Bf, g * Df[fi]]) for Bf, Df in sigs]
        Lda = np.vstack([Bd, g * Dd[fi]])
        ft = [np.vstack([Df[ri], np.zeros((nf_, Df.shape[1]))]) for _, Df in sigs]
        notes.append(
            f"output filter on channels {list(filt)} (a = {a:g}); the generator reads them "
            f"through it and channels {list(raw)} raw"
        )
        return DesignModel(
            Aa,
            Ba,
            Ca,
            Du,
            La,
            Lda,
            method,
            a,
            n,
            plant.dt,
            notes,
            [None] * len(sigs),
            ft,
            raw,
            filt,
        )
    # paper / mvw: C f = Df
    Ls = []
    for k, (Bf, Df) in enumerate(sigs):
        if not np.any(Df != 0):
            Ls.append(Bf)
            preimages.append(None)
            continue
        f, nonunique = _solve_output(C, Df, f"faults[{k}]")
        if nonunique:
            notes.append(
                f"faults[{k}]: C f = Df has many solutions (Ker C ≠ 0); the minimum-norm f "
                "was used, and S* may depend on this choice"
            )
        preimages.append(f)
        sig = _state_signature(A, Bf, f, plant.is_discrete)
        Ls.append(np.hstack([sig, f]) if method == "mvw" else sig)
    if np.any(Dd != 0):
        f, _ = _solve_output(C, Dd, "Dd (disturbance)")
        sig = _state_signature(A, Bd, f, plant.is_discrete)
        Ld = np.hstack([sig, f]) if method == "mvw" else sig
    else:
        Ld = Bd
    zeros = [np.zeros((q, L.shape[1])) for L in Ls]  # one column per signature column
    return DesignModel(
        A, B, C, D, Ls, Ld, method, None, n, plant.dt, notes, preimages, zeros, tuple(range(q)), ()
    )
