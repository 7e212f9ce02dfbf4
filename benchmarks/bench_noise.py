"""Standard normals per nanosecond: the counter generator against numpy's generators.

Fills of ``--samples`` normals (default 10^7, one buffer, allocated once), the best of
``--repeats``, timed in one process run:

* **counter, C**: ``fill_normals`` of :mod:`geomfdi.simulation.counter_normal` (the
  compiled Philox4x32-10 + Box–Muller kernel) for one run, and for 64 runs x 3 rows in
  one call (the layout of a campaign block);
* **counter, numpy**: the numpy fallback (the same bits; on a tenth of the samples);
* **numpy PCG64 / SFC64**: ``Generator.standard_normal(out=)`` (ziggurat), and PCG64's
  uniforms ``random(out=)`` for scale;
* **numpy PCG64, compiled**: :func:`geomfdi.simulation.pcg64_normal.standard_normal`,
  numpy's PCG64 normals (the same bits) drawn by geomfdi's compiled loop, what
  simulations with ``generator="numpy"`` use.

Prints ns per normal and the ratio of numpy's PCG64 and SFC64 to the counter kernel.
Everything runs twice (``benchmarks/_threads.py``: one BLAS thread, then the default
threads; none of these fills uses the BLAS or threads, so both give the same numbers).

``python benchmarks/bench_noise.py`` (a few seconds); ``--samples``, ``--repeats``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from _threads import run_thread_modes  # noqa: E402

from geomfdi.simulation import counter_normal as cn  # noqa: E402
from geomfdi.simulation import pcg64_normal as pn  # noqa: E402


def best_ns(fn: Any, count: int, repeats: int) -> float:
    """Best time of ``fn()`` over ``repeats`` calls, in ns per normal (``count``)."""
    fn()  # warm-up (builds the kernel, touches the buffer)
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return 1e9 * best / count


def main(argv: list[str]) -> dict[str, float]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=10**7)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    n, rep = args.samples, args.repeats
    key = cn.run_key(1)[None]
    buf = np.empty((1, 1, n))
    runs, rows = 64, 3
    per = max(2, n // (runs * rows))
    block = np.empty((runs, rows, per))
    keys = np.stack([cn.run_key(s) for s in np.random.SeedSequence(1).spawn(runs)])
    small = np.empty((1, 1, max(2, n // 10)))
    flat = buf.reshape(-1)
    pcg = np.random.Generator(np.random.PCG64(1))
    sfc = np.random.Generator(np.random.SFC64(1))
    print(
        f"compiled kernels: counter {cn.compiled()}, numpy PCG64 {pn.compiled()}; "
        f"{n} normals per fill, best of {rep}"
    )
    out = {
        "counter, C": best_ns(lambda: cn.fill_normals(key, 0, 0, 0, n, buf), n, rep),
        f"counter, C, {runs} runs x {rows} rows": best_ns(
            lambda: cn.fill_normals(keys, 0, 0, 0, per, block), block.size, rep
        ),
        "counter, numpy fallback": best_ns(
            lambda: cn.numpy_normals(key, 0, 0, 0, small.shape[2], small), small.size, 1
        ),
        "numpy PCG64 standard_normal": best_ns(lambda: pcg.standard_normal(out=flat), n, rep),
        "numpy PCG64, compiled (same bits)": best_ns(lambda: pn.standard_normal(pcg, flat), n, rep),
        "numpy SFC64 standard_normal": best_ns(lambda: sfc.standard_normal(out=flat), n, rep),
        "numpy PCG64 uniforms (random)": best_ns(lambda: pcg.random(out=flat), n, rep),
    }
    c = out["counter, C"]
    print(f"{'generator':<36} {'ns/normal':>10} {'vs counter, C':>14}")
    for name, ns in out.items():
        print(f"{name:<36} {ns:>10.2f} {ns / c:>13.2f}x")
    return out


if __name__ == "__main__":
    run_thread_modes(main)
