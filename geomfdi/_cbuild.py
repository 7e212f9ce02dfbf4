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

import hashlib
import os
import shutil
from pathlib import Path

from geomfdi.errors import GeomFDIError

__all__ = ["FLAGS", "NATIVE", "build_library", "cache_dir", "compiler", "processor"]

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
