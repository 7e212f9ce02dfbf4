"""Least orders of the rows of a structure matrix, before a design.

See the user guide, *Theory: achievable signatures* (``docs/theory/achievable-signatures.md``)
and *Theory: least-order synthesis* (``docs/theory/least-order.md``).

Each row is decided exactly as the design decides it: the balanced model, the quotient by
S* of the decoupled signals (:mod:`geomfdi.synthesis.least_order.quotient`) and the degree
search of :func:`geomfdi.synthesis.least_order.search.least_order_row`, whose certificate
states that the parity space of one degree less sees no residual with every target (Varga's
``fdichkspec(…; minimal = true)`` answers the same question by minimal-basis degrees).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from geomfdi._validation import as_real_array
from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.synthesis.specification.model import SpecModel, quotient_of, spec_model

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


def _row_order(model: SpecModel, row: np.ndarray) -> RowOrder:
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
    return RowOrder(int(lo.order), str(lo.certificate.get("statement", "")))


def row_orders(model: SpecModel, S: np.ndarray) -> list[RowOrder]:
    """:class:`RowOrder` of each row of the bool array S on a prepared model."""
    return [_row_order(model, row) for row in S]


def structure_orders(plant: Any, faults: Any, S: Any) -> np.ndarray:
    """Least order of a scalar residual achieving each row of ``S`` (−1: infeasible).

    Parameters
    ----------
    plant : Plant or control.StateSpace
        Disturbances are always decoupled; a static plant (n = 0) is accepted.
    faults : list of Fault
    S : array_like of 0/1, (rows, len(faults))
        ``S[r, j] = 1``: row r sees fault j; 0: decouples it.

    Returns
    -------
    ndarray of int, (rows,)
        The order :func:`~geomfdi.design_bank` reaches for the row at least order, or −1
        where no residual has that signature (a row of zeros is −1).

    Notes
    -----
    One quotient and one degree search per row (module Notes); the least order ν is
    certified by the degree-(ν − 1) parity space that misses a target.  Orders of the
    weak (normal-rank) problem: a row that is strong only at a higher order is reported
    at its least weak order.

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> plant = gf.Plant([[-1.0, 1.0], [0.0, -2.0]], None, np.eye(2))
    >>> faults = [gf.SensorFault(0), gf.SensorFault(1)]
    >>> gf.structure_orders(plant, faults, [[1, 1], [0, 1], [1, 0]]).tolist()
    [1, 1, 2]
    """
    model = spec_model(plant, faults)
    rows = as_structure(S, model.nf)
    return np.array([r.order for r in row_orders(model, rows)], dtype=int)
