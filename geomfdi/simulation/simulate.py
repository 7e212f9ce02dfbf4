"""Simulation of a plant with sensor faults and a bank of residual generators.

:func:`simulate` runs one scenario, :func:`simulate_batch` many Monte-Carlo runs (noise
seeds, fault sizes) in one vectorised call.  Both use the exact, loop-free LTI recursion
of :mod:`geomfdi.simulation.lti`.

Model (math.md §1, §4)::

    plant       x' = A x + B u + Bd d + Bw w          (x[k+1] = ... when dt > 0)
                y0 = C x + D u + Dd d + v              healthy reading, v: measurement noise
    faults      y_i = eta_i(t) y0_i + lambda_i(t)       (geomfdi.simulation.signals)
    generators  w_g' = F w_g - E y + G u,   r_g = M w_g - H y + K u     (measured y)
    controller  None:   u = u_ext(t)
                K:      u = u_ext(t) - K x             (state feedback, true state)
                system: u = u_ext(t) + K(s) y           (output feedback on the faulty y)

How it is computed
------------------
*Open loop and state feedback.*  The plant does not see the sensor faults, so its state
is simulated once over the whole horizon (and all runs).  The generators are driven
exactly: over one sampling interval the composite system ``[plant; generator]`` is
discretised with the hold of the exogenous inputs, so the generator's update uses the
plant *state* ``x[k]`` rather than an interpolation of the sampled ``y`` (a healthy
residual is therefore zero to rounding, not to ``O(dt^2)``).  A sensor fault enters as
``y_i = delta_i y0_i + rho_i`` with ``delta_i`` the gain over the interval (exact for
abrupt gains; the interval mean of ``eta`` for a time-varying gain, an ``O(dt^2)``
approximation) and ``rho_i`` (bias, held value, scaled noise) interpolated with the hold.
Each gain-faulty sensor adds one extra exact "channel" (one more matrix exponential).
When every generator has a ``Pi`` with ``F Pi - Pi A_cl = -Sigma`` (below; relative
residual <= 1e-12), the bank is simulated in the coordinates ``w~ = w - Pi x``, which obey
``w~' = F w~ + (Gamma - Pi B_cl) e - E rho``: the plant state drops out of the drive (an
exact change of state, fewer drive channels) and comes back in the output through
``M Pi x``.  Otherwise the composite ``[plant; bank]`` is discretised and the plant state
samples drive the bank.  ``res.info["plant_state_decoupled"]`` says which was used.
The whole bank is discretised with one matrix exponential and advanced together (block-
diagonal modal or Schur form, one ``lfilter`` call per generator state, on the lifted
system of blocks of ``M`` samples for large banks, time processed in chunks), see
:func:`geomfdi.lti_sim.block_recursion`.  A discrete plant drives its generators with the
measured samples directly, which is exact.

*Output feedback.*  The loop sees the faulty readings, so a gain fault changes the loop
dynamics.  For abrupt faults the closed loop is piecewise LTI: the horizon is cut at
every fault switching instant and each segment (plant + controller + all generators) is
simulated exactly with the fast recursion, the state carried over.  A time-varying gain
makes the loop time-varying: its segments fall back to a **stepping scheme** (one matrix
exponential and one step per sample, ``eta`` frozen at its interval mean) that is
correct to ``O(dt^2)`` but much slower (a Python loop over the samples; a progress bar
is shown on a terminal).

*Switching instants* are sample times: a fault starting at ``t_s`` is active from the
first sample ``t_k >= t_s``; with the first-order hold its jump happens exactly at that
sample (the interval before it uses the left limit), not spread over the interval.

*Initial states.*  With ``consistent_init=True`` (default) each generator starts at
``w0 = Pi X0`` where ``X`` is the healthy loop state (plant, with controller states under
output feedback) and ``Pi`` solves ``F Pi - Pi A_cl = -Sigma`` (Sigma: the coupling of the
healthy loop into the generator), so that healthy data give no start-up transient.  The
Sylvester equation is solved by :func:`scipy.linalg.solve_sylvester` when the spectra of
``F`` and ``A_cl`` are disjoint, else in least squares together with the output condition
``M Pi + N = 0``; when that condition fails (relative residual > 1e-8) an
:class:`InitialStateWarning` gives the number: the generator is then not decoupled from
the healthy loop.

*Discrete plants* (``dt > 0``): the same, with the sampled model itself; a time-varying
gain is then exact (stepping uses ``eta(t_k)``).

*Noise.*  :class:`Noise`: measurement noise ``v`` (i.i.d. per sample) and process noise
``w`` (i.i.d. samples entering through ``Bw``, interpolated with the same hold as ``u``
for continuous plants: for a white-noise intensity ``Q`` use covariance ``Q / dt``).

*Multiple outputs per generator.*  ``residuals`` has one row per bank row; a generator
with several residual components contributes their Euclidean norm (the components are in
``residual_vectors``).  Rows of missing generators (``None`` in ``bank.generators``)
are zero and never alarm.

References
----------
Hou, Wen, Chen (2011), seed 001: sensor fault model eq. (3)-(5), residual generator
eq. (23), simulation of §4 (reproduced in the tests, reference.md).
"""

from __future__ import annotations

import sys
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg

from geomfdi._validation import (
    as_bool,
    as_choice,
    as_float,
    as_int,
    as_matrix,
    as_real_array,
    as_seed,
    as_sequence_of,
)
from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.evaluation.decision import (
    FaultEvent,
    Threshold,
    as_threshold,
    detection_events,
    isolate,
)
from geomfdi.limits import check_allocation, check_runs
from geomfdi.model.faults import SensorFault
from geomfdi.model.plant import Plant, as_plant
from geomfdi.simulation.lti import (
    HOLDS,
    Discretization,
    Drive,
    block_recursion,
    discretize,
    linear_recursion,
    uniform_step,
)
from geomfdi.simulation.signals import SensorFaultSignal, fault_profile, validate_faults
from geomfdi.synthesis.generator import ResidualBank, ResidualGenerator

__all__ = [
    "Noise",
    "InitialStateWarning",
    "SimulationResult",
    "BatchResult",
    "simulate",
    "simulate_batch",
    "consistent_initial_state",
]

_MISMATCH_WARN = 1e-8


class InitialStateWarning(UserWarning):
    """The generator cannot start consistently: it is not decoupled from the healthy loop."""


# =================================================================== noise
def _factor(value: Any, dim: int, name: str) -> np.ndarray | None:
    """A square-root factor ``L`` (dim, dim) of a noise description (std or covariance)."""
    if value is None:
        return None
    arr = as_real_array(value, name)
    if arr.ndim == 0:
        if arr < 0:
            raise GeomFDIError(
                f"{name}: a standard deviation must be >= 0, got {arr}", argument=name
            )
        L = float(arr) * np.eye(dim)
    elif arr.ndim == 1:
        if arr.shape[0] != dim:
            raise ShapeError(
                f"{name}: expected {dim} standard deviations, got length {arr.shape[0]}",
                argument=name,
            )
        if np.any(arr < 0):
            raise GeomFDIError(f"{name}: standard deviations must be >= 0", argument=name)
        L = np.diag(arr)
    elif arr.ndim == 2:
        if arr.shape != (dim, dim):
            raise ShapeError(
                f"{name}: a covariance must be ({dim}, {dim}), got shape {arr.shape}",
                argument=name,
            )
        scale = max(float(np.max(np.abs(arr))), 1e-300)
        if np.max(np.abs(arr - arr.T)) > 1e-10 * scale:
            raise GeomFDIError(f"{name}: a covariance must be symmetric", argument=name)
        lam, V = np.linalg.eigh((arr + arr.T) / 2)
        if lam.min() < -1e-10 * scale:
            raise GeomFDIError(
                f"{name}: a covariance must be positive semidefinite (eigenvalue {lam.min():.3g})",
                argument=name,
            )
        L = V * np.sqrt(np.clip(lam, 0, None))
    else:
        raise ShapeError(f"{name}: expected a number, a vector or a matrix", argument=name)
    return None if not np.any(L) else L


@dataclass(frozen=True)
class Noise:
    """Measurement and process noise with a seed.

    Parameters
    ----------
    measurement : float, (q,) or (q, q), optional
        Measurement noise ``v`` added to the healthy readings: one standard deviation for
        all sensors, one per sensor, or a covariance matrix.  Sensor faults act on the
        noisy reading (a gain scales the noise, a stuck sensor freezes it).
    process : float, (k,) or (k, k), optional
        Process noise ``w`` entering ``x' = ... + Bw w`` (standard deviation(s) or
        covariance of the samples).  For a continuous plant the samples are interpolated
        with the simulation hold; the covariance of a sampled white noise of intensity
        ``Q`` is ``Q / dt``.
    process_input : (n, k), optional
        ``Bw``; the identity (noise on every state) by default.
    seed : int, numpy SeedSequence or None
        Seed of :func:`numpy.random.default_rng`.  In :func:`simulate_batch` run ``i``
        uses the ``i``-th child of ``SeedSequence(seed)`` unless seeds are given.

    Examples
    --------
    >>> import geomfdi as gf
    >>> gf.Noise(measurement=0.01, seed=1).measurement
    0.01
    """

    measurement: Any = None
    process: Any = None
    process_input: Any = None
    seed: Any = None

    def __post_init__(self) -> None:
        as_seed(self.seed, "noise.seed")

    def factors(
        self, plant: Plant
    ) -> tuple[np.ndarray | None, np.ndarray | None, np.ndarray | None]:
        """``(Lv, Bw, Lw)``: ``v = Lv z``, process noise ``Bw Lw z`` (z standard normal)."""
        Lv = _factor(self.measurement, plant.q, "noise.measurement")
        if self.process_input is None:
            Bw = np.eye(plant.n)
        else:
            Bw = as_matrix(
                self.process_input, "noise.process_input", rows=plant.n, vector_as="column"
            )
        Lw = _factor(self.process, Bw.shape[1], "noise.process")
        return Lv, (Bw if Lw is not None else None), Lw


# ============================================================ setup objects
@dataclass
class _BankView:
    generators: list[ResidualGenerator | None]
    structure: np.ndarray
    requested: np.ndarray | None
    design_faults: list[Any]
    fault_labels: list[str]
    bank: Any

    @property
    def present(self) -> list[int]:
        return [k for k, g in enumerate(self.generators) if g is not None]


def _bank_view(bank: Any, plant: Plant) -> _BankView:
    if isinstance(bank, ResidualGenerator):
        idx = set(bank.target) | set(bank.decoupled)
        nf = max(idx) + 1 if idx else 1
        S = np.zeros((1, nf), dtype=bool)
        for j in bank.target:
            S[0, j] = True
        view = _BankView([bank], S, S.copy(), [], [f"fault {j}" for j in range(nf)], bank)
    elif isinstance(bank, ResidualBank):
        S = np.asarray(bank.structure, dtype=bool)
        labels = [getattr(f, "name", None) or f"fault {j}" for j, f in enumerate(bank.faults)]
        labels += [f"fault {j}" for j in range(len(labels), S.shape[1])]
        req = None if bank.requested is None else np.asarray(bank.requested, dtype=bool)
        view = _BankView(list(bank.generators), S, req, list(bank.faults), labels, bank)
    else:
        raise GeomFDIError(
            f"bank: expected a ResidualBank or a ResidualGenerator, got {type(bank).__name__}",
            argument="bank",
        )
    if not view.present:
        raise GeomFDIError("bank: no residual generator exists in this bank", argument="bank")
    for k in view.present:
        g = view.generators[k]
        if g.q != plant.q or g.m != plant.m:
            raise ShapeError(
                f"bank: generator {k} reads {g.q} outputs and {g.m} inputs, the plant has "
                f"{plant.q} and {plant.m}",
                argument="bank",
            )
        if abs(g.dt - plant.dt) > 1e-12 * max(1.0, plant.dt):
            raise GeomFDIError(
                f"bank: generator {k} has dt={g.dt:g}, the plant dt={plant.dt:g}",
                argument="bank",
            )
    return view


@dataclass
class _Controller:
    mode: str  # "open", "state", "output"
    K: np.ndarray | None = None
    Ac: np.ndarray | None = None
    Bc: np.ndarray | None = None
    Cc: np.ndarray | None = None
    Dc: np.ndarray | None = None

    @property
    def nc(self) -> int:
        return 0 if self.Ac is None else self.Ac.shape[0]


def _controller(controller: Any, plant: Plant) -> _Controller:
    if controller is None:
        return _Controller("open")
    # an LTI object implies python-control is loaded: no import (about 0.3 s) for a gain
    control = sys.modules.get("control")
    if control is not None and isinstance(controller, control.LTI):
        try:
            ss = control.ss(controller)
        except Exception as exc:  # non-proper transfer function, ...
            raise GeomFDIError(
                f"controller: cannot be realised as a state-space system ({exc})",
                argument="controller",
            ) from exc
        if ss.ninputs != plant.q or ss.noutputs != plant.m:
            raise ShapeError(
                f"controller: must read the {plant.q} measured outputs and produce the "
                f"{plant.m} inputs, got {ss.ninputs} inputs and {ss.noutputs} outputs",
                argument="controller",
            )
        cdt = ss.dt
        if plant.is_discrete:
            ok = cdt is None or cdt is True or (cdt and abs(cdt - plant.dt) <= 1e-12 * plant.dt)
        else:
            ok = cdt is None or cdt == 0
        if not ok:
            raise GeomFDIError(
                f"controller: dt={cdt} does not match the plant (dt={plant.dt:g})",
                argument="controller",
            )
        nc = ss.nstates
        return _Controller(
            "output",
            Ac=np.asarray(ss.A, dtype=float).reshape(nc, nc),
            Bc=np.asarray(ss.B, dtype=float).reshape(nc, plant.q),
            Cc=np.asarray(ss.C, dtype=float).reshape(plant.m, nc),
            Dc=np.asarray(ss.D, dtype=float).reshape(plant.m, plant.q),
        )
    K = as_matrix(controller, "controller", rows=plant.m, cols=plant.n)
    return _Controller("state", K=K)


def _signal(value: Any, t: np.ndarray, rows: int, name: str) -> np.ndarray:
    """An exogenous signal as a (rows, N) array: None, array or vectorised callable."""
    N = t.shape[0]
    if value is None:
        return np.zeros((rows, N))
    if rows == 0:
        raise GeomFDIError(f"{name}: the plant has no such input", argument=name)
    if callable(value):
        try:
            value = value(t)
        except Exception as exc:
            raise GeomFDIError(
                f"{name}: calling it on the time array failed ({type(exc).__name__}: {exc}); "
                "the function must accept a numpy array of times",
                argument=name,
            ) from exc
    arr = as_real_array(value, name)
    if arr.ndim == 0:
        return np.full((rows, N), float(arr))
    if arr.ndim == 1 and rows == 1 and arr.shape[0] == N:
        return arr[None].copy()
    if arr.ndim == 1 and arr.shape[0] == rows:
        return np.repeat(arr[:, None], N, axis=1)
    if arr.shape != (rows, N):
        raise ShapeError(f"{name}: expected shape ({rows}, {N}), got {arr.shape}", argument=name)
    return arr


def _mm(Mat: np.ndarray, arr: np.ndarray) -> np.ndarray:
    """``Mat @ arr[r]`` for each run of ``arr`` (R, k, L) -> (R, p, L)."""
    if arr.shape[0] == 1:
        return (Mat @ arr[0])[None]
    return np.matmul(Mat, arr)


# ========================================================== consistent state
def consistent_initial_state(
    F: np.ndarray, A_cl: np.ndarray, Sigma: np.ndarray, M: np.ndarray, N_out: np.ndarray
) -> tuple[np.ndarray, float]:
    """``Pi`` with ``F Pi - Pi A_cl = -Sigma``, and the relative output mismatch.

    The healthy interconnection is block lower triangular::

        [X; w]' = [[A_cl, 0], [Sigma, F]] [X; w],      r = M w + N_out X

    and ``w = Pi X`` is invariant under it.  Then ``r = (M Pi + N_out) X``, which is
    zero for a generator decoupled from the healthy loop.

    Returns
    -------
    Pi : ndarray, (nw, nX)
    mismatch : float
        ``||M Pi + N_out|| / (||M|| ||Pi|| + ||N_out||)`` in Frobenius norms (0 when both
        vanish).

    Notes
    -----
    Unique when ``F`` and ``A_cl`` have no common eigenvalue (Bartels-Stewart,
    :func:`scipy.linalg.solve_sylvester`); otherwise the Sylvester equation and
    ``M Pi = -N_out`` are solved together in least squares (a minimum-norm solution).
    """
    nw, nX = F.shape[0], A_cl.shape[0]
    if nw == 0 or nX == 0:
        Pi = np.zeros((nw, nX))
    else:
        if _spectra_apart(F, A_cl):
            Pi = scipy.linalg.solve_sylvester(F, -A_cl, -Sigma)
        else:
            Inx, Inw = np.eye(nX), np.eye(nw)
            lhs = np.vstack([np.kron(Inx, F) - np.kron(A_cl.T, Inw), np.kron(Inx, M)])
            rhs = np.concatenate([-Sigma.ravel(order="F"), -N_out.ravel(order="F")])
            sol = np.linalg.lstsq(lhs, rhs, rcond=None)[0]
            Pi = sol.reshape((nw, nX), order="F")
    return Pi, _mismatch(M, Pi, N_out)


def _spectra_apart(F: np.ndarray, A_cl: np.ndarray, ea: np.ndarray | None = None) -> bool:
    """No eigenvalue of ``F`` within ``1e-8 max(||F||, ||A_cl||)`` of one of ``A_cl``
    (``ea``: the eigenvalues of ``A_cl`` when already known): the Sylvester equation
    ``F Pi - Pi A_cl = -Sigma`` then has a unique, well-posed solution."""
    ef = np.linalg.eigvals(F)
    ea = np.linalg.eigvals(A_cl) if ea is None else ea
    scale = max(np.linalg.norm(F), np.linalg.norm(A_cl), 1e-300)
    return bool(np.min(np.abs(ef[:, None] - ea[None, :])) > 1e-8 * scale)


def _mismatch(M: np.ndarray, Pi: np.ndarray, N_out: np.ndarray) -> float:
    """``||M Pi + N_out|| / (||M|| ||Pi|| + ||N_out||)`` (0 when both terms vanish)."""
    res = M @ Pi + N_out
    den = np.linalg.norm(M) * np.linalg.norm(Pi) + np.linalg.norm(N_out)
    return float(np.linalg.norm(res) / den) if den > 0 else 0.0


def _joint_sylvester(
    Fs: list[np.ndarray], A_cl: np.ndarray, Sigma: np.ndarray
) -> list[np.ndarray | None]:
    """``Pi`` of the generators from one Sylvester equation with ``blockdiag(F_g)``.

    The block-diagonal equation decouples into the generators' own equations, so this is
    :func:`consistent_initial_state` for all of them in one Bartels-Stewart solve.  A
    generator whose ``F_g`` shares an eigenvalue with ``A_cl`` is left out (None: it is
    solved on its own, with the least-squares fallback).  ``Sigma`` stacks the generators'
    ``Sigma_g`` row-wise.
    """
    out: list[np.ndarray | None] = [None] * len(Fs)
    if A_cl.shape[0] == 0:
        return out
    ea = np.linalg.eigvals(A_cl)
    offs = np.cumsum([0] + [F.shape[0] for F in Fs])
    keep = [g for g, F in enumerate(Fs) if F.shape[0] and _spectra_apart(F, A_cl, ea)]
    if not keep:
        return out
    rows = np.concatenate([np.arange(offs[g], offs[g + 1]) for g in keep])
    Pi = scipy.linalg.solve_sylvester(
        scipy.linalg.block_diag(*[Fs[g] for g in keep]), -A_cl, -Sigma[rows]
    )
    o = 0
    for g in keep:
        out[g] = Pi[o : o + Fs[g].shape[0]]
        o += Fs[g].shape[0]
    return out


_DECOUPLE_TOL = 1e-12  # relative Sylvester residual below which w - Pi x is decoupled


def _sylvester_residual(
    F: np.ndarray, A_cl: np.ndarray, Sigma: np.ndarray, Pi: np.ndarray
) -> float:
    """``||F Pi - Pi A_cl + Sigma|| / (||F|| ||Pi|| + ||Pi|| ||A_cl|| + ||Sigma||)``."""
    res = F @ Pi - Pi @ A_cl + Sigma
    nPi = np.linalg.norm(Pi)
    den = (np.linalg.norm(F) + np.linalg.norm(A_cl)) * nPi + np.linalg.norm(Sigma)
    return float(np.linalg.norm(res) / den) if den > 0 else 0.0


def _check_mismatch(k: int, mismatch: float) -> None:
    if mismatch > _MISMATCH_WARN:
        warnings.warn(
            f"generator {k}: no consistent initial state, relative |M Pi + N| = {mismatch:.3g}; "
            "the residual is not decoupled from the healthy loop and will show a start-up "
            "transient",
            InitialStateWarning,
            stacklevel=4,
        )


# ================================================================== context
@dataclass
class _Context:
    plant: Plant
    view: _BankView
    ctrl: _Controller
    t: np.ndarray
    step: float
    hold: str
    u_ext: np.ndarray  # (m, N)
    d: np.ndarray  # (nd, N)
    Lv: np.ndarray | None
    Bw: np.ndarray | None
    Lw: np.ndarray | None
    consistent: bool
    progress: bool
    keep_states: bool = False
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def discrete(self) -> bool:
        return self.plant.is_discrete

    @property
    def N(self) -> int:
        return self.t.shape[0]

    @property
    def nwp(self) -> int:
        return 0 if self.Bw is None else self.Bw.shape[1]

    def discretize(self, A: np.ndarray, B: np.ndarray) -> Discretization:
        if self.discrete:
            return Discretization(A, B, np.zeros_like(B), self.step, "discrete")
        return discretize(A, B, self.step, self.hold)


@dataclass
class _Raw:
    """Arrays of one chunk of runs (leading axis: runs, possibly 1 = broadcast)."""

    x: np.ndarray
    xc: np.ndarray | None
    y: np.ndarray
    y_healthy: np.ndarray
    u: np.ndarray
    r_vectors: list[np.ndarray | None]
    w: list[np.ndarray | None]
    rows: np.ndarray | None = None  # residual rows (R, n_rows, N), when already formed


# ===================================================== open loop / state fb
def _run_static(
    ctx: _Context,
    x0: np.ndarray,
    v: np.ndarray | None,
    wp: np.ndarray | None,
    fault_lists: list[list[SensorFaultSignal]],
    shared: bool,
) -> _Raw:
    """Open loop / state feedback.  Internally state-major arrays (k, runs, N)."""
    p = ctx.plant
    n, m, q, nd = p.n, p.m, p.q, p.nd
    N = ctx.N
    K = ctx.ctrl.K if ctx.ctrl.mode == "state" else np.zeros((m, n))
    A_X = p.A - p.B @ K
    nwp = ctx.nwp
    B_X = np.hstack([p.B, p.Bd] + ([ctx.Bw] if nwp else []))
    Cy0 = p.C - p.D @ K
    Dy0 = np.hstack([p.D, p.Dd, np.zeros((q, nwp))])
    Cu = -K
    Du = np.hstack([np.eye(m), np.zeros((m, nd + nwp))])
    es = np.vstack([ctx.u_ext, ctx.d]) if ctx.d.shape[0] else ctx.u_ext
    if wp is not None:
        e = np.empty((es.shape[0] + nwp, wp.shape[0], N))
        e[: es.shape[0]] = es[:, None, :]
        e[es.shape[0] :] = wp.transpose(1, 0, 2)
    else:
        e = es[:, None, :]
    ne = e.shape[0]
    foh = ctx.hold == "foh" and not ctx.discrete
    x0T = np.ascontiguousarray(x0.T)
    # ---- plant (closed with the state feedback): once for all runs
    dis = ctx.discretize(A_X, B_X)
    if foh:
        WX, dX = np.hstack([dis.B0, dis.B1]), [Drive(e), Drive(e, 1)]
    else:
        WX, dX = dis.B0, [Drive(e)]
    X, y0c, u = block_recursion(
        [dis.Ad],
        WX,
        dX,
        x0T,
        [[np.eye(n), Cy0, Cu]],
        N,
        direct=([e], [[None, Dy0, Du]]),
    )[0]
    y0n = y0c + v.transpose(1, 0, 2) if v is not None else y0c
    # ---- sensor faults on the readings, vectorised (only the sensors they touch)
    t = ctx.t
    touched = sorted({f.sensor for fl in fault_lists for f in fl if f.mask(t).any()})
    # profile rows: the sensors with faults, or every sensor when noise enters them all
    # (row[i]: the row of sensor i)
    need = sorted({f.sensor for fl in fault_lists for f in fl})
    if v is not None and not ctx.discrete:
        need = list(range(q))
    row = {i: j for j, i in enumerate(need)}
    if shared:
        prof = fault_profile(fault_lists[0], t, y0n.transpose(1, 0, 2), q=q, sensors=need)
        eta, eta_l = prof.eta[:, None, :], prof.eta_left[:, None, :]
        lam, lam_l = prof.lam.transpose(1, 0, 2), prof.lam_left.transpose(1, 0, 2)
    else:
        y0r = y0n.transpose(1, 0, 2)
        profs = [
            fault_profile(fl, t, y0r[r : r + 1] if y0r.shape[0] > 1 else y0r, q=q, sensors=need)
            for r, fl in enumerate(fault_lists)
        ]
        eta = np.stack([pr.eta for pr in profs], axis=1)
        eta_l = np.stack([pr.eta_left for pr in profs], axis=1)
        lam = np.concatenate([pr.lam[-1:].transpose(1, 0, 2) for pr in profs], axis=1)
        lam_l = np.concatenate([pr.lam_left[-1:].transpose(1, 0, 2) for pr in profs], axis=1)
    R = max(y0n.shape[1], eta.shape[1], lam.shape[1])
    if touched:
        y = np.empty((q, R, N))
        y[:] = y0n
        for i in touched:
            y[i] = eta[row[i]] * y0n[i] + lam[row[i]]
    else:
        y = y0n
    gens = [(k, g) for k, g in enumerate(ctx.view.generators) if g is not None]
    offs = np.cumsum([0] + [g.order for _, g in gens])
    Sig_all = np.vstack([-g.E @ Cy0 + g.G @ Cu for _, g in gens])
    E_all = np.vstack([g.E for _, g in gens])
    # ---- Pi with F Pi - Pi A_X = -Sigma per generator: the consistent start w = Pi x,
    # and (when every generator has one) the change of state w~ = w - Pi x that removes
    # the coupling to the plant state from the generators' equations
    Pis = _joint_sylvester([g.F for _, g in gens], A_X, Sig_all)
    w0s = {}
    for j, ((k, g), o0, o1) in enumerate(zip(gens, offs[:-1], offs[1:], strict=True)):
        if ctx.consistent:
            N_out = -g.H @ Cy0 + g.K @ Cu
            if Pis[j] is not None:
                mm = _mismatch(g.M, Pis[j], N_out)
            else:
                Pis[j], mm = consistent_initial_state(g.F, A_X, Sig_all[o0:o1], g.M, N_out)
            ctx.info.setdefault("init_mismatch", {})[k] = mm
            _check_mismatch(k, mm)
            w0s[k] = Pis[j] @ x0T
        else:
            w0s[k] = np.zeros((g.order, 1))
    decoupled = not ctx.discrete and all(
        Pi is not None and _sylvester_residual(g.F, A_X, Sig_all[o0:o1], Pi) <= _DECOUPLE_TOL
        for Pi, (_, g), o0, o1 in zip(Pis, gens, offs[:-1], offs[1:], strict=True)
    )
    # ---- drive signals of the generators, stacked once for the whole bank
    chan: list[int] = []
    if ctx.discrete:
        # exact: w[k+1] = F w[k] - E y[k] + G u[k] with the measured samples
        drives = [Drive(y), Drive(u)]
        W_all = np.hstack([-E_all, np.vstack([g.G for _, g in gens])])
        Fd = {k: g.F for k, g in gens}
    else:
        # y_i = delta_i y0c_i + rho_i over each interval (module docstring)
        sens = list(range(q)) if v is not None else touched
        if sens:
            prow = [row[i] for i in sens]
            delta = 0.5 * (eta[prow, :, :-1] + eta_l[prow, :, 1:]) if foh else eta[prow, :, :-1]
            rhoL = y[sens, :, :-1] - delta * y0c[sens, :, :-1]
            rhoR = eta_l[prow, :, 1:] * y0n[sens, :, 1:] + lam_l[prow, :, 1:]
            rhoR -= delta * y0c[sens, :, 1:]
            chan = [i for j, i in enumerate(sens) if np.any(delta[j] != 1)]
        Gam_all = np.vstack([-g.E @ Dy0 + g.G @ Du for _, g in gens])
        nwt = int(offs[-1])
        F_all = scipy.linalg.block_diag(*[g.F for _, g in gens])
        Ac = np.zeros((n + nwt, n + nwt))
        Ac[:n, :n] = A_X
        Ac[n:, :n] = Sig_all
        Ac[n:, n:] = F_all
        if decoupled:
            # w~' = F w~ + (Gamma - Pi B_X) e - E rho: the plant state drops out (exact)
            Pi_all = np.vstack(Pis)
            dc = ctx.discretize(F_all, np.hstack([Gam_all - Pi_all @ B_X, -E_all]))
            r0, drives, cols = 0, [], []
            for (k, _), Pi in zip(gens, Pis, strict=True):
                w0s[k] = w0s[k] - Pi @ x0T
        else:  # one matrix exponential of the plant and the whole bank
            dc = ctx.discretize(Ac, np.block([[B_X, np.zeros((n, q))], [Gam_all, -E_all]]))
            r0, drives, cols = n, [Drive(X)], [dc.Ad[n:, :n]]
        drives.append(Drive(e))
        cols.append(dc.B0[r0:, :ne])
        if foh:
            drives.append(Drive(e, 1))
            cols.append(dc.B1[r0:, :ne])
        if sens:
            drives.append(Drive(rhoL))
            cols.append(dc.B0[r0:, [ne + i for i in sens]])
            if foh:
                drives.append(Drive(rhoR))
                cols.append(dc.B1[r0:, [ne + i for i in sens]])
        for i in chan:  # exact coupling of a gain-faulty sensor: one more exponential each
            Aci = Ac.copy()
            Aci[n:, :n] = -E_all[:, i : i + 1] @ Cy0[i : i + 1]
            Bci = np.vstack([B_X, -E_all[:, i : i + 1] @ Dy0[i : i + 1]])
            di = ctx.discretize(Aci, Bci)
            scale = delta[sens.index(i)][None] - 1.0
            drives += [Drive(X, 0, scale), Drive(e, 0, scale)]
            cols += [di.Ad[n:, :n], di.B0[n:]]
            if foh:
                drives.append(Drive(e, 1, scale))
                cols.append(di.B1[n:])
        W_all = np.hstack(cols)
        Fd = {
            k: dc.Ad[r0 + o0 : r0 + o1, r0 + o0 : r0 + o1]
            for (k, _), o0, o1 in zip(gens, offs[:-1], offs[1:], strict=True)
        }
    ctx.info["channels"] = chan
    ctx.info["plant_state_decoupled"] = decoupled
    # residual rows are written in place, with the direct feedthrough -H y + K u (and
    # M Pi x, w = w~ + Pi x, for decoupled states) added chunk by chunk
    R = max([d.runs for d in drives] + [x0T.shape[1]])
    rows = np.zeros((R, len(ctx.view.generators), N))
    outs, dests, dmats = [], [], []
    for (k, g), Pi in zip(gens, Pis, strict=True):
        view = rows[:, k : k + 1].transpose(1, 0, 2) if g.n_outputs == 1 else None
        Dm = np.hstack([-g.H, g.K] + ([g.M @ Pi] if decoupled else []))
        if ctx.keep_states:
            Dw = np.hstack([np.zeros((g.order, q + m)), Pi]) if decoupled else None
            outs.append([g.M, np.eye(g.order)])
            dests.append([view, None])
            dmats.append([Dm, Dw])
        else:
            outs.append([g.M])
            dests.append([view])
            dmats.append([Dm])
    res = block_recursion(
        [Fd[k] for k, _ in gens],
        W_all,
        drives,
        np.vstack([np.broadcast_to(w0s[k], (g.order, x0T.shape[1])) for k, g in gens]),
        outs,
        N,
        direct=([y, u, X] if decoupled else [y, u], dmats),
        out=dests,
    )
    r_vectors: list[np.ndarray | None] = [None] * len(ctx.view.generators)
    ws: list[np.ndarray | None] = [None] * len(ctx.view.generators)
    for (k, g), rk in zip(gens, res, strict=True):
        r_vectors[k] = rk[0].transpose(1, 0, 2)
        if g.n_outputs > 1:
            rows[:, k] = np.sqrt(np.sum(r_vectors[k] ** 2, axis=1))
        if ctx.keep_states:
            ws[k] = rk[1].transpose(1, 0, 2)
    tr = lambda a: a.transpose(1, 0, 2)  # noqa: E731
    return _Raw(tr(X), None, tr(y), tr(y0n), tr(u), r_vectors, ws, rows)


# =========================================================== output feedback
class _LoopModel:
    """Closed loop plant + controller + generators for a diagonal sensor gain ``Delta``.

    Exogenous input ``e = [u_ext; d; w; v; lambda]``; states ``[x; xc; w_1; ...]``;
    outputs ``[y (measured); u; y0c (clean healthy reading); r_1; ...]``.
    """

    def __init__(self, ctx: _Context) -> None:
        self.ctx = ctx
        p, c = ctx.plant, ctx.ctrl
        self.n, self.nc, self.m, self.q, self.nd = p.n, c.nc, p.m, p.q, p.nd
        self.nwp = ctx.nwp
        self.ne = self.m + self.nd + self.nwp + 2 * self.q
        self.gens = [(k, g) for k, g in enumerate(ctx.view.generators) if g is not None]
        self.nX = self.n + self.nc
        self.nS = self.nX + sum(g.order for _, g in self.gens)
        self.nr = [g.n_outputs for _, g in self.gens]
        self._cache: dict[bytes, Any] = {}

    def loop(self, delta: np.ndarray) -> dict[str, np.ndarray]:
        """Loop matrices for sensor gains ``delta`` (q,)."""
        p, c = self.ctx.plant, self.ctx.ctrl
        n, nc, m, q, nd, nwp = self.n, self.nc, self.m, self.q, self.nd, self.nwp
        Dl = np.diag(delta)
        Lm = np.eye(m) - c.Dc @ Dl @ p.D
        if np.linalg.cond(Lm) > 1e12:
            raise GeomFDIError(
                "controller: the algebraic loop I - Dc diag(eta) D is singular; the feedback "
                "interconnection is ill-posed",
                argument="controller",
            )
        Li = np.linalg.inv(Lm)
        Bw = self.ctx.Bw if nwp else np.zeros((n, 0))
        Ux = Li @ np.hstack([c.Dc @ Dl @ p.C, c.Cc])
        Ue = Li @ np.hstack([np.eye(m), c.Dc @ Dl @ p.Dd, np.zeros((m, nwp)), c.Dc @ Dl, c.Dc])
        Y0x = np.hstack([p.C, np.zeros((q, nc))]) + p.D @ Ux
        Y0e = p.D @ Ue + np.hstack([np.zeros((q, m)), p.Dd, np.zeros((q, nwp + 2 * q))])
        Ymx = Dl @ Y0x
        Yme = Dl @ Y0e + np.hstack([np.zeros((q, m + nd + nwp)), Dl, np.eye(q)])
        AX = np.block([[p.A, np.zeros((n, nc))], [np.zeros((nc, n)), c.Ac]])
        AX = (
            AX
            + np.vstack([p.B, np.zeros((nc, m))]) @ Ux
            + np.vstack([np.zeros((n, q)), c.Bc]) @ Ymx
        )
        BX = np.vstack(
            [
                np.hstack([np.zeros((n, m)), p.Bd, Bw, np.zeros((n, 2 * q))]),
                np.zeros((nc, self.ne)),
            ]
        )
        BX = (
            BX
            + np.vstack([p.B, np.zeros((nc, m))]) @ Ue
            + np.vstack([np.zeros((n, q)), c.Bc]) @ Yme
        )
        return {
            "AX": AX,
            "BX": BX,
            "Ux": Ux,
            "Ue": Ue,
            "Y0x": Y0x,
            "Y0e": Y0e,
            "Ymx": Ymx,
            "Yme": Yme,
        }

    def composite(self, delta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(A_S, B_S, C_S, D_S)`` of the full composite for gains ``delta``."""
        key = np.asarray(delta, dtype=float).tobytes()
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        L = self.loop(delta)
        nX, nS, ne, q, m = self.nX, self.nS, self.ne, self.q, self.m
        A = np.zeros((nS, nS))
        B = np.zeros((nS, ne))
        A[:nX, :nX] = L["AX"]
        B[:nX] = L["BX"]
        nrt = sum(self.nr)
        C = np.zeros((2 * q + m + nrt, nS))
        D = np.zeros((2 * q + m + nrt, ne))
        C[:q, :nX], D[:q] = L["Ymx"], L["Yme"]
        C[q : q + m, :nX], D[q : q + m] = L["Ux"], L["Ue"]
        C[q + m : 2 * q + m, :nX], D[q + m : 2 * q + m] = L["Y0x"], L["Y0e"]
        i, o = nX, 2 * q + m
        for _, g in self.gens:
            nw, nr = g.order, g.n_outputs
            A[i : i + nw, :nX] = -g.E @ L["Ymx"] + g.G @ L["Ux"]
            A[i : i + nw, i : i + nw] = g.F
            B[i : i + nw] = -g.E @ L["Yme"] + g.G @ L["Ue"]
            C[o : o + nr, :nX] = -g.H @ L["Ymx"] + g.K @ L["Ux"]
            C[o : o + nr, i : i + nw] = g.M
            D[o : o + nr] = -g.H @ L["Yme"] + g.K @ L["Ue"]
            i += nw
            o += nr
        out = (A, B, C, D)
        if len(self._cache) < 4096:
            self._cache[key] = out
        return out

    def discretized(self, delta: np.ndarray) -> Discretization:
        key = b"d" + np.asarray(delta, dtype=float).tobytes()
        hit = self._cache.get(key)
        if hit is None:
            A, B, _, _ = self.composite(delta)
            hit = self.ctx.discretize(A, B)
            if len(self._cache) < 4096:
                self._cache[key] = hit
        return hit


def _breakpoints(faults: Sequence[SensorFaultSignal], t: np.ndarray) -> list[int]:
    N = t.shape[0]
    idx = {0, N}
    for f in faults:
        m = f.mask(t)
        change = np.flatnonzero(np.diff(m.astype(np.int8))) + 1
        idx.update(int(k) for k in change)
    return sorted(idx)


def _run_output_feedback(
    ctx: _Context,
    x0: np.ndarray,
    xc0: np.ndarray,
    v: np.ndarray | None,
    wp: np.ndarray | None,
    faults: list[SensorFaultSignal],
) -> _Raw:
    """Output feedback: piecewise-LTI segments between fault switching instants.

    Each segment simulates the composite (plant, controller, all generators) for the
    segment's sensor gains with the loop-free recursion; segments where a time-varying
    gain is active are stepped (:func:`_step_segment`).  Held readings of stuck sensors
    are taken from the previous segment's end (the reading just before the switch).
    """
    model = _LoopModel(ctx)
    p = ctx.plant
    n, nc, m, q, nX, nS = p.n, model.nc, p.m, p.q, model.nX, model.nS
    t, N = ctx.t, ctx.N
    R = max(x0.shape[0], 1 if v is None else v.shape[0], 1 if wp is None else wp.shape[0])
    X0 = np.hstack([np.broadcast_to(x0, (R, n)), np.broadcast_to(xc0, (R, nc))])
    # consistent generator states for the healthy loop (Delta = I)
    L0 = model.loop(np.ones(q))
    S0 = np.zeros((R, nS))
    S0[:, :nX] = X0
    i = nX
    for k, g in model.gens:
        nw = g.order
        if ctx.consistent:
            Sig = -g.E @ L0["Ymx"] + g.G @ L0["Ux"]
            Nout = -g.H @ L0["Ymx"] + g.K @ L0["Ux"]
            Pi, mm = consistent_initial_state(g.F, L0["AX"], Sig, g.M, Nout)
            ctx.info.setdefault("init_mismatch", {})[k] = mm
            _check_mismatch(k, mm)
            S0[:, i : i + nw] = X0 @ Pi.T
        i += nw
    # exogenous samples (lambda filled per segment)
    ne = model.ne
    e = np.zeros((R, ne, N))
    e[:, :m] = ctx.u_ext
    e[:, m : m + p.nd] = ctx.d
    o = m + p.nd
    if wp is not None:
        e[:, o : o + ctx.nwp] = wp
    o += ctx.nwp
    if v is not None:
        e[:, o : o + q] = v
    lam_slot = slice(o + q, o + 2 * q)
    nout = 2 * q + m + sum(model.nr)
    states = np.zeros((R, nS, N))
    outs = np.zeros((R, nout, N))
    y0n = np.zeros((R, q, N))  # noisy healthy readings (filled progressively, for holds)
    _, _, C1, D1 = model.composite(np.ones(q))
    first = C1 @ S0[..., None] + D1 @ e[:, :, :1]
    y0n[:, :, 0] = first[:, q + m : 2 * q + m, 0] + (v[:, :, 0] if v is not None else 0.0)
    holds: dict[int, np.ndarray] = {}
    bps = _breakpoints(faults, t)
    S = S0
    stepping = 0
    bar = _progress(ctx.progress and any(f.time_varying_gain for f in faults), N, "stepping")
    for a, b in zip(bps[:-1], bps[1:], strict=True):
        kend = min(b, N - 1)
        Lseg = kend - a + 1
        prof = fault_profile(faults, t, y0n, q=q, k0=a, k1=kend + 1, holds=holds, last_left=b < N)
        lam = np.broadcast_to(prof.lam, (R, q, Lseg)).copy()
        if b < N:  # right end of the segment: left limit (faults of this segment)
            lam[..., -1] = prof.lam_left[..., -1]
        e[:, lam_slot, a : kend + 1] = lam
        eseg = e[:, :, a : kend + 1]
        active = [f for f in faults if f.mask(t)[a]]
        if any(f.time_varying_gain for f in active):
            stepping += Lseg - 1
            seg_states, seg_out = _step_segment(ctx, model, S, eseg, prof, b < N, bar)
        else:
            delta = prof.eta[:, 0]
            dis = model.discretized(delta)
            _, _, C, D = model.composite(delta)
            seg_states = linear_recursion(dis.Ad, dis.forcing(eseg), S)
            seg_out = _mm(C, seg_states) + _mm(D, eseg)
            if bar is not None:
                bar.update(Lseg - 1)
        stop = Lseg if b >= N else Lseg - 1
        states[:, :, a : a + stop] = seg_states[:, :, :stop]
        outs[:, :, a : a + stop] = seg_out[:, :, :stop]
        y0h = seg_out[:, q + m : 2 * q + m]
        if v is not None:
            y0h = y0h + v[:, :, a : kend + 1]
        y0n[:, :, a : kend + 1] = y0h
        S = seg_states[:, :, -1]
    if bar is not None:
        bar.close()
    ctx.info["segments"] = len(bps) - 1
    ctx.info["stepped_samples"] = stepping
    # recompute the healthy readings recorded at segment ends with the final config
    y0n = outs[:, q + m : 2 * q + m] + (v if v is not None else 0.0)
    r_vectors: list[np.ndarray | None] = [None] * len(ctx.view.generators)
    ws: list[np.ndarray | None] = [None] * len(ctx.view.generators)
    i, o = nX, 2 * q + m
    for k, g in model.gens:
        ws[k] = states[:, i : i + g.order]
        r_vectors[k] = outs[:, o : o + g.n_outputs]
        i += g.order
        o += g.n_outputs
    return _Raw(
        states[:, :n],
        states[:, n:nX],
        outs[:, :q],
        y0n,
        outs[:, q : q + m],
        r_vectors,
        ws,
    )


def _step_segment(
    ctx: _Context,
    model: _LoopModel,
    S: np.ndarray,
    eseg: np.ndarray,
    prof: Any,
    left_end: bool,
    bar: Any,
) -> tuple[np.ndarray, np.ndarray]:
    """Time-varying gains under output feedback: one exact step per sample, gain frozen."""
    R, nS = S.shape
    L = eseg.shape[-1]
    states = np.empty((R, nS, L))
    states[:, :, 0] = S
    foh = not ctx.discrete and ctx.hold == "foh"
    for j in range(L - 1):
        eta_r = prof.eta_left[:, j + 1]
        delta = 0.5 * (prof.eta[:, j] + eta_r) if foh else prof.eta[:, j]
        dis = model.discretized(delta)
        nxt = dis.Ad @ states[:, :, j].T + dis.B0 @ eseg[:, :, j].T
        if foh:
            nxt = nxt + dis.B1 @ eseg[:, :, j + 1].T
        states[:, :, j + 1] = nxt.T
        if bar is not None:
            bar.update(1)
    nout = model.composite(prof.eta[:, 0])[2].shape[0]
    out = np.empty((R, nout, L))
    for j in range(L):
        eta = prof.eta_left[:, j] if (left_end and j == L - 1) else prof.eta[:, j]
        _, _, C, D = model.composite(eta)
        out[:, :, j] = states[:, :, j] @ C.T + eseg[:, :, j] @ D.T
    return states, out


def _progress(enabled: bool, total: int, desc: str) -> Any:
    if not enabled:
        return None
    from tqdm.auto import tqdm

    return tqdm(total=total, desc=desc, leave=False)


# ================================================================== results
def _rows(ctx: _Context, raw: _Raw) -> np.ndarray:
    """Residual rows (R, n_rows, N): one per bank row, norms for vector residuals."""
    if raw.rows is not None:
        return raw.rows
    r_vectors = raw.r_vectors
    R = max(r.shape[0] for r in r_vectors if r is not None)
    N = ctx.N
    out = np.zeros((R, len(r_vectors), N))
    for k, rv in enumerate(r_vectors):
        if rv is None:
            continue
        out[:, k] = rv[:, 0] if rv.shape[1] == 1 else np.sqrt(np.sum(rv * rv, axis=1))
    return out


def _fault_indices(view: _BankView, faults: Sequence[SensorFaultSignal]) -> list[int | None]:
    out: list[int | None] = []
    for f in faults:
        j = None
        for idx, df in enumerate(view.design_faults):
            if isinstance(df, SensorFault) and df.i == f.sensor:
                j = idx
                break
        out.append(j)
    return out


@dataclass
class SimulationResult:
    """Outcome of :func:`simulate`.

    Attributes
    ----------
    t : ndarray, (N,)
    x : ndarray, (n, N)
        Plant state.
    y : ndarray, (q, N)
        Faulty measured output (what the bank and an output-feedback controller saw).
    y_healthy : ndarray, (q, N)
        Healthy reading ``C x + D u + Dd d + v`` (noise included, no sensor fault).
    u : ndarray, (m, N)
        Applied input (including the controller's action).
    residuals : ndarray, (n_residuals, N)
        One row per bank row (aligned with ``bank.generators``); zeros for missing
        generators; the norm of the components for vector residuals.
    residual_vectors : list of ndarray or None
        Per bank row, the residual components (n_outputs, N).
    alarms : ndarray of bool, (n_residuals, N)
        All False when no threshold is given.
    isolated : ndarray of int, (N,)
        Isolation decision per sample (see :mod:`geomfdi.evaluation.decision`).
    candidates, suspects : ndarray of bool, (n_faults, N)
    threshold : Threshold or None
    events : list of FaultEvent
        Detection/isolation delay per simulated fault.
    faults : list
        The simulated fault signals.
    structure : ndarray of bool
        Achieved structure used for isolation (residuals x design faults).
    xc : ndarray or None
        Controller state (output feedback).
    w : list of ndarray or None
        Generator states per bank row (with ``keep_states=True`` or output feedback).
    info : dict
        ``mode``, ``hold``, ``init_mismatch`` per generator, ``segments``,
        ``stepped_samples``, ``channels``.
    """

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    y_healthy: np.ndarray
    u: np.ndarray
    residuals: np.ndarray
    residual_vectors: list[np.ndarray | None]
    alarms: np.ndarray
    isolated: np.ndarray
    candidates: np.ndarray
    suspects: np.ndarray
    threshold: Threshold | None
    events: list[FaultEvent]
    faults: list[SensorFaultSignal]
    structure: np.ndarray
    requested: np.ndarray | None
    fault_labels: list[str]
    residual_labels: list[str]
    xc: np.ndarray | None = None
    w: list[np.ndarray | None] = field(default_factory=list)
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def onsets(self) -> list[float]:
        """Onset time of each simulated fault that starts on the grid."""
        return [ev.onset for ev in self.events]

    def max_abs(self, start: float | None = None, stop: float | None = None) -> np.ndarray:
        """``max |r|`` per residual over ``start <= t <= stop`` (bounds optional)."""
        start = as_float(start, "start", allow_none=True)
        stop = as_float(stop, "stop", allow_none=True)
        sel = np.ones(self.t.shape, dtype=bool)
        if start is not None:
            sel &= self.t >= start - 1e-9 * max(1.0, abs(start))
        if stop is not None:
            sel &= self.t <= stop + 1e-9 * max(1.0, abs(stop))
        if not sel.any():
            raise GeomFDIError("start, stop: the window holds no sample", argument="start")
        return np.max(np.abs(self.residuals[:, sel]), axis=1)

    @property
    def false_alarm_rate(self) -> float | None:
        """Fraction of samples before the first onset where some residual alarms."""
        if self.threshold is None:
            return None
        k = np.searchsorted(self.t, min(self.onsets) - 1e-12) if self.onsets else self.t.size
        if k == 0:
            return None
        return float(np.mean(self.alarms[:, :k].any(axis=0)))

    def summary_rows(self) -> list[dict[str, Any]]:
        """One dict per simulated fault: onset, detection and isolation times/delays."""
        rows = []
        for ev in self.events:
            rows.append(
                {
                    "fault": ev.fault.label(),
                    "sensor": ev.fault.sensor,
                    "structure_column": ev.index,
                    "onset": ev.onset,
                    "detected_at": ev.detection_time,
                    "detection_delay": ev.detection_delay,
                    "isolated_at": ev.isolation_time,
                    "isolation_delay": ev.isolation_delay,
                    "alarming_residuals": [self.residual_labels[r] for r in ev.residuals],
                }
            )
        return rows

    def summary(self) -> str:
        """A plain-text report: residual peaks, thresholds, detection and isolation."""
        return _summary_text(self)

    def plot(self, **kwargs: Any) -> Any:
        """Residual traces with thresholds and fault onsets (a matplotlib Figure)."""
        from geomfdi.plotting.residuals import plot_result

        return plot_result(self, **kwargs)


def _fmt(x: float | None, unit: str = " s") -> str:
    return "-" if x is None else f"{x:.4g}{unit}"


def _summary_text(res: SimulationResult) -> str:
    lines = [
        f"simulation: {res.t.size} samples, t = {res.t[0]:g} .. {res.t[-1]:g} s, "
        f"mode {res.info.get('mode')}"
    ]
    first = min(res.onsets) if res.onsets else None
    lines.append("residual   max|r| before first onset   max|r| after   threshold")
    before = (
        res.max_abs(stop=res.t[max(np.searchsorted(res.t, first - 1e-12) - 1, 0)])
        if first is not None and first > res.t[0]
        else None
    )
    after = res.max_abs(start=first) if first is not None else res.max_abs()
    for k, lab in enumerate(res.residual_labels):
        thr = "-" if res.threshold is None else f"{res.threshold.values[k]:.4g}"
        b = "-" if before is None else f"{before[k]:.4g}"
        lines.append(f"{lab:<10} {b:>26} {after[k]:>14.4g} {thr:>11}")
    if res.events:
        lines.append("fault                                   onset    detected   isolated")
        for ev in res.events:
            lines.append(
                f"{ev.fault.label()[:38]:<38} {ev.onset:>7.4g} {_fmt(ev.detection_delay):>10} "
                f"{_fmt(ev.isolation_delay):>10}"
            )
    far = res.false_alarm_rate
    if far is not None:
        lines.append(f"false-alarm rate before the first onset: {far:.4g}")
    return "\n".join(lines)


@dataclass
class BatchResult:
    """Outcome of :func:`simulate_batch` (leading axis: runs).

    Attributes
    ----------
    t : ndarray, (N,)
    runs : int
    residuals : ndarray, (runs, n_residuals, N) or None
        Stored unless ``store="summary"``.
    alarms : ndarray of bool, (runs, n_residuals, N) or None
    isolated : ndarray of int, (runs, N) or None
    x, y, u, y_healthy : ndarray or None
        Stored with ``store="all"``.
    peak : ndarray, (runs, n_residuals)
        ``max |r|`` over each run.
    events : list of list of FaultEvent
    false_alarm_counts, healthy_samples : ndarray, (runs,)
        Number of samples before each run's first onset with some alarm, and of samples
        before the first onset (see :attr:`false_alarm_rate`).
    fault_lists : list of list
    seeds : list
    threshold : Threshold or None
    """

    t: np.ndarray
    runs: int
    residuals: np.ndarray | None
    alarms: np.ndarray | None
    isolated: np.ndarray | None
    x: np.ndarray | None
    y: np.ndarray | None
    u: np.ndarray | None
    y_healthy: np.ndarray | None
    peak: np.ndarray
    events: list[list[FaultEvent]]
    false_alarm_counts: np.ndarray
    healthy_samples: np.ndarray
    fault_lists: list[list[SensorFaultSignal]]
    seeds: list[Any]
    threshold: Threshold | None
    structure: np.ndarray
    requested: np.ndarray | None
    fault_labels: list[str]
    residual_labels: list[str]
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def false_alarm_rate(self) -> float | None:
        """Pooled fraction of fault-free samples with some alarm (None without data)."""
        tot = int(self.healthy_samples.sum())
        if self.threshold is None or tot == 0:
            return None
        return float(self.false_alarm_counts.sum() / tot)

    def detection_rate(self, which: int = 0) -> float:
        """Fraction of runs whose ``which``-th fault (in its list) was detected."""
        which = as_int(which, "which", minimum=0)
        ev = [e[which] for e in self.events if len(e) > which]
        if not ev:
            raise GeomFDIError(f"which: no run has a fault number {which}", argument="which")
        return float(np.mean([x.detected for x in ev]))

    def detection_delays(self, which: int = 0) -> np.ndarray:
        """Detection delays of the ``which``-th fault over the runs that detected it."""
        which = as_int(which, "which", minimum=0)
        return np.array(
            [e[which].detection_delay for e in self.events if len(e) > which and e[which].detected]
        )

    def run(self, i: int) -> SimulationResult:
        """Run ``i`` as a :class:`SimulationResult` (needs ``store="all"``)."""
        i = as_int(i, "i", minimum=0)
        if self.x is None or self.residuals is None:
            raise GeomFDIError("i: single runs need simulate_batch(..., store='all')", argument="i")
        if i >= self.runs:
            raise GeomFDIError(f"i: only {self.runs} runs", argument="i")
        iso = isolate(self.alarms[i], self.structure)
        return SimulationResult(
            self.t,
            self.x[i],
            self.y[i],
            self.y_healthy[i],
            self.u[i],
            self.residuals[i],
            [None] * self.residuals.shape[1],
            self.alarms[i],
            iso.isolated,
            iso.candidates,
            iso.suspects,
            self.threshold,
            self.events[i],
            self.fault_lists[i],
            self.structure,
            self.requested,
            self.fault_labels,
            self.residual_labels,
            info=dict(self.info),
        )

    def summary(self) -> str:
        """Plain-text Monte-Carlo summary."""
        lines = [f"batch: {self.runs} runs x {self.t.size} samples"]
        pk = self.peak
        for k, lab in enumerate(self.residual_labels):
            lines.append(
                f"{lab:<10} max|r| median {np.median(pk[:, k]):.4g}, max {np.max(pk[:, k]):.4g}"
            )
        nmax = max((len(e) for e in self.events), default=0)
        for j in range(nmax):
            rate = self.detection_rate(j)
            d = self.detection_delays(j)
            md = f"{np.median(d):.4g} s" if d.size else "-"
            lines.append(f"fault #{j}: detected in {rate:.1%} of runs, median delay {md}")
        far = self.false_alarm_rate
        if far is not None:
            lines.append(f"false-alarm rate (fault-free samples): {far:.4g}")
        return "\n".join(lines)


# ============================================================ entry points
def _prepare(
    plant: Any,
    bank: Any,
    t: Any,
    u: Any,
    d: Any,
    noise: Any,
    controller: Any,
    hold: str,
    consistent_init: bool,
    progress: Any,
) -> _Context:
    hold = as_choice(hold, "hold", HOLDS)
    consistent_init = as_bool(consistent_init, "consistent_init")
    progress = None if progress is None else as_bool(progress, "progress")
    plant = as_plant(plant)
    view = _bank_view(bank, plant)
    ctrl = _controller(controller, plant)
    t, step = uniform_step(t)
    if plant.is_discrete and abs(step - plant.dt) > 1e-6 * plant.dt:
        raise GeomFDIError(
            f"t: the grid step {step:g} must equal the plant's sampling period {plant.dt:g}",
            argument="t",
        )
    if hold not in HOLDS:
        raise GeomFDIError(f"hold: must be one of {HOLDS}, got {hold!r}", argument="hold")
    if noise is not None and not isinstance(noise, Noise):
        raise GeomFDIError(
            f"noise: expected a geomfdi Noise, got {type(noise).__name__}", argument="noise"
        )
    Lv, Bw, Lw = noise.factors(plant) if noise is not None else (None, None, None)
    if progress is None:
        progress = sys.stderr.isatty()
    return _Context(
        plant,
        view,
        ctrl,
        t,
        step,
        hold,
        _signal(u, t, plant.m, "u"),
        _signal(d, t, plant.nd, "d"),
        Lv,
        Bw,
        Lw,
        bool(consistent_init),
        bool(progress),
        info={
            "mode": {"open": "open loop", "state": "state feedback", "output": "output feedback"}[
                ctrl.mode
            ],
            "hold": "discrete" if plant.is_discrete else hold,
        },
    )


def _draw(ctx: _Context, rng: np.random.Generator) -> tuple[np.ndarray | None, np.ndarray | None]:
    N = ctx.N
    v = ctx.Lv @ rng.standard_normal((ctx.plant.q, N)) if ctx.Lv is not None else None
    w = ctx.Lw @ rng.standard_normal((ctx.Lw.shape[1], N)) if ctx.Lw is not None else None
    return v, w


def _state_vector(value: Any, n: int, name: str, runs: int | None = None) -> np.ndarray:
    if value is None:
        return np.zeros((1, n))
    arr = as_real_array(value, name)
    if arr.ndim == 1:
        if arr.shape[0] != n:
            raise ShapeError(f"{name}: expected length {n}, got {arr.shape[0]}", argument=name)
        return arr[None]
    if arr.ndim == 2 and runs is not None and arr.shape == (runs, n):
        return arr
    expect = f"({n},)" if runs is None else f"({n},) or ({runs}, {n})"
    raise ShapeError(f"{name}: expected shape {expect}, got {arr.shape}", argument=name)


def _run_chunk(
    ctx: _Context,
    x0: np.ndarray,
    xc0: np.ndarray,
    rngs: list[np.random.Generator | None],
    fault_lists: list[list[SensorFaultSignal]],
    shared: bool,
) -> _Raw:
    draws = [_draw(ctx, rng) if rng is not None else (None, None) for rng in rngs]
    v = np.stack([dv for dv, _ in draws]) if ctx.Lv is not None else None
    wp = np.stack([dw for _, dw in draws]) if ctx.Lw is not None else None
    if wp is not None:
        wp = np.asarray(wp)
    if ctx.ctrl.mode != "output":
        return _run_static(ctx, x0, v, wp, fault_lists, shared)
    if shared:
        return _run_output_feedback(ctx, x0, xc0, v, wp, fault_lists[0])
    parts = []
    for r, fl in enumerate(fault_lists):  # the loop differs per run: one at a time
        parts.append(
            _run_output_feedback(
                ctx,
                x0[r : r + 1] if x0.shape[0] > 1 else x0,
                xc0,
                None if v is None else v[r : r + 1],
                None if wp is None else wp[r : r + 1],
                fl,
            )
        )
    cat = lambda xs: np.concatenate(xs)  # noqa: E731
    return _Raw(
        cat([p.x for p in parts]),
        cat([p.xc for p in parts]),
        cat([p.y for p in parts]),
        cat([p.y_healthy for p in parts]),
        cat([p.u for p in parts]),
        [
            None if parts[0].r_vectors[k] is None else cat([p.r_vectors[k] for p in parts])
            for k in range(len(parts[0].r_vectors))
        ],
        [
            None if parts[0].w[k] is None else cat([p.w[k] for p in parts])
            for k in range(len(parts[0].w))
        ],
    )


def _labels(view: _BankView) -> list[str]:
    return [f"r[{k}]" for k in range(len(view.generators))]


def simulate(
    plant: Plant,
    bank: ResidualBank | ResidualGenerator,
    t: Any,
    u: Any = None,
    *,
    faults: Sequence[SensorFaultSignal] | SensorFaultSignal = (),
    x0: Any = None,
    noise: Noise | None = None,
    controller: Any = None,
    threshold: Any = None,
    d: Any = None,
    xc0: Any = None,
    hold: str = "foh",
    consistent_init: bool = True,
    keep_states: bool = False,
    progress: bool | None = None,
) -> SimulationResult:
    """Simulate the plant with sensor faults and run the residual bank on its output.

    Parameters
    ----------
    plant : Plant
        Continuous (``dt = 0``) or discrete.
    bank : ResidualBank or ResidualGenerator
        The generators, same ``dt`` as the plant.
    t : array_like, (N,)
        Uniform time grid; for a discrete plant its step must equal ``plant.dt``.
    u : array_like (m, N), callable or None
        External input ``u_ext`` (a vectorised function of the time array is accepted;
        ``None``: zero).  With a controller the applied input is ``u_ext - K x`` or
        ``u_ext + K(s) y``.
    faults : sequence of GainFault / BiasFault / StuckFault
        Any number, on any sensors (composed in order on one sensor).
    x0 : array_like (n,), optional
        Initial plant state (zero by default).
    noise : Noise, optional
        Measurement and process noise with a seed.
    controller : None, array (m, n), or python-control system
        None: open loop.  An array ``K``: state feedback ``u = u_ext - K x`` on the true
        state.  A python-control ``StateSpace``/``TransferFunction`` from the measured
        (faulty) ``y`` (q inputs) to ``u`` (m outputs): output feedback
        ``u = u_ext + K(s) y``.
    threshold : None, float, (n_residuals,) or Threshold
        Decision thresholds on ``|r|`` (or a calibrated :class:`Threshold`).  ``None``:
        no decision (no alarms).
    d : array_like (nd, N), callable or None
        Disturbance signal (decoupled by design).
    xc0 : array_like, optional
        Initial controller state (output feedback; zero by default).
    hold : {"foh", "zoh"}
        Interpolation of the sampled exogenous signals for continuous plants.  ``"foh"``
        (linear between samples) is the convention of :func:`control.forced_response`.
    consistent_init : bool
        Start the generators at the state consistent with the healthy loop (module
        docstring); False: at zero.
    keep_states : bool
        Also return the generator states ``w`` (``res.w``); off by default to save
        memory (always kept under output feedback, where they come for free).
    progress : bool, optional
        Progress bar for the stepping scheme (default: when stderr is a terminal).

    Returns
    -------
    SimulationResult

    Notes
    -----
    Fault model: seed 001, eq. (3)-(5); generator: eq. (23) with the measured y
    (Erratum 1 of math.md).  See the module docstring for how the simulation is exact
    for abrupt faults and what is approximated for time-varying gains.

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> p = gf.Plant([[-1.0]], [[1.0]], [[1.0]])
    >>> g = gf.ResidualGenerator([[-2.0]], [[-1.0]], [[1.0]], [[1.0]], [[1.0]], [[0.0]])
    >>> res = gf.simulate(p, g, np.linspace(0, 4, 401), faults=[gf.BiasFault(0, 2.0, 0.1)],
    ...                   threshold=0.05)
    >>> bool(res.max_abs(stop=1.99)[0] < 1e-12), res.events[0].detection_delay
    (True, 0.0)
    """
    keep_states = as_bool(keep_states, "keep_states")
    plant = as_plant(plant)
    ctx = _prepare(plant, bank, t, u, d, noise, controller, hold, consistent_init, progress)
    ctx.keep_states = bool(keep_states)
    fl = validate_faults(faults, plant.q)
    x0a = _state_vector(x0, plant.n, "x0")
    xc0a = _state_vector(xc0, ctx.ctrl.nc, "xc0")
    rng = np.random.default_rng(noise.seed) if noise is not None else None
    raw = _run_chunk(ctx, x0a, xc0a, [rng], [fl], True)
    res = _rows(ctx, raw)[0]
    view = ctx.view
    thr = as_threshold(threshold, len(view.generators), view.present)
    if thr is not None:
        alarms = thr.alarms(res)
    else:
        alarms = np.zeros(res.shape, dtype=bool)
    iso = isolate(alarms, view.structure)
    events = detection_events(ctx.t, alarms, iso.isolated, fl, _fault_indices(view, fl))
    first = lambda a: None if a is None else a[0]  # noqa: E731
    return SimulationResult(
        t=ctx.t,
        x=raw.x[0],
        y=raw.y[0],
        y_healthy=np.ascontiguousarray(raw.y_healthy[0]),
        u=np.ascontiguousarray(raw.u[0]),
        residuals=res,
        residual_vectors=[first(r) for r in raw.r_vectors],
        alarms=alarms,
        isolated=iso.isolated,
        candidates=iso.candidates,
        suspects=iso.suspects,
        threshold=thr,
        events=events,
        faults=fl,
        structure=view.structure,
        requested=view.requested,
        fault_labels=view.fault_labels,
        residual_labels=_labels(view),
        xc=first(raw.xc),
        w=[first(w) for w in raw.w],
        info=ctx.info,
    )


def simulate_batch(
    plant: Plant,
    bank: ResidualBank | ResidualGenerator,
    t: Any,
    u: Any = None,
    *,
    runs: int | None = None,
    faults: Any = (),
    x0: Any = None,
    noise: Noise | None = None,
    seeds: Sequence[Any] | None = None,
    controller: Any = None,
    threshold: Any = None,
    d: Any = None,
    xc0: Any = None,
    hold: str = "foh",
    consistent_init: bool = True,
    store: str = "residuals",
    chunk_size: int | None = None,
    progress: bool | None = None,
) -> BatchResult:
    """Many Monte-Carlo runs (noise seeds, fault sizes) in one vectorised call.

    Parameters
    ----------
    plant, bank, t, u, x0, controller, threshold, d, xc0, hold, consistent_init
        As for :func:`simulate`; ``x0`` may also be ``(runs, n)``.
    runs : int, optional
        Number of runs; defaults to the number of fault lists when ``faults`` is a list
        of lists, else 1.
    faults : sequence of fault signals, or a sequence of such sequences
        One list shared by all runs, or one list per run (e.g. a sweep of fault sizes).
    noise : Noise, optional
        Run ``i`` draws its noise from ``numpy.random.default_rng(seeds[i])``; by default
        the seeds are ``SeedSequence(noise.seed).spawn(runs)``, so run ``i`` equals
        ``simulate(..., noise=Noise(..., seed=seeds[i]))``.
    seeds : sequence, optional
        Explicit per-run seeds.
    store : {"residuals", "all", "summary"}
        What to keep per run: residuals, alarms and decisions (default); also ``x, y,
        u`` (``"all"``, enables :meth:`BatchResult.run`); or only peaks and events.
    chunk_size : int, optional
        Runs simulated together (default: as many as fit ~2e7 array elements).
    progress : bool, optional
        tqdm progress bar over the chunks (default: when stderr is a terminal).

    Returns
    -------
    BatchResult

    Notes
    -----
    Open loop and state feedback are vectorised across all runs of a chunk (one compiled
    recursion per state over the ``(runs, N)`` array).  Under output feedback runs with a
    shared fault list are vectorised; per-run fault lists are simulated one run at a time
    (the loop dynamics differ between runs).
    """
    store = as_choice(store, "store", ("residuals", "all", "summary"))
    if seeds is not None:
        seeds = [as_seed(s, "seeds") for s in as_sequence_of(seeds, "seeds", object)]
        # None: fresh OS entropy for that run (numpy's convention), not "no noise"
        seeds = [np.random.SeedSequence() if s is None else s for s in seeds]
    plant = as_plant(plant)
    ctx = _prepare(plant, bank, t, u, d, noise, controller, hold, consistent_init, progress)
    q = plant.q
    per_run = (
        not isinstance(faults, SensorFaultSignal)
        and isinstance(faults, Sequence)
        and len(faults) > 0
        and all(isinstance(f, Sequence) for f in faults)
    )
    if per_run:
        fault_lists = [validate_faults(f, q, argument=f"faults[{i}]") for i, f in enumerate(faults)]
        if runs is None:
            runs = len(fault_lists)
        if runs != len(fault_lists):
            raise ShapeError(
                f"faults: {len(fault_lists)} fault lists for runs={runs}", argument="faults"
            )
    else:
        runs = 1 if runs is None else runs
        fault_lists = None
    runs = check_runs(runs)
    shared_list = validate_faults(faults, q) if not per_run else None
    if store not in ("residuals", "all", "summary"):
        raise GeomFDIError(
            f"store: must be 'residuals', 'all' or 'summary', got {store!r}", argument="store"
        )
    x0a = _state_vector(x0, plant.n, "x0", runs)
    xc0a = _state_vector(xc0, ctx.ctrl.nc, "xc0")
    if noise is not None:
        if seeds is None:
            ss = (
                noise.seed
                if isinstance(noise.seed, np.random.SeedSequence)
                else (np.random.SeedSequence(noise.seed))
            )
            seeds = list(ss.spawn(runs))
        elif len(seeds) != runs:
            raise ShapeError(f"seeds: expected {runs} seeds, got {len(seeds)}", argument="seeds")
        seeds = list(seeds)
    else:
        seeds = [None] * runs
    view = ctx.view
    nres = len(view.generators)
    N = ctx.N
    width = (
        plant.n
        + 3 * q
        + plant.m
        + ctx.ctrl.nc
        + 2 * sum(g.order + g.n_outputs for g in view.generators if g is not None)
    )
    if chunk_size is None:
        chunk_size = max(1, int(2e7 // max(width * N, 1)))
    chunk_size = as_int(chunk_size, "chunk_size", minimum=1)
    stored = 2 * nres + 1 if store != "summary" else nres
    stored += plant.n + 3 * q + plant.m if store == "all" else 0
    check_allocation(N, runs, stored, argument="runs", what="simulate_batch")
    thr = as_threshold(threshold, nres, view.present)
    keep_r = store in ("residuals", "all")
    R_res = np.zeros((runs, nres, N)) if keep_r else None
    R_al = np.zeros((runs, nres, N), dtype=bool) if keep_r else None
    R_iso = np.zeros((runs, N), dtype=int) if keep_r else None
    R_x = np.zeros((runs, plant.n, N)) if store == "all" else None
    R_y = np.zeros((runs, q, N)) if store == "all" else None
    R_yh = np.zeros((runs, q, N)) if store == "all" else None
    R_u = np.zeros((runs, plant.m, N)) if store == "all" else None
    peak = np.zeros((runs, nres))
    events: list[list[FaultEvent]] = []
    fa_counts = np.zeros(runs)
    healthy = np.zeros(runs, dtype=int)
    all_lists = fault_lists if per_run else [shared_list] * runs
    bar = _progress(ctx.progress, runs, "runs")
    for a in range(0, runs, chunk_size):
        b = min(a + chunk_size, runs)
        rngs = [None if s is None else np.random.default_rng(s) for s in seeds[a:b]]
        x0c = x0a[a:b] if x0a.shape[0] > 1 else x0a
        lists = all_lists[a:b]
        raw = _run_chunk(ctx, x0c, xc0a, rngs, lists, not per_run)
        Rc = b - a
        res = np.broadcast_to(_rows(ctx, raw), (Rc, nres, N))
        al = thr.alarms(res) if thr is not None else np.zeros(res.shape, dtype=bool)
        iso = isolate(al, view.structure)
        peak[a:b] = np.max(np.abs(res), axis=-1)
        for r in range(Rc):
            fl = lists[r]
            evs = detection_events(ctx.t, al[r], iso.isolated[r], fl, _fault_indices(view, fl))
            events.append(evs)
            onset = min((ev.onset for ev in evs), default=None)
            k = N if onset is None else int(np.searchsorted(ctx.t, onset - 1e-12))
            healthy[a + r] = k
            fa_counts[a + r] = np.count_nonzero(al[r, :, :k].any(axis=0))
        if keep_r:
            R_res[a:b] = res
            R_al[a:b] = al
            R_iso[a:b] = iso.isolated
        if store == "all":
            R_x[a:b] = raw.x
            R_y[a:b] = raw.y
            R_yh[a:b] = raw.y_healthy
            R_u[a:b] = raw.u
        if bar is not None:
            bar.update(Rc)
    if bar is not None:
        bar.close()
    return BatchResult(
        t=ctx.t,
        runs=runs,
        residuals=R_res,
        alarms=R_al,
        isolated=R_iso,
        x=R_x,
        y=R_y,
        y_healthy=R_yh,
        u=R_u,
        peak=peak,
        events=events,
        false_alarm_counts=fa_counts,
        healthy_samples=healthy,
        fault_lists=all_lists,
        seeds=seeds,
        threshold=thr,
        structure=view.structure,
        requested=view.requested,
        fault_labels=view.fault_labels,
        residual_labels=_labels(view),
        info=ctx.info,
    )
