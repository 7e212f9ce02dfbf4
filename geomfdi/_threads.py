"""BLAS thread limits around geomfdi's small-matrix linear algebra.

The geometric design, the verification and the simulator make thousands of LAPACK calls
on matrices of a few dozen rows.  A multithreaded BLAS (OpenBLAS, MKL) starts or wakes
its worker threads for each of them, which makes such code 5-20 times slower than with
one thread on a busy machine.  The public entry points of geomfdi therefore run with the
BLAS limited to ``get_blas_threads()`` threads (one by default), through
threadpoolctl's limits of the loaded BLAS libraries, and restore the previous setting on return.

Opt out with ``gf.set_blas_threads(None)`` (or the environment variable
``GEOMFDI_BLAS_THREADS=default`` before ``import geomfdi``); choose another count with
``gf.set_blas_threads(4)`` or ``GEOMFDI_BLAS_THREADS=4``.

The limit is process-wide (a BLAS library has one thread pool); nested entry points
(``design_bank`` calling ``design_residual_generator``) switch it once, at the outermost
call, so the decorator costs one context-variable lookup when already inside.

The cores the limit takes from the BLAS are given to geomfdi's own threads where the work
splits into independent parts of some size (the noise draws of a batch's runs): an entry
point called from a process's main thread may use as many threads as the BLAS libraries
were set to when it began (:func:`work_threads`; one under
``threadpoolctl.threadpool_limits(1)`` or ``OPENBLAS_NUM_THREADS=1``).  Calls from other
threads (a Dask worker's task threads, a thread pool of the caller's) and campaign tasks
in worker processes use one, so parallel executors do not oversubscribe the cores.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import os
import sys
import threading
from collections.abc import Callable, Iterator
from typing import Any, TypeVar

from geomfdi.errors import GeomFDIError

__all__ = [
    "get_blas_threads",
    "limit_blas_threads",
    "set_blas_threads",
    "using_work_threads",
    "thread_pool",
    "work_threads",
]

F = TypeVar("F", bound=Callable[..., Any])

ENV_VAR = "GEOMFDI_BLAS_THREADS"

_inside: contextvars.ContextVar[bool] = contextvars.ContextVar(
    "geomfdi_blas_limited", default=False
)
_work: contextvars.ContextVar[int] = contextvars.ContextVar("geomfdi_work_threads", default=1)
_chosen: contextvars.ContextVar[int | None] = contextvars.ContextVar(
    "geomfdi_work_threads_chosen", default=None
)
_controller: Any = None
_blas: list[Any] = []  # its BLAS libraries (threadpoolctl's LibController objects)
_modules_seen = -1  # len(sys.modules) when _controller was made


def _parse(value: Any, name: str) -> int | None:
    """``None`` (no limit) or a positive thread count, from an int or a string."""
    if value is None:
        return None
    if isinstance(value, str):
        text = value.strip().lower()
        if text in ("", "default", "none", "off"):
            return None
        try:
            value = int(text)
        except ValueError:
            raise GeomFDIError(
                f"{name}: expected a positive integer or 'default', got {value!r}", argument=name
            ) from None
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise GeomFDIError(
            f"{name}: expected a positive integer or None, got {value!r}", argument=name
        )
    return value


_limit: int | None = _parse(os.environ.get(ENV_VAR, "1"), ENV_VAR)


def set_blas_threads(threads: int | None) -> None:
    """Set the number of BLAS threads geomfdi's entry points run with.

    Parameters
    ----------
    threads : int or None
        A positive thread count (default 1), or ``None`` to leave the BLAS libraries
        alone (their own default, usually one thread per core).

    Raises
    ------
    GeomFDIError
        ``threads`` is not a positive integer or None.

    Examples
    --------
    >>> import geomfdi as gf
    >>> gf.set_blas_threads(None)   # opt out
    >>> gf.get_blas_threads() is None
    True
    >>> gf.set_blas_threads(1)      # the default
    """
    global _limit
    _limit = _parse(threads, "threads")


def get_blas_threads() -> int | None:
    """The BLAS thread count of geomfdi's entry points (``None``: not limited)."""
    return _limit


def _get_controller() -> Any:
    """threadpoolctl's controller of the BLAS libraries loaded now.

    A controller knows the libraries loaded when it was made (scipy's OpenBLAS is a
    library of its own, loaded with ``scipy.linalg``, often after the first limited
    call), so it is made again whenever modules were imported since: a new BLAS comes
    with an import.  Cost: one ``len(sys.modules)`` per call once the imports settle.
    """
    global _controller, _blas, _modules_seen
    seen = len(sys.modules)
    if _controller is None or seen != _modules_seen:
        from threadpoolctl import ThreadpoolController

        _controller = ThreadpoolController()
        _blas = [lc for lc in _controller.lib_controllers if lc.user_api == "blas"]
        _modules_seen = len(sys.modules)  # after threadpoolctl's own import
    return _controller


def limit_blas_threads(func: F) -> F:
    """Decorator: run ``func`` with the BLAS limited to :func:`get_blas_threads` threads.

    Nested decorated calls switch the limit once (at the outermost call); with
    ``set_blas_threads(None)`` the wrapper only forwards the call.  Each BLAS library
    (threadpoolctl's controllers) is set only when its thread count differs from the
    limit, and set back on return: a few microseconds per call (a short record, a
    monitor's chunk of a few samples), nothing to set when the BLAS already runs one
    thread.
    """

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        limit = _limit
        if limit is None or _inside.get():
            return func(*args, **kwargs)
        token = _inside.set(True)
        changed = []
        cores = 1
        try:
            _get_controller()
            for lc in _blas:
                old = lc.get_num_threads()
                if old is not None:
                    cores = max(cores, int(old))
                    if old != limit:
                        lc.set_num_threads(limit)
                        changed.append((lc, old))
            if threading.current_thread() is not threading.main_thread():
                cores = 1
            chosen = _chosen.get()
            work = _work.set(min(cores, os.cpu_count() or 1) if chosen is None else chosen)
            try:
                return func(*args, **kwargs)
            finally:
                _work.reset(work)
        finally:
            for lc, old in reversed(changed):
                lc.set_num_threads(old)
            _inside.reset(token)

    return wrapper  # type: ignore[return-value]


def work_threads() -> int:
    """Threads geomfdi's own parallel parts may use inside the current entry point.

    As many as the BLAS libraries were set to when the outermost entry point began
    (module docstring), at most the machine's cores; 1 outside an entry point, with
    ``set_blas_threads(None)`` (the BLAS keeps its threads, nothing is freed) and in a
    thread other than the main one; inside :func:`using_work_threads`, its count.
    """
    return _work.get()


@contextlib.contextmanager
def using_work_threads(threads: int) -> Iterator[None]:
    """Run the body with :func:`work_threads` equal to ``threads``, also inside the entry
    points it calls (1 for a campaign task in a worker process: the workers already share
    the cores)."""
    threads = max(1, int(threads))
    token, chosen = _work.set(threads), _chosen.set(threads)
    try:
        yield
    finally:
        _chosen.reset(chosen)
        _work.reset(token)


_pools: dict[int, Any] = {}
_pool_lock = threading.Lock()


def _forget_pools() -> None:
    """In a forked child: the parent's pool threads do not exist there."""
    global _pool_lock
    _pools.clear()
    _pool_lock = threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_pools)


def thread_pool(threads: int) -> Any:
    """A process-wide ``ThreadPoolExecutor`` of ``threads`` workers (made once, kept; a
    forked child makes its own)."""
    with _pool_lock:
        pool = _pools.get(threads)
        if pool is None:
            from concurrent.futures import ThreadPoolExecutor

            pool = _pools[threads] = ThreadPoolExecutor(threads, thread_name_prefix="geomfdi")
        return pool
