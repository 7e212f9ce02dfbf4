"""Fuzz of the ``[campaign]`` table of model files: every entry x every bad TOML value
gives a named error (:class:`~geomfdi.errors.GeomFDIError`) or a valid campaign; none is
truncated (``runs = 2.7``) and none builds an oversized campaign (``runs = 1e9``)."""

from __future__ import annotations

import copy
import time
from pathlib import Path

import pytest

from geomfdi.campaign.config import build_campaign, read_campaign
from geomfdi.errors import GeomFDIError, ResourceLimitError
from geomfdi.io.cli import design_all

ROOT = Path(__file__).resolve().parents[2]
CAMP, SPEC = read_campaign(ROOT / "examples" / "discrete_disturbance.toml")
BANKS = design_all(SPEC)

BASE = {
    "runs": 2,
    "sizes": [0.0, 0.001],
    "onsets": [4.0],
    "faults": [{"type": "bias", "sensor": 1}],
    "test": {"type": "abs", "threshold": 0.05},
}
NAN, INF = float("nan"), float("inf")
BAD = {
    "fraction": 2.7,
    "negative": -1,
    "zero": 0,
    "bool": True,
    "text": "abc",
    "empty_list": [],
    "empty_table": {},
    "huge": 1e9,
    "huge_int": 10**18,
    "nan": NAN,
    "inf": INF,
    "mixed_list": [1, "a"],
    "nan_list": [NAN],
    "tiny": -1e300,
    "table": {"a": 1},
    "nested": [[[[1]]]],
}
# entry -> how a value is put in the table
PLACES = {
    "runs": lambda c, v: c.update(runs=v),
    "method": lambda c, v: c.update(method=v),
    "sizes": lambda c, v: c.update(sizes=v),
    "onsets": lambda c, v: c.update(onsets=v),
    "faults": lambda c, v: c.update(faults=v),
    "faults.sensor": lambda c, v: c.update(faults=[{"type": "bias", "sensor": v}]),
    "faults.type": lambda c, v: c.update(faults=[{"type": v, "sensor": 1}]),
    "detection_window": lambda c, v: c.update(detection_window=v),
    "eval_start": lambda c, v: c.update(eval_start=v),
    "block_size": lambda c, v: c.update(block_size=v),
    "seed": lambda c, v: c.update(seed=v),
    "test": lambda c, v: c.update(test=v),
    "test.threshold": lambda c, v: c.update(test={"type": "abs", "threshold": v}),
    "test.window": lambda c, v: c.update(test={"type": "glr", "window": v}),
    "test.false_alarm_rate": lambda c, v: c.update(test={"type": "glr", "false_alarm_rate": v}),
    "test.drift": lambda c, v: c.update(test={"type": "cusum", "drift": v}),
    "test.arl": lambda c, v: c.update(test={"type": "cusum", "arl": v}),
    "uncertainty": lambda c, v: c.update(uncertainty=v),
    "uncertainty.samples": lambda c, v: c.update(uncertainty={"relative": 0.01, "samples": v}),
    "uncertainty.relative": lambda c, v: c.update(uncertainty={"relative": v}),
    "uncertainty.seed": lambda c, v: c.update(uncertainty={"relative": 0.01, "seed": v}),
    "uncertainty.matrices": lambda c, v: c.update(uncertainty={"relative": 0.01, "matrices": v}),
    "persistence": lambda c, v: c.update(persistence=v),
    "persistence.k": lambda c, v: c.update(persistence={"k": v, "n": 3}),
    "persistence.reset": lambda c, v: c.update(persistence={"k": 1, "n": 3, "reset": v}),
    "persistence.latch": lambda c, v: c.update(persistence={"k": 1, "n": 3, "latch": v}),
}
# values that are valid for an entry (and must then give a campaign)
VALID = {
    ("eval_start", "negative"),
    ("eval_start", "zero"),
    ("eval_start", "tiny"),
    ("seed", "zero"),
    ("uncertainty.seed", "zero"),
    ("uncertainty.relative", "zero"),
    ("sizes", "negative"),
    ("sizes", "zero"),
    ("onsets", "zero"),
    ("test", "empty_table"),  # (chi2 by default... refused: type is required)
    ("persistence.latch", "bool"),
    ("uncertainty", "empty_table"),
    ("seed", "huge"),
    ("detection_window", "fraction"),
    ("detection_window", "huge"),
    ("detection_window", "huge_int"),
    ("eval_start", "fraction"),
    ("faults.sensor", "zero"),
    ("persistence", "empty_table"),
    ("test.threshold", "fraction"),
    ("test.threshold", "huge"),
    ("test.threshold", "huge_int"),
    ("uncertainty.matrices", "empty_list"),
    ("uncertainty.relative", "fraction"),
    ("uncertainty.relative", "huge"),
    ("uncertainty.relative", "huge_int"),
    ("block_size", "huge"),
    ("block_size", "huge_int"),
    ("seed", "huge_int"),
    ("uncertainty.seed", "huge"),
    ("uncertainty.seed", "huge_int"),
}


def _outcome(place: str, value: object) -> str:
    camp = copy.deepcopy(BASE)
    PLACES[place](camp, copy.deepcopy(value))
    try:
        cfg = build_campaign(camp, SPEC, BANKS)
    except GeomFDIError:
        return "named"
    except Exception as exc:  # noqa: BLE001 - the point of the fuzz
        return f"raw {type(exc).__name__}: {exc}"
    c = cfg.campaign
    runs = len(c.grid()["run"])
    if runs > 10_000:
        return f"oversized: {runs} runs built"
    return "correct"


@pytest.mark.parametrize("place", sorted(PLACES))
def test_campaign_entries_give_named_errors(place: str) -> None:
    failures = []
    for name, value in BAD.items():
        got = _outcome(place, value)
        if got not in ("named", "correct"):
            failures.append(f"{name}: {got}")
        elif got == "correct" and (place, name) not in VALID:
            failures.append(f"{name}: accepted")
    assert failures == []


def test_base_campaign_is_valid() -> None:
    assert _outcome("runs", 2) == "correct"


@pytest.mark.parametrize(
    "place, value",
    [("runs", 1e9), ("runs", 2e6), ("uncertainty.samples", 1e9), ("runs", 10**18)],
)
def test_oversized_campaigns_are_refused_at_once_with_an_estimate(place, value) -> None:
    camp = copy.deepcopy(BASE)
    PLACES[place](camp, value)
    t0 = time.perf_counter()
    with pytest.raises(ResourceLimitError) as info:
        build_campaign(camp, SPEC, BANKS)
    assert time.perf_counter() - t0 < 2.0
    assert info.value.limit == "max_runs" and "max_runs" in str(info.value)
    assert info.value.estimate is None or info.value.estimate > 1e8


def test_the_run_cap_can_be_raised() -> None:
    import geomfdi as gf

    camp = copy.deepcopy(BASE)
    camp["runs"] = 2_000
    with pytest.raises(ResourceLimitError):
        with gf.limits.limits(max_runs=1_000):
            build_campaign(camp, SPEC, BANKS)
    with gf.limits.limits(max_runs=10_000):
        assert len(build_campaign(camp, SPEC, BANKS).campaign.grid()["run"]) == 4_000
