"""Architecture: cheap ``import geomfdi``, lazy heavy libraries, no import cycle between
geomfdi's modules, no oversized module, every public name importable."""

from __future__ import annotations

import ast
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

import geomfdi

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "geomfdi"
MAX_LINES = 800
HEAVY = ("sympy", "scipy.signal", "scipy.stats", "matplotlib", "control", "pandas")


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


MODULES = {_module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _python(code: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120
    )


def _loaded_after(statement: str) -> set[str]:
    code = f"import sys, json\n{statement}\nprint(json.dumps(sorted(sys.modules)))"
    proc = _python(code)
    assert proc.returncode == 0, proc.stderr
    return set(json.loads(proc.stdout.splitlines()[-1]))


def _heavy(loaded: set[str]) -> list[str]:
    return sorted(h for h in HEAVY if h in loaded)


def test_import_geomfdi_loads_no_heavy_library():
    assert _heavy(_loaded_after("import geomfdi")) == []


def test_design_entry_points_load_no_sympy_matplotlib_or_control():
    loaded = _loaded_after("import geomfdi as gf\ngf.design_bank\ngf.design_sensor_bank")
    assert not {"sympy", "matplotlib", "control"} & {h for h in HEAVY if h in loaded}


def test_import_time_against_numpy():
    """``python -c "import geomfdi"`` within 0.6 s, or at most twice numpy's import on a
    busy machine (best of five, interleaved in the same run)."""

    def best(statement: str) -> float:
        t0 = time.perf_counter()
        proc = _python(statement)
        assert proc.returncode == 0, proc.stderr
        return time.perf_counter() - t0

    gf_times, np_times = [], []
    for _ in range(5):
        np_times.append(best("import numpy"))
        gf_times.append(best("import geomfdi"))
    t_gf, t_np = min(gf_times), min(np_times)
    print(f"import geomfdi {t_gf:.3f} s, import numpy {t_np:.3f} s, ratio {t_gf / t_np:.2f}")
    assert t_gf < 0.6 or t_gf < 2.0 * t_np, (t_gf, t_np)


# ------------------------------------------------------------------ import graph


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _resolve(name: str) -> str | None:
    """The geomfdi module ``name`` refers to (a module, or the package holding a name)."""
    while name:
        if name in MODULES:
            return name
        name = name.rpartition(".")[0]
    return None


def _imports(module: str, path: Path) -> set[str]:
    """geomfdi modules imported by ``module`` at module or function level (not in
    ``if TYPE_CHECKING:`` blocks)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    is_pkg = path.name == "__init__.py"
    out: set[str] = set()

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and _is_type_checking(node):
            for child in node.orelse:
                visit(child)
            return
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "geomfdi":
                    out.add(_resolve(alias.name) or alias.name)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = module if is_pkg else module.rpartition(".")[0]
                for _ in range(node.level - 1):
                    base = base.rpartition(".")[0]
                src = f"{base}.{node.module}" if node.module else base
            else:
                src = node.module or ""
            if src.split(".")[0] == "geomfdi":
                for alias in node.names:
                    target = _resolve(f"{src}.{alias.name}")
                    out.add(target if target and target != _resolve(src) else _resolve(src))
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    out.discard(None)  # type: ignore[arg-type]
    out.discard(module)
    return out


def _graph() -> dict[str, set[str]]:
    return {m: _imports(m, p) for m, p in MODULES.items()}


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[list[str]] = []
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10_000))

    def strong(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in graph:
        if v not in index:
            strong(v)
    return found


def test_cycle_finder_finds_a_planted_cycle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _cycles(graph) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


def test_import_walker_sees_function_level_imports(tmp_path):
    src = tmp_path / "mod.py"
    src.write_text(
        "from typing import TYPE_CHECKING\n"
        "from geomfdi.errors import GeomFDIError\n"
        "if TYPE_CHECKING:\n    from geomfdi.model.plant import Plant\n"
        "def f():\n    from geomfdi.synthesis import design\n    import geomfdi.tolerance\n",
        encoding="utf-8",
    )
    got = _imports("geomfdi.fake", src)
    assert got == {"geomfdi.errors", "geomfdi.synthesis.design", "geomfdi.tolerance"}


def test_no_import_cycle_between_modules():
    graph = _graph()
    assert len(graph) > 30 and any(graph.values())
    assert _cycles(graph) == []


# ------------------------------------------------------------------ sizes and names


@pytest.mark.parametrize("module", sorted(MODULES), ids=str)
def test_module_size(module):
    """No module over ~800 lines: one concept per module."""
    lines = len(MODULES[module].read_text(encoding="utf-8").splitlines())
    assert lines <= MAX_LINES, f"{module}: {lines} lines (at most {MAX_LINES})"


def test_every_public_name_is_importable():
    for name in geomfdi.__all__:
        assert getattr(geomfdi, name) is not None, name


def test_public_names_are_in_the_type_checking_block():
    tree = ast.parse((PACKAGE / "__init__.py").read_text(encoding="utf-8"))
    block = next(n for n in tree.body if isinstance(n, ast.If) and _is_type_checking(n))
    seen = {
        a.asname or a.name
        for n in ast.walk(block)
        if isinstance(n, ast.ImportFrom)
        for a in n.names
    }
    missing = sorted(set(geomfdi._NAMES) - seen)
    assert missing == []
