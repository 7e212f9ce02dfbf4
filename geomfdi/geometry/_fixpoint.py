"""The monotone subspace recursion shared by the exact and the parametric W* and S*.

Hou, Wen & Chen (2011), eqs. 14-15: ``W*`` is the limit of a growing sequence
``Z_k = L + A (Z_{k-1} ∩ Ker C)``, ``S*`` of a shrinking one
``Z_k = W* + A⁻¹(Z_{k-1}) ∩ Ker C``; each stops at the first step that does not change
the dimension (at most ``n + 1`` steps).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

__all__ = ["monotone_fixpoint"]


def monotone_fixpoint(Z: Any, step: Callable[[Any], Any], steps: int, *, grow: bool) -> Any:
    """``Z_k = step(Z_{k-1})`` from ``Z_0 = Z`` until the dimension stops growing
    (``grow=True``) or shrinking, at most ``steps`` times.

    Returns the last subspace with ``history`` set to the dimensions ``[dim Z_0, dim Z_1, …]``.
    """
    history = [Z.dim]
    for _ in range(steps):
        Znew = step(Z)
        history.append(Znew.dim)
        moved = Znew.dim > Z.dim if grow else Znew.dim < Z.dim
        Z = Znew
        if not moved:
            break
    Z.history = history
    return Z
