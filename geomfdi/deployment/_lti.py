"""The one place deployment imports the loop-free LTI core from.

``discretize_hold``: exact sampling of ``x' = A x + B u`` for a held input;
``schur_form``: ``Ad = Z T Z^H`` with ``T`` upper triangular and ``Z`` unitary;
``triangular_recursion``: ``z[k+1] = T z[k] + g[k]`` by back-substitution, one compiled
``lfilter`` call per state over the whole time axis (no per-sample loop).
"""

from __future__ import annotations

from geomfdi.simulation.lti import discretize as discretize_hold
from geomfdi.simulation.lti import schur_form, triangular_recursion

__all__ = ["discretize_hold", "schur_form", "triangular_recursion"]
