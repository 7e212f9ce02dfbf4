"""Work arrays reused from chunk to chunk and from call to call.

Fresh memory of a chunk's size (megabytes) is mapped from the operating system and
faulted in page by page on first use, then unmapped when freed: a sizeable share of a
simulation's time (a few microseconds per 4 KiB page on a virtual machine).  A
:class:`Workspace` therefore hands out views of one buffer per name, grown when a chunk
needs more; :func:`thread_workspace` keeps one per thread and purpose between calls.
Nothing returned to a caller lives in them.
"""

from __future__ import annotations

import threading
from typing import Any

import numpy as np

__all__ = ["Workspace", "thread_workspace"]

#: Bytes of work arrays a thread keeps between calls, per purpose, at most.
THREAD_WORK_BYTES = 64 * 2**20
_LOCAL = threading.local()


class Workspace:
    """Chunk-sized work arrays, one buffer per name and dtype (module docstring)."""

    def __init__(self) -> None:
        self._bufs: dict[tuple[str, str], np.ndarray] = {}

    def get(self, name: str, shape: tuple[int, ...], dtype: Any = float) -> np.ndarray:
        """An uninitialised C-contiguous array ``shape`` of ``dtype``, the buffer
        ``name`` (its content is that of the previous use)."""
        dt = np.dtype(dtype)
        size = int(np.prod(shape, dtype=np.int64))
        key = (name, dt.str)
        buf = self._bufs.get(key)
        if buf is None or buf.size < size:
            buf = self._bufs[key] = np.empty(size, dtype=dt)
        return buf[:size].reshape(shape)

    @property
    def nbytes(self) -> int:
        """Bytes held by the buffers."""
        return sum(b.nbytes for b in self._bufs.values())


def thread_workspace(purpose: str) -> Workspace:
    """The calling thread's :class:`Workspace` for ``purpose`` (e.g. the recursion's
    chunks, a single run's time chunks: their names do not meet), kept from call to
    call; renewed when its buffers have outgrown :data:`THREAD_WORK_BYTES`."""
    spaces = getattr(_LOCAL, "spaces", None)
    if spaces is None:
        spaces = _LOCAL.spaces = {}
    work = spaces.get(purpose)
    if work is None or work.nbytes > THREAD_WORK_BYTES:
        work = spaces[purpose] = Workspace()
    return work
