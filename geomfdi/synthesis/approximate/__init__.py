"""Approximate synthesis: noise attenuated instead of decoupled (Varga 2017, §5.3, §5.5).

* :mod:`~geomfdi.synthesis.approximate.nullspace` -- the exact decoupling basis ``Q1`` of
  ``u``, ``d`` and the non-target faults, the channels it leaves, normal rank.
* :mod:`~geomfdi.synthesis.approximate.factorization` -- quasi-co-outer–co-inner
  factorisation of the noise channel (Riccati; regularised in the non-standard case).
* :mod:`~geomfdi.synthesis.approximate.gap_design` -- one AFD/AFDI row maximising the
  fault-to-noise gap.
* :mod:`~geomfdi.synthesis.approximate.measure` -- β, γ, gap and leaks of a generator.
* :mod:`~geomfdi.synthesis.approximate.multimodel` -- the robust design over several models.
* :mod:`~geomfdi.synthesis.approximate.bank` -- the front end behind
  ``design_residual_generator(..., objective="gap")`` and ``design_bank(..., objective="gap")``.
* :mod:`~geomfdi.synthesis.approximate.estimation` -- fault estimators (model matching).

It may import :mod:`geomfdi.model`, :mod:`geomfdi.generators` (with the H∞ routine
:func:`geomfdi.generators.norms.hinf_norm`), :mod:`geomfdi.tolerance` and the least-order
row builders of :mod:`geomfdi.synthesis` (``build``, ``multirow``, ``least_order``,
lazily), never :mod:`geomfdi.verification`; the front end :mod:`geomfdi.synthesis.design`
imports it lazily, never the other way round.  See *Theory: approximate synthesis*
(``docs/theory/approximate-synthesis.md``).
"""

from geomfdi.synthesis.approximate.bank import gap_bank, gap_residual_generator
from geomfdi.synthesis.approximate.estimation import design_fault_estimator
from geomfdi.synthesis.approximate.factorization import CoOuterFactor, co_outer_factor

__all__ = [
    "gap_bank",
    "gap_residual_generator",
    "design_fault_estimator",
    "co_outer_factor",
    "CoOuterFactor",
]
