"""Options of the exact design are data, never code (poles and filter parameter as strings)."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import geomfdi as gf
from geomfdi.errors import DesignError, GeomFDIError


def _plant(dt: float = 0.0) -> gf.Plant:
    A = np.array([[-1.0, 1.0, 0.0], [0.0, -2.0, 1.0], [0.0, 0.0, -3.0]])
    if dt:
        A = np.eye(3) * 0.5 + 0.1 * np.triu(np.ones((3, 3)), 1)
    B = np.array([[0.0], [0.0], [1.0]])
    C = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    return gf.Plant(A, B, C, dt=dt)


@pytest.mark.parametrize(
    "payload",
    [
        "__import__('os').system('touch {marker}') or 1",
        "(lambda: __import__('os').system('touch {marker}'))() or 1",
        "exec(\"open('{marker}', 'w')\") or 1",
    ],
)
@pytest.mark.parametrize("option", ["filter_pole", "poles"])
def test_strings_are_never_executed(tmp_path, payload, option):
    marker = tmp_path / "pwned"
    text = payload.format(marker=marker)
    kwargs = {option: text} if option == "filter_pole" else {option: [text, -2, -3]}
    with pytest.raises(GeomFDIError) as err:
        gf.design_sensor_bank(_plant(), exact=True, **kwargs)
    assert not marker.exists()
    assert err.value.argument in ("filter_pole", "poles")
    assert "never evaluated" in str(err.value)


def test_plain_number_strings_are_exact_numbers():
    ref = gf.design_sensor_bank(_plant(), exact=True, filter_pole=sp.Rational(1, 2))
    got = gf.design_sensor_bank(_plant(), exact=True, filter_pole="1/2")
    assert [sp.Matrix(g.F) for g in got.generators] == [sp.Matrix(g.F) for g in ref.generators]
    other = gf.design_sensor_bank(_plant(), exact=True, filter_pole=2)
    assert [sp.Matrix(g.F) for g in other.generators] != [sp.Matrix(g.F) for g in ref.generators]


@pytest.mark.parametrize("bad", [-1, 0, "-1", sp.Integer(-2)])
def test_unstable_filter_pole_is_refused(bad):
    with pytest.raises(DesignError, match="filter_pole"):
        gf.design_sensor_bank(_plant(), exact=True, filter_pole=bad)


def test_discrete_filter_pole_must_be_inside_unit_interval():
    with pytest.raises(DesignError, match="0 < filter_pole < 1"):
        gf.design_sensor_bank(_plant(0.1), exact=True, filter_pole=1.5)


@pytest.mark.parametrize("bad", [[1.0, -1, -2], [0.0, -1, -2], [sp.Integer(2), -1, -2]])
def test_unstable_exact_poles_are_refused(bad):
    with pytest.raises(DesignError, match="left half-plane"):
        gf.design_residual_generator(
            _plant(), [gf.SensorFault(i) for i in range(3)], 0, exact=True, poles=bad
        )


def test_per_row_pole_error_names_the_row():
    with pytest.raises(DesignError, match=r"row 1"):
        gf.design_sensor_bank(_plant(), exact=True, poles=[[-1, -2, -3], [-1, 3, -2], [-1, -2, -3]])


def test_symbolic_poles_still_accepted():
    p = sp.Symbol("p", positive=True)
    g = gf.design_residual_generator(
        _plant(), [gf.SensorFault(i) for i in range(3)], 0, exact=True, poles=[-p, -2 * p, "-3"]
    )
    assert p in sp.Matrix(g.F).free_symbols


def test_parameter_values_given_as_strings_are_not_executed(tmp_path):
    m = sp.Symbol("m", positive=True)
    A = sp.Matrix([[-m, 1, 0], [0, -2, 1], [0, 0, -3]])
    plant = gf.Plant(A, np.array([[0.0], [0.0], [1.0]]), np.eye(3))
    g = gf.design_residual_generator(plant, [gf.SensorFault(i) for i in range(3)], 0, exact=True)
    marker = tmp_path / "pwned"
    with pytest.raises(GeomFDIError):
        g.subs({m: f"__import__('os').system('touch {marker}') or 1"})
    assert not marker.exists()
    np.testing.assert_allclose(
        np.asarray(g.subs({m: "3/2"}).F, dtype=float), np.asarray(g.subs({m: 1.5}).F, dtype=float)
    )
