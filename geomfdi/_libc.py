"""The process's C library through ctypes, loaded once (the allocator settings of a
campaign's workers, :mod:`geomfdi.campaign.executors`; the populated mappings of large
records, :mod:`geomfdi.simulation.result_memory`)."""

from __future__ import annotations

import ctypes
import functools
import platform

__all__ = ["is_glibc", "libc"]


@functools.cache
def libc() -> ctypes.CDLL | None:
    """The C library the process runs with (its ``errno`` kept), or None."""
    try:
        return ctypes.CDLL(None, use_errno=True)
    except OSError:  # pragma: no cover - a static interpreter
        return None


@functools.cache
def is_glibc() -> bool:
    """Whether that library is glibc (read once: it scans the interpreter's binary)."""
    return platform.libc_ver()[0] == "glibc"
