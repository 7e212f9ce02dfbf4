"""Public names renamed from internal labels to the papers' authors keep working, with a warning."""

from __future__ import annotations

import importlib

import pytest

from geomfdi._moved import RENAMED

CASES = [
    ("geomfdi.parity", "seed004_experiment"),
    ("geomfdi.parity", "Seed004Result"),
    ("geomfdi.parity", "plot_seed004"),
    ("geomfdi.parity.fdi", "seed004_experiment"),
    ("geomfdi.parity.results", "Seed004Result"),
    ("geomfdi.parity.dodecahedron_experiment", "SEED004_KINDS"),
    ("geomfdi.parity.dodecahedron_experiment", "SEED004_METHODS"),
    ("geomfdi.plotting.parity", "plot_seed004"),
]


@pytest.mark.parametrize(("module", "old"), CASES)
def test_old_name_is_the_new_object_with_a_warning(module: str, old: str) -> None:
    mod = importlib.import_module(module)
    with pytest.warns(DeprecationWarning, match=RENAMED[old]):
        obj = getattr(mod, old)
    assert obj is getattr(mod, RENAMED[old])
    assert old not in getattr(mod, "__all__", [])


def test_unknown_and_misplaced_names_still_raise() -> None:
    results = importlib.import_module("geomfdi.parity.results")
    with pytest.raises(AttributeError):
        results.plot_seed004  # noqa: B018  (renamed, but never lived in this module)
    with pytest.raises(AttributeError):
        results.no_such_name  # noqa: B018
