"""Input handling shared by the parity-space functions: samples, seeds, overflow guards."""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from geomfdi._validation import as_real_array
from geomfdi.errors import GeomFDIError, NonFiniteError, ShapeError
from geomfdi.parity._records import ParityData

__all__: list[str] = []


def _as_rng(rng: Any) -> np.random.Generator:
    if isinstance(rng, np.random.Generator):
        return rng
    if rng is None or isinstance(rng, int | np.integer | np.random.SeedSequence):
        return np.random.default_rng(rng)
    raise GeomFDIError(
        f"rng: expected a numpy Generator, an integer seed or None, got {type(rng).__name__}",
        argument="rng",
    )


def _raise_nonfinite_block(block: np.ndarray, offset: int, name: str) -> None:
    finite = np.isfinite(block)
    if finite.all():
        raise GeomFDIError(
            f"{name}: entries too large, the statistics overflow (rows {offset}.."
            f"{offset + block.shape[0] - 1})",
            argument=name,
        )
    r, c = np.argwhere(~finite)[0]
    raise NonFiniteError(
        f"{name}: entries must be finite, found {block[r, c]} at index ({offset + r}, {c})",
        argument=name,
    )


def _guarded(fn: Any) -> Any:
    """Run ``fn`` with overflow warnings off and reject non-finite float outputs.

    The inputs were checked finite; a non-finite statistic can then only come from an
    overflow (readings beyond ~1e150), which is reported instead of returned.
    """

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with np.errstate(over="ignore", invalid="ignore"):
            out = fn(*args, **kwargs)
        items = out if isinstance(out, tuple) else (out,)
        for item in items:
            if isinstance(item, np.ndarray) and item.dtype.kind == "f":
                if not np.isfinite(item).all():
                    raise GeomFDIError(
                        "Z: entries too large, the statistics overflow", argument="Z"
                    )
        return out

    return wrapper


# --------------------------------------------------------------------------------------
# the parity-space FDI object


def _samples(pf: ParityData, Z: Any, *, check: bool = True) -> np.ndarray:
    """``Z`` as a float64 (N, m) array; a 1-D vector is one sample."""
    if isinstance(Z, np.ndarray) and Z.dtype == np.float64:
        arr = Z
    else:
        arr = as_real_array(Z, "Z")
        check = False  # as_real_array checked finiteness
    if arr.ndim == 1:
        arr = arr.reshape(1, -1)
    if arr.ndim != 2 or arr.shape[1] != pf.m:
        raise ShapeError(
            f"Z: expected {pf.m} columns (one per sensor) as an (N, {pf.m}) array or "
            f"a length-{pf.m} vector, got shape {np.shape(Z)}",
            argument="Z",
        )
    if check:
        step = 1 << 16
        for start in range(0, arr.shape[0], step):
            block = arr[start : start + step]
            if not np.isfinite(block).all():
                _raise_nonfinite_block(block, start, "Z")
    return arr
