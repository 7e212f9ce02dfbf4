"""Residual generators and banks: the objects every stage after the synthesis consumes.

This layer holds :class:`ResidualGenerator` and :class:`ResidualBank`
(:mod:`~geomfdi.generators.generator`), their exact counterparts
(:mod:`~geomfdi.generators.exact`), the versioned bank file format
(:mod:`~geomfdi.generators.bankfile`), sampling a continuous bank
(:mod:`~geomfdi.generators.discretize`), minimal realisations
(:mod:`~geomfdi.generators.realization`), the transfer gains of a generator on the
physical plant (:mod:`~geomfdi.generators.gains`, with the resolvents at many points it
shares across a bank's rows in :mod:`~geomfdi.generators.resolvents`) and the system
norms (H∞ norm, H₋ index, peak-to-peak gain: :mod:`~geomfdi.generators.norms`, which
both the approximate synthesis and the verification use).  It may import
:mod:`geomfdi.model`, :mod:`geomfdi.geometry` and the package's base modules
(``errors``, ``tolerance``, ``_validation``), never :mod:`geomfdi.synthesis`; simulation,
verification, evaluation, deployment and campaigns import the generator types from here,
not from the design code.
"""

from geomfdi.generators.exact import (
    ExactResidualBank,
    ExactResidualGenerator,
    ExceptionalCondition,
)
from geomfdi.generators.generator import ResidualBank, ResidualGenerator
from geomfdi.generators.realization import minimal_realization, reachable_subspace

__all__ = [
    "ResidualGenerator",
    "ResidualBank",
    "ExactResidualGenerator",
    "ExactResidualBank",
    "ExceptionalCondition",
    "minimal_realization",
    "reachable_subspace",
]
