"""Hou, Wen & Chen (2011): the paper's residual bank against the exact one, gain fault on
sensor 0 at 8 s
(the paper's sensor 1; geomfdi numbers sensors from 0).

Closed loop u = v - K x with the numbers of Hou, Wen, Chen (2011), section 4.  Both banks
are scaled like the paper (unit first Markov parameter: M = 1, p_j L_j = +-1), so the
paper's threshold 0.06 applies.  Saves ``hou_wen_chen_residuals.png`` into ``--out``.

Run: ``python examples/hou_wen_chen_compare.py --out DIR``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import geomfdi as gf

A = [[1, 1, 1], [0, 1, 0], [2, 0, 1]]
B = [[1, 0, 1], [0, 1, 1], [0, 1, 0]]
C = [[0, 1, 0], [0, 0, 1], [1, 0, 2]]
K = np.array([[5, -1.5, 3], [2, 0, 2], [-2, 2.5, -2]])
X0 = [0.5, -0.3, 0.2]
THRESHOLD = 0.06


def run(out: Path) -> dict[str, np.ndarray]:
    """Simulate both banks; return max |r| on [8, 20] s per bank and save the figure."""
    plant = gf.Plant(A, B, C)
    banks = {
        "paper (L = -A f, F = -2)": gf.design_sensor_bank(plant, method="paper", poles=[-2]),
        "exact (output filter)": gf.design_sensor_bank(plant),
    }
    t = np.arange(0.0, 20.0 + 1e-9, 2e-3)

    def v(tt: np.ndarray) -> np.ndarray:
        return np.vstack([np.sin(0.5 * tt), np.cos(0.3 * tt), np.full_like(tt, 0.2)])

    fault = gf.GainFault(0, start=8.0, gain=1.5, bias=0.02)
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 6.5), layout="constrained")
    axes = fig.subplots(3, 2, sharex=True)
    peaks = {}
    for col, (name, bank) in enumerate(banks.items()):
        bank = bank.normalized("markov")
        res = gf.simulate(
            plant, bank, t, v, faults=[fault], x0=X0, controller=K, threshold=THRESHOLD
        )
        peaks[name] = res.max_abs(8.0, 20.0)
        for r in range(3):
            ax = axes[r, col]
            ax.plot(res.t, res.residuals[r], lw=1.2)
            ax.axhline(THRESHOLD, color="tab:red", ls="--", lw=0.8)
            ax.axhline(-THRESHOLD, color="tab:red", ls="--", lw=0.8)
            ax.axvline(8.0, color="k", ls=":", lw=0.8)
            ax.set_ylabel(f"r[{r}]")
            ax.grid(alpha=0.3)
        axes[0, col].set_title(
            f"{name}\nmax|r| on [8, 20] s = " + ", ".join(f"{x:.3g}" for x in peaks[name])
        )
        axes[2, col].set_xlabel("t [s]")
    fig.suptitle("Sensor 0 gain fault (eta = 1.5, lambda = 0.02) at t = 8 s; threshold 0.06")
    out.mkdir(parents=True, exist_ok=True)
    fig.savefig(out / "hou_wen_chen_residuals.png", dpi=110)
    return peaks


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path.cwd(), help="output directory")
    args = parser.parse_args(argv)
    for name, p in run(args.out).items():
        print(f"{name:28s} max|r| on [8, 20] s: " + ", ".join(f"{x:.4f}" for x in p))
    print(f"figure: {args.out / 'hou_wen_chen_residuals.png'}")


if __name__ == "__main__":
    main()
