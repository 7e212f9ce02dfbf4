"""Hostile inputs reported against geomfdi, each pinned to its named error.

Zero noise in a calibration, ``tol=inf`` in ``verify``, ``nan``/complex alarms,
``nan`` generator matrices, seeds ``[None, None]``, ``'abc'``, ``-1`` and ``nan``, empty
training data, duplicate labels, Python integers beyond float64, unused options such as
``filter_pole='abc'``, and the shared validators themselves.
"""

from __future__ import annotations

import numpy as np
import pytest

import geomfdi as gf
from geomfdi._validation import (
    INT_MAX,
    as_bool,
    as_bool_array,
    as_choice,
    as_float,
    as_int,
    as_int_array,
    as_labels,
    as_name,
    as_positive,
    as_probability,
    as_real_array,
    as_seed,
    as_sequence_of,
    check_nonempty,
)
from geomfdi.errors import (
    ComplexInputError,
    GeomFDIError,
    NonFiniteError,
    ResourceLimitError,
    ShapeError,
)

PLANT = gf.Plant([[1, 1, 1], [0, 1, 0], [2, 0, 1]], [[1, 0, 1], [0, 1, 1], [0, 1, 0]],
                 [[0, 1, 0], [0, 0, 1], [1, 0, 2]])  # fmt: skip
BANK = gf.design_sensor_bank(PLANT)
T = np.linspace(0.0, 1.0, 51)


def named(exc_type: type, argument: str, fn, *args, **kwargs) -> GeomFDIError:
    with pytest.raises(exc_type) as err:
        fn(*args, **kwargs)
    assert err.value.argument == argument, err.value
    assert argument in str(err.value)
    return err.value


# ------------------------------------------------------------------ wrong answers
def test_zero_noise_calibration_is_refused_not_an_infinite_threshold():
    named(GeomFDIError, "noise", gf.calibrate_threshold, PLANT, BANK, T,
          noise=gf.Noise(measurement=0.0, seed=1), false_alarm_rate=0.05, runs=2)  # fmt: skip
    thr = gf.calibrate_threshold(PLANT, BANK, T, noise=gf.Noise(measurement=0.01, seed=1),
                                 false_alarm_rate=0.05, runs=2)  # fmt: skip
    assert np.all(np.isfinite(thr.values)) and np.all(thr.values > 0)


@pytest.mark.parametrize("skip", [-1, float("nan"), "abc", 5.0])
def test_calibration_skip_is_validated(skip):
    named(GeomFDIError, "skip", gf.calibrate_threshold, PLANT, BANK, T,
          noise=gf.Noise(measurement=0.01, seed=1), false_alarm_rate=0.05, skip=skip)  # fmt: skip


@pytest.mark.parametrize("tol", [float("inf"), 1.0, 2.0, 0.0, -1e-8, float("nan"), "1e-8"])
def test_verify_tolerance_cannot_pass_anything(tol):
    named(GeomFDIError, "tol", gf.verify, BANK, PLANT, tol=tol)


def test_verify_still_fails_a_leaking_generator_at_a_valid_tolerance():
    g = BANK.generators[0]
    leaky = gf.ResidualGenerator(g.F, g.E, g.G + 0.5, g.M, g.H, g.K, target=g.target,
                                 decoupled=g.decoupled, info=g.info)  # fmt: skip
    assert gf.verify(g, PLANT, tol=1e-8).ok
    assert not gf.verify(leaky, PLANT, tol=1e-2).ok


@pytest.mark.parametrize(
    "alarms, exc",
    [
        (np.array([[np.nan, 1.0]] * 3), NonFiniteError),
        (np.array([[1j, 1.0]] * 3), ComplexInputError),
        (np.array([[2.0, 0.0]] * 3), GeomFDIError),
        ([["yes", "no"]] * 3, GeomFDIError),
    ],
)
def test_isolate_rejects_nan_complex_and_non_boolean_alarms(alarms, exc):
    named(exc, "alarms", gf.isolate, alarms, BANK.structure)


def test_isolate_accepts_exact_zeros_and_ones():
    iso = gf.isolate(np.array([[1.0, 0.0], [0.0, 0.0], [0.0, 0.0]]), BANK.structure)
    assert iso.isolated.tolist() == [0, -1]


@pytest.mark.parametrize("name", list("FEGMHK"))
def test_nan_generator_matrices_are_named(name):
    g = BANK.generators[1]
    mats = {k: getattr(g, k) for k in "FEGMHK"}
    mats[name] = np.full_like(mats[name], np.nan)
    named(NonFiniteError, name, gf.ResidualGenerator, **mats)


# --------------------------------------------------------------------- seeds
def test_seeds_none_none_gives_two_runs():
    res = gf.simulate_batch(PLANT, BANK, T, runs=2, seeds=[None, None],
                            noise=gf.Noise(measurement=0.01), progress=False)  # fmt: skip
    assert res.runs == 2 and np.all(np.isfinite(res.residuals))
    assert not np.allclose(res.residuals[0], res.residuals[1])  # fresh entropy per run


@pytest.mark.parametrize("seed", ["abc", -1, float("nan"), 1.5, True, [1, -2], []])
def test_bad_seeds_are_named(seed):
    named(GeomFDIError, "noise.seed", gf.Noise, measurement=0.01, seed=seed)
    named(GeomFDIError, "seeds", gf.simulate_batch, PLANT, BANK, T, runs=2,
          seeds=[seed, 1], noise=gf.Noise(measurement=0.01))  # fmt: skip
    named(GeomFDIError, "rng", gf.synthetic_innovations, 10, rng=seed)


def test_valid_seeds_pass_unchanged():
    ss = np.random.SeedSequence(3)
    gen = np.random.default_rng(4)
    assert as_seed(None, "s") is None and as_seed(ss, "s") is ss and as_seed(gen, "s") is gen
    assert as_seed(np.int64(7), "s") == 7 and as_seed(10**40, "s") == 10**40
    assert as_seed([1, 2], "s") == [1, 2]


# ------------------------------------------------------------ empty data, labels
def test_ar_monitor_fit_on_empty_data():
    named(ShapeError, "training", gf.ARMonitor(order=2, window=20).fit, np.zeros((0, 20)))
    named(GeomFDIError, "training", gf.ARMonitor(order=2, window=20).fit, [])


def test_duplicate_labels_are_refused():
    named(GeomFDIError, "sensors", gf.ParityFDI, gf.parity.dodecahedron(),
          sensors=[0, 0, 1, 2, 3, 4])  # fmt: skip
    named(GeomFDIError, "fault_names", gf.WindowModel, [[0.5]], None, [[1.0]], Bf=[[1.0, 1.0]],
          Qw=1.0, Rv=1.0, fault_names=["a", "a"])  # fmt: skip


# ------------------------------------------------------ options that were ignored
@pytest.mark.parametrize(
    "option, value",
    [
        ("filter_pole", "abc"),
        ("filter_pole", float("nan")),
        ("margin", "abc"),
        ("margin", -1.0),
        ("margin", 0.0),
        ("method", None),
        ("minimal", "yes"),
    ],
)
def test_design_options_are_validated_even_when_unused(option, value):
    named(GeomFDIError, option, gf.design_sensor_bank, PLANT, **{option: value})


def test_discrete_margin_is_a_radius_below_one():
    Pd = gf.Plant(np.eye(3) * 0.5 + np.diag([0.1, 0.1], 1), np.eye(3), np.eye(3)[:2], dt=0.1)
    named(GeomFDIError, "margin", gf.design_sensor_bank, Pd, margin=1.5)


@pytest.mark.parametrize("kappa, alpha", [("abc", 0.01), (3.0, 2.0)])
def test_table_options_are_validated_for_every_method(kappa, alpha):
    model = gf.WindowModel([[0.5]], None, [[1.0], [1.0]], Bf=[[1.0]], Qw=1.0, Rv=1.0)
    with pytest.raises(GeomFDIError) as err:
        gf.diagnosability_table(model, [1.0, 1.0], "kl", kappa=kappa, alpha=alpha)
    assert err.value.argument in ("kappa", "alpha")


# --------------------------------------------------------------- huge requests
def test_python_big_ints_are_named_not_overflow():
    named(NonFiniteError, "A", gf.Plant, [[10**400]], [[1]], [[1]])
    named(GeomFDIError, "dt", gf.Plant, [[1]], [[1]], [[1]], dt=10**400)
    named(GeomFDIError, "runs", gf.simulate_batch, PLANT, BANK, T, runs=10**400)
    named(GeomFDIError, "window", gf.ARMonitor, order=2, window=10**400)


def test_huge_counts_hit_the_limits_before_allocating():
    err = named(ResourceLimitError, "runs", gf.calibrate_threshold, PLANT, BANK, T,
                noise=gf.Noise(measurement=0.01, seed=1), false_alarm_rate=0.05,
                runs=10**9)  # fmt: skip
    assert err.limit == "max_runs"
    err = named(ResourceLimitError, "n_samples", gf.synthetic_innovations, 10**12)
    assert err.limit == "max_samples" and "TiB" in str(err)
    named(ResourceLimitError, "window", gf.WindowModel, [[0.5]], None, [[1.0]], Bf=[[1.0]],
          Qw=1.0, Rv=1.0, window=10**6)  # fmt: skip
    with gf.limits.limits(max_runs=3):
        named(ResourceLimitError, "runs", gf.simulate_batch, PLANT, BANK, T, runs=4)
        assert gf.simulate_batch(PLANT, BANK, T, runs=3, progress=False).runs == 3


# ---------------------------------------------------------------- validators
@pytest.mark.parametrize("bad", [True, 1.0, "3", None, 10**400, -(10**400), np.float64(2)])
def test_as_int_rejects_non_integers_and_big_ints(bad):
    with pytest.raises(GeomFDIError) as err:
        as_int(bad, "k")
    assert err.value.argument == "k"


def test_as_int_ranges_and_numpy_integers():
    assert as_int(np.int8(5), "k", minimum=0, maximum=5) == 5
    assert as_int(INT_MAX, "k") == INT_MAX
    with pytest.raises(GeomFDIError, match="<= 4"):
        as_int(5, "k", maximum=4)
    with pytest.raises(GeomFDIError, match=">= 6"):
        as_int(5, "k", minimum=6)


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), 1j, "1", True, None, [1.0],
                                 [[1.0], [2.0, 3.0]], {1: 2}, 10**400])  # fmt: skip
def test_scalar_validators_name_the_argument(bad):
    for fn in (as_positive, as_probability, as_float):
        with pytest.raises(GeomFDIError) as err:
            fn(bad, "x")
        assert err.value.argument == "x"


def test_scalar_validator_ranges():
    assert as_float(None, "x", allow_none=True) is None
    assert as_float(np.float32(0.5), "x", minimum=0, maximum=1) == 0.5
    with pytest.raises(GeomFDIError, match=">= 1"):
        as_float(0.5, "x", minimum=1)
    assert as_positive(0.0, "x", strict=False) == 0.0


def test_flag_choice_label_and_sequence_validators():
    assert as_bool(np.bool_(True), "f") is True
    for bad in (1, "yes", None, np.array([True])):
        with pytest.raises(GeomFDIError):
            as_bool(bad, "f")
    assert as_choice("abs", "s", ("abs", "rms")) == "abs"
    for bad in ("ABS", np.array(["abs"], dtype=object), None):
        with pytest.raises(GeomFDIError):
            as_choice(bad, "s", ("abs", "rms"))
    assert as_labels(["a", "b"], "l", count=2) == ("a", "b")
    for bad in (["a", "a"], "ab", ["a", ""], ["a", 1], ["x" * 201]):
        with pytest.raises(GeomFDIError):
            as_labels(bad, "l")
    with pytest.raises(ShapeError):
        as_labels(["a"], "l", count=2)
    with pytest.raises(GeomFDIError):
        as_name("a\nb", "n")
    assert as_sequence_of([None, None], "s", object) == [None, None]
    assert as_sequence_of(5, "s", int) == [5]
    with pytest.raises(GeomFDIError, match="entry 1"):
        as_sequence_of([1, "x"], "s", int)


def test_array_validators():
    assert as_bool_array([[0, 1]], "a").dtype == bool
    with pytest.raises(GeomFDIError):
        as_bool_array([[0.5]], "a")
    assert as_int_array([1.0, 2.0], "i").dtype == np.intp
    for bad in ([1.5], [True, False], [float("inf")], [10.0**300]):
        with pytest.raises(GeomFDIError):
            as_int_array(bad, "i")
    with pytest.raises(NonFiniteError):
        as_real_array([[10**400, 1]], "M")
    with pytest.raises(GeomFDIError):
        as_real_array(True, "M")
    with pytest.raises(ShapeError):
        check_nonempty(np.zeros((0, 3)), "d")
    with pytest.raises(ShapeError, match="axis 1"):
        check_nonempty(np.zeros((3, 0)), "d", axis=1)
    check_nonempty(np.zeros(2), "d", min_size=2)
