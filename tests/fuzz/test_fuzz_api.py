"""Fuzz table: every public entry point × every bad value.

Each case replaces one argument of a valid call by one value of :data:`BAD_VALUES`
and classifies the outcome:

``named``
    a :class:`~geomfdi.errors.GeomFDIError` whose ``.argument`` (or message) names the
    replaced argument;
``correct``
    a result that passes the entry point's own check (finite numbers, right shapes);
anything else
    a raw Python or numpy exception, a result with non-finite numbers, a numpy
    ``RuntimeWarning`` or a call that takes more than :data:`TIMEOUT` seconds.

Only the first two are accepted.  The values stand for what a hostile or careless user
passes: ``nan``/``inf``, complex numbers, text, ``None``, negative and zero counts,
Python integers beyond float64 (``10**400``), booleans, fractional counts, empty and
ragged lists, nested lists of the wrong depth, numpy object arrays, and counts that are
valid integers but would need terabytes.
"""

from __future__ import annotations

import warnings

import pytest
from fuzz_table import BAD_VALUES, ENTRIES, Entry, outcome

CASES = [
    pytest.param(entry, arg, id=f"{entry.name}-{arg}") for entry in ENTRIES for arg in entry.args
]


@pytest.mark.parametrize("entry, arg", CASES)
def test_bad_values_give_named_error_or_correct_result(entry: Entry, arg: str):
    """Every value of :data:`BAD_VALUES` in place of ``arg`` (one test per argument, so
    the table of 4 000+ calls costs no per-test overhead); the failure lists them all."""
    failures = []
    for value_name, value in BAD_VALUES.items():
        kind, detail = outcome(entry, arg, value)
        if kind not in ("named", "correct"):
            failures.append(f"{value_name}: {kind}: {detail}")
    assert failures == []


@pytest.mark.parametrize("entry", ENTRIES, ids=[e.name for e in ENTRIES])
def test_base_call_is_valid(entry: Entry):
    """The unmodified call succeeds, so every failure above is due to the bad value."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert entry.check(entry.call(**entry.base))


def test_table_covers_every_entry_point_and_value():
    assert len(ENTRIES) >= 75 and len(BAD_VALUES) >= 19
    assert len(CASES) == sum(len(e.args) for e in ENTRIES) >= 200
