"""Generated C and Python monitors reproduce gf.evaluate (residuals, alarms, isolation)."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from deploy_banks import DT, sampled_bank, seed_bank, vector_row_bank
from generated_c import compile_c, run_c
from script_loader import load_script

import geomfdi as gf
from geomfdi.errors import GeomFDIError, NotDiscreteError
from geomfdi.io.cli import main

CC = shutil.which("cc")
CFLAGS = ["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-O2"]
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler (cc) on this system")
N = 100_000


def _data(q: int, m: int, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(n) * DT
    Y = np.vstack([np.sin((i + 1) * 0.3 * t) for i in range(q)]) + 0.3 * rng.normal(size=(q, n))
    U = np.vstack([np.cos((j + 1) * 0.2 * t) for j in range(m)])
    Y[1, n // 20 : n // 20 + 4] = np.nan  # missing samples
    U[0, 7 * n // 10] = np.inf
    Y[0, 3 * n // 10 : 3 * n // 10 + 400] += 2.0  # a fault-like step
    return Y, U


def _check(
    res: gf.deployment.EvaluationResult, R: np.ndarray, Al: np.ndarray, iso: np.ndarray
) -> None:
    np.testing.assert_array_equal(np.isnan(R), np.isnan(res.residuals))
    assert np.nanmax(np.abs(R - res.residuals)) <= 1e-12
    np.testing.assert_array_equal(Al, res.alarms)
    np.testing.assert_array_equal(iso, res.isolated)


@pytest.fixture(scope="module")
def case() -> tuple:
    bank = sampled_bank()
    Y, U = _data(3, 3, N)
    kw = {"threshold": [0.9, 0.8, 0.8], "persistence": (2, 3)}
    res = gf.evaluate(bank, Y, U, dt=DT, **kw)
    assert res.alarms.any() and res.masked.sum() == 5 and len(set(res.isolated.tolist())) >= 3
    return bank, Y, U, kw, res


@needs_cc
def test_generated_c_matches_evaluate(case: tuple, tmp_path: Path) -> None:
    bank, Y, U, kw, res = case
    mon = gf.Monitor(bank, **kw)
    h, c = gf.codegen.c(mon, "fdi", tmp_path)
    src = c.read_text() + h.read_text()
    code = "\n".join(ln for ln in src.splitlines() if not ln.lstrip().startswith(("/*", "*")))
    assert "malloc" not in code and "static const double" in code
    lib = compile_c(c, tmp_path, CFLAGS)
    _check(res, *run_c(lib, "fdi", Y, U, 3))


@needs_cc
def test_generated_c_uses_no_libm_beyond_fabs_sqrt(case: tuple, tmp_path: Path) -> None:
    bank, *_ = case
    _, c = gf.codegen.c(vector_row_bank(), "vec", tmp_path, threshold=1.0)
    obj = tmp_path / "vec.o"
    proc = subprocess.run([CC, *CFLAGS, "-fno-builtin", "-c", "-o", str(obj), str(c)],
                          capture_output=True, text=True)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    nm = shutil.which("nm")
    if nm is None:
        pytest.skip("no nm to list the object's symbols")
    undefined = subprocess.run([nm, "-u", str(obj)], capture_output=True, text=True).stdout.split()
    calls = {s for s in undefined if s not in ("U", "w") and not s.startswith("_")}
    assert calls <= {"fabs", "sqrt"}, calls
    assert "sqrt" in calls  # the vector residual's norm


@needs_cc
def test_generated_c_vector_rows_and_bank_source(tmp_path: Path) -> None:
    bank = vector_row_bank()
    Y, U = _data(2, 1, 20_000, seed=3)
    kw = {"threshold": [1.5, 1.0, 1.0], "persistence": 2, "initial": "zero"}
    res = gf.evaluate(bank, Y, U, dt=DT, **kw)
    assert res.alarms[0].any() and res.alarms[2].any()
    _, c = gf.codegen.c(bank, "vec", tmp_path, **kw)
    _check(res, *run_c(compile_c(c, tmp_path, CFLAGS), "vec", Y, U, 3))
    mod = load_script(gf.codegen.python(bank, "vec_py", tmp_path, **kw))
    R, Al, iso = mod.run(Y.T, U.T)
    _check(res, R.T, Al.T, iso)


@pytest.mark.slow
def test_generated_python_matches_evaluate(case: tuple, tmp_path: Path) -> None:
    bank, Y, U, kw, res = case
    path = gf.codegen.python(gf.Monitor(bank, **kw), "fdi_py", tmp_path)
    text = path.read_text()
    imports = {ln.split()[1] for ln in text.splitlines() if ln.startswith("import ")}
    assert imports <= {"math", "numpy"} and "from " not in text.replace("float.fromhex", "")
    mod = load_script(path)
    R, Al, iso = mod.run(Y.T, U.T)
    _check(res, R.T, Al.T, iso)
    state = mod.init()  # step by step from a fresh state gives the same first samples
    for k in range(50):
        r, a, i = mod.step(state, Y[:, k], U[:, k])
        np.testing.assert_array_equal(r, R[k])
        assert i == iso[k]


@pytest.mark.slow
@pytest.mark.parametrize(
    "rule",
    [gf.Persistence(2, 3, reset=150), gf.Persistence(1, 1, reset=40), gf.Persistence(3, 5, False)],
)
def test_generated_code_latched_rule_with_reset(case: tuple, tmp_path: Path, rule: object) -> None:
    """The held pattern, its reset, MULTIPLE and the settling run the same in C and Python."""
    bank, Y, U, kw, _ = case
    kw = {**kw, "persistence": rule}
    res = gf.evaluate(bank, Y, U, dt=DT, **kw)
    iso = res.isolated
    assert (iso == -1).any() and (iso >= 0).any()
    if rule.latch:  # several faults at once, and episodes end: "no alarm" after a decision
        assert (iso == -4).any() and np.any((iso[:-1] >= 0) & (iso[1:] == -1))
    mon = gf.Monitor(bank, **kw)
    if CC is not None:
        h, c = gf.codegen.c(mon, "fdi_latch", tmp_path)
        assert "MULTIPLE" in h.read_text()
        _check(res, *run_c(compile_c(c, tmp_path, CFLAGS), "fdi_latch", Y, U, 3))
    mod = load_script(gf.codegen.python(mon, "fdi_latch_py", tmp_path))
    R, Al, isp = mod.run(Y.T, U.T)
    _check(res, R.T, Al.T, isp)


def test_generated_code_decides_multiple(tmp_path: Path) -> None:
    """A pattern that is the union of two columns gives -4 in C, Python and evaluate."""
    g = [
        gf.ResidualGenerator([[0.0]], -h[None], [[0.0]], [[0.0]], h[None], [[0.0]], dt=DT)
        for h in (np.array([1.0, 0.0]), np.array([0.0, 1.0]))
    ]
    S = np.eye(2, dtype=bool)
    bank = gf.ResidualBank(g, S, S, np.ones(2, bool), ["ok", "ok"], [], DT)
    Y = np.zeros((2, 60))
    Y[0, 10:] = 1.0  # fault 0 from sample 10
    Y[1, 20:25] = 1.0  # fault 1 for 5 samples: the held pattern keeps it
    U = np.zeros((1, 60))
    kw = {"threshold": 0.5, "persistence": gf.Persistence(2, 3, reset=10), "initial": "zero"}
    res = gf.evaluate(bank, Y, U, dt=DT, **kw)
    want = np.full(60, -1)
    want[11], want[12:21] = -2, 0  # confirmed at 11 (2 of 3), decision settled at 12
    want[21], want[22:] = -2, -4  # pattern {0, 1} held from 21, MULTIPLE settled at 22
    np.testing.assert_array_equal(res.isolated, want)
    mon = gf.Monitor(bank, **kw)
    mod = load_script(gf.codegen.python(mon, "multi_py", tmp_path))
    np.testing.assert_array_equal(mod.run(Y.T, U.T)[2], want)
    if CC is not None:
        _, c = gf.codegen.c(mon, "multi", tmp_path)
        np.testing.assert_array_equal(
            run_c(compile_c(c, tmp_path, CFLAGS), "multi", Y, U, 2)[2], want
        )


def test_continuous_bank_is_refused(tmp_path: Path) -> None:
    with pytest.raises(NotDiscreteError, match="discretize"):
        gf.codegen.c(seed_bank(), "x", tmp_path)
    with pytest.raises(NotDiscreteError, match="discretize"):
        gf.codegen.python(gf.Monitor(seed_bank(), dt=DT), "x", tmp_path)
    with pytest.raises(GeomFDIError, match="name: must be an identifier"):
        gf.codegen.c(sampled_bank(), "bad-name", tmp_path)


@pytest.mark.slow
@needs_cc
def test_cli_codegen(tmp_path: Path) -> None:
    model = tmp_path / "model.toml"
    model.write_text(
        "[plant]\nA = [[1, 1, 1], [0, 1, 0], [2, 0, 1]]\nB = [[1, 0, 1], [0, 1, 1], [0, 1, 0]]\n"
        "C = [[0, 1, 0], [0, 0, 1], [1, 0, 2]]\n"
    )
    out = tmp_path / "gen"
    args = ["codegen", str(model), "--lang", "c", "--out", str(out), "--quiet"]
    assert main([*args, "--threshold", "0.5"]) == 2  # continuous design without --dt
    assert main([*args, "--threshold", "0.5", "--dt", "0.01", "--persistence", "2/3"]) == 0
    lib = compile_c(out / "fdi_monitor.c", out, CFLAGS)
    bank = seed_bank().discretize(0.01)
    Y, U = _data(3, 3, 8000, seed=9)
    res = gf.evaluate(bank, Y, U, dt=0.01, threshold=0.5, persistence=(2, 3))
    _check(res, *run_c(lib, "fdi_monitor", Y, U, 3))
    py = ["codegen", str(model), "--lang", "python", "--out", str(out), "--dt", "0.01", "--quiet"]
    assert main(py) == 0 and (out / "fdi_monitor.py").exists()
