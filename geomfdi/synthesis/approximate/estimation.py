"""Fault estimation by model matching: a residual ``r ≈ f`` (Varga 2017, §5.6–5.7).

``Q`` decouples ``u`` and ``d`` exactly and makes the fault transfer ``R_f = Q [G_f; 0]``
match the identity reference ``M_r = I``:

1. ``Q1``: the decoupling basis of ``u`` and ``d`` (``ρ`` rows,
   :func:`~geomfdi.synthesis.approximate.nullspace.decoupling_basis`); ``R_f1 = Q1 [G_f; 0]``
   must have full column rank ``n_f`` (else no estimator exists).
2. ``H`` (``n_f × ρ``, orthonormal rows): the dominant left singular directions of ``R_f1``
   at three generic points; ``G = H R_f1`` is square and invertible.
3. ``G = G_o G_i`` (co-outer–co-inner, :mod:`~geomfdi.synthesis.approximate.factorization`,
   regularised when ``G`` has zeros at infinity or on the boundary) and
   ``Q = G_i(λ0)⁻¹ G_o⁻¹ H Q1`` with ``λ0 = 0`` (``1`` in discrete time).  Then
   ``R_f = G_i(λ0)⁻¹ G_i``.

**Exact case** (as Varga's ``emmsyn``): ``G`` biproper without zeros outside the stability
region: ``G_i`` is a constant orthogonal matrix and ``R_f = I`` exactly.  **Approximate
case** (zeros of ``G`` in the unstable region, at infinity — faults without a direct path to
the outputs — or on the boundary): ``R_f`` is all-pass (or nearly so) and equals ``I`` at
``λ0`` (the steady state is estimated exactly); the achieved error ``‖R_f − I‖∞`` is reported.
This is not the H∞-optimal solution of Varga's ``ammsyn`` (a Nehari problem), which geomfdi
does not compute.  See *Theory: approximate synthesis*.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from geomfdi.errors import DesignError, NotIsolableError
from geomfdi.generators.generator import ResidualGenerator
from geomfdi.model.faults import Fault, fault_matrices
from geomfdi.model.plant import Plant
from geomfdi.synthesis.approximate.factorization import co_outer_factor
from geomfdi.synthesis.approximate.gap_design import combine_rows, require_stable, series
from geomfdi.synthesis.approximate.measure import hinf
from geomfdi.synthesis.approximate.nullspace import (
    _PROBES,
    channel,
    decoupling_basis,
    noise_channel,
    normal_rank,
    transfer_on_grid,
)

__all__ = ["design_fault_estimator"]

EXACT_TOL = 1e-8


def design_fault_estimator(
    plant: Plant,
    faults: Sequence[Fault],
    *,
    poles: Any = None,
    regularization: float | None = None,
) -> ResidualGenerator:
    """A generator whose residual estimates the fault signals: ``r ≈ f`` (module docstring).

    Parameters
    ----------
    plant : Plant
    faults : list of Fault
        The faults to estimate; ``r`` has one component per fault signal column, in order.
    poles : sequence, optional
        Poles of the decoupling basis (as in :func:`geomfdi.design_residual_generator`).
    regularization : float, optional
        ``ε`` of the regularised factorisation in the non-standard case (default ``1e-2``
        relative to ``‖G‖∞``); smaller values estimate a wider band with faster poles.

    Returns
    -------
    ResidualGenerator
        ``method="estimator"``; ``info["exact"]`` (model matching holds exactly),
        ``info["error_norm"]`` (``‖R_f − I‖∞``), ``info["dc_error"]``
        (``‖R_f(λ0) − I‖``), ``info["noise_gain"]`` (``‖R_w‖∞``, 0 without noise),
        ``info["leak_u"]``, ``info["leak_d"]``, ``info["regularization"]``.

    Raises
    ------
    NotIsolableError
        The faults cannot be reconstructed: fewer independent residual directions than
        fault signals after decoupling ``u`` and ``d``.

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> p = gf.Plant([[-1.0, 0.0], [1.0, -2.0]], [[1.0], [0.0]], np.eye(2))
    >>> est = gf.design_fault_estimator(p, [gf.SensorFault(0), gf.SensorFault(1)])
    >>> est.info["exact"], est.info["error_norm"] < 1e-8
    (True, True)
    """
    from geomfdi.synthesis.construction import _coerce_faults, _coerce_plant

    plant = _coerce_plant(plant)
    faults = _coerce_faults(faults)
    if not faults:
        raise NotIsolableError("faults: give at least one fault to estimate", argument="faults")
    sigs = fault_matrices(faults, plant.n, plant.q)
    Bf = np.hstack([b for b, _ in sigs])
    Df = np.hstack([d for _, d in sigs])
    nf = Bf.shape[1]
    A, C, dt = plant.A, plant.C, plant.dt
    Q1 = decoupling_basis(plant, faults, sigs, tuple(range(len(faults))), (), poles=poles)
    rho = Q1.n_outputs
    Rf1 = channel(Q1, A, Bf, C, Df)
    rank = normal_rank(*Rf1, dt)
    if rho < nf or rank < nf:
        raise NotIsolableError(
            f"faults: {nf} fault signals cannot be estimated from {rank} independent "
            "residual directions left after decoupling u and d",
            argument="faults",
        )
    rad = max(float(np.max(np.abs(np.linalg.eigvals(A)))) if A.size else 0.0, 1.0)
    pts = np.array(_PROBES) * (1.0 if dt > 0 else rad) + (1.5 if dt > 0 else 0.0)
    Gp = transfer_on_grid(*Rf1, pts)
    U, _, _ = np.linalg.svd(np.hstack([np.hstack([G.real, G.imag]) for G in Gp]))
    H = U[:, :nf].T
    Ag, Bg, Cg, Dg = Rf1[0], Rf1[1], H @ Rf1[2], H @ Rf1[3]
    scale = hinf(Ag, Bg, Cg, Dg, dt)
    fac = co_outer_factor(Ag, Bg, Cg, Dg, dt, scale=scale, regularization=regularization)
    Qh = ResidualGenerator(Q1.F, Q1.E, Q1.G, H @ Q1.M, H @ Q1.H, H @ Q1.K, dt=dt)
    Qt = series(Qh, fac.Ai, fac.Bi, fac.Ci, fac.Di)
    lam0 = np.array([1.0 if dt > 0 else 0.0])
    Gi0 = transfer_on_grid(*channel(Qt, A, Bf, C, Df), lam0)[0].real
    if np.linalg.cond(Gi0) > 1e12:
        raise DesignError(
            "faults: the fault transfer vanishes at steady state (a zero at λ0); "
            "no steady-state-exact estimator exists",
            argument="faults",
        )
    T = np.linalg.inv(Gi0)
    g = combine_rows(Qt, T, dt)
    g.method = "estimator"
    g.target = tuple(range(len(faults)))
    Ae, Be, Ce, De = channel(g, A, Bf, C, Df)
    err = hinf(Ae, Be, Ce, De - np.eye(nf), dt)
    dc = float(np.linalg.norm(transfer_on_grid(Ae, Be, Ce, De, lam0)[0] - np.eye(nf), 2))
    Bw, Dw = noise_channel(plant)
    noise = hinf(*channel(g, A, Bw, C, Dw), dt) if Bw.shape[1] else 0.0
    leak_u = hinf(*channel(g, A, plant.B, C, plant.D, known_input=True), dt)
    leak_d = hinf(*channel(g, A, plant.Bd, C, plant.Dd), dt) if plant.nd else 0.0
    poles_g = require_stable(g, dt, "plant: the estimator came out unstable", argument="plant")
    g.info.update(
        exact=bool(err <= EXACT_TOL),
        error_norm=err,
        dc_error=dc,
        noise_gain=noise,
        leak_u=leak_u,
        leak_d=leak_d,
        regularization=fac.regularization,
        nullspace_dim=rho,
        poles=poles_g,
    )
    return g
