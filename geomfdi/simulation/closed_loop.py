"""Output feedback: the loop sees the faulty readings, simulated piecewise LTI.

The horizon is cut at every fault switching instant; each segment (plant, controller,
every generator) is one LTI system for the segment's sensor gains, simulated exactly
with the loop-free recursion.  Segments with a time-varying gain are stepped sample by
sample (gain frozen over the interval, ``O(dt^2)``).  The record is also cut at the
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
from geomfdi.simulation.lifting import linear_recursion
from geomfdi.simulation.signals import SensorFaultSignal, activity_span, fault_profile


# =========================================================== output feedback
class LoopModel:
    """Closed loop plant + controller + generators for a diagonal sensor gain ``Delta``.

    Exogenous input ``e = [u_ext; d; w; v; lambda]``; states ``[x; xc; w_1; ...]``;
    outputs ``[y (measured); u; y0c (clean healthy reading); r_1; ...]``.
    """

    def __init__(self, ctx: Context) -> None:
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
    readings of stuck sensors and the healthy reading at the chunk's last sample (a held
    reading starting there needs it) are carried from one chunk to the next.

    Parameters
    ----------
    ctx : Context
    x0 : ndarray, (R0, n)
    xc0 : ndarray, (1, nc)
    runs : int
        Runs (1 broadcasts when no run differs).
    faults : list of SensorFaultSignal
    """

    def __init__(
        self,
        ctx: Context,
        x0: np.ndarray,
        xc0: np.ndarray,
        runs: int,
        faults: list[SensorFaultSignal],
    ) -> None:
        self.ctx, self.faults = ctx, faults
        self.model = model = LoopModel(ctx)
        p = ctx.plant
        n, nc, q, nX, nS = p.n, model.nc, p.q, model.nX, model.nS
        R = max(x0.shape[0], runs)
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
                Pi = consistent_start(k, g.F, L0["AX"], Sig, g.M, Nout, ctx.info)
                if Pi is not None:
                    S0[:, i : i + nw] = X0 @ Pi.T
            ctx.info.setdefault("w0", {})[k] = np.array(S0[0, i : i + nw])
            i += nw
        self.R, self.S = R, S0
        self.holds: dict[int, np.ndarray] = {}
        self.y0_last: np.ndarray | None = None  # healthy reading at the carried sample
        self.bps = _breakpoints(faults, ctx.t)
        self.spans = [activity_span(f, ctx.t) for f in faults]
        self.bar = progress_bar(
            ctx.progress and any(f.time_varying_gain for f in faults), ctx.N, "stepping"
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
        # exogenous samples (lambda filled per segment)
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
        nout = 2 * q + m + sum(model.nr)
        states = np.zeros((R, model.nS, L))
        outs = np.zeros((R, nout, L))
        y0n = np.zeros((R, q, L))  # noisy healthy readings (filled progressively, for holds)
        if self.y0_last is None:
            _, _, C1, D1 = model.composite(np.ones(q))
            first = C1 @ self.S[..., None] + D1 @ e[:, :, :1]
            y0n[:, :, 0] = first[:, q + m : 2 * q + m, 0] + (v[:, :, 0] if v is not None else 0.0)
        else:
            y0n[:, :, 0] = self.y0_last
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
            lam = np.broadcast_to(prof.lam, (R, q, Lseg)).copy()
            if b < N:  # right end of the segment: left limit (faults of this segment)
                lam[..., -1] = prof.lam_left[..., -1]
            e[:, lam_slot, a - s : kend + 1 - s] = lam
            eseg = e[:, :, a - s : kend + 1 - s]
            active = [
                f
                for f, sp in zip(self.faults, self.spans, strict=True)
                if sp is not None and sp[0] <= a < sp[1]
            ]
            if any(f.time_varying_gain for f in active):
                ctx.info["stepped_samples"] += Lseg - 1
                seg_states, seg_out = _step_segment(ctx, model, S, eseg, prof, b < N, self.bar)
            else:
                delta = prof.eta[:, 0]
                dis = model.discretized(delta)
                _, _, C, D = model.composite(delta)
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
            S = seg_states[:, :, -1]
            if b in self.bps:
                ctx.info["segments"] += 1
        self.S = S
        self.y0_last = np.array(y0n[:, :, -1])
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


class FeedbackRuns:
    """The runs of a chunk under output feedback, with the interface of
    :class:`~geomfdi.simulation.open_loop.OpenLoopEngine` (``R``, :meth:`advance`).

    Runs sharing one fault list are simulated together (one
    :class:`OutputFeedbackEngine`); with one list per run the loop differs between runs,
    which are then simulated one at a time.
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
    ) -> None:
        noisy = ctx.Lv is not None or ctx.Lw is not None
        if shared:
            R = runs if noisy or x0.shape[0] > 1 else 1
            self.engines = [OutputFeedbackEngine(ctx, x0, xc0, R, fault_lists[0])]
        else:
            ctxs = contexts or [ctx] * len(fault_lists)
            self.engines = [
                OutputFeedbackEngine(c, x0[r : r + 1] if x0.shape[0] > 1 else x0, xc0, 1, fl)
                for r, (c, fl) in enumerate(zip(ctxs, fault_lists, strict=True))
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
