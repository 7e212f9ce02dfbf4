"""Checks of the design front end's choices: the ``method`` of the decoupling design and
the ``objective`` (exact ``"decoupling"`` or the approximate ``"gap"`` design of Varga
2017, ch. 5), each checked with a named error before any of them is compared.
"""

from __future__ import annotations

from typing import Any

from geomfdi._validation import as_bool, as_float
from geomfdi.errors import DesignError

__all__ = ["METHODS", "OBJECTIVES"]

METHODS = ("exact", "full", "paper", "mvw")


def _check_method(method: Any) -> str:
    if not isinstance(method, str) or method not in METHODS:
        raise DesignError(
            f"method: must be one of {list(METHODS)}, got {method!r:.40}", argument="method"
        )
    return str(method)


OBJECTIVES = ("decoupling", "gap")


def _objective(
    objective: Any, plant: Any, models: Any, exact: Any, method: Any, regularization: Any
) -> str:
    """``objective`` checked; ``None``: ``"gap"`` for a plant with noise inputs (unless an
    exact-decoupling construction was asked for: ``exact=True`` or another ``method``).
    ``method``, ``exact``, ``models``, ``regularization`` checked first (named errors)."""
    method = _check_method(method)
    exact = as_bool(exact, "exact")
    if models is not None:
        from geomfdi.synthesis.approximate.bank import check_models

        check_models(models, None)
    reg = as_float(regularization, "regularization", allow_none=True)
    if reg is not None and reg < 0:
        raise DesignError(
            f"regularization: must be a finite number >= 0, got {reg!r}",
            argument="regularization",
        )
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
