"""ROC and P_d-versus-fault-size figures of two Monte-Carlo campaigns.

* Hou, Wen & Chen (2011, section 4; closed loop ``u = v - K x``) with its exact
  bank of three residuals, measurement noise of standard deviation 0.01 on every sensor, a
  bias on each sensor at 8 s, evaluated by the windowed chi-square test (0.1 s window,
  analytic threshold at a per-window false-alarm probability of 1e-4); the same bias on
  sensor 1 again over three plant models with +-1 % entry-wise uncertainty on ``A`` and
  ``B`` (the bank stays the nominal design, so its residuals now see the input).
* The sampled DC motor of ``examples/discrete_disturbance.toml`` with the campaign of its
  ``[campaign]`` table (what ``geomfdi campaign`` runs).

Writes ``roc_*.png`` and ``detection_*.png`` (and the tables as CSV) into the output
directory.  Run: ``python examples/campaign_roc.py [OUT] [--runs N] [--executor processes]``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import geomfdi as gf
from geomfdi.campaign.config import write_outputs
from geomfdi.io.cli import design_all, load_campaign
from geomfdi.io.modelfile import load_model

ROOT = Path(__file__).resolve().parent


def hou_wen_chen_campaigns(runs: int) -> list[tuple[str, gf.Campaign]]:
    spec = load_model(ROOT / "hou_wen_chen.toml")
    bank = design_all(spec)["exact"]
    t = spec.t[spec.t <= 11.0 + 1e-9]
    noise = gf.Noise(measurement=0.01, seed=2011)
    models = gf.residual_noise_models(spec.plant, bank, noise, step=t[1] - t[0], controller=spec.K)
    test = gf.ChiSquareTest.design(models, window=50, false_alarm_rate=1e-4)
    sizes = [0.0, 0.005, 0.01, 0.0125, 0.015, 0.02, 0.03]
    common = dict(
        noise=noise,
        t=t,
        test=test,
        u=spec.u,
        controller=spec.K,
        x0=spec.x0,
        detection_window=2.0,
        eval_start=2.0,
    )
    nominal = gf.Campaign(
        spec.plant,
        bank,
        [gf.Scenario.sensor("bias", i, sizes, [8.0]) for i in range(3)],
        runs=runs,
        **common,
    )
    uncertain = gf.Campaign(
        spec.plant,
        bank,
        [gf.Scenario.sensor("bias", 1, sizes, [8.0], name="bias on sensor 1, 1 % uncertainty")],
        uncertainty=gf.Uncertainty(relative=0.01, samples=3, seed=1),
        runs=max(1, runs // 3),
        **common,
    )
    return [("hou_wen_chen", nominal), ("hou_wen_chen_uncertain", uncertain)]


def main(argv: list[str] | None = None) -> dict[str, gf.CampaignResult]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", nargs="?", type=Path, default=Path("campaign_out"))
    ap.add_argument("--runs", type=int, default=200, help="noise seeds per grid point")
    ap.add_argument("--executor", choices=("serial", "processes"), default="serial")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)
    motor = load_campaign(ROOT / "discrete_disturbance.toml", runs=args.runs)
    jobs = [*hou_wen_chen_campaigns(args.runs), ("discrete_disturbance", motor.campaign)]
    results = {}
    for name, campaign in jobs:
        res = campaign.run(args.executor, workers=args.workers)
        files = write_outputs(res, args.out / name, name=name)
        bank = res.summary().xs("bank", level="residual")
        print(f"{name}: {len(campaign.grid()['run'])} runs")
        print(bank[["runs", "pd", "far", "delay_median"]].round(4).to_string())
        print("  " + ", ".join(str(f) for f in files if f.suffix == ".png"))
        results[name] = res
    return results


if __name__ == "__main__":
    np.set_printoptions(precision=4)
    main()
