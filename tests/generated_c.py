"""Compile a generated C monitor and run it on recorded data (the deployment tests)."""

from __future__ import annotations

import ctypes
import shutil
import subprocess
from collections.abc import Sequence
from pathlib import Path

import numpy as np

CC = shutil.which("cc")


def compile_c(c_file: Path, out: Path, cflags: Sequence[str] = ("-std=c99", "-O2")) -> ctypes.CDLL:
    """``c_file`` built into a shared library in ``out`` and loaded; the compiler must
    accept it (its messages are the failure's text)."""
    lib = out / f"lib{c_file.stem}.so"
    proc = subprocess.run(
        [CC, *cflags, "-shared", "-fPIC", "-o", str(lib), str(c_file), "-lm"],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    return ctypes.CDLL(str(lib))


def run_c(
    lib: ctypes.CDLL, name: str, Y: np.ndarray, U: np.ndarray, rows: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The generated ``name_run`` over the samples (columns) of ``Y`` and ``U``: residuals
    ``(rows, N)``, alarms ``(rows, N)`` and isolated fault ``(N,)``."""
    n = Y.shape[1]
    state = ctypes.create_string_buffer(getattr(lib, f"{name}_state_size")())
    getattr(lib, f"{name}_init")(state)
    Yc, Uc = np.ascontiguousarray(Y.T), np.ascontiguousarray(U.T)
    R = np.zeros((n, rows))
    Al = np.zeros((n, rows), dtype=np.intc)
    iso = np.zeros(n, dtype=np.intc)
    run = getattr(lib, f"{name}_run")
    run.argtypes = [ctypes.c_void_p, ctypes.c_long] + [ctypes.c_void_p] * 5
    ptr = lambda a: a.ctypes.data_as(ctypes.c_void_p)  # noqa: E731
    run(state, n, ptr(Yc), ptr(Uc), ptr(R), ptr(Al), ptr(iso))
    return R.T, Al.T.astype(bool), iso.astype(int)
