"""No process started by ``geomfdi`` outlives the command: figure processes end with the
run, also when a figure fails or the main process is killed; names with mathtext markup
are drawn as plain text (geomfdi.io.figures, geomfdi.plotting._text)."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest

ROOT = Path(__file__).resolve().parents[1]

# the model of Hou, Wen & Chen (2011), section 4, its names made mathtext markup
MODEL = re.sub(
    r'^name = ".*"$',
    'name = "$x^{$"',
    (ROOT / "examples" / "hou_wen_chen.toml").read_text(encoding="utf-8"),
    flags=re.MULTILINE,
)

# the residual figure fails in the figure process (the warm-up figure is drawn)
FAILING = """
import sys
import geomfdi.plotting.residuals as pr
original = pr.plot_residuals
def failing(*args, **kwargs):
    if kwargs.get("title") != "warm-up":
        raise RuntimeError("figure failed")
    return original(*args, **kwargs)
pr.plot_residuals = failing
from geomfdi.io.cli import main
sys.exit(main(sys.argv[1:]))
"""


def _left_over(marker: str) -> list[psutil.Process]:
    """Processes (other than this one) whose command line names ``marker``."""
    found = []
    for p in psutil.process_iter(["pid", "cmdline"]):
        try:
            if p.pid != os.getpid() and marker in " ".join(p.info["cmdline"] or []):
                found.append(p)
        except (psutil.NoSuchProcess, psutil.AccessDenied):
            continue
    return found


def _assert_none_left(marker: str, within: float = 3.0) -> None:
    deadline = time.monotonic() + within
    while _left_over(marker) and time.monotonic() < deadline:
        time.sleep(0.1)
    left = _left_over(marker)
    for p in left:  # (clean up before failing)
        p.kill()
    assert not left, f"processes left behind: {[p.pid for p in left]}"


def _model(tmp_path: Path) -> Path:
    path = tmp_path / "markup.toml"
    path.write_text(MODEL, encoding="utf-8")
    return path


def _env() -> dict[str, str]:
    return {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": str(ROOT)}


@pytest.mark.slow
def test_mathtext_names_are_drawn_and_no_process_is_left(tmp_path: Path) -> None:
    """``name = "$x^{$"`` ran into "internal error" and left the figure process behind
    holding the captured stdout/stderr (the caller hung)."""
    model = _model(tmp_path)
    out = tmp_path / "out"
    proc = subprocess.run(
        [sys.executable, "-m", "geomfdi", "run", str(model), "--out", str(out), "--no-symbolic"],
        capture_output=True,
        text=True,
        env=_env(),
        timeout=120,
        cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stderr
    assert len(list(out.glob("*.png"))) == 8
    _assert_none_left(str(model))


@pytest.mark.slow
def test_a_failing_figure_leaves_no_process(tmp_path: Path) -> None:
    model = _model(tmp_path)
    proc = subprocess.run(
        [sys.executable, "-c", FAILING, "run", str(model), "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
        env=_env(),
        timeout=120,
        cwd=tmp_path,
    )
    assert proc.returncode == 1
    assert "figure failed" in proc.stderr
    _assert_none_left(str(model))


@pytest.mark.skipif(not hasattr(os, "fork"), reason="the figure process forks")
def test_figure_processes_end_when_the_command_is_killed(tmp_path: Path) -> None:
    """The main process killed (SIGKILL: no clean-up of its own) while the figure
    process and its copy wait for jobs: both stop by themselves."""
    from geomfdi.io.figures import POLL_SECONDS

    script = (
        "import sys, time\n"
        "from geomfdi.io.figures import _Figures\n"
        "figs = _Figures(True)\n"
        "figs.help.set()\n"  # the copy is forked at the first job
        "figs.submit('a', str, 'a')\n"
        "print('started', flush=True)\n"
        "time.sleep(60)\n"
    )
    marker = str(tmp_path / "marker")
    proc = subprocess.Popen(
        [sys.executable, "-c", script, marker], stdout=subprocess.PIPE, text=True, env=_env()
    )
    try:
        assert proc.stdout.readline().strip() == "started"
        deadline = time.monotonic() + 30
        while len(_left_over(marker)) < 3 and time.monotonic() < deadline:
            time.sleep(0.1)
        assert len(_left_over(marker)) == 3  # main, figure process, its copy
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
        _assert_none_left(marker, within=4 * POLL_SECONDS + 2)
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.stdout.close()


def test_plain_text_labels() -> None:
    from matplotlib.figure import Figure

    from geomfdi.plotting._text import plain

    fig = Figure()
    ax = fig.subplots()
    ax.set_title(plain("$x^{$"))
    fig.canvas.draw()  # an unbalanced $ raised a mathtext ParseException
    assert ax.get_title() == r"\$x^{\$"
