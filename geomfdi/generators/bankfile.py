"""Bank files: the versioned JSON schema of saved banks and monitors (no pickle).

This module writes and checks files; constructing banks and monitors from a file is in
:mod:`geomfdi.deployment.persistence` (``gf.load_bank``, ``gf.load_monitor``).

File layout (schema 1)::

    {"format": "geomfdi.bank" | "geomfdi.monitor",
     "schema": 1,
     "geomfdi": "<version that wrote it>",
     "checksum": "sha256:<hex>",
     "payload": {...}}

The checksum is the SHA-256 of the payload serialised canonically (sorted keys, no
spaces), so an edited or truncated file is refused.  Floats are written by their
shortest round-trip decimal representation (``repr``), so every matrix comes back
bit-exact; non-finite floats, complex numbers, tuples and numpy arrays are tagged
objects (``{"$float": "inf"}``, ``{"$complex": [re, im]}``, ``{"$tuple": [...]}``,
``{"$array": dtype, "shape": [...], "data": [...]}``).  Faults are stored by kind
(sensor index, actuator signature, general ``Bf``/``Df``) with their names.  An entry
of a generator's or bank's ``info`` of any other type is stored as its text
(``{"$repr": ...}``) and comes back as that string.

Every problem with a file raises :class:`~geomfdi.errors.BankFileError` naming the file
and what is wrong; a file from a newer schema raises its subclass
:class:`~geomfdi.errors.SchemaVersionError`.
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from geomfdi.errors import BankFileError, GeomFDIError, SchemaVersionError
from geomfdi.generators.interfaces import BankLike
from geomfdi.model.faults import ActuatorFault, Fault, SensorFault

__all__ = ["SCHEMA", "bank_to_dict", "save_bank"]

SCHEMA = 1
_DTYPES = {"f8": np.float64, "i8": np.int64, "b1": np.bool_, "c16": np.complex128}


class _Bad(Exception):
    """Internal: a malformed entry (turned into a BankFileError with the file name)."""


# ----------------------------------------------------------------- values
def _enc_float(x: float) -> Any:
    return x if math.isfinite(x) else {"$float": repr(x)}


def encode(value: Any) -> Any:
    """A JSON-ready form of ``value`` (module docstring)."""
    if value is None or isinstance(value, bool | str):
        return value
    if isinstance(value, int | np.integer) and not isinstance(value, np.bool_):
        return int(value)
    if isinstance(value, float | np.floating):
        return _enc_float(float(value))
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, complex | np.complexfloating):
        return {"$complex": [_enc_float(value.real), _enc_float(value.imag)]}
    if isinstance(value, np.ndarray):
        kind = {"f": "f8", "i": "i8", "u": "i8", "b": "b1", "c": "c16"}.get(value.dtype.kind)
        if kind is None:
            return {"$repr": repr(value)}
        flat = np.asarray(value, dtype=_DTYPES[kind]).ravel().tolist()
        return {"$array": kind, "shape": list(value.shape), "data": [encode(x) for x in flat]}
    if isinstance(value, tuple):
        return {"$tuple": [encode(x) for x in value]}
    if isinstance(value, list):
        return [encode(x) for x in value]
    if isinstance(value, dict):
        if all(isinstance(k, str) and not k.startswith("$") for k in value):
            return {k: encode(v) for k, v in value.items()}
        return {"$items": [[encode(k), encode(v)] for k, v in value.items()]}
    if isinstance(value, Fault):
        return {"$fault": fault_to_dict(value)}
    return {"$repr": repr(value)}


def _dec_float(x: Any, where: str) -> float:
    if isinstance(x, dict) and set(x) == {"$float"} and x["$float"] in ("nan", "inf", "-inf"):
        return float(x["$float"])
    if isinstance(x, int | float) and not isinstance(x, bool):
        return float(x)
    raise _Bad(f"{where}: expected a number, got {x!r}")


def decode(value: Any, where: str = "value") -> Any:
    """Inverse of :func:`encode`."""
    if isinstance(value, list):
        return [decode(x, f"{where}[{i}]") for i, x in enumerate(value)]
    if not isinstance(value, dict):
        return value
    if "$float" in value:
        return _dec_float(value, where)
    if "$complex" in value:
        re_im = value["$complex"]
        if not isinstance(re_im, list) or len(re_im) != 2:
            raise _Bad(f"{where}: a complex number needs [re, im]")
        return complex(_dec_float(re_im[0], where), _dec_float(re_im[1], where))
    if "$tuple" in value:
        return tuple(decode(value["$tuple"], where))
    if "$array" in value:
        return decode_array(value, where)
    if "$items" in value:
        return {decode(k, where): decode(v, where) for k, v in value["$items"]}
    if "$fault" in value:
        return fault_from_dict(value["$fault"], where)
    if "$repr" in value:
        return str(value["$repr"])
    return {k: decode(v, f"{where}.{k}") for k, v in value.items()}


def decode_array(value: Any, where: str) -> np.ndarray:
    """A tagged array; the shape and the number of entries are checked."""
    if not isinstance(value, dict) or set(value) != {"$array", "shape", "data"}:
        raise _Bad(f"{where}: expected an array object with $array, shape and data")
    kind, shape, data = value["$array"], value["shape"], value["data"]
    if kind not in _DTYPES:
        raise _Bad(f"{where}: unknown array type {kind!r}")
    if not isinstance(shape, list) or not all(
        isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in shape
    ):
        raise _Bad(f"{where}: shape must be a list of integers >= 0, got {shape!r}")
    size = int(np.prod(shape)) if shape else 1
    if not isinstance(data, list) or len(data) != size:
        got = len(data) if isinstance(data, list) else type(data).__name__
        raise _Bad(f"{where}: shape {shape} needs {size} entries, got {got}")
    if kind == "f8":
        flat = [_dec_float(x, where) for x in data]
    elif kind == "c16":
        flat = [decode(x, where) for x in data]
    elif kind == "b1":
        if not all(isinstance(x, bool) for x in data):
            raise _Bad(f"{where}: a boolean array holds non-boolean entries")
        flat = data
    else:
        if not all(isinstance(x, int) and not isinstance(x, bool) for x in data):
            raise _Bad(f"{where}: an integer array holds non-integer entries")
        flat = data
    return np.array(flat, dtype=_DTYPES[kind]).reshape(shape)


# ----------------------------------------------------------------- faults
def fault_to_dict(f: Any) -> dict[str, Any]:
    """A design fault as a tagged dict (sensor, actuator or general); ``size`` when set."""
    if isinstance(f, SensorFault):
        out = {"kind": "sensor", "i": f.i, "name": f.name}
    elif isinstance(f, ActuatorFault):
        out = {"kind": "actuator", "b": encode(f._Bf), "name": f.name}
    elif isinstance(f, Fault):
        out = {"kind": "general", "Bf": encode(f._Bf), "Df": encode(f._Df), "name": f.name}
    else:
        raise GeomFDIError(f"bank: cannot save a fault of type {type(f).__name__}", argument="bank")
    if getattr(f, "size", None) is not None:
        out["size"] = float(f.size)
    return out


def fault_from_dict(d: Any, where: str) -> Fault:
    if not isinstance(d, dict) or "kind" not in d:
        raise _Bad(f"{where}: a fault needs a 'kind'")
    kind = d["kind"]
    keys = set(d) - {"size"}
    size = d.get("size")
    try:
        if kind == "sensor" and keys == {"kind", "i", "name"}:
            return SensorFault(d["i"], name=d["name"], size=size)
        if kind == "actuator" and keys == {"kind", "b", "name"}:
            return ActuatorFault(decode_array(d["b"], f"{where}.b"), name=d["name"], size=size)
        if kind == "general" and keys == {"kind", "Bf", "Df", "name"}:
            Bf = None if d["Bf"] is None else decode_array(d["Bf"], f"{where}.Bf")
            Df = None if d["Df"] is None else decode_array(d["Df"], f"{where}.Df")
            return Fault(Bf, Df, name=d["name"], size=size)
    except GeomFDIError as exc:
        raise _Bad(f"{where}: {exc}") from exc
    raise _Bad(f"{where}: unknown fault kind {kind!r} or wrong keys {sorted(d)}")


# ------------------------------------------------------------------ banks
_GEN_KEYS = {"F", "E", "G", "M", "H", "K", "dt", "target", "decoupled", "method", "info"}
_BANK_KEYS = {
    "generators",
    "requested",
    "structure",
    "isolable",
    "diagnostics",
    "faults",
    "dt",
    "method",
    "info",
}


def bank_to_dict(bank: BankLike) -> dict[str, Any]:
    """The payload of a bank file (every field of the bank, generators included)."""
    gens = []
    for g in bank.generators:
        if g is None:
            gens.append(None)
            continue
        d = {k: encode(getattr(g, k)) for k in "FEGMHK"}
        d.update(
            dt=_enc_float(float(g.dt)),
            target=[int(i) for i in g.target],
            decoupled=[int(i) for i in g.decoupled],
            method=g.method,
            info=encode(g.info),
        )
        gens.append(d)
    return {
        "generators": gens,
        "requested": encode(np.asarray(bank.requested, dtype=bool)),
        "structure": encode(np.asarray(bank.structure, dtype=bool)),
        "isolable": encode(np.asarray(bank.isolable, dtype=bool)),
        "diagnostics": [str(s) for s in bank.diagnostics],
        "faults": [fault_to_dict(f) for f in bank.faults],
        "dt": _enc_float(float(bank.dt)),
        "method": bank.method,
        "info": encode(bank.info),
    }


def _keys(d: Any, keys: set[str], where: str) -> None:
    if not isinstance(d, dict):
        raise _Bad(f"{where}: expected an object, got {type(d).__name__}")
    if set(d) != keys:
        missing, extra = sorted(keys - set(d)), sorted(set(d) - keys)
        raise _Bad(f"{where}: missing keys {missing}, unexpected keys {extra}")


def _indices(x: Any, where: str) -> tuple[int, ...]:
    if not isinstance(x, list) or not all(
        isinstance(i, int) and not isinstance(i, bool) for i in x
    ):
        raise _Bad(f"{where}: expected a list of integers")
    return tuple(x)


def _checksum(payload: Any) -> str:
    text = json.dumps(payload, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return "sha256:" + hashlib.sha256(text.encode("utf-8")).hexdigest()


def _write(path: str | Path, fmt: str, payload: dict[str, Any]) -> Path:
    from geomfdi import __version__

    path = Path(path)
    doc = {
        "format": fmt,
        "schema": SCHEMA,
        "geomfdi": __version__,
        "checksum": _checksum(payload),
        "payload": payload,
    }
    path.write_text(json.dumps(doc, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    return path


def _read(path: str | Path, fmt: str) -> dict[str, Any]:
    path = Path(path)
    where = str(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise BankFileError(f"{where}: cannot read the file ({exc})", path=where) from exc
    except UnicodeDecodeError as exc:
        raise BankFileError(f"{where}: not a text (UTF-8) file", path=where) from exc
    if not text.strip():
        raise BankFileError(f"{where}: the file is empty", path=where)

    def no_constants(name: str) -> Any:
        raise BankFileError(f"{where}: non-standard JSON constant {name}", path=where)

    try:
        doc = json.loads(text, parse_constant=no_constants)
    except RecursionError as exc:
        raise BankFileError(
            f"{where}: not a geomfdi file (JSON nested too deeply)", path=where
        ) from exc
    except json.JSONDecodeError as exc:
        raise BankFileError(
            f"{where}: not valid JSON (truncated or corrupted at line {exc.lineno}, column "
            f"{exc.colno}: {exc.msg})",
            path=where,
        ) from exc
    if not isinstance(doc, dict) or "format" not in doc:
        raise BankFileError(f"{where}: not a geomfdi file (no 'format' entry)", path=where)
    if doc["format"] != fmt:
        raise BankFileError(
            f"{where}: holds {doc['format']!r}, expected {fmt!r}", path=where, argument="path"
        )
    schema = doc.get("schema")
    if isinstance(schema, bool) or not isinstance(schema, int):
        raise BankFileError(f"{where}: missing or invalid schema version {schema!r}", path=where)
    if schema > SCHEMA:
        raise SchemaVersionError(
            f"{where}: written with schema {schema} by geomfdi {doc.get('geomfdi', '?')}; this "
            f"version reads schema <= {SCHEMA} (upgrade geomfdi)",
            path=where,
        )
    if schema < 1:
        raise SchemaVersionError(f"{where}: unknown schema version {schema}", path=where)
    if set(doc) != {"format", "schema", "geomfdi", "checksum", "payload"}:
        raise BankFileError(f"{where}: unexpected top-level entries {sorted(doc)}", path=where)
    try:
        ok = _checksum(doc["payload"]) == doc["checksum"]
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise BankFileError(
            f"{where}: checksum mismatch (the file was modified after it was written)",
            path=where,
        )
    return doc["payload"]


def save_bank(bank: BankLike, path: str | Path) -> Path:
    """Write ``bank`` to ``path`` (JSON, schema :data:`SCHEMA`); returns the path."""
    return _write(path, "geomfdi.bank", bank_to_dict(bank))
