"""The one place deployment imports the loop-free LTI core from.

``discretize_hold``: exact sampling of ``x' = A x + B u`` for a held input;
``schur_form``: ``Ad = Z T Z^H`` with ``T`` upper triangular and ``Z`` unitary;
``lifted_maps`` / ``lifted_recursion``: the outputs and final state of a state-space
recursion on blocks of samples (block products and one compiled ``lfilter`` call per
state over the blocks; no per-sample loop).
"""

from __future__ import annotations

from geomfdi.simulation.lti import discretize as discretize_hold
from geomfdi.simulation.lti import schur_form
from geomfdi.simulation.recursion import LiftedMaps, lift_factor, lifted_maps, lifted_recursion

__all__ = [
    "LiftedMaps",
    "discretize_hold",
    "lift_factor",
    "lifted_maps",
    "lifted_recursion",
    "schur_form",
]
