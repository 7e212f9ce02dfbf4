"""Evaluate a residual bank on recorded data: design, record a faulty run, evaluate, plot.

1. Design a sensor-fault bank on the sampled plant of Hou, Wen & Chen (2011), section 4
   (``examples/hou_wen_chen.toml``, zero-order hold at 10 ms).
2. Record a healthy and a faulty closed-loop run (state feedback from the model file, a
   gain fault on sensor 0 at 8 s, measurement noise, a few dropped samples) to CSV.
3. Read the CSVs back; calibrate thresholds on the healthy one (false-alarm rate 1e-3),
   run ``gf.evaluate`` on the faulty one with 3-of-5 persistence, and print the alarm
   episodes and the isolated fault.
4. Save the residual and decision plots as PNGs, the bank as JSON, and the generated C
   and Python monitor code.

Usage: ``python examples/evaluate_recorded.py OUT_DIR``
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np
from scipy.signal import cont2discrete

import geomfdi as gf
from geomfdi.io.modelfile import load_model

HERE = Path(__file__).resolve().parent
ONSET = 8.0


def record(
    plant: gf.Plant, bank: gf.ResidualBank, K: np.ndarray, path: Path, *, fault: bool, seed: int
) -> None:
    """Simulate the closed loop (gain fault on sensor 0 at 8 s when ``fault``) and write
    ``t, y0.., u0..`` to ``path``; three samples of sensor 1 are lost by the logger."""
    t = np.arange(0.0, 20.0 + plant.dt / 2, plant.dt)
    u = np.vstack([np.sin(0.5 * t), np.cos(0.3 * t), np.full(t.size, 0.2)])
    faults = [gf.GainFault(0, start=ONSET, gain=1.5, bias=0.02)] if fault else []
    res = gf.simulate(
        plant, bank, t, u, controller=K, faults=faults, noise=gf.Noise(measurement=1e-3, seed=seed)
    )
    y = res.y.copy()
    if fault:
        y[1, 500:503] = np.nan
    names = [f"y{i}" for i in range(plant.q)] + [f"u{j}" for j in range(plant.m)]
    np.savetxt(
        path, np.vstack([t, y, res.u]).T, delimiter=",", header=",".join(["t", *names]), comments=""
    )


def read(path: Path) -> Any:
    """The recorded CSV as a pandas DataFrame (or a dict of arrays without pandas)."""
    try:
        import pandas as pd

        return pd.read_csv(path)
    except ImportError:
        raw = np.genfromtxt(path, delimiter=",", names=True)
        return {name: raw[name] for name in raw.dtype.names}


def evaluate(bank: gf.ResidualBank, data: Any, **kw: Any) -> Any:
    if isinstance(data, dict):
        y = np.vstack([data[k] for k in data if k.startswith("y")])
        u = np.vstack([data[k] for k in data if k.startswith("u")])
        return gf.evaluate(bank, y, u, data["t"], **kw)
    return gf.evaluate(bank, data, **kw)


def main(out_dir: str) -> Any:
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    spec = load_model(HERE / "hou_wen_chen.toml")
    p, dt = spec.plant, 0.01
    Ad, Bd, Cd, _, _ = cont2discrete((p.A, p.B, p.C, np.zeros((p.q, p.m))), dt)
    plant = gf.Plant(Ad, Bd, Cd, dt=dt)
    bank = gf.design_sensor_bank(plant)

    # a healthy recording calibrates the thresholds, a faulty one is diagnosed
    record(plant, bank, spec.K, out / "healthy.csv", fault=False, seed=1)
    record(plant, bank, spec.K, out / "recorded.csv", fault=True, seed=2)
    healthy = evaluate(bank, read(out / "healthy.csv"))
    threshold = gf.Threshold.from_residuals(healthy.residuals, 1e-3, skip=10)
    res = evaluate(bank, read(out / "recorded.csv"), threshold=threshold, persistence=(3, 5))

    print(f"thresholds: {np.round(threshold.values, 4).tolist()}")
    print(f"masked windows: {res.gaps}")
    print(f"{len(res.episodes)} alarm episodes; the first ones:")
    for ep in res.episodes[:5]:
        fault = "-" if ep.fault is None else res.fault_labels[ep.fault]
        print(f"alarm {ep.start:.2f} .. {ep.stop:.2f} s on {ep.residuals}; isolated: {fault}")
    print(f"fault onset {ONSET} s, first alarm {res.first_alarm} s")

    import matplotlib.pyplot as plt

    gf.save_png(
        res.plot(title="recorded run, gain fault on sensor 0 at 8 s"), out / "residuals.png"
    )
    fig, ax = plt.subplots(figsize=(7, 2.5))
    ax.step(res.t, res.isolated, where="post")
    ax.set_yticks([-3, -2, -1, *range(len(res.fault_labels))])
    ax.set_yticklabels(["ambiguous", "unexplained", "no alarm", *res.fault_labels])
    ax.set_xlabel("t [s]")
    ax.set_title("isolation decision per sample")
    fig.tight_layout()
    gf.save_png(fig, out / "isolation.png")
    plt.close("all")

    bank.save(out / "bank.json")
    mon = gf.Monitor(bank, threshold=threshold, persistence=(3, 5))
    gf.codegen.c(mon, "hou_wen_chen_monitor", out / "c")
    gf.codegen.python(mon, "hou_wen_chen_monitor", out / "python")
    return res


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "out_dir",
        nargs="?",
        default="evaluate_recorded_out",
        help="folder for the CSVs, figures, bank and code (default: %(default)s)",
    )
    main(ap.parse_args().out_dir)
