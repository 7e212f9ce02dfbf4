"""The rank decisions behind one designed row: recorded, summarised, reported when close.

Every rank decision of a design (W*, S*, the quotient's measurement map and pseudo-inverse,
the parity spaces of each degree, realisation) goes through
:func:`geomfdi.tolerance.rank_decision`.  A row is designed inside :func:`record_design`,
which collects them (silencing the per-algorithm :class:`~geomfdi.tolerance.CloseRankWarning`);
:func:`summarise` then reports the *closest* decision of the delivered attempt — the
smallest singular-value gap ``σ_r / σ_{r+1}`` and the step where it was taken — and
:func:`attach` stores it in ``g.info["rank_decisions"]`` and issues one warning when the
gap is below :data:`geomfdi.tolerance.GAP_WARN` (the tolerance policy: the row might
change with the tolerance).  See the user guide, *Theory: the geometric approach*
(``docs/theory/geometric-approach.md``).
"""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Iterator
from typing import Any

from geomfdi.tolerance import (
    GAP_WARN,
    CloseRankWarning,
    RankDecision,
    closest_decision,
    decision_stage,
    record_decisions,
)

__all__ = ["record_design", "summarise", "attach", "close_note", "OTHER_STAGE"]

OTHER_STAGE = "quotient and realisation"
"""Label of the decisions taken outside W*, S* and the parity spaces."""


@contextlib.contextmanager
def record_design() -> Iterator[list[RankDecision]]:
    """Collect the rank decisions of one row's design (warnings are issued by :func:`attach`)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CloseRankWarning)
        with decision_stage(OTHER_STAGE), record_decisions() as rec:
            yield rec


PARITY_WORDS = ("parity", "staircase")
"""Decisions whose operation names one of these words belong to the parity-space step (the
parity spaces of each degree, or the observer staircase that gives their dimensions)."""


def _stage(d: RankDecision) -> str:
    if d.where != OTHER_STAGE:
        return d.where
    return "parity space" if any(w in d.what for w in PARITY_WORDS) else OTHER_STAGE


def _delivered(rec: list[RankDecision]) -> list[RankDecision]:
    """The decisions of the last attempt: from the start of the last run of W* decisions
    (a failed realisation is retried from S* on; the earlier attempts' decisions are not
    behind the delivered row)."""
    start = 0
    for i, d in enumerate(rec):
        if d.where == "W*" and (i == 0 or rec[i - 1].where not in ("W*", "S*")):
            start = i
    return rec[start:]


def summarise(rec: list[RankDecision]) -> dict[str, Any] | None:
    """``{"gap", "where", "what", "rank", "tol", "close", "count", "by_stage"}`` of the
    closest decision (``None`` when no decision was taken)."""
    seg = _delivered(rec)
    d = closest_decision(seg)
    if d is None:
        return None
    by_stage: dict[str, float] = {}
    for x in seg:
        st = _stage(x)
        by_stage[st] = min(by_stage.get(st, float("inf")), float(x.gap))
    return {
        "gap": float(d.gap),
        "where": _stage(d),
        "what": d.what,
        "rank": d.rank,
        "tol": float(d.tol),
        "close": bool(d.close),
        "count": len(seg),
        "by_stage": by_stage,
    }


def close_note(summary: dict[str, Any] | None) -> str | None:
    """The diagnostic text of a close decision, or None."""
    if not summary or not summary["close"]:
        return None
    return (
        f"close rank decision: singular-value gap {summary['gap']:.3g} < {GAP_WARN:g} at "
        f"{summary['where']} ({summary['what']}); the row may change with the tolerance"
    )


def attach(g: Any, rec: list[RankDecision], row: str, *, warn: bool = True) -> str | None:
    """Store the summary in ``g.info`` (``"rank_decisions"``, ``"closest_gap"``); warn and
    return the note when the closest decision is close."""
    summary = summarise(rec)
    g.info["rank_decisions"] = summary
    g.info["closest_gap"] = float("inf") if summary is None else summary["gap"]
    note = close_note(summary)
    if note and warn:
        warnings.warn(f"{row}: {note}", CloseRankWarning, stacklevel=3)
    return note
