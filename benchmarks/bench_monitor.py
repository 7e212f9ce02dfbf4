"""``gf.Monitor`` per sample: numpy against the compiled backend (``backend="c"``).

Banks: ``make_bank(nb)`` of ``bench_simulation.py`` (the three Hou, Wen & Chen (2011)
generators plus random third-order ones) sampled at 1 ms: banks of 5, 10, 12 and 22
generators (9, 24, 30 and 60 generator states).  Per bank:

* ``step``: one ``Monitor.step(y, u)`` call from Python (numpy; C through the builtin
  function of the compiled library, the default, and through ``ctypes`` and ``cffi``);
* ``feed``: ``Monitor.feed`` of 10^5 samples, per sample (numpy: the lifted recursion;
  C: one ``name_run`` call for the whole chunk);
* ``C run``: the generated ``name_run`` called directly on prepared arrays, per sample
  (the generated C step alone, no Python; a few ms per call, so the best of ten times
  more calls than the rest).

CPU times (``time.process_time``: every timed function runs on one thread), best of
``--repeat``, numpy and C timed alternately, each call after a pause that lets the BLAS
threads go idle (``_timing.best_alternating``).  Decisions: the C feed and step against
the numpy ones, exactly (alarms and isolation, sample by sample).  The acceptance lines
at the end: the C step from Python for the bank of 10 within ``STEP_LIMIT_US``, the
generated C step for 30 states within ``RUN_LIMIT_NS``, the decisions equal.
Run ``python benchmarks/bench_monitor.py`` (``--quick`` for a smoke run).
"""

from __future__ import annotations

import argparse
import ctypes
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from _timing import best_alternating  # noqa: E402
from bench_simulation import make_bank  # noqa: E402

import geomfdi as gf  # noqa: E402

STEP_LIMIT_US = 1.5  # Monitor(..., backend="c").step from Python, bank of 10
RUN_LIMIT_NS = 150.0  # the generated C step alone, 30 generator states


def bench_bank(nb: int, steps: int, L: int, repeat: int) -> dict:
    from geomfdi.deployment import compiled

    bank = make_bank(nb).discretize(1e-3)
    rng = np.random.default_rng(0)
    Y = 0.02 * rng.standard_normal((3, L))
    U = rng.standard_normal((3, L))
    Y[0, L // 2 :] += 0.1
    thr = 0.05
    mn = gf.Monitor(bank, threshold=thr, persistence=3)
    mc = gf.Monitor(bank, threshold=thr, persistence=3, backend="c")
    alt = {}
    for calls in ("ctypes", "cffi"):  # the other ways of calling the C step
        compiled.STEP_CALLS = calls
        alt[calls] = gf.Monitor(bank, threshold=thr, persistence=3, backend="c")
    compiled.STEP_CALLS = "python"
    if mc.backend != "c":
        raise SystemExit("no C compiler: the compiled backend is not available")
    ys = [Y[:, k].copy() for k in range(steps)]
    us = [U[:, k].copy() for k in range(steps)]

    def stepper(mon):
        def run():
            step = mon.step
            for k in range(steps):
                step(ys[k], us[k])

        return run

    from geomfdi.deployment.codegen._c_text import c_source
    from geomfdi.deployment.codegen._spec import monitor_spec

    header, source = c_source(monitor_spec(mc), "gfmon")
    dll = compiled._load(compiled.build_library(header, source + compiled._SHIM))
    state = ctypes.create_string_buffer(int(dll.gfmon_state_size()))
    Yt, Ut = np.ascontiguousarray(Y.T), np.ascontiguousarray(U.T)
    R = np.empty((L, nb))
    A = np.empty((L, nb), dtype=np.intc)
    iso = np.empty(L, dtype=np.intc)

    def raw():
        dll.gfmon_init(state)
        dll.gfmon_run(
            state, L, Yt.ctypes.data, Ut.ctypes.data, R.ctypes.data, A.ctypes.data, iso.ctypes.data
        )

    sn, sc, st, sf, fn, fc, rc = best_alternating(
        [
            stepper(mn),
            stepper(mc),
            stepper(alt["ctypes"]),
            stepper(alt["cffi"]),
            lambda: mn.feed(Y, U),
            lambda: mc.feed(Y, U),
            raw,
        ],
        repeat,
        clock=time.process_time,
    )
    # the C run alone is a few ms: more repeats (no BLAS in it, no pause needed)
    rc = min(rc, *best_alternating([raw], 10 * repeat, settle=0.0, clock=time.process_time))
    mn.reset()
    ref = mn.feed(Y, U)
    mc.reset()
    out = mc.feed(Y, U)
    same = bool(
        np.array_equal(ref.alarms, out.alarms) and np.array_equal(ref.isolated, out.isolated)
    )
    mn.reset()
    mc.reset()
    for k in range(steps):  # the step path too, sample by sample
        a, b = mn.step(ys[k], us[k]), mc.step(ys[k], us[k])
        same = same and a.isolated == b.isolated and bool(np.array_equal(a.alarms, b.alarms))
    return {
        "bank": nb,
        "states": mn.program.nw,
        "step_numpy_us": sn / steps * 1e6,
        "step_c_us": sc / steps * 1e6,
        "step_ctypes_us": st / steps * 1e6,
        "step_cffi_us": sf / steps * 1e6,
        "feed_numpy_ns": fn / L * 1e9,
        "feed_c_ns": fc / L * 1e9,
        "c_run_ns": rc / L * 1e9,
        "decisions_equal": same,
    }


def main(argv: list[str] | None = None) -> list[dict]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small smoke run")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    print(f"load average {' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    steps, L = (2000, 20000) if args.quick else (20000, 100000)
    rows = [bench_bank(nb, steps, L, args.repeat) for nb in (5, 10, 12, 22)]
    print(
        f"{'bank':>5} {'states':>6} {'step numpy us':>14} {'step C us':>10} "
        f"{'ctypes us':>9} {'cffi us':>8} "
        f"{'feed numpy ns':>14} {'feed C ns':>10} {'C run ns':>9} {'same decisions':>15}"
    )
    for r in rows:
        print(
            f"{r['bank']:>5} {r['states']:>6} {r['step_numpy_us']:>14.2f} {r['step_c_us']:>10.2f} "
            f"{r['step_ctypes_us']:>9.2f} {r['step_cffi_us']:>8.2f} "
            f"{r['feed_numpy_ns']:>14.0f} {r['feed_c_ns']:>10.0f} {r['c_run_ns']:>9.0f} "
            f"{str(r['decisions_equal']):>15}"
        )
    by_bank = {r["bank"]: r for r in rows}
    step10, run30 = by_bank[10]["step_c_us"], by_bank[12]["c_run_ns"]
    same = all(r["decisions_equal"] for r in rows)
    for what, ok in (
        (
            f"C step from Python, bank of 10: {step10:.2f} us <= {STEP_LIMIT_US} us",
            step10 <= STEP_LIMIT_US,
        ),
        (
            f"generated C step, 30 states: {run30:.0f} ns <= {RUN_LIMIT_NS:.0f} ns",
            run30 <= RUN_LIMIT_NS,
        ),
        ("C and numpy decisions equal (feed and step, every bank)", same),
    ):
        print(f"{'PASS' if ok else 'FAIL'}  {what}")
    return rows


if __name__ == "__main__":
    from _threads import run_thread_modes

    run_thread_modes(main)
