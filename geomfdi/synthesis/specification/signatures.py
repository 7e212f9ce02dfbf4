"""Achievable fault signatures (structure-matrix rows) of a plant, before any design.

See the user guide, *Choosing a structure* (``docs/guide/choosing-a-structure.md``) and
*Theory: achievable signatures* (``docs/theory/achievable-signatures.md``).

**Weak (normal-rank) signatures.**  A residual that decouples the disturbances and the
faults of a set W sees fault j iff ``rank [G_W  G_j] > rank G_W`` (normal rank; Varga 2017,
§3.5).  Geometrically: with ``S*`` the least unobservability subspace containing the
channels of W and ``(A0, M)`` the quotient by it (:mod:`geomfdi.synthesis.least_order.quotient`),
every
such residual is ``v(s) (z − M ξ̂)`` and sees fault j iff the quotient's transfer
``G_j(s) = M (sI − A0)⁻¹ B_fj + H D_fj`` is not identically zero
(:func:`geomfdi.synthesis.least_order.search.quotient_target_gains`, the test the design
uses).
The signature of W is the set ``p(W)`` of faults so seen; an achievable signature is a
non-empty ``p(W)``.

**Strong signatures.**  At a frequency λ on the stability boundary (``s = iω``, or
``z = e^{iω dt}``) fault j is strongly detectable when some residual of the row has a
non-zero gain from it at λ: the quotient is observable, so (output injection does not
change the pencil's rank) this holds iff the column ``[B_fj; H D_fj]`` is outside the range
of ``[A0 − λI; M]``.  Its *strong gain* is the sine of the angle between them (the time
scaled by the plant's frequency scale ω, so that it is unit- and time-scale free); a
signature is strong when every seen fault has a strong gain above ``gain_tol`` at every
frequency (Varga's ``fdigenspec(…; FDfreq)`` and ``fdichkspec``).

**Recursion.**  Decoupling more faults never lets a residual see more, so ``p`` is
monotone and the complement of a signature is *closed* (decoupling it hides nothing else).
Starting from ``W = ∅``, each closed set W is extended by one fault of ``p(W)`` at a time
and closed again; a closed set reached twice is pruned (Varga 2017, Procedure GENSPEC).
Every achievable signature is reached (each closed set lies on a chain of one-fault
extensions), and the work is ``N · nf`` quotients at most for N achievable signatures —
not ``2^nf`` when few signatures are achievable.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from geomfdi._validation import as_float
from geomfdi.errors import GeomFDIError
from geomfdi.geometry.subspace import _norm2
from geomfdi.synthesis.specification.model import SpecModel, quotient_of, spec_model
from geomfdi.tolerance import rank_decision

__all__ = [
    "SignatureRow",
    "AchievableSignatures",
    "achievable_signatures",
    "achievable_structures",
    "GAIN_TOL",
]

GAIN_TOL = 1e-3
"""Default strong gain threshold: the sine of the angle between a fault's column and the
range of the decoupled quotient's pencil at a frequency (module Notes)."""


@dataclass(frozen=True)
class SignatureRow:
    """One achievable signature and why it is achievable."""

    pattern: np.ndarray
    """Bool (nf,): the faults the residuals of this row see."""
    decoupled: tuple[int, ...]
    """The faults decoupled (with every disturbance): the complement of ``pattern``."""
    residual_dim: int
    """Outputs of the decoupled quotient (independent measurement combinations left)."""
    gain: np.ndarray
    """(nf,): relative size of each fault's quotient transfer (0 where decoupled)."""
    strong_gain: np.ndarray | None
    """(len(frequencies), nf): strong gains (module Notes), ``None`` without frequencies."""
    strong: bool
    """Every seen fault has a strong gain above ``gain_tol`` at every frequency."""


@dataclass
class AchievableSignatures:
    """Every achievable signature of a plant and fault set (:func:`achievable_signatures`)."""

    weak: np.ndarray
    """Bool (N, nf): the achievable signatures in the normal-rank sense."""
    rows: list[SignatureRow]
    """One per row of ``weak``, with its reasons."""
    names: list[str]
    frequencies: np.ndarray | None
    gain_tol: float
    evaluations: int = 0
    """Quotients computed by the recursion."""
    notes: list[str] = field(default_factory=list)

    @property
    def strong(self) -> np.ndarray | None:
        """Bool (N', nf): the rows of ``weak`` that are strong (``None`` without frequencies)."""
        if self.frequencies is None:
            return None
        keep = [r.strong for r in self.rows]
        return self.weak[np.array(keep, dtype=bool)] if keep else self.weak[:0]

    @property
    def structures(self) -> np.ndarray:
        """``strong`` when frequencies were given, else ``weak``."""
        return self.weak if self.frequencies is None else self.strong  # type: ignore[return-value]

    def explain(self, i: int) -> str:
        """Why row i of ``weak`` is achievable (and whether it is strong)."""
        r = self.rows[i]
        seen = [self.names[j] for j in np.flatnonzero(r.pattern)]
        dec = [self.names[j] for j in r.decoupled]
        text = (
            f"sees {seen} while decoupling {dec or 'no fault'} and the disturbances "
            f"({r.residual_dim} measurement combination(s) left); relative gains "
            + ", ".join(f"{self.names[j]}: {r.gain[j]:.2g}" for j in np.flatnonzero(r.pattern))
        )
        if r.strong_gain is not None and self.frequencies is not None:
            worst = np.min(r.strong_gain[:, r.pattern], axis=0)
            text += "; strong gains (least over the frequencies) " + ", ".join(
                f"{self.names[j]}: {g:.2g}"
                for j, g in zip(np.flatnonzero(r.pattern), worst, strict=True)
            )
            if not r.strong:
                k, jj = np.unravel_index(
                    np.argmin(np.where(r.pattern, r.strong_gain, np.inf)), r.strong_gain.shape
                )
                text += (
                    f"; not strong: {self.names[jj]} has gain {r.strong_gain[k, jj]:.2g} "
                    f"<= {self.gain_tol:g} at ω = {self.frequencies[k]:g}"
                )
        return text


def _boundary_points(frequencies: np.ndarray, dt: float) -> np.ndarray:
    return np.exp(1j * frequencies * dt) if dt > 0 else 1j * frequencies


def strong_gains(Qm: Any, points: np.ndarray, omega: float, dt: float) -> np.ndarray:
    """(len(points), targets): the strong gain of each target of the quotient at each point.

    ``sin ∠([B_fj; H D_fj], range [A0 − λI; M])`` with the state rows divided by ω in
    continuous time (module Notes).
    """
    k, rho = Qm.k, Qm.rho
    nt = len(Qm.Bf)
    w = 1.0 if dt > 0 else max(omega, 1e-300)
    out = np.zeros((points.size, nt))
    for i, lam in enumerate(points):
        P = np.vstack([(Qm.A0 - lam * np.eye(k)) / w, Qm.M.astype(complex)])
        if k:
            U, s, _ = np.linalg.svd(P, full_matrices=False)
            dec = rank_decision(
                s, max(_norm2(P), 1e-300), k + rho, what="strong pencil", warn=False
            )
            U = U[:, : dec.rank]
        else:
            U = np.zeros((rho, 0))
        for j in range(nt):
            Cj = np.vstack([Qm.Bf[j] / w, Qm.Df[j]]).astype(complex)
            nC = _norm2(Cj)
            if nC == 0:
                continue
            out[i, j] = _norm2(Cj - U @ (U.conj().T @ Cj)) / nC
    return out


def _node(model: SpecModel, W: int, pts: np.ndarray | None) -> tuple[int, dict[str, Any]]:
    """Evaluate the closed-set candidate W (bit mask of decoupled faults)."""
    from geomfdi.synthesis.least_order.search import SEE_TOL, _points, quotient_target_gains

    nf = model.nf
    dec = tuple(j for j in range(nf) if W >> j & 1)
    tgt = tuple(j for j in range(nf) if not W >> j & 1)
    Qm = quotient_of(model, tgt, dec) if tgt else None
    gain = np.zeros(nf)
    info: dict[str, Any] = {"decoupled": dec, "rho": 0, "gain": gain, "strong_gain": None}
    if Qm is None or Qm.rho == 0:
        info["ill"] = Qm is None and bool(tgt)
        return 0, info
    _, size = quotient_target_gains(Qm, _points(Qm, np.zeros(0), model.omega, count=4))
    gain[list(tgt)] = size
    seen = 0
    for t, j in enumerate(tgt):
        if size[t] > SEE_TOL:
            seen |= 1 << j
    info["rho"] = Qm.rho
    if pts is not None:
        sg = np.zeros((pts.size, nf))
        sg[:, list(tgt)] = strong_gains(Qm, pts, model.omega, model.plant.dt)
        info["strong_gain"] = sg
    return seen, info


def _checked_frequencies(frequencies: Any) -> np.ndarray | None:
    if frequencies is None:
        return None
    f = np.atleast_1d(np.asarray(frequencies, dtype=float)).ravel()
    if f.size == 0 or not np.all(np.isfinite(f)) or np.any(f < 0):
        raise GeomFDIError(
            f"frequencies: expected finite non-negative frequencies (rad/s), got {frequencies!r}",
            argument="frequencies",
        )
    return f


def checked_gain_tol(gain_tol: Any) -> float:
    """``gain_tol`` validated: a value in [0, 1), :data:`GAIN_TOL` for ``None``."""
    tol = GAIN_TOL if gain_tol is None else as_float(gain_tol, "gain_tol")
    if not (0 <= tol < 1):
        raise GeomFDIError(
            f"gain_tol: expected a value in [0, 1), got {gain_tol!r}", argument="gain_tol"
        )
    return tol


def achievable_signatures(
    plant: Any,
    faults: Any,
    *,
    frequencies: Any = None,
    gain_tol: float | None = None,
) -> AchievableSignatures:
    """Every achievable fault signature of ``plant``, with the reasons for each.

    Parameters
    ----------
    plant : Plant or control.StateSpace
        Disturbances (``Bd``, ``Dd``) are always decoupled.  A static plant (n = 0) is
        accepted.
    faults : list of Fault
    frequencies : array_like, optional
        Frequencies (rad/s; ``z = e^{iω dt}`` in discrete time) for strong detectability;
        include 0 for constant faults.  Default: weak signatures only.
    gain_tol : float, optional
        Least strong gain (module Notes), default :data:`GAIN_TOL`.

    Returns
    -------
    AchievableSignatures
        ``weak`` (rows sorted by decreasing number of faults seen, then the pattern),
        ``strong``, ``rows[i]`` and :meth:`~AchievableSignatures.explain`.

    Notes
    -----
    Varga's recursion (module Notes): at most ``N · nf`` quotients for N achievable
    signatures and nf faults, each ``O((n + nd + nf)³)``.  See the user guide, *Theory:
    achievable signatures* (``docs/theory/achievable-signatures.md``).

    References
    ----------
    A. Varga, *Solving Fault Diagnosis Problems*, Springer 2017, §3.5 and §5.4
    (``fdigenspec``, ``fdichkspec``).
    """
    model = spec_model(plant, faults)
    freqs = _checked_frequencies(frequencies)
    tol = checked_gain_tol(gain_tol)
    pts = None if freqs is None else _boundary_points(freqs, model.plant.dt)
    nf = model.nf
    full = (1 << nf) - 1
    evaluated: dict[int, tuple[int, dict[str, Any]]] = {}
    closed: dict[int, dict[str, Any]] = {}
    notes: list[str] = []
    stack = [0]
    while stack:
        W = stack.pop()
        if W in evaluated:
            continue
        seen, info = _node(model, W, pts)
        evaluated[W] = (seen, info)
        if info.get("ill"):
            notes.append(
                f"decoupling {list(info['decoupled'])}: the quotient is ill-conditioned; "
                "treated as no residual"
            )
        if not seen:
            continue
        cl = full & ~seen
        if cl in closed:
            continue
        closed[cl] = info
        stack.extend(cl | (1 << j) for j in range(nf - 1, -1, -1) if seen >> j & 1)
    rows: list[SignatureRow] = []
    for cl, info in closed.items():
        pat = np.array([not cl >> j & 1 for j in range(nf)])
        sg = info["strong_gain"]
        strong = bool(sg is not None and np.all(sg[:, pat] > tol))
        rows.append(
            SignatureRow(
                pat,
                tuple(np.flatnonzero(~pat).tolist()),
                int(info["rho"]),
                info["gain"],
                sg,
                strong,
            )
        )
    rows.sort(key=lambda r: (-int(r.pattern.sum()), tuple(r.pattern.tolist())))
    weak = np.array([r.pattern for r in rows], dtype=bool).reshape(len(rows), nf)
    return AchievableSignatures(weak, rows, model.names, freqs, tol, len(evaluated), notes)


def achievable_structures(
    plant: Any,
    faults: Any,
    *,
    frequencies: Any = None,
    gain_tol: float | None = None,
) -> np.ndarray:
    """All achievable fault signatures as a boolean array (one row each, columns = faults).

    Weak signatures (normal-rank sense) by default; with ``frequencies``, the strong ones:
    every seen fault has a gain above ``gain_tol`` at each frequency (include 0 for
    constant faults).  The rows of Varga's ``fdigenspec`` (``FDfreq`` for the strong
    case).  :func:`achievable_signatures` returns the same rows with their reasons.

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> plant = gf.Plant([[-1.0, 0.0], [0.0, -2.0]], None, np.eye(2))
    >>> faults = [gf.SensorFault(0), gf.SensorFault(1)]
    >>> gf.achievable_structures(plant, faults).astype(int)
    array([[1, 1],
           [0, 1],
           [1, 0]])
    """
    res = achievable_signatures(plant, faults, frequencies=frequencies, gain_tol=gain_tol)
    return res.structures
