"""API leftovers of the hostile-input review, each pinned to its named error (or its
correct result): raw ``TypeError``/``IndexError``/``MemoryError`` before, now the
argument is named."""

from __future__ import annotations

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.errors import GeomFDIError, ResourceLimitError, ShapeError

PLANT = gf.Plant([[1, 1, 1], [0, 1, 0], [2, 0, 1]], [[1, 0, 1], [0, 1, 1], [0, 1, 0]],
                 [[0, 1, 0], [0, 0, 1], [1, 0, 2]])  # fmt: skip
BANK = gf.design_sensor_bank(PLANT)
DBANK = BANK.discretize(0.01)


def named(exc_type: type, argument: str, fn, *args, **kwargs) -> GeomFDIError:
    with pytest.raises(exc_type) as err:
        fn(*args, **kwargs)
    assert err.value.argument == argument, err.value
    return err.value


@pytest.mark.parametrize("n", [-1, 2.5, "3", None, 10**12])
def test_subspace_full_and_zero_name_n(n):
    named(GeomFDIError, "n", gf.Subspace.full, n)
    named(GeomFDIError, "n", gf.Subspace.zero, n)


def test_subspace_full_and_zero_still_work():
    assert gf.Subspace.full(3).dim == 3 and gf.Subspace.zero(3).dim == 0
    assert gf.Subspace.full(0).dim == 0


@pytest.mark.parametrize("Q", [np.nan, [[np.nan]], np.eye(3)[:2], "abc", [[1.0], [2.0, 3.0]]])
def test_subspace_from_orthonormal_checks_q(Q):
    named(GeomFDIError, "Q", gf.Subspace.from_orthonormal, Q)


def test_ar_monitor_sizes_are_capped_before_work():
    named(GeomFDIError, "order", gf.ARMonitor, order=10**9, window=10**10)
    err = named(ResourceLimitError, "window", gf.ARMonitor, order=500, window=10**6)
    assert "800 MB" in str(err)
    assert gf.ARMonitor(order=5, window=10**5).window == 10**5


def test_persistence_window_is_capped():
    named(GeomFDIError, "persistence.n", gf.Persistence, 1, 10**9)
    named(GeomFDIError, "persistence.n", gf.Monitor, DBANK, threshold=1.0,
          persistence=(1, 10**12))  # fmt: skip
    assert gf.Persistence(2, 10**6).n == 10**6


def test_monitor_arguments_are_named():
    named(GeomFDIError, "dt", gf.Monitor, DBANK, dt=1 + 2j)
    named(GeomFDIError, "dt", gf.Monitor, DBANK, dt=float("nan"))
    named(GeomFDIError, "isolation", gf.Monitor, DBANK, isolation=np.array([1, 0]))
    mon = gf.Monitor(DBANK, threshold=1.0)
    named(ShapeError, "y", mon.step, float("nan"), np.zeros(3))
    named(ShapeError, "u", mon.step, np.zeros(3), float("nan"))
    named(ShapeError, "y", mon.step, [[1.0, 2.0], [3.0]], np.zeros(3))
    state = mon.state
    state["ring"] = [[1, 0], [1]]
    named(ShapeError, "state", setattr, mon, "state", state)


def test_codegen_out_dir_is_named(tmp_path):
    named(GeomFDIError, "out_dir", gf.codegen.c, DBANK, "m", float("nan"))
    named(GeomFDIError, "out_dir", gf.codegen.python, DBANK, "m", None)
    (tmp_path / "file").write_text("x")
    named(GeomFDIError, "out_dir", gf.codegen.python, DBANK, "m", tmp_path / "file")


def test_statistics_helpers_name_their_arguments():
    named(ShapeError, "residuals", gf.windowed_sum_of_squares, -1, 3)
    named(ShapeError, "residuals", gf.glr, -1, np.ones(3))
    named(ShapeError, "variances", gf.glr, np.ones((3, 20)), 2.5)
    named(GeomFDIError, "two_sided", gf.cusum, np.ones(5), 0.1, np.array([1, 0]))
    named(GeomFDIError, "shift", gf.cusum_arl, 5.0, 0.5, float("nan"))
    named(GeomFDIError, "threshold", gf.cusum_arl, 10.0**12, 0.5)
    assert np.isfinite(gf.cusum_arl(5.0, 0.5))
    named(GeomFDIError, "successes", gf.wilson_interval, float("nan"), 10)
    named(GeomFDIError, "trials", gf.wilson_interval, 3, float("nan"))
    named(GeomFDIError, "alarm", gf.latch_alarms, True)
    named(GeomFDIError, "alarm", gf.latch_alarms, [[True], [False, True]])
    named(ShapeError, "structure", gf.fault_hypotheses, [True], 0)


def test_kalman_and_noise_model_name_their_arguments():
    y = np.random.default_rng(0).standard_normal((40, 3))
    args = (np.eye(3) * 0.5, np.eye(3), np.eye(3), np.eye(3))
    named(ShapeError, "y", gf.kalman_innovations, *args, -1)
    named(ShapeError, "x0", gf.kalman_innovations, *args, y, x0=-1)
    noise = gf.Noise(measurement=0.1)
    gen = BANK.generators[0]
    named(GeomFDIError, "generator", gf.residual_noise_model, PLANT, float("nan"), noise, step=0.01)
    named(GeomFDIError, "noise", gf.residual_noise_model, PLANT, gen, float("nan"), step=0.01)
    named(GeomFDIError, "hold", gf.residual_noise_model, PLANT, gen, noise, step=0.01,
          hold=np.array(["foh", "zoh"]))  # fmt: skip
