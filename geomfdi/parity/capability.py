"""Isolation capability of a sensor configuration (``w_ii``, angles, GDOP, pairs).

See the user guide, *Theory: parity space* (``docs/theory/parity-space.md``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from geomfdi.parity.configs import axis_cosines
from geomfdi.parity.multiple import _subset_info
from geomfdi.parity.results import ConfigurationCapability

if TYPE_CHECKING:
    from geomfdi.parity.model import ParityFDI

__all__ = ["capability"]


def capability(pf: ParityFDI) -> ConfigurationCapability:
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
    """
    Om = pf._Omega
    w = pf._w
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
    )
