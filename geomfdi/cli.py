"""The ``geomfdi`` command: design, verify and simulate residual banks from a model file.

``geomfdi run MODEL.toml`` designs a bank for every method of the file, verifies it
numerically (and exactly with sympy for small plants), simulates every scenario and
writes ``report.md``, ``summary.json`` and PNG figures to the working directory (or
``--out DIR``).  ``design``, ``verify`` and ``simulate`` run the first steps only;
``design --json`` prints the designed generators.  A bad model file gives a one-line
error and exit code 2.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .errors import GeomFDIError
from .generator import ResidualBank
from .modelfile import ModelSpec, load_model

__all__ = ["main", "design_all", "run_model"]

SYMBOLIC_MAX_N = 10


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-") or "scenario"


def design_all(spec: ModelSpec) -> dict[str, ResidualBank]:
    """One bank per method of the model file (normalised as requested)."""
    from .synthesis import design_bank

    banks = {}
    for opt in spec.methods:
        bank = design_bank(
            spec.plant,
            spec.faults,
            spec.structure,
            poles=opt.poles,
            method=opt.method,
            filter_pole=opt.filter_pole,
            margin=opt.margin,
        )
        if opt.normalize:
            bank = bank.normalized(opt.normalize)
        banks[opt.method] = bank
    return banks


def _bank_json(bank: ResidualBank) -> dict[str, Any]:
    gens = []
    for r, g in enumerate(bank.generators):
        if g is None:
            gens.append({"row": r, "exists": False, "diagnostic": bank.diagnostics[r]})
            continue
        gens.append(
            {
                "row": r,
                "exists": True,
                "order": g.order,
                "target": list(g.target),
                "decoupled": list(g.decoupled),
                "diagnostic": bank.diagnostics[r],
                "dt": g.dt,
                "poles": [[float(p.real), float(p.imag)] for p in g.poles],
                **{k: getattr(g, k).tolist() for k in "FEGMHK"},
            }
        )
    return {
        "method": bank.method,
        "requested": bank.requested.astype(int).tolist(),
        "structure": bank.structure.astype(int).tolist(),
        "isolable": bank.isolable.tolist(),
        "generators": gens,
    }


def _design_table(name: str, bank: ResidualBank) -> list[str]:
    lines = [f"### Design: {name}", "", "| row | order | sees | diagnostic |", "|---|---|---|---|"]
    for r, g in enumerate(bank.generators):
        sees = ", ".join(str(j) for j in np.flatnonzero(bank.structure[r])) or "-"
        order = "-" if g is None else str(g.order)
        lines.append(f"| r{r} | {order} | {sees} | {bank.diagnostics[r]} |")
    lines.append("")
    lines.append(f"isolable faults: {np.flatnonzero(bank.isolable).tolist()}")
    lines.append("")
    return lines


def _verify(spec: ModelSpec, bank: ResidualBank, symbolic: bool) -> dict[str, Any]:
    from .verification import verify, verify_symbolic

    rep = verify(bank, spec.plant)
    out: dict[str, Any] = {
        "ok": bool(rep.ok),
        "max_leakage": float(np.max(rep.leakage, initial=0.0)),
        "max_input_leakage": float(np.max(rep.input_leakage, initial=0.0)),
        "missing_rows": rep.missing,
        "details": rep.details,
    }
    if symbolic and spec.plant.n <= SYMBOLIC_MAX_N and bank.present:
        sym = verify_symbolic(bank, spec.plant)
        out["symbolic_ok"] = bool(sym.ok)
        out["symbolic_transfer"] = [
            [str(x) for x in sym.transfer.row(i)] for i in range(sym.transfer.rows)
        ]
    return out


def _threshold(spec: ModelSpec, bank: ResidualBank) -> Any:
    th = spec.threshold
    if isinstance(th, dict):
        from .decision import calibrate_threshold
        from .simulation import Noise

        if not spec.noise:
            raise GeomFDIError(
                "simulation.threshold: calibration needs [simulation.noise]", argument="threshold"
            )
        return calibrate_threshold(
            spec.plant,
            bank,
            spec.t,
            noise=Noise(**spec.noise),
            false_alarm_rate=th["false_alarm_rate"],
            runs=th["runs"],
            u=spec.u,
            controller=spec.K,
            x0=spec.x0,
        )
    return th


def _simulate(
    spec: ModelSpec, banks: dict[str, ResidualBank], out: Path | None, plots: bool, progress: bool
) -> list[dict[str, Any]]:
    from tqdm.auto import tqdm

    from .plotting import save_png
    from .simulation import Noise, simulate

    rows = []
    jobs = [(sc, m) for sc in spec.scenarios for m in banks]
    for sc, method in tqdm(jobs, desc="simulating", disable=not progress, leave=False):
        bank = banks[method]
        if not bank.present:
            continue
        noise_kw = sc.noise if sc.noise is not None else spec.noise
        res = simulate(
            spec.plant,
            bank,
            spec.t,
            spec.u,
            faults=sc.faults,
            x0=spec.x0,
            noise=Noise(**noise_kw) if noise_kw else None,
            controller=spec.K,
            threshold=_threshold(spec, bank),
            progress=False,
        )
        start, stop = spec.window if spec.window else (None, None)
        if start is None and res.onsets:
            start = min(res.onsets)
        peaks = res.max_abs(start, stop)
        row = {
            "scenario": sc.name,
            "method": method,
            "max_abs": [float(x) for x in peaks],
            "window": [start, stop],
            "events": res.summary_rows(),
            "false_alarm_rate": res.false_alarm_rate,
            "final_isolation": int(res.isolated[-1]) if res.isolated.size else None,
        }
        if plots and out is not None:
            fig = res.plot(title=f"{sc.name} — {method}")
            png = save_png(fig, out / f"residuals_{_slug(sc.name)}_{method}.png")
            row["figure"] = png.name
            import matplotlib.pyplot as plt

            plt.close(fig)
        rows.append(row)
    return rows


def _sim_table(rows: list[dict[str, Any]]) -> list[str]:
    lines = [
        "### Simulation",
        "",
        "| scenario | method | max abs(r) per residual | detected (delay) | isolated (delay) |",
        "|---|---|---|---|---|",
    ]
    for row in rows:
        peaks = ", ".join(f"{x:.3g}" for x in row["max_abs"])
        det = (
            "; ".join(
                "-" if e["detection_delay"] is None else f"{e['detection_delay']:.3g} s"
                for e in row["events"]
            )
            or "-"
        )
        iso = (
            "; ".join(
                "-" if e["isolation_delay"] is None else f"{e['isolation_delay']:.3g} s"
                for e in row["events"]
            )
            or "-"
        )
        lines.append(f"| {row['scenario']} | {row['method']} | {peaks} | {det} | {iso} |")
    lines.append("")
    return lines


def run_model(
    spec: ModelSpec,
    *,
    out: Path | None,
    steps: Sequence[str] = ("design", "verify", "simulate"),
    plots: bool = True,
    symbolic: bool = True,
    progress: bool = False,
) -> dict[str, Any]:
    """Design, verify and simulate ``spec``; write the report into ``out``."""
    banks = design_all(spec)
    summary: dict[str, Any] = {
        "model": spec.name,
        "source": spec.source,
        "plant": {"n": spec.plant.n, "m": spec.plant.m, "q": spec.plant.q, "dt": spec.plant.dt},
        "design": {m: _bank_json(b) for m, b in banks.items()},
    }
    lines = [
        f"# geomfdi report: {spec.name}",
        "",
        f"Plant: n = {spec.plant.n}, m = {spec.plant.m}, q = {spec.plant.q}, "
        + (f"dt = {spec.plant.dt:g}." if spec.plant.dt else "continuous time."),
        "",
    ]
    for m, b in banks.items():
        lines += _design_table(m, b)
    if out is not None and plots:
        import matplotlib.pyplot as plt

        from .plotting import plot_structure, save_png

        for m, b in banks.items():
            fig = plot_structure(b, title=f"structure — {m}")
            save_png(fig, out / f"structure_{m}.png")
            plt.close(fig)
    if "verify" in steps:
        summary["verification"] = {m: _verify(spec, b, symbolic) for m, b in banks.items()}
        lines += [
            "### Verification",
            "",
            "| method | ok | max leakage | max input leakage | exact proof |",
            "|---|---|---|---|---|",
        ]
        for m, v in summary["verification"].items():
            sym = {True: "zeros exact", False: "fails", None: "-"}[v.get("symbolic_ok")]
            lines.append(
                f"| {m} | {v['ok']} | {v['max_leakage']:.3g} | "
                f"{v['max_input_leakage']:.3g} | {sym} |"
            )
        lines.append("")
    if "simulate" in steps and spec.scenarios:
        rows = _simulate(spec, banks, out, plots, progress)
        summary["simulation"] = rows
        lines += _sim_table(rows)
        if plots and out is not None:
            lines += ["### Figures", ""]
            lines += [
                f"![{r['scenario']} — {r['method']}]({r['figure']})" for r in rows if "figure" in r
            ]
            lines.append("")
    summary["report"] = "\n".join(lines)
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        (out / "report.md").write_text(summary["report"] + "\n", encoding="utf-8")
        (out / "summary.json").write_text(
            json.dumps(
                {k: v for k, v in summary.items() if k != "report"}, indent=2, default=_json_default
            ),
            encoding="utf-8",
        )
    return summary


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return str(obj)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="geomfdi",
        description="Design, verify and simulate fault detection and isolation residual "
        "banks from a TOML model file.",
    )
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    helps = {
        "run": "design, verify and simulate; write report.md, summary.json and PNGs",
        "design": "design the residual banks and print their structure",
        "verify": "design and verify (numerically, and exactly for small plants)",
        "simulate": "design and simulate the scenarios",
    }
    for name, text in helps.items():
        sp = sub.add_parser(name, help=text, description=text)
        sp.add_argument("model", help="model file (TOML)")
        sp.add_argument(
            "--out",
            type=Path,
            default=None,
            help="output directory (default: the working directory for run)",
        )
        sp.add_argument(
            "--json",
            action="store_true",
            help="print the result (designed generators, checks) as JSON",
        )
        sp.add_argument("--no-plots", action="store_true", help="do not write PNG figures")
        sp.add_argument(
            "--no-symbolic", action="store_true", help="skip the exact (sympy) verification"
        )
        sp.add_argument("--quiet", action="store_true", help="print nothing but errors")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``geomfdi`` console script; returns the exit code."""
    args = _parser().parse_args(argv)
    steps = {
        "design": ("design",),
        "verify": ("design", "verify"),
        "simulate": ("design", "simulate"),
        "run": ("design", "verify", "simulate"),
    }
    out = args.out
    if out is None and args.command in ("run", "simulate"):
        out = Path.cwd()
    try:
        spec = load_model(args.model)
        if out is not None:
            out.mkdir(parents=True, exist_ok=True)
        with warnings.catch_warnings():
            warnings.simplefilter("default")
            summary = run_model(
                spec,
                out=out,
                steps=steps[args.command],
                plots=not args.no_plots,
                symbolic=not args.no_symbolic,
                progress=sys.stderr.isatty() and not args.quiet,
            )
    except GeomFDIError as exc:
        msg = " ".join(str(exc).split())
        print(f"geomfdi: error: {msg}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"geomfdi: error: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print(
            json.dumps(
                {k: v for k, v in summary.items() if k != "report"}, indent=2, default=_json_default
            )
        )
    elif not args.quiet:
        print(summary["report"])
        if out is not None and args.command in ("run", "simulate"):
            print(f"\nwritten to {out}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
