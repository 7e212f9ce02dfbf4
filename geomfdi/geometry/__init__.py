"""Geometric approach: subspace algebra and the invariant subspaces of the design.

* :mod:`~geomfdi.geometry.subspace` -- :class:`Subspace`, kernel, image, preimage, sums,
  intersections (orthonormal SVD bases, one rank policy).
* :mod:`~geomfdi.geometry.conditioned_invariant` -- W*, the minimal (C, A)-conditioned
  invariant subspace (Algorithm 1), friends.
* :mod:`~geomfdi.geometry.unobservability` -- S*, the minimal unobservability subspace
  (Algorithm 2).
* :mod:`~geomfdi.geometry.exact` -- the same algorithms in exact rational arithmetic (sympy).

Layer: directly on the base modules (``errors``, ``tolerance``, ``_validation``); it
imports no other subpackage.
"""

from geomfdi.geometry.conditioned_invariant import (
    FriendSet,
    InvariantSubspace,
    friend,
    friends,
    is_conditioned_invariant,
    min_conditioned_invariant,
)
from geomfdi.geometry.subspace import Subspace, apply, image, kernel, preimage, principal_angles
from geomfdi.geometry.unobservability import (
    is_unobservability_subspace,
    measurement_map,
    min_unobservability_subspace,
    unobservable_subspace,
)

__all__ = [
    "Subspace",
    "apply",
    "image",
    "kernel",
    "preimage",
    "principal_angles",
    "InvariantSubspace",
    "FriendSet",
    "friend",
    "friends",
    "is_conditioned_invariant",
    "min_conditioned_invariant",
    "min_unobservability_subspace",
    "is_unobservability_subspace",
    "measurement_map",
    "unobservable_subspace",
]
