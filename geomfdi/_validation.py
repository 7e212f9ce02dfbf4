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
    "INT_MAX",
    "as_matrix",
    "as_vector",
    "as_real_array",
    "as_float",
    "as_positive",
    "as_probability",
    "as_index",
    "as_indices",
    "as_int",
    "as_int_array",
    "as_optional_int",
    "as_bool",
    "as_bool_array",
    "as_choice",
    "as_seed",
    "as_sequence_of",
    "as_labels",
    "as_name",
    "check_finite",
    "check_nonempty",
]

#: Largest integer accepted by :func:`as_int` (``2**63 - 1``): counts, lengths and
#: indices beyond it cannot address memory and overflow numpy and the C libraries.
INT_MAX = int(np.iinfo(np.int64).max)


def _sympy_to_numpy(value: Any) -> Any:
    """A sympy matrix as an object array (through its list form); anything else as is.

    sympy is only imported for values whose type comes from it (a plain list or array
    never pays for the import).
    """
    if type(value).__module__.split(".")[0] != "sympy":
        return value
    import sympy

    if isinstance(value, sympy.MatrixBase):
        return np.array(value.tolist(), dtype=object)
    return value


def _too_large_integer(name: str) -> NonFiniteError:
    return NonFiniteError(
        f"{name}: entries must be finite floats, got an integer too large for float64",
        argument=name,
    )


def as_real_array(value: Any, name: str, *, allow_nonfinite: bool = False) -> np.ndarray:
    """Convert ``value`` to a real float64 array (any number of dimensions).

    ``allow_nonfinite=True`` keeps ``nan``/``inf`` entries (for data streams whose bad
    samples are reported by the caller instead of rejected).
    """
    if value is None:
        raise GeomFDIError(f"{name}: a value is required, got None", argument=name)
    value = _sympy_to_numpy(value)
    if isinstance(value, str | bytes):
        raise GeomFDIError(f"{name}: must be numbers, got text {value!r:.40}", argument=name)
    if isinstance(value, bool | np.bool_):
        raise GeomFDIError(f"{name}: must be numbers, got the boolean {value!r}", argument=name)
    try:
        arr = np.asarray(value)
    except OverflowError as exc:
        raise _too_large_integer(name) from exc
    except Exception as exc:  # ragged nested lists
        raise ShapeError(f"{name}: cannot be read as an array ({exc})", argument=name) from exc
    if arr.dtype == object:
        if any(x is None or isinstance(x, str | bytes) for x in arr.flat):
            raise GeomFDIError(f"{name}: entries must be numbers, got None or text", argument=name)
        try:
            arr = arr.astype(complex)
        except OverflowError as exc:
            raise _too_large_integer(name) from exc
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
    try:
        arr = np.array(arr, dtype=np.float64)
    except OverflowError as exc:  # pragma: no cover - object ints are handled above
        raise NonFiniteError(
            f"{name}: entries must be finite floats, got a value too large for float64",
            argument=name,
        ) from exc
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
    if isinstance(value, bool | np.bool_ | str | bytes) or value is None:
        raise GeomFDIError(f"{name}: must be a real number, got {value!r:.40}", argument=name)
    if isinstance(value, complex | np.complexfloating) or (
        isinstance(value, np.ndarray) and np.iscomplexobj(value)
    ):
        raise ComplexInputError(f"{name}: must be real, got {value!r:.40}", argument=name)
    if isinstance(value, dict | set):
        raise GeomFDIError(f"{name}: must be a real number, got {value!r:.40}", argument=name)
    try:
        arr = np.asarray(value, dtype=float)
    except OverflowError as exc:
        raise NonFiniteError(
            f"{name}: must be finite, got a number too large for float64", argument=name
        ) from exc
    except (TypeError, ValueError) as exc:
        raise GeomFDIError(
            f"{name}: must be a real number, got {value!r:.40}", argument=name
        ) from exc
    if arr.ndim != 0:
        raise ShapeError(f"{name}: must be a scalar, got shape {arr.shape}", argument=name)
    x = float(arr)
    if not np.isfinite(x):
        raise NonFiniteError(f"{name}: must be finite, got {x}", argument=name)
    return x


def as_float(
    value: Any,
    name: str,
    *,
    minimum: float | None = None,
    maximum: float | None = None,
    allow_none: bool = False,
) -> float | None:
    """A finite real number in ``[minimum, maximum]`` (booleans, text, complex rejected).

    ``allow_none=True`` passes ``None`` through (an optional option left unset).
    """
    if value is None and allow_none:
        return None
    x = _as_scalar(value, name)
    if minimum is not None and x < minimum:
        raise GeomFDIError(f"{name}: must be >= {minimum:g}, got {x:g}", argument=name)
    if maximum is not None and x > maximum:
        raise GeomFDIError(f"{name}: must be <= {maximum:g}, got {x:g}", argument=name)
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


def as_int(value: Any, name: str, *, minimum: int | None = None, maximum: int | None = None) -> int:
    """An integer in ``[minimum, maximum]`` (numpy integers accepted; booleans, floats
    and text rejected).  ``maximum`` defaults to :data:`INT_MAX`, so a Python integer
    such as ``10**400`` is reported here instead of overflowing later."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Integral):
        raise GeomFDIError(f"{name}: must be an integer, got {value!r:.40}", argument=name)
    v = int(value)
    top = INT_MAX if maximum is None else min(int(maximum), INT_MAX)
    if minimum is not None and v < minimum:
        raise GeomFDIError(f"{name}: must be >= {minimum}, got {v}", argument=name)
    if v > top:
        shown = f"{v}" if v.bit_length() < 200 else f"an integer of {len(str(v))} digits"
        raise GeomFDIError(f"{name}: must be <= {top}, got {shown}", argument=name)
    if v < -INT_MAX:
        raise GeomFDIError(f"{name}: integer too small, got {v}", argument=name)
    return v


def as_int_array(value: Any, name: str, *, minimum: int | None = None) -> np.ndarray:
    """An array of integers (``intp``): real entries with no fractional part, within
    ``[minimum, INT_MAX]``; booleans rejected."""
    arr = as_real_array(value, name)
    if np.asarray(value).dtype == bool:
        raise GeomFDIError(f"{name}: must be integers, got booleans", argument=name)
    if not np.all(arr == np.round(arr)):
        raise GeomFDIError(f"{name}: entries must be integers", argument=name)
    if arr.size and (arr.max() > INT_MAX or arr.min() < -INT_MAX):
        raise GeomFDIError(f"{name}: integers out of range", argument=name)
    if minimum is not None and arr.size and arr.min() < minimum:
        raise GeomFDIError(f"{name}: entries must be >= {minimum}", argument=name)
    return arr.astype(np.intp)


def as_optional_int(
    value: Any, name: str, *, minimum: int | None = None, maximum: int | None = None
) -> int | None:
    """``None`` or an integer checked by :func:`as_int`."""
    return None if value is None else as_int(value, name, minimum=minimum, maximum=maximum)


def as_bool(value: Any, name: str) -> bool:
    """A boolean flag (``True``/``False`` or numpy booleans; ``0``/``1`` and text rejected)."""
    if not isinstance(value, bool | np.bool_):
        raise GeomFDIError(f"{name}: must be True or False, got {value!r:.40}", argument=name)
    return bool(value)


def as_bool_array(value: Any, name: str) -> np.ndarray:
    """A boolean array: booleans, or numbers that are all exactly 0 or 1 (``nan``,
    complex entries and other values are rejected instead of being read as True)."""
    if isinstance(value, np.ndarray) and value.dtype == bool:
        return value
    arr = as_real_array(value, name)
    if not np.all((arr == 0) | (arr == 1)):
        raise GeomFDIError(f"{name}: entries must be booleans (0 or 1)", argument=name)
    return arr.astype(bool)


def as_choice(value: Any, name: str, choices: Sequence[str]) -> str:
    """One of the strings ``choices``."""
    if not isinstance(value, str) or value not in choices:
        listed = ", ".join(repr(c) for c in choices)
        raise GeomFDIError(f"{name}: must be one of {listed}, got {value!r:.40}", argument=name)
    return value


def as_seed(value: Any, name: str) -> Any:
    """A random seed: ``None``, a non-negative integer, a non-empty sequence of them (the
    entropy of a :class:`numpy.random.SeedSequence`), a ``SeedSequence``, a
    :class:`numpy.random.Generator` or ``BitGenerator`` (returned unchanged; integers as
    ``int``).

    Booleans, floats (also ``nan``), text and negative integers are rejected: numpy would
    either refuse them later with an unrelated message or silently accept a float.
    """
    if value is None or isinstance(
        value, np.random.SeedSequence | np.random.Generator | np.random.BitGenerator
    ):
        return value
    if isinstance(value, Sequence | np.ndarray) and not isinstance(value, str | bytes):
        items = list(np.asarray(value, dtype=object).ravel()) if len(value) else []
        if not items:
            raise GeomFDIError(f"{name}: an empty sequence is not a seed", argument=name)
        return [
            as_seed(v, name) if not isinstance(v, Sequence) else _bad_seed(v, name) for v in items
        ]
    if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Integral):
        raise GeomFDIError(
            f"{name}: must be None, a non-negative integer, a numpy SeedSequence or "
            f"Generator, got {value!r:.40}",
            argument=name,
        )
    v = int(value)
    if v < 0:
        raise GeomFDIError(f"{name}: must be a non-negative integer, got {v}", argument=name)
    return v


def as_sequence_of(
    value: Any, name: str, item_type: type | tuple[type, ...], *, min_length: int = 1
) -> list[Any]:
    """A list of ``item_type`` objects; one such object alone becomes a list of one."""
    what = (
        " / ".join(t.__name__ for t in item_type)
        if isinstance(item_type, tuple)
        else item_type.__name__
    )
    if isinstance(value, str | bytes | dict):
        raise GeomFDIError(f"{name}: must be a list of {what}, got {value!r:.40}", argument=name)
    if not isinstance(value, Sequence | np.ndarray):
        if isinstance(value, item_type):
            return [value]
        raise GeomFDIError(f"{name}: must be a list of {what}, got {value!r:.40}", argument=name)
    items = list(np.ravel(value)) if isinstance(value, np.ndarray) else list(value)
    for k, item in enumerate(items):
        if not isinstance(item, item_type):
            raise GeomFDIError(
                f"{name}: entry {k} must be a {what}, got {item!r:.40}", argument=name
            )
    if len(items) < min_length:
        raise GeomFDIError(
            f"{name}: needs at least {min_length} entries, got {len(items)}", argument=name
        )
    return items


def _bad_seed(value: Any, name: str) -> Any:
    raise GeomFDIError(f"{name}: a seed sequence holds integers, got {value!r:.40}", argument=name)


def as_name(value: Any, name: str, *, max_length: int = 200) -> str:
    """A non-empty label of printable text without line breaks, at most ``max_length``
    characters (labels end up in file names, plot legends and report tables)."""
    if not isinstance(value, str):
        raise GeomFDIError(f"{name}: must be a string, got {value!r:.40}", argument=name)
    if not value.strip():
        raise GeomFDIError(f"{name}: must not be empty", argument=name)
    if len(value) > max_length:
        raise GeomFDIError(
            f"{name}: at most {max_length} characters, got {len(value)}", argument=name
        )
    if not value.isprintable():
        raise GeomFDIError(f"{name}: must be printable text, got {value!r:.40}", argument=name)
    return value


def as_labels(
    value: Any, name: str, *, count: int | None = None, max_length: int = 200
) -> tuple[str, ...]:
    """A sequence of distinct labels (see :func:`as_name`), ``count`` of them if given."""
    if isinstance(value, str | bytes) or not isinstance(value, Sequence | np.ndarray):
        raise GeomFDIError(
            f"{name}: must be a sequence of strings, got {value!r:.40}", argument=name
        )
    labels = tuple(as_name(v, name, max_length=max_length) for v in value)
    if count is not None and len(labels) != count:
        raise ShapeError(f"{name}: expected {count} labels, got {len(labels)}", argument=name)
    seen: set[str] = set()
    for label in labels:
        if label in seen:
            raise GeomFDIError(f"{name}: labels must be distinct, {label!r} repeats", argument=name)
        seen.add(label)
    return labels


def check_nonempty(
    arr: np.ndarray, name: str, *, min_size: int = 1, axis: int | None = None
) -> None:
    """Raise :class:`ShapeError` unless ``arr`` has at least ``min_size`` entries (along
    ``axis`` when given): fitting or calibrating on empty data has no answer."""
    size = arr.size if axis is None else (arr.shape[axis] if arr.ndim > axis else 0)
    if size < min_size:
        where = "" if axis is None else f" along axis {axis}"
        raise ShapeError(
            f"{name}: needs at least {min_size} entries{where}, got shape {arr.shape}",
            argument=name,
        )


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
