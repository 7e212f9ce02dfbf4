"""Transfer gains of a generator on the physical model (shared by design and verification).

The composite of plant and generator (faults ``x' = … + Bf f``, ``y = … + Df f``)::

    [x; w]' = [[A, 0], [−E C, F]] [x; w] + [[B, Bd, Bf], [G − E D, −E Dd, −E Df]] [u; d; f]
    r       = [−H C, M] [x; w] + [K − H D, −H Dd, −H Df] [u; d; f]

A transfer is "identically zero" when its relative gain stays at rounding level at
``k + 2`` random complex points of the generator's scale and the plant's own ``n + 2``
(plant and generator evaluated apart: ``n + k + 4`` points, more than a non-zero transfer of
the composite's degree ``n + k`` can vanish at) or when the output map annihilates the
orthonormal Krylov subspace of the composite (``method="krylov"``).  The plant's complex
Schur form, its ``n + 2`` points and its responses there are computed once per plant
(:class:`PlantFactor`) and shared by every row of a bank; a row's own resolvent
``M (sI − F)⁻¹`` is solved row-wise, ``O(k²)`` per point, or ``O(k)`` for a generator in
output-normal form (:mod:`geomfdi.generators.output_normal`).  See the user guide, *Theory:
verification* (``docs/theory/verification.md``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from geomfdi.generators.generator import ResidualGenerator
from geomfdi.generators.output_normal import output_normal_blocks, rows_resolvent
from geomfdi.generators.realization import reachable_subspace
from geomfdi.generators.resolvents import (  # noqa: F401 (FEW_POINTS, _tri_solve_rows_many: shared)
    FEW_POINTS,
    _abs2_sum,
    _block_eigenvalues,
    _digest,
    _Memo,
    _on_column,
    _on_key,
    _on_rows,
    _spectral_norms,
    _tri_solve,
    _tri_solve_many,
    _tri_solve_rows_many,
    complex_schur,
)
from geomfdi.geometry.balancing import state_scaling
from geomfdi.geometry.subspace import _norm2
from geomfdi.model.faults import Fault, fault_matrices
from geomfdi.model.plant import Plant

__all__ = ["LEAK_TOL", "fault_gains", "PlantFactor", "Composite", "complex_schur"]


UNSTABLE_MARGIN = 1e-3
"""Distance (relative to ``‖A‖``) from the stability boundary beyond which the Schur
values of a plant are taken as stable without an eigen-decomposition (the computed
eigenvalues of a Jordan block of size m spread by ``(ε ‖A‖)^{1/m}``)."""

LEAK_TOL = 1e-8
"""Relative gain below which a transfer counts as identically zero."""

_EPS = float(np.finfo(float).eps)


class PlantFactor:
    """Complex Schur factor ``A = U_A T_A U_Aᴴ`` of a plant, computed once and shared.

    The state is balanced first (:func:`geomfdi.geometry.balancing.state_scaling`,
    ``Ã = D⁻¹ A D``), so that transfers of a badly scaled realisation are evaluated as
    accurately as those of a well-scaled one: ``A = (D U) T_A (D U)⁻¹``.  Attributes
    ``TA``, ``UA``, ``d`` (the diagonal of D), ``UAh`` (= U_Aᴴ D⁻¹), ``CUA`` (= C D U_A) and
    ``unstable``: the plant's unstable eigenvalues (Re λ ≥ 0, or |λ| ≥ 1 when dt > 0) with
    their eigenvectors.
    """

    def __init__(self, plant: Plant) -> None:
        A = np.asarray(plant.A, dtype=float)
        d = state_scaling(A, np.hstack([plant.B, plant.Bd]), plant.C)
        Ab = A * d[None, :] / d[:, None]
        TA, UA = complex_schur(Ab)
        self.plant, self.d, self.UA = plant, d, UA
        self.TA, self.UAh, self.CUA = TA, UA.conj().T / d[None, :], (plant.C * d[None, :]) @ UA
        self.nA, self.nCp = _norm2(TA), _norm2(self.CUA)  # balanced
        # the eigenvectors are needed only near or beyond the stability boundary: Schur
        # values clear of it by UNSTABLE_MARGIN ‖A‖ (more than the spread of a defective
        # eigenvalue under rounding) leave no unstable mode to find
        lt, margin = np.diag(TA), UNSTABLE_MARGIN * max(self.nA, 1e-300)
        near = np.abs(lt) >= 1.0 - margin if plant.dt > 0 else lt.real >= -margin
        if np.any(near):
            lam, V = np.linalg.eig(Ab)
        else:
            lam, V = np.zeros(0), np.zeros((plant.n, 0))
        bad = np.abs(lam) >= 1.0 if plant.dt > 0 else lam.real >= 0
        self.unstable = [(complex(lam[i]), d * V[:, i]) for i in np.flatnonzero(bad)]
        self._last: tuple[ResidualGenerator, Composite] | None = None
        # frequencies in the plant's own range (:func:`_boundary_points`, n + 2 of them)
        # shared by the angle measure of every generator on this plant, with the state
        # responses to its channels computed once
        self.plant_points = _boundary_points(
            max(self.nA, 1e-300), plant.n + 2, np.diag(TA), plant.dt, seed=4321
        )
        self._responses: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        # the random-point measure likewise: n + 2 random points in the plant's range and
        # the plant's responses there (to the random probe of Composite._clear_of_rounding
        # and to each channel), shared by every generator on the plant
        va = np.random.default_rng(7).standard_normal(plant.n)
        self.UAva = self.UAh @ (va / max(np.linalg.norm(va), 1e-300))
        self.plant_random = _points(max(self.nA, 1e-300), plant.n + 2, np.diag(TA), seed=54321)
        self._random: dict[int, tuple[Any, np.ndarray]] = {}
        self._solved = _Memo(64)
        # the resolvents of output-normal generators on this plant's checks
        # (generators.resolvents._on_rows, _on_column): rows sharing poles and points
        # compute them once
        self.on_memo = _Memo(64)

    def random_response(self, Bx: np.ndarray | None) -> np.ndarray:
        """``C U_A (sI − T_A)⁻¹ U_Aᴴ Bx`` at :attr:`plant_random`, shape ``(n + 2, q, cols)``
        (``Bx = None``: the state response to the probe ``U_Aᴴ v``, ``(n + 2, n, 1)``),
        computed once per channel matrix."""
        key = id(Bx)
        hit = self._random.get(key)
        if hit is not None and hit[0] is Bx:
            return hit[1]
        pts = self.plant_random
        if Bx is None:
            out = _tri_solve_many(self.TA, pts, self.UAva[:, None])
        else:
            UB = self.UAh @ Bx
            out = np.zeros((pts.size, self.CUA.shape[0], UB.shape[1]), dtype=complex)
            nz = np.flatnonzero(np.any(UB != 0, axis=0))
            if nz.size:
                out[:, :, nz] = self.CUA @ _tri_solve_many(self.TA, pts, UB[:, nz])
        self._random[key] = (Bx, out)
        return out

    def solve(self, pts: np.ndarray, X: np.ndarray) -> np.ndarray:
        """``(sI − T_A)⁻¹ X`` at the points, ``(P, n, cols)``; the last (points, X) are
        remembered by content (up to ``resolvents.MEMO_BYTES``): the rows of a bank whose
        own points coincide (same order, same spectrum) solve the plant there once."""
        key = _digest(pts, X)
        return self._solved.get(key, lambda: _tri_solve_many(self.TA, pts, X))

    def boundary_response(self, Bx: np.ndarray) -> np.ndarray:
        """``(sI − T_A)⁻¹ U_Aᴴ Bx`` at :attr:`plant_points`, shape ``(n + 2, n, cols)``
        (zero columns not solved), computed once per channel matrix."""
        hit = self._responses.get(id(Bx))
        if hit is not None and hit[0] is Bx:
            return hit[1]
        UB = self.UAh @ Bx
        out = np.zeros((self.plant_points.size, UB.shape[0], UB.shape[1]), dtype=complex)
        nz = np.flatnonzero(np.any(UB != 0, axis=0))
        if nz.size:
            out[:, :, nz] = _tri_solve_many(self.TA, self.plant_points, UB[:, nz])
        self._responses[id(Bx)] = (Bx, out)
        return out

    def composite(self, g: ResidualGenerator) -> Composite:
        """The :class:`Composite` of ``g`` with this plant; the last one built is kept, so
        that a row's checks and its strength verdict factor the generator once."""
        if self._last is not None and self._last[0] is g:
            return self._last[1]
        comp = Composite(g, self.plant, self)
        self._last = (g, comp)
        return comp


class Composite:
    """Plant and generator, Schur-factored once for fast transfer evaluations.

    The random-point measure and the DC gains evaluate the two apart:
    ``T(s) = G_y(s) P(s) (+ G_u(s))`` with ``P(s) = C (sI − A)⁻¹ Bx + Dy`` and the
    generator's ``G_y(s) = −M (sI − F)⁻¹ E − H``, ``G_u(s) = M (sI − F)⁻¹ G + K``; the
    complex Schur forms of A and F turn every resolvent into a triangular solve, so each
    point costs O(k²) per residual row and O(n²) per plant column (the plant's share of the
    points is solved once per plant, :class:`PlantFactor`).  The Krylov test works on
    the interconnection ``A_c = [[A, 0], [−E C, F]]``, ``C_c = [−H C, M]``, where an
    input ``(Bx, Dy)`` (entering the generator also through ``(Gx, Kx)``) has
    ``B_c = [Bx; −E Dy + Gx]``, ``D_c = −H Dy + Kx`` (built on first use).
    """

    def __init__(
        self, g: ResidualGenerator, plant: Plant, factor: PlantFactor | None = None
    ) -> None:
        n, k = plant.n, g.order
        if factor is None or factor.plant is not plant:
            factor = PlantFactor(plant)
        self.g, self.plant, self.n, self.k, self.N = g, plant, n, k, n + k
        self.TA, self.UAh, self.CUA = factor.TA, factor.UAh, factor.CUA
        self.nA, self.nCp = factor.nA, factor.nCp  # balanced
        self.nF, self.nE = _norm2(g.F), _norm2(g.E)
        self.nH, self.nM = _norm2(g.H), _norm2(g.M)
        rng = np.random.default_rng(7)
        rng.standard_normal(n)  # the plant's probe (factor.UAva) is drawn first
        vf = rng.standard_normal(k)
        self.UAva = factor.UAva
        self.vf = vf / max(np.linalg.norm(vf), 1e-300)
        # a generator in output-normal form: its resolvents in O(k) per point, its
        # eigenvalues from its diagonal blocks (its Schur form only on demand)
        self.on_blocks = output_normal_blocks(g.F, g.M) if k else None
        eig = [np.diag(self.TA)]
        if k:
            if self.on_blocks is not None:
                eig.append(_block_eigenvalues(g.F, self.on_blocks))
                self._fkey = _on_key(g.F, g.M[0], self.on_blocks)
            else:
                self._factor_F()
                eig.append(np.diag(self.TF))
        self.eig = np.concatenate(eig)
        self.scale = max(self.nA, self.nF, self.nE * self.nCp)
        # random points: k + 2 at the scale of plant and generator, and the plant's own
        # n + 2 (shared, responses computed once): N + 4 > N + 1 in all
        raw = np.concatenate([_points(self.scale, k + 2, self.eig), factor.plant_random])
        # the angle measure probes frequencies (module function _boundary_points): k + 2 at
        # the scale of plant and generator, and the plant's own n + 2 (generator poles may
        # be much faster and would push every point out of its range), shared by every
        # generator on the plant; together N + 4 > N + 1 distinct points, so a transfer of
        # degree ≤ N that vanishes at all of them is identically zero
        self.factor = factor
        self.raw_points = np.concatenate(
            [_boundary_points(self.scale, k + 2, self.eig, plant.dt), factor.plant_points]
        )
        self.points = self._clear_of_rounding(raw, shared=factor.plant_random.size)
        self._comp: dict[str, Any] | None = None
        self._tf: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    _F_FACTORS = ("TF", "MUF", "UFEG", "UFEC", "UFvf")

    def _factor_F(self) -> None:
        """The generator's complex Schur form ``F = U_F T_F U_Fᴴ`` and the matrices its
        resolvents need (``TF``, ``MUF`` = M U_F, ``UFEG`` = U_Fᴴ [−E, G],
        ``UFEC`` = U_Fᴴ E C, ``UFvf`` = U_Fᴴ v_f)."""
        g = self.g
        if not self.k:
            z = np.zeros((0, 0), complex)
            self.TF, self.MUF, self.UFEC = z, np.zeros((g.M.shape[0], 0), complex), z
            self.UFEG = np.zeros((0, g.q + g.m), complex)
            self.UFvf = np.zeros(0, complex)
            return
        self.TF, UF = complex_schur(g.F)
        UFh = UF.conj().T
        self.MUF = g.M @ UF
        self.UFEG = UFh @ np.hstack([-g.E, g.G])
        self.UFEC = UFh @ (g.E @ self.plant.C)
        self.UFvf = UFh @ self.vf

    def __getattr__(self, name: str) -> Any:
        # the generator's Schur factors, computed on first use (an output-normal
        # generator's resolvents do not need them)
        if name in Composite._F_FACTORS and "g" in self.__dict__:
            self._factor_F()
            return self.__dict__[name]
        raise AttributeError(name)

    # ----------------------------------------------------------- resolvents
    def _solve_A(self, s: complex, X: np.ndarray) -> np.ndarray:
        return _tri_solve(s * np.eye(self.n) - self.TA, X)

    def _solve_F(self, s: complex, X: np.ndarray) -> np.ndarray:
        return _tri_solve(s * np.eye(self.k) - self.TF, X)

    # ---------------------------------------------------------------- angles
    def unstable_angle(self, factor: PlantFactor) -> float:
        """Largest ``‖G_y(μ) C v‖ / (g ‖C v‖)`` over unstable eigenpairs (μ, v).

        The residual's response to a plant initial state along v has the pole μ unless
        this residue vanishes: 0 means the unstable mode is unobservable from r.  ``g`` is
        the largest ``‖G_y(s)‖`` at the random points (at μ itself G_y has a
        transmission zero when the mode is cancelled, so it cannot be the reference).
        """
        worst = 0.0
        if not factor.unstable:
            return worst
        ref = max(_norm2(self.generator_tf(s)[0]) for s in self.points)
        for mu, v in factor.unstable:
            try:
                Gy, _ = self.generator_tf(mu)
            except np.linalg.LinAlgError:  # a generator pole at mu: the mode is not removed
                return 1.0
            Cv = self.plant.C @ v
            nCv = float(np.linalg.norm(Cv))
            if nCv <= 1e2 * _EPS * self.N * _norm2(self.plant.C) * float(np.linalg.norm(v)):
                continue  # C v is rounding: the mode is unobservable, it reaches no residual
            den = max(ref, _norm2(Gy)) * nCv
            if den > 0:
                worst = max(worst, float(np.linalg.norm(Gy @ Cv)) / den)
        return worst

    def angle_gains(self, channels: list[tuple[Any, ...]]) -> np.ndarray:
        """Coordinate-free leakage ``‖Q(s) V(s)‖ / (‖Q(s)‖ ‖V(s)‖)`` at the random points.

        ``Q(s) = [G_y(s), G_u(s)]`` is the generator's transfer from ``[y; u]`` and, for a
        channel ``(Bx, Dx, is_input)``, ``V(s) = [C (sI − A)⁻¹ Bx + Dx; I_x]`` its
        response in ``[y; u]`` (``I_x = I`` for the known input, 0 otherwise).  The
        measure is the cosine of the angle between the row space of Q and the channel:
        invariant under any change of state coordinates of plant or generator and under
        scaling of the residual; 0 exactly when the channel is decoupled.  The points are
        frequencies at the scale of the spectrum of plant and generator
        (:func:`_boundary_points`): the measure is that of the frequency response.
        """
        best = np.zeros(len(channels))
        widths = [c[0].shape[1] for c in channels]
        if not channels or not all(widths):
            if channels and any(widths):
                keep = [c for c, w in enumerate(widths) if w]
                best[keep] = self.angle_gains([channels[c] for c in keep])
            return best
        edges = np.cumsum([0, *widths])
        UB = np.hstack([self.UAh @ c[0] for c in channels])
        pts = self.raw_points
        P, q, m = pts.size, self.g.q, self.g.m
        own = P - self.factor.plant_points.size  # the row's own points come first
        Qall = self.generator_tf_many(pts)
        # every channel at once: the response V = [C (sI − A)⁻¹ Bx + Dx; I_x] of all
        # columns, Q V in one product; the per-channel norms are sums over its columns
        Y = np.empty((P, q, edges[-1]), dtype=complex)
        Y[:] = np.hstack([c[1] for c in channels])[None, :, :]
        nX2 = np.zeros((P, edges[-1]))
        nz = np.flatnonzero(np.any(UB != 0, axis=0))  # state-side columns
        if nz.size:
            # the plant's shared responses of the state-side columns only (a sensor
            # fault's are zero)
            shared = []
            for c, ch in enumerate(channels):
                cols = nz[(nz >= edges[c]) & (nz < edges[c + 1])] - edges[c]
                if cols.size:
                    shared.append(self.factor.boundary_response(ch[0])[:, :, cols])
            X = np.concatenate(
                [self.factor.solve(pts[:own], UB[:, nz]), np.concatenate(shared, axis=2)]
            )
            Y[:, :, nz] += self.CUA @ X
            nX2[:, nz] = _abs2_sum(X)
        U = np.zeros((m, edges[-1]))
        for c, ch in enumerate(channels):
            if ch[2]:
                U[:, edges[c] : edges[c + 1]] = np.eye(m)
        V = np.concatenate([Y, np.broadcast_to(U, (P, m, edges[-1]))], axis=1)
        QV = Qall @ V

        def per_channel(sq: np.ndarray) -> np.ndarray:  # (P, columns) → (P, channels)
            return np.sqrt(np.add.reduceat(sq, edges[:-1], axis=1))

        nY = per_channel(_abs2_sum(Y))
        nXc = per_channel(nX2)
        nV = per_channel(_abs2_sum(V))
        nQV = per_channel(_abs2_sum(QV))
        nQ = (
            np.linalg.norm(Qall, ord=2, axis=(1, 2))
            if Qall.shape[1] > 1
            else (np.linalg.norm(Qall[:, 0, :], axis=1))
        )
        ok = nQ > 0
        for c, ch in enumerate(channels):
            w, blk = widths[c], slice(edges[c], edges[c + 1])
            if w > 1:  # spectral norms of the channel's block (Frobenius above)
                nV[:, c] = _spectral_norms(V[:, :, blk])
                if Qall.shape[1] > 1:
                    nQV[:, c] = np.linalg.norm(QV[:, :, blk], ord=2, axis=(1, 2))
            # a channel whose response in y is rounding of a cancellation (a fault direction
            # in ker C ∩ an A-invariant subspace) reaches no residual: its "angle" there is
            # that of rounding noise, not a leak
            refY = self.nCp * nXc[:, c] + _norm2(ch[1])
            seen = nY[:, c] > 1e2 * _EPS * self.N * refY
            sel = ok & (nV[:, c] > 0) & (seen | bool(ch[2]))
            if np.any(sel):
                best[c] = float(np.max(nQV[sel, c] / (nQ[sel] * nV[sel, c])))
        return best

    def _clear_of_rounding(self, points: np.ndarray, shared: int = 0) -> np.ndarray:
        """Push points out of the region where rounding in A or F shows.

        Near a defective or ill-conditioned eigenvalue (e.g. a Jordan block at 0, whose
        computed eigenvalues sit ~sqrt(eps) away) the resolvent amplifies the rounding of
        a cancelled channel to far above ``LEAK_TOL``.  A point is doubled until
        ``eps N scale r ≤ LEAK_TOL / 100``, with ``r = r_A + r_F + r_F ‖E‖ ‖C‖ r_A`` (a
        bound of the interconnection's resolvent from the fixed random probes
        ``r_A = ‖(sI − A)⁻¹ v‖``, ``r_F = ‖(sI − F)⁻¹ w‖``).  The last ``shared`` points
        are the plant's shared random points: ``r_A`` there is the factor's.
        """
        pts = np.asarray(points, dtype=complex).copy()
        todo = np.arange(pts.size)
        lim = LEAK_TOL / 100 / (_EPS * self.N * max(self.scale, 1.0))
        first = True
        for _ in range(60):
            if not todo.size:
                break
            s = pts[todo]
            if first and shared:
                own = pts.size - shared
                ra = np.empty(s.size)
                Xp = self.factor.solve(s[:own], self.UAva[:, None])
                self._probe = (s[:own].copy(), Xp)  # point_gains reuses it where unmoved
                ra[:own] = np.linalg.norm(Xp, axis=(1, 2))
                ra[own:] = np.linalg.norm(self.factor.random_response(None), axis=(1, 2))
            else:
                ra = np.linalg.norm(_tri_solve_many(self.TA, s, self.UAva[:, None]), axis=(1, 2))
            first = False
            if self.on_blocks is not None:  # in F's own coordinates, O(k) per point
                g = self.g
                rf = np.linalg.norm(
                    _on_column(
                        g.F, g.M[0], self.on_blocks, s, self.vf, self._fkey, self.factor.on_memo
                    ),
                    axis=1,
                )
            elif self.k:
                rf = np.linalg.norm(_tri_solve_many(self.TF, s, self.UFvf[:, None]), axis=(1, 2))
            else:
                rf = np.zeros(s.size)
            r = ra + rf + rf * self.nE * self.nCp * ra
            bad = ~(np.isfinite(r) & (r <= lim))
            pts[todo[bad]] *= 2
            todo = todo[bad]
        return pts

    def generator_tf(self, s: complex) -> tuple[np.ndarray, np.ndarray]:
        """``G_y(s) = −M (sI − F)⁻¹ E − H`` and ``G_u(s) = M (sI − F)⁻¹ G + K``."""
        g = self.g
        T = np.hstack([-g.H, g.K]).astype(complex)
        if self.k and self.on_blocks is not None:  # h (sI − F)⁻¹ in O(k)
            row = rows_resolvent(g.F, g.M[0], self.on_blocks, np.array([s], dtype=complex))
            if not np.all(np.isfinite(row)):
                raise np.linalg.LinAlgError("Singular matrix: s is a pole of the generator")
            T = T + row @ np.hstack([-g.E, g.G])
        elif self.k:
            T = T + self.MUF @ self._solve_F(s, self.UFEG)
        return T[:, : g.q], T[:, g.q :]

    def _state_response(self, pts: np.ndarray, UB: np.ndarray) -> np.ndarray:
        """``(sI − T_A)⁻¹ UB`` at every point, ``(P, n, cols)`` (zero columns not solved)."""
        out = np.zeros((pts.size, self.TA.shape[0], UB.shape[1]), dtype=complex)
        nz = np.flatnonzero(np.any(UB != 0, axis=0))
        if nz.size:
            out[:, :, nz] = _tri_solve_many(self.TA, pts, UB[:, nz])
        return out

    def _plant_response(self, pts: np.ndarray, UB: np.ndarray) -> np.ndarray:
        """``C U (sI − T_A)⁻¹ UB`` at every point, ``(P, q, cols)``; the zero columns (a
        sensor fault has ``Bx = 0``) are not solved for."""
        out = np.zeros((pts.size, self.g.q, UB.shape[1]), dtype=complex)
        nz = np.flatnonzero(np.any(UB != 0, axis=0))
        if nz.size:
            out[:, :, nz] = self.CUA @ _tri_solve_many(self.TA, pts, UB[:, nz])
        return out

    def generator_tf_many(self, pts: np.ndarray) -> np.ndarray:
        """``[G_y(s), G_u(s)]`` at every point: shape ``(P, 1, q + m)`` (one residual row)
        or ``(P, rdim, q + m)``.

        ``M (sI − F)⁻¹`` is solved row-wise (one triangular solve per residual row and
        point, not one per input column); the result for the point sets of this
        composite (``points``, ``raw_points``) is computed once.
        """
        hit = self._tf.get(id(pts))
        if hit is not None and hit[0] is pts:
            return hit[1]
        own = pts is self.points or pts is self.raw_points
        if own and self.k and not self._tf:  # both point sets in one solve
            both = self.generator_tf_many(np.concatenate([self.points, self.raw_points]))
            P = self.points.size
            self._tf[id(self.points)] = (self.points, both[:P])
            self._tf[id(self.raw_points)] = (self.raw_points, both[P:])
            return self._tf[id(pts)][1]
        g = self.g
        D = np.hstack([-g.H, g.K]).astype(complex)
        if not self.k:
            out = np.broadcast_to(D, (pts.size, *D.shape)).copy()
        elif self.on_blocks is not None:  # M (sI − F)⁻¹ in O(k) per point
            rows = _on_rows(g.F, g.M[0], self.on_blocks, pts, self._fkey, self.factor.on_memo)
            out = D[None, :, :] + (rows @ np.hstack([-g.E, g.G]))[:, None, :]
        elif self.MUF.shape[0] < self.UFEG.shape[1]:
            out = D[None, :, :] + _tri_solve_rows_many(self.TF, pts, self.MUF) @ self.UFEG
        else:
            out = D[None, :, :] + self.MUF @ _tri_solve_many(self.TF, pts, self.UFEG)
        if own:
            self._tf[id(pts)] = (pts, out)
        return out

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
        pts = self.points
        P, q = pts.size, self.g.q
        # the row's own points, then the plant's shared ones (responses computed once;
        # a shared point moved clear of rounding is solved here)
        f = self.factor
        own = P - f.plant_random.size
        probe = self.CUA @ f.random_response(None)
        shared = np.concatenate([f.random_response(c[0]) for c in channels] + [probe], axis=2)
        moved = np.flatnonzero(pts[own:] != f.plant_random)
        if moved.size:
            shared[moved] = self._plant_response(pts[own:][moved], UB)
        Yown = np.empty((own, q, UB.shape[1]), dtype=complex)
        Yown[:, :, :-1] = self._plant_response(pts[:own], UB[:, :-1])
        p0, Xp = getattr(self, "_probe", (np.zeros(0), None))
        same = p0.size == own and Xp is not None
        kept = (pts[:own] == p0) if same else np.zeros(own, dtype=bool)
        if np.any(kept):
            Yown[kept, :, -1:] = self.CUA @ Xp[kept]  # type: ignore[index]
        if not np.all(kept):
            Yown[~kept, :, -1:] = self._plant_response(pts[:own][~kept], UB[:, -1:])
        Yall = np.concatenate([Yown, shared])
        cr = np.linalg.norm(Yall[:, :, -1], axis=1)
        Qall = self.generator_tf_many(pts)
        Gy, Gu = Qall[:, :, :q], Qall[:, :, q:]

        def norms(X: np.ndarray) -> np.ndarray:
            if X.shape[2] == 0:
                return np.zeros(P)
            if X.shape[1] == 1:
                return np.linalg.norm(X[:, 0, :], axis=1)
            return np.linalg.norm(X, ord=2, axis=(1, 2))

        nGy, nGu = norms(Gy), norms(Gu)
        i = 0
        for c, (ch, w) in enumerate(zip(channels, widths, strict=True)):
            T = Gy @ (Yall[:, :, i : i + w] + ch[1][None, :, :])
            i += w
            den = nGy * (cr * base[c][0] + base[c][1])
            if len(ch) > 2 and ch[2] is not None:  # the known input: u enters G too
                T = T + Gu
                den = den + nGu
            num = np.linalg.norm(T.reshape(P, -1), axis=1)
            sel = den > 0
            if np.any(sel):
                best[c] = float(np.max(num[sel] / den[sel]))
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
        state = bool(np.any(UB))
        Dall = np.hstack([Df for _, Df in sigs])

        def T(s: complex) -> np.ndarray:
            Gy, _ = self.generator_tf(s)
            if not state:  # sensor faults only: no plant state is driven
                return Gy @ Dall
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


def _boundary_points(
    scale: float, count: int, eigenvalues: np.ndarray, dt: float, seed: int = 12345
) -> np.ndarray:
    """Random frequencies: ``s = iω`` (``ω`` at the scale of :func:`_points`) or ``z = e^{iθ}``.

    The leakage angle is measured on the stability boundary, i.e. on the frequency
    response that a residual shows in time: off the boundary a residual that moves many
    unstable eigenvalues through one output is exponentially small (its ``f(s)`` of
    :mod:`~geomfdi.synthesis.least_order.orthonormal_row`
    is ``Π (s − λ) / (s − μ)``), so rounding of any
    realisation would read as a large angle there while the response is exact.
    """
    rng = np.random.default_rng(seed)
    if dt > 0:
        return np.exp(1j * rng.uniform(0.15, np.pi - 0.15, count))
    return 1j * np.abs(_points(scale, count, eigenvalues, seed))


def fault_gains(
    g: ResidualGenerator,
    plant: Plant,
    faults: Sequence[Fault],
    *,
    method: str = "points",
    factor: PlantFactor | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Relative gain and DC gain from each fault to the residual, on the physical model."""
    sigs = fault_matrices(faults, plant.n, plant.q)
    return _gains(Composite(g, plant, factor), sigs, method)


def _gains(comp: Composite, sigs: list, method: str) -> tuple[np.ndarray, np.ndarray]:
    if not sigs:
        return np.zeros(0), np.zeros(0)
    dcs = comp.dc_gains(sigs)
    if method == "points":
        gains = comp.point_gains([(Bf, Df) for Bf, Df in sigs])
    else:
        gains = np.array([comp.krylov_gain(*comp.channel(Bf, Df)) for Bf, Df in sigs])
    return np.asarray(gains, dtype=float), dcs


def _input_gain(comp: Composite, method: str) -> float:
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


def frequency_gains(comp: Composite, sigs: list, omegas: np.ndarray) -> np.ndarray:
    """``‖T_j(s)‖`` from each fault on the stability boundary: ``s = iω`` (continuous) or
    ``z = e^{iω}`` (discrete), one row per frequency; a plant or generator pole hit
    exactly gives ``inf``."""
    if not sigs:
        return np.zeros((omegas.size, 0))
    widths = [Bf.shape[1] for Bf, _ in sigs]
    UB = comp.UAh @ np.hstack([Bf for Bf, _ in sigs])
    Dall = np.hstack([Df for _, Df in sigs])
    edges = np.cumsum([0, *widths])
    out = np.full((omegas.size, len(sigs)), np.inf)
    pts = np.exp(1j * omegas) if comp.plant.dt > 0 else 1j * omegas
    dist = np.min(np.abs(comp.eig[None, :] - pts[:, None]), axis=1, initial=np.inf)
    ok = dist >= 1e-12 * max(comp.scale, 1.0)  # a pole hit exactly: inf
    if np.any(ok):
        Gy = comp.generator_tf_many(pts[ok])[:, :, : comp.g.q]
        X = Gy @ (comp._plant_response(pts[ok], UB) + Dall[None, :, :])
        out[ok] = np.stack(
            [
                np.linalg.norm(X[:, :, edges[j] : edges[j + 1]], axis=(1, 2))
                for j in range(len(sigs))
            ],
            axis=1,
        )
    return out
