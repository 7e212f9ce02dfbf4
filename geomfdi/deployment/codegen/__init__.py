"""Code generation for deployed residual monitors: ``gf.codegen.c`` and ``gf.codegen.python``.

Both emit the per-sample algorithm of :class:`geomfdi.Monitor` for a discrete bank (or a
monitor built on one): C99 with static storage and no ``malloc``, or a single module
that needs numpy only.  See the user guide, *Theory: residual evaluation*
(``docs/theory/evaluation.md``).

Layer: part of :mod:`geomfdi.deployment`; it may import what deployment may.
"""

from geomfdi.deployment.codegen.c import c
from geomfdi.deployment.codegen.python import python

__all__ = ["c", "python"]
