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

import pytest
from fuzz_table import BAD_VALUES, ENTRIES, Entry, bad_value_failures, base_call_holds, cases

CASES = cases(ENTRIES)


@pytest.mark.parametrize("entry, arg", CASES)
def test_bad_values_give_named_error_or_correct_result(entry: Entry, arg: str):
    """Every value of :data:`BAD_VALUES` in place of ``arg`` (one test per argument, so
    the table of 4 000+ calls costs no per-test overhead); the failure lists them all."""
    failures = bad_value_failures(entry, arg)
    assert failures == []


@pytest.mark.parametrize("entry", ENTRIES, ids=[e.name for e in ENTRIES])
def test_base_call_is_valid(entry: Entry):
    """The unmodified call succeeds, so every failure above is due to the bad value."""
    assert base_call_holds(entry)


def test_table_covers_every_entry_point_and_value():
    assert len(ENTRIES) >= 75 and len(BAD_VALUES) >= 19
    assert len(CASES) == sum(len(e.args) for e in ENTRIES) >= 200
