"""A scalar row realised as the observer of the whole decoupled quotient.

See the user guide, *Theory: least-order synthesis* (``docs/theory/least-order.md``).

With a stabilising injection ``L`` of the quotient ``(A0, M)``
(:func:`geomfdi.synthesis.least_order.injection.stabilising_injection`) and a direction
``w ∈ R^{1×ρ}``, the functional observer of :mod:`geomfdi.synthesis.least_order.search` with::

    T = I,   Λ = A0 − L M,   G_s = L,   c = −w M,   h = w

satisfies ``T A0 − Λ T = G_s M`` and ``c T + h M = 0`` exactly; its residual is
``r = w (z − M ξ̂)`` with the quotient estimate ``ξ̂``: ``ε = ξ̂ − ξ`` obeys
``ε' = (A0 − L M) ε + (L H D_f − B_fq) f``.  The order is k, the quotient's dimension.
It *is* the least order when the least-order row needs the whole quotient (``ν = k``;
always when ``ρ = 1``, e.g. a residual reading a single sensor), otherwise it is the
robust fallback of a high-order row (``info["least_order"]`` then states both orders).

The row direction ``w`` maximises the smallest normalised target gain of the quotient's
target transfers ``G_j(s) = M (sI − A0)⁻¹ B_fj + H D_fj`` at a few points (the same
max–min as the least-order direction): ``w G_j(s) ≡ 0`` iff the row does not see target
j, because ``z − M ξ̂ = (I − M (sI − A0 + L M)⁻¹ L) G_j f`` with an invertible first factor.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi.synthesis.least_order.injection import stabilising_injection
from geomfdi.synthesis.least_order.search import (
    LeastOrderRow,
    Quotient,
    _maxmin_direction,
    _points,
    quotient_target_gains,
)

__all__ = ["quotient_observer_row"]


def quotient_observer_row(
    Qm: Quotient, *, omega: float, dt: float, relax: float, certificate: dict[str, Any]
) -> LeastOrderRow:
    """The quotient observer as a scalar row (module Notes).

    Raises
    ------
    numpy.linalg.LinAlgError
        No stabilising injection at this stability degree.
    """
    k = Qm.k
    L, how = stabilising_injection(Qm.A0, Qm.M, dt=dt, omega=omega, relax=relax)
    grams, _ = quotient_target_gains(Qm, _points(Qm, np.zeros(0), omega, count=4))
    w, val = _maxmin_direction(grams) if grams else (np.ones(Qm.rho), 0.0)
    F = Qm.A0 - L @ Qm.M
    c = -(w @ Qm.M)
    cert = dict(certificate)
    cert["realisation"] = "quotient observer"
    cert["injection"] = how
    cert["min_target_gain"] = float(np.sqrt(max(val, 0.0)))
    return LeastOrderRow(
        k, F, L.copy(), np.eye(k), c, w.copy(), np.linalg.eigvals(F) if k else np.zeros(0), cert
    )
