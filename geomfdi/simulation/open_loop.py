"""Open loop and state feedback: the plant once for all runs, the bank driven exactly.

The plant does not see the sensor faults, so its state is simulated once; each bank
generator is driven over each sampling interval by the exact discretisation of the
composite ``[plant; generator]`` (or, when the generators decouple, in the coordinates
``w~ = w - Pi x``).  See :mod:`geomfdi.simulation.simulate` for the model.

:class:`OpenLoopEngine` sets the matrices up once and then advances over the record one
time chunk at a time (:meth:`OpenLoopEngine.advance`): the plant state, the generator
states and the held readings of stuck sensors are carried from one chunk to the next
(the recursion is linear and time-invariant: the final state of a chunk is the initial
state of the next), so the memory is proportional to the chunk, not to the record.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import scipy.linalg

from geomfdi.simulation.compiled_single import run_recursion
from geomfdi.simulation.context import Context, Piece
from geomfdi.simulation.initial_state import (
    EXACT_TOL,
    consistent_start,
    inexact_start,
    joint_sylvester,
    start_error,
)
from geomfdi.simulation.lifting import Drive, _digest
from geomfdi.simulation.profiles import fault_profiles, profile_groups
from geomfdi.simulation.signals import (
    BiasFault,
    SensorFaultSignal,
    fault_profile,
    first_active,
)
from geomfdi.simulation.streaming import Workspace


# ===================================================== open loop / state fb
class OpenLoopEngine:
    """Open loop / state feedback over a record, advanced one time chunk at a time.

    Parameters
    ----------
    ctx : Context
    x0 : ndarray, (R0, n)
        Initial plant states (balanced units).
    fault_lists : list of list of SensorFaultSignal
        One list shared by every run (``shared``), or one per run.
    shared : bool
    runs : int
        Runs simulated together (the noise of each run differs).
    chunk : int
        Samples per window of the pass that finds the gain-faulty sensors.

    Attributes
    ----------
    R : int
        Runs of the generator arrays: ``runs``, or 1 when every run has the same data
        (no noise, one fault list, one initial state): then the rows broadcast.
    """

    def __init__(
        self,
        ctx: Context,
        x0: np.ndarray,
        fault_lists: list[list[SensorFaultSignal]],
        shared: bool,
        runs: int,
        chunk: int,
    ) -> None:
        self.ctx = ctx
        p = ctx.plant
        n, m, q, nd = p.n, p.m, p.q, p.nd
        self.fault_lists, self.shared = fault_lists, shared
        self.groups = None if shared else profile_groups(fault_lists)
        self._profiles: tuple[np.ndarray, ...] | None = None  # reused window after window
        K = ctx.ctrl.K if ctx.ctrl.mode == "state" else np.zeros((m, n))
        A_X = p.A - p.B @ K
        nwp = ctx.nwp
        B_X = np.hstack([p.B, p.Bd] + ([ctx.Bw] if nwp else []))
        Cy0 = p.C - p.D @ K
        Dy0 = np.hstack([p.D, p.Dd, ctx.Dwp if ctx.Dwp is not None else np.zeros((q, nwp))])
        Cu = -K
        Du = np.hstack([np.eye(m), np.zeros((m, nd + nwp))])
        self.ne = m + nd + nwp
        self.foh = foh = ctx.hold == "foh" and not ctx.discrete
        noisy = ctx.Lv is not None
        self.Cy0, self.Dy0, self.Cu, self.Du = Cy0, Dy0, Cu, Du
        # ---- plant (closed with the state feedback): once for all runs
        dis = ctx.discretize(A_X, B_X)
        self.dis = dis
        self.WX = np.hstack([dis.B0, dis.B1]) if foh else dis.B0
        # ---- sensors: those with faults on the grid (touched), the profile rows (need:
        # the faulty sensors, or every sensor when noise enters them all)
        t = ctx.t
        self.touched = sorted(
            {f.sensor for fl in fault_lists for f in fl if first_active(f, t) is not None}
        )
        need = sorted({f.sensor for fl in fault_lists for f in fl})
        if noisy and not ctx.discrete:
            need = list(range(q))
        self.need = need
        self.row = {i: j for j, i in enumerate(need)}
        self.holds: list[dict[int, np.ndarray]] = [{} for _ in fault_lists]
        gens = [(k, g) for k, g in enumerate(ctx.view.generators) if g is not None]
        self.gens = gens
        # ---- sensors read through their own drive channels (module docstring)
        self.sens = (list(range(q)) if noisy else self.touched) if not ctx.discrete else []
        chan = self._gain_channels(chunk) if self.sens else []
        # ---- the bank's matrices: they depend on the models and the time grid only, so
        # repeated simulations of the same bank (short records, Monte-Carlo loops) reuse
        # them (the warnings and info entries of the set-up are replayed)
        # (the generators by their fingerprints from the bank's checks: balanced
        # matrices are a function of them)
        key = (
            _digest([A_X, B_X, Cy0, Dy0, Cu, Du, dis.Ad]),
            tuple(_generator_key(ctx, k, g) for k, g in gens),
            ctx.discrete,
            ctx.consistent,
            ctx.keep_states,
            ctx.hold,
            float(ctx.step),
            tuple(self.sens),
            tuple(chan),
        )
        self.key = key
        setup = _SETUPS.get(key)
        if setup is None:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                setup = _bank_setup(ctx, gens, A_X, B_X, Cy0, Dy0, Cu, Du, self.sens, chan)
            setup["warnings"] = [(w.message, w.category) for w in caught]
            if len(_SETUPS) >= _SETUP_ENTRIES:
                _SETUPS.clear()
            _SETUPS[key] = setup
        for message, category in setup["warnings"]:
            warnings.warn(message, category, stacklevel=4)
        for name, entries in setup["info"].items():
            ctx.info.setdefault(name, {}).update(entries)
        Pis = list(setup["Pis"])
        x0T = np.ascontiguousarray(x0.T)
        for (k, g), Pi in zip(gens, Pis, strict=True):
            w0 = Pi @ x0T if ctx.consistent and Pi is not None else np.zeros((g.order, 1))
            ctx.info.setdefault("w0", {})[k] = np.array(w0[:, 0])
        self.decoupled = decoupled = setup["decoupled"]
        self.chan = chan
        self.W_all = setup["W_all"]
        self.Fd = setup["Fd"]
        self.outs, self.dmats = setup["outs"], setup["dmats"]
        self.setup = setup
        ctx.info["channels"] = chan
        ctx.info["plant_state_decoupled"] = decoupled
        self.Pis = Pis
        self.use_pi = [ctx.consistent and Pi is not None for Pi in Pis]
        #: work arrays reused window after window (``None``: fresh arrays); with one, the
        #: readings of a returned :class:`Piece` are valid until the next :meth:`advance`
        self.workspace: Workspace | None = None
        #: ``alloc(shape, name)`` of the plant state, the healthy readings and the inputs
        #: of a :class:`Piece` (the caller's result arrays, or work arrays it copies from;
        #: ``None``: :func:`numpy.empty`)
        self.result_alloc: Any = None
        #: generators without an exact consistent start (they start at zero), warned of
        #: once a run starts from a non-zero state (from x0 = 0 zero is the consistent one)
        self._inexact = {
            k: setup["info"]["init_residual"][k]
            for k, state in setup["info"].get("initial_state", {}).items()
            if state == "zero"
        }
        self.restart(x0, runs)

    def restart(self, x0: np.ndarray, runs: int) -> None:
        """Start a new chunk of ``runs`` runs from the initial plant states ``x0``
        (R0, n) at the first sample (the matrices are kept: the same fault lists)."""
        ctx = self.ctx
        if self._inexact and np.any(x0):
            for k, residual in self._inexact.items():
                inexact_start(k, residual)
            self._inexact = {}
        x0T = np.ascontiguousarray(x0.T)
        per_run = (
            ctx.Lv is not None
            or ctx.Lw is not None
            or not self.shared
            or x0.shape[0] > 1
            or (ctx.d.ndim == 3 and ctx.d.shape[0] > 1)
        )
        self.R = R = int(runs) if per_run else 1
        # the carried states: plant (n, R0) and bank (sum of orders, R)
        self.x = x0T
        if self.decoupled:  # the state w~ = w - Pi x: zero at a consistent start
            nw = sum(g.order for _, g in self.gens)
            if all(self.use_pi):
                self.w = np.zeros((nw, R))
            else:
                Pi_all = np.vstack(self.Pis)
                self.w = np.broadcast_to(-(Pi_all @ x0T), (nw, R)).copy()
                i0 = 0
                for (_, g), use in zip(self.gens, self.use_pi, strict=True):
                    if use:
                        self.w[i0 : i0 + g.order] = 0.0
                    i0 += g.order
        else:
            ws = []
            for (_, g), Pi, use in zip(self.gens, self.Pis, self.use_pi, strict=True):
                w = Pi @ x0T if use else np.zeros((g.order, 1))
                ws.append(np.broadcast_to(w, (g.order, R)))
            self.w = np.vstack(ws)
        self.holds = [{} for _ in self.fault_lists]

    # ------------------------------------------------------------------ helpers
    def _gain_channels(self, chunk: int) -> list[int]:
        """Sensors whose interval gain ``delta`` differs from 1 somewhere on the grid
        (each gets an exact drive channel), found window by window."""
        ctx, N, q = self.ctx, self.ctx.N, self.ctx.plant.q
        # a bias fault leaves eta = 1: only the sensors of the other faults can have a gain
        cand = {f.sensor for fl in self.fault_lists for f in fl if not isinstance(f, BiasFault)}
        cand = sorted(cand & set(self.sens))
        if not cand:
            return []
        rows = [self.row[i] for i in cand]
        step = max(int(chunk), 2)
        holds: list[dict[int, np.ndarray]] = [{} for _ in self.fault_lists]
        out: set[int] = set()
        for s in range(0, max(N - 1, 1), step):
            e1 = min(s + step + 1, N)
            zero = np.zeros((1, q, e1 - s))
            eta, eta_l, _, _ = fault_profiles(
                self.fault_lists, ctx.t, zero, q=q, k0=s, k1=e1, holds=holds,
                sensors=self.need, y0_start=s, groups=self.groups,
            )  # fmt: skip
            eta, eta_l = eta[rows], eta_l[rows]  # (sensors, runs, L)
            delta = 0.5 * (eta[:, :, :-1] + eta_l[:, :, 1:]) if self.foh else eta[:, :, :-1]
            out.update(i for j, i in enumerate(cand) if np.any(delta[j] != 1))
        return sorted(out)

    def _profile(self, s: int, e1: int, y0n: np.ndarray) -> tuple[np.ndarray, ...]:
        """``eta, eta_left`` (rows, R|1, L) and ``lam, lam_left`` (rows, R|1, L) of the
        window ``s .. e1-1``, the held readings carried over."""
        t, q = self.ctx.t, self.ctx.plant.q
        if self.shared:
            prof = fault_profile(
                self.fault_lists[0],
                t,
                y0n.transpose(1, 0, 2),
                q=q,
                k0=s,
                k1=e1,
                holds=self.holds[0],
                sensors=self.need,
                y0_start=s,
            )
            return (
                prof.eta[:, None, :],
                prof.eta_left[:, None, :],
                prof.lam.transpose(1, 0, 2),
                prof.lam_left.transpose(1, 0, 2),
            )
        # one update per fault for the runs of one fault-list structure (a sweep of
        # sizes), run by run otherwise (geomfdi.simulation.profiles)
        self._profiles = fault_profiles(
            self.fault_lists,
            t,
            y0n.transpose(1, 0, 2),
            q=q,
            k0=s,
            k1=e1,
            holds=self.holds,
            sensors=self.need,
            y0_start=s,
            groups=self.groups,
            out=self._profiles,  # the previous window's arrays (used up by advance)
        )
        return self._profiles

    # ------------------------------------------------------------------ advance
    def advance(
        self,
        s: int,
        e1: int,
        v: np.ndarray | None,
        wp: np.ndarray | None,
        rows: np.ndarray,
    ) -> Piece:
        """Simulate the samples ``s .. e1-1`` from the carried states.

        Parameters
        ----------
        s, e1 : int
            Window; the next call starts at ``e1 - 1`` (the last sample of a window is
            the first of the next: a first-order hold needs the right end of the last
            interval), or ``e1 = N`` ends the record.
        v, wp : ndarray or None
            Measurement ``(q, R, L)`` and process ``(k, R, L)`` noise of the window.
        rows : ndarray, (R, n_rows, L)
            Receives the residual rows (vector residuals: the norm of the components).
        """
        ctx = self.ctx
        p = ctx.plant
        n, m, q = p.n, p.m, p.q
        L = e1 - s
        es = ctx.u_ext[:, s:e1]
        if ctx.d.ndim == 3:  # per-run disturbance samples (additive faults differ per run)
            e = np.empty((self.ne, max(ctx.d.shape[0], 1 if wp is None else wp.shape[1]), L))
            e[:m] = es[:, None, :]
            e[m : m + p.nd] = ctx.d[:, :, s:e1].transpose(1, 0, 2)
        elif wp is not None:
            e = np.empty((self.ne, wp.shape[1], L))
            e[:m] = es[:, None, :]
            e[m : m + p.nd] = ctx.d[:, None, s:e1]
        else:
            e = (np.vstack([es, ctx.d[:, s:e1]]) if p.nd else es)[:, None, :]
        if wp is not None:
            e[m + p.nd :] = wp
        foh = self.foh
        dX = [Drive(e), Drive(e, 1)] if foh else [Drive(e)]
        # the state only; the readings and inputs from it by two plain products (cheaper
        # than lifting them: fewer lifted outputs per state)
        alloc = self.result_alloc
        Rx = max(self.x.shape[1], e.shape[1])
        xd = None if alloc is None else alloc((n, Rx, L), "X")
        ((X,),) = run_recursion(
            [self.dis.Ad], self.WX, dX, self.x, [[np.eye(n)]], L, key=("plant", self.key),
            batch=False, out=[[xd]],
        )  # fmt: skip
        y0c = _affine(self.Cy0, X, self.Dy0, e, alloc, "y0c")
        u = _affine(self.Cu, X, self.Du, e, alloc, "u")
        self.x = np.ascontiguousarray(X[:, :, -1])
        work = self._work
        if v is not None:
            y0n = np.add(y0c, v, out=work("y0n", np.broadcast_shapes(y0c.shape, v.shape)))
        else:
            y0n = y0c
        # ---- sensor faults on the readings, vectorised (only the sensors they touch)
        eta, eta_l, lam, lam_l = self._profile(s, e1, y0n)
        row, touched = self.row, self.touched
        R = max(y0n.shape[1], eta.shape[1], lam.shape[1])
        if touched:
            y = work("y", (q, R, L))
            y[:] = y0n
            for i in touched:
                yi = np.multiply(eta[row[i]], y0n[i], out=y[i])
                yi += lam[row[i]]
        else:
            y = y0n
        # ---- drive signals of the generators, in the columns' order of W_all
        if ctx.discrete:
            drives = [Drive(y), Drive(u)]
        else:
            drives = [] if self.decoupled else [Drive(X)]
            drives.append(Drive(e))
            if foh:
                drives.append(Drive(e, 1))
            sens = self.sens
            if sens:
                # views, not copies, when the rows are consecutive (every sensor with noise)
                prow, sr = _rows([row[i] for i in sens]), _rows(sens)
                if foh:
                    delta = 0.5 * (eta[prow, :, :-1] + eta_l[prow, :, 1:])
                else:
                    delta = eta[prow, :, :-1]
                dyL = delta * y0c[sr, :, :-1]
                yL = y[sr, :, :-1]
                rhoL = np.subtract(
                    yL, dyL, out=work("rhoL", np.broadcast_shapes(yL.shape, dyL.shape))
                )
                drives.append(Drive(rhoL))
                if foh:
                    el, yR = eta_l[prow, :, 1:], y0n[sr, :, 1:]
                    rhoR = np.multiply(
                        el, yR, out=work("rhoR", np.broadcast_shapes(el.shape, yR.shape))
                    )
                    rhoR += lam_l[prow, :, 1:]
                    rhoR -= delta * y0c[sr, :, 1:]
                    drives.append(Drive(rhoR))
            for i in self.chan:
                scale = delta[sens.index(i)][None] - 1.0
                drives += [Drive(X, 0, scale), Drive(e, 0, scale)]
                if foh:
                    drives.append(Drive(e, 1, scale))
        gens = self.gens
        dests = []
        for k, g in gens:
            view = rows[:, k : k + 1].transpose(1, 0, 2) if g.n_outputs == 1 else None
            dests.append([view, None] if ctx.keep_states else [view])
        # compiled kernels: one run vectorised over the states, many runs over the runs
        # (geomfdi.simulation.compiled_single, compiled_recursion), else numpy
        res, self.w = run_recursion(
            self.Fd,
            self.W_all,
            drives,
            self.w,
            self.outs,
            L,
            direct=self._direct(X, y, y0c, u, e),
            out=dests,
            final=True,
            key=("bank", self.key),
        )
        vectors: list[np.ndarray | None] = [None] * len(ctx.view.generators)
        ws: list[np.ndarray | None] = [None] * len(ctx.view.generators)
        for (k, g), rk in zip(gens, res, strict=True):
            if g.n_outputs > 1:
                vectors[k] = rk[0]
                rows[:, k] = np.sqrt(np.sum(rk[0] * rk[0], axis=0))
            if ctx.keep_states:
                ws[k] = rk[1]
        return Piece(s, X, y, y0n, u, vectors, ws)

    def _direct(
        self, X: np.ndarray, y: np.ndarray, y0c: np.ndarray, u: np.ndarray, e: np.ndarray
    ) -> tuple[list[np.ndarray], list[list[np.ndarray | None]]]:
        """The generators' feedthrough signals and matrices: ``-H y + K u`` (and ``M Pi x``
        for decoupled states).  When the readings are the healthy ones (no sensor fault
        on the window, no noise) ``y = Cy0 x + Dy0 e`` and ``u = Cu x + Du e``, so the
        feedthrough is ``(-H Cy0 + K Cu + M Pi) x + (-H Dy0 + K Du) e``: two products
        instead of three, the matrices (kept with the set-up) formed once."""
        if y is not y0c:
            return ([y, u, X] if self.decoupled else [y, u], self.dmats)
        xe = self.setup.get("dmats_xe")
        if xe is None:
            q, m = self.ctx.plant.q, self.ctx.plant.m
            xe = []
            for ms in self.dmats:
                row = []
                for D in ms:
                    if D is None:
                        row.append(None)
                        continue
                    Dy, Du = D[:, :q], D[:, q : q + m]
                    DX = Dy @ self.Cy0 + Du @ self.Cu
                    if self.decoupled:
                        DX = DX + D[:, q + m :]
                    row.append(np.hstack([DX, Dy @ self.Dy0 + Du @ self.Du]))
                xe.append(row)
            self.setup["dmats_xe"] = xe
        return [X, e], xe

    def _work(self, name: str, shape: tuple[int, ...]) -> np.ndarray:
        """A float work array of the window (from :attr:`workspace` when set)."""
        if self.workspace is None:
            return np.empty(shape)
        return self.workspace.get(name, shape)


def _generator_key(ctx: Context, k: int, g: Any) -> bytes:
    """Fingerprint of generator ``k``'s matrices: the one of the bank's checks (of the
    bank's own matrices, which determine the balanced ones), else a digest of ``g``'s."""
    keys = ctx.view.keys
    if k < len(keys) and keys[k] is not None:
        return keys[k]
    return _digest([g.F, g.E, g.G, g.M, g.H, g.K])


def _affine(
    Cm: np.ndarray,
    X: np.ndarray,
    Dm: np.ndarray,
    e: np.ndarray,
    alloc: Any = None,
    name: str = "",
) -> np.ndarray:
    """``Cm X + Dm e`` for state-major ``X`` (n, R, L) and ``e`` (ne, R | 1, L), in an
    array from ``alloc(shape, name)`` when given."""
    n, R, L = X.shape
    ne, Re, _ = e.shape
    p = Cm.shape[0]

    def new(shape: tuple[int, ...]) -> np.ndarray:
        return np.empty(shape) if alloc is None else alloc(shape, name)

    if Re >= R and not np.any(Cm):  # no state term (the input of an open loop)
        out = new((p, Re, L))
        if p <= ne and np.array_equal(Dm, np.eye(p, ne)):  # the leading rows of e
            out[...] = e[:p]
        else:
            np.matmul(Dm, e.reshape(ne, Re * L), out=out.reshape(p, Re * L))
        return out
    out = new((p, R, L))
    np.matmul(Cm, X.reshape(n, R * L), out=out.reshape(p, R * L))
    if Dm.size and np.any(Dm):
        out += (Dm @ e.reshape(ne, Re * L)).reshape(Dm.shape[0], Re, L)
    return out


def _rows(idx: list[int]) -> slice | list[int]:
    """Row indices as a slice when they are consecutive (a view instead of a copy)."""
    if idx and idx == list(range(idx[0], idx[0] + len(idx))):
        return slice(idx[0], idx[0] + len(idx))
    return idx


_SETUPS: dict[Any, dict[str, Any]] = {}
_SETUP_ENTRIES = 32


def _bank_setup(
    ctx: Context,
    gens: list[tuple[int, Any]],
    A_X: np.ndarray,
    B_X: np.ndarray,
    Cy0: np.ndarray,
    Dy0: np.ndarray,
    Cu: np.ndarray,
    Du: np.ndarray,
    sens: list[int],
    chan: list[int],
) -> dict[str, Any]:
    """The bank's part of :class:`OpenLoopEngine`, independent of the initial state.

    ``Pi`` per generator (``F Pi - Pi A_X = -Sigma``: the consistent start ``w = Pi x``
    and, when every generator has an exact one, the change of state ``w~ = w - Pi x``
    that removes the plant state from the generators' equations), the discretised
    drive matrix ``W_all`` of the bank in the order of the drive signals formed by
    :meth:`OpenLoopEngine.advance`, the generators' transition blocks ``Fd``, their
    outputs and feedthroughs; ``info`` holds the start-up diagnostics per generator.
    """
    p = ctx.plant
    n, m, q = p.n, p.m, p.q
    ne = m + p.nd + ctx.nwp
    foh = ctx.hold == "foh" and not ctx.discrete
    info: dict[str, dict[int, Any]] = {}
    offs = np.cumsum([0] + [g.order for _, g in gens])
    Sig_all = np.vstack([-g.E @ Cy0 + g.G @ Cu for _, g in gens])
    E_all = np.vstack([g.E for _, g in gens])
    Pis = joint_sylvester([g.F for _, g in gens], A_X, Sig_all)
    for j, ((k, g), o0, o1) in enumerate(zip(gens, offs[:-1], offs[1:], strict=True)):
        if ctx.consistent:
            N_out = -g.H @ Cy0 + g.K @ Cu
            Pis[j] = consistent_start(
                k, g.F, A_X, Sig_all[o0:o1], g.M, N_out, info, Pis[j], warn=False
            )  # the engine warns of an inexact start from a non-zero state
    known = info.get("init_residual", {}) if ctx.consistent else {}
    decoupled = not ctx.discrete and all(
        Pi is not None
        and (
            known[k]
            if k in known
            else start_error(g.F, A_X, Sig_all[o0:o1], g.M, -g.H @ Cy0 + g.K @ Cu, Pi)
        )
        <= EXACT_TOL
        for Pi, (k, g), o0, o1 in zip(Pis, gens, offs[:-1], offs[1:], strict=True)
    )
    if ctx.discrete:
        # exact: w[k+1] = F w[k] - E y[k] + G u[k] with the measured samples
        W_all = np.hstack([-E_all, np.vstack([g.G for _, g in gens])])
        Fd = {k: g.F for k, g in gens}
    else:
        # y_i = delta_i y0c_i + rho_i over each interval (module docstring)
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
            r0, cols = 0, []
        else:  # one matrix exponential of the plant and the whole bank
            dc = ctx.discretize(Ac, np.block([[B_X, np.zeros((n, q))], [Gam_all, -E_all]]))
            r0, cols = n, [dc.Ad[n:, :n]]
        cols.append(dc.B0[r0:, :ne])
        if foh:
            cols.append(dc.B1[r0:, :ne])
        if sens:
            cols.append(dc.B0[r0:, [ne + i for i in sens]])
            if foh:
                cols.append(dc.B1[r0:, [ne + i for i in sens]])
        for i in chan:  # exact coupling of a gain-faulty sensor: one more exponential each
            Aci = Ac.copy()
            Aci[n:, :n] = -E_all[:, i : i + 1] @ Cy0[i : i + 1]
            Bci = np.vstack([B_X, -E_all[:, i : i + 1] @ Dy0[i : i + 1]])
            di = ctx.discretize(Aci, Bci)
            cols += [di.Ad[n:, :n], di.B0[n:]] + ([di.B1[n:]] if foh else [])
        W_all = np.hstack(cols)
        Fd = {
            k: dc.Ad[r0 + o0 : r0 + o1, r0 + o0 : r0 + o1]
            for (k, _), o0, o1 in zip(gens, offs[:-1], offs[1:], strict=True)
        }
    # residual rows are written in place, with the direct feedthrough -H y + K u (and
    # M Pi x, w = w~ + Pi x, for decoupled states) added chunk by chunk
    outs, dmats = [], []
    for (_, g), Pi in zip(gens, Pis, strict=True):
        Dm = np.hstack([-g.H, g.K] + ([g.M @ Pi] if decoupled else []))
        if ctx.keep_states:
            Dw = np.hstack([np.zeros((g.order, q + m)), Pi]) if decoupled else None
            outs.append([g.M, np.eye(g.order)])
            dmats.append([Dm, Dw])
        else:
            outs.append([g.M])
            dmats.append([Dm])
    return {
        "Pis": Pis,
        "decoupled": decoupled,
        "W_all": W_all,
        "Fd": [Fd[k] for k, _ in gens],
        "outs": outs,
        "dmats": dmats,
        "info": info,
    }
