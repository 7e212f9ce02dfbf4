"""The ``geomfdi`` command: design, verify and simulate residual banks from a model file.

``geomfdi run MODEL.toml`` designs a bank for every method of the file, verifies it
numerically (and exactly with sympy for small plants), simulates every scenario and
writes ``report.md``, ``summary.json`` and PNG figures to the working directory (or
``--out DIR``).  ``design``, ``verify`` and ``simulate`` run the first steps only;
``design --json`` prints the designed generators.  A bad model file gives a one-line
error and exit code 2; an unexpected internal error a one-line error and exit code 1
(``--traceback`` shows the Python traceback instead).

Progress goes to stderr as plain ``geomfdi: ...`` lines (shown when stderr is a terminal,
or with ``--progress``; never with ``--quiet``).  The PNG figures are drawn in worker
processes while the simulations run, from traces decimated to the minimum and maximum of
each pixel column (peaks are kept); ``--no-plots`` skips them.  Sensors, inputs, faults
and residuals are numbered from 0, as in the Python API and the model files.

The report has one table per design (order, faults seen, diagnostics), a verification
table (numerical leakage and, for plants with at most ``SYMBOLIC_MAX_N`` states, the
exact sympy check), the thresholds and, per scenario and method, ``max |r|`` per residual,
the false-alarm rate before the first onset and the detection and isolation delay of
every fault; the figures are the achieved structure matrices and the residual traces.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from geomfdi._files import write_text
from geomfdi.errors import GeomFDIError
from geomfdi.io.figures import (
    _draw_residuals,
    _draw_structure,
    _Figures,
    _residual_figure_args,
    _structure_figure_args,
    decimate_minmax,
)

if TYPE_CHECKING:
    from geomfdi.generators.generator import ResidualBank
    from geomfdi.io.modelfile import ModelSpec
    from geomfdi.model.plant import Plant

# The model file reader, the report and the design stack are imported where they are
# used: ``geomfdi run`` starts its figure worker first, which then loads matplotlib
# while this process loads them (see :func:`main`).

__all__ = ["main", "design_all", "run_model", "check_outputs", "decimate_minmax"]

SYMBOLIC_MAX_N = 10

MAX_STEM = 80
"""Longest file-name stem taken from a scenario name (longer names are shortened)."""


def _slug(text: str) -> str:
    slug = re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")[:MAX_STEM].strip("-")
    return slug or "scenario"


def _say(enabled: bool) -> Callable[[str], None]:
    """A progress printer: ``geomfdi: <text>`` lines on stderr, or nothing."""

    def say(text: str) -> None:
        if enabled:
            print(f"geomfdi: {text}", file=sys.stderr, flush=True)

    return say


def _with_context(exc: GeomFDIError, where: str) -> GeomFDIError:
    """The same kind of error with ``where`` (file and entry) in front of its message."""
    try:
        return type(exc)(f"{where}: {exc}", argument=exc.argument)
    except TypeError:  # a subclass with another signature
        return GeomFDIError(f"{where}: {exc}", argument=exc.argument)


def _row_options(opt: Any) -> dict[str, Any]:
    """``residual_dim`` and ``common_poles`` of a method, only where the file sets them."""
    out: dict[str, Any] = {}
    if opt.residual_dim is not None:
        out["residual_dim"] = opt.residual_dim
    if opt.common_poles:
        out["common_poles"] = True
    return out


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
                **_row_options(opt),
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


def _verify(plant: Plant, bank: ResidualBank, symbolic: bool) -> dict[str, Any]:
    from geomfdi.verification import verify, verify_symbolic

    rep = verify(bank, plant)
    out: dict[str, Any] = {
        "ok": bool(rep.ok),
        "complete": bool(rep.complete),
        "max_leakage": float(np.max(rep.leakage, initial=0.0)),
        "max_input_leakage": float(np.max(rep.input_leakage, initial=0.0)),
        "missing_rows": rep.missing,
        "details": rep.details,
    }
    if symbolic and plant.n <= SYMBOLIC_MAX_N and bank.present:
        sym = verify_symbolic(bank, plant)
        out["symbolic_ok"] = bool(sym.ok)
        out["symbolic_summary"] = sym.summary()
        out["symbolic_rounding_level"] = float(sym.rounding_level)
        out["symbolic_transfer"] = [
            [str(x) for x in sym.transfer.row(i)] for i in range(sym.transfer.rows)
        ]
    return out


def _threshold(spec: ModelSpec, bank: ResidualBank) -> Any:
    """The decision threshold of one bank: fixed, or calibrated on noise-only runs."""
    th = spec.threshold
    if isinstance(th, dict):
        from geomfdi.simulation.calibration import calibrate_threshold
        from geomfdi.simulation.noise import Noise

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


def check_outputs(
    spec: ModelSpec, out: Path, methods: Sequence[str], *, plots: bool = True
) -> None:
    """Check, before any work, that every file of a run can be created in ``out``.

    The directory is created if needed and must be writable; every file name (report,
    summary, figures named after the scenarios) must fit the file system's limit.

    Raises
    ------
    GeomFDIError
        Naming the directory or the file (argument ``out``).
    """
    names = ["report.md", "summary.json"]
    if plots:
        names += [f"structure_{m}.png" for m in methods]
        names += [f"residuals_{stem}_{m}.png" for stem in _unique_names(spec) for m in methods]
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise GeomFDIError(
            f"--out {out}: cannot create the directory ({exc.strerror or exc})", argument="out"
        ) from exc
    try:
        limit = os.pathconf(out, "PC_NAME_MAX")
    except (OSError, ValueError, AttributeError):
        limit = 255
    for name in names:
        if len(os.fsencode(name)) > limit:
            raise GeomFDIError(
                f"--out {out}: file name {name!r} longer than {limit} bytes", argument="out"
            )
    if not os.access(out, os.W_OK | os.X_OK):
        raise GeomFDIError(f"--out {out}: the directory is not writable", argument="out")


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
    figures: _Figures | None = None,
) -> list[dict[str, Any]]:
    from geomfdi.io.report import _events, _threshold_values
    from geomfdi.simulation.noise import Noise
    from geomfdi.simulation.simulate import simulate

    say = _say(progress)
    rows = []
    stems = dict(zip((id(sc) for sc in spec.scenarios), _unique_names(spec), strict=True))
    jobs = [(sc, m) for sc in spec.scenarios for m in banks]
    for k, (sc, method) in enumerate(jobs):
        bank = banks[method]
        if not bank.present:
            say(f"[{k + 1}/{len(jobs)}] {sc.name} ({method}): no residual, skipped")
            continue
        say(f"[{k + 1}/{len(jobs)}] simulating {sc.name} ({method})")
        if method not in thresholds:
            if isinstance(spec.threshold, dict):
                say(f"calibrating the threshold ({method}, {spec.threshold['runs']} runs)")
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
            "false_alarm_rate": res.false_alarm_rate(),
            "final_isolation": int(res.isolated[-1]) if res.isolated.size else None,
        }
        if plots and out is not None and figures is not None:
            png = out / f"residuals_{stems[id(sc)]}_{method}.png"
            args = _residual_figure_args(res, f"{sc.name} — {method}")
            figures.submit(png.name, _draw_residuals, args, png)
            row["figure"] = png.name
        rows.append(row)
    return rows


def run_model(
    spec: ModelSpec,
    *,
    out: Path | None,
    steps: Sequence[str] = ("design", "verify", "simulate"),
    plots: bool = True,
    symbolic: bool = True,
    progress: bool = False,
    figures: _Figures | None = None,
) -> dict[str, Any]:
    """Design, verify and simulate ``spec``; write the report into ``out``.

    ``progress`` prints ``geomfdi: ...`` lines on stderr; with ``out`` and ``plots`` the
    figures are drawn by worker processes while the verification and the simulations run
    (``figures``: a pool already started, as :func:`main` does; closed on return).
    """
    from geomfdi.io.report import _bank_json, _json_default

    say = _say(progress)
    try:
        if out is not None:
            check_outputs(spec, out, [o.method for o in spec.methods], plots=plots)
    except BaseException:
        if figures is not None:
            figures.close()
        raise
    # workers load matplotlib during the design
    figs = figures if figures is not None else _Figures(plots and out is not None)
    try:
        say(f"designing {len(spec.methods)} bank(s): {', '.join(o.method for o in spec.methods)}")
        banks = design_all(spec)
        summary: dict[str, Any] = {
            "model": spec.name,
            "source": spec.source,
            "plant": {
                "n": spec.plant.n,
                "m": spec.plant.m,
                "q": spec.plant.q,
                "dt": spec.plant.dt,
            },
            "design": {m: _bank_json(b) for m, b in banks.items()},
        }
        _run_steps(spec, banks, summary, out, steps, plots, symbolic, progress, figs)
        if figs.jobs:
            say(f"writing the report and {len(figs.jobs)} figure(s)")
        figs.results()
    finally:
        figs.close()
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        write_text(out / "report.md", summary["report"] + "\n")
        write_text(
            out / "summary.json",
            json.dumps(
                {k: v for k, v in summary.items() if k != "report"}, indent=2, default=_json_default
            ),
        )
    return summary


def _run_steps(
    spec: ModelSpec,
    banks: dict[str, ResidualBank],
    summary: dict[str, Any],
    out: Path | None,
    steps: Sequence[str],
    plots: bool,
    symbolic: bool,
    progress: bool,
    figs: _Figures,
) -> None:
    """The report's text (``summary["report"]``) and the figures of :func:`run_model`."""
    from geomfdi.io.report import _design_table, _sim_table, _threshold_values

    say = _say(progress)
    lines = [
        f"# geomfdi report: {spec.name}",
        "",
        f"Plant: n = {spec.plant.n} states, m = {spec.plant.m} inputs, q = {spec.plant.q} "
        "sensors, "
        + (f"dt = {spec.plant.dt:g}." if spec.plant.dt else "continuous time.")
        + " Sensors, faults and residuals are numbered from 0.",
        "",
    ]
    for m, b in banks.items():
        lines += _design_table(m, b)
    figures: list[tuple[str, str]] = []
    if out is not None and plots:
        out.mkdir(parents=True, exist_ok=True)
        for m, b in banks.items():
            png = out / f"structure_{m}.png"
            figs.submit(
                png.name, _draw_structure, _structure_figure_args(b, f"structure — {m}"), png
            )
            figures.append((f"achieved structure — {m}", png.name))
    if "simulate" in steps and spec.scenarios:
        thresholds: dict[str, Any] = {}
        rows = _simulate(spec, banks, out, plots, progress, thresholds, figs)
    if "verify" in steps:  # after the scenarios: the figures are drawn meanwhile
        summary["verification"] = {}
        for m, b in banks.items():
            exact = symbolic and spec.plant.n <= SYMBOLIC_MAX_N and b.present
            say(f"verifying {m}" + (" (numerically and exactly)" if exact else ""))
            summary["verification"][m] = _verify(spec.plant, b, symbolic)
        lines += [
            "### Verification",
            "",
            "| method | ok | max leakage | max input leakage | exact proof |",
            "|---|---|---|---|---|",
        ]
        for m, v in summary["verification"].items():
            sym = v.get("symbolic_summary", "-") if v.get("symbolic_ok") is not None else "-"
            sym = sym.split(": ")[0] if sym.startswith("fails") else sym
            lines.append(
                f"| {m} | {v['ok']} | {v['max_leakage']:.3g} | "
                f"{v['max_input_leakage']:.3g} | {sym} |"
            )
        lines.append("")
    if "simulate" in steps and spec.scenarios:
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
            "--progress",
            action="store_true",
            help="show progress on stderr even when it is not a terminal",
        )
        sp.add_argument(
            "--traceback",
            action="store_true",
            help="on an unexpected internal error, show the Python traceback",
        )
    _add_deployment_parsers(sub)
    _campaign_parser(sub)
    return p


# ---------------------------------------------------- deployment: evaluate, codegen
def _add_deployment_parsers(sub: Any) -> None:
    """``evaluate`` and ``codegen``; their work is in :mod:`geomfdi.deployment.commands`."""
    text = "run the designed bank on recorded data (CSV); write residuals, alarms, report.md"
    ev = sub.add_parser("evaluate", help=text, description=text)
    ev.add_argument("model", help="model file (TOML)")
    ev.add_argument("data", help="CSV with a header row: t, y0, y1, ..., u0, ...")
    ev.add_argument("--settle", default="0", help="seconds without decisions first, or auto")
    text = "write C99 or Python code of the designed bank's online monitor"
    cg = sub.add_parser("codegen", help=text, description=text)
    cg.add_argument("model", help="model file (TOML)")
    cg.add_argument("--lang", choices=("c", "python"), required=True)
    cg.add_argument("--name", default="fdi_monitor", help="file and symbol prefix")
    cg.add_argument("--dt", type=float, default=None, help="sample a continuous design at DT")
    for sp in (ev, cg):
        sp.add_argument("--out", type=Path, default=Path.cwd(), help="output directory")
        sp.add_argument("--method", default=None, help="design method (default: the first)")
        sp.add_argument(
            "--threshold",
            type=float,
            nargs="+",
            default=None,
            metavar="THR",
            help="override the threshold: one value, or one per residual",
        )
        _bank_and_progress(sp)
        sp.add_argument(
            "--persistence",
            default=None,
            help="D consecutive, K/N or K/N/RESET samples (an alarm holds K of N samples; "
            "an alarm episode ends after RESET quiet samples)",
        )
        sp.add_argument("--initial", choices=("steady", "zero"), default="steady")
        sp.add_argument("--no-plots", action="store_true", help="do not write PNG figures")
        sp.add_argument("--quiet", action="store_true", help="print nothing but errors")
        sp.add_argument("--traceback", action="store_true", help="show internal tracebacks")


def _bank_and_progress(sp: Any) -> None:
    sp.add_argument("--bank", type=Path, help="a saved bank (gf.load_bank), not designed")
    sp.add_argument("--progress", action="store_true", help="report progress on stderr")


def _deployment_bank(args: Any) -> tuple[ModelSpec, str, ResidualBank, Any]:
    from geomfdi.deployment import commands
    from geomfdi.io.modelfile import load_model

    say = _say(bool(getattr(args, "progress", False)))
    spec = load_model(args.model)
    if getattr(args, "bank", None) is not None:
        from geomfdi.deployment.persistence import load_bank

        say(f"loading the bank {args.bank}")
        bank = load_bank(args.bank)
        method = args.method or f"saved bank {Path(args.bank).name}"
    else:
        say("designing the banks")
        banks = design_all(spec)
        method = args.method or next(iter(banks))
        if method not in banks:
            raise GeomFDIError(
                f"--method: {method!r} is not a design of the model file ({sorted(banks)})",
                argument="method",
            )
        bank = banks[method]
    threshold = commands.parse_threshold(args.threshold, bank.n_residuals)
    if threshold is None:
        threshold = _threshold(spec, bank)
    return spec, method, bank, threshold


def _run_deployment(args: Any) -> int:
    from geomfdi.deployment import commands

    try:
        spec, method, bank, threshold = _deployment_bank(args)
        persistence = commands.parse_persistence(args.persistence)
        if args.command == "evaluate":
            summary = commands.evaluate_files(
                bank,
                threshold,
                args.data,
                args.out,
                model=spec.name,
                method=method,
                persistence=persistence,
                initial=args.initial,
                plots=not args.no_plots,
                settle=commands.parse_settle(args.settle),
            )
            text = summary["report"] + f"\nwritten to {args.out}"
        else:
            paths = commands.codegen_files(
                bank,
                threshold,
                args.lang,
                args.out,
                name=args.name,
                dt=args.dt,
                persistence=persistence,
                initial=args.initial,
            )
            text = "written: " + ", ".join(str(p) for p in paths)
    except (GeomFDIError, OSError) as exc:
        print(f"geomfdi: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except Exception as exc:  # an internal error: one line unless asked for the traceback
        if args.traceback:
            raise
        return _internal_error(exc, hint="")
    if not args.quiet:
        print(text)
    return 0


# ---------------------------------------------------------------------------------


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
        help="where the blocks run (dask: a local cluster, or --scheduler)",
    )
    sp.add_argument(
        "--workers", type=int, default=2, help="worker processes (one thread each), local or Dask"
    )
    sp.add_argument("--scheduler", default=None, help="address of a running Dask scheduler")
    _bank_and_progress(sp)
    sp.add_argument("--no-plots", action="store_true", help="do not write PNG figures")
    sp.add_argument("--quiet", action="store_true", help="print nothing but errors")
    sp.add_argument("--traceback", action="store_true", help="show internal tracebacks")


def load_campaign(
    path: str | Path, *, runs: int | None = None, bank: str | Path | None = None
) -> Any:
    """Design the banks of a model file (or load the saved ``bank`` for the campaign's
    method) and build its ``[campaign]`` (a CampaignConfig)."""
    from geomfdi.campaign.config import build_campaign, read_campaign

    camp, spec = read_campaign(path)
    if bank is None:
        return build_campaign(camp, spec, design_all(spec), runs=runs)
    from geomfdi.deployment.persistence import load_bank

    method = str(camp.get("method", "saved"))
    return build_campaign(camp, spec, {method: load_bank(bank)}, runs=runs)


def campaign_command(args: argparse.Namespace) -> int:
    """``geomfdi campaign MODEL.toml``: run, write CSV tables and PNGs, print the summary."""
    from geomfdi.campaign.config import campaign_report, save_partial, write_outputs

    try:
        if args.runs is not None and args.runs < 1:
            raise GeomFDIError("--runs: must be >= 1", argument="runs")
        cfg = load_campaign(args.model, runs=args.runs, bank=args.bank)
        progress = args.progress or (sys.stderr.isatty() and not args.quiet)
        if args.executor == "dask":
            from distributed import Client

            from geomfdi.campaign.executors import local_dask_client

            make = Client(args.scheduler) if args.scheduler else local_dask_client(args.workers)
            with make as client:
                result = cfg.campaign.run(client, progress=progress)
        else:
            result = cfg.campaign.run(args.executor, workers=args.workers, progress=progress)
        files = write_outputs(result, args.out, plots=not args.no_plots, name=cfg.spec.name)
    except (GeomFDIError, OSError) as exc:  # (lost workers: the runs done are saved)
        print(f"geomfdi: error: {_one_line(exc)}{save_partial(exc, args.out)}", file=sys.stderr)
        return 2
    except ImportError as exc:
        print(f"geomfdi: error: {_one_line(exc)} (install geomfdi[dask])", file=sys.stderr)
        return 2
    except Exception as exc:
        if args.traceback:
            raise
        return _internal_error(exc)
    if not args.quiet:
        print(campaign_report(cfg, result, files))
    return 0


# ------------------------------------------------------------------------------------
def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _internal_error(exc: Exception, hint: str = " (rerun with --traceback for details)") -> int:
    """Report an unexpected error on one line of stderr; exit code 1."""
    text = f"geomfdi: error: internal error {type(exc).__name__}: {_one_line(exc)}{hint}"
    print(text, file=sys.stderr)
    return 1


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``geomfdi`` console script; returns the exit code.

    Exit codes: 0 success; 2 bad command line, unreadable or invalid model file, an
    option out of range, a design/simulation the model does not allow, an output file
    that cannot be created (checked before any work), a system limit (memory, disk)
    (one line ``geomfdi: error: ...`` on stderr); 1 an unexpected internal error (one
    line, or the traceback with ``--traceback``); 141 the reader of stdout stopped early
    (``geomfdi design m.toml --json | head``), like a program ended by SIGPIPE, without
    a message.  After a successful run, warnings are printed as
    ``geomfdi: warning: ...`` lines unless ``--quiet``.
    """
    if argv is None:  # the command line: the process ends after this call
        import atexit
        import gc

        # the interpreter's last collection would walk every object of sympy, scipy and
        # numpy (about 0.1 s); the memory goes back to the system anyway
        atexit.register(gc.freeze)
    args = _parser().parse_args(argv)
    if args.command in ("evaluate", "codegen"):
        return _run_deployment(args)
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
    # the figure worker starts now, before the model file reader and the design stack
    # are loaded: it loads matplotlib meanwhile (run_model closes it)
    figs = _Figures(not args.no_plots and out is not None)
    try:
        from geomfdi.io.modelfile import load_model

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
                progress=not args.quiet and (args.progress or sys.stderr.isatty()),
                figures=figs,
            )
    except (GeomFDIError, OSError) as exc:
        print(f"geomfdi: error: {_one_line(exc)}", file=sys.stderr)
        return 2
    except MemoryError:
        print("geomfdi: error: out of memory (use a shorter grid or fewer runs)", file=sys.stderr)
        return 2
    except Exception as exc:  # an internal error: one line unless asked for the traceback
        if args.traceback:
            raise
        return _internal_error(exc)
    finally:
        figs.close()
    try:
        _print_results(args, summary, caught, out)
    except BrokenPipeError:
        # the reader went away (``| head``): stop quietly, as a program ended by SIGPIPE;
        # stdout is pointed at devnull so that the interpreter's final flush is silent
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
        return 141
    return 0


def _print_results(
    args: argparse.Namespace, summary: dict[str, Any], caught: list, out: Any
) -> None:
    """Warnings on stderr, then the report or the JSON on stdout."""
    from geomfdi.io.report import _json_default

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
    sys.stdout.flush()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
