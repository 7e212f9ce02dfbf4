"""Exceptions raised by geomfdi.

Every error geomfdi raises on bad input or an impossible design derives from
:class:`GeomFDIError`, itself a :class:`ValueError`, so callers may catch either.
Messages name the offending argument and say what was wrong with it.
"""

from __future__ import annotations

import re

__all__ = [
    "GeomFDIError",
    "ShapeError",
    "NonFiniteError",
    "ComplexInputError",
    "DesignError",
    "NotIsolableError",
    "RankDeficientError",
    "ModelFileError",
    "TimeGridError",
    "NotDiscreteError",
    "BankFileError",
    "SchemaVersionError",
    "ResourceLimitError",
    "CampaignIncompleteError",
    "IsolabilityWarning",
    "BackendFallbackWarning",
]


_NP_SCALAR = re.compile(r"\bnp\.(?:float|int|uint|complex|bool|str)_?\d*\(([^()]*)\)")
_NP_BOOL = re.compile(r"\bnp\.(True|False)_")


def plain_numbers(text: str) -> str:
    """``text`` with numpy scalar reprs (``np.float64(0.5)``, ``np.True_``) written as the
    plain numbers (``0.5``, ``True``) a user typed: messages quote values with ``!r``."""
    if "np." not in text:
        return text
    return _NP_BOOL.sub(r"\1", _NP_SCALAR.sub(r"\1", text))


class GeomFDIError(ValueError):
    """Base class of all geomfdi input and design errors.

    Attributes
    ----------
    argument : str or None
        Name of the argument at fault, when there is one.
    """

    def __init__(self, message: str, *, argument: str | None = None) -> None:
        super().__init__(plain_numbers(message))
        self.argument = argument


class ShapeError(GeomFDIError):
    """An array has the wrong shape, is empty, or two arrays do not conform."""


class NonFiniteError(GeomFDIError):
    """An array contains ``nan`` or ``inf``."""


class ComplexInputError(GeomFDIError):
    """An array that must be real has complex entries."""


class RankDeficientError(GeomFDIError):
    """A matrix that must have full rank (e.g. full column rank) does not."""


class DesignError(GeomFDIError):
    """A requested design cannot be carried out (bad options or unsolvable equations)."""


class NotIsolableError(DesignError):
    """The requested residual does not exist: the target fault cannot be decoupled.

    Attributes
    ----------
    reason : str
        Why: ``"dim S* = n"``, ``"L_j in S*"``, ``"L_j = 0"`` or another explanation.
    """

    def __init__(self, message: str, *, reason: str = "", argument: str | None = None) -> None:
        super().__init__(message, argument=argument)
        self.reason = reason or message


class ModelFileError(GeomFDIError):
    """A model file (TOML) is missing an entry or holds an invalid one."""


# ------------------------------------------------------- deployment (evaluate, save/load)
class TimeGridError(GeomFDIError):
    """A time vector is not finite, not strictly increasing, or not uniformly spaced."""


class NotDiscreteError(GeomFDIError):
    """A discrete-time bank is needed (code generation); discretise the bank first."""


class BankFileError(GeomFDIError):
    """A saved bank or monitor file is unreadable, truncated, tampered with or invalid.

    Attributes
    ----------
    path : str or None
        The file, when the data came from one.
    """

    def __init__(
        self, message: str, *, path: str | None = None, argument: str | None = "path"
    ) -> None:
        super().__init__(message, argument=argument)
        self.path = path


class SchemaVersionError(BankFileError):
    """A saved file was written with a newer (or unknown) schema version."""


class ResourceLimitError(GeomFDIError):
    """A request would exceed a resource cap of :mod:`geomfdi.limits` (runs, samples ×
    runs, memory or symbolic size); raised before anything is allocated.

    Attributes
    ----------
    limit : str
        Name of the cap that was hit (``"max_runs"``, ``"max_samples"``,
        ``"max_memory"`` or ``"max_symbolic_size"``).
    estimate : float or None
        Estimated memory of the request in bytes, when known.
    """

    def __init__(
        self,
        message: str,
        *,
        limit: str = "",
        estimate: float | None = None,
        argument: str | None = None,
    ) -> None:
        super().__init__(message, argument=argument)
        self.limit = limit
        self.estimate = estimate


class CampaignIncompleteError(GeomFDIError):
    """A campaign lost workers more often than it retries their tasks.

    Attributes
    ----------
    partial : CampaignResult or None
        The runs that were done (``partial.complete`` is False), or None.
    """

    def __init__(self, message: str, *, partial: object = None, argument: str | None = None):
        super().__init__(message, argument=argument)
        self.partial = partial


# ------------------------------------------------------------------------------- warnings
class IsolabilityWarning(UserWarning):
    """A requested structure matrix cannot tell two faults apart (identical columns).

    Issued by :func:`geomfdi.design_bank` before the design; see
    :func:`geomfdi.isolability_analysis` and the user guide, *Choosing a structure*
    (``docs/guide/choosing-a-structure.md``).
    """


class BackendFallbackWarning(RuntimeWarning):
    """A compiled path (``backend="c"``) is not available; the numpy path runs instead.

    Issued once per process by the simulator's compiled batch recursion and by
    :class:`geomfdi.Monitor` when no C compiler works (the results are the same to
    rounding); see the user guide, *Performance* (``docs/guide/performance.md``).
    """
