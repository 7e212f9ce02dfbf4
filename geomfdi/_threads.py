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
"""

from __future__ import annotations

import contextvars
import functools
import os
import sys
from collections.abc import Callable
from typing import Any, TypeVar

from geomfdi.errors import GeomFDIError

__all__ = ["get_blas_threads", "limit_blas_threads", "set_blas_threads"]

F = TypeVar("F", bound=Callable[..., Any])

ENV_VAR = "GEOMFDI_BLAS_THREADS"

_inside: contextvars.ContextVar[bool] = contextvars.ContextVar(
    "geomfdi_blas_limited", default=False
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
        try:
            _get_controller()
            for lc in _blas:
                old = lc.get_num_threads()
                if old is not None and old != limit:
                    lc.set_num_threads(limit)
                    changed.append((lc, old))
            return func(*args, **kwargs)
        finally:
            for lc, old in reversed(changed):
                lc.set_num_threads(old)
            _inside.reset(token)

    return wrapper  # type: ignore[return-value]
