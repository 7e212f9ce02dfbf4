"""``geomfdi run``: what the main process loads, and the figure process (geomfdi.io.figures)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from geomfdi.io.figures import _Figures

ROOT = Path(__file__).resolve().parents[1]
SEED001 = ROOT / "examples" / "hou_wen_chen.toml"

DRIVER = """
import json, sys
from geomfdi.io.cli import main
rc = main(["run", sys.argv[1], "--out", sys.argv[2]] + sys.argv[3:])
heavy = ("scipy.signal", "scipy.stats", "matplotlib")
print(json.dumps({"rc": rc, "loaded": sorted(h for h in heavy if h in sys.modules)}))
"""


def _run_driver(out: Path, *extra: str) -> dict:
    env = {**os.environ, "MPLBACKEND": "Agg"}
    proc = subprocess.run(
        [sys.executable, "-c", DRIVER, str(SEED001), str(out), *extra],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
        cwd=ROOT,
    )
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_run_loads_neither_scipy_signal_nor_stats(tmp_path: Path) -> None:
    """The Hou-Wen-Chen example run (pole placement, simulation, exact proof) without scipy.signal
    (about 0.6 s to import) or scipy.stats; the figures are drawn in another process,
    so the main process does not load matplotlib either."""
    res = _run_driver(tmp_path / "plots")
    assert res == {"rc": 0, "loaded": []}
    assert len(list((tmp_path / "plots").glob("*.png"))) == 8
    res = _run_driver(tmp_path / "noplots", "--no-plots")
    assert res == {"rc": 0, "loaded": []}
    assert not list((tmp_path / "noplots").glob("*.png"))


def _name(text: str) -> str:
    return f"drawn {text}"


def _fail(text: str) -> str:
    raise ValueError(f"cannot draw {text}")


def test_figures_come_back_in_order() -> None:
    figs = _Figures(True)
    for k in range(6):
        figs.submit(k, _name, str(k))
    assert figs.jobs == list(range(6))
    assert figs.results() == {k: f"drawn {k}" for k in range(6)}
    assert figs.proc is None  # closed


def test_a_failing_figure_raises_in_the_main_process() -> None:
    figs = _Figures(True)
    figs.submit("a", _name, "a")
    figs.submit("b", _fail, "b")
    with pytest.raises(ValueError, match="cannot draw b"):
        figs.results()
    assert figs.proc is None


def test_figures_left_by_a_dead_process_are_drawn_here() -> None:
    figs = _Figures(True)
    figs.proc.terminate()
    figs.proc.join()
    for k in range(3):
        figs.submit(k, _name, str(k))
    assert figs.results() == {k: f"drawn {k}" for k in range(3)}


def test_disabled_and_early_close() -> None:
    off = _Figures(False)
    off.submit("x", _fail, "x")  # figures off: nothing is drawn
    assert off.results() == {}
    figs = _Figures(True)
    figs.submit("x", _name, "x")
    figs.close()  # an early end (an error in the run): the process is stopped
    assert figs.proc is None


def test_residual_figure_pixels_do_not_depend_on_the_png_level(tmp_path: Path) -> None:
    """The PNG level changes the file size only (lossless)."""
    from PIL import Image

    from geomfdi.io import figures

    t = np.linspace(0.0, 10.0, 5000)
    r = np.vstack([np.sin(t), np.cos(3 * t)])
    kwargs = {"t": t, "residuals": r, "threshold": 0.5, "onsets": [4.0], "title": "x"}
    fast = figures._draw_residuals(kwargs, tmp_path / "fast.png")
    old = figures.PNG_COMPRESS_LEVEL
    try:
        figures.PNG_COMPRESS_LEVEL = 6
        default = figures._draw_residuals(kwargs, tmp_path / "default.png")
    finally:
        figures.PNG_COMPRESS_LEVEL = old
    a = np.asarray(Image.open(tmp_path / fast))
    b = np.asarray(Image.open(tmp_path / default))
    assert a.shape == b.shape and np.array_equal(a, b)
