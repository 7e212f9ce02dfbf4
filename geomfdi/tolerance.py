"""The one rank-decision policy used throughout geomfdi.

A singular value ``sigma`` of a matrix ``X`` produced by an operator counts as
non-zero when

    sigma > tol,    tol = rtol * scale,

where ``scale`` is the norm of the data that produced ``X`` (``||A||_2`` for an image
``A Z``, ``||C||_2`` for ``C Z``; 1 for stacks of orthonormal bases) and ``rtol``
defaults to ``1e3 * n * eps`` with ``n`` the ambient dimension (see the user guide,
*Theory: the geometric approach*, ``docs/theory/geometric-approach.md``).  The
decision is always taken on the *un-normalised* product, never on a re-orthonormalised
one.

The *gap* of a decision is ``sigma_r / max(sigma_{r+1}, eps * scale)``: the smallest
kept over the largest dropped singular value, with ``scale`` standing in for a missing
kept value (rank 0) and the rounding floor ``eps * scale`` for a missing or negligible
dropped one (full rank).  A gap below :data:`GAP_WARN` means the rank was a close call:
geomfdi issues a :class:`CloseRankWarning` and records the gap in the result.

``rtol`` can be changed globally with :func:`set_rtol` or locally with the
:func:`tolerance` context manager; ``None`` restores the default.
"""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

__all__ = [
    "CloseRankWarning",
    "RankDecision",
    "GAP_WARN",
    "default_rtol",
    "get_rtol",
    "set_rtol",
    "tolerance",
    "rank_decision",
    "record_decisions",
]

GAP_WARN = 1e3
_EPS = float(np.finfo(float).eps)
_RTOL: float | None = None
_RECORDERS: list[list[RankDecision]] = []


class CloseRankWarning(UserWarning):
    """A rank decision had a small singular-value gap (see :data:`GAP_WARN`)."""


def default_rtol(n: int) -> float:
    """Default relative tolerance ``1e3 * max(n, 1) * eps``."""
    return 1e3 * max(int(n), 1) * _EPS


def get_rtol(n: int) -> float:
    """The relative tolerance in force for ambient dimension ``n``."""
    return _RTOL if _RTOL is not None else default_rtol(n)


def set_rtol(rtol: float | None) -> None:
    """Set the global relative tolerance (``None``: back to the default)."""
    global _RTOL
    if rtol is not None:
        rtol = float(rtol)
        if not (0.0 < rtol < 1.0) or not np.isfinite(rtol):
            from geomfdi.errors import GeomFDIError

            raise GeomFDIError(f"rtol: must lie in (0, 1), got {rtol}", argument="rtol")
    _RTOL = rtol


@contextlib.contextmanager
def tolerance(rtol: float | None) -> Iterator[None]:
    """Context manager: use ``rtol`` inside the ``with`` block."""
    old = _RTOL
    set_rtol(rtol)
    try:
        yield
    finally:
        set_rtol(old)


@dataclass(frozen=True)
class RankDecision:
    """Outcome of one rank decision.

    Attributes
    ----------
    rank : int
        Number of singular values above ``tol``.
    tol : float
        Absolute threshold ``rtol * scale``.
    gap : float
        ``sigma_rank / max(sigma_{rank+1}, eps * scale)``; ``scale`` stands in for a
        missing kept value (rank 0).
    """

    rank: int
    tol: float
    gap: float
    what: str = ""

    @property
    def close(self) -> bool:
        """True when the gap is below :data:`GAP_WARN`."""
        return self.gap < GAP_WARN


@contextlib.contextmanager
def record_decisions() -> Iterator[list[RankDecision]]:
    """Collect every rank decision taken inside the block (and silence their warnings).

    Algorithms use this to keep the smallest gap behind their result and to issue one
    summary :class:`CloseRankWarning` instead of many.
    """
    rec: list[RankDecision] = []
    _RECORDERS.append(rec)
    try:
        yield rec
    finally:
        _RECORDERS.remove(rec)


def rank_decision(
    s: np.ndarray, scale: float, n: int, *, what: str = "rank decision", warn: bool = True
) -> RankDecision:
    """Decide the rank from singular values ``s`` (descending).

    Parameters
    ----------
    s : ndarray
        Singular values, descending.
    scale : float
        Norm of the data that produced the matrix (0 is treated as 1).
    n : int
        Ambient dimension, for the default ``rtol``.
    what : str
        Description used in the warning.
    warn : bool
        Issue a :class:`CloseRankWarning` when the gap is small.
    """
    s = np.asarray(s, dtype=float)
    scale = float(scale) if scale > 0 else 1.0
    tol = get_rtol(n) * scale
    rank = int(np.count_nonzero(s > tol))
    floor = _EPS * scale
    kept = float(s[rank - 1]) if rank > 0 else scale
    dropped = float(s[rank]) if rank < s.size else 0.0
    gap = kept / max(dropped, floor)
    dec = RankDecision(rank=rank, tol=tol, gap=gap, what=what)
    for rec in _RECORDERS:
        rec.append(dec)
    if warn and dec.close and not _RECORDERS:
        warnings.warn(
            f"{what}: close rank decision (singular-value gap {gap:.3g} < {GAP_WARN:g} around "
            f"tol {tol:.3g}); the result may change with the tolerance",
            CloseRankWarning,
            stacklevel=3,
        )
    return dec
