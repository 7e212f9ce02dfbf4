"""The paper-like diagnosability table (fault x [FD, FI...]) of a window model.

See the user guide, *Theory: diagnosability* (``docs/theory/diagnosability.md``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from geomfdi._threads import limit_blas_threads
from geomfdi._validation import as_int, as_positive, as_probability, as_real_array, as_vector
from geomfdi.diagnosability import indices as _indices
from geomfdi.diagnosability._records import WindowData
from geomfdi.diagnosability.indices import _COSINES
from geomfdi.diagnosability.results import DiagnosabilityTable
from geomfdi.errors import GeomFDIError, ShapeError

if TYPE_CHECKING:
    from geomfdi.diagnosability._records import CosineConvention, NullSpaceMethod, TableMethod


class WindowModelLike(Protocol):
    """What :func:`diagnosability_table` reads of a
    :class:`~geomfdi.diagnosability.model.WindowModel`: its record."""

    @property
    def data(self) -> WindowData: ...


__all__ = ["diagnosability_table"]

_TABLE_METHODS = ("kl", "directional", "probability", "probability_index")


def _profiles(theta: Any, p: int, s: int, name: str = "theta") -> np.ndarray:
    """One profile for all faults (length ``s``) or one per fault (``p x s``)."""
    arr = as_real_array(theta, name)
    if arr.ndim == 2 and arr.shape != (1, s) and arr.shape != (s, 1):
        if arr.shape != (p, s):
            raise ShapeError(
                f"{name}: expected length {s} or shape ({p}, {s}), got shape {arr.shape}",
                argument=name,
            )
        return arr
    vec = as_vector(arr, name, length=s)
    return np.tile(vec, (p, 1))


# --------------------------------------------------------------------------- tables
@limit_blas_threads
def diagnosability_table(
    model: WindowModelLike,
    theta: Any,
    method: TableMethod = "kl",
    *,
    kappa: float = 3.0,
    cosine: CosineConvention = "absolute",
    alpha: float = 0.01,
    nullspace: NullSpaceMethod | None = None,
    digits: int = 4,
) -> DiagnosabilityTable:
    """The paper's table: each fault's detectability and its isolability from every fault.

    Parameters
    ----------
    model : WindowModel
    theta : array_like, (window,) or (p, window)
        One profile for every fault (the paper's tables) or one per fault.
    method : {"kl", "directional", "probability", "probability_index"}
        ``"kl"``: :meth:`WindowModel.kl_detectability` / ``kl_isolability`` (Table 1).
        ``"directional"``: eqs. (17), (22) with ``kappa`` and ``cosine`` (Tables 2-4;
        Table 2 with ``cosine="absolute"``, Table 4 with ``cosine="signed"``).
        ``"probability"``: detection / isolation probabilities at false-alarm rate ``alpha``.
        ``"probability_index"``: the same rescaled to ``(P - alpha) / (1 - alpha)``.
    kappa, cosine
        Options of the directional method.
    alpha : float
        False-alarm rate of the probability methods.
    nullspace : {"structured", "direct"}, optional
        Null-space path (default: the model's).
    digits : int
        Decimals in the formatted text.

    Returns
    -------
    DiagnosabilityTable
        ``values[i, 0] = FD(f_i)``, ``values[i, 1 + j] = FI(f_i, f_j)``, with the profile of
        each row's fault (for the directional method the column fault uses its own profile).

    References
    ----------
    Li, Wang & Liu (2015), Tables 1-4; Eriksson, Frisk, Krysander, Automatica 49(6), 2013.
    """
    data = getattr(model, "data", None)
    if not isinstance(data, WindowData):
        raise GeomFDIError(
            f"model: expected a WindowModel, got {type(model).__name__}", argument="model"
        )
    return _table(data, theta, method, kappa, cosine, alpha, nullspace, digits)


def _table(
    model: WindowData,
    theta: Any,
    method: str,
    kappa: float,
    cosine: str,
    alpha: float,
    nullspace: str | None,
    digits: int,
) -> DiagnosabilityTable:
    if not isinstance(method, str) or method not in _TABLE_METHODS:
        raise GeomFDIError(
            f"method: must be one of {_TABLE_METHODS}, got {method!r}", argument="method"
        )
    p, s = model.p, model.window
    thetas = _profiles(theta, p, s)
    ns = model.nullspace_method(nullspace)
    digits = as_int(digits, "digits", minimum=0, maximum=30)
    kappa, alpha = as_positive(kappa, "kappa"), as_probability(alpha, "alpha")
    if not isinstance(cosine, str) or cosine not in _COSINES:
        raise GeomFDIError(
            f"cosine: must be one of {_COSINES}, got {cosine!r:.40}", argument="cosine"
        )
    vals = np.zeros((p, p + 1))
    opts: dict[str, Any] = {"nullspace": ns}
    if method == "kl":
        for i in range(p):
            vals[i, 0] = _indices.kl_detectability(model, i, thetas[i], method=ns)
            for j in range(p):
                vals[i, 1 + j] = _indices.kl_isolability(model, i, j, thetas[i], method=ns)
    elif method == "directional":
        opts.update(kappa=float(as_positive(kappa, "kappa")), cosine=cosine)
        for i in range(p):
            vals[i, 0] = _indices.directional_detectability(model, i, thetas[i], method=ns)
            for j in range(p):
                vals[i, 1 + j] = _indices.directional_isolability(
                    model, i, j, thetas[i], kappa, theta_j=thetas[j], cosine=cosine, method=ns
                )
    else:
        alpha = as_probability(alpha, "alpha")
        opts["alpha"] = alpha
        det = (
            _indices.detection_probability
            if method == "probability"
            else _indices.probabilistic_detectability
        )
        iso = (
            _indices.isolation_probability
            if method == "probability"
            else _indices.probabilistic_isolability
        )
        for i in range(p):
            vals[i, 0] = det(model, i, thetas[i], alpha, method=ns)
            for j in range(p):
                vals[i, 1 + j] = iso(model, i, j, thetas[i], alpha, method=ns)
    text = _format_table(vals, model.fault_names, digits)
    return DiagnosabilityTable(
        values=vals, method=method, fault_names=model.fault_names, options=opts, text=text
    )


def _format_table(vals: np.ndarray, names: tuple[str, ...], digits: int) -> str:
    big = float(np.max(np.abs(vals))) if vals.size and np.isfinite(vals).all() else 0.0
    width = max(digits + 4, len(f"{big:.{digits}f}") + 2, *(len(nm) + 1 for nm in names))
    head = " " * width + "".join(f"{h:>{width}}" for h in ("FD", *names))
    rows = [
        f"{nm:<{width}}" + "".join(f"{v:>{width}.{digits}f}" for v in row)
        for nm, row in zip(names, vals, strict=True)
    ]
    return "\n".join([head, *rows])
