"""A lightly damped mass–spring chain of any length: a real-size test plant.

``N`` unit masses in a row, each joined to the next by a unit spring, the first one also to
a wall, the last one free; every mass has the same viscous damping.  With positions ``p``
and velocities ``v`` (``x = [p; v]``, ``n = 2N`` states)::

    p' = v
    v' = -K p - 2 ζ √2 v + B_f f

with ``K`` the tridiagonal stiffness matrix (2 on the diagonal, −1 beside it, 1 in the last
corner: the free end).  The natural frequencies are ``ω_k = 2 sin((2k − 1) π / (2 (2N + 1)))``,
``k = 1 .. N``: from about ``π / (2N)`` to 2 rad/s, so long chains are stiff.  Every mode
decays at the rate ``ζ √2`` (damping ratio ``ζ √2 / ω_k``, about ``0.71 ζ`` for the
fastest mode: lightly damped).  A sensor at one mass observes all modes through one
output, so every residual that reads one sensor is an observer of the whole chain, of
order ≈ ``n``.  The chain is the usual yardstick of the geometric design's cost and
conditioning at 20 – 400 states (``benchmarks/bench_least_order.py``,
``benchmarks/bench_sensor_bank.py``).
"""

from __future__ import annotations

import numbers
from collections.abc import Sequence

import numpy as np

from geomfdi._validation import as_int
from geomfdi.errors import GeomFDIError
from geomfdi.model.plant import Plant

__all__ = ["mass_spring_chain"]


def _masses(values: Sequence[int], N: int, argument: str) -> list[int]:
    out = []
    for v in values:
        k = as_int(v, argument, minimum=0)
        if k >= N:
            raise GeomFDIError(
                f"{argument}: mass {k} does not exist (masses 0 .. {N - 1})", argument=argument
            )
        out.append(k)
    return out


def mass_spring_chain(
    masses: int,
    sensors: int | Sequence[int] = 1,
    forces: Sequence[int] = (0,),
    zeta: float = 0.01,
) -> Plant:
    """The chain of ``masses`` masses, position sensors and force inputs (module docstring).

    Parameters
    ----------
    masses : int
        Number of masses ``N`` (``n = 2N`` states), at least 1.
    sensors : int or sequence of int
        A count ``q``: that many position sensors spread evenly along the chain (masses
        ``linspace(0, N - 1, q)`` rounded down); or the masses whose positions are read.
    forces : sequence of int
        The masses a force input acts on (one input each).
    zeta : float
        Damping: ``v' = ... - 2 ζ √2 v``, ``ζ >= 0``.

    Returns
    -------
    Plant
        Continuous, with names: states ``p0 .. p{N-1}, v0 .. v{N-1}``, inputs ``force k``,
        outputs ``position k``.

    Raises
    ------
    GeomFDIError
        A count below 1, a mass index outside the chain, a negative or non-finite ``zeta``.

    Examples
    --------
    >>> import geomfdi as gf
    >>> p = gf.mass_spring_chain(100, sensors=10, forces=(33, 99))
    >>> p.n, p.q, p.m
    (200, 10, 2)
    """
    N = as_int(masses, "masses", minimum=1)
    if isinstance(sensors, int | np.integer) and not isinstance(sensors, bool):
        q = as_int(sensors, "sensors", minimum=1)
        read = [int(k) for k in np.linspace(0, N - 1, q).astype(int)]
    else:
        read = _masses(sensors, N, "sensors")
        if not read:
            raise GeomFDIError("sensors: expected at least one sensor", argument="sensors")
    push = _masses(forces, N, "forces")
    if isinstance(zeta, bool) or not isinstance(zeta, numbers.Real):
        raise GeomFDIError(f"zeta: expected a real number, got {zeta!r:.40}", argument="zeta")
    z = float(zeta)
    if not np.isfinite(z) or z < 0:
        raise GeomFDIError(f"zeta: expected a finite value >= 0, got {zeta!r}", argument="zeta")
    n = 2 * N
    K = 2 * np.eye(N) - np.eye(N, k=1) - np.eye(N, k=-1)
    K[-1, -1] = 1.0
    A = np.block([[np.zeros((N, N)), np.eye(N)], [-K, -2 * z * np.sqrt(2) * np.eye(N)]])
    B = np.zeros((n, len(push)))
    B[[N + k for k in push], np.arange(len(push))] = 1.0
    C = np.zeros((len(read), n))
    C[np.arange(len(read)), read] = 1.0
    return Plant(
        A,
        B,
        C,
        inputs=[f"force {k}" for k in push],
        outputs=[f"position {k}" for k in read],
        states=[f"p{k}" for k in range(N)] + [f"v{k}" for k in range(N)],
    )
