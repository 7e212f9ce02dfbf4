"""Robust approximate design over several models (linearisations, parameter corners).

A residual ``Q`` designed on one model decouples ``u``, ``d`` and the non-target faults
exactly only there; on another model ``k`` their leaks ``L_k = Q [G_u^k G_d^k G_fdec^k;
I 0 0]`` act like extra noise.  The gap on model ``k`` is therefore

    gap_k = min_j ‖R_fj^k‖∞ / ‖[R_w^k  L_k]‖∞

(inputs that leak count as unit-size noise: scale ``B``, ``Bd`` of the models to the sizes
expected).  :func:`robust_gap_design` maximises ``min_k gap_k`` over a small set of
candidates, each built on the decoupling basis ``Q1`` of one model ``c``:

* the nominal gap design on model ``c`` (noise channel of ``c`` only);
* (once) the *joint exact* design: the basis that decouples ``u``, ``d`` and ``f_dec``
  exactly on every model (the left nullspace of model 0's channels and of the differences
  ``G_x^k − G_x^0``), with the stacked factorisation below — it exists when the models share
  enough structure (e.g. static parity relations, or identical input channels);
* the *stacked* design: the co-outer factor of all channels of all models at once,
  ``[R_w^1 L_1 … R_w^N L_N] = R_o R_i``, so that ``‖[R_w^k L_k]‖∞ ≤ 1`` after ``R_o⁻¹`` on
  every model, then the rows maximising ``min_{k,j} ‖M R_o⁻¹ R_fj^k‖∞``.

The candidate with the largest worst-case gap (H∞ norms on every model) is returned; the
nominal design on the first model is one of the candidates, so the robust worst case is never
below the nominal one.  When ``Q1`` of a model decouples exactly on every model (leak below
``1e-9`` relative), the leaks vanish and only the noise counts.  See *Theory: approximate
synthesis* (``docs/theory/approximate-synthesis.md``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi.errors import DesignError, NotIsolableError
from geomfdi.generators.generator import ResidualGenerator
from geomfdi.model.faults import Fault, fault_matrices
from geomfdi.model.plant import Plant
from geomfdi.synthesis.approximate.factorization import co_outer_factor
from geomfdi.synthesis.approximate.gap_design import (
    choose_rows,
    combine_rows,
    gap_design,
    require_stable,
    series,
)
from geomfdi.synthesis.approximate.measure import hinf
from geomfdi.synthesis.approximate.nullspace import (
    channel,
    decoupling_basis,
    frequency_grid,
    noise_channel,
    quiet_minimal,
    transfer_on_grid,
)

__all__ = ["robust_gap_design", "model_gaps"]

Channel = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def _stack(chs: list[Channel]) -> Channel:
    """``[R_1 R_2 …]`` (same outputs): block-diagonal state, inputs side by side."""
    from scipy.linalg import block_diag

    A = block_diag(*[c[0] for c in chs]) if chs else np.zeros((0, 0))
    B = block_diag(*[c[1] for c in chs])
    C = np.hstack([c[2] for c in chs])
    D = np.hstack([c[3] for c in chs])
    return quiet_minimal(A, B, C, D)


def _channels(
    g: ResidualGenerator, model: Plant, sigs: list, target: tuple, decouple: tuple
) -> tuple[Channel, Channel, list[Channel]]:
    """Noise channel, leak channel ``[u, d, f_dec]`` and target-fault channels on ``model``."""
    A, C = model.A, model.C
    Bw, Dw = noise_channel(model)
    nz = channel(g, A, Bw, C, Dw)
    Bd = np.hstack([model.Bd, *[sigs[j][0] for j in decouple]]).reshape(model.n, -1)
    Dd = np.hstack([model.Dd, *[sigs[j][1] for j in decouple]]).reshape(model.q, -1)
    lu = channel(g, A, model.B, C, model.D, known_input=True)
    ld = channel(g, A, Bd, C, Dd)
    leak = _stack([lu, ld])
    fch = [channel(g, A, sigs[j][0], C, sigs[j][1]) for j in target]
    return nz, leak, fch


def _grid_norm(ch: Channel, pts: np.ndarray) -> float:
    """``max`` over the grid of ``σmax`` (a lower estimate of the H∞ norm)."""
    if ch[1].shape[1] == 0 or ch[2].shape[0] == 0:
        return 0.0
    return float(np.max(np.linalg.norm(transfer_on_grid(*ch, pts), ord=2, axis=(1, 2))))


def _norm(ch: Channel, dt: float, pts: np.ndarray | None) -> float:
    return hinf(*ch, dt) if pts is None else _grid_norm(ch, pts)


def model_gaps(
    g: ResidualGenerator,
    models: list[Plant],
    faults: list[Fault],
    target: tuple,
    decouple: tuple,
    *,
    grid: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """``gap_k`` of ``g`` on every model and the relative leak ``‖L_k‖∞ / β_k``.

    ``grid=True``: norms estimated on a frequency grid (to rank candidates cheaply);
    otherwise H∞ norms.
    """
    gaps, leaks = [], []
    for m in models:
        sigs = fault_matrices(faults, m.n, m.q)
        nz, leak, fch = _channels(g, m, sigs, target, decouple)
        pts = frequency_grid(m.A, m.dt) if grid else None
        beta = min(_norm(f, m.dt, pts) for f in fch)
        lk = _norm(leak, m.dt, pts)
        gamma = _norm(_stack([nz, leak]), m.dt, pts)
        gaps.append(np.inf if gamma <= 1e-12 * max(beta, 1e-300) else beta / gamma)
        leaks.append(lk / max(beta, 1e-300))
    return np.array(gaps), np.array(leaks)


def _joint_basis(
    models: list[Plant], faults: list[Fault], target: tuple, decouple: tuple, poles: Any
) -> ResidualGenerator:
    """``Q1`` decoupling ``u``, ``d`` and ``f_dec`` exactly on **every** model.

    ``Q [G_x^k; I] = 0`` for all ``k`` iff ``Q`` decouples ``x`` on model 0 and the
    differences ``G_x^k − G_x^0`` (``k ≥ 1``): an augmented plant (model 0 and, per model
    ``k``, the states of ``G_x^k − G_x^0``) whose disturbances are those differences.
    Raises :class:`NotIsolableError` when no such residual sees the targets.
    """
    from scipy.linalg import block_diag

    m0 = models[0]
    n, q = m0.n, m0.q
    sig = [fault_matrices(faults, m.n, m.q) for m in models]
    nk = 1 + 2 * (len(models) - 1)  # model 0, then (model k, copy of model 0) per k
    A = block_diag(m0.A, *[block_diag(m.A, m0.A) for m in models[1:]])
    C = np.hstack([m0.C, *[np.hstack([m.C, -m0.C]) for m in models[1:]]])

    def pad(X: np.ndarray) -> np.ndarray:  # a column block entering model 0 only
        return np.vstack([X, np.zeros(((nk - 1) * n, X.shape[1]))])

    cols_B, cols_D = [pad(m0.Bd)], [m0.Dd]
    for k, m in enumerate(models[1:], start=1):
        groups = [(m.B, m0.B, m.D - m0.D), (m.Bd, m0.Bd, m.Dd - m0.Dd)]
        groups += [(sig[k][j][0], sig[0][j][0], sig[k][j][1] - sig[0][j][1]) for j in decouple]
        for Bk, B0, Dk in groups:
            X = np.zeros((nk * n, Bk.shape[1]))
            X[(2 * k - 1) * n : 2 * k * n] = Bk
            X[2 * k * n : (2 * k + 1) * n] = B0
            cols_B.append(X)
            cols_D.append(Dk)
    aug = Plant(A, pad(m0.B), C, m0.D, m0.dt, Bd=np.hstack(cols_B), Dd=np.hstack(cols_D))
    fa = [Fault(pad(Bf), Df) for Bf, Df in sig[0]]
    del q
    return decoupling_basis(
        aug, fa, fault_matrices(fa, aug.n, aug.q), target, decouple, poles=poles
    )


def _stacked_candidate(
    models: list[Plant],
    faults: list[Fault],
    c: int | None,
    target: tuple,
    decouple: tuple,
    poles: Any,
    residual_dim: int | None,
    regularization: float | None,
) -> ResidualGenerator:
    """The stacked design on the basis of model ``c`` (``None``: the joint exact basis)."""
    m0 = models[0 if c is None else c]
    if c is None:
        Q1 = _joint_basis(models, faults, target, decouple, poles)
    else:
        sigs0 = fault_matrices(faults, m0.n, m0.q)
        Q1 = decoupling_basis(m0, faults, sigs0, target, decouple, poles=poles)
    chs: list[Channel] = []
    fch_all = []
    for m in models:
        sigs = fault_matrices(faults, m.n, m.q)
        nz, leak, fch = _channels(Q1, m, sigs, target, decouple)
        chs += [nz, leak]
        fch_all.append(fch)
    S = _stack(chs)
    scale = hinf(*S, m0.dt)
    if scale == 0:
        raise DesignError("models: no noise and no leak: use the nominal design")
    fac = co_outer_factor(*S, m0.dt, scale=scale, regularization=regularization)
    Qt = series(Q1, fac.Ai, fac.Bi, fac.Ci, fac.Di)
    rho = Q1.n_outputs
    rdim = rho if residual_dim is None else int(residual_dim)
    pts = frequency_grid(m0.A, m0.dt)
    Gf = []
    for m in models:
        sigs = fault_matrices(faults, m.n, m.q)
        Gf += [
            transfer_on_grid(*channel(Qt, m.A, sigs[j][0], m.C, sigs[j][1]), pts) for j in target
        ]
    Mrow, _ = choose_rows(Gf, rdim)
    g = combine_rows(Qt, Mrow, m0.dt, target, decouple)
    g.info.update(nullspace_dim=rho, residual_dim=rdim, regularization=fac.regularization)
    return g


def robust_gap_design(
    models: list[Plant],
    faults: list[Fault],
    target: tuple[int, ...],
    decouple: tuple[int, ...],
    *,
    poles: Any = None,
    residual_dim: int | None = None,
    regularization: float | None = None,
) -> ResidualGenerator:
    """The candidate (module docstring) with the largest worst-case gap over ``models``.

    ``g.info``: ``model_gaps`` (gap per model), ``worst_gap``, ``nominal_model_gaps`` (the
    nominal design on ``models[0]``), ``model_leaks`` (leak relative to β per model),
    ``exact_on_all_models``, ``candidate`` (``"nominal c"``, ``"stacked c"`` or
    ``"joint exact"``) and
    ``candidates`` (worst-case gap of each on the frequency grid, which ranks them; the
    chosen one and the nominal one are then measured by H∞ norms).
    """
    cands: list[tuple[str, ResidualGenerator]] = []
    for c, m in enumerate(models):
        sigs = fault_matrices(faults, m.n, m.q)
        Bw, Dw = noise_channel(m)
        try:
            cands.append(
                (
                    f"nominal {c}",
                    gap_design(
                        m,
                        faults,
                        sigs,
                        target,
                        decouple,
                        Bw,
                        Dw,
                        poles=poles,
                        residual_dim=residual_dim,
                        regularization=regularization,
                    ),
                )
            )
        except (NotIsolableError, DesignError):
            if c == 0:
                raise
        try:
            cands.append(
                (
                    f"stacked {c}",
                    _stacked_candidate(
                        models, faults, c, target, decouple, poles, residual_dim, regularization
                    ),
                )
            )
        except (NotIsolableError, DesignError, np.linalg.LinAlgError, ValueError):
            pass
    try:  # the basis that decouples exactly on every model, where it exists
        cands.append(
            (
                "joint exact",
                _stacked_candidate(
                    models, faults, None, target, decouple, poles, residual_dim, regularization
                ),
            )
        )
    except (NotIsolableError, DesignError, np.linalg.LinAlgError, ValueError):
        pass
    ranks = [
        float(np.min(model_gaps(g, models, faults, target, decouple, grid=True)[0]))
        for _, g in cands
    ]
    best = int(np.argmax(ranks))
    scored = []
    for i in sorted({0, best}):  # H∞ numbers for the nominal design and the chosen one
        gaps, leaks = model_gaps(cands[i][1], models, faults, target, decouple)
        scored.append((float(np.min(gaps)), cands[i][0], cands[i][1], gaps, leaks))
    nominal = scored[0]
    worst, name, g, gaps, leaks = max(scored, key=lambda t: t[0])
    poles_g = require_stable(
        g, models[0].dt, "models: the robust design produced an unstable generator"
    )
    g.method = "gap"
    g.info.update(
        gap=worst,
        worst_gap=worst,
        model_gaps=gaps,
        model_leaks=leaks,
        nominal_model_gaps=nominal[3],
        nominal_worst_gap=nominal[0],
        exact_on_all_models=bool(np.all(leaks < 1e-9)),
        candidate=name,
        candidates={n: r for (n, _), r in zip(cands, ranks, strict=True)},
        poles=poles_g,
    )
    return g
