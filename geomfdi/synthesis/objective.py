"""The objective of a design: exact decoupling, or the fault-to-noise gap.

Used by the front end :mod:`geomfdi.synthesis.design`; imports only the package's errors and
validation helpers.
"""

from __future__ import annotations

from typing import Any

from geomfdi._validation import as_bool
from geomfdi.errors import DesignError

__all__ = ["OBJECTIVES", "objective_of"]

OBJECTIVES = ("decoupling", "gap")


def objective_of(
    objective: Any,
    plant: Any,
    models: Any = None,
    exact: bool = False,
    method: Any = "exact",
    band: Any = None,
) -> str:
    """``objective`` checked; ``None``: ``"gap"`` for a plant with noise inputs (unless an
    exact-decoupling construction was asked for: ``exact=True`` or another ``method``).

    ``band`` (a frequency band of the gap design) is refused with any other objective."""
    # checked first (named errors), before any of them is compared
    if not isinstance(method, str) or method not in ("exact", "full", "paper", "mvw"):
        raise DesignError(
            f"method: must be one of ['exact', 'full', 'paper', 'mvw'], got {method!r:.40}",
            argument="method",
        )
    exact = as_bool(exact, "exact")
    if models is not None and (
        not isinstance(models, list | tuple) or not models or isinstance(models, str)
    ):
        raise DesignError("models: give a non-empty list of plants", argument="models")
    out = _objective(objective, plant, models, exact, method)
    if band is not None and out != "gap":
        raise DesignError('band: an objective of the gap design (objective="gap")', argument="band")
    return out


def _objective(objective: Any, plant: Any, models: Any, exact: bool, method: Any) -> str:
    if objective is None:
        if exact is True or method != "exact":
            return "decoupling"
        nw = getattr(plant, "nw", 0)
        if models is not None:
            return "gap"
        return "gap" if isinstance(nw, int) and nw > 0 else "decoupling"
    if not isinstance(objective, str) or objective not in OBJECTIVES:
        raise DesignError(
            f"objective: must be one of {list(OBJECTIVES)}, got {objective!r:.40}",
            argument="objective",
        )
    if objective == "gap" and (exact is True or method != "exact"):
        raise DesignError(
            "method: objective='gap' builds on the least-order decoupling basis "
            f"(method='exact', exact=False); got method={method!r}, exact={exact!r}",
            argument="method",
        )
    if objective == "decoupling" and models is not None:
        raise DesignError(
            "models: several models are designed for with objective='gap'", argument="models"
        )
    return objective
