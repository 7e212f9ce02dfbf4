"""``gf.evaluate(settle=...)``: no decisions during the start-up transient, so a record
simulated from a non-zero initial state gives the events of ``gf.simulate`` (the
example of the deployment guide, docs/guide/deployment.md)."""

from __future__ import annotations

import numpy as np
import pytest
from hwc_bank import K_FB, A, B, C

import geomfdi as gf
from geomfdi.deployment.recorded import SETTLE_TIME_CONSTANTS, settling_time
from geomfdi.errors import GeomFDIError

PLANT = gf.Plant(A, B, C)
BANK = gf.design_sensor_bank(PLANT)
T = np.arange(0.0, 10.0, 0.01)
FAULTS = [gf.BiasFault(0, start=5.0, bias=0.05)]


def _events(evs: list) -> list[tuple]:
    return [(e.detection_time, e.isolation_time, e.decided, e.residuals, e.hypothesis) for e in evs]


@pytest.mark.parametrize("rule", [None, (2, 3), gf.Persistence(2, 3, reset=50)])
@pytest.mark.parametrize("initial", ["zero", "steady"])
def test_evaluate_with_settle_reproduces_simulate(rule, initial) -> None:
    log = gf.simulate(PLANT, BANK, T, controller=K_FB, x0=[0.5, -0.3, 0.2], faults=FAULTS,
                      threshold=0.02, persistence=rule)  # fmt: skip
    assert log.events[0].decided == 0  # simulate isolates sensor 0
    res = gf.evaluate(BANK, log.y, log.u, T, threshold=0.02, persistence=rule, initial=initial,
                      faults=FAULTS, settle=3.0)  # fmt: skip
    assert _events(res.events) == _events(log.events)
    assert not res.alarms[:, T < 5].any()
    np.testing.assert_array_equal(res.alarms[:, T >= 5], log.alarms[:, T >= 5])
    # without settling, the start-up transient alarms before the fault (and, held by the
    # persistence rule, turns the sensor-0 fault into "several faults")
    raw = gf.evaluate(BANK, log.y, log.u, T, threshold=0.02, persistence=rule, initial=initial,
                      faults=FAULTS)  # fmt: skip
    assert raw.alarms[:, T < 5].any()
    if rule is not None and getattr(rule, "reset", None) is None:
        assert raw.events[0].decided != 0


def test_settling_time_is_time_constants_of_the_slowest_pole() -> None:
    slow = max(-1.0 / np.max(np.asarray(g.poles).real) for g in BANK.generators)
    assert settling_time(BANK, 0.01) == pytest.approx(SETTLE_TIME_CONSTANTS * slow)
    res = gf.evaluate(BANK, np.zeros((3, 50)), np.zeros((3, 50)), dt=0.01, settle="auto")
    assert res.info["settle"] == pytest.approx(SETTLE_TIME_CONSTANTS * slow)


@pytest.mark.parametrize("bad", [-1.0, float("nan"), "soon", True, float("inf")])
def test_bad_settle_is_a_named_error(bad) -> None:
    with pytest.raises(GeomFDIError, match="settle"):
        gf.evaluate(BANK, np.zeros((3, 5)), np.zeros((3, 5)), dt=0.01, settle=bad)
