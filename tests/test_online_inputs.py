"""What reaches a deployed monitor from outside: states, odd samples, names.

* A state holding ``nan`` or ``inf`` (``mon.state = ...`` or a monitor file) is refused:
  a state never holds one (a missing sample sets the pending start-up rule instead), and
  a ``nan`` state silenced the monitor for good.
* One rule for out-of-range samples on ``step``, ``feed``, ``evaluate`` and generated
  code: an entry that is ``nan``, infinite or beyond ``SAMPLE_LIMIT`` makes the sample
  missing; so does an update that overflows (an unstable bank).
* Complex and text samples are refused by name; the generated ``run()`` works for a bank
  without inputs; code-generation names are checked and the C internals prefixed.
"""

from __future__ import annotations

import importlib.util
import json
import shutil
import subprocess
import warnings
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.deployment.program import SAMPLE_LIMIT
from geomfdi.errors import BankFileError, ComplexInputError, GeomFDIError, NonFiniteError

CC = shutil.which("cc")
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler (cc) on this system")
NO_INPUT = np.zeros((1, 0))


def _gen(F: float = 0.5, dt: float = 0.1) -> gf.ResidualGenerator:
    """``w+ = F w + 0.5 y``, ``r = w - y``: a step in ``y`` shows in ``r`` for a while."""
    return gf.ResidualGenerator([[F]], [[-0.5]], NO_INPUT, [[1.0]], [[1.0]], NO_INPUT, dt=dt)


def _load(path: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location(path.stem, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


# ------------------------------------------------------------------ states
@pytest.mark.parametrize("key", ["xi", "last_sample", "pending"])
@pytest.mark.parametrize("bad", [np.nan, np.inf, "abc", 1 + 2j])
def test_state_with_nan_or_junk_is_refused(key: str, bad: object) -> None:
    mon = gf.Monitor(_gen(), threshold=0.4)
    state = mon.state
    state[key] = [bad]
    with pytest.raises(GeomFDIError) as err:
        mon.state = state
    assert err.value.argument == "state" and key in str(err.value)
    # the monitor is unchanged and still alarms on a step
    mon.step([0.0])
    assert mon.step([5.0]).alarms[0]


def test_state_with_out_of_range_last_sample_is_refused() -> None:
    mon = gf.Monitor(_gen(), threshold=0.4)
    state = mon.state
    state["last_sample"] = [1e200]
    with pytest.raises(NonFiniteError, match="last_sample"):
        mon.state = state


def test_monitor_file_with_nan_state_is_refused(tmp_path: Path) -> None:
    """A file whose checksum is right (written by someone else's tool) but whose state
    holds ``nan``: refused by the state check, not only by the checksum."""
    from geomfdi.generators.bankfile import _checksum

    mon = gf.Monitor(_gen(), threshold=0.4)
    path = mon.save(tmp_path / "m.json")
    assert gf.load_monitor(path).state == mon.state
    doc = json.loads(path.read_text())
    doc["payload"]["state"]["xi"] = [{"$float": "nan"}]
    doc["checksum"] = _checksum(doc["payload"])
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(doc))
    with pytest.raises(BankFileError, match="state"):
        gf.load_monitor(bad)


def test_missing_samples_never_put_nan_into_the_state() -> None:
    """The decision the refusal rests on: a missing sample keeps ``xi`` finite and sets
    the pending rule, so a saved state always loads back."""
    mon = gf.Monitor(_gen(), threshold=0.4)
    for y in (1.0, np.nan, np.inf, 1e308, 2.0, np.nan):
        mon.step([y])
        state = mon.state
        assert np.isfinite(state["xi"]).all() and np.isfinite(state["last_sample"]).all()
        mon.state = state
    assert mon.state["pending"] == "steady"


# ------------------------------------------------------------------ samples
@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf, 1e308, -1e155, SAMPLE_LIMIT * 1.01])
def test_out_of_range_sample_is_missing_on_step_feed_and_evaluate(value: float) -> None:
    g = _gen()
    Y = np.array([[1.0, 1.0, value, 3.0, 3.0, 3.0]])
    mon = gf.Monitor(g, threshold=0.4)
    step = np.array([mon.step(Y[:, k]).residuals[0] for k in range(Y.shape[1])])
    fed = gf.Monitor(g, threshold=0.4).feed(Y)
    ev = gf.evaluate(g, Y, dt=0.1, threshold=0.4)
    for r in (step, fed.residuals[0], ev.residuals[0]):
        assert np.isnan(r[2]) and np.isfinite(np.delete(r, 2)).all()
        # the next valid sample restarts at the steady state: residual 0 for a constant
        assert r[3] == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(fed.residuals[0], step, rtol=1e-12, equal_nan=True)
    assert fed.masked.tolist() == [False, False, True, False, False, False]


def test_sample_at_the_limit_is_evaluated() -> None:
    mon = gf.Monitor(_gen(), threshold=0.4)
    mon.step([1.0])
    r = mon.step([SAMPLE_LIMIT]).residuals[0]
    assert np.isfinite(r) and abs(r) > 1e149


def _unstable_case() -> tuple[gf.ResidualGenerator, np.ndarray]:
    """``w+ = 1e80 w + 0.5 y``: the state overflows within four samples."""
    g = _gen(F=1e80)
    Y = np.ones((1, 12))
    Y[0, 6] = np.nan
    return g, Y


def test_overflowing_update_is_a_missing_sample_and_restarts() -> None:
    g, Y = _unstable_case()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow warning escapes
        mon = gf.Monitor(g, threshold=0.4, initial="zero")
        steps = [mon.step(Y[:, k]) for k in range(Y.shape[1])]
        fed = gf.Monitor(g, threshold=0.4, initial="zero").feed(Y)
        chunks = gf.Monitor(g, threshold=0.4, initial="zero")
        parts = [chunks.feed(Y[:, a:b]).residuals for a, b in ((0, 5), (5, 12))]
    r = np.array([s.residuals[0] for s in steps])
    np.testing.assert_allclose(fed.residuals[0], r, rtol=1e-12, equal_nan=True)
    np.testing.assert_allclose(np.concatenate(parts, axis=1)[0], r, rtol=1e-12, equal_nan=True)
    # some samples overflow, but the monitor never stays silent: it restarts each time
    assert np.isnan(r).sum() >= 3 and np.isfinite(r[-3:]).any()
    assert np.isfinite(mon.state["xi"]).all()


@needs_cc
def test_overflowing_update_agrees_in_generated_code(tmp_path: Path) -> None:
    from test_codegen_agreement import SAMPLES, _run_c

    g, Y = _unstable_case()
    Y = np.pad(Y, ((0, 0), (0, SAMPLES - Y.shape[1])), constant_values=2.0)
    mon = gf.Monitor(g, threshold=0.4, initial="zero")
    ref = np.array([mon.step(Y[:, k]).residuals[0] for k in range(SAMPLES)])
    ((R, A, iso),) = _run_c([mon], [(Y, np.zeros((0, SAMPLES)))], tmp_path)
    np.testing.assert_allclose(R[0], ref, rtol=1e-12, equal_nan=True)
    py = _load(gf.codegen.python(mon, "unstable_py", tmp_path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # numpy only: overflow warnings
        Rp, _, _ = py.run(Y.T)
    np.testing.assert_allclose(Rp[:, 0], ref, rtol=1e-12, equal_nan=True)


@pytest.mark.parametrize("bad", [[1 + 2j], np.array([1 + 2j]), ["abc"], [object()]])
def test_step_refuses_complex_and_text_samples(bad: object) -> None:
    mon = gf.Monitor(_gen(), threshold=0.4)
    with pytest.raises(GeomFDIError) as err:
        mon.step(bad)
    assert err.value.argument == "y"
    if isinstance(np.asarray(bad).flat[0], complex):
        assert isinstance(err.value, ComplexInputError)
    assert mon.state["samples"] == 0


def test_step_reads_integer_and_boolean_samples_as_numbers() -> None:
    a, b = gf.Monitor(_gen(), threshold=0.4), gf.Monitor(_gen(), threshold=0.4)
    for y in ([1], [True], [np.int64(3)]):
        assert a.step(y).residuals[0] == b.step([float(y[0])]).residuals[0]


# ------------------------------------------------------------------ generated code
def test_generated_python_runs_a_bank_without_inputs(tmp_path: Path) -> None:
    g = _gen()
    mod = _load(gf.codegen.python(g, "noinput", tmp_path, threshold=0.4))
    Y = np.linspace(0, 3, 8)[:, None]
    ref = gf.Monitor(g, threshold=0.4).feed(Y.T)
    for U in (None, np.zeros((8, 0)), []):
        R, A, iso = mod.run(Y, U)
        np.testing.assert_allclose(R[:, 0], ref.residuals[0], rtol=1e-12)
        np.testing.assert_array_equal(A[:, 0], ref.alarms[0])


def test_generated_python_refuses_complex_samples(tmp_path: Path) -> None:
    mod = _load(gf.codegen.python(_gen(), "cplx", tmp_path, threshold=0.4))
    with pytest.raises(TypeError):
        mod.step(mod.init(), np.array([1 + 2j]))


@needs_cc
@pytest.mark.parametrize("name", ["start", "decide", "init", "state", "fdi_start"])
def test_c_names_that_met_internal_names_compile(name: str, tmp_path: Path) -> None:
    _, src = gf.codegen.c(_gen(), name, tmp_path, threshold=0.4)
    obj = tmp_path / "x.o"
    proc = subprocess.run(
        [CC, "-std=c99", "-Wall", "-Werror", "-pedantic", "-c", "-o", str(obj), str(src)],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr


@pytest.mark.parametrize(
    "name", ["numpy", "np", "math", "json", "random", "int", "class", "while", "_x", "a" * 65]
)
@pytest.mark.parametrize("lang", ["c", "python"])
def test_names_that_shadow_modules_or_are_keywords_are_refused(
    name: str, lang: str, tmp_path: Path
) -> None:
    write = gf.codegen.c if lang == "c" else gf.codegen.python
    with pytest.raises(GeomFDIError) as err:
        write(_gen(), name, tmp_path)
    assert err.value.argument == "name"
    assert not list(tmp_path.iterdir())
