"""Closed loops with faults inside the loop, simulated piecewise LTI.

Output feedback sees the faulty readings; under state or output feedback a gain or stuck
actuator fault sits between the controller's (commanded) input ``u`` and the plant, the
applied input being ``u^a = Gamma u + lambda^a`` (:func:`geomfdi.simulation.input_faults.
actuator_profile`), while the residual generators read the commanded ``u``.  With the
sensor gains ``Delta`` and the actuator gains ``Gamma`` piecewise constant between fault
events, the loop is a switched linear system: the horizon is cut at every switching
instant and each segment (plant, controller, every generator) is one LTI system for the
segment's gains, simulated exactly with the loop-free recursion, the state carried over
from segment to segment.  Segments with a time-varying gain are stepped sample by sample
(gain frozen over the interval, ``O(dt^2)``).  The record is also cut at the
boundaries of the time chunks of the simulation (:class:`OutputFeedbackEngine`), the
loop state carried over: memory is proportional to the chunk.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from geomfdi.errors import GeomFDIError
from geomfdi.simulation.context import (
    Context,
    Piece,
    RawRuns,
    batched_matmul,
    progress_bar,
)
from geomfdi.simulation.discretization import Discretization
from geomfdi.simulation.initial_state import consistent_start
from geomfdi.simulation.input_faults import InputFaultSignal, actuator_profile
from geomfdi.simulation.lifting import linear_recursion
from geomfdi.simulation.signals import (
    FaultProfile,
    SensorFaultSignal,
    activity_span,
    fault_profile,
)


# =========================================================== output feedback
class LoopModel:
    """Closed loop plant + controller + generators for sensor gains ``Delta`` and actuator
    gains ``Gamma`` (both diagonal).

    Commanded input ``u = u_ext - K x + Cc xc + Dc y_m`` (state feedback: ``K``; output
    feedback: ``Cc, Dc`` on the measured ``y_m = Delta (y0 + v) + lambda``), applied input
    ``u^a = Gamma u + lambda^a``, ``x' = A x + B u^a + Bd d + Bw w``,
    ``y0 = C x + D u^a + Dd d``.  Exogenous input ``e = [u_ext; d; w; v; lambda;
    lambda^a]``; states ``[x; xc; w_1; ...]``; outputs ``[y (measured); u (commanded);
    y0c (clean healthy reading); r_1; ...]``.
    """

    def __init__(self, ctx: Context) -> None:
        self.ctx = ctx
        p, c = ctx.plant, ctx.ctrl
        self.n, self.nc, self.m, self.q, self.nd = p.n, c.nc, p.m, p.q, p.nd
        self.nwp = ctx.nwp
        self.ne = 2 * self.m + self.nd + self.nwp + 2 * self.q
        self.gens = [(k, g) for k, g in enumerate(ctx.view.generators) if g is not None]
        self.nX = self.n + self.nc
        self.nS = self.nX + sum(g.order for _, g in self.gens)
        self.nr = [g.n_outputs for _, g in self.gens]
        m, q, nc = self.m, self.q, self.nc
        self.K = c.K if c.mode == "state" else np.zeros((m, self.n))
        self.Ac = c.Ac if c.Ac is not None else np.zeros((0, 0))
        self.Bc = c.Bc if c.Bc is not None else np.zeros((nc, q))
        self.Cc = c.Cc if c.Cc is not None else np.zeros((m, nc))
        self.Dc = c.Dc if c.Dc is not None else np.zeros((m, q))
        self._cache: dict[bytes, Any] = {}

    def loop(self, delta: np.ndarray, gamma: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """Loop matrices for sensor gains ``delta`` (q,) and actuator gains ``gamma`` (m,)."""
        p = self.ctx.plant
        n, nc, m, q, nd, nwp = self.n, self.nc, self.m, self.q, self.nd, self.nwp
        Dc, Cc, Ac, Bc = self.Dc, self.Cc, self.Ac, self.Bc
        Dl = np.diag(delta)
        Gm = np.eye(m) if gamma is None else np.diag(gamma)
        Lm = np.eye(m) - Dc @ Dl @ p.D @ Gm
        if np.linalg.cond(Lm) > 1e12:
            raise GeomFDIError(
                "controller: the algebraic loop I - Dc diag(eta) D diag(gamma) is singular; "
                "the feedback interconnection is ill-posed",
                argument="controller",
            )
        Li = np.linalg.inv(Lm)
        Bw = self.ctx.Bw if nwp else np.zeros((n, 0))
        Dwp = self.ctx.Dwp if self.ctx.Dwp is not None else np.zeros((q, nwp))
        # commanded input u = Ux X + Ue e
        Ux = Li @ np.hstack([Dc @ Dl @ p.C - self.K, Cc])
        Ue = Li @ np.hstack([np.eye(m), Dc @ Dl @ p.Dd, Dc @ Dl @ Dwp, Dc @ Dl, Dc, Dc @ Dl @ p.D])
        # applied input u^a = Gamma u + lambda^a
        Uax = Gm @ Ux
        Uae = Gm @ Ue
        Uae[:, -m:] += np.eye(m)
        Y0x = np.hstack([p.C, np.zeros((q, nc))]) + p.D @ Uax
        Y0e = p.D @ Uae + np.hstack([np.zeros((q, m)), p.Dd, Dwp, np.zeros((q, 2 * q + m))])
        Ymx = Dl @ Y0x
        Yme = Dl @ Y0e + np.hstack([np.zeros((q, m + nd + nwp)), Dl, np.eye(q), np.zeros((q, m))])
        AX = np.block([[p.A, np.zeros((n, nc))], [np.zeros((nc, n)), Ac]])
        AX = (
            AX + np.vstack([p.B, np.zeros((nc, m))]) @ Uax + np.vstack([np.zeros((n, q)), Bc]) @ Ymx
        )
        BX = np.vstack(
            [
                np.hstack([np.zeros((n, m)), p.Bd, Bw, np.zeros((n, 2 * q + m))]),
                np.zeros((nc, self.ne)),
            ]
        )
        BX = (
            BX + np.vstack([p.B, np.zeros((nc, m))]) @ Uae + np.vstack([np.zeros((n, q)), Bc]) @ Yme
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

    def composite(
        self, delta: np.ndarray, gamma: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(A_S, B_S, C_S, D_S)`` of the full composite for gains ``delta``, ``gamma``."""
        key = _key(delta, gamma)
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        L = self.loop(delta, gamma)
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

    def discretized(self, delta: np.ndarray, gamma: np.ndarray | None = None) -> Discretization:
        key = b"d" + _key(delta, gamma)
        hit = self._cache.get(key)
        if hit is None:
            A, B, _, _ = self.composite(delta, gamma)
            hit = self.ctx.discretize(A, B)
            if len(self._cache) < 4096:
                self._cache[key] = hit
        return hit


def _key(delta: np.ndarray, gamma: np.ndarray | None) -> bytes:
    d = np.asarray(delta, dtype=float).tobytes()
    return d if gamma is None else d + b"|" + np.asarray(gamma, dtype=float).tobytes()


def _breakpoints(faults: Sequence[Any], t: np.ndarray) -> list[int]:
    """Sample indices where some fault switches on or off, with 0 and ``N``."""
    N = t.shape[0]
    idx = {0, N}
    for f in faults:
        span = activity_span(f, t)
        if span is not None:
            idx.update(k for k in span if 0 < k < N)
    return sorted(idx)


class OutputFeedbackEngine:
    """Output feedback over a record, advanced one time chunk at a time.

    The horizon is cut at every fault switching instant and at the chunk boundaries;
    each piece (plant, controller, every generator) is one LTI system for its sensor
    gains, simulated exactly with the loop-free recursion (pieces with a time-varying
    gain are stepped sample by sample, :func:`_step_segment`).  The loop state, the held
    readings of stuck sensors, the held inputs of stuck actuators, the healthy reading
    and the commanded input at the chunk's last sample (a held reading or input starting
    there needs it) are carried from one chunk to the next.

    Parameters
    ----------
    ctx : Context
    x0 : ndarray, (R0, n)
    xc0 : ndarray, (1, nc)
    runs : int
        Runs (1 broadcasts when no run differs).
    faults : list of SensorFaultSignal
    actuators : sequence of ActuatorGainFault / ActuatorStuckFault
        Faults between the commanded and the applied input (state or output feedback).
    """

    def __init__(
        self,
        ctx: Context,
        x0: np.ndarray,
        xc0: np.ndarray,
        runs: int,
        faults: list[SensorFaultSignal],
        actuators: Sequence[InputFaultSignal] = (),
    ) -> None:
        self.ctx, self.faults, self.actuators = ctx, faults, list(actuators)
        self.model = model = LoopModel(ctx)
        p = ctx.plant
        n, nc, q, nX, nS = p.n, model.nc, p.q, model.nX, model.nS
        R = max(x0.shape[0], runs)
        X0 = np.hstack([np.broadcast_to(x0, (R, n)), np.broadcast_to(xc0, (R, nc))])
        # consistent generator states for the healthy loop (Delta = I, Gamma = I)
        L0 = model.loop(np.ones(q))
        S0 = np.zeros((R, nS))
        S0[:, :nX] = X0
        i = nX
        for k, g in model.gens:
            nw = g.order
            if ctx.consistent:
                Sig = -g.E @ L0["Ymx"] + g.G @ L0["Ux"]
                Nout = -g.H @ L0["Ymx"] + g.K @ L0["Ux"]
                Pi = consistent_start(  # from X0 = 0 the zero start is consistent
                    k, g.F, L0["AX"], Sig, g.M, Nout, ctx.info, warn=bool(np.any(X0))
                )
                if Pi is not None:
                    S0[:, i : i + nw] = X0 @ Pi.T
            ctx.info.setdefault("w0", {})[k] = np.array(S0[0, i : i + nw])
            i += nw
        self.R, self.S = R, S0
        self.holds: dict[int, np.ndarray] = {}
        self.act_holds: dict[int, np.ndarray] = {}
        self.y0_last: np.ndarray | None = None  # healthy reading at the carried sample
        self.u_last: np.ndarray | None = None  # commanded input there (left limit)
        every = [*faults, *self.actuators]
        self.bps = _breakpoints(every, ctx.t)
        self.spans = [activity_span(f, ctx.t) for f in every]
        self.bar = progress_bar(
            ctx.progress and any(f.time_varying_gain for f in every), ctx.N, "stepping"
        )
        ctx.info["segments"] = 0
        ctx.info["stepped_samples"] = 0

    def advance(self, s: int, e1: int, v: np.ndarray | None, wp: np.ndarray | None) -> RawRuns:
        """Simulate samples ``s .. e1-1`` (``v``, ``wp``: (R, q|k, L) noise samples).

        Returns the chunk's arrays ``(R, k, L)``; when ``e1 < N`` the last sample is the
        first of the next chunk, computed (and returned) there.
        """
        ctx, model = self.ctx, self.model
        p = ctx.plant
        n, m, q, nX = p.n, p.m, p.q, model.nX
        t, N, R = ctx.t, ctx.N, self.R
        L = e1 - s
        # exogenous samples (lambda and lambda^a filled per segment)
        e = np.zeros((R, model.ne, L))
        e[:, :m] = ctx.u_ext[:, s:e1]
        e[:, m : m + p.nd] = ctx.d[..., s:e1]
        o = m + p.nd
        if wp is not None:
            e[:, o : o + ctx.nwp] = wp
        o += ctx.nwp
        if v is not None:
            e[:, o : o + q] = v
        lam_slot = slice(o + q, o + 2 * q)
        act_slot = slice(o + 2 * q, o + 2 * q + m)
        nout = 2 * q + m + sum(model.nr)
        states = np.zeros((R, model.nS, L))
        outs = np.zeros((R, nout, L))
        y0n = np.zeros((R, q, L))  # noisy healthy readings (filled progressively, for holds)
        if self.y0_last is None:
            _, _, C1, D1 = model.composite(np.ones(q))
            first = C1 @ self.S[..., None] + D1 @ e[:, :, :1]
            y0n[:, :, 0] = first[:, q + m : 2 * q + m, 0] + (v[:, :, 0] if v is not None else 0.0)
            u_start = first[:, q : q + m, 0]
        else:
            y0n[:, :, 0] = self.y0_last
            u_start = self.u_last
        end = N if e1 >= N else e1 - 1
        cuts = [s] + [k for k in self.bps if s < k < end] + [end]
        S = self.S
        for a, b in zip(cuts[:-1], cuts[1:], strict=True):
            kend = min(b, N - 1)
            Lseg = kend - a + 1
            prof = fault_profile(
                self.faults,
                t,
                y0n,
                q=q,
                k0=a,
                k1=kend + 1,
                holds=self.holds,
                last_left=b < N,
                y0_start=s,
            )
            aprof = actuator_profile(
                self.actuators,
                t,
                m=m,
                k0=a,
                k1=kend + 1,
                u_start=u_start,
                holds=self.act_holds,
                last_left=b < N,
            )
            for slot, pr in ((lam_slot, prof), (act_slot, aprof)):
                lam = np.broadcast_to(pr.lam, (R, pr.lam.shape[1], Lseg)).copy()
                if b < N:  # right end of the segment: left limit (faults of this segment)
                    lam[..., -1] = pr.lam_left[..., -1]
                e[:, slot, a - s : kend + 1 - s] = lam
            eseg = e[:, :, a - s : kend + 1 - s]
            active = [
                f
                for f, sp in zip([*self.faults, *self.actuators], self.spans, strict=True)
                if sp is not None and sp[0] <= a < sp[1]
            ]
            if any(f.time_varying_gain for f in active):
                ctx.info["stepped_samples"] += Lseg - 1
                seg_states, seg_out = _step_segment(
                    ctx, model, S, eseg, prof, aprof, b < N, self.bar
                )
            else:
                delta, gamma = prof.eta[:, 0], aprof.eta[:, 0]
                dis = model.discretized(delta, gamma)
                _, _, C, D = model.composite(delta, gamma)
                seg_states = linear_recursion(dis.Ad, dis.forcing(eseg), S)
                seg_out = batched_matmul(C, seg_states) + batched_matmul(D, eseg)
                if self.bar is not None:
                    self.bar.update(Lseg - 1)
            stop = Lseg if b >= N else Lseg - 1
            states[:, :, a - s : a - s + stop] = seg_states[:, :, :stop]
            outs[:, :, a - s : a - s + stop] = seg_out[:, :, :stop]
            y0h = seg_out[:, q + m : 2 * q + m]
            if v is not None:
                y0h = y0h + v[:, :, a - s : kend + 1 - s]
            y0n[:, :, a - s : kend + 1 - s] = y0h
            u_start = seg_out[:, q : q + m, -1]
            S = seg_states[:, :, -1]
            if b in self.bps:
                ctx.info["segments"] += 1
        self.S = S
        self.y0_last = np.array(y0n[:, :, -1])
        self.u_last = np.array(u_start)
        if e1 >= N and self.bar is not None:
            self.bar.close()
        # the healthy readings recorded at segment ends, recomputed with the final config
        y0n = outs[:, q + m : 2 * q + m] + (v if v is not None else 0.0)
        r_vectors: list[np.ndarray | None] = [None] * len(ctx.view.generators)
        ws: list[np.ndarray | None] = [None] * len(ctx.view.generators)
        i, o = nX, 2 * q + m
        for k, g in model.gens:
            ws[k] = states[:, i : i + g.order]
            r_vectors[k] = outs[:, o : o + g.n_outputs]
            i += g.order
            o += g.n_outputs
        return RawRuns(
            states[:, :n],
            states[:, n:nX],
            outs[:, :q],
            y0n,
            outs[:, q : q + m],
            r_vectors,
            ws,
        )


def _step_segment(
    ctx: Context,
    model: LoopModel,
    S: np.ndarray,
    eseg: np.ndarray,
    prof: FaultProfile,
    aprof: FaultProfile,
    left_end: bool,
    bar: Any,
) -> tuple[np.ndarray, np.ndarray]:
    """Time-varying gains in the loop: one exact step per sample, gains frozen."""
    R, nS = S.shape
    L = eseg.shape[-1]
    states = np.empty((R, nS, L))
    states[:, :, 0] = S
    foh = not ctx.discrete and ctx.hold == "foh"
    for j in range(L - 1):
        if foh:
            delta = 0.5 * (prof.eta[:, j] + prof.eta_left[:, j + 1])
            gamma = 0.5 * (aprof.eta[:, j] + aprof.eta_left[:, j + 1])
        else:
            delta, gamma = prof.eta[:, j], aprof.eta[:, j]
        dis = model.discretized(delta, gamma)
        nxt = dis.Ad @ states[:, :, j].T + dis.B0 @ eseg[:, :, j].T
        if foh:
            nxt = nxt + dis.B1 @ eseg[:, :, j + 1].T
        states[:, :, j + 1] = nxt.T
        if bar is not None:
            bar.update(1)
    nout = model.composite(prof.eta[:, 0], aprof.eta[:, 0])[2].shape[0]
    out = np.empty((R, nout, L))
    for j in range(L):
        last = left_end and j == L - 1
        eta = prof.eta_left[:, j] if last else prof.eta[:, j]
        gam = aprof.eta_left[:, j] if last else aprof.eta[:, j]
        _, _, C, D = model.composite(eta, gam)
        out[:, :, j] = states[:, :, j] @ C.T + eseg[:, :, j] @ D.T
    return states, out


class FeedbackRuns:
    """The runs of a chunk in a closed loop with faults inside it (output feedback, or
    actuator gain/stuck faults under state feedback), with the interface of
    :class:`~geomfdi.simulation.open_loop.OpenLoopEngine` (``R``, :meth:`advance`).

    Runs sharing one fault list are simulated together (one
    :class:`OutputFeedbackEngine`); with one list per run the loop differs between runs,
    which are then simulated one at a time.  ``actuator_lists``: the actuator gain and
    stuck faults of each list (:func:`split_actuator_faults`).
    """

    def __init__(
        self,
        ctx: Context,
        x0: np.ndarray,
        xc0: np.ndarray,
        fault_lists: list[list[SensorFaultSignal]],
        shared: bool,
        runs: int,
        contexts: list[Context] | None = None,
        actuator_lists: list[list[InputFaultSignal]] | None = None,
    ) -> None:
        noisy = ctx.Lv is not None or ctx.Lw is not None
        acts = actuator_lists or [[] for _ in fault_lists]
        if shared:
            R = runs if noisy or x0.shape[0] > 1 else 1
            self.engines = [OutputFeedbackEngine(ctx, x0, xc0, R, fault_lists[0], acts[0])]
        else:
            ctxs = contexts or [ctx] * len(fault_lists)
            self.engines = [
                OutputFeedbackEngine(c, x0[r : r + 1] if x0.shape[0] > 1 else x0, xc0, 1, fl, ac)
                for r, (c, fl, ac) in enumerate(zip(ctxs, fault_lists, acts, strict=True))
            ]
        self.ctx = ctx
        self.R = sum(eng.R for eng in self.engines)

    def advance(
        self, s: int, e1: int, v: np.ndarray | None, wp: np.ndarray | None, rows: np.ndarray
    ) -> Piece:
        """Samples ``s .. e1-1``; ``v``, ``wp`` (q|k, R, L); the residual rows written into
        ``rows`` (R, n_rows, L)."""
        parts = []
        r0 = 0
        for eng in self.engines:
            sl = slice(r0, r0 + eng.R) if len(self.engines) > 1 else slice(None)
            vv = None if v is None else v[:, sl].transpose(1, 0, 2)
            ww = None if wp is None else wp[:, sl].transpose(1, 0, 2)
            parts.append(eng.advance(s, e1, vv, ww))
            r0 += eng.R
        cat = (lambda xs: xs[0]) if len(parts) == 1 else (lambda xs: np.concatenate(xs))
        sm = lambda a: a.transpose(1, 0, 2)  # noqa: E731  state-major views
        nres = len(self.ctx.view.generators)
        vectors: list[np.ndarray | None] = [None] * nres
        ws: list[np.ndarray | None] = [None] * nres
        for k in range(nres):
            if parts[0].r_vectors[k] is None:
                continue
            rv = cat([pt.r_vectors[k] for pt in parts])
            if rv.shape[1] == 1:
                rows[:, k] = rv[:, 0]
            else:
                rows[:, k] = np.sqrt(np.sum(rv * rv, axis=1))
                vectors[k] = sm(rv)
            ws[k] = sm(cat([pt.w[k] for pt in parts]))
        return Piece(
            s,
            sm(cat([pt.x for pt in parts])),
            sm(cat([pt.y for pt in parts])),
            sm(cat([pt.y_healthy for pt in parts])),
            sm(cat([pt.u for pt in parts])),
            vectors,
            ws,
            sm(cat([pt.xc for pt in parts])),
        )


def split_actuator_faults(schedule: Any) -> tuple[Any, list[InputFaultSignal]]:
    """``(schedule without them, the gain/stuck actuator faults)`` of a fault schedule.

    Under feedback these faults sit inside the loop (:class:`OutputFeedbackEngine`); the
    other additive faults stay exogenous input channels.
    """
    from dataclasses import replace

    inside = [f for f in schedule.inputs if f.needs_input]
    if not inside:
        return schedule, []
    rest = [f for f in schedule.inputs if not f.needs_input]
    return replace(schedule, inputs=rest), inside
