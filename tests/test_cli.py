"""The ``geomfdi`` command line: the bundled examples, ``--json`` output and bad model files."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from geomfdi.errors import GeomFDIError, ModelFileError
from geomfdi.io import cli
from geomfdi.io.modelfile import load_model, parse_model

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "examples").glob("*.toml"))
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"

# Reference values (Hou, Wen & Chen 2011, §4): max |r| on [8, 20] s of the paper
# design for the sensor-1 gain fault eta = 1.5, lambda = 0.02.
SEED001_PAPER_PEAKS = (0.145, 0.213, 0.319)


def _run_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "geomfdi.io.cli", *args],
        capture_output=True,
        text=True,
        cwd=cwd,
        env={**os.environ, "MPLBACKEND": "Agg"},
        timeout=300,
    )


def _row(summary: dict, scenario: int, method: str) -> dict:
    spec_rows = [r for r in summary["simulation"] if r["method"] == method]
    names = list(dict.fromkeys(r["scenario"] for r in summary["simulation"]))
    return next(r for r in spec_rows if r["scenario"] == names[scenario])


def _check_outputs(out: Path) -> tuple[str, dict]:
    report = (out / "report.md").read_text(encoding="utf-8")
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert report.startswith("# geomfdi report:")
    named = re.findall(r"!\[[^\]]*\]\(([^)]+\.png)\)", report)
    assert named, "the report shows no figure"
    for name in named:
        png = out / name
        assert png.is_file(), f"{name} is named in report.md but missing"
        data = png.read_bytes()
        assert data[:8] == PNG_SIGNATURE, f"{name} is not a PNG"
        assert len(data) > 5000, f"{name} is suspiciously small ({len(data)} bytes)"
    written = {p.name for p in out.glob("*.png")}
    assert written == set(named), "every PNG written is shown in the report"
    return report, summary


@pytest.mark.slow
@pytest.mark.parametrize("model", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_run_every_example(model: Path, tmp_path: Path) -> None:
    proc = _run_cli("run", str(model), "--out", str(tmp_path / "out"), "--quiet")
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    report, summary = _check_outputs(tmp_path / "out")
    spec = load_model(model)
    assert set(summary["design"]) == {m.method for m in spec.methods}
    # the exact design is verified exact and decouples what it must
    if "exact" in summary["verification"]:
        ver = summary["verification"]["exact"]
        assert ver["ok"] and ver["max_leakage"] < 1e-9
        assert ver.get("symbolic_ok", True)
    # every scenario was simulated with every method that has a generator
    assert len(summary["simulation"]) == len(spec.scenarios) * len(spec.methods)
    for row in summary["simulation"]:
        assert len(row["max_abs"]) == spec.structure.shape[0]
        assert all(np.isfinite(row["max_abs"]))
        if row["method"] not in ("exact", "full"):  # the exactly decoupling designs
            continue
        faults = row["events"]
        if not faults:  # healthy run (disturbance and noise only): no alarm at all
            assert not row["alarms"], row["scenario"]
        for ev in faults:  # the exact bank detects every simulated fault ...
            assert ev["detection_delay"] is not None, (row["scenario"], ev["fault"])
        if len(faults) == 1:  # ... and isolates every single fault
            assert faults[0]["isolation_delay"] is not None, row["scenario"]
    assert spec.name in report


@pytest.mark.slow
def test_seed001_reference_numbers(tmp_path: Path) -> None:
    out = tmp_path / "hou_wen_chen"
    assert (
        cli.main(
            ["run", str(ROOT / "examples" / "hou_wen_chen.toml"), "--out", str(out), "--quiet"]
        )
        == 0
    )
    _, summary = _check_outputs(out)
    paper = _row(summary, 0, "paper")
    assert paper["window"] == [8.0, 20.0]
    np.testing.assert_allclose(paper["max_abs"], SEED001_PAPER_PEAKS, rtol=0.02)
    exact = _row(summary, 0, "exact")
    assert exact["max_abs"][0] > 0.06  # sees the fault above the paper's threshold
    assert max(exact["max_abs"][1:]) < 1e-9  # r2, r3: leakage at rounding level
    assert summary["verification"]["paper"]["ok"] is False
    assert summary["verification"]["paper"]["symbolic_ok"] is False
    assert summary["verification"]["exact"]["symbolic_ok"] is True
    # only the exact bank isolates all three sensors
    assert summary["design"]["paper"]["isolable"] == [True, False, False]
    assert summary["design"]["exact"]["isolable"] == [True, True, True]


@pytest.mark.slow
def test_run_writes_to_working_directory_by_default(tmp_path: Path) -> None:
    model = ROOT / "examples" / "discrete_disturbance.toml"
    proc = _run_cli("run", str(model), "--no-symbolic", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "report.md").is_file()
    assert "written to" in proc.stdout and "| scenario |" in proc.stdout
    _check_outputs(tmp_path)


def test_design_json_lists_generator_matrices(capsys: pytest.CaptureFixture[str]) -> None:
    code = cli.main(["design", str(ROOT / "examples" / "hou_wen_chen.toml"), "--json"])
    assert code == 0
    data = json.loads(capsys.readouterr().out)
    assert data["plant"] == {"n": 3, "m": 3, "q": 3, "dt": 0.0}
    assert set(data["design"]) == {"paper", "exact"}
    for method, bank in data["design"].items():
        assert len(bank["generators"]) == 3
        for g in bank["generators"]:
            assert g["exists"], (method, g)
            F, E, G, M, H, K = (np.array(g[k], dtype=float) for k in "FEGMHK")
            n = g["order"]
            assert F.shape == (n, n) and E.shape == (n, 3) and G.shape == (n, 3)
            p = M.shape[0]
            assert M.shape == (p, n) and H.shape == (p, 3) and K.shape == (p, 3)
            # the generator is stable (continuous time)
            assert np.all(np.linalg.eigvals(F).real < 0)
    exact = data["design"]["exact"]["generators"]
    assert [g["order"] for g in exact] == [1, 3, 3]  # the paper: r2, r3 need third order
    # r1 reads only y1 and u: its columns of E and H for sensors 2, 3 vanish
    E0, H0 = np.array(exact[0]["E"]), np.array(exact[0]["H"])
    assert np.abs(E0[:, 1:]).max() < 1e-12 and np.abs(H0[:, 1:]).max() < 1e-12
    assert np.abs(np.hstack([E0[:, :1], H0[:, :1]])).max() > 1e-3
    paper = data["design"]["paper"]["generators"]
    assert all(np.allclose(g["F"], [[-2.0]]) for g in paper)  # the paper's F = -2


def test_verify_json_reports_paper_leakage(capsys: pytest.CaptureFixture[str]) -> None:
    code = cli.main(["verify", str(ROOT / "examples" / "hou_wen_chen.toml"), "--json"])
    assert code == 0
    data = json.loads(capsys.readouterr().out)
    assert "simulation" not in data
    ver = data["verification"]
    assert ver["exact"]["ok"] and ver["exact"]["max_leakage"] < 1e-9
    assert not ver["paper"]["ok"] and ver["paper"]["max_leakage"] > 1e-3
    assert ver["exact"]["symbolic_ok"] and not ver["paper"]["symbolic_ok"]


def test_help_lists_the_commands(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        cli.main(["--help"])
    assert exc.value.code == 0
    text = capsys.readouterr().out
    for command in ("run", "design", "verify", "simulate"):
        assert command in text


# ------------------------------------------------------------------ bad model files
BASE = """\
name = "tiny"

[plant]
A = [[-1, 0], [1, -2]]
B = [[1], [0]]
C = [[1, 0], [0, 1]]

[simulation]
t_end = 2.0
step = 0.01
u = ["sin(t)"]
threshold = 0.05

[[scenario]]
name = "bias on sensor 0"
[[scenario.faults]]
type = "bias"
sensor = 0
start = 1.0
bias = 0.2
"""


def _variant(old: str, new: str) -> str:
    assert BASE.count(old) == 1, old
    return BASE.replace(old, new)


BAD_MODELS = {
    # case: (model text, substrings the error line must contain)
    "missing-C": (_variant("C = [[1, 0], [0, 1]]\n", ""), ["plant.C", "missing"]),
    "wrong-shape-B": (
        _variant("B = [[1], [0]]", "B = [[1], [0], [2]]"),
        ["plant.B", "expected shape (2, any)", "(3, 1)"],
    ),
    "non-numeric-A": (
        _variant("A = [[-1, 0], [1, -2]]", 'A = [[-1, "zero"], [1, -2]]'),
        ["plant.A[0][1]", "expected a number", "'zero'"],
    ),
    "non-square-A": (
        _variant("A = [[-1, 0], [1, -2]]", "A = [[-1, 0, 0], [1, -2, 0]]"),
        ["plant.A", "square"],
    ),
    "infinite-entry": (
        _variant("A = [[-1, 0], [1, -2]]", "A = [[-1, inf], [1, -2]]"),
        ["plant.A", "finite"],
    ),
    "unknown-fault-type": (
        _variant('type = "bias"', 'type = "drift"'),
        ["scenario[0].faults[0].type", "unknown fault type 'drift'", "gain, bias, stuck"],
    ),
    "unknown-key-typo": (
        _variant("t_end = 2.0", "t_ned = 2.0"),
        ["simulation", "unknown key 't_ned'", "did you mean 't_end'"],
    ),
    "invalid-toml": (_variant("step = 0.01", "step = = 0.01"), ["not valid TOML", "line 10"]),
    "bad-expression-import": (
        _variant('u = ["sin(t)"]', "u = [\"__import__('os')\"]"),
        ["simulation.u[0]", "unknown function '__import__'"],
    ),
    "bad-expression-attribute": (
        _variant('u = ["sin(t)"]', 'u = ["t.real"]'),
        ["simulation.u[0]", "Attribute"],
    ),
    "bad-expression-arity": (
        _variant('u = ["sin(t)"]', 'u = ["sin(t, 2)"]'),
        ["simulation.u[0]", "sin() takes 1"],
    ),
    "expression-not-finite": (
        _variant('u = ["sin(t)"]', 'u = ["log(t)"]'),
        ["simulation.u[0]", "not finite", "t = 0"],
    ),
    "wrong-number-of-inputs": (
        _variant('u = ["sin(t)"]', 'u = ["sin(t)", "1"]'),
        ["simulation.u", "1 entries (one per input)"],
    ),
    "sensor-out-of-range": (
        _variant("sensor = 0", "sensor = 5"),
        ["scenario[0].faults[0].sensor", "0..1", "5"],
    ),
    "fault-expression-not-finite-while-active": (
        _variant("bias = 0.2", 'bias = "log(t - 1.5)"'),
        ["scenario[0].faults[0].bias", "not finite", "t = 1"],
    ),
    "unknown-key-in-fault": (
        _variant("sensor = 0", "sensr = 0"),
        ["scenario[0].faults[0]", "unknown key 'sensr'", "did you mean 'sensor'"],
    ),
    "missing-fault-start": (_variant("start = 1.0\n", ""), ["faults[0].start", "missing"]),
    "calibration-without-noise": (
        _variant("threshold = 0.05", "threshold = {false_alarm_rate = 0.001, runs = 3}"),
        ["simulation.threshold", "noise"],
    ),
    "calibration-runs-not-integer": (
        _variant(
            "threshold = 0.05",
            'threshold = {false_alarm_rate = 0.001, runs = "many"}\nnoise = {measurement = 0.01}',
        ),
        ["simulation.threshold.runs", "integer"],
    ),
    "negative-seed": (
        _variant("threshold = 0.05", "threshold = 0.05\nnoise = {measurement = 0.01, seed = -1}"),
        ["simulation.noise.seed", ">= 0"],
    ),
    "negative-noise": (
        _variant("threshold = 0.05", "threshold = 0.05\nnoise = {measurement = -0.01}"),
        ["simulation.noise.measurement", "non-negative"],
    ),
    "disturbance-without-Bd": (
        _variant('u = ["sin(t)"]', 'u = ["sin(t)"]\nd = ["1"]'),
        ["simulation.d", "no disturbance"],
    ),
    "structure-wrong-columns": (
        _variant("[simulation]", "[design]\nstructure = [[1, 0, 0]]\n\n[simulation]"),
        ["design.structure", "expected shape (any, 2)"],
    ),
    "unknown-method": (
        _variant("[simulation]", '[design]\nmethods = ["fast"]\n\n[simulation]'),
        ["design.methods[0]", "unknown method 'fast'"],
    ),
    "design-poles-wrong-count": (
        _variant("[simulation]", "[design]\npoles = [-1, -2, -3]\n\n[simulation]"),
        ["design.exact: poles", "expected 1 poles"],
    ),
    "window-outside-grid": (
        _variant("threshold = 0.05", "threshold = 0.05\nwindow = [5.0, 8.0]"),
        ["simulation.window", "overlapping"],
    ),
    "too-many-samples": (
        _variant("step = 0.01", "step = 1e-9"),
        ["simulation.step", "samples"],
    ),
    "negative-margin": (
        _variant("[simulation]", "[design]\nmargin = -1\n\n[simulation]"),
        ["design.exact.margin", "positive"],
    ),
    "negative-filter-pole": (
        _variant("[simulation]", "[design]\nfilter_pole = -1\n\n[simulation]"),
        ["design.exact.filter_pole", "positive"],
    ),
    "integer-beyond-float-in-matrix": (
        _variant("A = [[-1, 0], [1, -2]]", "A = [[-1, 1" + "0" * 400 + "], [1, -2]]"),
        ["plant.A[0][1]", "too large"],
    ),
    "integer-beyond-float-in-number": (
        _variant("t_end = 2.0", "t_end = 1" + "0" * 400),
        ["simulation.t_end", "too large"],
    ),
    "integer-beyond-float-in-expression": (
        _variant('u = ["sin(t)"]', "u = [1" + "0" * 400 + "]"),
        ["simulation.u[0]", "finite"],
    ),
    "grid-overflow": (
        _variant("t_end = 2.0\nstep = 0.01", "t_end = 1e308\nstep = 1e-308"),
        ["simulation.step", "more than 1e308 samples", "at most"],
    ),
    "calibration-runs-over-the-cap": (
        _variant("threshold = 0.05", "threshold = {false_alarm_rate = 1e-3, runs = 1000000000}"),
        ["simulation.threshold.runs", "at most 10000"],
    ),
    "arrays-nested-too-deep": (
        _variant('u = ["sin(t)"]', 'u = [[[["sin(t)"]]]]'),
        ["simulation.u", "nested more than 3 levels"],
    ),
    "arrays-nested-beyond-the-parser": (
        _variant('u = ["sin(t)"]', "u = " + "[" * 100_000 + "]" * 100_000),
        ["nested too deeply"],
    ),
}


def _error_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("geomfdi: error: ")
    return lines[0]


def test_base_model_is_valid(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Control for the bad-file cases: the unmodified model runs."""
    path = tmp_path / "tiny.toml"
    path.write_text(BASE, encoding="utf-8")
    assert cli.main(["simulate", str(path), "--out", str(tmp_path), "--no-plots", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    ev = data["simulation"][0]["events"][0]
    assert ev["detection_delay"] is not None and ev["isolation_delay"] is not None


def test_fault_expression_only_needs_to_be_finite_while_active(tmp_path: Path) -> None:
    path = tmp_path / "late.toml"
    path.write_text(_variant("bias = 0.2", 'bias = "log(t - 0.5)"'), encoding="utf-8")
    spec = load_model(path)  # log(t - 0.5) is -inf at t = 0.5 < start = 1
    (fault,) = spec.scenarios[0].faults
    t = np.array([1.0, 1.5])
    np.testing.assert_allclose(fault.bias_values(t), np.log(t - 0.5))


@pytest.mark.parametrize("case", sorted(BAD_MODELS))
def test_bad_model_file(case: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    text, expected = BAD_MODELS[case]
    path = tmp_path / "model.toml"
    path.write_text(text, encoding="utf-8")
    code = cli.main(["run", str(path), "--out", str(tmp_path / "out"), "--no-plots"])
    assert code == 2
    line = _error_line(capsys)
    assert str(path) in line
    for piece in expected:
        assert piece in line, (piece, line)
    # nothing was written for a model that does not load
    assert not (tmp_path / "out" / "report.md").exists()


def test_missing_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "nowhere.toml"
    assert cli.main(["design", str(path)]) == 2
    line = _error_line(capsys)
    assert str(path) in line and "cannot read the file" in line


def test_directory_instead_of_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["design", str(tmp_path)]) == 2
    assert "cannot read the file" in _error_line(capsys)


def test_binary_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "model.toml"
    path.write_bytes(b"\xff\xfe\x00A = 1")
    assert cli.main(["design", str(path)]) == 2
    assert "not a UTF-8 text file" in _error_line(capsys)


def test_bad_model_file_via_console_script(tmp_path: Path) -> None:
    """The installed entry point: exit code 2 and one line on stderr, in a fresh process."""
    path = tmp_path / "model.toml"
    path.write_text(BAD_MODELS["wrong-shape-B"][0], encoding="utf-8")
    proc = _run_cli("run", str(path), "--out", str(tmp_path))
    assert proc.returncode == 2
    assert proc.stdout == ""
    lines = proc.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("geomfdi: error: ")
    assert "plant.B" in lines[0] and "expected shape (2, any)" in lines[0]


def test_internal_error_is_one_line_unless_traceback_requested(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "tiny.toml"
    path.write_text(BASE, encoding="utf-8")

    def broken(*args: object, **kwargs: object) -> None:
        raise ZeroDivisionError("division by zero\nsecond line")

    monkeypatch.setattr(cli, "run_model", broken)
    assert cli.main(["design", str(path)]) == 1
    line = _error_line(capsys)
    assert "internal error ZeroDivisionError: division by zero second line" in line
    assert "--traceback" in line
    with pytest.raises(ZeroDivisionError):
        cli.main(["design", str(path), "--traceback"])


def test_model_errors_name_the_argument() -> None:
    with pytest.raises(ModelFileError) as exc:
        parse_model({"plant": {"A": [[1.0]], "C": [[1.0]], "B": [[1.0], [2.0]]}}, "m.toml")
    assert exc.value.argument == "plant.B"
    assert str(exc.value) == "m.toml: plant.B: expected shape (1, any), got (2, 1)"


def test_disturbance_signals_are_parsed(tmp_path: Path) -> None:
    text = _variant('u = ["sin(t)"]', 'u = ["sin(t)"]\nd = ["0.5*step(t - 1)"]').replace(
        "B = [[1], [0]]", "B = [[1], [0]]\nBd = [[0], [1]]"
    )
    text += '\n[[scenario]]\nname = "other load"\nd = ["2"]\n'
    path = tmp_path / "dist.toml"
    path.write_text(text, encoding="utf-8")
    spec = load_model(path)
    assert spec.plant.nd == 1
    t = np.array([0.0, 0.5, 1.0, 1.5])
    np.testing.assert_array_equal(spec.d(t), [[0.0, 0.0, 0.5, 0.5]])
    assert spec.scenarios[0].d is None
    np.testing.assert_array_equal(spec.scenarios[1].d(t), [[2.0] * 4])
    np.testing.assert_array_equal(spec.u(t), [np.sin(t)])


# ------------------------------------------------------------------ labels, limits, output


def _scenario_sensors(name: str) -> set[int]:
    """Sensor numbers a scenario name mentions ("sensor 0", "sensors 1, 2")."""
    found: set[int] = set()
    for m in re.finditer(r"sensors? ((?:\d+(?:, | and |, and )?)+)", name):
        found |= {int(x) for x in re.findall(r"\d+", m.group(1))}
    return found


def test_scenario_sensor_helper() -> None:
    assert _scenario_sensors("sensors 1, 2 abrupt at 8 s, sensor 0 time-varying") == {0, 1, 2}
    assert _scenario_sensors("gain steps on all three sensors at 8 s") == set()


@pytest.mark.parametrize("model", EXAMPLES, ids=lambda p: p.stem)
def test_example_sensor_labels_are_the_0_based_indices(model: Path) -> None:
    """A scenario title names the sensors its faults touch, with the file's 0-based index."""
    spec = load_model(model)
    for sc in spec.scenarios:
        named = _scenario_sensors(sc.name)
        touched = {f.sensor for f in sc.faults}
        assert named <= touched, (sc.name, touched)


def test_report_numbers_sensors_from_0(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["design", str(ROOT / "examples" / "hou_wen_chen.toml"), "--no-plots"]) == 0
    report = capsys.readouterr().out
    assert "numbered from 0" in report
    assert "| r0 | 1 | 0 | ok |" in report  # the paper's first residual sees sensor 0


def test_report_gives_plant_n_and_design_dimension_apart(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Decoupling both sensors of a 4-state plant: dim S* is the design model's 6.

    The full-quotient design (exact sensor-fault transform, one output-filter state per
    sensor) is the one whose design model is larger than the plant.
    """
    path = tmp_path / "four.toml"
    path.write_text(
        """
[plant]
A = [[0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1], [-1, -2, -3, -4]]
B = [[0], [0], [0], [1]]
C = [[1, 0, 0, 0], [0, 1, 0, 0]]
[design]
structure = [[0, 0, 1]]
methods = ["full"]
[[design.faults]]
type = "sensor"
sensor = 0
[[design.faults]]
type = "sensor"
sensor = 1
[[design.faults]]
type = "actuator"
b = [0, 0, 0, 1]
""",
        encoding="utf-8",
    )
    assert cli.main(["design", str(path)]) == 0
    report = capsys.readouterr().out
    assert "n = 4 states" in report
    assert "dim S* = n_d = 6 (the design model's dimension: plant n = 4 + 2 output-filter" in report
    assert "n = 6" not in report
    # the default least-order design makes the two decoupled sensor faults states
    path.write_text(path.read_text(encoding="utf-8").replace('methods = ["full"]\n', ""))
    assert cli.main(["design", str(path)]) == 0
    report = capsys.readouterr().out
    assert (
        "dim S* = n_d = 6 (the design model's dimension: plant n = 4 + 2 states of decoupled "
        "faults on the outputs)" in report
    )
    assert "n = 6" not in report


def test_long_scenario_name_gives_a_short_file_name(tmp_path: Path) -> None:
    path = tmp_path / "long.toml"
    path.write_text(_variant('name = "bias on sensor 0"', f'name = "{"x" * 300}"'))
    out = tmp_path / "out"
    assert cli.main(["simulate", str(path), "--out", str(out), "--quiet"]) == 0
    (png,) = out.glob("residuals_*.png")
    assert len(png.stem) <= cli.MAX_STEM + len("residuals__exact")
    assert png.name in (out / "report.md").read_text(encoding="utf-8")


def test_unique_stems_after_shortening() -> None:
    text = BASE + BASE[BASE.index("[[scenario]]") :]
    long = f'name = "{"y" * 200}"'
    spec = parse_model(__import__("tomllib").loads(text.replace('name = "bias on sensor 0"', long)))
    stems = cli._unique_names(spec)
    assert len(set(stems)) == 2 and all(len(s) <= cli.MAX_STEM + 2 for s in stems)


def test_output_problems_are_found_before_any_work(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "tiny.toml"
    path.write_text(BASE, encoding="utf-8")
    blocker = tmp_path / "a-file"
    blocker.write_text("", encoding="utf-8")

    def no_design(*args: object, **kwargs: object) -> None:
        raise AssertionError("the design ran before the output was checked")

    monkeypatch.setattr(cli, "design_all", no_design)
    assert cli.main(["run", str(path), "--out", str(blocker / "sub")]) == 2
    assert "a-file" in _error_line(capsys)
    spec = load_model(path)
    monkeypatch.setattr(os, "pathconf", lambda *a: 20)
    with pytest.raises(cli.GeomFDIError, match="longer than 20 bytes"):
        cli.check_outputs(spec, tmp_path / "o", ["exact"])


def test_closed_pipe_ends_quietly(tmp_path: Path) -> None:
    """``geomfdi design ... --json | head``: no traceback when the reader goes away."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "geomfdi.io.cli", "design", str(EXAMPLES[0]), "--json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env={**os.environ, "MPLBACKEND": "Agg"},
    )
    proc.stdout.close()  # the reader is gone before anything is written
    err = proc.stderr.read().decode()
    proc.stderr.close()
    assert proc.wait(timeout=300) == 141
    assert "Traceback" not in err and "BrokenPipe" not in err, err


def test_progress_goes_to_stderr_unless_quiet(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "tiny.toml"
    path.write_text(BASE, encoding="utf-8")
    out = tmp_path / "out"
    assert cli.main(["simulate", str(path), "--out", str(out), "--progress", "--json"]) == 0
    captured = capsys.readouterr()
    assert "geomfdi: designing 1 bank(s): exact" in captured.err
    assert "geomfdi: [1/1] simulating bias on sensor 0 (exact)" in captured.err
    json.loads(captured.out)  # stdout keeps only the JSON
    assert cli.main(["simulate", str(path), "--out", str(out), "--progress", "--quiet"]) == 0
    assert capsys.readouterr().err == ""


def test_decimation_keeps_every_bucket_extreme() -> None:
    rng = np.random.default_rng(0)
    r = rng.standard_normal((3, 10_007)).cumsum(axis=1)
    cols = 50
    idx = cli.decimate_minmax(np.arange(r.shape[1]), r, columns=cols)
    assert np.all(np.diff(idx) > 0) and idx[0] == 0 and idx[-1] == r.shape[1] - 1
    assert idx.size <= 3 * cols * 2 + r.shape[1] % cols + 1 + cols
    width = r.shape[1] // cols
    for b in range(cols):
        lo, hi = b * width, (b + 1) * width
        kept = idx[(idx >= lo) & (idx < hi)]
        np.testing.assert_array_equal(r[:, kept].max(axis=1), r[:, lo:hi].max(axis=1))
        np.testing.assert_array_equal(r[:, kept].min(axis=1), r[:, lo:hi].min(axis=1))
    short = cli.decimate_minmax(np.arange(30), r[:, :30], columns=50)
    np.testing.assert_array_equal(short, np.arange(30))


def test_figure_alarms_follow_the_decimation() -> None:
    """An alarm of one sample inside a bucket still shades the decimated figure."""

    class Res:
        t = np.linspace(0, 1, 100_000)
        residuals = np.zeros((1, 100_000))
        threshold = 0.5
        alarms = np.zeros((1, 100_000), dtype=bool)
        onsets: list[float] = []
        residual_labels = ["r[0]"]

    Res.alarms[0, 54_321] = True
    args = cli._residual_figure_args(Res, "t")
    assert args["t"].size < 5000
    assert args["alarms"].any() and args["alarms"].sum() < 10


def test_model_file_residual_dim_and_common_poles() -> None:
    from geomfdi.io.cli import design_all

    triplex = {"A": [[-1.0]], "B": [[1.0]], "C": [[1.0], [1.0], [1.0]]}
    spec = parse_model({"plant": triplex, "design": {"structure": [[1, 1, 1]], "residual_dim": 2}})
    (g,) = design_all(spec)["exact"].generators
    assert g.n_outputs == 2 and g.order == 0  # two independent static parity rows
    spec = parse_model(
        {"plant": triplex, "design": {"structure": [[1, 1, 1], [1, 1, 0]], "residual_dim": [3, 0]}}
    )
    bank = design_all(spec)["exact"]
    assert [x.n_outputs for x in bank.generators] == [3, 1]
    spec = parse_model(
        {"plant": triplex, "design": {"exact": {"common_poles": True}, "structure": [[1, 1, 1]]}}
    )
    assert "joint_order" in design_all(spec)["exact"].info
    for bad in (0, -1, 1.5, "2", True):
        with pytest.raises(GeomFDIError, match="residual_dim"):
            parse_model({"plant": triplex, "design": {"residual_dim": bad}})
    with pytest.raises(GeomFDIError, match="common_poles"):
        parse_model({"plant": triplex, "design": {"common_poles": 1}})
