"""Per-sample decisions of a chunk of runs by the table of alarm patterns, compiled.

Without a persistence rule (and with at most 16 residual rows) the isolation decision of
a sample is a function of its alarm pattern (:class:`~geomfdi.simulation.streaming.
DecisionStream` keeps the table of the ``2^n`` patterns' decisions).  :func:`table_decisions`
computes, in one pass over a chunk's residuals ``r`` (R, n, L) (``compiled_decisions.c``,
built like the batch recursion, :mod:`geomfdi.simulation.compiled_recursion`):

* the alarms ``a_i[k] = |r_i[k]| > v_i``;
* the pattern code ``c[k] = sum_i a_i[k] 2^i`` and the decision ``table[c[k]]``;
* whether any row alarms, ``c[k] != 0``;
* the peaks ``max_k |r_i[k]|`` of each run and row;

the same values as the numpy passes (comparisons and maxima are exact).  It declines
(returns ``None``) when some ``|r|`` is not finite or above ``1e300`` (the general path
then reports it), when ``GEOMFDI_SIM_BACKEND=numpy`` or when no C compiler works.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from geomfdi._cbuild import load_kernel, typed
from geomfdi.simulation.compiled_recursion import sim_backend

__all__ = ["table_decisions"]

_NAME = "gfdec"
_SOURCE = Path(__file__).with_name("compiled_decisions.c")


#: More compiler flags (tests: ``-DGFD_NO_VECTOR_EXT``, the plain loops of compilers
#: without vector types).
_FLAGS: tuple[str, ...] = ()


def _kernel() -> Any:
    """``gfdec_table`` (built on first use), or ``None`` when no compiler works (the
    batch recursion's :class:`~geomfdi.errors.BackendFallbackWarning` says so)."""
    return load_kernel(
        _NAME,
        _SOURCE,
        lambda dll: typed(dll.gfdec_table, "iiiviiivvviiiviiviivv"),
        flags=_FLAGS,
    )


def _strides(a: np.ndarray) -> list[int]:
    return [s // a.itemsize for s in a.strides]


def table_decisions(
    res: np.ndarray,
    thresholds: np.ndarray,
    table: np.ndarray,
    alarms: np.ndarray,
    isolated: np.ndarray,
    any_alarm: np.ndarray,
) -> np.ndarray | None:
    """Alarms, decisions and peaks of a chunk in one compiled pass (module docstring).

    Parameters
    ----------
    res : ndarray, float64 (R, n, L)
        Residual rows (any strides).
    thresholds : ndarray, (n,)
        ``v_i``.
    table : ndarray, int64 (2**n,)
        Decision of every alarm pattern.
    alarms : ndarray, bool (R, n, L)
        Receives ``|r| > v`` (any strides).
    isolated : ndarray, int64 (R, L)
        Receives the decisions.
    any_alarm : ndarray, bool (R, L)
        Receives whether any row alarms.

    Returns
    -------
    ndarray or None
        The peaks (R, n); ``None`` when the kernel declined (nothing usable written).
    """
    R, n, L = res.shape
    if (
        sim_backend() != "c"
        or L == 0
        or res.dtype != np.float64
        or isolated.dtype != np.int64
        or alarms.dtype != np.bool_
        or any_alarm.dtype != np.bool_
        or table.dtype != np.int64
        or table.shape != (2**n,)
        or alarms.shape != res.shape
        or isolated.shape != (R, L)
        or any_alarm.shape != (R, L)
        or not (alarms.flags.writeable and isolated.flags.writeable)
    ):
        return None
    fn = _kernel()
    if fn is None:
        return None
    thr = np.ascontiguousarray(thresholds, dtype=np.float64)
    tab = np.ascontiguousarray(table)
    peaks = np.empty((R, n))
    code = np.empty(L, dtype=np.int64)
    bad = fn(
        R, n, L, res.ctypes.data, *_strides(res), thr.ctypes.data, tab.ctypes.data,
        alarms.ctypes.data, *_strides(alarms), isolated.ctypes.data, *_strides(isolated),
        any_alarm.ctypes.data, *_strides(any_alarm), peaks.ctypes.data, code.ctypes.data,
    )  # fmt: skip
    return None if bad else peaks
