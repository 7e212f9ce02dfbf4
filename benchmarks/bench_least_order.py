"""Least-order synthesis: orders against an independent reference, success, cost.

Table 1: total order of the delivered rows against the least order found by an
independent brute-force parity-space search on the physical model (numpy only), on
random problems (n ≤ 8, continuous and discrete, disturbances, sensor / actuator /
general faults, random structure rows).  Goal: ratio 1.00.

Table 2: success rate (rows delivered with leakage angle < 1e-9 / rows requested) of
``design_sensor_bank`` on lightly damped mass-spring chains and dense random plants, by n.

Table 3: time of one least-order fault-detection row on a dense random plant with
q = n/2 sensors against one n × n SVD, n = 10 … 400, with one BLAS thread and with the
default threads (threadpoolctl).

Run ``python benchmarks/bench_least_order.py`` (``--quick`` for a smoke run).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import geomfdi as gf  # noqa: E402
from geomfdi.model.faults import fault_matrices  # noqa: E402


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
    print("Table 1: total order vs independent least order")
    print(
        f"  feasible rows {rows}, total order {tot_ours}, least {tot_ref}, "
        f"ratio {tot_ours / max(tot_ref, 1):.2f}, rows at least order {exact}/{rows}"
    )


def chain(N, ns, zeta=0.01):
    n = 2 * N
    K = 2 * np.eye(N) - np.eye(N, k=1) - np.eye(N, k=-1)
    K[-1, -1] = 1.0
    A = np.block([[np.zeros((N, N)), np.eye(N)], [-K, -2 * zeta * np.sqrt(2) * np.eye(N)]])
    B = np.zeros((n, 1))
    B[N] = 1.0
    C = np.zeros((ns, n))
    C[np.arange(ns), np.linspace(0, N - 1, ns).astype(int)] = 1.0
    return gf.Plant(A, B, C)


def dense(n, q, m, seed):
    rng = np.random.default_rng(seed)
    return gf.Plant(
        rng.standard_normal((n, n)) / np.sqrt(n),
        rng.standard_normal((n, m)),
        rng.standard_normal((q, n)),
    )


def table_success(sizes):
    print("Table 2: design_sensor_bank success (rows delivered, verify ok) / rows, time [s]")
    for name, make in (
        ("chain", lambda n: chain(n // 2, max(4, n // 10))),
        ("dense", lambda n: dense(n, max(4, n // 5), 2, n)),
    ):
        for n in sizes:
            p = make(n)
            t = time.perf_counter()
            bank = gf.design_sensor_bank(p)
            el = time.perf_counter() - t
            rep = gf.verify(bank, p)
            ok = sum(
                1
                for r, g in enumerate(bank.generators)
                if g is not None and rep.leakage[r].max() < 1e-9 and rep.input_leakage[r] < 1e-9
            )
            orders = [None if g is None else g.order for g in bank.generators]
            print(f"  {name:5s} n={n:4d} q={p.q:3d}: {ok}/{p.q}  time {el:7.2f}  orders {orders}")


def table_structure(sizes):
    print("Table 2b: design_bank, structure [all; all but sensor 0; … 1; … 2] (low orders)")
    for name, make in (
        ("chain", lambda n: chain(n // 2, n // 4)),
        ("dense", lambda n: dense(n, n // 2, 2, n)),
    ):
        for n in sizes:
            p = make(n)
            S = np.ones((4, p.q), dtype=int)
            S[1, 0] = S[2, 1] = S[3, 2] = 0
            t = time.perf_counter()
            bank = gf.design_bank(p, [gf.SensorFault(i) for i in range(p.q)], S)
            el = time.perf_counter() - t
            rep = gf.verify(bank, p)
            ok = sum(
                1
                for r, g in enumerate(bank.generators)
                if g is not None and rep.leakage[r].max() < 1e-9 and rep.input_leakage[r] < 1e-9
            )
            orders = [None if g is None else g.order for g in bank.generators]
            print(f"  {name:5s} n={n:4d} q={p.q:3d}: {ok}/4  time {el:7.2f}  orders {orders}")


def table_time(sizes):
    print("Table 3: one fault-detection row (q = n/2) vs one n x n SVD")
    for threads in (1, None):
        with threadpool_limits(threads):
            for n in sizes:
                p = dense(n, n // 2, 2, 7)
                faults = [gf.SensorFault(i) for i in range(p.q)]
                X = np.random.default_rng(0).standard_normal((n, n))
                t = time.perf_counter()
                np.linalg.svd(X)
                tsvd = time.perf_counter() - t
                t = time.perf_counter()
                g = gf.design_residual_generator(p, faults, list(range(p.q)))
                td = time.perf_counter() - t
                print(
                    f"  threads={threads or 'default'} n={n:4d}: design {td:8.3f} s, SVD "
                    f"{tsvd:8.4f} s, ratio {td / max(tsvd, 1e-9):8.1f}, order {g.order}"
                )


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv)
    table_orders(40 if args.quick else 200)
    table_success((20, 40) if args.quick else (20, 40, 60, 100, 200))
    table_structure((20, 40) if args.quick else (20, 40, 60, 100, 200))
    table_time((10, 40) if args.quick else (10, 20, 50, 100, 200, 400))


if __name__ == "__main__":
    main()
