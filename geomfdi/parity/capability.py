"""Isolation capability of a sensor configuration (``w_ii``, angles, GDOP, pairs).

See the user guide, *Theory: parity space* (``docs/theory/parity-space.md``).
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING

import numpy as np

from geomfdi.parity._records import ParityData, as_data
from geomfdi.parity.configs import axis_cosines
from geomfdi.parity.multiple import _subset_info
from geomfdi.parity.results import ConfigurationCapability
from geomfdi.tolerance import rank_decision

if TYPE_CHECKING:
    from geomfdi.parity._records import HasParityData

__all__ = ["capability"]


def capability(pf: ParityData | HasParityData) -> ConfigurationCapability:
    """Isolation-capability figures (``w_ii``, angles, GDOP, identifiable pairs).

    Returns
    -------
    ConfigurationCapability
        See its attributes; ``.summary()`` gives a text report.

    References
    ----------
    Zhang, Chen & Liu (2005), Lemmas 1-2 (``0 < w_ii < 1``, ``V_i^T V_j = w_ij``).

    Examples
    --------
    >>> import geomfdi as gf
    >>> cap = gf.ParityFDI(gf.parity.dodecahedron()).capability()
    >>> [round(float(x), 6) for x in cap.w[:2]], cap.isolable.all()
    ([0.5, 0.5], np.True_)
    >>> print(cap.summary().splitlines()[-1])
    pairs confusable with a disjoint pair for some fault sizes: 15/15 (not isolable for those sizes)
    """
    pf = as_data(pf)
    Om = pf.Omega
    w = pf.w
    k = pf.k
    with np.errstate(invalid="ignore", divide="ignore"):
        den = np.sqrt(np.outer(w, w))
        cos = np.where(den > 0, Om / np.where(den > 0, den, 1.0), 0.0)
    cos = np.clip(cos, -1.0, 1.0)
    sep = np.degrees(np.arccos(np.abs(cos)))
    np.fill_diagonal(sep, 0.0)
    pair_id = np.zeros((k, k), dtype=bool)
    if k >= 2:
        info = _subset_info(pf, 2)
        ok = info["valid"] & ~info["ambiguous"]
        S = info["subsets"]
        pair_id[S[:, 0], S[:, 1]] = ok
        pair_id[S[:, 1], S[:, 0]] = ok
    confusable = _confusable_pairs(pf) if k >= 4 else np.zeros((k, k), dtype=bool)
    HtH = pf.H.T @ pf.H
    gdop = float(np.sqrt(np.trace(np.linalg.inv(HtH))))
    return ConfigurationCapability(
        w=w.copy(),
        parity_cos=cos,
        separation_deg=sep,
        axis_cos=axis_cosines(pf.H),
        gdop=gdop,
        dof=pf.s,
        detectable=pf.detectable.copy(),
        isolable=pf.isolable.copy(),
        pair_identifiable=pair_id,
        pair_confusable=confusable,
    )


_MAX_PAIR_QUADS = 200_000


def _confusable_pairs(pf: ParityData) -> np.ndarray | None:
    """Pairs {i, j} whose span meets the span of a disjoint pair {k, l} (rank < 4)."""
    k, s = pf.k, pf.s
    out = np.zeros((k, k), dtype=bool)
    det = np.flatnonzero(pf.detectable)
    if s < 4:  # two planes in R^s, s <= 3, always share a line
        out[np.ix_(det, det)] = True
        np.fill_diagonal(out, False)
        return out
    quads = np.array(list(itertools.combinations(det, 4)), dtype=np.intp).reshape(-1, 4)
    if 3 * quads.shape[0] > _MAX_PAIR_QUADS:
        return None
    sv = np.linalg.svd(pf.G[:, quads].transpose(1, 0, 2), compute_uv=False)
    dep = np.array([rank_decision(x, pf.scaleG, pf.m, warn=False).rank < 4 for x in sv])
    for a, b, c, d in quads[dep]:  # the three ways of splitting {a, b, c, d} into pairs
        for (i, j), (p, q) in (((a, b), (c, d)), ((a, c), (b, d)), ((a, d), (b, c))):
            out[i, j] = out[j, i] = out[p, q] = out[q, p] = True
    return out
