"""Least-order synthesis: orders against an independent reference, success, cost.

Table 1: total order of the delivered rows against the least order found by an
independent brute-force parity-space search on the physical model (numpy only), on
random problems (n ≤ 8, continuous and discrete, disturbances, sensor / actuator /
general faults, random structure rows).  Goal: ratio 1.00.

Table 2: success rate (rows delivered with leakage angle < 1e-9 and a stable generator,
over rows requested; every row of these plants is feasible) of ``design_sensor_bank``
(each row reads one sensor, order ≈ n: realised in the orthonormal basis) and of a
four-row bank (detection, and "all but sensor j", j = 0, 1, 2) on lightly damped
mass-spring chains (n = 20 … 200, 4 … 20 position sensors) and dense random plants
(n = 20 … 100, q = n/5); with the design time against one n × n SVD.

Table 3: time of one least-order fault-detection row on a dense random plant with
q = n/2 sensors against one n × n SVD, n = 10 … 400.

Table 4: ``min_unobservability_subspace`` (S*, with W*) on a dense random plant with
q = n/10 sensors and 3 disturbance columns, and on a lightly damped chain (q = n/10),
n = 50 … 400, against one n × n SVD.

Table 5: the 32-state aircraft model (``gf.aircraft_model``): a dedicated bank of 8 rows
with the gusts decoupled (full run only).

Each table runs once with one BLAS thread and once with the default threads
(``_threads.run_thread_modes``); every time is the best of a few repeats, alternated
with its SVD baseline.  Run ``python benchmarks/bench_least_order.py`` (``--quick`` for a
smoke run; ``--threads 1`` or ``--threads default`` for one mode).
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _timing import svd_time  # noqa: E402

import geomfdi as gf  # noqa: E402
from geomfdi.model.faults import fault_matrices  # noqa: E402

BUDGET = 120.0  # seconds per design above which the larger sizes of a family are skipped
SENSOR_BANK_MAX_N = 200  # single-sensor rows have order ≈ n: the sensor bank up to this n


def _toeplitz(A, C, Bx, Dx, nu):
    q, k = C.shape[0], Bx.shape[1]
    T = np.zeros(((nu + 1) * q, (nu + 1) * k))
    mk = [Dx] + [C @ np.linalg.matrix_power(A, i) @ Bx for i in range(nu)]
    for i in range(nu + 1):
        for j in range(i + 1):
            T[i * q : (i + 1) * q, j * k : (j + 1) * k] = mk[i - j]
    return T


def reference_least_order(A, C, Bw, Dw, targets):
    """Least degree of a parity row ``v [O_ν, T_w] = 0`` seeing every target (numpy only)."""
    n = A.shape[0]
    for nu in range(n + 2):
        O = np.vstack([C @ np.linalg.matrix_power(A, i) for i in range(nu + 1)])
        X = np.hstack([O, _toeplitz(A, C, Bw, Dw, nu)])
        U, s, _ = np.linalg.svd(X, full_matrices=True)
        N = U[:, int(np.sum(s > 1e-9 * max(s[0] if s.size else 1.0, 1.0))) :]
        if N.shape[1] and all(
            np.linalg.norm(N.T @ (T := _toeplitz(A, C, Bf, Df, nu))) > 1e-7 * np.linalg.norm(T)
            for Bf, Df in targets
        ):
            return nu
    return None


def random_problem(seed):
    rng = np.random.default_rng(seed)
    n, q, m = int(rng.integers(1, 9)), int(rng.integers(1, 5)), int(rng.integers(0, 3))
    dt = 0.1 if rng.random() < 0.4 else 0.0
    A = rng.standard_normal((n, n)) / np.sqrt(n)
    if dt:
        A = 0.9 * A / max(1.0, np.max(np.abs(np.linalg.eigvals(A))))
    nd = int(rng.integers(0, 2))
    p = gf.Plant(
        A,
        rng.standard_normal((n, m)),
        rng.standard_normal((q, n)),
        Bd=rng.standard_normal((n, nd)) if nd else None,
        dt=dt,
    )
    faults = []
    for _ in range(int(rng.integers(1, 4))):
        kind = rng.integers(0, 3)
        if kind == 0:
            faults.append(gf.SensorFault(int(rng.integers(0, q))))
        elif kind == 1:
            faults.append(gf.ActuatorFault(rng.standard_normal(n)))
        else:
            faults.append(gf.Fault(rng.standard_normal((n, 1)), rng.standard_normal((q, 1))))
    row = rng.random(len(faults)) < 0.5
    if not row.any():
        row[0] = True
    return p, faults, row


def table_orders(count):
    """Returns ``{"rows", "total", "least", "ratio", "exact"}``."""
    tot_ours = tot_ref = rows = exact = 0
    for seed in range(count):
        p, faults, row = random_problem(seed)
        sig = fault_matrices(faults, p.n, p.q)
        tgt = [j for j in range(len(faults)) if row[j]]
        dec = [j for j in range(len(faults)) if not row[j]]
        ref = reference_least_order(
            p.A,
            p.C,
            np.hstack([p.Bd] + [sig[j][0] for j in dec]),
            np.hstack([p.Dd] + [sig[j][1] for j in dec]),
            [sig[j] for j in tgt],
        )
        if ref is None:
            continue
        g = gf.design_residual_generator(p, faults, tgt, decouple=dec)
        rows += 1
        tot_ours += g.order
        tot_ref += ref
        exact += g.order == ref
    ratio = tot_ours / max(tot_ref, 1)
    print("Table 1: total order vs independent least order (random problems, n ≤ 8)")
    print(
        f"  feasible rows {rows}, total order {tot_ours}, least {tot_ref}, "
        f"ratio {ratio:.2f}, rows at least order {exact}/{rows}"
    )
    return {"rows": rows, "total": tot_ours, "least": tot_ref, "ratio": ratio, "exact": exact}


def chain(N, ns, zeta=0.01):
    """Lightly damped mass-spring chain, N masses, ns position sensors, a force on mass 0."""
    return gf.mass_spring_chain(N, sensors=ns, forces=(0,), zeta=zeta)


def dense(n, q, m, seed):
    rng = np.random.default_rng(seed)
    return gf.Plant(
        rng.standard_normal((n, n)) / np.sqrt(n),
        rng.standard_normal((n, m)),
        rng.standard_normal((q, n)),
    )


def _good_rows(bank, plant):
    """Rows delivered, stable, with every decoupling below 1e-9 (gf.verify's angle)."""
    rep = gf.verify(bank, plant)
    good = 0
    for r, g in enumerate(bank.generators):
        if g is None:
            continue
        lam = np.linalg.eigvals(g.F) if g.order else np.zeros(0)
        stable = np.all(np.abs(lam) < 1) if plant.dt else np.all(lam.real < 0)
        leak = max(float(np.max(rep.leakage[r], initial=0.0)), float(rep.input_leakage[r]))
        good += bool(stable) and leak < 1e-9
    return good


def _timed(fn, repeats):
    best, out = np.inf, None
    for _ in range(repeats):
        t = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", gf.CloseRankWarning)
            out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def _four_rows(q):
    S = np.ones((4, q), dtype=int)
    S[1, 0] = S[2, 1] = S[3, 2] = 0
    return S


def table_success(chain_sizes, dense_sizes):
    """Rows ``(family, n, q, bank, good, rows, t_design, ratio, orders)``."""
    print("Table 2: success (rows delivered, stable, leak < 1e-9) / rows requested; time")
    print(
        f"  {'plant':5s} {'n':>4} {'q':>3} {'bank':>7} {'success':>8} {'design [s]':>10} "
        f"{'/SVD':>8}  orders"
    )
    out = []
    fams = [("chain", chain_sizes, lambda n: chain(n // 2, int(np.clip(n // 10, 4, 20))))]
    fams.append(("dense", dense_sizes, lambda n: dense(n, max(4, n // 5), 2, n)))
    for name, sizes, make in fams:
        skip = False
        for n in sizes:
            p = make(n)
            for kind in ("sensor", "4-row"):
                if kind == "sensor" and n > SENSOR_BANK_MAX_N:
                    continue
                if skip:
                    print(f"  {name:5s} {n:>4} {p.q:>3} {kind:>7}  skipped (time budget)")
                    continue
                faults = [gf.SensorFault(i) for i in range(p.q)]

                def run(p=p, faults=faults, kind=kind):
                    if kind == "sensor":
                        return gf.design_sensor_bank(p)
                    return gf.design_bank(p, faults, _four_rows(p.q))

                td, bank = _timed(run, 1)
                ts = svd_time(n)
                good = _good_rows(bank, p)
                orders = [None if g is None else g.order for g in bank.generators]
                rows = len(bank.generators)
                print(
                    f"  {name:5s} {n:>4} {p.q:>3} {kind:>7} {good:>4}/{rows:<3} {td:>10.2f} "
                    f"{td / ts:>8.0f}  {orders}"
                )
                out.append((name, n, p.q, kind, good, rows, td, td / ts, orders))
                skip = skip or td > BUDGET
    return out


def table_time(sizes):
    """Rows ``(n, t_design, t_svd, ratio, order)``."""
    print("Table 3: one fault-detection row (dense plant, q = n/2) vs one n x n SVD")
    out = []
    for n in sizes:
        p = dense(n, n // 2, 2, 7)
        faults = [gf.SensorFault(i) for i in range(p.q)]
        reps = 3 if n <= 50 else 1
        ts, td, g = np.inf, np.inf, None
        for _ in range(reps):  # baseline and design alternated
            ts = min(ts, svd_time(n, 3))
            t, g = _timed(
                lambda p=p, f=faults: gf.design_residual_generator(p, f, list(range(p.q))), 1
            )
            td = min(td, t)
        print(
            f"  n={n:4d}: design {td:8.3f} s, SVD {1e3 * ts:8.2f} ms, ratio {td / ts:8.1f}, "
            f"order {g.order}"
        )
        out.append((n, td, ts, td / ts, g.order))
    return out


def sstar_problem(kind, n):
    """(A, C, L): dense random (q = n/10, 3 disturbance columns) or a lightly damped chain."""
    rng = np.random.default_rng(n)
    q = max(2, n // 10)
    if kind == "dense":
        return (
            rng.standard_normal((n, n)) / np.sqrt(n),
            rng.standard_normal((q, n)),
            rng.standard_normal((n, 3)),
        )
    p = chain(n // 2, q)
    L = np.zeros((n, 2))
    L[n // 2, 0] = L[n // 2 + n // 4, 1] = 1.0
    return p.A, p.C, L


def table_sstar(sizes):
    """Rows ``(kind, n, t_S, t_svd, ratio, dim S*, steps)``."""
    print("Table 4: S* = min_unobservability_subspace (with W*) vs one n x n SVD")
    out = []
    for kind in ("dense", "chain"):
        for n in sizes:
            A, C, L = sstar_problem(kind, n)
            reps = 3 if n <= 200 else 2
            ts, tS, S = np.inf, np.inf, None
            for _ in range(reps):
                ts = min(ts, svd_time(n, 3))
                t, S = _timed(lambda A=A, C=C, L=L: gf.min_unobservability_subspace(A, C, L), 1)
                tS = min(tS, t)
            print(
                f"  {kind:5s} n={n:4d} q={C.shape[0]:3d}: S* {1e3 * tS:9.2f} ms, SVD "
                f"{1e3 * ts:8.2f} ms, ratio {tS / ts:6.1f}, dim {S.dim:3d}, steps {S.steps}"
            )
            out.append((kind, n, tS, ts, tS / ts, S.dim, S.steps))
    return out


def table_aircraft():
    """The 32-state aircraft model: dedicated bank (8 rows), gusts decoupled."""
    print("Table 5: gf.aircraft_model() (n = 32), dedicated bank of 8 rows, gusts decoupled")
    p, faults = gf.aircraft_model()
    td, bank = _timed(lambda: gf.design_bank(p, faults, np.eye(len(faults), dtype=int)), 1)
    ts = svd_time(p.n)
    good = _good_rows(bank, p)
    orders = [None if g is None else g.order for g in bank.generators]
    print(
        f"  success {good}/{len(faults)}, isolable {int(bank.isolable.sum())}/{len(faults)}, "
        f"design {td:.2f} s ({td / ts:.0f} SVDs), orders {orders}"
    )
    return {"good": good, "orders": orders, "t_design": td, "ratio": td / ts}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (smoke run)")
    ap.add_argument(
        "--only",
        choices=("orders", "success", "time", "sstar", "aircraft"),
        default=None,
        help="run one table of the full run",
    )
    args = ap.parse_args(argv)
    if args.only:
        full = {
            "orders": lambda: table_orders(200),
            "success": lambda: table_success((20, 40, 60, 100, 200), (20, 40, 60, 100)),
            "time": lambda: table_time((10, 20, 50, 100, 200, 400)),
            "sstar": lambda: table_sstar((50, 100, 200, 400)),
            "aircraft": table_aircraft,
        }
        return {args.only: full[args.only]()}
    if args.quick:
        res = {
            "orders": table_orders(20),
            "success": table_success((20,), (20,)),
            "time": table_time((10, 20)),
            "sstar": table_sstar((50,)),
        }
        return res
    else:
        res = {
            "orders": table_orders(200),
            "success": table_success((20, 40, 60, 100, 200), (20, 40, 60, 100)),
            "time": table_time((10, 20, 50, 100, 200, 400)),
            "sstar": table_sstar((50, 100, 200, 400)),
            "aircraft": table_aircraft(),
        }
    return res


if __name__ == "__main__":
    from _threads import run_thread_modes

    run_thread_modes(main)
