"""Fuzz of bank and monitor files: inconsistent metadata (with a valid checksum: the
checksum detects accidents, not intent), malformed and deeply nested JSON give a
:class:`~geomfdi.errors.BankFileError` (geomfdi.deployment.persistence)."""

from __future__ import annotations

import copy
import json
import sys
from pathlib import Path

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.errors import BankFileError
from geomfdi.generators.bankfile import _checksum

PLANT = gf.Plant([[-1.0, 0.0], [0.0, -2.0]], [[1.0], [1.0]], [[1.0, 0.0], [0.0, 1.0]])
BANK = gf.design_sensor_bank(PLANT).discretize(0.1)


def _doc(tmp: Path, kind: str = "bank") -> dict:
    path = tmp / f"{kind}.json"
    if kind == "bank":
        BANK.save(path)
    else:
        gf.Monitor(BANK, threshold=0.5, persistence=(1, 2)).save(path)
    return json.loads(path.read_text())


def _write(tmp: Path, doc: dict) -> Path:
    doc["checksum"] = _checksum(doc["payload"])  # (a deliberate edit keeps it valid)
    path = tmp / "edited.json"
    path.write_text(json.dumps(doc))
    return path


def _gen(bank: dict, r: int = 0) -> dict:
    return bank["generators"][r]


def _set_F(bank: dict, value: float) -> None:
    g = _gen(bank)
    n = g["F"]["shape"][0]
    g["F"]["data"] = [value if i % (n + 1) == 0 else 0.0 for i in range(n * n)]


EDITS = {
    "sensor index >= outputs": lambda b: b["faults"][0].update(i=7),
    "target 99": lambda b: _gen(b).update(target=[99]),
    "decoupled -1": lambda b: _gen(b).update(decoupled=[-1]),
    "unstable F": lambda b: _set_F(b, 1.5),
    "marginal F": lambda b: _set_F(b, 1.0),
}


@pytest.mark.parametrize("edit", sorted(EDITS))
def test_inconsistent_bank_metadata_is_refused(tmp_path: Path, edit: str) -> None:
    doc = _doc(tmp_path)
    EDITS[edit](doc["payload"])
    with pytest.raises(BankFileError):
        gf.load_bank(_write(tmp_path, doc))


@pytest.mark.parametrize("threshold", [0.0, -1.0])
def test_monitor_threshold_must_be_positive(tmp_path: Path, threshold: float) -> None:
    doc = _doc(tmp_path, "monitor")
    thr = doc["payload"]["threshold"]
    thr["data"] = [threshold] * len(thr["data"])
    with pytest.raises(BankFileError, match="threshold"):
        gf.load_monitor(_write(tmp_path, doc))


@pytest.mark.parametrize(
    "text",
    [
        "[" * 100_000 + "]" * 100_000,
        '{"format": "geomfdi.bank", "schema": 1, "payload": ' + "[" * 50_000 + "]" * 50_000 + "}",
        '{"format": "geomfdi.bank"',
        "\x00\x01",
        "NaN",
        '{"format": "geomfdi.bank", "schema": 1, "payload": {}, "checksum": "x"}',
        "[]",
        '"text"',
    ],
    ids=["deep", "deep-payload", "truncated", "binary", "nan", "bad-checksum", "list", "str"],
)
def test_malformed_json_is_a_named_error(tmp_path: Path, text: str) -> None:
    path = tmp_path / "bad.json"
    path.write_text(text)
    for load in (gf.load_bank, gf.load_monitor):
        with pytest.raises(BankFileError):
            load(path)


def test_deep_nesting_is_refused_whatever_the_recursion_limit(tmp_path: Path) -> None:
    doc = _doc(tmp_path)
    nested: object = 1.0
    for _ in range(200):  # json writes and reads this at the default limit
        nested = [nested]
    doc["payload"]["info"] = {"deep": nested}
    path = _write(tmp_path, doc)
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 20_000))
    try:
        with pytest.raises(BankFileError, match="nested"):
            gf.load_bank(path)
    finally:
        sys.setrecursionlimit(limit)


def test_the_unedited_files_load(tmp_path: Path) -> None:
    doc = _doc(tmp_path)
    bank = gf.load_bank(_write(tmp_path, copy.deepcopy(doc)))
    np.testing.assert_array_equal(bank.structure, BANK.structure)
