"""Least orders of the rows of a structure matrix, before a design.

See the user guide, *Theory: achievable signatures* (``docs/theory/achievable-signatures.md``)
and *Theory: least-order synthesis* (``docs/theory/least-order.md``).

Each row is decided exactly as the design decides it: the balanced model, the quotient by
S* of the decoupled signals (:mod:`geomfdi.synthesis.least_order.quotient`) and the degree
search of :func:`geomfdi.synthesis.least_order.search.least_order_row`, whose certificate
states that the parity space of one degree less sees no residual with every target (Varga's
``fdichkspec(…; minimal = true)`` answers the same question by minimal-basis degrees).

**Strong detection at frequencies Ω.**  A row is strongly feasible when every target has a
strong gain above ``gain_tol`` at every frequency (the test of
:func:`~geomfdi.synthesis.specification.signatures.strong_gains`, as in
``achievable_structures(…, frequencies=Ω)``); otherwise every residual of the row has a
zero there in the fault's channel (an invariant zero of the decoupled fault channel, or a
plant pole the residual must cancel) and the row is −1 at every order.  A feasible row's
least strong order is the least degree ν, from its least weak order on, whose parity space
``P_ν`` has a non-zero response to every target at every frequency
(:func:`geomfdi.synthesis.least_order.strong.strong_least_degree`): the numerators
``p_j = v G_j`` with ``p_j(λ₀) = 0`` form a proper subspace of ``P_ν`` for each pair, and
finitely many proper subspaces cannot cover it, so a generic residual of degree ν is strong
for every pair at once (Varga 2017, §3.5 and Chapter 5: strong fault detectability).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from geomfdi._validation import as_real_array
from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.synthesis.specification.model import SpecModel, quotient_of, spec_model
from geomfdi.synthesis.specification.signatures import (
    _boundary_points,
    _checked_frequencies,
    checked_gain_tol,
    strong_gains,
)

__all__ = ["RowOrder", "structure_orders", "row_orders", "as_structure"]


@dataclass(frozen=True)
class RowOrder:
    """The least order of one row and the statement behind it."""

    order: int
    """Least order of a scalar residual with this signature; −1 when none exists."""
    statement: str
    """The certificate's statement (why lower orders fail), or why the row is infeasible."""


def as_structure(S: Any, nf: int, name: str = "S") -> np.ndarray:
    """``S`` as a bool (rows, nf) array of 0/1 entries (a 1-D S is one row)."""
    arr = as_real_array(S, name)
    if arr.ndim == 1:
        arr = arr.reshape(1, -1)
    if arr.ndim != 2 or arr.shape[1] != nf:
        raise ShapeError(
            f"{name}: expected {nf} columns (one per fault), got shape {arr.shape}", argument=name
        )
    if not np.all((arr == 0) | (arr == 1)):
        raise GeomFDIError(f"{name}: entries must be 0 or 1", argument=name)
    return arr.astype(bool)


@dataclass(frozen=True)
class _Strong:
    """Frequencies of a strong search: the values, their points on the boundary, gain_tol."""

    frequencies: np.ndarray
    points: np.ndarray
    gain_tol: float


def _row_order(model: SpecModel, row: np.ndarray, strong: _Strong | None = None) -> RowOrder:
    from geomfdi.synthesis.least_order.search import _Infeasible, least_order_row

    tgt = tuple(int(j) for j in np.flatnonzero(row))
    dec = tuple(int(j) for j in np.flatnonzero(~row))
    if not tgt:
        return RowOrder(-1, "the row requests no fault")
    Qm = quotient_of(model, tgt, dec)
    if Qm is None:
        return RowOrder(-1, "the quotient of the decoupled signals is ill-conditioned")
    try:
        lo = least_order_row(Qm, omega=model.omega, dt=model.plant.dt)
    except _Infeasible as exc:
        return RowOrder(-1, exc.reason)
    weak = RowOrder(int(lo.order), str(lo.certificate.get("statement", "")))
    return weak if strong is None else _strong_order(model, Qm, tgt, weak, strong)


def _strong_order(
    model: SpecModel, Qm: Any, tgt: tuple[int, ...], weak: RowOrder, strong: _Strong
) -> RowOrder:
    """The least strong order of a weakly feasible row (module Notes)."""
    from geomfdi.synthesis.least_order.strong import strong_least_degree

    names, freqs = model.names, strong.frequencies
    dt = model.plant.dt
    sg = strong_gains(Qm, strong.points, model.omega, dt)
    if np.any(sg <= strong.gain_tol):
        k, t = np.unravel_index(np.argmin(sg), sg.shape)
        return RowOrder(
            -1,
            f"{names[tgt[t]]} has strong gain {sg[k, t]:.2g} <= gain_tol = "
            f"{strong.gain_tol:g} at ω = {freqs[k]:g}: every residual that decouples the "
            "other signals has a zero there in its channel, at every order",
        )
    got = strong_least_degree(Qm, strong.points, omega=model.omega, dt=dt, start=weak.order)
    nu = got["order"]
    where = ", ".join(f"{w:g}" for w in freqs)
    if nu is None:  # the pencil says strong, no degree confirmed it: the largest index holds all
        top = max(got["unseen"])
        return RowOrder(
            top,
            f"order {top} (the largest observability index, where the parity space holds "
            "every residual) for strong detection at ω ∈ {" + where + "}: the degree "
            "search did not confirm a lower one",
        )
    if nu == weak.order:
        return RowOrder(nu, f"strong at ω ∈ {{{where}}} at the least weak order; {weak.statement}")
    miss = got["unseen"][nu - 1]
    pairs = ", ".join(f"{names[tgt[j]]} at ω = {freqs[i]:g}" for i, j in miss)
    return RowOrder(
        nu,
        f"order {nu} is least for strong detection at ω ∈ {{{where}}}: the degree-{nu - 1} "
        f"parity space has no response from {pairs} (least weak order {weak.order})",
    )


def row_orders(
    model: SpecModel,
    S: np.ndarray,
    *,
    frequencies: Any = None,
    gain_tol: float | None = None,
) -> list[RowOrder]:
    """:class:`RowOrder` of each row of the bool array S on a prepared model; with
    ``frequencies``, the least orders for strong detection (:func:`structure_orders`)."""
    freqs = _checked_frequencies(frequencies)
    tol = checked_gain_tol(gain_tol)
    strong = None if freqs is None else _Strong(freqs, _boundary_points(freqs, model.plant.dt), tol)
    return [_row_order(model, row, strong) for row in S]


def structure_orders(
    plant: Any,
    faults: Any,
    S: Any,
    *,
    frequencies: Any = None,
    gain_tol: float | None = None,
) -> np.ndarray:
    """Least order of a scalar residual achieving each row of ``S`` (−1: infeasible).

    Parameters
    ----------
    plant : Plant or control.StateSpace
        Disturbances are always decoupled; a static plant (n = 0) is accepted.
    faults : list of Fault
    S : array_like of 0/1, (rows, len(faults))
        ``S[r, j] = 1``: row r sees fault j; 0: decouples it.
    frequencies : array_like, optional
        Frequencies (rad/s; the point ``z = e^{iω dt}`` in discrete time, as in
        :func:`~geomfdi.achievable_structures`) at which every target must be seen
        *strongly*: include 0 for constant faults.  Default: weak (normal-rank) orders.
    gain_tol : float, optional
        Least strong gain of a target at a frequency (the semantics of
        :func:`~geomfdi.achievable_structures`), default
        :data:`~geomfdi.synthesis.specification.signatures.GAIN_TOL`.

    Returns
    -------
    ndarray of int, (rows,)
        The order :func:`~geomfdi.design_bank` reaches for the row at least order, or −1
        where no residual has that signature (a row of zeros is −1).  With
        ``frequencies``: the least order ν of a residual of the row whose response to each
        target is non-zero at each frequency, −1 where no order has one.

    Notes
    -----
    One quotient and one degree search per row (module Notes); the least order ν is
    certified by the degree-(ν − 1) parity space that misses a target.

    With frequencies Ω, at degree ν the candidate residuals are the parity space ``P_ν``;
    their responses to target j are ``p_j(s)/d(s)`` with the numerator ``p_j = v G_j``
    linear in ``v ∈ P_ν`` and ``d(s) = Π (s − λ_i)`` from the design's stable poles, never
    zero on the stability boundary.  So the least strong order is::

        ν_s = min { ν ≥ ν_w : ∀ j ∈ targets, ∀ ω ∈ Ω :  p_j(λ_ω) ≢ 0 on P_ν },
        λ_ω = iω  (or e^{iω dt}),

    with ν_w the least weak order: a generic vector of ``P_ν`` avoids the finitely many
    proper subspaces ``{v : p_j(λ_ω) = 0}``.  ``P_ν`` does not depend on the poles, only
    ``d`` does, so the choice of poles does not change ν_s.  A row whose target has a
    strong gain ``<= gain_tol`` at some ω (an invariant zero of the decoupled fault
    channel at λ_ω) is −1: no order helps.  The weak order (``frequencies=None``)
    reports a row that is strong only at a higher order at its least weak order.

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> plant = gf.Plant([[-1.0, 1.0], [0.0, -2.0]], None, np.eye(2))
    >>> faults = [gf.SensorFault(0), gf.SensorFault(1)]
    >>> gf.structure_orders(plant, faults, [[1, 1], [0, 1], [1, 0]]).tolist()
    [1, 1, 2]
    >>> gf.structure_orders(plant, faults, [[1, 1], [0, 1], [1, 0]], frequencies=[0]).tolist()
    [1, 1, 2]
    """
    model = spec_model(plant, faults)
    rows = as_structure(S, model.nf)
    orders = row_orders(model, rows, frequencies=frequencies, gain_tol=gain_tol)
    return np.array([r.order for r in orders], dtype=int)
