"""The bundled three-tank model: steady state and linearisation against the nonlinear model."""

from __future__ import annotations

import numpy as np
import pytest

from geomfdi.data.three_tank import (
    ThreeTankParameters,
    three_tank_model,
    three_tank_operating_point,
    three_tank_rhs,
)
from geomfdi.errors import GeomFDIError


@pytest.mark.parametrize("levels", [(0.5, 0.3, 0.4), (0.5, 0.2, 0.35)])
def test_operating_point_is_a_steady_state(levels):
    h, Q = three_tank_operating_point(levels)
    assert np.all(Q > 0)
    np.testing.assert_allclose(three_tank_rhs(h, Q), 0.0, atol=1e-15)
    assert h[0] > h[2] > h[1]


def test_linear_model_is_the_jacobian_of_the_nonlinear_one():
    p = ThreeTankParameters(az13=0.46, az32=0.45, az20=0.6)
    plant, faults = three_tank_model((0.5, 0.25, 0.42), p)
    h, Q = three_tank_operating_point((0.5, 0.25, 0.42), p)
    eps = 1e-7
    J = np.column_stack(
        [(three_tank_rhs(h + eps * e, Q, params=p) - three_tank_rhs(h - eps * e, Q, params=p))
         / (2 * eps) for e in np.eye(3)]
    )  # fmt: skip
    np.testing.assert_allclose(plant.A, J, rtol=1e-6)
    Ju = np.column_stack(
        [(three_tank_rhs(h, Q + 1e-9 * e, params=p) - three_tank_rhs(h, Q, params=p)) / 1e-9
         for e in np.eye(2)]
    )  # fmt: skip
    np.testing.assert_allclose(plant.B, Ju, rtol=1e-6)
    leak = (three_tank_rhs(h, Q, 1e-9, params=p) - three_tank_rhs(h, Q, params=p)) / 1e-9
    Bf, _ = faults[2].signatures(3, 3)
    np.testing.assert_allclose(Bf[:, 0], leak, rtol=1e-6)
    assert np.all(np.linalg.eigvals(plant.A).real < 0)


def test_levels_without_a_steady_state_are_refused():
    with pytest.raises(GeomFDIError, match="levels"):
        three_tank_operating_point((0.5, 0.4, 0.3))
    with pytest.raises(GeomFDIError, match="outside"):
        three_tank_operating_point((5.0, 0.3, 4.0))
