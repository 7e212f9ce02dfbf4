"""Signal names and operating points of a plant (see the user guide, *Physical plants*,
``docs/guide/physical-plants.md``).

A plant's inputs, outputs, states, disturbances and noise inputs carry names
(python-control's ``inputs=``, ``outputs=``, ``states=``; defaults ``u0, u1, ...``,
``y0, ...``, ``x0, ...``, ``d0, ...``, ``w0, ...``, the column names of recorded data).
A linearised plant also carries its operating point ``x_op, u_op, y_op``: the linear model
holds for the deviations ``x - x_op``, ``u - u_op``, ``y - y_op``.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import Any

import numpy as np

from geomfdi.errors import GeomFDIError, ShapeError

__all__ = [
    "default_names",
    "check_names",
    "check_point",
    "index_of",
    "c_identifier",
    "python_control_names",
    "bank_signals",
]

_PREFIX = {"inputs": "u", "outputs": "y", "states": "x", "disturbances": "d", "noise": "w"}
_PC_DEFAULT = re.compile(r"^[uyxdw]\[\d+\]$")


def default_names(kind: str, count: int) -> tuple[str, ...]:
    """``u0, u1, ...`` (inputs), ``y0, ...`` (outputs), ``x0, ...``, ``d0, ...``, ``w0, ...``
    (noise inputs)."""
    return tuple(f"{_PREFIX[kind]}{i}" for i in range(count))


def check_names(names: Any, count: int, kind: str) -> tuple[str, ...]:
    """``names`` as a tuple of ``count`` distinct non-empty strings (``None``: defaults).

    A single string is accepted for one signal.  Raises :class:`ShapeError` naming
    ``kind`` on a wrong count and :class:`GeomFDIError` on empty or repeated names.
    """
    if names is None:
        return default_names(kind, count)
    if isinstance(names, str):
        names = [names]
    try:
        out = tuple(names)
    except TypeError as exc:
        raise GeomFDIError(
            f"{kind}: expected a list of {count} names, got {type(names).__name__}",
            argument=kind,
        ) from exc
    if len(out) != count:
        raise ShapeError(f"{kind}: expected {count} names, got {len(out)}", argument=kind)
    bad = [v for v in out if not isinstance(v, str) or not v.strip()]
    if bad:
        raise GeomFDIError(f"{kind}: names must be non-empty strings, got {bad}", argument=kind)
    out = tuple(v.strip() for v in out)
    seen: set[str] = set()
    dup = sorted({v for v in out if v in seen or seen.add(v)})  # type: ignore[func-returns-value]
    if dup:
        raise GeomFDIError(f"{kind}: repeated names {dup}", argument=kind)
    return out


def python_control_names(labels: Sequence[str], kind: str) -> tuple[str, ...] | None:
    """python-control's labels, or ``None`` when they are its generated defaults
    (``u[0]``, ``y[1]``, ...): then geomfdi's own defaults apply."""
    labels = [str(v) for v in labels]
    if labels and all(_PC_DEFAULT.match(v) for v in labels):
        return None
    return tuple(labels)


def check_point(value: Any, count: int, name: str) -> np.ndarray:
    """An operating-point vector of length ``count`` (``None``: zeros), finite, read-only."""
    if value is None:
        out = np.zeros(count)
    else:
        try:
            out = np.array(value, dtype=float).reshape(-1)
        except (TypeError, ValueError) as exc:
            raise GeomFDIError(f"{name}: expected {count} numbers", argument=name) from exc
        if out.size != count:
            raise ShapeError(f"{name}: expected {count} values, got {out.size}", argument=name)
        if not np.all(np.isfinite(out)):
            raise GeomFDIError(f"{name}: must be finite, got {out.tolist()}", argument=name)
    out.setflags(write=False)
    return out


def index_of(key: Any, names: Sequence[str], kind: str, argument: str) -> int:
    """The position of a signal given by index or by name in ``names``."""
    if isinstance(key, str):
        try:
            return list(names).index(key.strip())
        except ValueError:
            raise GeomFDIError(
                f"{argument}: no {kind} named {key!r}; the {kind}s are {list(names)}",
                argument=argument,
            ) from None
    if isinstance(key, bool) or not isinstance(key, int | np.integer):
        raise GeomFDIError(
            f"{argument}: expected a {kind} index or name, got {key!r}", argument=argument
        )
    if not 0 <= int(key) < len(names):
        raise GeomFDIError(
            f"{argument}: {kind} index must be in 0..{len(names) - 1}, got {key}",
            argument=argument,
        )
    return int(key)


def c_identifier(name: str) -> str:
    """``name`` as a C (and Python) identifier: runs of other characters become ``_``,
    a leading digit is prefixed with ``_`` (``"level 1"`` -> ``level_1``)."""
    out = re.sub(r"[^0-9A-Za-z_]+", "_", str(name)).strip("_") or "signal"
    return f"_{out}" if out[0].isdigit() else out


def bank_signals(bank: Any) -> dict[str, Any]:
    """The signal names and operating point a bank was designed with.

    Read from ``bank.info["signals"]`` (written by the design functions from the plant);
    defaults ``y0, ...``, ``u0, ...`` and a zero operating point for a bank without it.
    Returns a dict with ``outputs``, ``inputs`` (tuples), ``named`` (bool), ``y_op``,
    ``u_op`` (arrays) and ``z_op = [y_op; u_op]``.
    """
    gens = [g for g in getattr(bank, "generators", [bank]) if g is not None]
    q, m = (gens[0].q, gens[0].m) if gens else (0, 0)
    info = getattr(bank, "info", None) or {}
    sig = info.get("signals") if isinstance(info, dict) else None
    sig = sig if isinstance(sig, dict) else {}
    outputs = tuple(sig.get("outputs") or default_names("outputs", q))
    inputs = tuple(sig.get("inputs") or default_names("inputs", m))
    if len(outputs) != q:
        outputs = default_names("outputs", q)
    if len(inputs) != m:
        inputs = default_names("inputs", m)
    y_op = np.asarray(sig.get("y_op") or np.zeros(q), dtype=float).reshape(-1)
    u_op = np.asarray(sig.get("u_op") or np.zeros(m), dtype=float).reshape(-1)
    if y_op.size != q:
        y_op = np.zeros(q)
    if u_op.size != m:
        u_op = np.zeros(m)
    return {
        "outputs": outputs,
        "inputs": inputs,
        "named": bool(sig.get("named", False)),
        "y_op": y_op,
        "u_op": u_op,
        "z_op": np.concatenate([y_op, u_op]),
    }
