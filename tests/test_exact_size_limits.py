"""Parametric design refuses entries whose degree would make the exact elimination run
out of memory or time (``k**100000``), before any work, with a named error."""

from __future__ import annotations

import time

import pytest
import sympy as sp

import geomfdi as gf
from geomfdi.errors import ResourceLimitError
from geomfdi.geometry.parametric import MAX_EXACT_DEGREE, degree_bound

k, p = sp.symbols("k p")
B = sp.Matrix([[1, 0, 1], [0, 1, 1], [0, 1, 0]])
C = sp.Matrix([[0, 1, 0], [0, 0, 1], [1, 0, 2]])


def _A(entry: sp.Expr) -> sp.Matrix:
    return sp.Matrix([[1, 1, 1], [0, 1, 0], [entry, 0, 1]])


@pytest.mark.parametrize(
    "entry, bound",
    [
        (k, 1),
        (k**3 * p**2, 5),
        ((k + 1) ** 300, 300),
        (1 / (k**2 + p), 2),
        ((k**3 + 1) ** 11 / (k - 2), 34),
        (p**100000, 100000),
        (sp.Rational(3, 7), 0),
    ],
)
def test_degree_bound_is_read_without_expanding(entry: sp.Expr, bound: int) -> None:
    t0 = time.perf_counter()
    assert degree_bound(sp.sympify(entry)) == bound
    assert time.perf_counter() - t0 < 1.0
    # it bounds the true degree (numerator plus denominator) when that is cheap to get
    if bound <= 40:
        num, den = sp.fraction(sp.cancel(sp.sympify(entry)))
        syms = sorted(entry.free_symbols, key=str) if entry.free_symbols else [k]
        true = sp.Poly(num, *syms).total_degree() + sp.Poly(den, *syms).total_degree()
        assert true <= bound


@pytest.mark.parametrize("entry", [p**100000, (p + 1) ** 300, (k**3 + 1) ** 11 / (k - 2)])
def test_parametric_plant_of_huge_degree_is_refused_before_work(entry: sp.Expr) -> None:
    t0 = time.perf_counter()
    with pytest.raises(ResourceLimitError) as err:
        gf.design_sensor_bank(gf.Plant(_A(entry), B, C), exact=True)
    assert err.value.argument == "A" and err.value.limit == "max_exact_degree"
    assert str(MAX_EXACT_DEGREE) in str(err.value)
    assert time.perf_counter() - t0 < 10.0


def test_exact_poles_of_huge_degree_are_refused() -> None:
    plant = gf.Plant(_A(k), B, C)
    with pytest.raises(ResourceLimitError) as err:
        gf.design_sensor_bank(plant, exact=True, poles=[-(k**2) - 1 - p**100000])
    assert err.value.argument == "poles"


def test_moderate_degree_is_designed() -> None:
    bank = gf.design_sensor_bank(gf.Plant(_A(k**2), B, C), exact=True)
    assert all(g is not None for g in bank.generators)
