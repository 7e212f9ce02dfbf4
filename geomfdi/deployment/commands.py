"""The ``geomfdi evaluate`` and ``geomfdi codegen`` commands (their work, not their parsing).

``geomfdi evaluate MODEL.toml DATA.csv --out DIR`` designs the model's bank, reads the
CSV (a header row naming the columns ``t`` or ``time``, the plant's output and input
names, or outputs ``y0, y1, ...`` and inputs ``u0, ...``; empty or ``nan`` cells are
missing samples, anything else that is not a decimal number is refused:
:mod:`geomfdi.deployment.csvfile`; physical values when the plant has an operating
point), runs
:func:`geomfdi.evaluate` and writes ``residuals.csv``, ``alarms.csv`` (confirmed alarms and
the isolation decision per sample), ``report.md`` (thresholds, masked windows, alarm
episodes with isolation) and ``residuals.png``.

``geomfdi codegen MODEL.toml --lang c|python --out DIR`` writes the monitor's code
(:mod:`geomfdi.deployment.codegen`) for the model's discrete bank, or for a continuous
design sampled at ``--dt``.
"""

from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from geomfdi._files import csv_texts, replace_file, write_text
from geomfdi.deployment.csvfile import CHUNK_ROWS, read_record
from geomfdi.deployment.decide import as_persistence
from geomfdi.deployment.recorded import EvaluationResult, evaluate
from geomfdi.errors import GeomFDIError
from geomfdi.evaluation.persistence import Persistence
from geomfdi.model.signals import bank_signals

__all__ = [
    "read_csv",
    "evaluate_files",
    "codegen_files",
    "parse_persistence",
    "parse_threshold",
    "describe_rule",
]


MAX_PERSISTENCE = 100_000
"""Largest sample count of ``--persistence`` (the rule's window and reset; the monitor
and the generated code keep a ring of that many samples)."""


def parse_persistence(text: str | None) -> Any:
    """``"3"`` (3 consecutive samples), ``"2/3"`` (2 of 3) or ``"2/3/50"`` (2 of 3, the
    alarm episode ends after 50 quiet samples) from the command line; the pattern is
    held over the episode (:class:`geomfdi.Persistence`)."""
    if text is None:
        return None
    try:
        parts = [int(p) for p in str(text).split("/")]
    except ValueError:
        parts = []
    if any(p > MAX_PERSISTENCE for p in parts):
        raise GeomFDIError(
            f"--persistence: at most {MAX_PERSISTENCE} samples per count, got {text!r}",
            argument="persistence",
        )
    if len(parts) == 1:
        return as_persistence(parts[0])
    if len(parts) == 2:
        return as_persistence(tuple(parts))
    if len(parts) == 3:
        return Persistence(parts[0], parts[1], reset=parts[2])
    raise GeomFDIError(
        f"--persistence: expected D, K/N or K/N/RESET (integers), got {text!r}",
        argument="persistence",
    )


def parse_settle(text: str) -> float | str:
    """``--settle``: seconds (a finite number >= 0) or ``auto``."""
    if str(text).strip() == "auto":
        return "auto"
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (value >= 0 and value < float("inf")):
        raise GeomFDIError(
            f"--settle: expected seconds >= 0 or auto, got {text!r:.40}", argument="settle"
        )
    return value


def parse_threshold(values: Sequence[float] | None, rows: int) -> Any:
    """``--threshold``: ``None``, one value for every residual, or one per residual."""
    if values is None:
        return None
    vals = [float(v) for v in values]
    if len(vals) == 1:
        return vals[0]
    if len(vals) != rows:
        raise GeomFDIError(
            f"--threshold: give one value or {rows} (one per residual), got {len(vals)}",
            argument="threshold",
        )
    return vals


def describe_rule(rule: Persistence) -> str:
    """A one-line description of a persistence rule (for reports)."""
    if rule.trivial:
        return "none (per-sample alarms and isolation)"
    text = f"{rule.k} of {rule.n} samples"
    if rule.latch:
        end = f"ends after {rule.reset} quiet samples" if rule.reset else "never ends"
        return f"{text}, isolation on the pattern held over the alarm episode ({end})"
    return f"{text}, isolation on the momentary pattern"


def read_csv(
    path: str | Path, q: int, m: int, names: tuple[Any, Any] | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``t, y (q, N), u (m, N)`` from a CSV with a header row (module docstring), read by
    the strict reader :func:`geomfdi.deployment.csvfile.read_record`.

    ``names = (outputs, inputs)``: the plant's signal names, read when the header has
    them all (else the columns ``y0, ..., u0, ...``)."""
    rec = read_record(path, q, m, names=names)
    return rec.t, rec.y, rec.u


def _write_table(path: Path, header: list[str], columns: list[np.ndarray]) -> None:
    """A CSV table (floats in their shortest round-trip form, integers as integers),
    written in chunks of rows through :func:`geomfdi._files.replace_file`."""
    import pandas as pd

    def write(tmp: Path) -> None:
        N = len(columns[0]) if columns else 0
        with tmp.open("w", newline="", encoding="utf-8") as fh:
            csv.writer(fh).writerow(csv_texts(header))
            for a in range(0, N, CHUNK_ROWS):
                frame = pd.DataFrame({k: c[a : a + CHUNK_ROWS] for k, c in enumerate(columns)})
                frame.to_csv(fh, header=False, index=False, lineterminator="\r\n")

    replace_file(path, write)


def _fmt(x: float | None) -> str:
    return "-" if x is None else f"{x:.6g}"


def _decision(res: EvaluationResult, fault: int | None, at: float | None) -> str:
    if fault is None:
        return "-"
    if fault < 0:  # MULTIPLE: several faults at once
        k = int(np.searchsorted(res.t, at))
        sus = np.flatnonzero(res.suspects[:, k])
        return "several: " + ", ".join(res.fault_labels[j] for j in sus)
    return res.fault_labels[fault]


def _report(
    res: EvaluationResult, model: str, data: str, method: str, missing: tuple[int, int] = (0, 0)
) -> str:
    lines = [
        f"# Residual evaluation: {model}",
        "",
        f"Data: `{data}`, {res.t.size} samples, t = {res.t[0]:g} .. {res.t[-1]:g} s, "
        f"dt = {res.info['dt']:g} s; design `{method}`; start-up `{res.info['initial']}`; "
        f"persistence: {describe_rule(res.persistence)}; no decisions in the first "
        f"{res.info['settle']:g} s (settle).",
        "",
        "| residual | threshold | max abs(r) | alarming samples |",
        "|---|---|---|---|",
    ]
    for i, lab in enumerate(res.residual_labels):
        thr = "-" if res.threshold is None else _fmt(float(res.threshold.values[i]))
        row = res.residuals[i]
        peak = float(np.nanmax(np.abs(row))) if np.isfinite(row).any() else float("nan")
        lines.append(f"| {lab} | {thr} | {peak:.6g} | {int(res.alarms[i].sum())} |")
    lines += ["", "## Masked windows (missing samples)", ""]
    lines += [
        f"{missing[0]} missing cells (empty or nan) in {missing[1]} of {res.t.size} samples; "
        f"{int(res.masked.sum())} samples masked (a missing or non-finite value).",
        "",
    ]
    lines += [f"- {a:g} .. {b:g} s" for a, b in res.gaps] or ["none"]
    lines += ["", "## Alarm episodes", ""]
    if res.episodes:
        lines += [
            "| start | stop | residuals | isolated fault (settled) | share | isolated at "
            "| first decision |",
            "|---|---|---|---|---|---|---|",
        ]
        for ep in res.episodes:
            fault = _decision(res, ep.fault, ep.isolated_at)
            first = _decision(res, ep.first_fault, ep.first_isolated_at)
            if ep.first_fault is not None:
                first += f" at {ep.first_isolated_at:g}"
            share = "-" if ep.fault is None else f"{100 * ep.share:.0f} %"
            rs = ", ".join(res.residual_labels[r] for r in ep.residuals)
            lines.append(
                f"| {ep.start:g} | {ep.stop:g} | {rs} | {fault} | {share} "
                f"| {_fmt(ep.isolated_at)} | {first} |"
            )
        lines += [
            "",
            "The settled decision is the one held on most of the episode's decided samples.",
        ]
    else:
        lines.append("none")
    return "\n".join(lines) + "\n"


def evaluate_files(
    bank: Any,
    threshold: Any,
    data: str | Path,
    out: Path,
    *,
    model: str = "model",
    method: str = "",
    persistence: Any = None,
    initial: str = "steady",
    plots: bool = True,
    settle: float | str = 0.0,
) -> dict[str, Any]:
    """Evaluate ``bank`` on the CSV ``data``; write the outputs to ``out`` (module docstring).

    Returns a summary dict (``report`` text, ``episodes``, ``gaps``, file paths).
    """
    gens = [g for g in bank.generators if g is not None]
    if not gens:
        raise GeomFDIError("bank: no residual generator exists in this bank", argument="bank")
    sig = bank_signals(bank)
    names = (sig["outputs"], sig["inputs"]) if sig["named"] else None
    rec = read_record(data, gens[0].q, gens[0].m, names=names)
    res = evaluate(
        bank,
        rec.y,
        rec.u,
        rec.t,
        threshold=threshold,
        persistence=persistence,
        initial=initial,
        settle=settle,
    )
    missing = (rec.missing, rec.missing_samples)
    del rec  # (the residuals are computed: the signals are not needed any more)
    out.mkdir(parents=True, exist_ok=True)
    _write_table(out / "residuals.csv", ["t", *res.residual_labels], [res.t, *list(res.residuals)])
    _write_table(
        out / "alarms.csv",
        ["t", *res.residual_labels, "isolated"],
        [res.t, *[a.astype(int) for a in res.alarms], res.isolated],
    )
    report = _report(res, model, str(data), method, missing)
    write_text(out / "report.md", report)
    files = ["residuals.csv", "alarms.csv", "report.md"]
    if plots:
        fig = res.plot(title=f"{model}: {Path(data).name}")
        replace_file(out / "residuals.png", lambda tmp: fig.savefig(tmp, dpi=120, format="png"))
        files.append("residuals.png")
    return {
        "report": report,
        "files": files,
        "episodes": [ep.__dict__ for ep in res.episodes],
        "gaps": res.gaps,
        "result": res,
    }


def codegen_files(
    bank: Any,
    threshold: Any,
    lang: str,
    out: Path,
    *,
    name: str = "fdi_monitor",
    dt: float | None = None,
    persistence: Any = None,
    initial: str = "steady",
) -> list[Path]:
    """Write the monitor code for ``bank`` (sampled with zero-order hold at ``dt`` when
    continuous) in ``lang`` (``"c"`` or ``"python"``) to ``out``."""
    from geomfdi.deployment import codegen
    from geomfdi.errors import NotDiscreteError
    from geomfdi.generators.discretize import discretize_bank

    if bank.dt <= 0:
        if dt is None:
            raise NotDiscreteError(
                "--dt: the model's bank is continuous; give the sampling period to "
                "discretise it (or set plant.dt in the model)",
                argument="dt",
            )
        bank = discretize_bank(bank, dt, "zoh")
    kw = {"threshold": threshold, "persistence": persistence, "initial": initial}
    if lang == "c":
        return list(codegen.c(bank, name, out, **kw))
    if lang == "python":
        return [codegen.python(bank, name, out, **kw)]
    raise GeomFDIError(f"--lang: must be c or python, got {lang!r}", argument="lang")
