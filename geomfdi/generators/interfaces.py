"""What the bank functions read of a generator and a bank (structural types).

:mod:`~geomfdi.generators.bankfile` and :mod:`~geomfdi.generators.discretize` are plain
functions called by :class:`~geomfdi.generators.generator.ResidualBank` (``bank.save``,
``bank.discretize``); they are typed against these protocols, not against the object
module, so the objects call the functions and the functions never import the objects
back.  :class:`~geomfdi.generators.generator.ResidualGenerator` and
:class:`~geomfdi.generators.generator.ResidualBank` satisfy them.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

import numpy as np

__all__ = ["GeneratorLike", "BankLike"]


class GeneratorLike(Protocol):
    """A generator ``w' = F w - E y + G u``, ``r = M w - H y + K u`` and its labels."""

    F: np.ndarray
    E: np.ndarray
    G: np.ndarray
    M: np.ndarray
    H: np.ndarray
    K: np.ndarray
    dt: float
    target: tuple[int, ...]
    decoupled: tuple[int, ...]
    method: str
    info: dict[str, Any]

    @property
    def order(self) -> int: ...

    @property
    def q(self) -> int: ...


class BankLike(Protocol):
    """A bank: generators aligned with the rows of its structure, and its labels."""

    @property
    def generators(self) -> Sequence[Any]: ...

    requested: np.ndarray
    structure: np.ndarray
    isolable: np.ndarray
    diagnostics: list[str]
    faults: list[Any]
    dt: float
    method: str
    info: dict[str, Any]
