"""Resource caps (``gf.limits``): checked before allocation, configurable, thread-local."""

from __future__ import annotations

import doctest
import threading

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.errors import GeomFDIError, ResourceLimitError
from geomfdi.limits import (
    Limits,
    check_allocation,
    check_runs,
    check_symbolic_size,
    format_bytes,
    get_limits,
    limits,
    reset_limits,
    set_limits,
)


def test_module_doctest():
    flags = doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS | doctest.IGNORE_EXCEPTION_DETAIL
    result = doctest.testmod(gf.limits, optionflags=flags)
    assert result.attempted >= 3 and result.failed == 0


def test_defaults_and_registration():
    assert gf.limits.get_limits() == Limits()
    assert "limits" in dir(gf)
    assert get_limits().max_runs == 1_000_000 and get_limits().max_symbolic_size == 16


def test_a_billion_runs_fails_at_once_with_a_memory_estimate():
    with pytest.raises(ResourceLimitError) as err:
        check_allocation(1001, runs=10**9, channels=3, argument="threshold.runs")
    assert err.value.argument == "runs" and err.value.limit == "max_runs"
    with limits(max_runs=10**10):
        with pytest.raises(ResourceLimitError) as err:
            check_allocation(1001, runs=10**9, channels=3, argument="t")
    e = err.value
    assert e.limit == "max_samples" and e.argument == "t"
    assert e.estimate == pytest.approx(1001 * 10**9 * 3 * 8)
    assert "TiB" in str(e) and "max_samples" in str(e)


def test_memory_cap_and_estimate():
    est = check_allocation(10**6, runs=100, channels=2)
    assert est == 10**6 * 100 * 2 * 8
    with limits(max_memory=est - 1):
        with pytest.raises(ResourceLimitError, match="max_memory") as err:
            check_allocation(10**6, runs=100, channels=2)
        assert err.value.estimate == est
        assert check_allocation(10**6, runs=100, channels=1) == est / 2
    with limits(max_memory=None, max_samples=10**15):
        assert check_allocation(10**12, channels=100) == 8e14


@pytest.mark.parametrize(
    "bad, argument",
    [(0, "runs"), (-3, "runs"), (2.5, "runs"), (True, "runs"), ("10", "runs"), (10**400, "runs")],
)
def test_check_runs_rejects_non_counts(bad, argument):
    with pytest.raises(GeomFDIError) as err:
        check_runs(bad)
    assert err.value.argument == argument


def test_numpy_integers_are_counts():
    assert check_runs(np.int64(7)) == 7
    assert check_allocation(np.int32(10), np.uint8(3)) == 240.0


def test_symbolic_size_cap():
    assert check_symbolic_size(16) == 16
    with pytest.raises(ResourceLimitError, match="size\\*\\*4") as err:
        check_symbolic_size(24, argument="plant")
    assert err.value.argument == "plant" and err.value.limit == "max_symbolic_size"
    with limits(max_symbolic_size=30):
        assert check_symbolic_size(24) == 24


@pytest.mark.parametrize(
    "caps, argument",
    [
        ({"max_runs": 0}, "max_runs"),
        ({"max_runs": 1.5}, "max_runs"),
        ({"max_memory": float("nan")}, "max_memory"),
        ({"max_memory": -1}, "max_memory"),
        ({"max_symbolic_size": None}, "max_symbolic_size"),
        ({"max_stuff": 3}, "max_stuff"),
    ],
)
def test_bad_caps_are_rejected_and_nothing_changes(caps, argument):
    with pytest.raises(GeomFDIError) as err:
        set_limits(**caps)
    assert err.value.argument == argument
    assert get_limits() == Limits()


def test_set_limits_is_process_wide_outside_blocks_and_local_inside():
    seen: list[int] = []
    try:
        set_limits(max_runs=50)
        t = threading.Thread(target=lambda: seen.append(get_limits().max_runs))
        t.start()
        t.join()
        with limits(max_runs=5) as inside:
            assert inside.max_runs == 5
            set_limits(max_runs=7)
            assert get_limits().max_runs == 7
            t = threading.Thread(target=lambda: seen.append(get_limits().max_runs))
            t.start()
            t.join()
        assert get_limits().max_runs == 50
    finally:
        reset_limits()
    assert seen == [50, 50] and get_limits() == Limits()


def test_format_bytes():
    assert format_bytes(512) == "512 B"
    assert format_bytes(3 * 2**30) == "3 GiB"
    assert format_bytes(1.5 * 2**50) == "1.5 PiB"
