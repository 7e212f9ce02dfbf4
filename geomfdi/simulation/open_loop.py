"""Open loop and state feedback: the plant once for all runs, the bank driven exactly.

The plant does not see the sensor faults, so its state is simulated once; each bank
generator is driven over each sampling interval by the exact discretisation of the
composite ``[plant; generator]`` (or, when the generators decouple, in the coordinates
``w~ = w - Pi x``).  See :mod:`geomfdi.simulation.simulate` for the model.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from geomfdi.simulation.context import (
    Context,
    RawRuns,
)
from geomfdi.simulation.initial_state import (
    EXACT_TOL,
    consistent_start,
    joint_sylvester,
    start_error,
)
from geomfdi.simulation.lifting import Drive, block_recursion
from geomfdi.simulation.signals import SensorFaultSignal, fault_profile


# ===================================================== open loop / state fb
def run_open_loop(
    ctx: Context,
    x0: np.ndarray,
    v: np.ndarray | None,
    wp: np.ndarray | None,
    fault_lists: list[list[SensorFaultSignal]],
    shared: bool,
) -> RawRuns:
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
    if ctx.d.ndim == 3:  # per-run disturbance samples (additive faults differ per run)
        es = np.empty((m + nd, ctx.d.shape[0], N))
        es[:m] = ctx.u_ext[:, None, :]
        es[m:] = ctx.d.transpose(1, 0, 2)
    else:
        es = (np.vstack([ctx.u_ext, ctx.d]) if ctx.d.shape[0] else ctx.u_ext)[:, None, :]
    if wp is not None:
        Re = max(es.shape[1], wp.shape[0])
        e = np.empty((es.shape[0] + nwp, Re, N))
        e[: es.shape[0]] = es
        e[es.shape[0] :] = wp.transpose(1, 0, 2)
    else:
        e = es
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
    Pis = joint_sylvester([g.F for _, g in gens], A_X, Sig_all)
    w0s = {}
    for j, ((k, g), o0, o1) in enumerate(zip(gens, offs[:-1], offs[1:], strict=True)):
        w0s[k] = np.zeros((g.order, 1))
        if ctx.consistent:
            N_out = -g.H @ Cy0 + g.K @ Cu
            Pis[j] = consistent_start(k, g.F, A_X, Sig_all[o0:o1], g.M, N_out, ctx.info, Pis[j])
            if Pis[j] is not None:
                w0s[k] = Pis[j] @ x0T
        ctx.info.setdefault("w0", {})[k] = np.array(w0s[k][:, 0])
    known = ctx.info.get("init_residual", {}) if ctx.consistent else {}
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
    return RawRuns(tr(X), None, tr(y), tr(y0n), tr(u), r_vectors, ws, rows)
