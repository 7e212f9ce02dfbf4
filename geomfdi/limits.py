"""Resource caps checked before geomfdi allocates large arrays or starts long work.

A hostile or mistaken request (``runs = 10**9`` in a model file, ``t_end = 1e308`` with a
tiny step, an exact proof on a large floating-point plant) must fail at once with a
:class:`~geomfdi.errors.ResourceLimitError` naming the argument and estimating the
memory it would take, not after filling the machine's memory.  The caps are:

``max_runs`` (default ``1_000_000``)
    Monte-Carlo runs of one batch or calibration.
``max_samples`` (default ``1_000_000_000``)
    Time samples × runs of one simulation request (one record of ``10**9`` samples, or
    1 000 runs of ``10**6``).
``max_memory`` (default 8 GiB)
    Estimated bytes of the arrays a request allocates (``None``: no byte cap).
``max_symbolic_size`` (default ``16``)
    State dimension of a system treated in exact (sympy) arithmetic, i.e. the plant
    states plus the generator states of one exact transfer; symbolic work grows roughly
    like the fourth power of this size.

One setting is a budget rather than a cap:

``chunk_memory`` (default 64 MiB)
    Working memory of one chunk of a simulation.  :func:`geomfdi.simulate` and
    :func:`geomfdi.simulate_batch` cut the time axis (and the runs) into chunks whose
    temporary arrays (signals, noise draws, decisions) fit in it, the state carried
    from one chunk to the next, so their memory is the returned arrays plus about this
    budget and at most :data:`OVERHEAD_PER_SAMPLE` bytes per time sample (copies kept
    across chunks; measured on a three-state closed loop: 50 MiB over the output for
    200 000 samples and 55 MiB for 800 000 at the default budget, about 35 bytes per
    sample with an 8 MiB budget), a part of the output that does not grow with the
    record's length relative to it.
    A smaller budget means more chunks (more per-chunk overhead); results do not depend
    on it (to rounding, about 1e-15 relative).

Change them for the whole process with :func:`set_limits` or locally with the
:func:`limits` context manager; like the tolerance of :mod:`geomfdi.tolerance`, the local
setting is a :class:`contextvars.ContextVar`, private to the thread or asyncio task.

Examples
--------
>>> import geomfdi as gf
>>> gf.limits.get_limits().max_runs
1000000
>>> with gf.limits.limits(max_runs=10):
...     gf.limits.check_runs(100)
Traceback (most recent call last):
    ...
geomfdi.errors.ResourceLimitError: runs: 100 runs exceed the cap max_runs = 10; ...
"""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
import os
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from geomfdi._validation import as_float, as_int
from geomfdi.errors import GeomFDIError, ResourceLimitError

__all__ = [
    "Limits",
    "check_allocation",
    "check_runs",
    "check_symbolic_size",
    "estimate_bytes",
    "format_bytes",
    "get_limits",
    "limits",
    "reset_limits",
    "set_limits",
]


OVERHEAD_PER_SAMPLE = 48
"""Bytes per time sample a simulation may hold beyond its returned arrays and
``chunk_memory`` (the promise above; checked by the test suite)."""


@dataclass(frozen=True)
class Limits:
    """The resource caps in force (see the module documentation for each)."""

    max_runs: int = 1_000_000
    max_samples: int = 1_000_000_000
    max_memory: float | None = 8 * 2**30
    max_symbolic_size: int = 16
    chunk_memory: float = 64 * 2**20

    def replace(self, **caps: Any) -> Limits:
        """A copy with the given caps changed, each validated."""
        unknown = set(caps) - {f.name for f in dataclasses.fields(self)}
        if unknown:
            name = sorted(unknown)[0]
            raise GeomFDIError(
                f"{name}: unknown limit; known: max_runs, max_samples, max_memory, "
                "max_symbolic_size, chunk_memory",
                argument=name,
            )
        checked: dict[str, Any] = {}
        for name, value in caps.items():
            if name == "max_memory":
                checked[name] = as_float(value, name, minimum=1.0, allow_none=True)
            elif name == "chunk_memory":
                checked[name] = as_float(value, name, minimum=1.0)
            else:
                checked[name] = as_int(value, name, minimum=1)
        return dataclasses.replace(self, **checked)


_GLOBAL = Limits()
_GLOBAL_LOCK = threading.Lock()
_LOCAL: contextvars.ContextVar[Limits | None] = contextvars.ContextVar(
    "geomfdi_limits", default=None
)


def get_limits() -> Limits:
    """The caps in force in the current thread or task."""
    local = _LOCAL.get()
    return _GLOBAL if local is None else local


def set_limits(**caps: Any) -> Limits:
    """Change some caps (``max_runs=...``, ...) and return the new :class:`Limits`.

    Outside any :func:`limits` block this changes the process-wide caps; inside one, the
    caps of that block only (restored when it exits).
    """
    global _GLOBAL
    local = _LOCAL.get()
    if local is not None:
        new = local.replace(**caps)
        _LOCAL.set(new)
        return new
    with _GLOBAL_LOCK:
        _GLOBAL = _GLOBAL.replace(**caps)
        return _GLOBAL


def reset_limits() -> Limits:
    """Back to the default caps (process-wide, or for the current :func:`limits` block)."""
    global _GLOBAL
    if _LOCAL.get() is not None:
        _LOCAL.set(Limits())
        return Limits()
    with _GLOBAL_LOCK:
        _GLOBAL = Limits()
        return _GLOBAL


@contextlib.contextmanager
def limits(**caps: Any) -> Iterator[Limits]:
    """Context manager: use the given caps inside the ``with`` block (this thread or
    task only); the others keep their current value."""
    token = _LOCAL.set(get_limits().replace(**caps))
    try:
        yield _LOCAL.get()  # type: ignore[misc]
    finally:
        _LOCAL.reset(token)


def format_bytes(n: float) -> str:
    """``n`` bytes in binary units (``'4.7 GiB'``)."""
    n = float(n)
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if abs(n) < 1024.0 or unit == "PiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.3g} {unit}"
        n /= 1024.0
    return f"{n:.3g} EiB"  # pragma: no cover - unreachable


def _physical_memory() -> int | None:
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, ValueError, OSError):  # pragma: no cover - non-POSIX
        return None


def estimate_bytes(
    samples: int, runs: int = 1, channels: int = 1, *, itemsize: int = 8, copies: float = 1.0
) -> float:
    """Memory of ``copies`` arrays of ``samples × runs × channels`` items of
    ``itemsize`` bytes (a float, so huge requests do not overflow)."""
    return float(samples) * float(runs) * float(max(channels, 1)) * itemsize * copies


def _memory_note(estimate: float) -> str:
    phys = _physical_memory()
    note = f"about {format_bytes(estimate)}"
    if phys:
        note += f" (this machine has {format_bytes(phys)})"
    return note


def check_runs(runs: Any, *, argument: str = "runs") -> int:
    """Validate a number of Monte-Carlo runs: an integer in ``1..max_runs``.

    Raises
    ------
    GeomFDIError
        ``runs`` is not a positive integer.
    ResourceLimitError
        ``runs`` exceeds ``max_runs``.
    """
    n = as_int(runs, argument, minimum=1)
    cap = get_limits().max_runs
    if n > cap:
        raise ResourceLimitError(
            f"{argument}: {n} runs exceed the cap max_runs = {cap}; raise it with "
            "gf.limits.set_limits(max_runs=...) if this is intended",
            limit="max_runs",
            argument=argument,
        )
    return n


def check_allocation(
    samples: Any,
    runs: Any = 1,
    channels: Any = 1,
    *,
    itemsize: int = 8,
    copies: float = 1.0,
    argument: str = "t",
    runs_argument: str = "runs",
    what: str = "simulation",
) -> float:
    """Check a request of ``samples`` time samples × ``runs`` runs × ``channels``
    signals before allocating it; return the estimated bytes.

    The estimate is ``samples * runs * channels * itemsize * copies`` (``copies``: how
    many arrays of that size the request holds at once).  Call it with the sizes known
    *before* the arrays are created.  ``argument`` names the argument that sets the
    samples, ``runs_argument`` the one that sets the runs (in the errors).

    Raises
    ------
    ResourceLimitError
        ``samples × runs`` exceeds ``max_samples``, ``runs`` exceeds ``max_runs`` or the
        estimate exceeds ``max_memory``.  The message names ``argument`` and gives the
        estimate.
    """
    n_samples = as_int(samples, argument, minimum=0)
    n_runs = check_runs(runs, argument=runs_argument)
    n_channels = as_int(channels, "channels", minimum=0)
    caps = get_limits()
    estimate = estimate_bytes(n_samples, n_runs, n_channels, itemsize=itemsize, copies=copies)
    total = n_samples * n_runs
    if total > caps.max_samples:
        raise ResourceLimitError(
            f"{argument}: {what} of {n_samples} samples x {n_runs} runs = {total:.3g} exceeds "
            f"the cap max_samples = {caps.max_samples:.3g}; it would need "
            f"{_memory_note(estimate)}. Raise the cap with "
            "gf.limits.set_limits(max_samples=...) or use fewer samples or runs",
            limit="max_samples",
            estimate=estimate,
            argument=argument,
        )
    if caps.max_memory is not None and estimate > caps.max_memory:
        raise ResourceLimitError(
            f"{argument}: {what} would need {_memory_note(estimate)}, more than the cap "
            f"max_memory = {format_bytes(caps.max_memory)}. Raise the cap with "
            "gf.limits.set_limits(max_memory=...) or use fewer samples, runs or signals",
            limit="max_memory",
            estimate=estimate,
            argument=argument,
        )
    return estimate


def check_symbolic_size(size: Any, *, argument: str = "plant", what: str = "exact proof") -> int:
    """Check the state dimension of a system about to be treated in exact arithmetic.

    Raises
    ------
    ResourceLimitError
        ``size`` exceeds ``max_symbolic_size``.
    """
    n = as_int(size, argument, minimum=0)
    cap = get_limits().max_symbolic_size
    if n > cap:
        raise ResourceLimitError(
            f"{argument}: {what} on a system of {n} states exceeds the cap "
            f"max_symbolic_size = {cap} (symbolic work grows roughly like size**4: about "
            f"{(n / cap) ** 4:.3g} times the largest allowed); raise it with "
            "gf.limits.set_limits(max_symbolic_size=...) or use the numeric gf.verify",
            limit="max_symbolic_size",
            argument=argument,
        )
    return n
