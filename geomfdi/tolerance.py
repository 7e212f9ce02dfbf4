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

Every decision records the operation (``what``) and the step of the algorithm that took it
(``where``: the innermost :func:`decision_stage`, e.g. ``"W*"``, ``"S*"``);
:func:`closest_decision` picks the one with the smallest gap.  A residual design reports
its closest decision in ``g.info["rank_decisions"]`` (see the user guide, *Synthesis*,
``docs/guide/synthesis.md``).

``rtol`` can be changed for the whole process with :func:`set_rtol` or locally with the
:func:`tolerance` context manager; ``None`` restores the default.

Thread and task safety
----------------------
The local setting and the decision recorders live in :mod:`contextvars`: a
``with tolerance(...)`` block or a ``with record_decisions()`` block affects only the
thread (or :mod:`asyncio` task) that entered it, never a design running concurrently in
another thread.  :func:`set_rtol` called outside any ``tolerance`` block sets the
process-wide default, seen by every thread that is not inside such a block; called inside
one, it changes the setting of that block only (restored when the block exits).  A new
thread starts outside any block (``threading`` does not copy the context), so a thread
pool started inside ``with tolerance(...)`` should enter its own block, or run its work
with :func:`contextvars.copy_context`.
"""

from __future__ import annotations

import contextlib
import contextvars
import threading
import warnings
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from geomfdi._validation import as_probability

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
    "decision_stage",
    "closest_decision",
]

GAP_WARN = 1e3
_EPS = float(np.finfo(float).eps)

# Process-wide default set by ``set_rtol`` outside any ``tolerance`` block.
_GLOBAL_RTOL: float | None = None
_GLOBAL_LOCK = threading.Lock()


class _Unset:
    """Marker: no ``tolerance`` block is active in this context."""


_UNSET = _Unset()
# The setting of the innermost active ``tolerance`` block (``None``: the default).
_LOCAL_RTOL: contextvars.ContextVar[float | None | _Unset] = contextvars.ContextVar(
    "geomfdi_rtol", default=_UNSET
)
# The step of an algorithm the current decisions belong to (``decision_stage``).
_STAGE: contextvars.ContextVar[str] = contextvars.ContextVar("geomfdi_rank_stage", default="")
# The lists collecting decisions for the active ``record_decisions`` blocks.
_RECORDERS: contextvars.ContextVar[tuple[list[RankDecision], ...]] = contextvars.ContextVar(
    "geomfdi_rank_recorders", default=()
)


class CloseRankWarning(UserWarning):
    """A rank decision had a small singular-value gap (see :data:`GAP_WARN`)."""


def default_rtol(n: int) -> float:
    """Default relative tolerance ``1e3 * max(n, 1) * eps``."""
    return 1e3 * max(int(n), 1) * _EPS


def _current_rtol() -> float | None:
    local = _LOCAL_RTOL.get()
    return _GLOBAL_RTOL if isinstance(local, _Unset) else local


def get_rtol(n: int) -> float:
    """The relative tolerance in force for ambient dimension ``n`` in this context."""
    rtol = _current_rtol()
    return rtol if rtol is not None else default_rtol(n)


def _checked(rtol: float | None) -> float | None:
    return None if rtol is None else as_probability(rtol, "rtol")


def set_rtol(rtol: float | None) -> None:
    """Set the relative tolerance (``None``: back to the default ``1e3 * n * eps``).

    Outside any :func:`tolerance` block this sets the process-wide default (every
    thread not inside a block sees it); inside one it changes that block's setting in
    the current thread or task only.

    Raises
    ------
    GeomFDIError
        ``rtol`` is not a finite number in the open interval (0, 1)
        (``argument == "rtol"``).
    """
    global _GLOBAL_RTOL
    rtol = _checked(rtol)
    if isinstance(_LOCAL_RTOL.get(), _Unset):
        with _GLOBAL_LOCK:
            _GLOBAL_RTOL = rtol
    else:
        _LOCAL_RTOL.set(rtol)


@contextlib.contextmanager
def tolerance(rtol: float | None) -> Iterator[None]:
    """Context manager: use ``rtol`` inside the ``with`` block (``None``: the default).

    The setting is local to the current thread or :mod:`asyncio` task (a
    :class:`contextvars.ContextVar`); other threads keep theirs.  Blocks nest; the
    previous setting is restored on exit, also after an exception.
    """
    token = _LOCAL_RTOL.set(_checked(rtol))
    try:
        yield
    finally:
        _LOCAL_RTOL.reset(token)


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
    what : str
        The operation (e.g. ``"S ∩ Ker C"``).
    where : str
        The step of the algorithm that took it (the innermost :func:`decision_stage`,
        e.g. ``"W*"``, ``"S*"``; empty outside any stage).
    """

    rank: int
    tol: float
    gap: float
    what: str = ""
    where: str = ""

    @property
    def close(self) -> bool:
        """True when the gap is below :data:`GAP_WARN`."""
        return self.gap < GAP_WARN


@contextlib.contextmanager
def record_decisions() -> Iterator[list[RankDecision]]:
    """Collect every rank decision taken inside the block (and silence their warnings).

    Algorithms use this to keep the smallest gap behind their result and to issue one
    summary :class:`CloseRankWarning` instead of many.  Only decisions taken in the
    current thread or :mod:`asyncio` task are collected.
    """
    rec: list[RankDecision] = []
    token = _RECORDERS.set((*_RECORDERS.get(), rec))
    try:
        yield rec
    finally:
        _RECORDERS.reset(token)


@contextlib.contextmanager
def decision_stage(name: str) -> Iterator[None]:
    """Label the rank decisions taken inside the block with ``name`` (their ``where``).

    Blocks nest (the innermost label wins) and are local to the current thread or
    :mod:`asyncio` task, like :func:`record_decisions`.
    """
    token = _STAGE.set(str(name))
    try:
        yield
    finally:
        _STAGE.reset(token)


def closest_decision(decisions: Iterable[RankDecision]) -> RankDecision | None:
    """The decision with the smallest gap (``None`` when there is none)."""
    return min(decisions, key=lambda d: d.gap, default=None)


def rank_decision(
    s: np.ndarray,
    scale: float,
    n: int,
    *,
    what: str = "rank decision",
    warn: bool = True,
    noise: float = 0.0,
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
    noise : float
        Relative rounding level of the data beyond ``eps`` (e.g. the error of directions
        extracted from a strong cancellation in an earlier step of a recursion): the
        tolerance is ``max(rtol, noise) · scale``.
    """
    s = np.asarray(s, dtype=float)
    scale = float(scale) if scale > 0 else 1.0
    local = _LOCAL_RTOL.get()  # get_rtol(n), inlined: one call per step of a recursion
    rtol = _GLOBAL_RTOL if isinstance(local, _Unset) else local
    tol = max(rtol if rtol is not None else 1e3 * max(int(n), 1) * _EPS, float(noise)) * scale
    if s.size <= 16:  # the few values of a recursion step: plain floats, no array calls
        rank, gap = _decide(s.ravel().tolist(), tol, scale)
    else:
        rank = int(np.count_nonzero(s > tol))
        kept = float(s[rank - 1]) if rank > 0 else scale
        dropped = float(s[rank]) if rank < s.size else 0.0
        gap = kept / max(dropped, _EPS * scale)
    dec = RankDecision(rank=rank, tol=tol, gap=gap, what=what, where=_STAGE.get())
    _record((dec,), warn, 3)
    return dec


def _decide(sv: list[float], tol: float, scale: float) -> tuple[int, float]:
    """Rank and gap of :func:`rank_decision` from a few descending singular values given
    as plain floats (``scale > 0``, ``tol`` the absolute threshold): for recursions that
    take one small decision per step and record them with :func:`_record`."""
    rank = len([v for v in sv if v > tol])
    kept = sv[rank - 1] if rank > 0 else scale
    dropped = sv[rank] if rank < len(sv) else 0.0
    return rank, kept / max(dropped, _EPS * scale)


def _stage() -> str:
    """The label of the innermost :func:`decision_stage` (empty outside any)."""
    return _STAGE.get()


def _record(decisions: Sequence[RankDecision], warn: bool = True, stacklevel: int = 2) -> None:
    """Hand decisions to the active :func:`record_decisions` blocks, in order; without
    any, warn of each close one (:class:`CloseRankWarning`) when ``warn``."""
    recorders = _RECORDERS.get()
    for rec in recorders:
        rec.extend(decisions)
    if not warn or recorders:
        return
    for dec in decisions:
        if dec.close:
            warnings.warn(
                f"{dec.what}: close rank decision (singular-value gap {dec.gap:.3g} < "
                f"{GAP_WARN:g} around tol {dec.tol:.3g}); the result may change with the "
                "tolerance",
                CloseRankWarning,
                stacklevel=stacklevel + 1,
            )
