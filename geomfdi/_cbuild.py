"""Compiling C sources into shared libraries, once per machine, cached by hash.

The compiled paths of geomfdi (the online monitor's generated C step,
:mod:`geomfdi.deployment.compiled`, and the batch recursion of the simulator,
:mod:`geomfdi.simulation.compiled_recursion`) build their C99 sources with the system's
C compiler (``$CC``, else ``cc``) for the running processor (``-march=native``, retried
without when the compiler refuses) and without fused multiply-add
(``-ffp-contract=off``: sums round as written).  A library is cached under a hash of its
sources, the compiler, the flags and the processor in the cache directory
(``$GEOMFDI_CACHE_DIR``, else ``$XDG_CACHE_HOME/geomfdi/c`` or ``~/.cache/geomfdi/c``),
written to a temporary file and moved into place atomically (:func:`os.replace`), so
concurrent builds of the same source agree.  See the user guide, *Performance*
(``docs/guide/performance.md``).
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

from geomfdi.errors import GeomFDIError

__all__ = [
    "FLAGS",
    "NATIVE",
    "build_library",
    "cache_dir",
    "compiler",
    "environment_key",
    "forget_kernels",
    "load_kernel",
    "processor",
    "typed",
]

# -O3: loops unrolled and vectorised; -ffp-contract=off: no fused multiply-add
FLAGS = ("-O3", "-std=c99", "-ffp-contract=off", "-shared", "-fPIC")
NATIVE = ("-march=native",)


def cache_dir() -> Path:
    """Directory of the compiled libraries (created on first build).

    ``$GEOMFDI_CACHE_DIR`` when set, else ``$XDG_CACHE_HOME/geomfdi/c`` (default
    ``~/.cache/geomfdi/c``).
    """
    env = os.environ.get("GEOMFDI_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "geomfdi" / "c"


def processor() -> str:
    """What identifies this machine's processor (its instruction set extensions)."""
    import platform

    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                if line.startswith(("flags", "Features", "isa")):
                    return line.strip()
    except OSError:
        pass
    return f"{platform.machine()} {platform.processor()}"


def compiler() -> str | None:
    """Path of the C compiler (``$CC``, else ``cc``), or ``None`` when not found."""
    return shutil.which(os.environ.get("CC", "cc"))


def build_library(name: str, files: dict[str, str], main: str, flags: tuple[str, ...] = ()) -> Path:
    """Compile C source texts into a shared library ``<name>_<hash>.so``, cached by hash.

    Parameters
    ----------
    name : str
        Prefix of the library's file name.
    files : dict of str to str
        File name -> text of every source and header (written side by side).
    main : str
        The file compiled (a key of ``files``).
    flags : tuple of str
        More compiler flags (include folders).

    Returns
    -------
    Path
        The library in :func:`cache_dir` (built only when missing).

    Raises
    ------
    GeomFDIError
        No C compiler, or the compiler failed (its message attached).
    """
    import subprocess
    import tempfile

    cc = compiler()
    if cc is None:
        raise GeomFDIError("backend: no C compiler found ($CC or cc)", argument="backend")
    parts = [name, *files.values(), cc, *FLAGS, *NATIVE, *flags, processor()]
    key = hashlib.sha256("\0".join(parts).encode()).hexdigest()[:24]
    out_dir = cache_dir()
    lib = out_dir / f"{name}_{key}.so"
    if lib.exists():
        return lib
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=out_dir) as tmp:
        for fname, text in files.items():
            (Path(tmp) / fname).write_text(text, encoding="utf-8")
        part = Path(tmp) / "lib.so"
        src = str(Path(tmp) / main)
        for native in (NATIVE, ()):  # a compiler refusing -march=native: without
            cmd = [cc, *FLAGS, *native, *flags, "-o", str(part), src, "-lm"]
            try:
                done = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
            except (OSError, subprocess.TimeoutExpired) as exc:
                raise GeomFDIError(
                    f"backend: the C compiler failed: {exc}", argument="backend"
                ) from exc
            if done.returncode == 0:
                break
        if done.returncode != 0:
            raise GeomFDIError(
                f"backend: the C compiler failed: {done.stderr.strip()[:500]}",
                argument="backend",
            )
        os.replace(part, lib)  # atomic: concurrent builds of the same source agree
    return lib


# ---------------------------------------------------------------- loading, once per process
_LOADED: dict[tuple[Any, ...], Any] = {}
_LOAD_LOCK = threading.RLock()  # re-entrant: a failure may load another kernel instead


def environment_key() -> tuple[str | None, ...]:
    """What selects a library besides its source and flags: the variables that set
    :func:`cache_dir` and the compiler (read from the environment: cheap, every call
    checks it)."""
    env = os.environ
    return tuple(env.get(v) for v in ("GEOMFDI_CACHE_DIR", "XDG_CACHE_HOME", "HOME", "CC"))


def typed(fn: Any, kinds: str, restype: Any = ctypes.c_int) -> Any:
    """``fn`` with its ctypes signature: one letter per argument, ``i`` a 64-bit
    integer, ``v`` a pointer (``void *``); ``restype`` the result's type."""
    fn.argtypes = [ctypes.c_int64 if c == "i" else ctypes.c_void_p for c in kinds]
    fn.restype = restype
    return fn


def load_kernel(
    name: str,
    source: Path,
    bind: Callable[[ctypes.CDLL], Any],
    *,
    flags: tuple[str, ...] = (),
    on_fail: Callable[[Exception], Any] | None = None,
) -> Any:
    """The functions of the library built from ``source`` (:func:`build_library`),
    loaded once per process.

    Parameters
    ----------
    name : str
        Library name (the source is compiled as ``<name>.c``).
    source : Path
        The C source file.
    bind : callable
        ``bind(dll)``: picks and types the library's functions (:func:`typed`); what it
        returns is what this returns.
    flags : tuple of str
        More compiler flags.
    on_fail : callable, optional
        ``on_fail(exc)`` when the build or the loading fails (no compiler, a compiler
        error, a library that does not load): its result is returned instead (``None``
        without it), e.g. after a warning, or another kernel.

    Returns
    -------
    object
        ``bind``'s or ``on_fail``'s result, remembered per name, flags and
        :func:`environment_key` (a failure is not retried in the process).
    """
    key = (name, flags, environment_key())
    if key in _LOADED:
        return _LOADED[key]
    with _LOAD_LOCK:
        if key not in _LOADED:
            try:
                src = source.read_text(encoding="utf-8")
                path = build_library(name, {f"{name}.c": src}, f"{name}.c", flags)
                lib = bind(ctypes.CDLL(str(path)))
            except (GeomFDIError, OSError) as exc:
                lib = None if on_fail is None else on_fail(exc)
            _LOADED[key] = lib
        return _LOADED[key]


def forget_kernels() -> None:
    """Forget the loaded kernels (tests: what a new process finds, the cached files)."""
    with _LOAD_LOCK:
        _LOADED.clear()
