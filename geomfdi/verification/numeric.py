"""Verification of residual generators on the physical model (math.md §5).

The composite of plant and generator (faults ``x' = … + Bf f``, ``y = … + Df f``)::

    [x; w]' = [[A, 0], [−E C, F]] [x; w] + [[B, Bd, Bf], [G − E D, −E Dd, −E Df]] [u; d; f]
    r       = [−H C, M] [x; w] + [K − H D, −H Dd, −H Df] [u; d; f]

A transfer is "identically zero" when its relative gain stays at rounding level at
``order + 2`` random complex points (default; plant and generator are evaluated apart,
``T(s) = G_y(s) P(s) (+ G_u(s))``, and ``‖T(s)‖`` is compared with
``‖G_y(s)‖ (‖C (sI − A)⁻¹‖ ‖Bx‖ + ‖Dy‖) (+ ‖G_u(s)‖)``, see ``_Composite.point_gains``),
or when the output map annihilates the orthonormal Krylov (reachable) subspace of the
composite (``method="krylov"``).  :func:`verify_symbolic` redoes the
design in exact rational arithmetic and proves the zeros.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg

from geomfdi._validation import as_choice, as_probability, as_sequence_of
from geomfdi.errors import GeomFDIError
from geomfdi.geometry.subspace import _norm2
from geomfdi.model.faults import Fault, SensorFault, fault_matrices
from geomfdi.model.plant import Plant, as_plant
from geomfdi.synthesis.generator import ResidualBank, ResidualGenerator
from geomfdi.synthesis.realization import reachable_subspace

__all__ = [
    "verify",
    "VerificationReport",
    "fault_gains",
    "LEAK_TOL",
]

LEAK_TOL = 1e-8
"""Relative gain below which a transfer counts as identically zero."""

_EPS = float(np.finfo(float).eps)


_PLANT_SCHUR: dict[int, tuple[Any, ...]] = {}
"""Complex Schur factors of recently verified plants (a bank verifies one plant many
times); keyed by ``id(plant)`` and guarded by the identity of ``plant.A``."""


def _plant_schur(plant: Plant) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(T_A, U_Aᴴ, C U_A)`` with ``A = U_A T_A U_Aᴴ`` (complex Schur form)."""
    hit = _PLANT_SCHUR.get(id(plant))
    if hit is not None and hit[0] is plant.A:
        return hit[1], hit[2], hit[3]
    TA, UA = scipy.linalg.schur(np.asarray(plant.A, dtype=complex), output="complex")
    entry = (plant.A, TA, UA.conj().T, plant.C @ UA)
    if len(_PLANT_SCHUR) >= 8:
        _PLANT_SCHUR.pop(next(iter(_PLANT_SCHUR)))
    _PLANT_SCHUR[id(plant)] = entry
    return TA, entry[2], entry[3]


class _Composite:
    """Plant and generator, Schur-factored once for fast transfer evaluations.

    The random-point measure and the DC gains evaluate the two apart:
    ``T(s) = G_y(s) P(s) (+ G_u(s))`` with ``P(s) = C (sI − A)⁻¹ Bx + Dy`` and the
    generator's ``G_y(s) = −M (sI − F)⁻¹ E − H``, ``G_u(s) = M (sI − F)⁻¹ G + K``; the
    complex Schur forms of A and F turn every resolvent into a triangular solve, so each
    of the ``order + 2`` points costs O(n² + k²) per column.  The Krylov test works on
    the interconnection ``A_c = [[A, 0], [−E C, F]]``, ``C_c = [−H C, M]``, where an
    input ``(Bx, Dy)`` (entering the generator also through ``(Gx, Kx)``) has
    ``B_c = [Bx; −E Dy + Gx]``, ``D_c = −H Dy + Kx`` (built on first use).
    """

    def __init__(self, g: ResidualGenerator, plant: Plant) -> None:
        n, k = plant.n, g.order
        self.g, self.plant, self.n, self.k, self.N = g, plant, n, k, n + k
        self.TA, self.UAh, self.CUA = _plant_schur(plant)
        self.nA, self.nCp = _norm2(plant.A), _norm2(plant.C)
        self.nF, self.nE = _norm2(g.F), _norm2(g.E)
        self.nH, self.nM = _norm2(g.H), _norm2(g.M)
        eig = [np.diag(self.TA)]
        if k:
            self.TF, UF = scipy.linalg.schur(g.F.astype(complex), output="complex")
            self.MUF = g.M @ UF
            self.UFEG = UF.conj().T @ np.hstack([-g.E, g.G])
            self.UFEC = UF.conj().T @ (g.E @ plant.C)
            eig.append(np.diag(self.TF))
        self.eig = np.concatenate(eig)
        rng = np.random.default_rng(7)
        va, vf = rng.standard_normal(n), rng.standard_normal(k)
        self.UAva = self.UAh @ (va / max(np.linalg.norm(va), 1e-300))
        self.UFvf = (
            UF.conj().T @ (vf / max(np.linalg.norm(vf), 1e-300)) if k else np.zeros(0, complex)
        )
        self.scale = max(self.nA, self.nF, self.nE * self.nCp)
        self.points = self._clear_of_rounding(_points(self.scale, self.N + 2, self.eig))
        self._comp: dict[str, Any] | None = None

    # ----------------------------------------------------------- resolvents
    def _solve_A(self, s: complex, X: np.ndarray) -> np.ndarray:
        return scipy.linalg.solve_triangular(s * np.eye(self.n) - self.TA, X, check_finite=False)

    def _solve_F(self, s: complex, X: np.ndarray) -> np.ndarray:
        return scipy.linalg.solve_triangular(s * np.eye(self.k) - self.TF, X, check_finite=False)

    def _clear_of_rounding(self, points: np.ndarray) -> np.ndarray:
        """Push points out of the region where rounding in A or F shows.

        Near a defective or ill-conditioned eigenvalue (e.g. a Jordan block at 0, whose
        computed eigenvalues sit ~sqrt(eps) away) the resolvent amplifies the rounding of
        a cancelled channel to far above ``LEAK_TOL``.  A point is doubled until
        ``eps N scale r ≤ LEAK_TOL / 100``, with ``r = r_A + r_F + r_F ‖E‖ ‖C‖ r_A`` (a
        bound of the interconnection's resolvent from the fixed random probes
        ``r_A = ‖(sI − A)⁻¹ v‖``, ``r_F = ‖(sI − F)⁻¹ w‖``).
        """
        out = []
        for s in points:
            for _ in range(60):
                ra = float(np.linalg.norm(self._solve_A(s, self.UAva)))
                rf = float(np.linalg.norm(self._solve_F(s, self.UFvf))) if self.k else 0.0
                r = ra + rf + rf * self.nE * self.nCp * ra
                if np.isfinite(r) and _EPS * self.N * max(self.scale, 1.0) * r <= LEAK_TOL / 100:
                    break
                s = 2 * s
            out.append(s)
        return np.array(out)

    def generator_tf(self, s: complex) -> tuple[np.ndarray, np.ndarray]:
        """``G_y(s) = −M (sI − F)⁻¹ E − H`` and ``G_u(s) = M (sI − F)⁻¹ G + K``."""
        g = self.g
        T = np.hstack([-g.H, g.K]).astype(complex)
        if self.k:
            T = T + self.MUF @ self._solve_F(s, self.UFEG)
        return T[:, : g.q], T[:, g.q :]

    # ------------------------------------------------------- random points
    def point_gains(self, channels: list[tuple[Any, ...]]) -> np.ndarray:
        """Relative gains at the random points, plant and generator evaluated apart.

        A channel ``(Bx, Dy[, Gx, Kx])`` gives ``T(s) = G_y(s) P(s) (+ G_u(s))``; its
        relative gain is the largest
        ``‖T(s)‖ / (‖G_y(s)‖ (‖C (sI − A)⁻¹‖ ‖Bx‖ + ‖Dy‖) + ‖G_u(s)‖)``: the residual's
        response compared with what its own sensitivity to y (and u) would give without
        any cancellation.  ``‖C (sI − A)⁻¹‖`` is estimated on a fixed random vector.  No
        norm of a product the design cancels to rounding enters the denominator, so a
        generator whose E is itself rounding (e.g. A = 0) is judged correctly.
        """
        widths = [c[0].shape[1] for c in channels]
        UB = np.hstack([self.UAh @ c[0] for c in channels] + [self.UAva[:, None]])
        base = [(_norm2(c[0]), _norm2(c[1])) for c in channels]
        best = np.zeros(len(channels))
        for s in self.points:
            Y = self.CUA @ self._solve_A(s, UB)
            cr = float(np.linalg.norm(Y[:, -1]))
            Gy, Gu = self.generator_tf(s)
            nGy, nGu = _norm2(Gy), _norm2(Gu)
            i = 0
            for c, (ch, w) in enumerate(zip(channels, widths, strict=True)):
                T = Gy @ (Y[:, i : i + w] + ch[1])
                i += w
                den = nGy * (cr * base[c][0] + base[c][1])
                if len(ch) > 2 and ch[2] is not None:  # the known input: u enters G too
                    T = T + Gu
                    den += nGu
                if den > 0:
                    best[c] = max(best[c], float(np.linalg.norm(T) / den))
        return best

    # ------------------------------------------------------------ DC gains
    def dc_gains(self, sigs: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
        """``‖T(s0)‖`` per fault, s0 = 0 (continuous) or 1 (discrete); ``inf`` where the
        channel integrates.

        Where A or F has a pole at s0 it may cancel in the channel: then T is analytic at
        s0 and the linear extrapolation of ``T(s0 + e1)``, ``T(s0 + e2)`` to e = 0 is
        accurate to O(e1 e2) (a zero DC gain comes out as 0, not as ~e2); where it does
        not cancel, T grows like 1/e.
        """
        if not sigs:
            return np.zeros(0)
        widths = [Bf.shape[1] for Bf, _ in sigs]
        UB = self.UAh @ np.hstack([Bf for Bf, _ in sigs])
        Dall = np.hstack([Df for _, Df in sigs])

        def T(s: complex) -> np.ndarray:
            Gy, _ = self.generator_tf(s)
            return Gy @ (self.CUA @ self._solve_A(s, UB) + Dall)

        def split(X: np.ndarray) -> np.ndarray:
            edges = np.cumsum([0, *widths])
            return np.array(
                [np.linalg.norm(X[:, edges[i] : edges[i + 1]]) for i in range(len(widths))]
            )

        s0 = 1.0 if self.plant.dt > 0 else 0.0
        sc = max(self.scale, 1.0)
        if np.min(np.abs(s0 - self.eig)) > 1e-9 * sc:
            return split(T(s0))
        e1, e2 = 1e-5 * sc, 1e-7 * sc
        T1, T2 = T(s0 + e1), T(s0 + e2)
        v1, v2 = split(T1), split(T2)
        out = split(T2 - e2 * (T1 - T2) / (e1 - e2))
        out[(v2 > 10 * np.maximum(v1, 1e-300)) & (v2 > 1e-6)] = np.inf
        return out

    # --------------------------------------------------------- Krylov test
    def _composite(self) -> dict[str, Any]:
        if self._comp is None:
            g, plant, n, k = self.g, self.plant, self.n, self.k
            Ac = np.block([[plant.A, np.zeros((n, k))], [-g.E @ plant.C, g.F]])
            Cc = np.hstack([-g.H @ plant.C, g.M])
            # natural sizes, not norms of products the design may have cancelled to
            # rounding (e.g. H C = 0 for a parity row): ‖C_c‖ ≤ ‖H‖ ‖C‖ + ‖M‖, and an E
            # that is rounding relative to ‖F‖ / ‖C‖ counts as zero
            nC = self.nH * self.nCp + self.nM
            nE = max(self.nE, self.nF / self.nCp if self.nCp > 0 else 0.0)
            self._comp = {"Ac": Ac, "Cc": Cc, "nC": nC, "nE": nE}
        return self._comp

    def channel(self, Bx, Dy, Gx=None, Kx=None):
        """``(B_c, D_c, b, d)``: the channel and the norms its rounding is judged against.

        ``b = ‖Bx‖ + max(‖E‖, ‖F‖/‖C‖) ‖Dy‖ (+ ‖Gx‖)`` and ``d = ‖H‖ ‖Dy‖ (+ ‖Kx‖)``: the
        size the transfer would have if the generator did not cancel this input.
        """
        g = self.g
        Bw = -g.E @ Dy
        Dc = -g.H @ Dy
        b = _norm2(Bx) + self._composite()["nE"] * _norm2(Dy)
        d = self.nH * _norm2(Dy)
        if Gx is not None:
            Bw, Dc = Bw + Gx, Dc + Kx
            b += _norm2(Gx)
            d += _norm2(Kx)
        return np.vstack([Bx, Bw]), Dc, b, d

    def krylov_gain(self, Bc, Dc, b: float, d: float) -> float:
        """``‖C_c V‖ ‖B_c‖ / (‖C_c‖ b)`` with V an orthonormal basis of ``<A_c | Im B_c>``
        (and the feedthrough relative to ``d``)."""
        comp = self._composite()
        if Bc.shape[1] == 0 or comp["Cc"].shape[0] == 0 or (b == 0 and d == 0):
            return 0.0
        V = reachable_subspace(comp["Ac"], Bc).basis
        num = _norm2(comp["Cc"] @ V) * _norm2(Bc) if V.size else 0.0
        nC = comp["nC"]
        return max(num / (nC * b + 1e-300), _norm2(Dc) / (d + nC * b + 1e-300))


def _points(scale: float, count: int, eigenvalues: np.ndarray, seed: int = 12345) -> np.ndarray:
    """Random points in the upper half-plane at the scale of the spectrum.

    The radius is the spectral radius (not a matrix norm, which a non-normal generator
    can make orders of magnitude larger: far from the poles a strictly proper transfer
    decays like ``|s|^{-k}`` and a real response would look like rounding), at least
    ``1e-6 scale``; 1 when every pole is at 0 to rounding.
    """
    rng = np.random.default_rng(seed)
    rho = float(np.max(np.abs(eigenvalues))) if eigenvalues.size else 0.0
    rad = max(rho, 1e-6 * scale)
    if rad < 1e-8:  # every pole at 0 to rounding (e.g. A = 0, F = 0): any scale will do
        rad = 1.0
    r = rad * rng.uniform(0.3, 1.5, count)
    th = rng.uniform(0.15, np.pi - 0.15, count)
    return r * np.exp(1j * th)


def fault_gains(
    g: ResidualGenerator, plant: Plant, faults: Sequence[Fault], *, method: str = "points"
) -> tuple[np.ndarray, np.ndarray]:
    """Relative gain and DC gain from each fault to the residual, on the physical model."""
    sigs = fault_matrices(faults, plant.n, plant.q)
    return _gains(_Composite(g, plant), sigs, method)


def _gains(comp: _Composite, sigs: list, method: str) -> tuple[np.ndarray, np.ndarray]:
    if not sigs:
        return np.zeros(0), np.zeros(0)
    dcs = comp.dc_gains(sigs)
    if method == "points":
        gains = comp.point_gains([(Bf, Df) for Bf, Df in sigs])
    else:
        gains = np.array([comp.krylov_gain(*comp.channel(Bf, Df)) for Bf, Df in sigs])
    return np.asarray(gains, dtype=float), dcs


def _input_gain(comp: _Composite, method: str) -> float:
    g, plant = comp.g, comp.plant
    chans: list[tuple[Any, ...]] = []
    if plant.m:
        chans.append((plant.B, plant.D, g.G, g.K))
    if plant.nd:
        chans.append((plant.Bd, plant.Dd))
    if not chans:
        return 0.0
    if method == "points":
        return float(np.max(comp.point_gains(chans)))
    return max(comp.krylov_gain(*comp.channel(*c)) for c in chans)


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
        Rows without a generator (not counted in ``ok``).
    tol : float
        Threshold for "zero".
    ok : bool
        Every decoupling holds, no input leaks, every target is seen — over the rows
        whose generator exists (a bank with missing rows can be ``ok``; see
        :attr:`complete`).
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

    @property
    def complete(self) -> bool:
        """``ok`` and no row missing: the bank realises the whole requested structure."""
        return self.ok and not self.missing

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


def verify(
    bank_or_generator: ResidualBank | ResidualGenerator,
    plant: Plant,
    faults: Sequence[Fault] | None = None,
    *,
    method: str = "points",
    tol: float = LEAK_TOL,
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

    Notes
    -----
    math.md §5, items 1–3.  The transfer from sensor i is
    ``−M (sI − F)⁻¹ E e_i − H e_i`` composed with the plant; from u and d it must vanish.
    Unlike the paper's check on its pseudo-actuator model, this one uses the measured y,
    so the paper design's transient leakage (Erratum 2) is visible.
    """
    method = as_choice(method, "method", ("points", "krylov"))
    tol = as_probability(tol, "tol")
    if faults is not None:
        faults = as_sequence_of(faults, "faults", Fault)
    plant = as_plant(plant)
    gens, faults, req = _unpack(bank_or_generator, plant, faults)
    rows, nf = req.shape
    gain = np.zeros((rows, nf))
    dc = np.zeros((rows, nf))
    inp = np.zeros(rows)
    idents: list[dict[str, float]] = []
    missing, details = [], []
    for r, g in enumerate(gens):
        if g is None:
            missing.append(r)
            idents.append({})
            continue
        comp = _Composite(g, plant)
        gain[r], dc[r] = _gains(comp, fault_matrices(faults, plant.n, plant.q), method)
        for j in np.flatnonzero(req[r] & (gain[r] <= tol)):
            # a target at rounding level under the random-point measure (a badly scaled
            # generator): second opinion from the orthonormal Krylov test, as in the design
            gain[r, j] = max(gain[r, j], fault_gains(g, plant, [faults[j]], method="krylov")[0][0])
        inp[r] = _input_gain(comp, method)
        idents.append(dict(g.info.get("identities", {})))
    leak = np.where(req, 0.0, gain)
    tgain = np.where(req, gain, 0.0)
    ok = True
    for r, g in enumerate(gens):
        if g is None:
            continue
        for j in range(nf):
            if not req[r, j] and gain[r, j] > tol:
                ok = False
                details.append(f"row {r}: leaks fault {j} (relative gain {gain[r, j]:.3g})")
            if req[r, j] and gain[r, j] <= tol:
                ok = False
                details.append(f"row {r}: does not see fault {j}")
        if inp[r] > tol:
            ok = False
            details.append(f"row {r}: input leakage {inp[r]:.3g}")
        if any(v > 1e-8 for v in idents[r].values()):
            ok = False
            details.append(f"row {r}: identities {idents[r]}")
    return VerificationReport(gain, leak, tgain, inp, dc, idents, missing, tol, ok, method, details)


# ----------------------------------------------------------------- exact
