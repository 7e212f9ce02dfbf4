"""The mass-spring chain test plant: its physics, its names and its argument checks."""

from __future__ import annotations

import numpy as np
import pytest

import geomfdi as gf


def test_chain_is_the_spring_mass_model_it_describes() -> None:
    N = 7
    p = gf.mass_spring_chain(N, sensors=[0, 6], forces=(2, 6), zeta=0.05)
    assert (p.n, p.q, p.m) == (2 * N, 2, 2)
    # positions integrate velocities; the stiffness is symmetric positive definite
    assert np.array_equal(p.A[:N, N:], np.eye(N)) and not p.A[:N, :N].any()
    K = -p.A[N:, :N]
    assert np.allclose(K, K.T) and np.all(np.linalg.eigvalsh(K) > 0)
    # undamped natural frequencies of a fixed-free chain: 2 sin((2k - 1) pi / (2 (2N + 1)))
    w = np.sqrt(np.sort(np.linalg.eigvalsh(K)))
    k = np.arange(1, N + 1)
    assert np.allclose(w, 2 * np.sin((2 * k - 1) * np.pi / (2 * (2 * N + 1))))
    # every mode decays at the rate zeta sqrt(2); damping ratio zeta sqrt(2) / |lambda|
    lam = np.linalg.eigvals(p.A)
    assert np.allclose(lam.real, -0.05 * np.sqrt(2))
    assert np.min(-lam.real / np.abs(lam)) == pytest.approx(0.05 * np.sqrt(2) / w[-1])
    # a force accelerates its own mass only; a sensor reads one position
    assert np.flatnonzero(p.B[:, 0]).tolist() == [N + 2]
    assert np.flatnonzero(p.C[1]).tolist() == [6]


def test_sensor_count_spreads_along_the_chain_and_names_follow() -> None:
    p = gf.mass_spring_chain(100, sensors=10, forces=(33, 99))
    read = [int(np.flatnonzero(row)[0]) for row in p.C]
    assert read[0] == 0 and read[-1] == 99 and np.all(np.diff(read) > 0)
    assert p.outputs[0] == "position 0" and list(p.inputs) == ["force 33", "force 99"]
    assert p.states[0] == "p0" and p.states[100] == "v0"


@pytest.mark.parametrize(
    ("kwargs", "argument"),
    [
        ({"masses": 0}, "masses"),
        ({"masses": 3, "sensors": [3]}, "sensors"),
        ({"masses": 3, "sensors": []}, "sensors"),
        ({"masses": 3, "forces": (-1,)}, "forces"),
        ({"masses": 3, "zeta": -0.1}, "zeta"),
        ({"masses": 3, "zeta": float("nan")}, "zeta"),
        ({"masses": 3, "zeta": "0.1"}, "zeta"),
    ],
)
def test_bad_arguments_are_named(kwargs: dict, argument: str) -> None:
    with pytest.raises(gf.errors.GeomFDIError) as err:
        gf.mass_spring_chain(**kwargs)
    assert err.value.argument == argument


def test_one_sensor_residual_observes_the_whole_chain() -> None:
    p = gf.mass_spring_chain(6, sensors=3, forces=(0,))
    bank = gf.design_sensor_bank(p)
    assert gf.verify(bank, p).ok
    assert max(g.order for g in bank.generators if g is not None) >= p.n - 2
