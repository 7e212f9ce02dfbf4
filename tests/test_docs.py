"""The documentation: the site builds with warnings as errors, links stay inside the
repository, the guide's code runs, and every docstring example passes."""

from __future__ import annotations

import doctest
import importlib
import os
import pkgutil
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import geomfdi

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = sorted(DOCS.rglob("*.md"))
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)[^)]*\)|<(https?://[^>]+)>|(https?://\S+)")


def _links(path: Path) -> list[str]:
    text = path.read_text(encoding="utf-8")
    return [next(g for g in m.groups() if g) for m in LINK.finditer(text)]


@pytest.mark.slow
def test_site_builds_strict(tmp_path):
    mkdocs = pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocstrings")
    assert mkdocs
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1", "PYTHONPATH": str(ROOT)}
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env=env,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    # the API reference is rendered from the numpy-style docstrings
    html = (tmp_path / "reference" / "synthesis" / "index.html").read_text(encoding="utf-8")
    assert 'id="geomfdi.synthesis.design_bank"' in html
    assert "Parameters" in html


def test_nav_lists_every_page():
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    listed = set(re.findall(r"([\w/-]+\.md)", nav))
    on_disk = {p.relative_to(DOCS).as_posix() for p in PAGES}
    assert listed == on_disk


@pytest.mark.parametrize("path", [ROOT / "README.md", *PAGES], ids=lambda p: p.name)
def test_links_stay_inside_the_repository(path):
    for target in _links(path):
        assert not re.match(r"[a-z][a-z0-9+.-]*:", target, re.I), f"{path}: external {target}"
        file = target.split("#", 1)[0]
        if not file:
            continue
        resolved = (path.parent / file).resolve()
        assert resolved.is_relative_to(ROOT), f"{path}: {target} leaves the repository"
        assert resolved.exists(), f"{path}: {target} does not exist"


def test_link_checker_catches_external_and_escaping_links(tmp_path):
    page = tmp_path / "p.md"
    page.write_text("[a](https://example.org) [b](../../x.md) <http://x.y>", encoding="utf-8")
    assert _links(page) == ["https://example.org", "../../x.md", "http://x.y"]


def test_no_page_cites_internal_notes():
    for path in [ROOT / "README.md", *PAGES]:
        text = path.read_text(encoding="utf-8")
        assert "math.md" not in text and "shared/" not in text, path


GUIDE = [DOCS / "index.md", DOCS / "getting-started.md", *sorted((DOCS / "guide").glob("*.md"))]


def _page(path: Path) -> object:
    """A page as a test parameter: marked slow when its code starts a Dask cluster."""
    slow = "local_dask_client(" in path.read_text(encoding="utf-8")
    return pytest.param(path, marks=pytest.mark.slow) if slow else path


@pytest.mark.parametrize("path", [_page(p) for p in GUIDE], ids=lambda p: p.name)
def test_guide_code_runs(path, monkeypatch, capsys):
    """Every ``python`` block of a page runs, in order, in one namespace."""
    blocks = re.findall(r"```python\n(.*?)```", path.read_text(encoding="utf-8"), re.S)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    blas = geomfdi.get_blas_threads()
    namespace: dict = {"__name__": "__docs__"}
    try:
        for k, code in enumerate(blocks):
            exec(compile(code, f"{path.name}[{k}]", "exec"), namespace)
    finally:
        geomfdi.set_blas_threads(blas)


def _modules() -> list[str]:
    names = ["geomfdi"]
    for info in pkgutil.walk_packages(geomfdi.__path__, "geomfdi."):
        if not info.name.endswith("__main__"):  # running it is the command line
            names.append(info.name)
    return sorted(names)


@pytest.mark.parametrize("name", _modules())
def test_docstring_examples(name):
    """The ``>>>`` examples of every module of the package pass (doctest)."""
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    blas = geomfdi.get_blas_threads()
    try:
        for test in finder.find(module, name):
            runner.run(test)
    finally:
        geomfdi.set_blas_threads(blas)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{result.failed} doctest failure(s) in {name}"


def test_mkdocs_is_available_for_ci():
    """CI installs the test extra, which must bring the site builder."""
    assert shutil.which("mkdocs") or importlib.util.find_spec("mkdocs") is not None
