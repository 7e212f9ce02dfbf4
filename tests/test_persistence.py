"""Save/load of banks and monitors: bit-exact round trips and clear errors on bad files."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from deploy_banks import DT, A, B, C, sampled_bank, seed_bank

import geomfdi as gf
from geomfdi.errors import BankFileError, GeomFDIError, SchemaVersionError
from geomfdi.generators.bankfile import SCHEMA, _checksum


def _hexes(a: np.ndarray) -> list[str]:
    return [float(x).hex() for x in np.asarray(a, dtype=float).ravel()]


def _same_bank(a: gf.ResidualBank, b: gf.ResidualBank) -> None:
    assert len(a.generators) == len(b.generators)
    for g, h in zip(a.generators, b.generators, strict=True):
        assert (g is None) == (h is None)
        if g is None:
            continue
        for k in "FEGMHK":
            x, y = getattr(g, k), getattr(h, k)
            assert x.shape == y.shape and _hexes(x) == _hexes(y)  # bit-exact
        assert (g.dt, g.target, g.decoupled, g.method) == (h.dt, h.target, h.decoupled, h.method)
        assert set(g.info) == set(h.info)
        for key, val in g.info.items():
            if isinstance(val, np.ndarray):
                np.testing.assert_array_equal(h.info[key], val)
    for name in ("requested", "structure", "isolable"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
        assert getattr(b, name).dtype == bool
    assert a.diagnostics == b.diagnostics and (a.dt, a.method) == (b.dt, b.method)
    assert [type(f) for f in a.faults] == [type(f) for f in b.faults]
    assert [f.name for f in a.faults] == [f.name for f in b.faults]
    n, q = 3, 3
    for f, g in zip(a.faults, b.faults, strict=True):
        for x, y in zip(f.signatures(n, q), g.signatures(n, q), strict=True):
            assert _hexes(x) == _hexes(y)


@pytest.fixture(scope="module")
def banks() -> dict[str, gf.ResidualBank]:
    plant = gf.Plant(A, B, C)
    actuator = gf.design_bank(
        plant,
        [gf.ActuatorFault([1.0, 0, 0], name="actuator 0"), gf.SensorFault(1)],
        np.eye(2, dtype=bool),
    )
    general = gf.design_bank(
        plant,
        [gf.Fault([[0.0], [1.0], [0.0]], [[0.0], [0.0], [1.0]], name="mixed"), gf.SensorFault(0)],
        [[1, 0], [0, 1], [1, 1]],
    )
    return {
        "sensor": seed_bank(),
        "sensor_sampled": sampled_bank(),
        "actuator": actuator,
        "general": general,
    }


@pytest.mark.parametrize("kind", ["sensor", "sensor_sampled", "actuator", "general"])
def test_bank_round_trip_is_bit_exact(
    banks: dict[str, gf.ResidualBank], kind: str, tmp_path: Path
) -> None:
    bank = banks[kind]
    path = bank.save(tmp_path / "bank.json")
    back = gf.load_bank(path)
    _same_bank(bank, back)
    doc = json.loads(path.read_text())
    assert doc["format"] == "geomfdi.bank" and doc["schema"] == SCHEMA
    # the loaded bank behaves identically
    if back.dt > 0:
        rng = np.random.default_rng(0)
        y, u = rng.normal(size=(3, 200)), rng.normal(size=(3, 200))
        r1 = gf.evaluate(bank, y, u, dt=bank.dt).residuals
        r2 = gf.evaluate(back, y, u, dt=back.dt).residuals
        np.testing.assert_array_equal(r1, r2)
    back.save(tmp_path / "again.json")
    assert (tmp_path / "again.json").read_text() == path.read_text()


def test_non_finite_and_complex_info_survive(tmp_path: Path) -> None:
    bank = sampled_bank()
    g = bank.generators[0]
    extra = {"inf": np.inf, "nan": float("nan"), "z": 1 + 2j, "t": (1, 2.5), "arr": np.eye(2)}
    g2 = gf.ResidualGenerator(g.F, g.E, g.G, g.M, g.H, g.K, dt=g.dt, info=extra)
    b2 = gf.ResidualBank([g2, *bank.generators[1:]], bank.requested, bank.structure,
                         bank.isolable, bank.diagnostics, bank.faults, bank.dt)  # fmt: skip
    info = gf.load_bank(b2.save(tmp_path / "b.json")).generators[0].info
    assert info["inf"] == np.inf and np.isnan(info["nan"]) and info["z"] == 1 + 2j
    assert info["t"] == (1, 2.5)
    np.testing.assert_array_equal(info["arr"], np.eye(2))


def test_monitor_round_trip_with_state(tmp_path: Path) -> None:
    bank = sampled_bank()
    rng = np.random.default_rng(2)
    Y, U = rng.normal(size=(3, 600)), rng.normal(size=(3, 600))
    mon = gf.Monitor(bank, threshold=0.8, persistence=(2, 3))
    ref = mon.feed(Y, U)
    mon.reset()
    mon.feed(Y[:, :250], U[:, :250])
    path = mon.save(tmp_path / "monitor.json")
    back = gf.load_monitor(path)
    assert back.state == mon.state
    assert (back.persistence.k, back.persistence.n) == (2, 3)
    np.testing.assert_array_equal(back.thresholds, mon.thresholds)
    rest = back.feed(Y[:, 250:], U[:, 250:])
    assert np.max(np.abs(rest.residuals - ref.residuals[:, 250:])) <= 1e-12
    np.testing.assert_array_equal(rest.alarms, ref.alarms[:, 250:])
    np.testing.assert_array_equal(rest.isolated, ref.isolated[250:])
    with pytest.raises(BankFileError, match="holds 'geomfdi.monitor', expected 'geomfdi.bank'"):
        gf.load_bank(path)


def _resign(doc: dict[str, Any]) -> dict[str, Any]:
    doc["checksum"] = _checksum(doc["payload"])
    return doc


def _corruptions(path: Path) -> list[tuple[str, Any, type, str]]:
    text = path.read_text()
    doc = json.loads(text)

    def edited(fn: Any, resign: bool = True) -> str:
        d = json.loads(text)
        fn(d)
        return json.dumps(_resign(d) if resign else d)

    def set_(keys: list, value: Any) -> Any:
        def fn(d: dict) -> None:
            node = d
            for k in keys[:-1]:
                node = node[k]
            node[keys[-1]] = value

        return fn

    g0 = ["payload", "generators", 0]
    F = doc["payload"]["generators"][0]["F"]
    return [
        ("empty", "", BankFileError, "empty"),
        ("truncated", text[: len(text) // 2], BankFileError, "not valid JSON"),
        ("not an object", "[1, 2, 3]", BankFileError, "not a geomfdi file"),
        ("wrong format", edited(set_(["format"], "other")), BankFileError, "'geomfdi.bank'"),
        ("newer schema", edited(set_(["schema"], SCHEMA + 1)), SchemaVersionError, "schema 2"),
        ("bad schema", edited(set_(["schema"], "one")), BankFileError, "invalid schema version"),
        ("tampered", text.replace(repr(F["data"][0]), repr(F["data"][0] + 1), 1), BankFileError,
         "checksum mismatch"),
        ("no checksum", edited(lambda d: d.pop("checksum"), False), BankFileError,
         "unexpected top-level|checksum"),
        ("wrong shape", edited(set_([*g0, "F", "shape"], [F["shape"][0] + 1, F["shape"][1]])),
         BankFileError, "needs .* entries"),
        ("inconsistent matrices", edited(set_([*g0, "E"], {"$array": "f8", "shape": [1, 1],
         "data": [1.0]})), BankFileError, "E: expected shape"),
        ("non-finite matrix", edited(set_([*g0, "F", "data", 0], {"$float": "nan"})),
         BankFileError, "F: non-finite"),
        ("unknown fault", edited(set_(["payload", "faults", 0, "kind"], "thermal")),
         BankFileError, "unknown fault kind"),
        ("structure shape", edited(set_(["payload", "structure", "shape"], [2, 3])),
         BankFileError, "needs .* entries|structure"),
        ("missing key", edited(lambda d: d["payload"].pop("diagnostics")), BankFileError,
         "missing keys \\['diagnostics'\\]"),
        ("dt mismatch", edited(set_(["payload", "dt"], 0.5)), BankFileError, "differs from"),
        ("NaN constant", text.replace(repr(F["data"][0]), "NaN", 1), BankFileError,
         "non-standard JSON constant"),
        ("binary", b"\xff\xfe\x00garbage", BankFileError, "not a text"),
    ]  # fmt: skip


def test_corrupt_files_give_one_clear_error(tmp_path: Path) -> None:
    path = sampled_bank().save(tmp_path / "good.json")
    cases = _corruptions(path)
    assert len(cases) >= 10
    for name, content, exc, pattern in cases:
        bad = tmp_path / f"{name.replace(' ', '_')}.json"
        if isinstance(content, bytes):
            bad.write_bytes(content)
        else:
            bad.write_text(content)
        with pytest.raises(exc, match=pattern) as info:
            gf.load_bank(bad)
        assert isinstance(info.value, GeomFDIError), name
        assert str(bad) in str(info.value), name
        assert info.value.path == str(bad)
    with pytest.raises(BankFileError, match="cannot read"):
        gf.load_bank(tmp_path / "missing.json")


def test_continuous_monitor_round_trip(tmp_path: Path) -> None:
    mon = gf.Monitor(seed_bank(), dt=DT, threshold=0.5, initial="zero")
    mon.step([0.1, 0.2, 0.3], [0.0, 0.1, 0.0])
    back = gf.load_monitor(mon.save(tmp_path / "m.json"))
    assert back.dt == DT and back.initial == "zero" and back.state == mon.state
    a = mon.step([0.2, 0.1, 0.3], [0.0, 0.1, 0.0])
    b = back.step([0.2, 0.1, 0.3], [0.0, 0.1, 0.0])
    np.testing.assert_array_equal(a.residuals, b.residuals)
