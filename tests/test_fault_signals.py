"""Sensor fault signals: y_i = eta(t) y_i0 + lambda(t) (Hou, Wen & Chen 2011, eq. 3-5)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import geomfdi as gf
from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.simulation.signals import fault_profile

T = np.arange(0.0, 10.0001, 0.5)  # 21 samples, 8 s is sample 16


def _y0(q=3, runs=None, seed=0):
    rng = np.random.default_rng(seed)
    shape = (q, T.size) if runs is None else (runs, q, T.size)
    return rng.standard_normal(shape)


def test_abrupt_gain_with_bias():
    y0 = _y0()
    y = gf.GainFault(1, start=4.0, gain=1.5, bias=0.2).apply(T, y0)
    on = T >= 4.0
    assert np.array_equal(y[[0, 2]], y0[[0, 2]])
    assert np.array_equal(y[1, ~on], y0[1, ~on])
    assert np.allclose(y[1, on], 1.5 * y0[1, on] + 0.2)


def test_time_varying_gain_and_bias_are_evaluated_on_active_samples_only():
    y0 = _y0()
    # sqrt(t - 5) is nan before 5 s: evaluating it there would raise
    f = gf.GainFault(0, start=5.0, gain=lambda t: 1 + np.sqrt(t - 5), bias=lambda t: 0.1 * t)
    assert f.time_varying_gain
    y = f.apply(T, y0)
    on = T >= 5
    assert np.allclose(y[0, on], (1 + np.sqrt(T[on] - 5)) * y0[0, on] + 0.1 * T[on])
    assert np.array_equal(y[0, ~on], y0[0, ~on])


def test_bias_fault_with_end():
    y0 = _y0()
    y = gf.BiasFault(2, start=2.0, bias=-0.3, end=3.0).apply(T, y0)
    on = (T >= 2.0) & (T < 3.0)
    assert on.sum() == 2
    assert np.allclose(y[2] - y0[2], np.where(on, -0.3, 0.0))


def test_stuck_holds_reading_at_start_and_fixed_value():
    y0 = _y0()
    y = gf.StuckFault(0, start=3.0).apply(T, y0)
    k = int(np.searchsorted(T, 3.0))
    assert np.all(y[0, k:] == y0[0, k])
    assert np.array_equal(y[0, :k], y0[0, :k])
    y = gf.StuckFault(1, start=3.0, value=7.0, end=6.0).apply(T, y0)
    on = (T >= 3) & (T < 6)
    assert np.all(y[1, on] == 7.0) and np.array_equal(y[1, ~on], y0[1, ~on])


def test_stuck_hold_is_per_run():
    y0 = _y0(runs=4)
    y = gf.StuckFault(1, start=2.0).apply(T, y0)
    k = int(np.searchsorted(T, 2.0))
    assert np.allclose(y[:, 1, k:], y0[:, 1, k : k + 1])
    assert len(set(np.round(y[:, 1, -1], 12))) == 4


def test_faults_on_one_sensor_compose_in_list_order():
    y0 = _y0()
    fs = [
        gf.GainFault(0, start=1.0, gain=2.0),
        gf.BiasFault(0, start=2.0, bias=0.5),
        gf.StuckFault(0, start=6.0),
    ]
    y = gf.apply_faults(fs, T, y0)
    k6 = int(np.searchsorted(T, 6.0))
    expect = y0[0].copy()
    expect[T >= 1] *= 2.0
    expect[T >= 2] += 0.5
    # the stuck fault holds its input (gain and bias applied) at 6 s
    expect[k6:] = 2.0 * y0[0, k6] + 0.5
    assert np.allclose(y[0], expect)
    # reversed order: the stuck value (the raw reading) is then shifted and scaled
    y_rev = gf.apply_faults(fs[::-1], T, y0)
    assert np.allclose(y_rev[0, k6:], 2.0 * (y0[0, k6] + 0.5))
    fs2 = [gf.StuckFault(0, start=6.0), gf.GainFault(0, start=1.0, gain=2.0)]
    assert np.allclose(gf.apply_faults(fs2, T, y0)[0, k6:], 2.0 * y0[0, k6])


def test_onset_tolerates_rounded_grid_times():
    t = np.arange(20001) * 1e-3  # t[8000] is 8 up to rounding
    m = gf.GainFault(0, start=8.0, gain=2.0).mask(t)
    assert int(np.argmax(m)) == 8000


def test_left_limits_switch_at_the_sample():
    y0 = np.ones((1, T.size))
    prof = fault_profile([gf.BiasFault(0, start=4.0, bias=1.0)], T, y0[None], q=1)
    k = int(np.searchsorted(T, 4.0))
    assert prof.lam[0, 0, k] == 1.0 and prof.lam_left[0, 0, k] == 0.0
    assert prof.lam_left[0, 0, k + 1] == 1.0


def test_profile_of_selected_sensors_equals_those_rows():
    """``sensors=`` computes only some rows (in the given order), identical to the full
    profile's; a faulty sensor left out is an error."""
    rng = np.random.default_rng(2)
    y0 = rng.standard_normal((2, 4, T.size))  # 2 runs, 4 sensors
    faults = [
        gf.GainFault(2, start=3.0, gain=lambda t: 1 + 0.1 * t, end=8.0),
        gf.BiasFault(0, start=5.0, bias=0.3),
        gf.StuckFault(2, start=6.0),
        gf.GainFault(0, start=7.5, gain=0.5),
    ]
    full = fault_profile(faults, T, y0, q=4)
    part = fault_profile(faults, T, y0, q=4, sensors=[2, 0])
    for name in ("eta", "eta_left"):
        assert np.array_equal(getattr(part, name), getattr(full, name)[[2, 0]])
    for name in ("lam", "lam_left"):
        assert np.array_equal(getattr(part, name), getattr(full, name)[:, [2, 0]])
    with pytest.raises(GeomFDIError, match="sensors"):
        fault_profile(faults, T, y0, q=4, sensors=[2])


@given(
    gain=st.floats(-3, 3, allow_nan=False),
    bias=st.floats(-2, 2, allow_nan=False),
    start=st.floats(0, 10, allow_nan=False),
    sensor=st.integers(0, 2),
)
@settings(max_examples=40)
def test_gain_fault_is_additive_output_fault(gain, bias, start, sensor):
    # Erratum 1: the fault is phi = (eta - 1) y0 + lambda added to the reading
    y0 = _y0(seed=3)
    y = gf.GainFault(sensor, start=start, gain=gain, bias=bias).apply(T, y0)
    on = T >= start - 1e-9 * max(1, start)
    phi = np.zeros_like(y0)
    phi[sensor, on] = (gain - 1) * y0[sensor, on] + bias
    assert np.allclose(y, y0 + phi, atol=1e-12)


def test_validation_names_the_argument():
    with pytest.raises(GeomFDIError, match="sensor"):
        gf.GainFault(-1, start=1.0, gain=2.0)
    with pytest.raises(GeomFDIError, match="end"):
        gf.BiasFault(0, start=5.0, bias=1.0, end=5.0)
    with pytest.raises(GeomFDIError, match="gain"):
        gf.GainFault(0, start=1.0, gain="big")
    with pytest.raises(GeomFDIError, match="start"):
        gf.StuckFault(0, start=float("nan"))
    with pytest.raises(GeomFDIError, match="value"):
        gf.StuckFault(0, start=1.0, value=lambda t: t)
    with pytest.raises(ShapeError, match="gain"):  # not vectorised over t
        gf.GainFault(0, start=1.0, gain=lambda t: [1.0, 2.0]).apply(T, _y0())
    with pytest.raises(GeomFDIError, match="bias"):  # nan produced
        gf.GainFault(0, start=1.0, gain=1.0, bias=lambda t: np.full_like(t, np.nan)).apply(T, _y0())
    with pytest.raises(GeomFDIError, match=r"faults\[0\].sensor"):
        gf.apply_faults([gf.BiasFault(5, start=1.0, bias=1.0)], T, _y0())
    with pytest.raises(GeomFDIError, match=r"faults\[1\]"):
        gf.apply_faults([gf.BiasFault(0, start=1.0, bias=1.0), "oops"], T, _y0())
    with pytest.raises(ShapeError, match="y0"):
        gf.apply_faults([], T, np.ones((3, 5)))


def test_labels_and_repr():
    f = gf.GainFault(1, start=8.0, gain=1.5, bias=0.02)
    assert "gain 1.5" in f.label() and "sensor 1" in f.label()
    assert "StuckFault(2" in repr(gf.StuckFault(2, start=1.0))
    assert "bias 0.3" in gf.BiasFault(0, start=1.0, bias=0.3).label()


def test_fault_constructors_are_keyword_only_after_the_sensor():
    # GainFault(0, 1.5, 5.0) used to mean start=1.5, gain=5 silently
    for call in (
        lambda: gf.GainFault(0, 1.5, 5.0),
        lambda: gf.BiasFault(0, 1.5, 5.0),
        lambda: gf.StuckFault(0, 1.5),
    ):
        with pytest.raises(TypeError):
            call()
    f = gf.GainFault(0, start=1.5, gain=5.0)
    assert (f.start, f.gain, f.bias) == (1.5, 5.0, 0.0)
    assert gf.StuckFault(1, start=2.0).value is None
