"""The ``geomfdi`` command: design, verify and simulate residual banks from a model file.

``geomfdi run MODEL.toml`` designs a bank for every method of the file, verifies it
numerically (and exactly with sympy for small plants), simulates every scenario and
writes ``report.md``, ``summary.json`` and PNG figures to the working directory (or
``--out DIR``).  ``design``, ``verify`` and ``simulate`` run the first steps only;
``design --json`` prints the designed generators.  A bad model file gives a one-line
error and exit code 2; an unexpected internal error a one-line error and exit code 1
(``--traceback`` shows the Python traceback instead).

The report has one table per design (order, faults seen, diagnostics), a verification
table (numerical leakage and, for plants with at most ``SYMBOLIC_MAX_N`` states, the
exact sympy check), the thresholds and, per scenario and method, ``max |r|`` per residual,
the false-alarm rate before the first onset and the detection and isolation delay of
every fault; the figures are the achieved structure matrices and the residual traces.
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

from geomfdi.errors import GeomFDIError
from geomfdi.io.modelfile import ModelSpec, load_model
from geomfdi.synthesis.generator import ResidualBank

__all__ = ["main", "design_all", "run_model"]

SYMBOLIC_MAX_N = 10


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-") or "scenario"


def _with_context(exc: GeomFDIError, where: str) -> GeomFDIError:
    """The same kind of error with ``where`` (file and entry) in front of its message."""
    try:
        return type(exc)(f"{where}: {exc}", argument=exc.argument)
    except TypeError:  # a subclass with another signature
        return GeomFDIError(f"{where}: {exc}", argument=exc.argument)


def design_all(spec: ModelSpec) -> dict[str, ResidualBank]:
    """One bank per method of the model file (normalised as requested)."""
    from geomfdi.synthesis.design import design_bank

    banks = {}
    for opt in spec.methods:
        where = f"{spec.source}: design.{opt.method}"
        try:
            bank = design_bank(
                spec.plant,
                spec.faults,
                spec.structure,
                poles=opt.poles,
                method=opt.method,
                filter_pole=opt.filter_pole,
                margin=opt.margin,
            )
        except GeomFDIError as exc:
            raise _with_context(exc, where) from exc
        if opt.normalize:
            try:
                bank = bank.normalized(opt.normalize)
            except GeomFDIError as exc:
                raise GeomFDIError(
                    f"{where}.normalize = {opt.normalize!r}: {exc}", argument="normalize"
                ) from exc
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
    from geomfdi.verification import verify, verify_symbolic

    rep = verify(bank, spec.plant)
    out: dict[str, Any] = {
        "ok": bool(rep.ok),
        "complete": bool(rep.complete),
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
    """The decision threshold of one bank: fixed, or calibrated on noise-only runs."""
    th = spec.threshold
    if isinstance(th, dict):
        from geomfdi.evaluation.decision import calibrate_threshold
        from geomfdi.simulation.simulate import Noise

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
            d=spec.d,
            controller=spec.K,
            x0=spec.x0,
        )
    return th


def _threshold_values(th: Any, rows: int) -> list[float | None] | None:
    """Per-row threshold values (None for a disabled row), or None without a threshold."""
    if th is None:
        return None
    values = np.broadcast_to(np.asarray(getattr(th, "values", th), dtype=float), (rows,))
    return [float(x) if np.isfinite(x) else None for x in values]


def _events(res: Any) -> list[dict[str, Any]]:
    """``res.summary_rows()`` with the expressions of time-varying faults in the labels."""
    rows = res.summary_rows()
    for row, ev in zip(rows, res.events, strict=True):
        for key in ("gain", "bias"):
            expr = getattr(getattr(ev.fault, key, None), "expression", None)
            if expr is not None:
                row["fault"] = row["fault"].replace(f"{key} f(t)", f"{key} {expr}", 1)
    return rows


def _unique_names(spec: ModelSpec) -> list[str]:
    """File-name stems of the scenarios, made unique when two names give the same slug."""
    seen: dict[str, int] = {}
    out = []
    for sc in spec.scenarios:
        base = _slug(sc.name)
        seen[base] = seen.get(base, 0) + 1
        out.append(base if seen[base] == 1 else f"{base}-{seen[base]}")
    return out


def _simulate(
    spec: ModelSpec,
    banks: dict[str, ResidualBank],
    out: Path | None,
    plots: bool,
    progress: bool,
    thresholds: dict[str, Any],
) -> list[dict[str, Any]]:
    from tqdm.auto import tqdm

    from geomfdi.plotting.residuals import save_png
    from geomfdi.simulation.simulate import Noise, simulate

    rows = []
    stems = dict(zip((id(sc) for sc in spec.scenarios), _unique_names(spec), strict=True))
    jobs = [(sc, m) for sc in spec.scenarios for m in banks]
    for sc, method in tqdm(jobs, desc="simulating", disable=not progress, leave=False):
        bank = banks[method]
        if not bank.present:
            continue
        if method not in thresholds:
            try:
                thresholds[method] = _threshold(spec, bank)
            except GeomFDIError as exc:
                raise _with_context(exc, f"{spec.source}: simulation.threshold ({method})") from exc
        noise_kw = sc.noise if sc.noise is not None else spec.noise
        try:
            res = simulate(
                spec.plant,
                bank,
                spec.t,
                spec.u,
                faults=sc.faults,
                x0=spec.x0,
                noise=Noise(**noise_kw) if noise_kw else None,
                controller=spec.K,
                threshold=thresholds[method],
                d=sc.d if sc.d is not None else spec.d,
                progress=False,
            )
        except GeomFDIError as exc:
            raise _with_context(exc, f"{spec.source}: scenario {sc.name!r} ({method})") from exc
        start, stop = spec.window if spec.window else (None, None)
        if start is None and res.onsets:
            start = min(res.onsets)
        peaks = res.max_abs(start, stop)
        row = {
            "scenario": sc.name,
            "method": method,
            "max_abs": [float(x) for x in peaks],
            "window": [start, stop],
            "threshold": _threshold_values(res.threshold, res.residuals.shape[0]),
            "alarms": bool(res.alarms.any()),
            "events": _events(res),
            "false_alarm_rate": res.false_alarm_rate,
            "final_isolation": int(res.isolated[-1]) if res.isolated.size else None,
        }
        if plots and out is not None:
            fig = res.plot(title=f"{sc.name} — {method}")
            png = save_png(fig, out / f"residuals_{stems[id(sc)]}_{method}.png")
            row["figure"] = png.name
            import matplotlib.pyplot as plt

            plt.close(fig)
        rows.append(row)
    return rows


def _delay(x: float | None) -> str:
    return "no" if x is None else f"after {x:.3g} s"


def _sim_table(rows: list[dict[str, Any]], thresholds: dict[str, Any]) -> list[str]:
    lines = ["### Simulation", ""]
    for method, th in thresholds.items():
        values = _threshold_values(th, len(rows[0]["max_abs"])) if rows else None
        if values is not None:
            how = getattr(th, "source", "fixed")
            text = ", ".join("-" if v is None else f"{v:.3g}" for v in values)
            lines.append(f"Threshold ({method}): {text}; {how}.")
    lines += [
        "",
        "| scenario | method | max abs(r) per residual | false-alarm rate | fault | "
        "detected | isolated |",
        "|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        peaks = ", ".join(f"{x:.3g}" for x in row["max_abs"])
        far = "-" if row["false_alarm_rate"] is None else f"{row['false_alarm_rate']:.3g}"
        head = f"| {row['scenario']} | {row['method']} | {peaks} | {far} |"
        if not row["events"]:
            alarm = "alarm" if row["alarms"] else "no alarm"
            lines.append(f"{head} none ({alarm}) | - | - |")
        for k, e in enumerate(row["events"]):
            prefix = head if k == 0 else "| | | | |"
            lines.append(
                f"{prefix} {e['fault']} | {_delay(e['detection_delay'])} | "
                f"{_delay(e['isolation_delay'])} |"
            )
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
    figures: list[tuple[str, str]] = []
    if out is not None and plots:
        import matplotlib.pyplot as plt

        from geomfdi.plotting.residuals import plot_structure, save_png

        out.mkdir(parents=True, exist_ok=True)
        for m, b in banks.items():
            fig = plot_structure(b, title=f"structure — {m}")
            png = save_png(fig, out / f"structure_{m}.png")
            figures.append((f"achieved structure — {m}", png.name))
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
        thresholds: dict[str, Any] = {}
        rows = _simulate(spec, banks, out, plots, progress, thresholds)
        summary["simulation"] = rows
        summary["thresholds"] = {
            m: _threshold_values(th, banks[m].structure.shape[0]) for m, th in thresholds.items()
        }
        lines += _sim_table(rows, thresholds)
        figures += [
            (f"{r['scenario']} — {r['method']}", r["figure"]) for r in rows if "figure" in r
        ]
    if figures:
        lines += ["### Figures", ""]
        lines += [f"![{caption}]({name})" for caption, name in figures]
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
        sp.add_argument(
            "--traceback",
            action="store_true",
            help="on an unexpected internal error, show the Python traceback",
        )
    _campaign_parser(sub)
    return p


# ------------------------------------------------------------------- geomfdi campaign
def _campaign_parser(sub: Any) -> None:
    text = "Monte-Carlo campaign of the [campaign] table: tables, summary, ROC and P_d figures"
    sp = sub.add_parser("campaign", help=text, description=text)
    sp.add_argument("model", help="model file (TOML) with a [campaign] table")
    sp.add_argument("--out", type=Path, default=Path("campaign_out"), help="output directory")
    sp.add_argument("--runs", type=int, default=None, help="override campaign.runs")
    sp.add_argument(
        "--executor",
        choices=("serial", "processes", "dask"),
        default="serial",
        help="where the blocks run (dask: a LocalCluster, or --scheduler)",
    )
    sp.add_argument("--workers", type=int, default=2, help="processes or Dask workers")
    sp.add_argument("--scheduler", default=None, help="address of a running Dask scheduler")
    sp.add_argument("--no-plots", action="store_true", help="do not write PNG figures")
    sp.add_argument("--quiet", action="store_true", help="print nothing but errors")
    sp.add_argument("--traceback", action="store_true", help="show internal tracebacks")


def load_campaign(path: str | Path, *, runs: int | None = None) -> Any:
    """Design the banks of a model file and build its ``[campaign]`` (a CampaignConfig)."""
    from geomfdi.campaign.config import build_campaign, read_campaign

    camp, spec = read_campaign(path)
    return build_campaign(camp, spec, design_all(spec), runs=runs)


def campaign_command(args: argparse.Namespace) -> int:
    """``geomfdi campaign MODEL.toml``: run, write CSV tables and PNGs, print the summary."""
    from geomfdi.campaign.config import write_outputs

    try:
        if args.runs is not None and args.runs < 1:
            raise GeomFDIError("--runs: must be >= 1", argument="runs")
        cfg = load_campaign(args.model, runs=args.runs)
        progress = sys.stderr.isatty() and not args.quiet
        if args.executor == "dask":
            from distributed import Client, LocalCluster

            if args.scheduler:
                with Client(args.scheduler) as client:
                    result = cfg.campaign.run(client, progress=progress)
            else:
                with (
                    LocalCluster(n_workers=args.workers, dashboard_address=None) as cluster,
                    Client(cluster) as client,
                ):
                    result = cfg.campaign.run(client, progress=progress)
        else:
            result = cfg.campaign.run(args.executor, workers=args.workers, progress=progress)
        files = write_outputs(result, args.out, plots=not args.no_plots, name=cfg.spec.name)
    except (GeomFDIError, OSError) as exc:
        print(f"geomfdi: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except ImportError as exc:
        print(f"geomfdi: error: {_one_line(exc)} (install geomfdi[dask])", file=sys.stderr)
        return 2
    except Exception as exc:
        if args.traceback:
            raise
        print(
            f"geomfdi: error: internal error {type(exc).__name__}: {_one_line(exc)} "
            "(rerun with --traceback for details)",
            file=sys.stderr,
        )
        return 1
    if not args.quiet:
        import pandas as pd

        c = cfg.campaign
        print(
            f"campaign: {cfg.spec.name}, bank {cfg.method!r}, test {result.info['test']}, "
            f"{len(c.grid()['run'])} runs x {c.t.size} samples, {len(c.plants)} model(s)"
        )
        with pd.option_context("display.width", 120, "display.max_rows", 200):
            print(result.summary().xs("bank", level="residual").round(4).to_string())
        print("written: " + ", ".join(str(f) for f in files))
    return 0


# ------------------------------------------------------------------------------------
def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``geomfdi`` console script; returns the exit code.

    Exit codes: 0 success; 2 bad command line, unreadable or invalid model file, or a
    design/simulation the model does not allow (one line ``geomfdi: error: ...`` on
    stderr); 1 an unexpected internal error (one line, or the traceback with
    ``--traceback``).  After a successful run, warnings are printed as
    ``geomfdi: warning: ...`` lines unless ``--quiet``.
    """
    args = _parser().parse_args(argv)
    if args.command == "campaign":
        return campaign_command(args)
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
        with warnings.catch_warnings(record=True) as caught:
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
        print(f"geomfdi: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"geomfdi: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except Exception as exc:  # an internal error: one line unless asked for the traceback
        if args.traceback:
            raise
        print(
            f"geomfdi: error: internal error {type(exc).__name__}: {_one_line(exc)} "
            "(rerun with --traceback for details)",
            file=sys.stderr,
        )
        return 1
    if not args.quiet:
        shown = set()
        for w in caught:
            line = f"geomfdi: warning: {w.category.__name__}: {_one_line(w.message)}"
            if line not in shown:
                shown.add(line)
                print(line, file=sys.stderr)
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
