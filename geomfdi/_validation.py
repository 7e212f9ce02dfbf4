"""Input conversion shared by every public entry point.

Each helper converts its argument to a ``float64`` numpy array (nested lists are
accepted), checks it, and raises a :class:`~geomfdi.errors.GeomFDIError` subclass
naming the argument when it is unusable.  Modelled on python-control's
``_ssmatrix(A, name=...)``.
"""

from __future__ import annotations

import numbers
from collections.abc import Sequence
from typing import Any

import numpy as np

from geomfdi.errors import ComplexInputError, GeomFDIError, NonFiniteError, ShapeError

__all__ = [
    "as_matrix",
    "as_vector",
    "as_real_array",
    "as_positive",
    "as_probability",
    "as_index",
    "as_int",
    "check_finite",
]


def _sympy_to_numpy(value: Any) -> Any:
    try:  # sympy matrices convert through their list form
        import sympy

        if isinstance(value, sympy.MatrixBase):
            return np.array(value.tolist(), dtype=object)
    except ImportError:  # pragma: no cover - sympy is a dependency
        pass
    return value


def as_real_array(value: Any, name: str, *, allow_nonfinite: bool = False) -> np.ndarray:
    """Convert ``value`` to a real float64 array (any number of dimensions).

    ``allow_nonfinite=True`` keeps ``nan``/``inf`` entries (for data streams whose bad
    samples are reported by the caller instead of rejected).
    """
    if value is None:
        raise GeomFDIError(f"{name}: a value is required, got None", argument=name)
    value = _sympy_to_numpy(value)
    try:
        arr = np.asarray(value)
    except Exception as exc:  # ragged nested lists
        raise ShapeError(f"{name}: cannot be read as an array ({exc})", argument=name) from exc
    if arr.dtype == object:
        if any(x is None or isinstance(x, str | bytes) for x in arr.flat):
            raise GeomFDIError(f"{name}: entries must be numbers, got None or text", argument=name)
        try:
            arr = arr.astype(complex)
        except (TypeError, ValueError) as exc:
            raise GeomFDIError(
                f"{name}: entries must be numbers (could not convert {arr.dtype} data)",
                argument=name,
            ) from exc
        if np.all(arr.imag == 0):
            arr = arr.real
    if np.iscomplexobj(arr):
        if np.any(np.imag(arr) != 0):
            raise ComplexInputError(f"{name}: must be real, got complex entries", argument=name)
        arr = np.real(arr)
    if arr.dtype.kind not in "biuf":
        raise GeomFDIError(
            f"{name}: entries must be real numbers, got dtype {arr.dtype}", argument=name
        )
    arr = np.array(arr, dtype=np.float64)
    if not allow_nonfinite:
        check_finite(arr, name)
    return arr


def check_finite(arr: np.ndarray, name: str) -> None:
    """Raise :class:`NonFiniteError` if ``arr`` holds ``nan`` or ``inf``."""
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        where = tuple(int(i) for i in bad)
        raise NonFiniteError(
            f"{name}: entries must be finite, found {arr[where]} at index {where}",
            argument=name,
        )


def as_matrix(
    value: Any,
    name: str,
    *,
    rows: int | None = None,
    cols: int | None = None,
    square: bool = False,
    allow_empty: bool = False,
    vector_as: str | None = None,
) -> np.ndarray:
    """Convert ``value`` to a real 2-D float64 array and check its shape.

    Parameters
    ----------
    value
        Array-like (nested list, numpy array, sympy Matrix).
    name
        Argument name used in error messages.
    rows, cols
        Required number of rows / columns (``None``: any).
    square
        Require a square matrix.
    allow_empty
        Accept a matrix with zero rows or columns.
    vector_as
        How to read a 1-D input: ``"column"`` (n, 1), ``"row"`` (1, n) or ``None``
        (rejected).
    """
    arr = as_real_array(value, name)
    if arr.ndim == 0:
        arr = arr.reshape(1, 1)
    elif arr.ndim == 1:
        if vector_as == "column":
            arr = arr.reshape(-1, 1)
        elif vector_as == "row":
            arr = arr.reshape(1, -1)
        else:
            raise ShapeError(
                f"{name}: must be a 2-D matrix, got a 1-D array of length {arr.shape[0]}",
                argument=name,
            )
    elif arr.ndim > 2:
        raise ShapeError(f"{name}: must be a 2-D matrix, got shape {arr.shape}", argument=name)
    r, c = arr.shape
    if not allow_empty and (r == 0 or c == 0):
        raise ShapeError(f"{name}: must not be empty, got shape {arr.shape}", argument=name)
    if square and r != c:
        raise ShapeError(f"{name}: must be square, got shape {arr.shape}", argument=name)
    if rows is not None and r != rows:
        raise ShapeError(f"{name}: expected {rows} rows, got shape {arr.shape}", argument=name)
    if cols is not None and c != cols:
        raise ShapeError(f"{name}: expected {cols} columns, got shape {arr.shape}", argument=name)
    return arr


def as_vector(
    value: Any, name: str, *, length: int | None = None, allow_empty: bool = False
) -> np.ndarray:
    """Convert ``value`` to a real 1-D float64 array (a scalar becomes length 1)."""
    arr = as_real_array(value, name)
    if arr.ndim == 0:
        arr = arr.reshape(1)
    elif arr.ndim == 2 and 1 in arr.shape:
        arr = arr.reshape(-1)
    elif arr.ndim != 1:
        raise ShapeError(f"{name}: must be a vector, got shape {arr.shape}", argument=name)
    if not allow_empty and arr.size == 0:
        raise ShapeError(f"{name}: must not be empty", argument=name)
    if length is not None and arr.shape[0] != length:
        raise ShapeError(
            f"{name}: expected length {length}, got length {arr.shape[0]}", argument=name
        )
    return arr


def _as_scalar(value: Any, name: str) -> float:
    if isinstance(value, bool) or value is None:
        raise GeomFDIError(f"{name}: must be a real number, got {value!r}", argument=name)
    if isinstance(value, complex) or np.iscomplexobj(value):
        raise ComplexInputError(f"{name}: must be real, got {value!r}", argument=name)
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise GeomFDIError(f"{name}: must be a real number, got {value!r}", argument=name) from exc
    if arr.ndim != 0:
        raise ShapeError(f"{name}: must be a scalar, got shape {arr.shape}", argument=name)
    x = float(arr)
    if not np.isfinite(x):
        raise NonFiniteError(f"{name}: must be finite, got {x}", argument=name)
    return x


def as_positive(value: Any, name: str, *, strict: bool = True) -> float:
    """A finite real number > 0 (``strict``) or >= 0."""
    x = _as_scalar(value, name)
    if (strict and x <= 0) or (not strict and x < 0):
        rel = "> 0" if strict else ">= 0"
        raise GeomFDIError(f"{name}: must be {rel}, got {x}", argument=name)
    return x


def as_probability(value: Any, name: str) -> float:
    """A number strictly between 0 and 1 (a false-alarm rate, a confidence level)."""
    x = _as_scalar(value, name)
    if not 0.0 < x < 1.0:
        raise GeomFDIError(f"{name}: must lie in the open interval (0, 1), got {x}", argument=name)
    return x


def as_int(value: Any, name: str, *, minimum: int | None = None) -> int:
    """An integer (numpy integers accepted, booleans and floats rejected)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise GeomFDIError(f"{name}: must be an integer, got {value!r}", argument=name)
    v = int(value)
    if minimum is not None and v < minimum:
        raise GeomFDIError(f"{name}: must be >= {minimum}, got {v}", argument=name)
    return v


def as_index(value: Any, name: str, size: int) -> int:
    """A 0-based index into a collection of ``size`` items (negative indices rejected)."""
    v = as_int(value, name)
    if not 0 <= v < size:
        raise GeomFDIError(
            f"{name}: index {v} out of range, must be in 0..{size - 1}", argument=name
        )
    return v


def as_indices(value: Any, name: str, size: int) -> tuple[int, ...]:
    """One index or a sequence of distinct indices (see :func:`as_index`)."""
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        return (as_index(value, name, size),)
    if not isinstance(value, Sequence | np.ndarray):
        raise GeomFDIError(
            f"{name}: must be an index or a sequence of indices, got {value!r}", argument=name
        )
    out = tuple(as_index(v, name, size) for v in value)
    if len(set(out)) != len(out):
        raise GeomFDIError(f"{name}: indices must be distinct, got {list(out)}", argument=name)
    return out
