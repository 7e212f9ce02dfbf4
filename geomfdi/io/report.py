"""Text of the ``geomfdi`` command's outputs: design tables, simulation tables, JSON."""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi.generators.generator import ResidualBank


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


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return str(obj)
