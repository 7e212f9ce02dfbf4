"""One BLAS thread around the simulator's small-matrix work (opt out: environment).

The simulator's linear algebra is many small products and factorisations, for which
multithreaded BLAS pays thread start-up on every call (measured: ``gf.simulate`` 2-5x
slower with the default threads on a 2-core machine).  :func:`single_blas_thread` limits
BLAS to one thread for the duration of a call through ``threadpoolctl``; set the
environment variable ``GEOMFDI_BLAS_THREADS=default`` to keep the process's setting.
"""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Iterator
from typing import Any

__all__ = ["single_blas_thread"]

_LOCK = threading.Lock()
_CONTROLLER: list[Any] = []


def _controller() -> Any:
    with _LOCK:
        if not _CONTROLLER:
            try:
                from threadpoolctl import ThreadpoolController

                _CONTROLLER.append(ThreadpoolController())
            except ImportError:  # optional: without it BLAS keeps its threads
                _CONTROLLER.append(None)
        return _CONTROLLER[0]


@contextlib.contextmanager
def single_blas_thread() -> Iterator[None]:
    """Limit BLAS to one thread inside the block (no-op when opted out or unavailable)."""
    if os.environ.get("GEOMFDI_BLAS_THREADS", "").lower() == "default":
        yield
        return
    ctrl = _controller()
    if ctrl is None:
        yield
        return
    with ctrl.limit(limits=1, user_api="blas"):
        yield
