"""Residual-generator synthesis: the public front end (``design_*``).

See the user guide, *Theory: least-order synthesis* (``docs/theory/least-order.md``) and
*Theory: the geometric approach* (``docs/theory/geometric-approach.md``).

``method="exact"`` (default) delivers, per row, one **scalar residual of least order**
(:mod:`geomfdi.synthesis.least_order.search`, :mod:`geomfdi.synthesis.build`): order 0 (a static
parity relation) where redundant sensors allow it, otherwise the smallest order of any
proper residual that sees every target and ignores the rest, with a certificate.
``method="full"`` keeps the full-quotient observer of the geometric construction (the
vector residual ``r = M e`` with the output filter of the exact sensor-fault transform;
:mod:`geomfdi.synthesis.construction`); ``"paper"`` and ``"mvw"`` are the sensor-fault
transforms of Hou, Wen & Chen (2011) and Massoumnia, Verghese & Willsky (1989) on that
construction.

Defaults relative to the plant: the default poles of a least-order row are distinct, real
and geometrically spread over ``[−10ω, −ω/10]`` (continuous; ω the plant's time scale, the
geometric mean of the moduli of A's non-zero eigenvalues, at least its fastest unstable
one, see :func:`geomfdi.synthesis.least_order.poles.plant_scale`) or ``[0.001, 0.93]``
(discrete).
A row is reported ``"weak"`` when the DC gain from a target is below ``FD_GAIN_TOL``
times the largest gain from any fault over frequency (strong detectability), never
``"ok"``.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from geomfdi._threads import limit_blas_threads
from geomfdi._validation import as_bool, as_float, as_real_array
from geomfdi.errors import (
    DesignError,
    GeomFDIError,
    IsolabilityWarning,
    NotIsolableError,
    ShapeError,
)
from geomfdi.generators.gains import LEAK_TOL, PlantFactor
from geomfdi.generators.generator import ResidualBank, ResidualGenerator
from geomfdi.generators.realization import minimal_realization
from geomfdi.model.faults import Fault, SensorFault, bind_faults, fault_matrices
from geomfdi.model.plant import Plant
from geomfdi.synthesis.build import FD_GAIN_TOL, build_least_order, check_angles, weak_targets
from geomfdi.synthesis.construction import (
    _coerce_faults,
    _coerce_plant,
    _NumericalDesignError,
    build_full,
    checked_margin,
    checked_poles,
    row_poles,
    row_split,
    target_decouple,
)
from geomfdi.synthesis.least_order.poles import plant_scale
from geomfdi.synthesis.multirow import ResidualDimError, build_multirow, check_residual_dim
from geomfdi.synthesis.objective import objective_of
from geomfdi.synthesis.rank_decisions import attach, close_note, record_design, summarise
from geomfdi.synthesis.row_notes import check_strength as _check_strength
from geomfdi.synthesis.row_notes import row_notes
from geomfdi.synthesis.sensor_transforms import default_filter_pole, pseudo_actuator_model

__all__ = [
    "design_residual_generator",
    "design_bank",
    "design_sensor_bank",
    "METHODS",
    "FD_GAIN_TOL",
]

METHODS = ("exact", "full", "paper", "mvw")


def _check_method(method: Any) -> str:
    if not isinstance(method, str) or method not in METHODS:
        raise DesignError(
            f"method: must be one of {list(METHODS)}, got {method!r:.40}", argument="method"
        )
    return str(method)


def _plant_and_faults(plant: Any, faults: Any) -> tuple[Plant, list[Fault]]:
    """The plant as a :class:`Plant` and the faults bound to it."""
    plant = _coerce_plant(plant)
    return plant, bind_faults(plant, _coerce_faults(faults))


def _checked_options(method: Any, minimal: Any, filter_pole: Any) -> tuple[str, bool, float | None]:
    """``method``, ``minimal`` and ``filter_pole`` of a numerical design, validated."""
    return (
        _check_method(method),
        as_bool(minimal, "minimal"),
        as_float(filter_pole, "filter_pole", allow_none=True),
    )


def _check_rows_method(rdim: int, method: Any, exact: Any) -> None:
    """Rows beyond the first (``residual_dim > 1``) need ``method="exact"``, ``exact=False``."""
    if rdim > 1 and (exact or method != "exact"):
        raise DesignError(
            "residual_dim: rows beyond the first are designed by the least-order method "
            f"(method='exact', exact=False); got method={method!r}, exact={exact!r}",
            argument="residual_dim",
        )


def _factor_and_scale(plant: Plant) -> tuple[PlantFactor, float]:
    """The plant's Schur factor and its time scale ``ω`` (default poles, pole scaling)."""
    factor = PlantFactor(plant)
    return factor, plant_scale(plant.A, plant.dt, eigenvalues=np.diag(factor.TA))


def _design_row(
    plant: Plant,
    faults: list[Fault],
    sigs: list[tuple[np.ndarray, np.ndarray]],
    method: str,
    filter_pole: float | None,
    target: tuple[int, ...],
    decouple: tuple[int, ...],
    poles: Any,
    margin: float,
    minimal: bool,
    row: str,
    factor: PlantFactor,
    omega: float,
    prefix: bool = False,
    residual_dim: int = 1,
    strength: str = "strong",
) -> ResidualGenerator:
    """One row: least order for ``"exact"`` (full-quotient fallback on numerical failure).

    ``residual_dim > 1`` (exact method only): that many independent least-order rows
    stacked (:func:`geomfdi.synthesis.multirow.build_multirow`), no fallback.
    """
    if residual_dim > 1:
        return build_multirow(
            plant,
            faults,
            sigs,
            target,
            decouple,
            residual_dim=residual_dim,
            poles=poles,
            omega=omega,
            row=row,
            factor=factor,
            prefix=prefix,
        )
    if method != "exact":
        transform = "exact" if method == "full" else method
        g = build_full(
            plant,
            faults,
            transform,
            filter_pole,
            target,
            decouple,
            poles,
            margin,
            minimal,
            row,
            factor,
        )
        g.info["synthesis"] = "full"
        return g
    try:
        return build_least_order(
            plant,
            faults,
            sigs,
            target,
            decouple,
            poles=poles,
            omega=omega,
            row=row,
            factor=factor,
            prefix=prefix,
            strengthen=strength == "strong",
        )
    except _NumericalDesignError as exc:
        first = str(exc)
    if poles is not None:  # the user's spectrum was for the least-order row
        raise _NumericalDesignError(first, argument="plant")
    try:
        g = build_full(
            plant,
            faults,
            "exact",
            filter_pole,
            target,
            decouple,
            None,
            margin,
            minimal,
            row,
            factor,
        )
    except NotIsolableError:
        raise
    except DesignError as exc:
        raise _NumericalDesignError(f"{first}; full-quotient fallback: {exc}") from None
    check_angles(g, plant, sigs, factor, row)
    g.info["synthesis"] = "full"
    g.info["fallback"] = f"least-order realisation failed numerically ({first}); full quotient"
    return g


@limit_blas_threads
def design_residual_generator(
    plant: Plant,
    faults: Sequence[Fault],
    target: int | Sequence[int],
    *,
    decouple: int | Sequence[int] | None = None,
    poles: Any = None,
    method: str = "exact",
    filter_pole: float | None = None,
    margin: float | None = None,
    minimal: bool = True,
    residual_dim: int | None = None,
    exact: bool = False,
    strength: str = "strong",
    objective: str | None = None,
    regularization: float | None = None,
    models: Sequence[Plant] | None = None,
    band: Any = None,
) -> ResidualGenerator:
    """Design one residual generator that sees ``target`` and ignores ``decouple``.

    Parameters
    ----------
    plant : Plant
    faults : list of SensorFault / ActuatorFault / Fault
    target : int or sequence of int
        Faults the residual must see (indices into ``faults``).
    decouple : int or sequence of int, optional
        Faults it must ignore (default: all faults not in ``target``).  Disturbances
        of the plant are always decoupled.
    poles : sequence, optional
        ``method="exact"``: poles of the scalar least-order residual, distinct and stable
        (closed under conjugation); a row of order ν uses the first ν (fewer raise a
        :class:`DesignError` naming the order).  Default: distinct real poles spread
        geometrically over ``[−10ω, −ω/10]`` (continuous, ω the plant's time scale:
        :func:`geomfdi.synthesis.least_order.poles.plant_scale`) or ``[0.001, 0.93]``
        (discrete).  Other methods: the spectrum of the quotient observer (its order).
    method : {"exact", "full", "paper", "mvw"}
        ``"exact"``: least-order scalar residual (exact decoupling, no output filter).
        ``"full"``: full-quotient observer with the output filter of the exact
        sensor-fault transform.  ``"paper"``, ``"mvw"``: the full-quotient observer on
        those transforms (:mod:`geomfdi.synthesis.sensor_transforms`).
    filter_pole : float, optional
        ``a`` of the output filter (``"full"``).
    margin : float, optional
        Stability requirement of the full-quotient default spectrum.
    minimal : bool
        Minimal realisation of a full-quotient generator.
        Deliver a minimal realization (default); the order before reduction is in
        ``g.info["full_order"]``.
    residual_dim : int, optional
        Number of residual components (``method="exact"`` only; default 1, a scalar
        residual).  ``p > 1`` stacks ``p`` rows that each decouple every signal to be
        decoupled and are linearly independent over the rational functions: row 0 is the
        scalar least-order row (it sees every target), row ``i`` a row of the least
        degree independent of rows ``0 … i−1``.  ``g.info["row_orders"]`` holds the
        degrees, ``g.info["stacked_order"]`` the order of the delivered stack (a joint
        minimal realisation when it passes the leakage check).  At most ``ρ`` rows exist
        (``g.info["max_residual_dim"]``: the measurement combinations blind to the
        decoupled signals); asking for more raises :class:`DesignError` with
        ``argument="residual_dim"``.  With ``poles``, every row of order ν uses the
        first ν of that list (give at least the largest row order).
    strength : {"strong", "weak"}
        ``"strong"`` (default): a least-order row that sees a target only weakly (DC
        gain below ``FD_GAIN_TOL`` of its largest fault gain, faults at their reference
        sizes) is replaced by the first strong row of higher order (up to 3 degrees
        above), stated in ``g.info["least_order"]`` (``raised_from``) and in a bank's
        diagnostic; ``"weak"``: the least-order row itself, reported weak.
    exact : bool
        Run the construction in exact arithmetic (rationals, or rational functions of the
        parameters of a parametric plant) and return an
        :class:`~geomfdi.generators.exact.ExactResidualGenerator`; see
        :func:`geomfdi.synthesis.exact.design.design_bank_exact` (``margin`` and
        ``minimal`` do not apply).
    objective : {"decoupling", "gap"}, optional
        ``"decoupling"``: the exact design above (every unknown input decoupled).
        ``"gap"``: the approximate design (Varga 2017, §5.3): ``u``, ``d`` and the
        ``decouple`` faults decoupled exactly, the fault-to-noise gap ``β/γ`` over the noise
        inputs ``w`` of the plant (``Bw``, ``Dw``) maximised; ``residual_dim`` is then the
        number of rows (default: the whole decoupling basis, the optimal gap) and the gap,
        β and γ are in ``g.info`` (:mod:`geomfdi.synthesis.approximate`; user guide,
        *Approximate synthesis*).  Default: ``"gap"`` when the plant has noise inputs
        (``plant.nw > 0``) and ``method="exact"``, ``exact=False``, else ``"decoupling"``.
    regularization : float, optional
        ``objective="gap"``: ``ε`` (relative to the noise channel's H∞ norm) of the
        regularised factorisation used when the noise channel is non-standard (zeros at
        infinity or on the stability boundary); default ``1e-2`` there, unused otherwise.
    models : list of Plant, optional
        ``objective="gap"``: design over several models (same dimensions); see
        :func:`design_bank`.
    band : (w1, w2), optional
        ``objective="gap"``, one model: β is the H₋ index over the band (rad/s),
        ``min_j min_ω ‖R_fj(jω)‖`` (Varga 2017, §3.3), in the row choice and in the
        reported ``beta`` and ``gap``; γ stays the H∞ norm.

    Returns
    -------
    ResidualGenerator
        Acting on the measured y and u.  ``g.info["least_order"]`` (exact method) holds
        the certificate: the dimensions of the parity spaces of each degree and the
        targets unseen below the delivered order.

    Raises
    ------
    NotIsolableError
        When no residual sees every target while decoupling the others.
    DesignError
        Bad options (``argument`` names them: e.g. a ``residual_dim`` that is not an
        integer ``≥ 1``, or exceeds what the decoupling leaves) or a construction that
        failed numerically.

    Examples
    --------
    >>> import geomfdi as gf
    >>> p = gf.Plant([[1, 1, 1], [0, 1, 0], [2, 0, 1]], [[1, 0, 1], [0, 1, 1], [0, 1, 0]],
    ...              [[0, 1, 0], [0, 0, 1], [1, 0, 2]])
    >>> faults = [gf.SensorFault(i) for i in range(3)]
    >>> g = gf.design_residual_generator(p, faults, 0, method="paper", poles=[-2])
    >>> g.order, round(float(g.F[0, 0]), 12)
    (1, -2.0)

    Fault detection (every fault a target): C is invertible, so no static parity relation
    (a row ``h`` with ``h C = 0``) exists and the least order of a scalar residual is 1;
    the full-quotient observer keeps all three states.

    >>> gf.design_residual_generator(p, faults, [0, 1, 2]).order
    1
    >>> gf.design_residual_generator(p, faults, [0, 1, 2], method="full").order
    3

    Two independent residual components for fault detection: the second row is the
    least-order row independent of the first.

    >>> g2 = gf.design_residual_generator(p, faults, [0, 1, 2], residual_dim=2)
    >>> g2.n_outputs, g2.info["row_orders"]
    (2, [1, 1])
    """
    strength = _check_strength(strength)
    if objective_of(objective, plant, models, exact, method, band) == "gap":
        from geomfdi.synthesis.approximate.bank import gap_residual_generator

        return gap_residual_generator(
            *_plant_and_faults(plant, faults),
            target,
            decouple=decouple,
            poles=None if poles is None else checked_poles(poles),
            residual_dim=None if residual_dim is None else check_residual_dim(residual_dim),
            regularization=regularization,
            models=models,
            band=band,
        )
    rdim = check_residual_dim(residual_dim)
    _check_rows_method(rdim, method, exact)
    # --- exact / parametric design (geomfdi.synthesis.exact.design) ---
    if exact:
        from geomfdi.synthesis.exact.design import exact_dispatch

        return exact_dispatch(
            "residual",
            plant,
            faults,
            target=target,
            decouple=decouple,
            poles=poles,
            method=method,
            filter_pole=filter_pole,
        )
    # --- end exact ---
    plant, faults = _plant_and_faults(plant, faults)
    method, minimal, filter_pole = _checked_options(method, minimal, filter_pole)
    poles = checked_poles(poles)
    tgt, dec = target_decouple(target, decouple, len(faults))
    mg = checked_margin(margin, plant.dt)
    if filter_pole is not None:  # validated by the transform even when unused
        pseudo_actuator_model(plant, faults, "exact", filter_pole=filter_pole)
    sigs = fault_matrices(faults, plant.n, plant.q)
    factor, omega = _factor_and_scale(plant)
    with record_design() as rec:
        g = _design_row(
            plant,
            faults,
            sigs,
            method,
            filter_pole,
            tgt,
            dec,
            poles,
            mg,
            minimal,
            "the residual",
            factor,
            omega,
            residual_dim=rdim,
            strength=strength,
        )
    attach(g, rec, "the residual")
    if "target_strength" not in g.info and rdim == 1 and "dc_gain" in g.info:
        g.info["weak_targets"] = weak_targets(g, plant, sigs, factor, omega, tgt)
    return g


def _row_dims(residual_dim: Any, rows: int) -> list[int]:
    """``residual_dim`` for a bank: one integer for every row, or one per row."""
    if isinstance(residual_dim, list | tuple | np.ndarray):
        if len(residual_dim) != rows:
            raise DesignError(
                f"residual_dim: a per-row list must have {rows} entries, got {len(residual_dim)}",
                argument="residual_dim",
            )
        return [check_residual_dim(v) for v in residual_dim]
    return [check_residual_dim(residual_dim)] * rows


def _joint_order(gens: list[ResidualGenerator | None]) -> int:
    """Order of the stacked bank after a joint minimal realisation."""
    present = [g for g in gens if g is not None]
    if not present:
        return 0
    nw = sum(g.order for g in present)
    q, m = present[0].q, present[0].m
    F = np.zeros((nw, nw))
    B = np.zeros((nw, q + m))
    C = np.zeros((len(present), nw))
    i = 0
    for r, g in enumerate(present):
        F[i : i + g.order, i : i + g.order] = g.F
        B[i : i + g.order] = np.hstack([-g.E, g.G])
        C[r : r + 1, i : i + g.order] = g.M[:1]
        i += g.order
    if nw == 0:
        return 0
    return minimal_realization(F, B, C, np.zeros((len(present), q + m))).A.shape[0]


def _warn_inseparable(req: np.ndarray, faults: Sequence[Fault]) -> None:
    """:class:`~geomfdi.errors.IsolabilityWarning` when a structure of several rows gives
    two requested faults identical columns (no residual of the bank separates them)."""
    if req.shape[0] < 2:
        return  # one row: fault detection, not isolation
    from geomfdi.synthesis.specification.isolability import identical_columns

    groups = identical_columns(req, [j for j in range(req.shape[1]) if req[:, j].any()])
    if groups:
        text = "; ".join(", ".join(f"{j} ({faults[j].name!r})" for j in g) for g in groups)
        warnings.warn(
            f"structure: identical columns for faults {text}: the bank cannot tell them "
            "apart (gf.isolability_analysis suggests a structure that can)",
            IsolabilityWarning,
            stacklevel=4,  # the caller of design_bank (behind its BLAS-limit wrapper)
        )


@limit_blas_threads
def design_bank(
    plant: Plant,
    faults: Sequence[Fault],
    structure: Any,
    *,
    poles: Any = None,
    method: str = "exact",
    filter_pole: float | None = None,
    margin: float | None = None,
    minimal: bool = True,
    common_poles: bool = False,
    residual_dim: int | Sequence[int] | None = None,
    exact: bool = False,
    strength: str = "strong",
    objective: str | None = None,
    regularization: float | None = None,
    models: Sequence[Plant] | None = None,
    band: Any = None,
) -> ResidualBank:
    """Design one residual generator per row of a structure matrix.

    Parameters
    ----------
    plant : Plant
    faults : list of SensorFault / ActuatorFault / Fault
    structure : array_like of bool, (rows, len(faults))
        ``structure[r, j] = 1``: residual r must see fault j; 0: must ignore it.
    poles : sequence or list of sequences, optional
        One pole list used for every row, or one per row (``None`` entries: default).
        A list that does not fit its row (e.g. fewer poles than the row's least order)
        raises :class:`DesignError` with ``argument="poles"`` naming the row.
    method, filter_pole, margin, minimal
        As in :func:`design_residual_generator`.
    common_poles : bool
        Every row draws its poles from one common list (the default sequence, or
        ``poles``: a row of order ν uses its first ν entries), and
        ``bank.info["joint_order"]`` reports the order of the stacked bank after a joint
        minimal realisation.
    residual_dim : int or sequence of int, optional
        Residual components per row (``method="exact"`` only): one integer for every
        row or one per row (``None`` entries: 1).  Default 1, scalar residuals; see
        :func:`design_residual_generator`.  A row that cannot have that many independent
        components is missing, its diagnostic names ``residual_dim`` and the maximum.
    strength : {"strong", "weak"}
        As in :func:`design_residual_generator`.
    exact : bool
        Exact / parametric design: returns an
        :class:`~geomfdi.generators.exact.ExactResidualBank` (see
        :func:`geomfdi.synthesis.exact.design.design_bank_exact`).
    objective, regularization
        As in :func:`design_residual_generator`: with ``"gap"`` (default for a plant with
        noise inputs) every row is an approximate FDI row (Varga 2017, §5.5): it decouples
        the faults of its structure row exactly and maximises its gap;
        ``bank.info["gaps"]`` lists the gap per row.
    models : list of Plant, optional
        Several models of the same dimensions (operating points, parameter corners);
        ``plant`` is the nominal one (put first in the family when it is not in the
        list).  Exact decoupling is used where it holds on every model; otherwise each row
        maximises its worst-case gap
        over the models, the leaking inputs counting as noise
        (:mod:`geomfdi.synthesis.approximate.multimodel`).  ``g.info["model_gaps"]`` (and
        ``bank.info["model_gaps"]``) hold the gap per model of the family, and
        ``"nominal_model_gaps"`` those of the gap design on the nominal plant alone.
    band : (w1, w2), optional
        As in :func:`design_residual_generator` (every row).

    Returns
    -------
    ResidualBank
        ``generators[r]`` is ``None`` where row r cannot be realised (reason in
        ``diagnostics[r]``); a per-row failure never raises.  ``structure`` is the
        *achieved* structure on the physical model (relative gain above 1e-8).
        ``diagnostics[r]``: ``"ok"``; ``"missing: <reason>"``; ``"weak: ..."`` (a target's
        DC gain below ``FD_GAIN_TOL`` of the row's largest fault gain);
        ``"leaks faults [...] on the physical model (...)"`` (paper method);
        ``"ill-conditioned: ..."``; ``"close rank decision: ..."`` (the smallest
        singular-value gap behind the row is below ``gf.tolerance.GAP_WARN``; also added
        to a missing row's reason).  Several notes are joined with ``"; "``.
        ``bank.info["closest_gaps"]``: that gap per row (``g.info["rank_decisions"]``
        has where it was taken).
    """
    strength = _check_strength(strength)
    if objective_of(objective, plant, models, exact, method, band) == "gap":
        from geomfdi.synthesis.approximate.bank import gap_bank

        bank = gap_bank(
            *_plant_and_faults(plant, faults),
            structure,
            poles=poles,
            residual_dim=residual_dim,
            regularization=regularization,
            models=models,
            band=band,
        )
        _warn_inseparable(bank.requested, bank.faults)
        return bank
    dims_given = np.atleast_1d(np.asarray(residual_dim, dtype=object)).tolist()
    if exact and any(v is not None and v != 1 for v in dims_given):
        raise DesignError(
            "residual_dim: rows beyond the first are designed by the least-order method "
            "(method='exact', exact=False), not by the exact-arithmetic design",
            argument="residual_dim",
        )
    # --- exact / parametric design (geomfdi.synthesis.exact.design) ---
    if exact:
        from geomfdi.synthesis.exact.design import exact_dispatch

        return exact_dispatch(
            "bank",
            plant,
            faults,
            structure=structure,
            poles=poles,
            method=method,
            filter_pole=filter_pole,
        )
    # --- end exact ---
    plant, faults = _plant_and_faults(plant, faults)
    method, minimal, filter_pole = _checked_options(method, minimal, filter_pole)
    nf = len(faults)
    S = as_real_array(structure, "structure")
    if S.ndim == 1:
        S = S.reshape(1, -1)
    if S.ndim != 2 or S.shape[1] != nf:
        raise ShapeError(
            f"structure: expected {nf} columns (one per fault), got shape {S.shape}",
            argument="structure",
        )
    if not np.all((S == 0) | (S == 1)):
        raise GeomFDIError("structure: entries must be 0 or 1", argument="structure")
    req = S.astype(bool)
    _warn_inseparable(req, faults)
    dims = _row_dims(residual_dim, req.shape[0])
    _check_rows_method(max(dims, default=1), method, exact)
    sigs = fault_matrices(faults, plant.n, plant.q)
    info: dict[str, Any] = {}
    if method != "exact" or filter_pole is not None:
        if filter_pole is None and method == "full":
            filter_pole = default_filter_pole(plant)
        tr = "exact" if method == "full" else method
        model = pseudo_actuator_model(plant, faults, tr, filter_pole=filter_pole)
        info.update(design_n=model.n, filter_pole=model.filter_pole, notes=model.notes)
    mg = checked_margin(margin, plant.dt)
    rows = req.shape[0]
    per_row = row_poles(poles, rows)
    factor, omega = _factor_and_scale(plant)
    gens: list[ResidualGenerator | None] = []
    diags: list[str] = []
    achieved = np.zeros_like(req)
    for r in range(rows):
        tgt, dec = row_split(req[r])
        if not tgt:
            gens.append(None)
            diags.append("missing: the row requests no fault")
            continue
        rec: list = []
        try:
            with record_design() as rec:
                g = _design_row(
                    plant,
                    faults,
                    sigs,
                    method,
                    filter_pole,
                    tgt,
                    dec,
                    per_row[r],
                    mg,
                    minimal,
                    f"row {r}",
                    factor,
                    omega,
                    common_poles,
                    residual_dim=dims[r],
                    strength=strength,
                )
        except NotIsolableError as exc:
            gens.append(None)
            close = close_note(summarise(rec))
            diags.append(f"missing: {exc.reason}" + (f" ({close})" if close else ""))
            continue
        except ResidualDimError as exc:
            gens.append(None)
            diags.append(f"missing: {exc}")
            continue
        except DesignError as exc:
            if (
                exc.argument == "poles"
                and per_row[r] is not None
                and not isinstance(exc, _NumericalDesignError)
            ):
                msg = str(exc)  # the user's poles are wrong for this row: say which
                raise DesignError(
                    msg if f"row {r}" in msg else f"poles: row {r}: {msg.removeprefix('poles: ')}",
                    argument="poles",
                ) from None
            gens.append(None)
            close = close_note(summarise(rec))
            diags.append(
                f"missing: design failed numerically: {exc}" + (f" ({close})" if close else "")
            )
            continue
        gens.append(g)
        close = attach(g, rec, f"row {r}")
        achieved[r] = g.info["fault_gain"] > LEAK_TOL
        weak = g.info.get("weak_targets")
        if weak is None:
            weak = weak_targets(g, plant, sigs, factor, omega, tgt)
        leaks = [j for j in dec if achieved[r, j]]
        notes = row_notes(g, weak, leaks, method)
        if close:
            notes.append(close)
        diags.append("; ".join(notes) if notes else "ok")
    cols = [tuple(achieved[:, j]) for j in range(nf)]
    isolable = np.array(
        [any(cols[j]) and all(cols[j] != cols[i] for i in range(nf) if i != j) for j in range(nf)]
    )
    info.update(margin=mg, plant_scale=omega)
    info["signals"] = plant.signal_info()  # names and operating point for deployment
    info["total_order"] = sum(g.order for g in gens if g is not None)
    info["closest_gaps"] = [None if g is None else g.info.get("closest_gap") for g in gens]
    if common_poles:
        info["joint_order"] = _joint_order(gens)
    return ResidualBank(
        generators=gens,
        requested=req,
        structure=achieved,
        isolable=isolable,
        diagnostics=diags,
        faults=faults,
        dt=plant.dt,
        method=method,
        info=info,
    )


@limit_blas_threads
def design_sensor_bank(
    plant: Plant,
    *,
    method: str = "exact",
    poles: Any = None,
    filter_pole: float | None = None,
    margin: float | None = None,
    minimal: bool = True,
    common_poles: bool = False,
    exact: bool = False,
) -> ResidualBank:
    """One residual per sensor, each decoupled from every other sensor (``S_FDI = I``).

    The bank of Hou, Wen & Chen (2011), §4.  See :func:`design_bank`.

    Examples
    --------
    >>> import geomfdi as gf
    >>> p = gf.Plant([[1, 1, 1], [0, 1, 0], [2, 0, 1]], [[1, 0, 1], [0, 1, 1], [0, 1, 0]],
    ...              [[0, 1, 0], [0, 0, 1], [1, 0, 2]])
    >>> gf.design_sensor_bank(p).isolable.tolist()
    [True, True, True]
    >>> gf.design_sensor_bank(p, method="mvw").isolable.tolist()
    [True, False, False]
    """
    # --- exact / parametric design (geomfdi.synthesis.exact.design) ---
    if exact:
        from geomfdi.synthesis.exact.design import exact_dispatch

        return exact_dispatch(
            "sensor", plant, None, poles=poles, method=method, filter_pole=filter_pole
        )
    # --- end exact ---
    plant = _coerce_plant(plant)
    faults = bind_faults(plant, [SensorFault(i) for i in range(plant.q)])
    return design_bank(
        plant,
        faults,
        np.eye(plant.q),
        poles=poles,
        method=method,
        filter_pole=filter_pole,
        margin=margin,
        minimal=minimal,
        common_poles=common_poles,
    )
