"""The one place deployment imports the loop-free LTI core from.

``discretize_hold``: exact sampling of ``x' = A x + B u`` for a held input;
``linear_recursion``: ``x[k+1] = Ad x[k] + f[k]`` solved without a per-sample loop.
"""

from __future__ import annotations

from geomfdi.simulation.lti import discretize as discretize_hold
from geomfdi.simulation.lti import linear_recursion

__all__ = ["discretize_hold", "linear_recursion"]
