"""The diagnostic of one delivered row of a bank, and the ``strength`` option.

See the user guide, *Synthesis* (``docs/guide/synthesis.md``): a row's diagnostic is
``"ok"`` or notes joined with ``"; "`` -- ``weak: ...`` (a target's DC gain below
``FD_GAIN_TOL`` of the row's largest fault gain, faults at their reference sizes),
``leaks ...`` / ``ill-conditioned: ...``, ``not least order: ...`` and
``raised for strength: ...`` (the least-order row was weak; ``strength="weak"`` gives it).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi.generators.generator import ResidualGenerator
from geomfdi.synthesis.build import FD_GAIN_TOL

__all__ = ["STRENGTHS", "check_strength", "row_notes"]

STRENGTHS = ("strong", "weak")


def check_strength(strength: Any) -> str:
    """``strength`` validated: ``"strong"`` (default) or ``"weak"``."""
    from geomfdi.errors import DesignError

    if not isinstance(strength, str) or strength not in STRENGTHS:
        raise DesignError(
            f"strength: must be one of {list(STRENGTHS)}, got {strength!r:.40}",
            argument="strength",
        )
    return str(strength)


def row_notes(g: ResidualGenerator, weak: list[int], leaks: list[int], method: str) -> list[str]:
    """The notes of a delivered row (module Notes), without the close-rank note."""
    gain = g.info["fault_gain"]
    notes = []
    if weak:
        dc = g.info["dc_gain"]
        zero = [j for j in weak if dc[j] <= 1e-8 * max(gain[j], 1e-300)]
        small = [j for j in weak if j not in zero]
        if zero:
            notes.append("weak: zero DC gain from fault " + ", ".join(map(str, zero)))
        if small:
            notes.append(
                "weak: DC gain from fault "
                + ", ".join(map(str, small))
                + f" below {FD_GAIN_TOL:g} of the residual's largest fault gain (faults at"
                " their reference sizes)"
            )
    if leaks and method == "paper":
        dc = g.info["dc_gain"]
        kind = (
            "zero DC gain: decoupled in steady state only"
            if all(np.isfinite(dc[j]) and dc[j] <= 1e-8 * max(gain[j], 1e-300) for j in leaks)
            else "non-zero DC gain"
        )
        notes.append(f"leaks faults {leaks} on the physical model ({kind})")
    elif leaks:
        worst = float(max(gain[j] for j in leaks))
        notes.append(
            f"ill-conditioned: faults {leaks} leak at relative gain up to {worst:.2g} "
            "(the decoupling is exact in theory; rounding is amplified by the design)"
        )
    if "fallback" in g.info:
        notes.append(f"not least order: {g.info['fallback']}")
    cert = g.info.get("least_order")
    if (  # above the least order for numerical reasons (a raise for strength is stated)
        isinstance(cert, dict)
        and "raised_from" not in cert
        and cert.get("delivered_order", g.order) != cert.get("order")
    ):
        notes.append(f"not least order: {cert.get('statement', '')}")
    if isinstance(cert, dict) and "raised_from" in cert:
        notes.append(
            f"raised for strength: order {g.order} delivered, the least-order row (order "
            f"{cert['raised_from']}) sees faults {cert.get('weak_at_least', [])} weakly "
            "(strength='weak' gives it)"
        )
    return notes
