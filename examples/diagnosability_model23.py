"""Diagnosability of model (23) of Li, Wang & Liu 2015.

Model (23) is example 1 of Eriksson, Frisk & Krysander 2013.

::

    x1(k+1) = x1(k) + x2(k)
    x2(k+1) = -x1(k) + x2(k) + u(k) + f1(k) + f2(k) + w(k)
    y1(k)   = x1(k) + f3(k) + v1(k)
    y2(k)   = x1(k) + f4(k) + v2(k)

``w ~ N(0, 0.1)``, ``v1 ~ N(0, 1)``, ``v2 ~ N(0, 0.5)``, window 3, constant profile
``[1, 1, 1]``.  Prints Table 1 (KL), Table 2 (directional, absolute cosine), the
probability-based table, the applicability report, and saves heat maps of the KL and
directional isolability.

Run ``python examples/diagnosability_model23.py --out DIR``.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

try:
    import geomfdi as gf
except ImportError:  # running from a source checkout without installation
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    import geomfdi as gf

THETA = [1.0, 1.0, 1.0]


def model23(nullspace: str = "structured") -> gf.WindowModel:
    """Model (23) of Li, Wang & Liu 2015 as a :class:`geomfdi.WindowModel`."""
    return gf.WindowModel(
        [[1.0, 1.0], [-1.0, 1.0]],
        [[0.0], [1.0]],
        [[1.0, 0.0], [1.0, 0.0]],
        Bf=[[0.0, 0.0, 0.0, 0.0], [1.0, 1.0, 0.0, 0.0]],
        Df=[[0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]],
        Bw=[[0.0], [1.0]],
        Dv=[[1.0, 0.0], [0.0, 1.0]],
        Qw=0.1,
        Rv=[1.0, 0.5],
        nullspace=nullspace,
    )


def main(argv: Sequence[str] | None = None) -> dict[str, gf.DiagnosabilityTable]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=".", help="directory for the PNGs (default: .)")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    dm = model23()
    print(dm, f"residual dimension d = {dm.residual_dim}")
    tables = {
        "Table 1 (KL)": dm.table(THETA, "kl"),
        "Table 2 (directional, |cos|)": dm.table(THETA, "directional"),
        "directional, signed cos": dm.table(THETA, "directional", cosine="signed"),
        "detection / isolation probability, alpha = 0.01": dm.table(THETA, "probability"),
    }
    for key, tab in tables.items():
        print(f"\n{key}:")
        print(tab)
    print("\nApplicability of the KL method (Theorems 1-2):")
    print(dm.applicability(THETA))

    for key, stem in (("Table 1 (KL)", "kl"), ("Table 2 (directional, |cos|)", "directional")):
        fig = gf.plot_isolability(tables[key], title=f"Model (23): {key}")
        path = out / f"diagnosability_model23_{stem}.png"
        fig.savefig(path, dpi=120, bbox_inches="tight")
        print(f"saved {path}")
    return tables


if __name__ == "__main__":
    main()
