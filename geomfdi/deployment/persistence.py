"""Loading banks and monitors from their versioned JSON files (``gf.load_bank``,
``gf.load_monitor``); the schema and the writers are in :mod:`geomfdi.generators.bankfile`.

Every problem with a file raises :class:`~geomfdi.errors.BankFileError` naming the file
and what is wrong; a file from a newer schema raises its subclass
:class:`~geomfdi.errors.SchemaVersionError`.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from geomfdi.errors import BankFileError, GeomFDIError
from geomfdi.generators.bankfile import (
    _BANK_KEYS,
    _GEN_KEYS,
    SCHEMA,
    _Bad,
    _dec_float,
    _indices,
    _keys,
    _read,
    bank_to_dict,
    decode,
    decode_array,
    fault_from_dict,
    save_bank,
)
from geomfdi.generators.generator import ResidualBank, ResidualGenerator

__all__ = [
    "SCHEMA",
    "bank_to_dict",
    "bank_from_dict",
    "save_bank",
    "load_bank",
    "save_monitor",
    "load_monitor",
]


def bank_from_dict(d: Any) -> ResidualBank:
    """Inverse of :func:`bank_to_dict` (every entry checked)."""
    _keys(d, _BANK_KEYS, "bank")
    if not isinstance(d["generators"], list):
        raise _Bad("bank.generators: expected a list")
    gens: list[ResidualGenerator | None] = []
    for r, gd in enumerate(d["generators"]):
        where = f"bank.generators[{r}]"
        if gd is None:
            gens.append(None)
            continue
        _keys(gd, _GEN_KEYS, where)
        mats = {k: decode_array(gd[k], f"{where}.{k}") for k in "FEGMHK"}
        for k, a in mats.items():
            if not np.all(np.isfinite(a)):
                raise _Bad(f"{where}.{k}: non-finite entries")
        if not isinstance(gd["method"], str):
            raise _Bad(f"{where}.method: expected a string")
        info = decode(gd["info"], f"{where}.info")
        if not isinstance(info, dict):
            raise _Bad(f"{where}.info: expected an object")
        try:
            gens.append(
                ResidualGenerator(
                    **mats,
                    dt=_dec_float(gd["dt"], f"{where}.dt"),
                    target=_indices(gd["target"], f"{where}.target"),
                    decoupled=_indices(gd["decoupled"], f"{where}.decoupled"),
                    method=gd["method"],
                    info=info,
                )
            )
        except GeomFDIError as exc:
            raise _Bad(f"{where}: {exc}") from exc
    rows = len(gens)
    req = decode_array(d["requested"], "bank.requested")
    st = decode_array(d["structure"], "bank.structure")
    iso = decode_array(d["isolable"], "bank.isolable")
    faults = d["faults"]
    if not isinstance(faults, list):
        raise _Bad("bank.faults: expected a list")
    fl = [fault_from_dict(f, f"bank.faults[{j}]") for j, f in enumerate(faults)]
    nf = len(fl)
    for name, a, shape in (
        ("requested", req, (rows, nf)),
        ("structure", st, (rows, nf)),
        ("isolable", iso, (nf,)),
    ):
        if a.dtype != np.bool_ or a.shape != shape:
            raise _Bad(f"bank.{name}: expected a boolean array of shape {shape}, got {a.shape}")
    diags = d["diagnostics"]
    if (
        not isinstance(diags, list)
        or len(diags) != rows
        or not all(isinstance(s, str) for s in diags)
    ):
        raise _Bad(f"bank.diagnostics: expected {rows} strings")
    dt = _dec_float(d["dt"], "bank.dt")
    if not math.isfinite(dt) or dt < 0:
        raise _Bad(f"bank.dt: must be finite and >= 0, got {dt}")
    present = [g for g in gens if g is not None]
    if any(g.dt != dt for g in present):
        raise _Bad("bank.dt: differs from a generator's dt")
    if len({(g.q, g.m) for g in present}) > 1:
        raise _Bad("bank.generators: the generators read different numbers of signals")
    info = decode(d["info"], "bank.info")
    if not isinstance(d["method"], str) or not isinstance(info, dict):
        raise _Bad("bank.method, bank.info: expected a string and an object")
    _check_consistent(gens, fl, dt)
    return ResidualBank(gens, req, st, iso, diags, fl, dt, d["method"], info)


def _check_consistent(gens: list[ResidualGenerator | None], faults: list[Any], dt: float) -> None:
    """The metadata of a bank file agree with its generators: fault channels exist
    (a sensor index below the outputs read), target and decoupled faults are faults of
    the bank, and every generator is stable (a residual that grows without bound is no
    residual)."""
    from geomfdi.model.faults import SensorFault

    present = [g for g in gens if g is not None]
    q = present[0].q if present else None
    for j, f in enumerate(faults):
        if q is not None and isinstance(f, SensorFault) and not 0 <= f.i < q:
            raise _Bad(f"bank.faults[{j}]: sensor {f.i} does not exist (the bank reads {q})")
    nf = len(faults)
    for r, g in enumerate(gens):
        if g is None:
            continue
        where = f"bank.generators[{r}]"
        for name in ("target", "decoupled"):
            bad = [i for i in getattr(g, name) if not 0 <= i < nf]
            if bad:
                raise _Bad(f"{where}.{name}: fault {bad[0]} is not one of the bank's {nf}")
        if g.order:
            p = np.asarray(g.poles)
            stable = np.all(np.abs(p) < 1.0) if dt > 0 else np.all(p.real < 0.0)
            if not stable:
                raise _Bad(f"{where}.F: the generator is not stable (poles {np.round(p, 6)})")


# ------------------------------------------------------------------ files
def load_bank(path: str | Path) -> ResidualBank:
    """Read a bank written by ``bank.save(path)``; bit-exact round trip.

    Raises
    ------
    BankFileError
        Unreadable, empty, truncated, tampered with (checksum), or invalid content.
    SchemaVersionError
        Written with a newer schema.
    """
    payload = _read(path, "geomfdi.bank")
    try:
        return bank_from_dict(payload)
    except _Bad as exc:
        raise BankFileError(f"{path}: {exc}", path=str(path)) from exc
    except RecursionError as exc:
        raise BankFileError(f"{path}: nested too deeply", path=str(path)) from exc


def load_monitor(path: str | Path) -> Any:
    """Read a monitor written by ``monitor.save(path)``, state included.

    The persistence rule is stored as ``{k, n, latch, reset}``.  A file that stores it
    as ``[k, n]`` (written before the rule held the pattern over alarm episodes) loads
    with ``Persistence(k, n, latch=False)``: the same confirmed alarms, isolation on the
    momentary pattern, with decisions kept when they held for ``k`` of the last ``n``
    samples; its state starts the decision history afresh.
    """
    from geomfdi.deployment.monitor import Monitor
    from geomfdi.evaluation.decision import Threshold

    payload = _read(path, "geomfdi.monitor")
    try:
        _keys(
            payload,
            {"bank", "dt", "threshold", "persistence", "isolation", "initial", "state"},
            "monitor",
        )
        bank = bank_from_dict(payload["bank"])
        thr = payload["threshold"]
        if thr is not None:
            values = decode_array(thr, "monitor.threshold")
            if values.dtype.kind not in "fi" or not np.all(values > 0):
                raise _Bad("monitor.threshold: thresholds must be numbers > 0")
            thr = Threshold(values)
        initial = payload["initial"]
        if not isinstance(initial, str):
            initial = decode_array(initial, "monitor.initial")
        from geomfdi.deployment.monitor import persistence_from

        try:
            pers = persistence_from(payload["persistence"])
        except GeomFDIError as exc:
            raise _Bad(f"monitor.{exc}") from exc
        if not isinstance(payload["isolation"], bool):
            raise _Bad("monitor.isolation: expected true or false")
        try:
            mon = Monitor(
                bank,
                dt=_dec_float(payload["dt"], "monitor.dt"),
                threshold=thr,
                persistence=pers,
                isolation=payload["isolation"],
                initial=initial,
            )
            mon.state = decode(payload["state"], "monitor.state")
        except GeomFDIError as exc:
            raise _Bad(f"monitor: {exc}") from exc
    except _Bad as exc:
        raise BankFileError(f"{path}: {exc}", path=str(path)) from exc
    return mon


from geomfdi.deployment.monitor import save_monitor  # noqa: E402  (re-export)
