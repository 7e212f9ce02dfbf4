"""The Examples blocks of the geometry and model modules run and give what they show."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = [
    "geomfdi.geometry.subspace",
    "geomfdi.geometry.conditioned_invariant",
    "geomfdi.geometry.unobservability",
    "geomfdi.geometry.exact",
    "geomfdi.model.plant",
]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    flags = doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS
    result = doctest.testmod(module, optionflags=flags, report=True, verbose=False)
    assert result.attempted > 0, f"{name} has no examples"
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed in {name}"
