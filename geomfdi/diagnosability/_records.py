"""The frozen record of a window model that the stacking, index, table and applicability
functions take, so that they never import the
:class:`~geomfdi.diagnosability.model.WindowModel` object back.

See the user guide, *Theory: diagnosability* (``docs/theory/diagnosability.md``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np

from geomfdi._validation import as_index, as_vector
from geomfdi.errors import GeomFDIError

__all__ = ["CosineConvention", "NullSpaceMethod", "TableMethod", "WindowData", "WindowSizes"]

NullSpaceMethod = Literal["structured", "direct"]
CosineConvention = Literal["absolute", "signed"]
TableMethod = Literal["kl", "directional", "probability", "probability_index"]

NULLSPACE_METHODS = ("structured", "direct")


def nullspace_choice(method: Any, argument: str) -> str:
    """``method`` checked to be one of :data:`NULLSPACE_METHODS` (``argument`` names it)."""
    if not isinstance(method, str) or method not in NULLSPACE_METHODS:
        raise GeomFDIError(
            f"{argument}: must be one of {NULLSPACE_METHODS}, got {method!r}", argument=argument
        )
    return method


class WindowSizes:
    """The sizes ``n``, ``m``, ``p`` of a window model from its ``A``, ``C`` and ``Bf``."""

    A: np.ndarray
    C: np.ndarray
    Bf: np.ndarray

    @property
    def n(self) -> int:
        """Number of states."""
        return self.A.shape[0]

    @property
    def m(self) -> int:
        """Number of outputs."""
        return self.C.shape[0]

    @property
    def p(self) -> int:
        """Number of (scalar) faults."""
        return self.Bf.shape[1]


@dataclass(frozen=True, eq=False)
class WindowData(WindowSizes):
    """The validated matrices of a window model (Li, Wang & Liu 2015, eq. 1), its window
    length, fault names and default null-space path, and a cache of the whitened fault
    maps (per null-space path) and of ``rank O_s``.  Built by
    :class:`~geomfdi.diagnosability.model.WindowModel`; the arrays are read-only."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    Bf: np.ndarray
    Df: np.ndarray
    Bw: np.ndarray
    Dv: np.ndarray
    Dw: np.ndarray
    Qw: np.ndarray
    Rv: np.ndarray
    window: int
    fault_names: tuple[str, ...]
    nullspace: str
    cache: dict[str, Any] = field(default_factory=dict, repr=False)

    def nullspace_method(self, method: str | None) -> str:
        """``method`` checked (default: the model's ``nullspace``)."""
        if method is None:
            return self.nullspace
        return nullspace_choice(method, "method")

    def fault_index(self, i: Any, name: str = "i") -> int:
        """A fault index checked against ``p``."""
        return as_index(i, name, self.p)

    def profile(self, theta: Any, name: str = "theta") -> np.ndarray:
        """A fault profile checked to have the window's length."""
        return as_vector(theta, name, length=self.window)
