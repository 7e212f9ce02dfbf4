"""Fuzz table, part two: the deployed monitor, generated code and the entry points the
first table did not reach (``fuzz_online_table.py``), with the bad values and the
classifier of ``fuzz_table.py``: every outcome is a named error or a correct result."""

from __future__ import annotations

import pytest
from fuzz_online_table import ENTRIES_ONLINE
from fuzz_table import Entry, bad_value_failures, base_call_holds, cases

CASES = cases(ENTRIES_ONLINE)


@pytest.mark.parametrize("entry, arg", CASES)
def test_bad_values_give_named_error_or_correct_result(entry: Entry, arg: str):
    failures = bad_value_failures(entry, arg)
    assert failures == []


@pytest.mark.parametrize("entry", ENTRIES_ONLINE, ids=[e.name for e in ENTRIES_ONLINE])
def test_base_call_is_valid(entry: Entry):
    assert base_call_holds(entry)


def test_table_covers_the_online_surface():
    names = {e.name for e in ENTRIES_ONLINE}
    assert {"Monitor", "Monitor.step", "Monitor.feed", "Monitor.state", "codegen.c",
            "codegen.python", "evaluate"} <= names  # fmt: skip
    assert len(CASES) >= 80
