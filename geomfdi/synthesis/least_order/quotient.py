"""The decoupled quotient of one residual row: S*, the quotient map and its system.

See the user guide, *Theory: least-order synthesis* (``docs/theory/least-order.md``,
sections 1–2).

**Decoupled signals with feedthrough.**  A signal ``w`` to be decoupled (a disturbance, a
decoupled fault) enters as ``x' = … + B_w w``, ``y = … + D_w w``.  Columns with
``D_w ≠ 0`` are made states of an augmented model (``v' = free``)::

    A_a = [[A, B_w'], [0, 0]],   C_a = [C, D_w'],   L_a = [[B_w'', 0], [0, I]]

(``'``: columns with an output part, ``''``: the others), so that no output filter is
needed and rows with ``H C = 0`` come out as static (order-0) parity relations.

**Quotient.**  With ``S = S*(A_a, C_a, L_a)``, Q an orthonormal basis of S^⊥, P = Qᵀ,
``D0 = −Q Qᵀ A_a S (C_a S)⁺`` and H an orthonormal basis of the left null space of
``C_a S`` (so ``H [C S, D_w'] = 0``), ``ξ = P x_a`` obeys::

    ξ' = A0 ξ − P D0 y + (P B + P D0 D_u) u + (P B_f + P D0 D_f) f,
    z  = H (y − D_u u) = M ξ + H D_f f

with ``A0 = P (A_a + D0 C_a) Q`` and ``M = H C_a Q``; decoupled signals are gone.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg.blas

from geomfdi.geometry.subspace import Subspace, _norm2, pinv
from geomfdi.geometry.unobservability import min_unobservability_subspace
from geomfdi.tolerance import GAP_WARN, get_rtol, tolerance

__all__ = ["Quotient", "quotient_model", "adaptive_quotient_model", "QUOTIENT_IDENTITY_TOL"]

QUOTIENT_IDENTITY_TOL = 1e-8
"""Largest relative residual of the quotient identities (the design's ``IDENTITY_TOL``)."""

RTOL_LADDER = (10.0, 100.0, 1e3, 1e4, 0.1)
"""Factors of the tolerance in force tried for S* when its decisions are close or its
quotient identities fail (:func:`adaptive_quotient_model`)."""

SCHUR_EIG_MIN = 12
"""Quotient dimension above which its eigenvalues are read off its complex Schur form."""

RTOL_MAX = 1e-7
"""Largest tolerance the ladder reaches (a dropped singular value above it would break
the quotient identities)."""


@dataclass
class Quotient:
    """The decoupled quotient system of one row (module Notes)."""

    A0: np.ndarray
    M: np.ndarray
    H: np.ndarray
    Bqy: np.ndarray
    Bqu: np.ndarray
    Bf: list[np.ndarray]
    Df: list[np.ndarray]
    P: np.ndarray
    S: Any
    n_aug: int
    identities: dict[str, float] = field(default_factory=dict)
    rtol: float | None = None
    """The tolerance S* was decided with when it differs from the one in force."""
    plant_schur: tuple[np.ndarray, np.ndarray] | None = None
    """Complex Schur form ``(T, U)`` of the (balanced) plant matrix A, when at hand: a
    quotient that is A in rotated coordinates takes its Schur form from it (:attr:`schur`)."""

    @property
    def k(self) -> int:
        return self.A0.shape[0]

    @property
    def rho(self) -> int:
        return self.M.shape[0]

    def norm(self, name: str) -> float:
        """Spectral norm of the matrix ``name`` (``"A0"``, ``"M"``), computed once."""
        key = f"_norm_{name}"
        mat = getattr(self, name)
        cached = self.__dict__.get(key)
        if cached is None or cached[0] is not mat:
            cached = (mat, float(np.linalg.norm(mat, 2)) if mat.size else 0.0)
            self.__dict__[key] = cached
        return cached[1]

    @property
    def eigenvalues(self) -> np.ndarray:
        """Eigenvalues of ``A0`` (computed once: every pole check of a search uses them).

        Read off the complex Schur form when it is at hand or the quotient is large (a
        row of such a quotient is realised through that form anyway, :attr:`schur`)."""
        cached = self.__dict__.get("_eigenvalues")
        if cached is None or cached[0] is not self.A0:
            if not self.A0.size:
                ev = np.zeros(0, complex)
            elif self.A0.shape[0] > SCHUR_EIG_MIN or "_schur" in self.__dict__:
                ev = np.diag(self.schur[0]).copy()
            else:
                ev = np.linalg.eigvals(self.A0)
            cached = (self.A0, ev)
            self.__dict__["_eigenvalues"] = cached
        return cached[1]

    def resolvent_rows(self, points: np.ndarray) -> list[np.ndarray]:
        """``M (sI − A0)⁻¹`` (ρ × k) at every point: above ``SCHUR_EIG_MIN`` states by
        triangular solves on the complex Schur form (:attr:`schur`, ``O(ρ k²)`` per
        point), else by one dense solve per point."""
        return _resolvent_rows(self, points)

    @property
    def schur(self) -> tuple[np.ndarray, np.ndarray]:
        """Complex Schur form ``A0 = U T Uᴴ`` as ``(T, U)`` (computed once: every
        realisation attempt of the row evaluates the quotient's resolvent through it)."""
        cached = self.__dict__.get("_schur")
        if cached is None or cached[0] is not self.A0:
            from geomfdi.generators.gains import complex_schur

            TU = _schur_from_plant(self.A0, self.P, self.plant_schur)
            cached = (self.A0, TU if TU is not None else complex_schur(self.A0))
            self.__dict__["_schur"] = cached
        return cached[1]


SCHUR_REUSE_TOL = 100.0
"""Backward error, in units of ``n ε ‖A0‖``, below which the plant's Schur form is taken
for the quotient's (:func:`_schur_from_plant`)."""


def _resolvent_rows(Qm: Quotient, points: np.ndarray) -> list[np.ndarray]:
    k, M = Qm.k, Qm.M
    if k <= SCHUR_EIG_MIN:
        return [
            np.linalg.solve((s * np.eye(k) - Qm.A0).T, M.T).T if k else M[:, :0] for s in points
        ]
    T, U = Qm.schur
    from geomfdi.generators.gains import _tri_solve_rows_many

    pts = np.asarray(points, dtype=complex)
    return list(_tri_solve_rows_many(T, pts, M @ U) @ U.conj().T)


REORDER_MAX = 8
"""A quotient of order k takes the plant's reordered Schur form when at most
``k / REORDER_MAX`` eigenvalues of the plant are factored out (the reordering costs
``O(n)`` per swap and ``O(k)`` swaps per eigenvalue moved)."""


def _schur_from_plant(
    A0: np.ndarray, P: np.ndarray, TU: tuple[np.ndarray, np.ndarray] | None
) -> tuple[np.ndarray, np.ndarray] | None:
    """``(T0, W)`` with ``A0 = W T0 Wᴴ`` from the plant's ``A = U T Uᴴ``, or None.

    When S* lies in the coordinates of decoupled feedthrough only (nothing of the plant's
    state is factored out: ``P`` square with orthonormal rows), the quotient is the plant
    in rotated coordinates, ``A0 = P A Pᵀ``, and ``(T, W = P U)`` is a Schur form of it.
    When S* also holds an A-invariant subspace ``S_p`` of the plant's state (``P``: k × n
    with orthonormal rows, ``S_p = (Im Pᵀ)^⊥``, e.g. modes no output of the row sees), the
    quotient is A modulo ``S_p``: the plant's form is reordered (LAPACK ``ztrsen``) so that
    its first ``n − k`` Schur vectors span ``S_p`` (the eigenvalues of A on ``S_p`` are
    taken first; at most ``k / REORDER_MAX`` of them), and ``(T_22, W = P U_2)`` is a
    Schur form of ``A0``, since
    ``A U_2 = U_1 T_12 + U_2 T_22`` and ``P U_1 = 0`` (Golub & Van Loan 2013, §7.6.2).
    The form is accepted only when it is one to working accuracy: ``P Pᵀ = I``,
    ``‖P U_1‖ ≤ SCHUR_REUSE_TOL · k ε`` (W unitary) and
    ``‖A0 W − W T0‖_F = ‖Wᴴ A0 W − T0‖_F ≤ SCHUR_REUSE_TOL · k ε ‖A0‖_F`` (the backward
    error of the QR algorithm itself, Golub & Van Loan 2013, §7.5.6).  ``O(k³)`` products
    and a reordering instead of the QR algorithm; the rows of a bank on one plant share
    the entries of T, hence their eigenvalues bit for bit.
    """
    if TU is None or not A0.size:
        return None
    T, U = TU
    k = A0.shape[0]
    n = T.shape[0]
    if P.shape != (k, n) or T.shape != (n, n) or k > n:
        return None
    tol = SCHUR_REUSE_TOL * k * float(np.finfo(float).eps)
    if float(np.max(np.abs(P @ P.T - np.eye(k)))) > tol:
        return None
    if k < n:
        if REORDER_MAX * (n - k) > k:  # many swaps: the QR algorithm on A0 is cheaper
            return None
        TU = _reordered(T, U, P, tol)
        if TU is None:
            return None
        T, U = TU
    W = _real_times(P, U)
    # ‖Wᴴ A0 W − T‖ = ‖A0 W − W T‖ for a unitary W; W T by a triangular product
    WT = scipy.linalg.blas.ztrmm(1.0, np.asfortranarray(T), W, side=1)
    err = float(np.linalg.norm(_real_times(A0, W) - WT))
    if not err <= tol * float(np.linalg.norm(A0)):
        return None
    return T, W


def _real_times(M: np.ndarray, Z: np.ndarray) -> np.ndarray:
    """``M Z`` for a real M and a complex Z by two real products (half the flops of the
    complex product numpy would form after promoting M)."""
    out = np.empty((M.shape[0], Z.shape[1]), dtype=complex)
    out.real = M @ np.ascontiguousarray(Z.real)
    out.imag = M @ np.ascontiguousarray(Z.imag)
    return out


def _reordered(
    T: np.ndarray, U: np.ndarray, P: np.ndarray, tol: float
) -> tuple[np.ndarray, np.ndarray] | None:
    """``(T_22, U_2)`` of the plant's Schur form reordered so that its first ``n − k``
    Schur vectors span ``S_p = (Im Pᵀ)^⊥`` (:func:`_schur_from_plant`), or None when
    ``S_p`` is not an invariant subspace of the form to working accuracy.

    The eigenvalues to move first are those of A on ``S_p`` (of ``Gᴴ T G``, G an
    orthonormal basis of ``Uᴴ S_p``), each matched to the nearest Schur value not yet
    taken; a wrong match or a subspace that is not invariant leaves ``‖P U_1‖`` large
    and is refused."""
    import scipy.linalg.lapack as lapack

    n, k = T.shape[0], P.shape[0]
    m = n - k
    Qf, _ = np.linalg.qr(P.T, mode="complete")
    G = U.conj().T @ Qf[:, k:]  # Uᴴ S_p, orthonormal
    mu = np.linalg.eigvals(G.conj().T @ (T @ G))
    lt = np.diag(T)
    select = np.zeros(n, dtype=np.int32)
    for v in mu[np.argsort(-np.abs(mu))]:
        d = np.abs(lt - v)
        d[select.astype(bool)] = np.inf
        select[int(np.argmin(d))] = 1
    if int(select.sum()) != m:
        return None
    Ts, Us, _, mm, _, _, info = lapack.ztrsen(select, T, U, job="N")
    if info != 0 or mm != m:
        return None
    if not float(np.max(np.abs(P @ Us[:, :m]), initial=0.0)) <= tol:
        return None
    return np.triu(Ts[m:, m:]), Us[:, m:]


def quotient_model(
    A: np.ndarray,
    B: np.ndarray,
    C: np.ndarray,
    Du: np.ndarray,
    Bw: np.ndarray,
    Dw: np.ndarray,
    targets: list[tuple[np.ndarray, np.ndarray]],
) -> Quotient:
    """Augment decoupled feedthrough, compute S* and the quotient (module Notes)."""
    n, q = A.shape[0], C.shape[0]
    sc = max(_norm2(np.vstack([Bw, Dw])) if Bw.size else 0.0, 1e-300)
    direct = np.linalg.norm(Dw, axis=0) > get_rtol(n + q) * sc if Dw.size else np.zeros(0, bool)
    Wf_B, Wf_D = Bw[:, direct], Dw[:, direct]
    Ws = Bw[:, ~direct] if Bw.size else np.zeros((n, 0))
    na = int(np.count_nonzero(direct))
    Aa = np.zeros((n + na, n + na))
    Aa[:n, :n] = A
    Aa[:n, n:] = Wf_B
    Ca = np.hstack([C, Wf_D])
    La = np.zeros((n + na, Ws.shape[1] + na))
    La[:n, : Ws.shape[1]] = Ws
    La[n:, Ws.shape[1] :] = np.eye(na)
    Ba = np.vstack([B, np.zeros((na, B.shape[1]))])
    # a static model (no state, no decoupled feedthrough) has S* = 0 and no quotient state
    S = min_unobservability_subspace(Aa, Ca, La) if n + na else None
    nC, nA = max(_norm2(Ca), 1e-300), _norm2(Aa)
    if S is not None and S.dim:
        Sb = S.basis
        CS = Ca @ Sb
        Q = S.complement().basis
        CSp = pinv(CS, nC, what="(C S)⁺")
        D0 = -Q @ (Q.T @ Aa @ Sb @ CSp)
        # the size D0 has before the cancellation Qᵀ A S ≈ 0 (S nearly A-invariant): the
        # scale against which its entries are rounding
        nD0 = max(_norm2(D0), nA * _norm2(CSp))
        H = Subspace(CS, scale=nC).complement().basis.T
    else:
        Sb = np.zeros((n + na, 0))
        Q = np.eye(n + na)
        D0 = np.zeros((n + na, q))
        nD0 = 0.0
        H = np.eye(q)
    P = Q.T
    A0 = P @ (Aa + D0 @ Ca) @ Q
    M = H @ Ca @ Q
    ident = {
        "P (A + D0 C) S = 0": float(
            _norm2(P @ (Aa + D0 @ Ca) @ Sb) / max(nA, _norm2(D0) * nC, 1e-300)
        )
        if Sb.size
        else 0.0,
        "H C S = 0": float(_norm2(H @ Ca @ Sb) / nC) if Sb.size and H.size else 0.0,
    }
    Bqy = -P @ D0
    Bqu = P @ Ba + P @ D0 @ Du
    Bf, Df = [], []
    rt = 1e3 * get_rtol(n + na + q)
    for Bt, Dt in targets:  # a target that reaches the quotient only through rounding is 0
        b = P @ np.vstack([Bt, np.zeros((na, Bt.shape[1]))]) + P @ D0 @ Dt
        dd = H @ Dt
        if _norm2(b) <= rt * (_norm2(Bt) + nD0 * _norm2(Dt)):
            b = np.zeros_like(b)
        if _norm2(dd) <= rt * _norm2(Dt):
            dd = np.zeros_like(dd)
        Bf.append(b)
        Df.append(dd)
    return Quotient(A0, M, H, Bqy, Bqu, Bf, Df, P[:, :n], S, n + na, ident)


def _ok(Qm: Quotient) -> bool:
    return all(v <= QUOTIENT_IDENTITY_TOL for v in Qm.identities.values())


def adaptive_quotient_model(
    A: np.ndarray,
    B: np.ndarray,
    C: np.ndarray,
    Du: np.ndarray,
    Bw: np.ndarray,
    Dw: np.ndarray,
    targets: list[tuple[np.ndarray, np.ndarray]],
) -> Quotient:
    """:func:`quotient_model` with S*'s rank decisions adapted to the row.

    No single tolerance suits every row of a badly scaled plant: the recursion of S*
    reaches some directions weakly (singular values far below ``‖A‖``), and whether such
    a direction is kept depends on where the tolerance falls.  The quotient is formed at
    the tolerance in force; when its identities fail (S is not conditioned invariant) or
    its closest decision has a gap below :data:`geomfdi.tolerance.GAP_WARN`, S* is
    recomputed at the tolerances :data:`RTOL_LADDER` × the one in force (up to
    :data:`RTOL_MAX`), and among the quotients whose identities hold, the one whose
    closest rank decision has the **largest** singular-value gap is kept (the rank
    decision taken at the largest gap, as in Varga 2017, Section 10.4).  ``Qm.rtol``
    records the tolerance used when it differs from the one in force.
    """
    n = A.shape[0] + Dw.shape[1]
    base = get_rtol(n)
    Qm = quotient_model(A, B, C, Du, Bw, Dw, targets)
    if _ok(Qm) and Qm.S.min_gap >= GAP_WARN:
        return Qm
    best = Qm if _ok(Qm) else None
    for f in RTOL_LADDER:
        rt = base * f
        if rt > RTOL_MAX or rt <= 0 or rt >= 1:
            continue
        with tolerance(rt):
            cand = quotient_model(A, B, C, Du, Bw, Dw, targets)
        if not _ok(cand):
            continue
        cand.rtol = rt
        if best is None or cand.S.min_gap > best.S.min_gap:
            best = cand
    return best if best is not None else Qm
