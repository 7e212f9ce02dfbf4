"""The full-quotient observer: (F, E, G, M, H, K) from S* (Hou, Wen & Chen 2011, §3.4).

This is the construction behind ``method="full"``, ``"paper"`` and ``"mvw"``; the default
least-order rows are in :mod:`geomfdi.synthesis.least_order.search`.  See the user guide,
*Theory: the geometric approach* (``docs/theory/geometric-approach.md``).

For a residual that must see the faults ``target`` and ignore ``decouple`` (and every
disturbance), with S = S*(Σ_{i∈decouple} Im L_i + Im L_d) on the design model of
:mod:`geomfdi.synthesis.sensor_transforms`, Q an orthonormal basis of S^⊥ and P = Qᵀ::

    D0 = −Q Qᵀ A S (C S)⁺              P (A + D0 C) S = 0
    H  = orthonormal rows of Im C ⊖ C S  Ker H C = Ker C + S
    M  = H C Q,   A0 = P (A + D0 C) Q    (M, A0) observable
    F  = A0 + D1 M                       D1 places the spectrum (only what must move)
    D  = D0 + Q D1 H,   E = P D,   G = P B + E Du,   K = H Du

giving ``w' = F w − E y + G u, r = M w − H y + K u`` with the identities
``F P = P A + E C``, ``M P = H C`` checked on every design, so that ``e = w − P x``
obeys ``e' = F e − P L m`` and ``r = M e``.

Beyond the construction of Hou, Wen & Chen 2011 (§3.4, eq. 17–23):

* **Parity rows.**  With redundant sensors (rank C < q, e.g. a zero or a repeated row
  of C) a target's direct output part can be read by static relations ``N y``,
  ``N C = 0``, which ``Im C ⊖ C S`` misses; the rows of ``(Im C)^⊥`` that see the
  targets' direct part are appended to H (with zero rows in M).  When S* = R^n they
  are the whole generator (order 0).
* **Default spectrum.**  Eigenvalues of A0 that violate the margin are *mirrored*
  across it (continuous ``λ → −λ̄ − 2·margin``, discrete ``λ → margin² / λ̄``) by the
  minimum-norm output injection (zero-state-weight Riccati solution, one Lyapunov or
  Stein equation); the others are kept.  Pushing them onto the margin line instead is
  far worse conditioned for quotients observed through few outputs.
* **Numerical failure.**  The computed spectrum of A0 + D1 M and the delivered
  generator's poles are checked; a design whose placement or minimal realization is
  too ill-conditioned to meet the request, or whose identities fail, raises
  :class:`~geomfdi.errors.DesignError` (a bank reports the row missing with
  "design failed numerically") rather than delivering an unstable generator.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import scipy.linalg

from geomfdi._validation import as_indices, as_positive, as_sequence_of
from geomfdi.errors import DesignError, GeomFDIError, NotIsolableError
from geomfdi.generators.gains import LEAK_TOL, PlantFactor, fault_gains
from geomfdi.generators.generator import ResidualGenerator
from geomfdi.generators.realization import minimal_realization, reachable_subspace
from geomfdi.geometry.subspace import Subspace, _norm2, pinv
from geomfdi.geometry.unobservability import measurement_map, min_unobservability_subspace
from geomfdi.model.faults import Fault
from geomfdi.model.plant import Plant, as_plant
from geomfdi.synthesis.least_order.placement import place_poles
from geomfdi.synthesis.least_order.search import validate_poles
from geomfdi.synthesis.sensor_transforms import DesignModel, pseudo_actuator_model
from geomfdi.tolerance import rank_decision

__all__ = ["build_full", "default_margin", "IDENTITY_TOL"]

IDENTITY_TOL = 1e-8
"""Largest relative residual of the construction identities accepted in a design."""


# ----------------------------------------------------------------- poles
def default_margin(dt: float) -> float:
    """Default stability requirement on the generator's spectrum.

    Continuous: every eigenvalue must have ``Re λ ≤ −1``; discrete: ``|λ| ≤ 0.5``.
    Eigenvalues already inside are kept; the others are mirrored across the margin
    (continuous ``λ → −λ̄ − 2·margin``, discrete ``λ → margin² / λ̄``; see ``_place``).
    """
    return 0.5 if dt > 0 else 1.0


def checked_poles(poles: Any) -> Any:
    """``poles`` (one spectrum) checked up front: ``None``, or a flat list of finite numbers
    closed under complex conjugation (the spectrum of a real generator).  Returned as given;
    its count and stability are checked against the row's order where the row is built."""
    if poles is None:
        return None
    try:
        arr = np.atleast_1d(np.asarray(poles))
    except (TypeError, ValueError, OverflowError) as exc:
        raise DesignError(f"poles: must be a list of numbers ({exc})", argument="poles") from exc
    if arr.ndim != 1 or arr.dtype.kind not in "iufc":
        raise DesignError(
            f"poles: must be a flat list of numbers, got {poles!r:.60}", argument="poles"
        )
    arr = arr.astype(complex)
    if not np.all(np.isfinite(arr)):
        raise DesignError("poles: must be finite", argument="poles")
    if not np.allclose(np.sort_complex(arr), np.sort_complex(arr.conj())):
        raise DesignError(
            "poles: complex poles must come in conjugate pairs (a real generator)",
            argument="poles",
        )
    return poles


def row_poles(poles: Any, rows: int, check: Callable[[Any], Any] = checked_poles) -> list[Any]:
    """``poles`` for a bank of ``rows`` rows: ``None`` (every row its default), one spectrum
    for every row, or a list with one spectrum (or ``None``) per row; each row's entry passed
    through ``check`` (:func:`checked_poles` by default)."""
    if poles is None:
        return [None] * rows
    if (
        isinstance(poles, list | tuple)
        and poles
        and all(p is None or isinstance(p, list | tuple | np.ndarray) for p in poles)
    ):
        if len(poles) != rows:
            raise DesignError(
                f"poles: a per-row list must have {rows} entries, got {len(poles)}",
                argument="poles",
            )
        return [check(p) for p in poles]
    return [check(poles)] * rows


def target_decouple(target: Any, decouple: Any, nf: int) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """A single residual's ``target`` and ``decouple`` fault indices, validated.

    ``decouple=None`` means every fault that is not a target; a fault may not be both.
    """
    tgt = as_indices(target, "target", nf)
    if not tgt:
        raise GeomFDIError("target: at least one fault index is required", argument="target")
    dec = (
        tuple(j for j in range(nf) if j not in tgt)
        if decouple is None
        else as_indices(decouple, "decouple", nf)
    )
    both = set(tgt) & set(dec)
    if both:
        raise GeomFDIError(f"decouple: faults {sorted(both)} are also targets", argument="decouple")
    return tgt, dec


def row_split(row: np.ndarray) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """A structure row (boolean, one entry per fault) as its target and decoupled fault
    indices: the faults the residual must see and those it must ignore."""
    return tuple(int(j) for j in np.flatnonzero(row)), tuple(int(j) for j in np.flatnonzero(~row))


def checked_margin(margin: Any, dt: float) -> float:
    """``margin`` validated: finite, > 0, and < 1 for a discrete plant (a radius)."""
    if margin is None:
        return default_margin(dt)
    mg = as_positive(margin, "margin")
    if dt > 0 and mg >= 1.0:
        raise GeomFDIError(
            f"margin: must lie in (0, 1) for a discrete plant (a radius), got {mg}",
            argument="margin",
        )
    return mg


def _is_good(lam: complex, dt: float, margin: float, slack: float = 0.0) -> bool:
    if dt > 0:
        return abs(lam) <= margin * (1.0 + slack)
    return lam.real <= -margin + slack * max(1.0, abs(lam))


_SORT_SLACKS = (1e-6, 1e-5, 1e-4, 1e-3)
"""Relative slacks (tried in turn) within which an eigenvalue on the margin counts as
meeting it.  Eigenvalues often sit exactly on it (the filter pole ``a = 0.5`` of a
discrete design, ``−a = −1`` of a continuous one, often repeated): mirroring one of them
would be singular, and rounding can move it across the boundary during the Schur
reordering, which LAPACK reports as a failed sort (then the next slack is tried)."""


def _split_schur(At: np.ndarray, dt: float, margin: float) -> tuple[np.ndarray, np.ndarray, int]:
    """Ordered real Schur form of ``At`` with the eigenvalues meeting the margin first."""
    for slack in _SORT_SLACKS:
        try:
            return scipy.linalg.schur(
                At,
                output="real",
                sort=lambda x, y, sl=slack: _is_good(complex(x, y), dt, margin, sl),
            )
        except np.linalg.LinAlgError:
            continue
    raise DesignError(
        f"poles: the spectrum {np.linalg.eigvals(At).tolist()} sits on the stability margin "
        f"{margin:g} and cannot be split reliably; give the poles explicitly",
        argument="poles",
    )


def _check_spectrum(poles: Any, k: int, dt: float, row: str) -> np.ndarray:
    try:
        arr = np.atleast_1d(np.asarray(poles))
    except (TypeError, ValueError, OverflowError) as exc:
        raise DesignError(f"poles: must be a list of numbers ({exc})", argument="poles") from exc
    if arr.ndim != 1 or arr.size != k:
        raise DesignError(
            f"poles: expected {k} poles for {row} (the order of its quotient observer), got "
            f"{arr.size}",
            argument="poles",
        )
    return validate_poles(arr, dt)


class _NumericalDesignError(DesignError):
    """A construction step failed numerically (ill-conditioned placement or identities).

    Raised as a :class:`DesignError` by :func:`design_residual_generator`; a bank reports
    the row as missing with the reason instead of failing as a whole.
    """


def _mirror_gain(T22: np.ndarray, B2: np.ndarray, dt: float, margin: float) -> np.ndarray:
    """Minimum-norm feedback K2 mirroring ``eig(T22)`` across the margin.

    Continuous (every eigenvalue has ``Re λ > −m``): with ``W`` solving
    ``(T22 + mI) W + W (T22 + mI)ᵀ = B2 B2ᵀ``, ``K2 = B2ᵀ W⁻¹`` gives
    ``T22 − B2 K2 + mI = −W (T22 + mI)ᵀ W⁻¹``: each λ goes to ``−λ̄ − 2m``.
    Discrete (``|λ| > m``): with ``Ã = T22 / m``, ``B̃ = B2 / m`` and ``W`` solving the
    Stein equation ``W − Ã⁻¹ W Ã⁻ᵀ = Ã⁻¹ B̃ B̃ᵀ Ã⁻ᵀ``, ``K2 = B̃ᵀ (W + B̃ B̃ᵀ)⁻¹ Ã`` gives
    ``Ã − B̃ K2 = W Ã⁻ᵀ W⁻¹``: each λ goes to ``m² / λ̄``.
    This is the zero-state-weight LQ (Riccati) solution of the shifted problem, the
    smallest gain that achieves the margin.
    """
    nb = T22.shape[0]
    if dt > 0:
        At = T22 / margin
        Bs = B2 / margin
        Ai = np.linalg.inv(At)
        AiB = Ai @ Bs
        W = scipy.linalg.solve_discrete_lyapunov(Ai, AiB @ AiB.T)
        W = (W + W.T) / 2
        return Bs.T @ np.linalg.solve(W + Bs @ Bs.T, At)
    W = scipy.linalg.solve_continuous_lyapunov(T22 + margin * np.eye(nb), B2 @ B2.T)
    W = (W + W.T) / 2
    return np.linalg.solve(W, B2).T


def _place(
    A0: np.ndarray, M: np.ndarray, poles: np.ndarray | None, dt: float, margin: float
) -> tuple[np.ndarray, dict[str, Any]]:
    """D1 with ``eig(A0 + D1 M)`` as requested; only violating eigenvalues when poles=None.

    Partial assignment: ordered real Schur form of ``A0ᵀ = U [[T11, T12], [0, T22]] Uᵀ``
    with the eigenvalues meeting the margin in T11; feedback acting on the T22
    coordinates only moves eig(T22) and keeps eig(T11).  Default: T22's eigenvalues are
    mirrored across the margin (:func:`_mirror_gain`, the minimum-norm choice; far
    better conditioned than pushing them onto the margin line).  Requested poles: the
    Schur method of :func:`geomfdi.synthesis.least_order.placement.place_poles` on the whole
    quotient.  The computed spectrum is checked afterwards; a placement that misses it
    (a high-order quotient observed through few outputs is intrinsically
    ill-conditioned) raises.
    """
    k = A0.shape[0]
    if k == 0:
        return np.zeros((0, M.shape[0])), {
            "kept": 0,
            "moved": 0,
            "computed_poles": np.zeros(0, dtype=complex),
        }
    At, Bt = A0.T, M.T
    if poles is not None:
        U, k1 = np.eye(k), 0
        T22 = At
    else:
        T, U, k1 = _split_schur(At, dt, margin)
        T22 = T[k1:, k1:]
    nb = k - k1
    info: dict[str, Any] = {"kept": k1, "moved": nb}
    if nb == 0:
        info["computed_poles"] = np.linalg.eigvals(A0)
        return np.zeros((k, M.shape[0])), info
    B2 = (U.T @ Bt)[k1:]
    # act through an orthonormal basis of Im B2ᵀ (full column rank)
    _, sv, Vt = np.linalg.svd(B2, full_matrices=False)
    rb = rank_decision(sv, _norm2(Bt), max(B2.shape), what="placement input", warn=False).rank
    Vr = Vt[:rb].T
    bad_eigs = np.linalg.eigvals(T22)
    if rb == 0:
        raise _NumericalDesignError(
            f"poles: eigenvalues {bad_eigs.tolist()} of the quotient cannot be moved (they are "
            "unobservable from the residual)",
            argument="poles",
        )
    try:
        if poles is None:
            # an eigenvalue just beyond the margin makes the equation nearly singular;
            # scipy then warns and perturbs it: the spectrum check below judges the result
            with np.errstate(all="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                K2 = _mirror_gain(T22, B2 @ Vr, dt, margin)
            if not np.all(np.isfinite(K2)):
                raise np.linalg.LinAlgError("singular Gramian")
            targets = (margin**2 / bad_eigs.conj()) if dt > 0 else (-bad_eigs.conj() - 2 * margin)
        else:
            targets = poles
            K2 = place_poles(T22, B2 @ Vr, targets)
    except (ValueError, np.linalg.LinAlgError) as exc:
        raise DesignError(
            f"poles: cannot place {np.asarray(targets if poles is not None else bad_eigs).tolist()}"
            f": {exc}",
            argument="poles",
        ) from exc
    K = np.zeros((M.shape[0], k))
    K[:, k1:] = Vr @ K2
    Kt = K @ U.T
    D1 = -Kt.T
    computed = np.linalg.eigvals(A0 + D1 @ M)
    info["computed_poles"] = computed
    info["requested_poles"] = np.asarray(targets)
    info["gain_norm"] = _norm2(D1)
    _check_placed(computed, poles, dt, margin)
    return D1, info


def _check_placed(computed: np.ndarray, poles: np.ndarray | None, dt: float, margin: float) -> None:
    """The computed spectrum must meet the request (margin, or the poles to 1e-4)."""
    if poles is None:
        bad = [lam for lam in computed if not _is_good(complex(lam), dt, margin, _SORT_SLACKS[-1])]
        if bad:
            raise _NumericalDesignError(
                f"poles: placement is ill-conditioned: the computed generator poles "
                f"{np.round(bad, 6).tolist()} violate the stability margin {margin:g}; give a "
                "smaller margin or explicit poles",
                argument="poles",
            )
        return
    miss = max(float(np.min(np.abs(computed - p)) / max(1.0, abs(p))) for p in np.asarray(poles))
    stable = np.abs(computed) < 1 if dt > 0 else computed.real < 0
    if miss > 1e-4 or not np.all(stable):
        raise _NumericalDesignError(
            f"poles: placement is ill-conditioned: requested {np.asarray(poles).tolist()}, "
            f"computed {np.round(computed, 6).tolist()}",
            argument="poles",
        )


# --------------------------------------------------------- construction
def _rel(x: np.ndarray, *scales: float) -> float:
    s = max([*scales, 1e-300])
    return float(np.linalg.norm(x, 2) / s) if x.size else 0.0


def _parity_rows(C: np.ndarray, direct: np.ndarray) -> np.ndarray:
    """Rows of ``(Im C)^⊥`` that see the direct output part ``direct`` of the targets.

    A static relation ``N y`` with ``N C = 0`` is blind to every state-side signal and
    reads the output part of a fault directly.  With the exact transform the decoupled
    faults' output parts sit on filtered channels, whose rows of the design C are
    independent, so ``N`` sees only target feedthrough (and u through K).  Returned as
    orthonormal rows spanning ``N N^T Im(direct)``; zero rows when C has full row rank
    or no target has a direct part.
    """
    q = C.shape[0]
    if direct.size == 0 or _norm2(direct) == 0 or q == 0:
        return np.zeros((0, q))
    Nb = Subspace(C, scale=_norm2(C)).complement().basis if _norm2(C) > 0 else np.eye(q)
    if Nb.shape[1] == 0:
        return np.zeros((0, q))
    seen = Subspace(Nb @ (Nb.T @ direct), scale=_norm2(direct))
    return seen.basis.T


def _construct(
    model: DesignModel,
    S: Subspace,
    poles: Any,
    margin: float,
    row: str,
    target: Sequence[int] = (),
) -> dict[str, Any]:
    A, B, C, Du = model.A, model.B, model.C, model.Du
    Q = S.complement().basis
    P = Q.T
    # D0 = −Q Qᵀ A S (C S)⁺ (``docs/theory/geometric-approach.md``).  Whether S is
    # conditioned invariant is judged by the identity P (A + D0 C) S = 0 checked below,
    # relative to the data's norms, not by the subspace-membership test of ``friend``,
    # whose rank decision on A (S ∩ Ker C) can be close for large n although S* itself
    # was decided with a wide gap.
    if S.dim < model.n:
        Sb = S.basis
        D0 = -Q @ (Q.T @ A @ Sb @ pinv(C @ Sb, _norm2(C), what="(C S)⁺"))
    else:
        D0 = np.zeros((model.n, C.shape[0]))
    Hobs = measurement_map(C, S)
    direct = [model.feedthrough[j] for j in target if model.feedthrough]
    Hpar = _parity_rows(C, np.hstack(direct) if direct else np.zeros((C.shape[0], 0)))
    Mobs = Hobs @ C @ Q
    A0 = P @ (A + D0 @ C) @ Q
    k = A0.shape[0]
    req = None if poles is None else _check_spectrum(poles, k, model.dt, row)
    D1obs, pinfo = _place(A0, Mobs, req, model.dt, margin)
    # parity rows: M = H C Q = 0 there, and they take no part in the placement
    H = np.vstack([Hobs, Hpar])
    M = np.vstack([Mobs, np.zeros((Hpar.shape[0], k))])
    D1 = np.hstack([D1obs, np.zeros((k, Hpar.shape[0]))])
    F = A0 + D1 @ M
    D = D0 + Q @ D1 @ H
    E = P @ D
    G = P @ B + E @ Du
    K = H @ Du
    nA, nC = _norm2(A), _norm2(C)
    ident = {
        "F P = P A + E C": _rel(F @ P - P @ A - E @ C, _norm2(F), nA, _norm2(E) * nC),
        "M P = H C": _rel(M @ P - H @ C, _norm2(M), nC),
        "P (A + D0 C) S = 0": _rel(P @ (A + D0 @ C) @ S.basis, nA, _norm2(D0) * nC),
    }
    bad = {k_: v for k_, v in ident.items() if v > IDENTITY_TOL}
    if bad:
        raise _NumericalDesignError(
            f"{row}: construction identities fail ({bad}); the rank decisions behind S* are "
            "probably ill-conditioned",
            argument="plant",
        )
    return {
        "F": F,
        "E": E,
        "G": G,
        "M": M,
        "H": H,
        "K": K,
        "P": P,
        "D0": D0,
        "D1": D1,
        "identities": ident,
        "placement": pinfo,
        "parity_rows": Hpar.shape[0],
    }


def _deliver(model: DesignModel, c: dict[str, Any], minimal: bool) -> dict[str, Any]:
    """The generator on the measured y: wrap the output filter, then reduce.

    With filtered channels Φ and raw channels R, the design generator reads
    ``[y_R; z]``; its states are joined with the filter ``z' = −a z + a y_Φ``
    (discrete ``z⁺ = a z + (1 − a) y_Φ``)::

        [w; z]' = [[F, −E_z], [0, −a I]] [w; z] − [E_R y_R ; −a y_Φ] + [G; 0] u
        r       = [M, −H_z] [w; z] − H_R y_R + K u
    """
    F, E, G, M, H, K = (c[x] for x in "FEGMHK")
    q = len(model.raw) + len(model.filtered)
    if model.augmented:
        a = model.filter_pole
        nr, nz = len(model.raw), len(model.filtered)
        g, Azz = ((1.0 - a), a * np.eye(nz)) if model.dt > 0 else (a, -a * np.eye(nz))
        k = F.shape[0]
        ER, Ez = E[:, :nr], E[:, nr:]
        HR, Hz = H[:, :nr], H[:, nr:]
        Fn = np.block([[F, -Ez], [np.zeros((nz, k)), Azz]])
        En = np.zeros((k + nz, q))
        En[:k, list(model.raw)] = ER
        En[k:, list(model.filtered)] = -g * np.eye(nz)
        Hn = np.zeros((M.shape[0], q))
        Hn[:, list(model.raw)] = HR
        F, E, H = Fn, En, Hn
        G = np.vstack([G, np.zeros((nz, G.shape[1]))])
        M = np.hstack([M, -Hz])
    full_order = F.shape[0]
    removed = 0
    if minimal:
        mr = minimal_realization(F, np.hstack([-E, G]), M, np.hstack([-H, K]))
        F, Bm, M, Dm = mr.A, mr.B, mr.C, mr.D
        E, G = -Bm[:, :q], Bm[:, q:]
        H, K = -Dm[:, :q], Dm[:, q:]
        removed = mr.removed
    return {
        "F": F,
        "E": E,
        "G": G,
        "M": M,
        "H": H,
        "K": K,
        "full_order": full_order,
        "removed": removed,
    }


def _check_delivered(
    F: np.ndarray, model: DesignModel, requested: bool, margin: float, row: str
) -> None:
    """The delivered generator's poles: stable, and (default spectrum) meeting the margin.

    Its poles are quotient poles and output-filter poles; the minimal realization of an
    ill-conditioned design can move them (its rank decisions perturb the dynamics at
    rounding level, which ill-conditioned eigenvalues amplify), so they are checked
    again on the matrices the user gets.
    """
    if F.size == 0:
        return
    lam = np.linalg.eigvals(F)
    dt = model.dt
    stable = np.abs(lam) < 1 if dt > 0 else lam.real < 0
    ok = stable.copy()
    if not requested:
        fp = None
        if model.augmented:
            fp = model.filter_pole if dt > 0 else -model.filter_pole
        for i, mu in enumerate(lam):
            on_filter = fp is not None and abs(mu - fp) <= 1e-6 * max(1.0, abs(fp))
            ok[i] = ok[i] and (_is_good(complex(mu), dt, margin, _SORT_SLACKS[-1]) or on_filter)
    if not np.all(ok):
        raise _NumericalDesignError(
            f"{row}: the delivered generator has poles {np.round(lam[~ok], 6).tolist()} that "
            f"violate {'stability' if requested else f'the stability margin {margin:g}'} "
            "(an ill-conditioned design whose minimal realization moved them)",
            argument="poles",
        )


def _design_transfer_zero(model: DesignModel, c: dict[str, Any], j: int) -> bool:
    """Is the design-model transfer from fault j identically zero?

    ``e' = F e − (P L_j + E Df_j) f``, ``r = M e − H Df_j f`` (Df_j: raw feedthrough).
    """
    Lj = model.signatures[j]
    Dfj = model.feedthrough[j] if model.feedthrough else np.zeros((model.C.shape[0], Lj.shape[1]))
    b = c["P"] @ Lj + c["E"] @ Dfj
    d = c["H"] @ Dfj
    # E may itself be rounding (e.g. E = P D0 with P A S ≈ 0): judge E Df against the
    # size an output injection has in this design, not against ||E|| alone
    nC = _norm2(model.C)
    e_scale = max(_norm2(c["E"]), _norm2(c["D1"]), _norm2(model.A) / nC if nC else 0.0)
    scale = max(_norm2(c["P"]) * _norm2(Lj) + e_scale * _norm2(Dfj), 1e-300)
    if _norm2(d) > 1e-9 * max(_norm2(c["H"]) * _norm2(Dfj), 1e-300):
        return False
    if _norm2(b) <= 1e-9 * scale:
        return True
    V = reachable_subspace(c["F"], b).basis
    return _norm2(c["M"] @ V) <= 1e-9 * max(_norm2(c["M"]), 1e-300)


# ------------------------------------------------------------ front ends
def _coerce_plant(plant: Any) -> Plant:
    return as_plant(plant)


def _coerce_faults(faults: Any) -> list[Fault]:
    return as_sequence_of(fault_list(faults), "faults", Fault)


def fault_list(faults: Any) -> list[Fault]:
    """``faults`` as a non-empty list (one fault alone becomes a list of one); the entries
    are checked where their signatures are formed (:func:`geomfdi.model.faults.fault_matrices`)."""
    if isinstance(faults, Fault):
        faults = [faults]
    try:
        out = list(faults)
    except TypeError as exc:
        raise GeomFDIError(
            "faults: must be a list of SensorFault / ActuatorFault / Fault", argument="faults"
        ) from exc
    if not out:
        raise GeomFDIError("faults: at least one fault is required", argument="faults")
    return out


def _first_markov(model: DesignModel, c: dict[str, Any], j: int) -> float:
    """Norm of the first non-zero Markov parameter of fault j's design-model transfer.

    ``h_0 = −H Df_j``, ``h_k = −M F^{k−1} (P L_j + E Df_j)`` (k ≥ 1).
    """
    Dfj = model.feedthrough[j] if model.feedthrough else 0.0 * model.signatures[j][:0]
    if isinstance(Dfj, np.ndarray) and Dfj.size:
        h0 = c["H"] @ Dfj
        if _norm2(h0) > 1e-9 * max(_norm2(c["H"]) * _norm2(Dfj), 1e-300):
            return _norm2(h0)
        b = c["P"] @ model.signatures[j] + c["E"] @ Dfj
    else:
        b = c["P"] @ model.signatures[j]
    ref = max(_norm2(c["M"]) * _norm2(b), 1e-300)
    v = b
    for _ in range(c["F"].shape[0]):
        h = c["M"] @ v
        if _norm2(h) > 1e-9 * ref:
            return _norm2(h)
        v = c["F"] @ v
        ref *= max(_norm2(c["F"]), 1.0)
    return 0.0


def _existence(
    model: DesignModel, target: Sequence[int], decouple: Sequence[int]
) -> tuple[Any, list[str]]:
    """S*_J and, per target, why it cannot be seen ('' when it may be)."""
    n = model.n
    cols = [model.signatures[j] for j in decouple] + [model.disturbance]
    L = np.hstack(cols) if cols else np.zeros((n, 0))
    S = min_unobservability_subspace(model.A, model.C, L)
    reasons = []
    for j in target:
        Lj = model.signatures[j]
        direct = bool(model.feedthrough) and _norm2(model.feedthrough[j]) > 0
        if direct:
            reasons.append("")
        elif Lj.size == 0 or _norm2(Lj) == 0:
            if model.preimages and model.preimages[j] is not None:
                step = "(A − I)" if model.dt > 0 else "A"
                reasons.append(
                    f"fault {j}: not isolable with method={model.method!r}: its signature "
                    f"L_{j} = Bf − {step} f_{j} = 0 ({step} f_{j} = 0, e.g. a sensor on an "
                    "integrator), so the transform makes it invisible; method='exact' does not "
                    "have this limitation"
                )
            else:
                reasons.append(f"fault {j}: L_{j} = 0 (it does not act on the design model)")
        elif S.dim == n:
            reasons.append(
                f"fault {j}: {design_dims(n, model.n_plant)}: decoupling the others leaves nothing"
            )
        elif S.contains(Subspace(Lj)):
            reasons.append(
                f"fault {j}: Im L_{j} ⊆ S* (dim {S.dim}): it is not isolable from faults "
                f"{list(decouple)}"
            )
        else:
            reasons.append("")
    return S, reasons


def design_dims(n_design: int, n_plant: int) -> str:
    """``dim S* = n ...`` with the plant's ``n`` and the design model's dimension apart.

    The exact sensor-fault transform augments the plant with one output-filter state per
    filtered sensor, so S* may fill a design model larger than the plant:
    ``"dim S* = n_d = 6 (the design model's dimension: plant n = 4 + 2 output-filter
    states)"``.
    """
    extra = n_design - n_plant
    if extra == 0:
        return f"dim S* = n = {n_design} (the plant's state dimension)"
    return (
        f"dim S* = n_d = {n_design} (the design model's dimension: plant n = {n_plant} "
        f"+ {extra} output-filter states)"
    )


def build_full(
    plant: Plant,
    faults: list[Fault],
    method: str,
    filter_pole: float | None,
    target: tuple[int, ...],
    decouple: tuple[int, ...],
    poles: Any,
    margin: float,
    minimal: bool,
    row: str,
    factor: PlantFactor | None = None,
) -> ResidualGenerator:
    """The full-quotient observer of one row (``method="full"``, ``"paper"``, ``"mvw"``)."""
    model = pseudo_actuator_model(plant, faults, method, decouple=decouple, filter_pole=filter_pole)
    S, reasons = _existence(model, target, decouple)
    why = [r for r in reasons if r]
    if why:
        raise NotIsolableError(
            f"{row}: no residual exists: " + "; ".join(why), reason="; ".join(why)
        )
    c = _construct(model, S, poles, margin, row, target)
    if c["H"].shape[0] == 0:
        why = [
            f"{design_dims(model.n, model.n_plant)} and no parity relation reads the targets: "
            "decoupling "
            f"faults {list(decouple)} leaves nothing"
        ]
        raise NotIsolableError(
            f"{row}: no residual exists: " + "; ".join(why), reason="; ".join(why)
        )
    unseen = [j for j in target if _design_transfer_zero(model, c, j)]
    if unseen:
        why = [
            f"fault {j}: not isolable from faults {list(decouple)}: Im L_{j} ⊆ S* and its "
            "direct output part is cancelled (transfer identically zero)"
            for j in unseen
        ]
        raise NotIsolableError(
            f"{row}: no residual exists: " + "; ".join(why), reason="; ".join(why)
        )
    d = _deliver(model, c, minimal)
    _check_delivered(d["F"], model, poles is not None, margin, row)
    info = {
        "markov_gain": _first_markov(model, c, target[0]),
        "S_dim": S.dim,
        "S_history": S.history,
        "W_dim": S.W.dim,
        "W_history": S.W.history,
        "min_gap": S.min_gap,
        "quotient_order": c["F"].shape[0],
        "full_order": d["full_order"],
        "removed_states": d["removed"],
        "design_n": model.n,
        "filter_pole": model.filter_pole if model.augmented else None,
        "filtered_channels": model.filtered,
        "P": c["P"],
        "identities": c["identities"],
        "poles": c["placement"]["computed_poles"],
        "placement": c["placement"],
        "transform_notes": model.notes,
        "faults": list(faults),
        "construction": {k: c[k] for k in ("F", "E", "G", "M", "H", "K", "P", "D0", "D1")},
    }
    g = ResidualGenerator(
        d["F"],
        d["E"],
        d["G"],
        d["M"],
        d["H"],
        d["K"],
        dt=plant.dt,
        target=target,
        decoupled=decouple,
        method=model.method,
        info=info,
    )
    gains, dc = fault_gains(g, plant, faults, factor=factor)
    for j in target:
        if not gains[j] > LEAK_TOL:  # second opinion: the orthonormal Krylov test
            gains[j] = fault_gains(g, plant, [faults[j]], method="krylov", factor=factor)[0][0]
    g.info["fault_gain"] = gains
    g.info["dc_gain"] = dc
    unseen = [j for j in target if not gains[j] > LEAK_TOL]
    if unseen:  # the delivered generator is blind to a target on the physical model
        if model.method == "paper":  # the pseudo-actuator model is not the plant
            why = [
                f"fault {j}: not seen by the paper-method residual: its transfer is "
                f"identically zero on the physical model (relative gain {gains[j]:.2g}), "
                "although the pseudo-actuator model sees it (Hou, Wen & Chen 2011, erratum 2 "
                "in docs/theory/errata.md)"
                for j in unseen
            ]
        else:
            why = [
                f"fault {j}: not isolable from faults {list(decouple)}: its transfer to the "
                f"residual is identically zero on the physical model (relative gain "
                f"{gains[j]:.2g})"
                for j in unseen
            ]
        raise NotIsolableError(
            f"{row}: no residual exists: " + "; ".join(why), reason="; ".join(why)
        )
    return g
