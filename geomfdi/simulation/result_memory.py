"""Memory of the arrays a simulation returns, reused once the caller has dropped them.

A fresh array costs a page fault per 4 KiB page on first use (the operating system maps
and zeroes the page): about 2.5 microseconds each on a virtual machine, and a large
share of a short simulation's time (a record of 10^4 samples with a bank of 10 returns
about 1 000 pages).  The C library hands freed memory of that size back to the
operating system, so a loop of simulations would fault every page again at every call.

:func:`empty` allocates the returned arrays from blocks kept per thread instead: a block
is reused when nothing refers to it any more (no array or view of it is alive: its
reference count is the pool's own), so a loop that drops each result (or keeps a
summary of it) reads and writes memory that is already mapped.  Each array has its own
block (keeping one array does not keep the others alive); small arrays (under
``_MIN_BYTES``) and arrays beyond the budget ``_POOL_BYTES`` per thread are plain numpy
arrays.  The arrays are views of their block (``a.base`` is the block), with the values
of :func:`numpy.empty` (not initialised).

Arrays of at least ``_MAPPED_BYTES`` that do not come from a block (too large for the
pool, or the pool is full because the caller keeps its results) are mapped by
:func:`mapped`: one ``mmap`` call with ``MAP_POPULATE`` maps and zeroes all their pages
at once (Linux), instead of one fault per page on first use, or, for numpy's arrays of 4
MiB and more (which ask for huge pages), a compaction of physical memory by the kernel
when no free huge page is at hand.  Arrays of ``_PARALLEL_BYTES`` (64 MiB) and more,
made where geomfdi may use several threads (:func:`geomfdi._threads.work_threads`), are
populated by that many threads at once, a part each (``madvise(MADV_POPULATE_WRITE)``,
:func:`_populate`).  On this kind of machine the populated mapping costs 0.4-0.5 ms per
MB on one thread, steadily, and about half that on two; first touches of
:func:`numpy.empty` arrays cost 0.2-1.9 ms per MB depending on the memory's
fragmentation (``benchmarks/bench_simulation.py``, batch case).  Elsewhere (no
``MAP_POPULATE``) :func:`mapped` is :func:`numpy.zeros`.  Huge pages for the records
(``MADV_HUGEPAGE``, then ``MADV_POPULATE_WRITE``) cost less when free huge pages are at
hand (0.12 s for 1 GB) but the kernel compacts memory when they are not: in the batch
case the records then took 3.6 s of system time against 0.5-1.2 s in small pages, so
they are not used.
"""

from __future__ import annotations

import functools
import math
import mmap
import sys
import threading
from typing import Any

import numpy as np

from geomfdi._threads import work_threads

__all__ = ["empty", "mapped"]

_POOL_BYTES = 64 * 2**20  # kept per thread, at most
_MIN_BYTES = 2**16  # smaller arrays come from the C library's small-block heap anyway
_MAX_BYTES = 2**22  # larger ones: numpy asks for huge pages (a fault per 2 MiB), and their
# release keeps the C library's threshold for mapping fresh memory above the temporaries
_MAPPED_BYTES = 2**20  # from here on, fresh arrays are populated mappings (mapped)
_PARALLEL_BYTES = 2**26  # from here on, the pages are populated by the work threads
_LOCAL = threading.local()
_POPULATE = getattr(mmap, "MAP_POPULATE", 0)
_MADV_POPULATE_WRITE = 23  # Linux's madvise option (5.14 and later)


def mapped(shape: tuple[int, ...], dtype: Any = float, fill: Any = None) -> np.ndarray:
    """A zero-filled array (or filled with ``fill``) in freshly mapped, populated memory.

    One anonymous private ``mmap`` with ``MAP_POPULATE``: the kernel maps and zeroes
    every page in the call (module docstring).  Small arrays (under ``_MAPPED_BYTES``) and
    systems without ``MAP_POPULATE`` get :func:`numpy.zeros`.  The memory is returned to
    the system when the array and every view of it are gone (``a.base`` is the mapping).

    Parameters
    ----------
    shape : tuple of int
    dtype : data-type, optional
    fill : scalar, optional
        The value of every element (zero when None).

    Returns
    -------
    ndarray
        C-contiguous, writeable.
    """
    dt = np.dtype(dtype)
    nbytes = math.prod(shape) * dt.itemsize
    if not _POPULATE or nbytes < _MAPPED_BYTES:
        a = np.zeros(shape, dtype=dt)
    else:
        k = work_threads() if nbytes >= _PARALLEL_BYTES and _madvise() is not None else 1
        flags = mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS | (_POPULATE if k == 1 else 0)
        try:
            m = mmap.mmap(-1, nbytes, flags=flags)
        except OSError:  # e.g. a limit on mappings: the C library's memory instead
            a = np.zeros(shape, dtype=dt)
        else:
            if k > 1:
                _populate(m, nbytes, k)
            a = np.frombuffer(m, dtype=dt, count=math.prod(shape)).reshape(shape)
    if fill is not None and fill != 0:
        a.fill(fill)
    return a


@functools.cache
def _madvise() -> Any:
    """The C library's ``madvise`` (through ctypes, which lets other threads run during
    the call), or None where ``MADV_POPULATE_WRITE`` is unknown (not Linux)."""
    import ctypes

    from geomfdi._libc import libc

    lib = libc() if sys.platform.startswith("linux") else None
    if lib is None:
        return None
    try:
        lib.madvise.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int]
    except AttributeError:  # pragma: no cover - an unusual libc
        return None
    return lib.madvise


def _populate(m: mmap.mmap, nbytes: int, k: int) -> None:
    """The pages of the mapping ``m`` mapped and zeroed by ``k`` threads at once, each a
    part (``madvise(MADV_POPULATE_WRITE)``, Linux 5.14 and later: on 2 cores, 0.24-0.29 s
    for 1 GB against 0.45-0.48 s for one ``MAP_POPULATE``).  A part the kernel refuses
    (an older kernel) stays as it is: its pages fault in on first use."""
    import ctypes

    from geomfdi._threads import thread_pool

    view = ctypes.c_char.from_buffer(m)
    base = ctypes.addressof(view)
    del view  # (no buffer of the mapping left exported: it may be closed)
    page = mmap.PAGESIZE
    per = -(-nbytes // (k * page)) * page
    madvise = _madvise()

    def part(i: int) -> None:
        start = i * per
        if start < nbytes:
            madvise(base + start, min(per, nbytes - start), _MADV_POPULATE_WRITE)

    list(thread_pool(k).map(part, range(k)))


def _pool() -> list[np.ndarray]:
    pool = getattr(_LOCAL, "blocks", None)
    if pool is None:
        pool = _LOCAL.blocks = []
    return pool


def _free_refs() -> int:
    """The reference count :func:`_find` sees for a block nothing else refers to."""
    probe = [np.empty(1, dtype=np.uint8)]
    for blk in probe:
        return sys.getrefcount(blk)
    return 0  # pragma: no cover


_FREE = _free_refs()


def _find(pool: list[np.ndarray], nbytes: int) -> np.ndarray | None:
    """A free block of ``nbytes`` to twice that (none: ``None``)."""
    for blk in pool:
        if nbytes <= blk.size <= 2 * nbytes and sys.getrefcount(blk) <= _FREE:
            return blk
    return None


def empty(shape: tuple[int, ...], dtype: Any = float) -> np.ndarray:
    """An uninitialised array like :func:`numpy.empty`, from a reused block when one is
    free (module docstring).

    Parameters
    ----------
    shape : tuple of int
    dtype : data-type, optional

    Returns
    -------
    ndarray
        C-contiguous, writeable; a view of a pool block when large enough.
    """
    dt = np.dtype(dtype)
    nbytes = math.prod(shape) * dt.itemsize
    if nbytes < _MIN_BYTES:
        return np.empty(shape, dtype=dt)
    if nbytes >= _MAX_BYTES:
        return mapped(shape, dt)
    pool = _pool()
    blk = _find(pool, nbytes)
    if blk is None:
        held = sum(b.size for b in pool)
        if held + nbytes > _POOL_BYTES:
            # drop the free blocks first (the others belong to live arrays)
            pool[:] = [b for b in pool if sys.getrefcount(b) > _FREE]
            held = sum(b.size for b in pool)
            if held + nbytes > _POOL_BYTES:
                return mapped(shape, dt) if nbytes >= _MAPPED_BYTES else np.empty(shape, dt)
        blk = np.empty(nbytes, dtype=np.uint8)
        pool.append(blk)
    return blk[:nbytes].view(dt).reshape(shape)
