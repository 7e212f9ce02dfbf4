"""Isolability of a fault set before design, and a suggested structure matrix.

See the user guide, *Choosing a structure* (``docs/guide/choosing-a-structure.md``) and
*Theory: achievable signatures* (``docs/theory/achievable-signatures.md``).

From the achievable signatures (weak, or strong at the given frequencies):

* **classes**: faults whose columns agree in *every* achievable signature; no bank, of
  any order, tells them apart;
* **contained columns**: fault i is *inside* fault j when every achievable signature that
  sees i also sees j (a bank can separate them only by rows that see j and not i);
* **suggested structure**: the achievable rows of least total order (each at its least
  order, :mod:`geomfdi.synthesis.specification.orders`) such that every detectable fault
  has a non-zero column and the columns of faults in different classes differ.  This is a
  weighted test-cover problem, solved exactly by branch and bound on the pairs still to
  separate (the generalised and dedicated observer schemes are candidates like any other
  set of rows; their total orders are reported for comparison).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from geomfdi.synthesis.specification.orders import as_structure, row_orders
from geomfdi.synthesis.specification.signatures import AchievableSignatures, achievable_signatures

__all__ = [
    "IsolabilityReport",
    "Scheme",
    "isolability_analysis",
    "identical_columns",
    "contained_columns",
    "COVER_NODES",
]

COVER_NODES = 200_000
"""Branch-and-bound nodes after which the best structure found so far is returned
(``IsolabilityReport.optimal`` is then False)."""


def identical_columns(S: np.ndarray, faults: list[int] | None = None) -> list[tuple[int, ...]]:
    """Groups (of two or more) of faults whose columns of the bool matrix S are identical.

    ``faults``: the columns considered (default all); a zero column is grouped too.
    """
    cols = range(S.shape[1]) if faults is None else faults
    groups: dict[bytes, list[int]] = {}
    for j in cols:
        groups.setdefault(np.asarray(S[:, j], dtype=bool).tobytes(), []).append(int(j))
    return [tuple(g) for g in groups.values() if len(g) > 1]


def contained_columns(S: np.ndarray, faults: list[int] | None = None) -> list[tuple[int, int]]:
    """Pairs ``(i, j)`` with column i of S strictly inside column j (non-zero column i)."""
    cols = list(range(S.shape[1])) if faults is None else list(faults)
    S = np.asarray(S, dtype=bool)
    out = []
    for i in cols:
        if not S[:, i].any():
            continue
        for j in cols:
            if i != j and np.all(S[:, i] <= S[:, j]) and np.any(S[:, j] & ~S[:, i]):
                out.append((i, j))
    return out


@dataclass(frozen=True)
class Scheme:
    """A candidate structure matrix and its cost."""

    name: str
    structure: np.ndarray
    orders: np.ndarray | None
    """Least order per row; ``None`` when a row is not achievable."""
    isolates: bool
    """Every isolable fault has a non-zero column distinct from every other fault's."""
    note: str = ""

    @property
    def total_order(self) -> int | None:
        return None if self.orders is None else int(self.orders.sum())


@dataclass
class IsolabilityReport:
    """Result of :func:`isolability_analysis`."""

    names: list[str]
    achievable: AchievableSignatures
    S: np.ndarray
    """The achievable signatures the analysis used (strong with frequencies, else weak)."""
    orders: np.ndarray
    """Least order of each row of ``S`` (−1: the row could not be decided numerically)."""
    detectable: np.ndarray
    classes: list[tuple[int, ...]]
    """Faults that no bank can tell apart (identical columns in every achievable row)."""
    contained: list[tuple[int, int]]
    """``(i, j)``: every achievable row that sees fault i also sees fault j."""
    isolable: np.ndarray
    """Detectable and alone in its class."""
    suggested: Scheme
    schemes: dict[str, Scheme]
    """``"generalised observer scheme"``, ``"dedicated observer scheme"``, ``"suggested"``
    and, with ``structure=``, ``"requested"``."""
    optimal: bool
    notes: list[str] = field(default_factory=list)

    def summary(self) -> str:
        """A readable account of the analysis (printed by the examples)."""
        nm = self.names
        a = self.achievable
        kind = (
            "weak (normal rank)"
            if a.frequencies is None
            else f"strong at ω = {a.frequencies.tolist()} rad/s (gain above {a.gain_tol:g})"
        )
        lines = [f"{len(self.S)} achievable signatures, {kind}; {len(a.weak)} weak in all"]
        und = [nm[j] for j in np.flatnonzero(~self.detectable)]
        if und:
            lines.append(f"not detectable: {und}")
        for c in self.classes:
            lines.append(f"never told apart (identical columns): {[nm[j] for j in c]}")
        for i, j in self.contained:
            lines.append(
                f"column of {nm[i]!r} inside that of {nm[j]!r}: every residual that sees "
                f"{nm[i]!r} also sees {nm[j]!r}"
            )
        if not self.classes and not und:
            lines.append("every fault is isolable")
        else:
            iso = [nm[j] for j in np.flatnonzero(self.isolable)]
            lines.append(f"isolable: {iso if iso else 'none'}")
        for sch in self.schemes.values():
            cost = "not achievable" if sch.orders is None else f"total order {sch.total_order}"
            lines.append(
                f"{sch.name}: {sch.structure.shape[0]} rows, {cost}"
                + ("" if sch.isolates else ", does not isolate every isolable fault")
                + (f" ({sch.note})" if sch.note else "")
            )
        lines += self.notes
        return "\n".join(lines)


def _pairs(det: list[int], cls_of: dict[int, int]) -> list[tuple[int, int]]:
    """Elements to cover: (j, -1) detect j; (a, b) separate a and b (different classes)."""
    out = [(j, -1) for j in det]
    out += [(a, b) for k, a in enumerate(det) for b in det[k + 1 :] if cls_of[a] != cls_of[b]]
    return out


def _masks(S: np.ndarray, elems: list[tuple[int, int]]) -> list[int]:
    masks = []
    for row in S:
        m = 0
        for e, (a, b) in enumerate(elems):
            if (row[a] if b < 0 else row[a] != row[b]) and True:
                m |= 1 << e
        masks.append(m)
    return masks


def _min_cover(masks: list[int], costs: list[int], universe: int) -> tuple[list[int], bool]:
    """Least-cost set of rows covering ``universe`` (branch and bound on the element with
    the fewest covering rows); returns (rows, proven optimal)."""
    nel = universe.bit_length()
    cover = [sorted((r for r, m in enumerate(masks) if m >> e & 1), key=lambda r: costs[r])
             for e in range(nel)]  # fmt: skip
    cheapest = [costs[c[0]] if c else None for c in cover]
    best: list[Any] = [None, float("inf")]
    nodes = [0]
    # greedy start: most newly covered elements per unit cost
    covered, chosen = 0, []
    while covered != universe:
        r = max(
            range(len(masks)),
            key=lambda r: (bin(masks[r] & ~covered).count("1") / (costs[r] + 1), -costs[r]),
        )
        if not masks[r] & ~covered:
            return [], True
        chosen.append(r)
        covered |= masks[r]
    best[:] = [list(chosen), sum(costs[r] for r in chosen)]

    def rec(cov: int, rows: list[int], cost: int) -> None:
        if cov == universe:
            if cost < best[1]:
                best[:] = [list(rows), cost]
            return
        nodes[0] += 1
        if nodes[0] > COVER_NODES:
            return
        unc = [e for e in range(nel) if (universe & ~cov) >> e & 1]
        lb = max(cheapest[e] for e in unc)
        if cost + lb >= best[1]:
            return
        e = min(unc, key=lambda e: len(cover[e]))
        for r in cover[e]:
            if cost + costs[r] >= best[1]:
                break
            rows.append(r)
            rec(cov | masks[r], rows, cost + costs[r])
            rows.pop()

    rec(0, [], 0)
    return sorted(best[0]), nodes[0] <= COVER_NODES


def _isolates(S: np.ndarray, det: list[int], cls_of: dict[int, int]) -> bool:
    for a in det:
        if not S[:, a].any():
            return False
        for b in det:
            if cls_of[a] != cls_of[b] and np.array_equal(S[:, a], S[:, b]):
                return False
    return True


def _scheme(
    name: str,
    Sc: np.ndarray,
    lookup: dict[bytes, int],
    det: list[int],
    cls_of: dict[int, int],
    model: Any,
    weak_rows: set[bytes],
) -> Scheme:
    missing = [i for i, row in enumerate(Sc) if row.tobytes() not in lookup]
    if missing:
        weak = [i for i in missing if Sc[i].tobytes() in weak_rows]
        none = [i for i in missing if i not in weak]
        note = "; ".join(
            text
            for text in (
                f"rows {none} not achievable" if none else "",
                f"rows {weak} achievable in the weak sense only (not strong)" if weak else "",
            )
            if text
        )
        return Scheme(name, Sc, None, _isolates(Sc, det, cls_of), note)
    orders = np.array([lookup[row.tobytes()] for row in Sc], dtype=int)
    if np.any(orders < 0):
        orders = np.array([r.order for r in row_orders(model, Sc)], dtype=int)
    return Scheme(name, Sc, orders if np.all(orders >= 0) else None, _isolates(Sc, det, cls_of))


def isolability_analysis(
    plant: Any,
    faults: Any,
    *,
    frequencies: Any = None,
    gain_tol: float | None = None,
    structure: Any = None,
) -> IsolabilityReport:
    """Which faults can be isolated, which never, and the cheapest structure that isolates.

    Parameters
    ----------
    plant : Plant or control.StateSpace
    faults : list of Fault
    frequencies, gain_tol
        As in :func:`~geomfdi.achievable_structures`: with frequencies, only the strong
        signatures are used (include 0 for constant faults).
    structure : array_like of 0/1, optional
        A requested structure matrix, judged too (``schemes["requested"]``): rows that are
        not achievable, faults it cannot separate (``notes``).

    Returns
    -------
    IsolabilityReport
        ``classes``, ``contained``, ``isolable``, ``suggested`` (a :class:`Scheme`) and the
        generalised / dedicated observer schemes for comparison; ``summary()`` prints them.

    Notes
    -----
    The suggested structure is a least-total-order subset of the achievable rows (module
    Notes); ties go to fewer rows.  The least orders come from
    :func:`~geomfdi.structure_orders` (one degree search per achievable row), with the
    same ``frequencies``: the orders of strong detection when they are given.

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> plant = gf.Plant([[-1.0, 0.0], [0.0, -2.0]], None, np.eye(2))
    >>> rep = gf.isolability_analysis(plant, [gf.SensorFault(0), gf.SensorFault(1)])
    >>> rep.suggested.name, rep.suggested.structure.astype(int).tolist()
    ('suggested (generalised observer scheme)', [[0, 1], [1, 0]])
    """
    from geomfdi.synthesis.specification.model import spec_model

    ach = achievable_signatures(plant, faults, frequencies=frequencies, gain_tol=gain_tol)
    model = spec_model(plant, faults)
    nf = model.nf
    S = ach.structures
    strong = row_orders(model, S, frequencies=frequencies, gain_tol=gain_tol)
    orders = np.array([r.order for r in strong], dtype=int)
    detectable = S.any(axis=0) if len(S) else np.zeros(nf, dtype=bool)
    det = [int(j) for j in np.flatnonzero(detectable)]
    classes = identical_columns(S, det)
    cls_of = {j: j for j in range(nf)}
    for c in classes:
        for j in c:
            cls_of[j] = c[0]
    isolable = detectable & np.array([all(j not in c for c in classes) for j in range(nf)])
    contained = contained_columns(S, det)
    lookup = {row.tobytes(): int(o) for row, o in zip(S, orders, strict=True)}
    weak = {row.tobytes() for row in ach.weak}
    usable = [i for i in range(len(S)) if orders[i] >= 0]
    elems = _pairs(det, cls_of)
    notes: list[str] = []
    optimal = True
    if elems and usable:
        Su = S[usable]
        masks = _masks(Su, elems)
        weight = len(usable) + 1
        costs = [int(orders[i]) * weight + 1 for i in usable]
        universe = 0
        for m in masks:
            universe |= m
        rows, optimal = _min_cover(masks, costs, universe)
        chosen = Su[rows] if rows else S[:0]
        if universe != (1 << len(elems)) - 1:
            notes.append("the usable rows do not separate every pair of isolable faults")
    else:
        chosen = S[:0]
    if not optimal:
        notes.append(f"branch and bound stopped after {COVER_NODES} nodes: best found so far")
    order_key = np.lexsort(np.asarray(chosen, dtype=int).T[::-1]) if len(chosen) else []
    chosen = chosen[order_key][::-1] if len(chosen) else chosen
    schemes = {
        "generalised observer scheme": _scheme(
            "generalised observer scheme", ~np.eye(nf, dtype=bool), lookup, det, cls_of, model, weak
        ),
        "dedicated observer scheme": _scheme(
            "dedicated observer scheme", np.eye(nf, dtype=bool), lookup, det, cls_of, model, weak
        ),
    }
    suggested = _scheme("suggested (least total order)", chosen, lookup, det, cls_of, model, weak)
    for sch in list(schemes.values()):  # a classical scheme at the same cost is preferred
        if (
            sch.isolates
            and sch.orders is not None
            and suggested.orders is not None
            and (sch.total_order, len(sch.orders)) <= (suggested.total_order, len(chosen))
        ):
            suggested = Scheme(f"suggested ({sch.name})", sch.structure, sch.orders, True)
            break
    schemes["suggested"] = suggested
    if structure is not None:
        req = as_structure(structure, nf, "structure")
        schemes["requested"] = _scheme("requested", req, lookup, det, cls_of, model, weak)
        for g in identical_columns(req, det):
            notes.append(
                "requested structure: identical columns for "
                + ", ".join(repr(model.names[j]) for j in g)
                + (" (never separable)" if any(set(g) <= set(c) for c in classes) else "")
            )
        for i, j in contained_columns(req, det):
            notes.append(
                f"requested structure: column of {model.names[i]!r} inside that of "
                f"{model.names[j]!r}"
            )
    return IsolabilityReport(
        names=model.names,
        achievable=ach,
        S=S,
        orders=orders,
        detectable=detectable,
        classes=classes,
        contained=contained,
        isolable=isolable,
        suggested=suggested,
        schemes=schemes,
        optimal=optimal,
        notes=notes,
    )
