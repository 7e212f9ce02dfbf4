"""System norms of the approximate problems: the H∞ norm and the H₋ index.

A stable system ``(A, B, C, D)`` (continuous: ``s = iω``; discrete with sampling period
``dt``: ``z = e^{iω dt}``, ``0 ≤ ω ≤ π/dt``; frequencies are always in rad/s) has

    ‖G‖∞ = sup_ω σ_max(G(iω)),       G(s) = C (sI − A)⁻¹ B + D.

**H∞ norm** (:func:`hinf_norm`): the two-step algorithm of Bruinsma & Steinbuch (1990),
after Boyd, Balakrishnan & Kabamba (1989): γ is a singular value of ``G`` at a point of
the stability boundary exactly when the pencil of the system and its adjoint at level γ,

    [[A, 0, B, 0], [0, −Aᵀ, 0, −Cᵀ], [C, 0, D, −γI], [0, Bᵀ, −γI, Dᵀ]] − s diag(I, I, 0, 0)

(continuous) has an eigenvalue on the imaginary axis, or, in discrete time,

    [[A, 0, B, 0], [0, I, 0, 0], [C, 0, D, −γI], [0, Bᵀ, −γI, Dᵀ]]
        − z [[I, 0, 0, 0], [0, Aᵀ, 0, Cᵀ], [0, 0, 0, 0], [0, 0, 0, 0]]

an eigenvalue on the unit circle (the symplectic pencil; no bilinear transform).  The
inputs are eliminated (γ above ``σ_max(D)``, so the lower block is invertible), which leaves
the Hamiltonian matrix of order 2n, or a 2n pencil in discrete time.  Starting from the
largest ``σ_max`` at ω = 0, at the boundary point of ``D`` and at the poles' frequencies,
each step takes γ just above the current lower bound, finds the boundary frequencies
where ``σ_max(G) = γ`` and evaluates ``σ_max`` at the midpoints of consecutive ones: the
lower bound then increases quadratically to the peak.  It stops when no boundary
eigenvalue remains at ``(1 + 2 tol) γ`` or the bound stops increasing; the peak frequency
is then polished by a bounded scalar search (the peak is flat, so ``σ_max`` is exact to
rounding).  The state is first balanced (:func:`geomfdi.geometry.balancing.state_scaling`)
and the response evaluated through the complex Schur form of ``A``.

Stability: poles of the realisation that are not strictly stable are first removed where
they are uncontrollable or unobservable (:func:`geomfdi.minimal_realization`, so the
internal form of a generator on an unstable plant is measured by its transfer function).
A pole within ``BOUNDARY_TOL`` (relative) of the boundary gives the norm ``inf`` at its
frequency; a system with an unstable pole is refused (:class:`UnstableSystemError`).

**H₋ index** (:func:`hminus_index`): Varga (2017), §3.3, as FDITOOLS ``fdhinfminus``: for
column groups ``G_j`` (one per fault) either ``min_j ‖G_j‖∞`` (the default), or, over a list
of frequencies or a band ``[ω₁, ω₂]``, ``min_j min_ω σ_max(G_j(iω))`` (``measure="columns"``:
for single columns the column's 2-norm) or ``min_ω σ_min(G(iω))``, the smallest of the
``min(p, m)`` singular values (``measure="singular"``, Ding 2008's index: meaningful when
the residual has at least as many components as target fault columns).  A band is searched
on a grid (linear and logarithmic points, the poles' frequencies) whose local minima are
refined by a bounded scalar search.

See the user guide, *Theory: approximate synthesis* (``docs/theory/approximate-synthesis.md``).

References
----------
Boyd, Balakrishnan & Kabamba (1989), *A bisection method for computing the H∞ norm of a
transfer matrix and related problems*, Math. Control Signals Systems 2.
Bruinsma & Steinbuch (1990), *A fast algorithm to compute the H∞-norm of a transfer
function matrix*, Systems & Control Letters 14.
Varga (2017), *Solving Fault Diagnosis Problems*, Springer, §3.3 and §5.3.
Ding (2008), *Model-Based Fault Diagnosis Techniques*, Springer, §7.2.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg
import scipy.optimize

from geomfdi._threads import limit_blas_threads
from geomfdi._validation import as_choice, as_float, as_matrix
from geomfdi.errors import GeomFDIError, ShapeError

__all__ = [
    "BOUNDARY_TOL",
    "HinfNorm",
    "HminusIndex",
    "UnstableSystemError",
    "hinf_norm",
    "hminus_index",
    "peak_gain",
]

BOUNDARY_TOL = 1e-9
"""Relative distance of a pole to the stability boundary below which it lies on it:
``|Re λ| ≤ BOUNDARY_TOL · max(1, ‖A‖)`` (continuous) or ``||λ| − 1| ≤ BOUNDARY_TOL``."""

_CROSS_TOL = 1e-8  # eigenvalue counted on the boundary (relative), see _crossings
_MAX_STEPS = 60


class UnstableSystemError(GeomFDIError):
    """A norm of an unstable system was asked for (its H∞ norm is not defined)."""


@dataclass(frozen=True)
class HinfNorm:
    """The H∞ norm of a system and where it is attained.

    Attributes
    ----------
    value : float
        ``sup_ω σ_max(G(iω))``; ``inf`` with a pole on the stability boundary.
    frequency : float
        The peak frequency in rad/s (``inf``: the continuous-time limit ``D``).
    steps : int
        Iterations of the two-step algorithm.
    """

    value: float
    frequency: float
    steps: int = 0

    def __float__(self) -> float:
        return float(self.value)


@dataclass(frozen=True)
class HminusIndex:
    """The H₋ index of a system and where it is attained.

    Attributes
    ----------
    value : float
    frequency : float
        Frequency (rad/s) of the minimum (for the default measure: the peak frequency of
        the weakest column group).
    column : int
        Index of the weakest column group (``-1`` for ``measure="singular"``).
    measure : str
        ``"columns"`` or ``"singular"``.
    """

    value: float
    frequency: float
    column: int
    measure: str = "columns"

    def __float__(self) -> float:
        return float(self.value)


# ====================================================================== the system
class _System:
    """A balanced, Schur-factored realisation for fast frequency responses."""

    def __init__(self, A, B, C, D, dt: float) -> None:
        from geomfdi.geometry.balancing import state_scaling

        n = A.shape[0]
        d = state_scaling(A, B, C) if n else np.ones(0)
        self.A = A * d[None, :] / d[:, None] if n else A
        self.B, self.C, self.D = B / d[:, None] if n else B, C * d[None, :] if n else C, D
        self.dt = dt
        self.n, self.p, self.m = n, C.shape[0], B.shape[1]
        self.dual = False
        if n:
            T, U = scipy.linalg.schur(self.A.astype(complex), output="complex")
            self.T, self.UhB, self.CU = T, U.conj().T @ self.B, self.C @ U
            # fewer outputs than inputs: solve the transposed system, whose right-hand side
            # has p columns instead of m (Gᵀ = B̃ᵀ (sI − Tᵀ)⁻¹ C̃ᵀ; Tᵀ with rows and columns
            # reversed is upper triangular again)
            self.dual = self.p < self.m
            if self.dual:
                self.Tt = np.ascontiguousarray(T.T[::-1, ::-1])
                self.CUt = np.ascontiguousarray(self.CU.T[::-1])
                self.UhBt = np.ascontiguousarray(self.UhB.T[:, ::-1])
            self.poles = np.diag(T).copy()
        else:
            self.poles = np.zeros(0, complex)
        self.scale = max(float(np.linalg.norm(self.A, 1)) if n else 0.0, 1.0)

    def point(self, w: np.ndarray) -> np.ndarray:
        """``s = iω`` or ``z = e^{iω dt}``."""
        return np.exp(1j * w * self.dt) if self.dt > 0 else 1j * w

    def response(self, w: Any) -> np.ndarray:
        """``G`` at the frequencies ``w`` (rad/s): shape ``(P, p, m)``; ``ω = inf`` gives D."""
        from geomfdi.generators.gains import _tri_solve_many

        w = np.atleast_1d(np.asarray(w, dtype=float))
        out = np.empty((w.size, self.p, self.m), dtype=complex)
        out[:] = self.D
        fin = np.isfinite(w)
        if self.n and np.any(fin):
            pts = self.point(w[fin])
            T, R = (self.Tt, self.CUt) if self.dual else (self.T, self.UhB)
            if self.n <= 48 or pts.size > self.n // 4:
                X = _tri_solve_many(T, pts, R)
            else:  # a few points of a large system: one triangular solve each
                X = np.stack(
                    [
                        scipy.linalg.solve_triangular(s * np.eye(self.n) - T, R, check_finite=False)
                        for s in pts
                    ]
                )
            if self.dual:
                out[fin] += np.matmul(self.UhBt, X).transpose(0, 2, 1)
            else:
                out[fin] += np.matmul(self.CU, X)
        return out

    def sigma_max(self, w: Any) -> np.ndarray:
        G = self.response(w)
        if G.shape[1] == 0 or G.shape[2] == 0:
            return np.zeros(G.shape[0])
        return np.linalg.norm(G, ord=2, axis=(1, 2))

    def pole_frequencies(self) -> np.ndarray:
        """Frequencies (rad/s, ≥ 0) where the poles are closest to the boundary."""
        lam = self.poles
        if self.dt > 0:
            lam = lam[np.abs(lam) > 1e-12]
            w = np.abs(np.angle(lam)) / self.dt
        else:
            w = np.concatenate([np.abs(lam.imag), np.abs(lam)])
        return np.unique(w[np.isfinite(w)])

    def w_max(self) -> float:
        return np.pi / self.dt if self.dt > 0 else np.inf


def _checked(A: Any, B: Any, C: Any, D: Any, dt: Any) -> tuple[np.ndarray, ...]:
    A = as_matrix(A, "A", square=True, allow_empty=True)
    n = A.shape[0]
    B = as_matrix(B, "B", rows=n, allow_empty=True, vector_as="column")
    C = as_matrix(C, "C", cols=n, allow_empty=True, vector_as="row")
    p, m = C.shape[0], B.shape[1]
    if D is None or (np.ndim(D) == 0 and float(D) == 0):
        D = np.zeros((p, m))
    D = as_matrix(D, "D", rows=p, cols=m, allow_empty=True)
    dt = as_float(dt, "dt")
    if not (np.isfinite(dt) and dt >= 0):
        raise GeomFDIError(f"dt: must be 0 or a positive sampling period, got {dt}", argument="dt")
    return A, B, C, D, dt


def _boundary_distance(lam: np.ndarray, dt: float, scale: float) -> np.ndarray:
    """Signed distance of poles to the boundary (> 0: unstable), relative."""
    if dt > 0:
        return np.abs(lam) - 1.0
    return lam.real / scale


def _stable_system(A, B, C, D, dt: float, argument: str) -> tuple[_System | None, float, float]:
    """The system, or ``(None, inf, ω)`` for a pole on the boundary; unstable: refused."""
    from geomfdi.generators.realization import minimal_realization

    n = A.shape[0]
    if n == 0:
        return _System(A, B, C, D, dt), 0.0, 0.0
    scale = max(float(np.linalg.norm(A, 1)), 1.0)
    lam = np.linalg.eigvals(A)
    if np.any(_boundary_distance(lam, dt, scale) >= -BOUNDARY_TOL):
        mr = minimal_realization(A, B, C, D)  # hidden modes have no effect on the norm
        A, B, C = mr.A, mr.B, mr.C
        lam = np.linalg.eigvals(A) if A.shape[0] else np.zeros(0, complex)
        dist = _boundary_distance(lam, dt, scale)
        if np.any(dist > BOUNDARY_TOL):
            bad = lam[dist > BOUNDARY_TOL]
            raise UnstableSystemError(
                f"{argument}: the system is unstable (poles {np.round(bad, 6).tolist()}); "
                "its H-infinity norm is not defined",
                argument=argument,
            )
        on = np.abs(dist) <= BOUNDARY_TOL
        if np.any(on):
            mu = lam[on][0]
            w = abs(np.angle(mu)) / dt if dt > 0 else abs(mu.imag)
            return None, np.inf, float(w)
    return _System(A, B, C, D, dt), 0.0, 0.0


# ====================================================================== H-infinity
def _crossings(sys: _System, gamma: float) -> np.ndarray:
    """Signed frequencies (rad/s) where γ is a singular value of G on the boundary."""
    A, B, C, D = sys.A, sys.B, sys.C, sys.D
    n, p, m = sys.n, sys.p, sys.m
    K = np.block([[D, -gamma * np.eye(p)], [-gamma * np.eye(m), D.T]])
    rhs = np.block([[C, np.zeros((p, n))], [np.zeros((m, n)), B.T]])
    try:
        L = -np.linalg.solve(K, rhs)  # [u; v] = L [x; p]
    except np.linalg.LinAlgError:
        return np.zeros(0)
    Lu, Lv = L[:m], L[m:]
    top = np.hstack([A + B @ Lu[:, :n], B @ Lu[:, n:]])
    if sys.dt > 0:
        M = np.vstack([top, np.hstack([np.zeros((n, n)), np.eye(n)])])
        N = np.block([[np.eye(n), np.zeros((n, n))], [C.T @ Lv[:, :n], A.T + C.T @ Lv[:, n:]]])
        alpha, beta = scipy.linalg.eigvals(M, N, homogeneous_eigvals=True)
        size = np.maximum(np.abs(alpha), np.abs(beta))
        ok = (size > 0) & (np.abs(np.abs(alpha) - np.abs(beta)) <= _CROSS_TOL * size)
        w = np.angle(alpha[ok] * np.conj(beta[ok])) / sys.dt
    else:
        H = np.vstack([top, np.hstack([-C.T @ Lv[:, :n], -A.T - C.T @ Lv[:, n:]])])
        lam = np.linalg.eigvals(H)
        ok = np.abs(lam.real) <= _CROSS_TOL * (np.abs(lam) + sys.scale)
        w = lam[ok].imag
    return np.sort(w)


def _polish(sys: _System, w0: float, value: float, lo: float, hi: float) -> tuple[float, float]:
    """Local maximum of ``σ_max`` near ``w0`` in ``[lo, hi]`` (bounded Brent search)."""
    if not (np.isfinite(w0) and hi > lo):
        return value, w0
    res = scipy.optimize.minimize_scalar(
        lambda x: -float(sys.sigma_max(x)[0]),
        bounds=(lo, hi),
        method="bounded",
        options={"xatol": 1e-12 * max(abs(w0), 1e-300) + 1e-300, "maxiter": 200},
    )
    if np.isfinite(res.fun) and -res.fun > value:
        return float(-res.fun), float(res.x)
    return value, w0


def _hinf(sys: _System, tol: float) -> HinfNorm:
    if sys.p == 0 or sys.m == 0:
        return HinfNorm(0.0, 0.0)
    wmax = sys.w_max()
    cand = np.unique(np.concatenate([[0.0, wmax], sys.pole_frequencies()]))
    cand = cand[cand <= wmax]
    sv = sys.sigma_max(cand)
    k = int(np.argmax(sv))
    glb, wbest = float(sv[k]), float(cand[k])
    if glb == 0.0:  # zero at every candidate: try a grid before calling the system zero
        grid = np.geomspace(1e-3, 1e3, 61) * max(sys.scale, 1.0)
        grid = grid[grid < wmax] if np.isfinite(wmax) else grid
        sv = sys.sigma_max(grid)
        if not np.any(sv > 0):
            return HinfNorm(0.0, 0.0)
        k = int(np.argmax(sv))
        glb, wbest = float(sv[k]), float(grid[k])
    steps, bracket = 0, None
    while steps < _MAX_STEPS:
        steps += 1
        ws = _crossings(sys, (1.0 + 2.0 * tol) * glb)
        if ws.size == 0:
            break
        mids = np.abs(0.5 * (ws[:-1] + ws[1:]))
        extra = [0.0, wmax] if np.isfinite(wmax) else [0.0]
        mids = np.concatenate([mids, extra])
        sv = sys.sigma_max(mids)
        k = int(np.argmax(sv))
        aw = np.sort(np.abs(ws))
        bracket = aw
        if sv[k] <= glb * (1.0 + tol):
            break
        glb, wbest = float(sv[k]), float(mids[k])
    # polish between the neighbouring crossing frequencies (or a small relative interval)
    if np.isfinite(wbest):
        lo, hi = wbest * (1 - 1e-3), wbest * (1 + 1e-3) + 1e-9 * sys.scale
        if bracket is not None and bracket.size:
            below, above = bracket[bracket < wbest], bracket[bracket > wbest]
            lo = float(below[-1]) if below.size else lo
            hi = float(above[0]) if above.size else hi
        glb, wbest = _polish(sys, wbest, glb, max(lo, 0.0), min(hi, wmax))
    return HinfNorm(glb, wbest, steps)


@limit_blas_threads
def hinf_norm(
    A: Any, B: Any, C: Any, D: Any = None, dt: float = 0.0, *, tol: float = 1e-10
) -> HinfNorm:
    """The H∞ norm ``sup_ω σ_max(G(iω))`` of a stable system (module docstring).

    Parameters
    ----------
    A, B, C, D : array_like
        The realisation; ``D`` zero by default.
    dt : float
        0 for continuous time, else the sampling period (``z = e^{iω dt}``).
    tol : float
        Relative accuracy of the two-step iteration (the result is then polished).

    Returns
    -------
    HinfNorm
        ``value`` and the peak ``frequency`` (rad/s).

    Raises
    ------
    UnstableSystemError
        Naming ``A`` when a pole that reaches the transfer is unstable.

    Notes
    -----
    Bruinsma & Steinbuch (1990) on the Hamiltonian matrix (continuous time) or the
    symplectic pencil (discrete time); poles on the boundary give ``inf``.

    Examples
    --------
    >>> import geomfdi as gf
    >>> r = gf.hinf_norm([[-1.0]], [[1.0]], [[1.0]])
    >>> round(r.value, 12), r.frequency
    (1.0, 0.0)
    """
    A, B, C, D, dt = _checked(A, B, C, D, dt)
    tol = as_float(tol, "tol")
    if not 0 < tol < 1e-2:
        raise GeomFDIError(f"tol: must be in (0, 0.01), got {tol}", argument="tol")
    sys, inf, w = _stable_system(A, B, C, D, dt, "A")
    if sys is None:
        return HinfNorm(inf, w)
    return _hinf(sys, tol)


# ====================================================================== H-minus
def _groups(columns: Any, m: int) -> list[np.ndarray]:
    if columns is None:
        return [np.array([j]) for j in range(m)]
    if isinstance(columns, str | bytes) or not isinstance(columns, Sequence):
        raise GeomFDIError("columns: expected a list of column-index lists", argument="columns")
    out = []
    for k, grp in enumerate(columns):
        idx = np.atleast_1d(np.asarray(grp, dtype=int))
        if idx.size == 0 or np.any((idx < 0) | (idx >= m)):
            raise ShapeError(
                f"columns: group {k} must hold column indices in 0..{m - 1}, got {grp!r}",
                argument="columns",
            )
        out.append(idx)
    if not out:
        raise GeomFDIError("columns: no column group given", argument="columns")
    return out


def _frequencies(frequencies: Any, band: Any, wmax: float) -> tuple[np.ndarray | None, Any]:
    if frequencies is not None and band is not None:
        raise GeomFDIError("band: give either frequencies or band, not both", argument="band")
    if frequencies is not None:
        w = np.atleast_1d(np.asarray(frequencies, dtype=float))
        if w.ndim != 1 or w.size == 0 or np.any(~np.isfinite(w)) or np.any(w < 0):
            raise GeomFDIError(
                "frequencies: expected finite frequencies >= 0 (rad/s)", argument="frequencies"
            )
        if np.any(w > wmax * (1 + 1e-12)):
            raise GeomFDIError(
                f"frequencies: above the Nyquist frequency {wmax:g} rad/s",
                argument="frequencies",
            )
        return w, None
    if band is not None:
        b = np.asarray(band, dtype=float)
        if b.shape != (2,) or not np.all(np.isfinite(b)) or b[0] < 0 or b[1] < b[0]:
            raise GeomFDIError(
                f"band: expected (w1, w2) with 0 <= w1 <= w2 < inf (rad/s), got {band!r}",
                argument="band",
            )
        if b[1] > wmax * (1 + 1e-12):
            raise GeomFDIError(f"band: above the Nyquist frequency {wmax:g} rad/s", argument="band")
        return None, (float(b[0]), float(b[1]))
    return None, None


def _measure_values(sys: _System, w: np.ndarray, groups, measure: str) -> np.ndarray:
    """``(P, G)``: per frequency, each group's ``σ_max`` (or one column of ``σ_min``)."""
    Gw = sys.response(w)
    if measure == "singular":
        k = min(sys.p, sys.m)
        sv = np.linalg.svd(Gw, compute_uv=False)
        return sv[:, k - 1 : k] if k else np.zeros((w.size, 1))
    return np.stack([np.linalg.norm(Gw[:, :, g], ord=2, axis=(1, 2)) for g in groups], axis=1)


def _band_minimum(sys: _System, band, groups, measure: str) -> tuple[float, float, int]:
    lo, hi = band
    if hi == lo:
        vals = _measure_values(sys, np.array([lo]), groups, measure)[0]
        j = int(np.argmin(vals))
        return float(vals[j]), lo, j
    pts = [np.linspace(lo, hi, 201)]
    if hi > 0:
        pts.append(np.geomspace(max(lo, hi * 1e-6), hi, 201))
    pf = sys.pole_frequencies()
    pts.append(pf[(pf >= lo) & (pf <= hi)])
    grid = np.unique(np.concatenate(pts))
    vals = _measure_values(sys, grid, groups, measure)
    best: tuple[float, float, int] = (np.inf, lo, 0)
    for j in range(vals.shape[1]):
        v = vals[:, j]
        interior = np.flatnonzero((v[1:-1] <= v[:-2]) & (v[1:-1] <= v[2:])) + 1
        idx = np.unique(np.concatenate([[0, v.size - 1], interior]))
        for i in idx[np.argsort(v[idx])][:4]:  # the lowest local minima
            a, b = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
            val, wv = float(v[i]), float(grid[i])
            if b > a:
                res = scipy.optimize.minimize_scalar(
                    lambda x, j=j: float(
                        _measure_values(sys, np.array([x]), groups, measure)[0][j]
                    ),
                    bounds=(a, b),
                    method="bounded",
                    options={"xatol": 1e-12 * max(b, 1e-300), "maxiter": 200},
                )
                if res.fun < val:
                    val, wv = float(res.fun), float(res.x)
            if val < best[0]:
                best = (val, wv, j)
    return best


@limit_blas_threads
def hminus_index(
    A: Any,
    B: Any,
    C: Any,
    D: Any = None,
    dt: float = 0.0,
    *,
    columns: Sequence[Sequence[int]] | None = None,
    frequencies: Any = None,
    band: Any = None,
    measure: str = "columns",
    tol: float = 1e-10,
) -> HminusIndex:
    """The H₋ index of a stable system (module docstring, Varga 2017 §3.3).

    Parameters
    ----------
    A, B, C, D, dt
        As for :func:`hinf_norm`.
    columns : list of lists of int, optional
        Column groups ``G_j`` (e.g. the columns of one fault); default: each column alone.
    frequencies : array_like, optional
        Frequencies (rad/s) at which the minimum is taken.
    band : (w1, w2), optional
        A frequency band (rad/s) over which the minimum is taken.
    measure : {"columns", "singular"}
        Without ``frequencies``/``band``: only ``"columns"``, ``min_j ‖G_j‖∞`` (FDITOOLS
        ``fdhinfminus``).  With them: ``min_j min_ω σ_max(G_j)`` (``"columns"``) or
        ``min_ω σ_min(G)`` (``"singular"``, Ding 2008).
    tol : float
        Relative accuracy of the H∞ norms.

    Returns
    -------
    HminusIndex

    Examples
    --------
    >>> import geomfdi as gf
    >>> r = gf.hminus_index([[-1.0]], [[1.0, 2.0]], [[1.0]])
    >>> round(r.value, 12), r.column
    (1.0, 0)
    """
    A, B, C, D, dt = _checked(A, B, C, D, dt)
    measure = as_choice(measure, "measure", ("columns", "singular"))
    groups = _groups(columns, B.shape[1])
    sys, inf, w_inf = _stable_system(A, B, C, D, dt, "A")
    wmax = np.pi / dt if dt > 0 else np.inf
    freqs, bnd = _frequencies(frequencies, band, wmax)
    if freqs is None and bnd is None:
        if measure != "columns":
            raise GeomFDIError(
                "measure: 'singular' needs frequencies or a band", argument="measure"
            )
        best = (np.inf, 0.0, 0)
        for j, g in enumerate(groups):
            if sys is None:
                r = hinf_norm(A, B[:, g], C, D[:, g], dt, tol=tol)
            else:
                r = _hinf(_System(sys.A, sys.B[:, g], sys.C, sys.D[:, g], dt), tol)
            if r.value < best[0]:
                best = (r.value, r.frequency, j)
        return HminusIndex(best[0], best[1], best[2], measure)
    if sys is None:
        return HminusIndex(np.inf, w_inf, 0 if measure == "columns" else -1, measure)
    if freqs is not None:
        vals = _measure_values(sys, freqs, groups, measure)
        i, j = np.unravel_index(int(np.argmin(vals)), vals.shape)
        val, wv, col = float(vals[i, j]), float(freqs[i]), int(j)
    else:
        val, wv, col = _band_minimum(sys, bnd, groups, measure)
    return HminusIndex(val, wv, col if measure == "columns" else -1, measure)


# ====================================================================== peak-to-peak
@limit_blas_threads
def peak_gain(
    A: Any, B: Any, C: Any, D: Any = None, dt: float = 0.0, *, samples: int = 20000
) -> np.ndarray:
    """Peak-to-peak (L1) gains of the outputs: ``sup |y_i| / sup_t max_j |u_j|`` per output.

    ``g_i = Σ_j ( ∫₀^∞ |h_ij(t)| dt + |D_ij| )`` with ``h = C e^{At} B`` (continuous; the
    integral by the trapezoidal rule on ``samples`` points over the horizon where
    ``‖e^{At}‖`` has decayed to 1e-16 of its start, an ``O(h²)`` approximation), or
    ``Σ_j Σ_k |h_ij[k]| + |D_ij|`` with ``h[k] = C A^{k-1} B`` (discrete, exact up to the
    decay).  A bounded input ``|u_j(t)| ≤ δ`` gives ``|y_i(t)| ≤ g_i δ`` (the induced
    L∞ norm; Dahleh & Diaz-Bobillo 1995, §4).

    Returns
    -------
    ndarray (p,)
        ``inf`` for a pole on the stability boundary.

    Raises
    ------
    UnstableSystemError
        Naming ``A`` for an unstable system.
    """
    A, B, C, D, dt = _checked(A, B, C, D, dt)
    sys, inf, _ = _stable_system(A, B, C, D, dt, "A")
    p = C.shape[0]
    if sys is None:
        return np.full(p, np.inf)
    out = np.abs(D).sum(axis=1)
    n = sys.n
    if n == 0 or sys.m == 0:
        return out
    rate = np.max(np.abs(sys.poles)) if dt > 0 else -np.max(sys.poles.real)
    if dt > 0:
        N = int(min(max(np.ceil(np.log(1e-16) / np.log(max(rate, 1e-300))) + 1, 2), 10**6))
        Phi, step = sys.A, 1.0
    else:
        T = 36.8 / rate  # e^{-36.8} = 1e-16
        step = T / samples
        Phi, N = scipy.linalg.expm(sys.A * step), samples + 1
    # h_k = C Phi^k B for k = 0 .. N-1 in blocks of L: [B, Phi B, ...] by doubling
    L = 1 << int(np.ceil(np.log2(max(min(N, 512), 1))))
    Y, P = sys.B, Phi
    while Y.shape[1] < L * sys.m:
        Y = np.hstack([Y, P @ Y])
        P = P @ P
    Z = sys.C
    acc = np.zeros((p, sys.m))
    weights_done = 0
    while weights_done < N:
        H = (Z @ Y).reshape(p, -1, sys.m)[:, : N - weights_done]  # (p, L, m)
        w = np.ones(H.shape[1])
        if dt == 0:
            w *= step
            if weights_done == 0:
                w[0] *= 0.5
            if weights_done + H.shape[1] == N:
                w[-1] *= 0.5
        acc += np.einsum("plm,l->pm", np.abs(H), w)
        weights_done += H.shape[1]
        Z = Z @ P
    return out + acc.sum(axis=1)
