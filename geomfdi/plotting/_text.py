"""User text on figures: names and titles are drawn as plain text.

Fault, residual, scenario and model names come from model files and other people's data;
matplotlib would parse a ``$...$`` pair in them as mathtext and fail on an unbalanced
one (``"$x^{$"``).  Every string a caller hands to a plotting function goes through
:func:`plain` first, so a dollar sign is drawn as a dollar sign.
"""

from __future__ import annotations

from typing import Any

__all__ = ["plain", "plain_all"]


def plain(text: Any) -> str:
    """``str(text)`` with every ``$`` escaped (``\\$``): matplotlib draws it verbatim.

    Examples
    --------
    >>> plain("$x^{$")
    '\\\\$x^{\\\\$'
    """
    return str(text).replace("$", r"\$")


def plain_all(texts: Any) -> list[str]:
    """:func:`plain` of every entry of ``texts``."""
    return [plain(t) for t in texts]
