"""Fault profiles of many runs at once: :func:`fault_profiles`.

A Monte-Carlo sweep simulates runs whose fault lists have the same *structure* (the same
kinds of fault, on the same sensors, with the same activity windows) and differ only in
their sizes (a bias of ``0.01 .. 0.03`` on sensor 1 from ``t = 8``).  The composition of
Hou, Wen & Chen (2011, eq. 3-5), ``y_i = eta_i y_i0 + lambda_i``, is then one update per
fault of the stacked runs (their gains and biases side by side) instead of one
:func:`~geomfdi.simulation.signals.fault_profile` call per run: on the samples where a
fault is active, ``eta <- g eta`` and ``lambda <- g lambda + b``, the same floating-point
operations in the same order as the per-run composition, so the profiles are equal to
it bit for bit.

Fault lists of another structure form their own group; a list with a fault whose profile
is not a pair of numbers (a callable gain or bias, a stuck sensor holding its reading,
a user subclass) is composed run by run (:func:`~geomfdi.simulation.signals.fault_profile`).
See the user guide, *Theory: sensor-fault transforms*
(``docs/theory/sensor-fault-transforms.md``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from geomfdi.errors import GeomFDIError
from geomfdi.simulation.signals import (
    BiasFault,
    GainFault,
    SensorFaultSignal,
    StuckFault,
    fault_profile,
)

__all__ = ["ProfileGroups", "fault_profiles", "profile_groups", "structure_key"]

_PLAIN = (GainFault, BiasFault, StuckFault)


def _values(f: SensorFaultSignal) -> tuple[Any, Any]:
    """``(gain, bias)`` of a fault of the plain kinds while it is active."""
    if type(f) is GainFault:
        return f.gain, f.bias  # type: ignore[attr-defined]
    if type(f) is BiasFault:
        return 1.0, f.bias  # type: ignore[attr-defined]
    return 0.0, f.value  # type: ignore[attr-defined]


def structure_key(faults: Sequence[SensorFaultSignal]) -> tuple[Any, ...] | None:
    """What the profile of a fault list depends on besides its sizes.

    The kinds, sensors and activity windows of the faults, in the list's order; ``None``
    when some fault's profile is not a pair of numbers while it is active (a callable
    gain or bias, a stuck sensor holding its reading, a subclass with its own rules):
    such a list is composed on its own.
    """
    key = []
    for f in faults:
        if type(f) not in _PLAIN or f.holds_reading:
            return None
        if any(callable(v) for v in _values(f)):
            return None
        key.append((type(f), f.sensor, f.start, f.end))
    return tuple(key)


@dataclass(frozen=True)
class ProfileGroups:
    """The runs of a list of fault lists grouped by :func:`structure_key`.

    Attributes
    ----------
    groups : list of (ndarray, list, list)
        Per structure: the runs (indices), the fault list of its first run (the kinds,
        sensors and windows of all), and per position in the list the gains and
        biases of the runs ``(G, 1)``.
    alone : list of int
        The runs composed one by one.
    """

    groups: list[tuple[np.ndarray, Sequence[SensorFaultSignal], list[tuple[np.ndarray, ...]]]]
    alone: list[int]


def profile_groups(fault_lists: Sequence[Sequence[SensorFaultSignal]]) -> ProfileGroups:
    """Group runs by the structure of their fault lists (see :class:`ProfileGroups`);
    a simulation groups its runs once and composes every time window with the groups."""
    by_key: dict[Any, list[int]] = {}
    alone: list[int] = []
    for r, fl in enumerate(fault_lists):
        key = structure_key(fl)
        if key is None:
            alone.append(r)
        else:
            by_key.setdefault(key, []).append(r)
    groups = []
    for idx in by_key.values():
        first = fault_lists[idx[0]]
        values = []
        for pos in range(len(first)):
            vals = np.array([_values(fault_lists[r][pos]) for r in idx], dtype=float)
            values.append((vals[:, :1], vals[:, 1:]))  # one gain and one bias per run
        groups.append((np.array(idx, dtype=np.intp), first, values))
    return ProfileGroups(groups, alone)


def fault_profiles(
    fault_lists: Sequence[Sequence[SensorFaultSignal]],
    t: np.ndarray,
    y0: np.ndarray | None,
    *,
    q: int,
    k0: int,
    k1: int,
    holds: Sequence[dict[int, np.ndarray]],
    sensors: Sequence[int],
    y0_start: int = 0,
    groups: ProfileGroups | None = None,
    out: tuple[np.ndarray, ...] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``eta, eta_left, lam, lam_left`` (rows, R, L) of ``R`` runs' fault lists.

    Each run's slice equals :func:`~geomfdi.simulation.signals.fault_profile` of its
    list on the window ``k0 .. k1-1`` (rows of ``sensors``), bit for bit; runs of the
    same :func:`structure_key` are composed together (module docstring).

    Parameters
    ----------
    fault_lists : sequence of sequences of SensorFaultSignal
        One validated list per run.
    t : ndarray, (N,)
        The increasing time grid (a plain fault is active on one interval of it).
    y0 : ndarray, (R | 1, q, L0) or None
        Healthy readings from sample ``y0_start`` on (read by the runs composed one by
        one: a stuck sensor holding its reading).
    q : int
    k0, k1 : int
    holds : sequence of dict
        Per run, the held readings (updated in place; see ``fault_profile``).
    sensors : sequence of int
        The rows (every faulty sensor among them).
    y0_start : int
    groups : ProfileGroups, optional
        :func:`profile_groups` of ``fault_lists`` (computed when not given).
    out : tuple of 4 ndarray, optional
        Arrays of shape (rows, R, L) to fill and return (a simulation reuses them
        window after window); new ones when not given or of another shape.
    """
    R, L = len(fault_lists), k1 - k0
    rows = [int(i) for i in sensors]
    where = {s: j for j, s in enumerate(rows)}
    nq = len(rows)
    groups = profile_groups(fault_lists) if groups is None else groups
    if out is not None and all(x.shape == (nq, R, L) for x in out):
        eta, eta_l, lam, lam_l = out
        eta.fill(1.0)
        eta_l.fill(1.0)
        lam.fill(0.0)
        lam_l.fill(0.0)
    else:
        eta, eta_l = np.ones((nq, R, L)), np.ones((nq, R, L))
        lam, lam_l = np.zeros((nq, R, L)), np.zeros((nq, R, L))
    for idx, first, values in groups.groups:
        if idx.size == R:  # one structure (the usual sweep): in place
            _compose(first, values, t, k0, k1, where, (eta, eta_l, lam, lam_l))
            continue
        part = (np.ones((nq, idx.size, L)), np.ones((nq, idx.size, L)))
        part += (np.zeros((nq, idx.size, L)), np.zeros((nq, idx.size, L)))
        _compose(first, values, t, k0, k1, where, part)
        for full, p in zip((eta, eta_l, lam, lam_l), part, strict=True):
            full[:, idx] = p
    for r in groups.alone:
        y0r = None if y0 is None else y0[r : r + 1] if y0.shape[0] > 1 else y0
        pr = fault_profile(
            fault_lists[r],
            t,
            y0r,
            q=q,
            k0=k0,
            k1=k1,
            holds=holds[r],
            sensors=rows,
            y0_start=y0_start,
        )
        eta[:, r], eta_l[:, r] = pr.eta, pr.eta_left
        lam[:, r], lam_l[:, r] = pr.lam[-1], pr.lam_left[-1]
    return eta, eta_l, lam, lam_l


def _compose(
    first: Sequence[SensorFaultSignal],
    values: list[tuple[np.ndarray, ...]],
    t: np.ndarray,
    k0: int,
    k1: int,
    where: dict[int, int],
    out: tuple[np.ndarray, ...],
) -> None:
    """Compose the fault lists of one structure (``first``'s faults with the runs'
    ``values``) into ``out = (eta, eta_l, lam, lam_l)`` (rows, G, L), as
    ``fault_profile`` does run by run."""
    eta, eta_l, lam, lam_l = out
    L = k1 - k0
    lo = max(k0 - 1, 0)
    for f, (g, bias) in zip(first, values, strict=True):
        if f.sensor not in where:
            raise GeomFDIError(
                f"sensors: {list(where)} must include every faulty sensor", argument="sensors"
            )
        mw = f.mask(t[lo:k1])  # the window and the sample before it (left limit at k0)
        m = mw[k0 - lo :]
        prev = mw[:-1] if k0 > 0 else np.concatenate([mw[:1], mw[:-1]])
        on = m | prev
        if not on.any():
            continue
        i = where[f.sensor]
        unit = bool(np.all(g == 1.0))  # x * 1 == x: a bias fault leaves eta alone
        for ek, lk, mk in ((eta, lam, m), (eta_l, lam_l, prev)):
            # the active samples of a plain fault are one interval of the window
            if not mk.any():
                continue
            sl = slice(int(np.argmax(mk)), L - int(np.argmax(mk[::-1])))
            if not unit:
                ek[i, :, sl] *= g
                lk[i, :, sl] *= g
            lk[i, :, sl] += bias
