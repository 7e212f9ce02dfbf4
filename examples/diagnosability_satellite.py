"""Diagnosability of a satellite pitch-axis attitude system (Li, Wang & Liu 2015, eq. 24).

Pitch-axis model with an infrared Earth sensor (attitude angle) and a gyro (rate)::

    x = [theta, d_y, b_y]  (pitch angle, exponentially correlated drift, constant drift)

    x(k+1) = [[1, -dt, -dt], [0, 1 - dt/tau_y, 0], [0, 0, 1]] x(k) + dt I u(k)
             + Bf [f_gy; f_htheta] + w(k),        u = [omega_0 + g_y, 0, 0]
    y(k)   = [1, 0, 0] x(k) + [0, 1] [f_gy; f_htheta] + n_theta(k)

with ``dt = 0.1 s``, ``tau_y = 1/11``, ``w = [n_y, n_dy, n_by]`` of variances
``1e-6, 1e-5, 1e-4`` and ``n_theta`` of variance ``1e-4``.  The gyro fault ``f_gy`` adds
to the gyro reading, so it enters like the input: ``Bf = [dt, 0; 0, 0; 0, 0]`` (the
printed equation is garbled there; this reading reproduces Tables 3-4, ``Bf = e_1``
would give ``FD(f_gy) = 1.0000`` instead of 0.9300).

Prints the applicability report (Theorems 1-2 fail: ``m = 1``, rref rows with 3 and 4
non-zeros), Tables 3 (constant bias ``[0.1]*4``) and 4 (increasing bias
``[0.1, 0.3, 0.7, 0.9]``) with the directional method under both cosine conventions, the
KL and probability tables beside them, and saves the heat map of Table 4's isolability.

Run ``python examples/diagnosability_satellite.py --out DIR``.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

try:
    import geomfdi as gf
except ImportError:  # running from a source checkout without installation
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    import geomfdi as gf

DT = 0.1
TAU_Y = 1.0 / 11.0
CONSTANT_BIAS = [0.1, 0.1, 0.1, 0.1]  # f_csi, Table 3
INCREASING_BIAS = [0.1, 0.3, 0.7, 0.9]  # f_rsi, Table 4


def satellite_model(nullspace: str = "structured") -> gf.WindowModel:
    """Model (24) of Li, Wang & Liu 2015 as a :class:`geomfdi.WindowModel` (window n + 1 = 4)."""
    A = [[1.0, -DT, -DT], [0.0, 1.0 - DT / TAU_Y, 0.0], [0.0, 0.0, 1.0]]
    B = DT * np.eye(3)
    C = [[1.0, 0.0, 0.0]]
    Bf = [[DT, 0.0], [0.0, 0.0], [0.0, 0.0]]
    Df = [[0.0, 1.0]]
    return gf.WindowModel(
        A,
        B,
        C,
        Bf=Bf,
        Df=Df,
        Bw=np.eye(3),
        Dv=[[1.0]],
        Qw=[1e-6, 1e-5, 1e-4],  # n_y (on theta), n_dy (on d_y), n_by (on b_y)
        Rv=1e-4,  # n_theta
        fault_names=["f_gy", "f_htheta"],
        nullspace=nullspace,
    )


def main(argv: Sequence[str] | None = None) -> dict[str, gf.DiagnosabilityTable]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=".", help="directory for the PNG (default: .)")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    dm = satellite_model()
    print(dm, f"residual dimension d = {dm.residual_dim}")
    print("\nApplicability of the KL method (Theorems 1-2):")
    print(dm.applicability(CONSTANT_BIAS))

    tables: dict[str, gf.DiagnosabilityTable] = {}
    for label, theta in (("Table 3", CONSTANT_BIAS), ("Table 4", INCREASING_BIAS)):
        for method, opts in (
            ("directional", {"cosine": "signed"}),
            ("directional", {"cosine": "absolute"}),
            ("kl", {}),
            ("probability_index", {"alpha": 0.01}),
        ):
            tab = dm.table(theta, method, **opts)
            key = f"{label} {method} {' '.join(f'{k}={v}' for k, v in opts.items())}".strip()
            tables[key] = tab
            print(f"\n{key} (theta = {theta}):")
            print(tab)

    fig = gf.plot_isolability(
        tables["Table 4 directional cosine=signed"],
        title="Satellite (24), increasing bias: directional FI (signed cosine)",
    )
    path = out / "diagnosability_satellite_isolability.png"
    fig.savefig(path, dpi=120, bbox_inches="tight")
    print(f"\nsaved {path}")
    return tables


if __name__ == "__main__":
    main()
