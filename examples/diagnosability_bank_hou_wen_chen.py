"""Diagnosability of two residual banks for the sensor faults of Hou, Wen & Chen (2011).

The exact bank and the paper's bank are compared by the same KL indices (per unit step
fault, sensor noise variance 0.01, sampling 0.1 s):

* the joint indices of the whole residual vector -- the best test using every residual
  with its exact transfers, leaks included -- and, for reference, those of the raw
  outputs ``r = y`` (the plant's own diagnosability);
* the structured indices: fault ``i`` against fault ``j`` on the residuals designed to
  see ``i`` and ignore ``j``, which is how a structured decision isolates.

The paper bank keeps more of the output information (its joint indices are close to the
raw outputs'), but its residuals 2 and 3 leak the other sensors: on them ``FI = 0``.  See
the user guide, *Theory: diagnosability* (``docs/theory/diagnosability.md``).

Run:  python examples/diagnosability_bank_hou_wen_chen.py [--window 40]
"""

from __future__ import annotations

import argparse
from types import SimpleNamespace

import numpy as np

import geomfdi as gf

A = [[1, 1, 1], [0, 1, 0], [2, 0, 1]]
B = [[1, 0, 1], [0, 1, 1], [0, 1, 0]]
C = [[0, 1, 0], [0, 0, 1], [1, 0, 2]]
NOISE, DT = 0.01, 0.1


def _raw_outputs_bank(faults) -> SimpleNamespace:
    """A 'bank' whose residual is the measured output itself (order 0)."""
    gen = SimpleNamespace(
        F=np.zeros((0, 0)), E=np.zeros((0, 3)), M=np.zeros((3, 0)), H=-np.eye(3), order=0
    )
    return SimpleNamespace(
        generators=[gen], dt=0.0, faults=faults, structure=np.ones((1, 3), dtype=bool)
    )


def _print_joint(name: str, d) -> None:
    print(f"  {name:<12} residual dim {d.model.residual_dim}")
    for i, row in enumerate(d.kl.values):
        cells = "".join(f"{v:10.1f}" if k != i + 1 else f"{'-':>10}" for k, v in enumerate(row))
        print(f"    s{i + 1}{cells}")


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--window", type=int, default=40, help="window length in samples")
    args = ap.parse_args(argv)
    plant = gf.Plant(A, B, C)
    banks = {m: gf.design_sensor_bank(plant, method=m) for m in ("exact", "paper")}
    opts = {"measurement_noise": NOISE, "dt": DT, "window": args.window}
    joint = {m: gf.bank_diagnosability(b, plant, **opts) for m, b in banks.items()}
    joint["raw outputs"] = gf.bank_diagnosability(
        _raw_outputs_bank(banks["exact"].faults), plant, **opts
    )
    print(f"joint KL indices, window {args.window} (columns: FD, FI vs s1, s2, s3)")
    for name, d in joint.items():
        _print_joint(name, d)
    structured = {m: gf.bank_structured_isolability(b, plant, **opts) for m, b in banks.items()}
    pairs = [(i, j) for i in range(3) for j in range(3) if i != j]
    print("structured KL indices on the residuals designed to see s_i and ignore s_j")
    print("  pair        " + "".join(f"  (s{i + 1},s{j + 1})" for i, j in pairs))
    for name, s in structured.items():
        print(f"  {name + ' FD':<12}" + "".join(f"{s.fd[i, j]:10.1f}" for i, j in pairs))
        print(f"  {name + ' FI':<12}" + "".join(f"{s.fi[i, j]:10.1f}" for i, j in pairs))
    return {"joint": joint, "structured": structured}


if __name__ == "__main__":
    main()
