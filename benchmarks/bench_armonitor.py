"""Sliding AR least squares of :class:`geomfdi.ARMonitor` against per-window refits.

For windows of 60 and 600 samples on a stream of 10^5 white innovations, times

* ``sliding (batch)``: :meth:`ARMonitor.run` -- moving sums of lagged products for all
  windows at once and a batched n x n solve;
* ``sliding (stream)``: :meth:`ARMonitor.update` one sample at a time (rank-1 updates
  of the normal equations, O(n^2) per sample, plus a Python call per sample);
* ``refit lstsq (loop)``: ``numpy.linalg.lstsq`` on each window (the baseline);
* ``refit einsum (vectorised)``: normal equations of every window rebuilt from scratch
  with one batched ``einsum`` (O(m n^2) per window, no Python loop);
* ``refit AutoReg (loop)``: ``statsmodels`` ``AutoReg(trend="n")`` on each window, if
  statsmodels is installed.

Slow methods are timed on a subset of windows and extrapolated linearly to the full
stream; such rows are marked ``*``.  The coefficients of every method are checked
against the lstsq baseline on the windows both computed.

Run ``python benchmarks/bench_armonitor.py`` (``--quick`` for a smoke run).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import geomfdi as gf  # noqa: E402


def _design(w: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    rows = sliding_window_view(w, n + 1)[:, ::-1]  # (x_j, x_{j-1}, ..., x_{j-n})
    return rows[:, 1:], rows[:, 0]


def refit_lstsq(x: np.ndarray, n: int, m: int, ends: np.ndarray) -> np.ndarray:
    out = np.empty((ends.size, n))
    for i, e in enumerate(ends):
        R, y = _design(x[e - m + 1 : e + 1], n)
        out[i] = np.linalg.lstsq(R, y, rcond=None)[0]
    return out


def refit_einsum(x: np.ndarray, n: int, m: int, ends: np.ndarray, chunk: int = 512) -> np.ndarray:
    out = np.empty((ends.size, n))
    for i in range(0, ends.size, chunk):
        e = ends[i : i + chunk]
        W = x[(e - m + 1)[:, None] + np.arange(m)[None, :]]  # (c, m)
        rows = sliding_window_view(W, n + 1, axis=1)[:, :, ::-1]  # (c, m-n, n+1)
        R, y = rows[..., 1:], rows[..., 0]
        A = np.einsum("cji,cjk->cik", R, R)
        b = np.einsum("cji,cj->ci", R, y)
        out[i : i + chunk] = np.linalg.solve(A, b[..., None])[..., 0]
    return out


def refit_autoreg(x: np.ndarray, n: int, m: int, ends: np.ndarray) -> np.ndarray:
    from statsmodels.tsa.ar_model import AutoReg

    out = np.empty((ends.size, n))
    for i, e in enumerate(ends):
        out[i] = AutoReg(x[e - m + 1 : e + 1], lags=n, trend="n").fit().params
    return out


def _timed(fn, *args):
    t0 = time.perf_counter()
    res = fn(*args)
    return time.perf_counter() - t0, res


def bench(
    n_samples: int = 100_000,
    windows: tuple[int, ...] = (60, 600),
    order: int = 5,
    subset: int = 5000,
    subset_autoreg: int = 500,
    stream_samples: int | None = None,
    seed: int = 0,
) -> list[dict]:
    """Run the comparison; return one row per (window, method).

    The sliding batch path is timed as the best of 3 runs; the others once.
    """
    rng = np.random.default_rng(seed)
    x = gf.synthetic_innovations(n_samples, rng=rng)
    rows: list[dict] = []
    for m in windows:
        mon = gf.ARMonitor(order, m, reset_after=None)
        mon.fit(gf.synthetic_innovations(max(20 * m, 2000), rng=rng))
        n_win = n_samples - m + 1
        all_ends = np.arange(m - 1, n_samples)

        t_batch, out = min((_timed(mon.run, x) for _ in range(3)), key=lambda r: r[0])
        phi_batch = out.coefficients[m - 1 :]

        n_stream = n_samples if stream_samples is None else min(stream_samples, n_samples)
        mon.reset()
        t0 = time.perf_counter()
        for v in x[:n_stream]:
            mon.update(v)
        t_stream = (time.perf_counter() - t0) * n_samples / n_stream

        sub = all_ends[: min(subset, n_win)]
        t_lstsq, phi_lstsq = _timed(refit_lstsq, x, order, m, sub)
        t_lstsq *= n_win / sub.size
        ref = phi_batch[: sub.size]
        scale = np.max(np.abs(phi_lstsq))

        t_einsum, phi_ein = _timed(refit_einsum, x, order, m, sub)
        t_einsum *= n_win / sub.size

        def row(method, t, extrapolated, err, m=m):
            return {
                "window": m,
                "method": method,
                "time": t,
                "us_per_sample": 1e6 * t / n_samples,
                "extrapolated": extrapolated,
                "max_err": err,
            }

        rows.append(
            row(
                "refit lstsq (loop)",
                t_lstsq,
                sub.size < n_win,
                0.0,
            )
        )
        rows.append(
            row(
                "refit einsum (vectorised)",
                t_einsum,
                sub.size < n_win,
                float(np.max(np.abs(phi_ein - phi_lstsq)) / scale),
            )
        )
        try:
            sub_ar = all_ends[: min(subset_autoreg, n_win)]
            refit_autoreg(x, order, m, sub_ar[:2])  # warm-up (imports)
            t_ar, phi_ar = _timed(refit_autoreg, x, order, m, sub_ar)
            t_ar *= n_win / sub_ar.size
            err_ar = float(np.max(np.abs(phi_ar - phi_lstsq[: sub_ar.size])) / scale)
            rows.append(row("refit AutoReg (loop)", t_ar, sub_ar.size < n_win, err_ar))
        except ImportError:
            print("statsmodels not installed: AutoReg baseline skipped")
        rows.append(
            row(
                "sliding (stream)",
                t_stream,
                n_stream < n_samples,
                float(np.max(np.abs(_stream_check(mon, x, sub.size, m) - phi_lstsq)) / scale),
            )
        )
        rows.append(
            row("sliding (batch)", t_batch, False, float(np.max(np.abs(ref - phi_lstsq)) / scale))
        )
        base = t_lstsq
        for r in rows:
            if r["window"] == m:
                r["speedup"] = base / r["time"]
    return rows


def _stream_check(mon: gf.ARMonitor, x: np.ndarray, count: int, m: int) -> np.ndarray:
    """Coefficients of the first ``count`` windows from the streaming API."""
    mon.reset()
    out = np.empty((count, mon.order))
    for t, v in enumerate(x[: m - 1 + count]):
        mon.update(v)
        if t >= m - 1:
            out[t - m + 1] = mon.last.coefficients
    return out


def print_table(rows: list[dict], n_samples: int) -> None:
    print(f"AR(5) least squares on every sliding window of a {n_samples}-sample stream")
    print(
        f"{'window':>6}  {'method':<27} {'time [s]':>10} {'us/sample':>10} "
        f"{'speed-up':>9} {'max rel err':>12}"
    )
    for r in rows:
        star = "*" if r["extrapolated"] else " "
        print(
            f"{r['window']:>6}  {r['method']:<27} {r['time']:>9.3f}{star} "
            f"{r['us_per_sample']:>10.2f} {r['speedup']:>8.1f}x {r['max_err']:>12.1e}"
        )
    print("* timed on a subset of windows and extrapolated linearly to the whole stream")
    print("speed-up: time of the per-window lstsq refit divided by the method's time")


def main(argv: list[str] | None = None) -> list[dict]:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="small smoke run")
    p.add_argument("--samples", type=int, default=100_000)
    args = p.parse_args(argv)
    if args.quick:
        kw = dict(n_samples=3000, subset=300, subset_autoreg=30, stream_samples=1500)
    else:
        kw = dict(n_samples=args.samples)
    rows = bench(**kw)
    print_table(rows, kw["n_samples"])
    return rows


if __name__ == "__main__":
    from _threads import run_thread_modes

    run_thread_modes(main)
