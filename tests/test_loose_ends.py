"""Loose ends a new user meets first: imports, messages, CLI details (one test each)."""

from __future__ import annotations

import importlib
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import geomfdi
import geomfdi as gf
from geomfdi.errors import GeomFDIError, NotIsolableError

ROOT = Path(__file__).resolve().parents[1]

# One fresh interpreter imports the third-party stack and the package's root only; each
# defining module's first public name is then resolved in a forked child of it, so every
# module meets an empty geomfdi module cache (no import order can hide a cycle) without
# starting a hundred interpreters.
_FRESH = """
import os, sys
import numpy, scipy.linalg, scipy.signal, scipy.stats, sympy, control, matplotlib.pyplot
import geomfdi
loaded = [m for m in sys.modules if m.startswith("geomfdi.") and not m.startswith("geomfdi._")]
assert not loaded, f"the root imports {loaded}"
bad = []
for name in sys.argv[1:]:
    pid = os.fork()
    if pid == 0:
        try:
            getattr(geomfdi, name)
        except BaseException as exc:  # report and leave the child at once
            sys.stderr.write(f"{name}: {type(exc).__name__}: {exc}\\n")
            os._exit(1)
        os._exit(0)
    _, status = os.waitpid(pid, 0)
    if status:
        bad.append(name)
print(",".join(bad))
"""


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs os.fork")
def test_every_public_name_imports_in_a_fresh_interpreter():
    first: dict[str, str] = {}
    for name, module in sorted(geomfdi._NAMES.items()):
        first.setdefault(module, name)
    names = sorted(first.values())
    assert "plot_isolability" in names and len(first) > 40
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    out = subprocess.run(
        [sys.executable, "-c", _FRESH, *names],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
        check=True,
    )
    assert out.stdout.strip() == "", out.stderr


def _dup_plant():
    A = -np.diag([1.0, 2.0, 3.0])
    faults = [
        *(gf.SensorFault(i) for i in range(3)),
        gf.ActuatorFault([1.0, 0.0, 0.0]),
        gf.ActuatorFault([0.0, 1.0, 0.0]),
        gf.ActuatorFault([0.0, 1.0, 0.0], name="duplicate"),
    ]
    return gf.Plant(A, np.eye(3), np.eye(3)), faults


def test_not_isolable_message_names_fault_numbers_not_target_positions():
    plant, faults = _dup_plant()
    with pytest.raises(NotIsolableError) as info:
        gf.design_residual_generator(plant, faults, target=[0, 5], decouple=[4])
    msg = str(info.value)
    assert "faults [5] are not isolable from faults [4]" in msg
    assert "[1]" not in msg  # 5 is the target at position 1


def test_least_order_certificate_names_fault_numbers():
    plant, faults = _dup_plant()
    g = gf.design_residual_generator(plant, faults, target=[5], decouple=[0, 3])
    cert = g.info["least_order"]
    assert cert["order"] == 1 and cert["unseen_below"] == {0: [5]}
    assert "does not see faults [5]" in cert["statement"]


DOTTED = re.compile(r"`(geomfdi(?:\.[A-Za-z_]\w*)+)")


def _resolve(name: str) -> bool:
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        try:
            for attr in parts[i:]:
                obj = getattr(obj, attr)
        except AttributeError:
            return False
        return True
    return False


def test_dotted_names_in_the_docs_exist():
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    names = {(p.name, m) for p in pages for m in DOTTED.findall(p.read_text(encoding="utf-8"))}
    assert len(names) > 20
    assert ("cli-and-model-files.md", "geomfdi.io.modelfile.load_model") in names
    assert [n for n in sorted(names) if not _resolve(n[1])] == []
    assert not _resolve("geomfdi.io.load_model")


def test_verification_page_defines_the_plant_before_its_matrices():
    text = (ROOT / "docs" / "theory" / "verification.md").read_text(encoding="utf-8")
    first_use = min(text.index(s) for s in ("[[A, 0]", "−E C", "B; G"))
    assert text.index("x' = A x + B u") < first_use
    assert text.index("y = C x + D u") < first_use


@pytest.mark.parametrize("script", sorted((ROOT / "examples").glob("*.py")), ids=lambda p: p.name)
def test_example_help_prints_usage_and_writes_nothing(script, tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    proc = subprocess.run(
        [sys.executable, str(script), "--help"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.startswith("usage:")
    assert list(tmp_path.iterdir()) == []


def test_wilson_bounds_are_exact_at_the_ends():
    n = np.array([7, 50, 1000, 1000])
    k = np.array([0, 50, 0, 300])
    lo, hi = gf.wilson_interval(k, n)
    assert lo[0] == 0.0 and lo[2] == 0.0 and hi[1] == 1.0  # not 3.5e-18
    assert np.all((lo <= k / n) & (k / n <= hi))
    assert 0.0 < hi[0] < 1.0 and 0.0 < lo[1] < 1.0 and 0.0 < lo[3] < 0.3 < hi[3] < 1.0
    lo0, hi0 = gf.wilson_interval(0, 1000)
    assert isinstance(lo0, float) and f"{lo0:.3g}" == "0" and hi0 > 0


def test_messages_quote_numbers_as_the_user_typed_them():
    with pytest.raises(GeomFDIError) as info:
        gf.Plant([[-1.0]], [[1.0]], [[1.0]], dt=np.float64(-0.1))
    assert "got -0.1" in str(info.value) and "np." not in str(info.value)
    from geomfdi.errors import plain_numbers

    got = plain_numbers(str([np.float64(1.5), np.int64(-3), np.True_, np.complex128(1j)]))
    assert got == "[1.5, -3, True, 1j]"
    assert plain_numbers("np.linalg.norm(x) = 2") == "np.linalg.norm(x) = 2"
