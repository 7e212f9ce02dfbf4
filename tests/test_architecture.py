"""Architecture: cheap ``import geomfdi``, lazy heavy libraries, the layers, no import cycle
between geomfdi's modules (inside subpackages too), no oversized module, no docstring or
comment naming a file outside the repository, old module paths and every public name
importable."""

from __future__ import annotations

import ast
import io
import json
import os
import re
import subprocess
import sys
import time
import tokenize
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
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 10_000))  # restored below: other tests see the default

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

    try:
        for v in graph:
            if v not in index:
                strong(v)
    finally:
        sys.setrecursionlimit(limit)
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


def test_no_import_cycle_inside_any_subpackage():
    """The same graph restricted to each subpackage (a cycle there is one of the whole
    graph too; this names the subpackage when it fails)."""
    graph = _graph()
    packages = {m for m, p in MODULES.items() if p.name == "__init__.py"}
    assert {"geomfdi.generators", "geomfdi.synthesis.least_order"} <= packages
    for pkg in sorted(packages):
        inside = {m for m in graph if m.startswith(pkg + ".")}
        sub = {m: graph[m] & inside for m in inside}
        assert _cycles(sub) == [], pkg


def _type_imports(path: Path) -> set[str]:
    """geomfdi modules imported inside ``if TYPE_CHECKING:`` blocks of ``path``."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and _is_type_checking(node):
            for child in node.body:
                if isinstance(child, ast.ImportFrom) and (child.module or "").startswith("geomfdi"):
                    for alias in child.names:
                        out.add(_resolve(f"{child.module}.{alias.name}") or child.module)
    out.discard(None)  # type: ignore[arg-type]
    return out


def test_no_import_cycle_even_through_annotations():
    """Objects call plain functions and pass them arrays or small records; no function
    module imports the object module back, not even inside ``if TYPE_CHECKING:``."""
    graph = _graph()
    for m, p in MODULES.items():
        if m != "geomfdi":  # the package's TYPE_CHECKING block re-exports every name
            graph[m] = graph[m] | (_type_imports(p) - {m})
    assert _cycles(graph) == []


# ------------------------------------------------------------------ layers

LOWER_THAN_SYNTHESIS = (
    "geomfdi.model",
    "geomfdi.geometry",
    "geomfdi.generators",
)
CONSUMERS = (
    "geomfdi.verification",
    "geomfdi.simulation",
    "geomfdi.evaluation",
    "geomfdi.deployment",
    "geomfdi.campaign",
)


def _in(module: str, packages: tuple[str, ...]) -> bool:
    return any(module == p or module.startswith(p + ".") for p in packages)


def test_layers():
    """model, geometry and generators never import synthesis (not even for annotations);
    verification, simulation, evaluation, deployment and campaigns take the generator
    types from geomfdi.generators, never from the design code."""
    bad = []
    for m, p in MODULES.items():
        deps = _imports(m, p) | _type_imports(p)
        if _in(m, LOWER_THAN_SYNTHESIS):
            bad += [(m, d) for d in deps if _in(d, ("geomfdi.synthesis",))]
        if _in(m, CONSUMERS):
            bad += [(m, d) for d in deps if _in(d, ("geomfdi.synthesis",))]
    assert bad == []


def test_compiled_recursion_never_imports_deployment():
    """The simulator's compiled recursion and the compiled monitor share the build and
    cache helpers of ``geomfdi._cbuild``, a module below both (it imports only
    ``geomfdi.errors``); the compiled recursion never loads the deployment code."""
    graph = _graph()
    seen, todo = set(), ["geomfdi.simulation.compiled_recursion"]
    while todo:  # everything it imports, at module level or lazily
        m = todo.pop()
        if m not in seen and m != "geomfdi":
            seen.add(m)
            todo += sorted(graph.get(m, ()))
    assert not any(_in(m, ("geomfdi.deployment",)) for m in seen), sorted(seen)
    assert graph["geomfdi._cbuild"] == {"geomfdi.errors"}
    assert "geomfdi._cbuild" in graph["geomfdi.deployment.compiled"]


def test_generators_never_import_synthesis_even_lazily():
    for m, p in MODULES.items():
        if _in(m, ("geomfdi.generators",)):
            assert not any(_in(d, ("geomfdi.synthesis",)) for d in _imports(m, p)), m


def test_synthesis_never_imports_verification_even_lazily():
    """The design code measures its designs with :mod:`geomfdi.generators.norms`; the
    verification, which checks the designs, is above it."""
    bad = [
        (m, d)
        for m, p in MODULES.items()
        if _in(m, ("geomfdi.synthesis",))
        for d in _imports(m, p) | _type_imports(p)
        if _in(d, ("geomfdi.verification",))
    ]
    assert bad == []


def test_every_subpackage_says_what_it_holds_and_may_import():
    for m, p in MODULES.items():
        if p.name == "__init__.py" and m != "geomfdi":
            doc = ast.get_docstring(ast.parse(p.read_text(encoding="utf-8"))) or ""
            assert len(doc) > 80 and "import" in doc, m


# ------------------------------------------------------------------ citations

# a file outside the repository: internal notes, a parent directory, a sibling checkout;
# papers are cited by author and year, not by internal seed numbers
OUTSIDE = re.compile(
    r"math\.md|reference\.md|style\.md|\bshared/|\.\./|/work/|\b[Ss]eeds? 0\d\d\b|\b[Ss]eed-0\d\d\b"
)
SCANNED = ("geomfdi", "tests", "benchmarks", "examples")


def _docs_and_comments(path: Path) -> list[tuple[int, str]]:
    """(line, text) of every comment and docstring of a Python file."""
    text = path.read_text(encoding="utf-8")
    out = [
        (tok.start[0], tok.string)
        for tok in tokenize.generate_tokens(io.StringIO(text).readline)
        if tok.type == tokenize.COMMENT
    ]
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                if isinstance(body[0].value.value, str):
                    out.append((body[0].lineno, body[0].value.value))
    return out


def _outside_citations(path: Path) -> list[str]:
    return [
        f"{path.name}:{line}: {m.group(0)}"
        for line, text in _docs_and_comments(path)
        for m in OUTSIDE.finditer(text)
    ]


def test_citation_checker_finds_planted_citations(tmp_path):
    src = tmp_path / "mod.py"
    src.write_text(
        '"""See math.md §3."""\n'
        "def f():\n    '''As in seed 001, eq. 3.'''\n    return 1  # ../shared/notes\n"
        'x = "seed 001"  # Hou, Wen & Chen 2011; examples/hou_wen_chen.toml\n',
        encoding="utf-8",
    )
    assert [h.split(": ")[1] for h in _outside_citations(src)] == [
        "../",
        "shared/",
        "math.md",
        "seed 001",
    ]


@pytest.mark.parametrize("folder", SCANNED)
def test_no_docstring_or_comment_names_a_file_outside_the_repository(folder):
    hits = [h for p in sorted((ROOT / folder).rglob("*.py")) for h in _outside_citations(p)]
    assert hits == []


# ------------------------------------------------------------------ old paths, public names


def test_old_module_paths_import_with_a_deprecation_warning():
    """Every moved module still imports from its old path, warns, and is the new module."""
    from geomfdi._moved import MOVED

    code = (
        "import importlib, json, warnings\n"
        "import geomfdi\n"
        "from geomfdi._moved import MOVED\n"
        "out = {}\n"
        "for old, new in MOVED.items():\n"
        "    with warnings.catch_warnings(record=True) as w:\n"
        "        warnings.simplefilter('always')\n"
        "        mod = importlib.import_module(old)\n"
        "    out[old] = [mod is importlib.import_module(new),\n"
        "                [str(x.message) for x in w if x.category is DeprecationWarning]]\n"
        "with warnings.catch_warnings(record=True) as w:\n"
        "    warnings.simplefilter('always')\n"
        "    from geomfdi.synthesis.least_order import least_order_row\n"
        "from geomfdi.synthesis.least_order.search import least_order_row as new\n"
        "out['least_order_row'] = [least_order_row is new, [str(x.message) for x in w]]\n"
        "print(json.dumps(out))\n"
    )
    proc = _python(code)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.splitlines()[-1])
    assert set(out) == {*MOVED, "least_order_row"}
    for old, (same, messages) in out.items():
        assert same, old
        new = MOVED.get(old, "geomfdi.synthesis.least_order.search")
        assert any(new in msg for msg in messages), (old, messages)


def test_every_public_name_imports_in_a_fresh_interpreter_without_deprecation():
    code = (
        "import json, warnings\n"
        "warnings.simplefilter('always')\n"
        "with warnings.catch_warnings(record=True) as w:\n"
        "    warnings.simplefilter('always')\n"
        "    import geomfdi\n"
        "    missing = [n for n in geomfdi.__all__ if getattr(geomfdi, n, None) is None]\n"
        "ours = [str(x.message) for x in w if x.category is DeprecationWarning\n"
        "        and 'geomfdi' in str(x.message)]\n"
        "print(json.dumps([len(geomfdi.__all__), missing, ours]))\n"
    )
    proc = _python(code)
    assert proc.returncode == 0, proc.stderr
    count, missing, ours = json.loads(proc.stdout.splitlines()[-1])
    assert count > 100 and missing == [] and ours == []


def test_type_import_walker_sees_type_checking_imports(tmp_path):
    src = tmp_path / "mod.py"
    src.write_text(
        "from typing import TYPE_CHECKING\n"
        "from geomfdi.errors import GeomFDIError\n"
        "if TYPE_CHECKING:\n    from geomfdi.parity.model import ParityFDI\n",
        encoding="utf-8",
    )
    assert _type_imports(src) == {"geomfdi.parity.model"}
    graph = {"a": {"b"}, "b": set()}
    graph["b"] |= {"a"}  # an annotation import back makes the cycle
    assert _cycles(graph) == [["a", "b"]]
