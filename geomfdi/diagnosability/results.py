"""Result records of the diagnosability functions: stacked window, tables, reports.

See the user guide, *Theory: diagnosability* (``docs/theory/diagnosability.md``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["StackedWindow", "DiagnosabilityTable", "FaultApplicability", "ApplicabilityReport"]


@dataclass(frozen=True)
class StackedWindow:
    """The stacked window model eq. (2) of Li, Wang & Liu (2015): ``L z_s = H x_s + F f_s + E e_s``.

    Attributes
    ----------
    L : ndarray, ((n + m) s, (m + q) s)
        Acts on ``z_s = [y(k-s+1); ...; y(k); u(k-s+1); ...; u(k)]``.
    H : ndarray, ((n + m) s, n (s + 1))
        Acts on ``x_s = [x(k-s+1); ...; x(k+1)]``.
    F : ndarray, ((n + m) s, p s)
        Acts on ``f_s = [f(k-s+1); ...; f(k)]``; fault ``i`` owns columns ``i, i+p, ...``.
    E : ndarray, ((n + m) s, (l + t) s)
        Acts on ``e_s = [w(k-s+1); ...; w(k); v(k-s+1); ...; v(k)]``.
    Sigma : ndarray, ((l + t) s, (l + t) s)
        Covariance of ``e_s``: ``blockdiag(I_s (x) Qw, I_s (x) Rv)``.
    """

    L: np.ndarray
    H: np.ndarray
    F: np.ndarray
    E: np.ndarray
    Sigma: np.ndarray


@dataclass(frozen=True)
class DiagnosabilityTable:
    """A paper-like diagnosability table (Li, Wang & Liu (2015), Tables 1-4).

    Attributes
    ----------
    values : ndarray, (p, p + 1)
        Column 0: detectability of each fault; column ``1 + j``: isolability of the row
        fault from fault ``j``.
    method : str
        ``"kl"``, ``"directional"``, ``"probability"`` or ``"probability_index"``.
    fault_names : tuple of str
    options : dict
        The options behind the numbers (``kappa``, ``cosine``, ``alpha``, null-space path).
    text : str
        The table formatted like the paper's.
    """

    values: np.ndarray
    method: str
    fault_names: tuple[str, ...]
    options: dict = field(default_factory=dict)
    text: str = ""

    @property
    def detectability(self) -> np.ndarray:
        """Column ``FD`` (length p)."""
        return self.values[:, 0]

    @property
    def isolability(self) -> np.ndarray:
        """The ``p x p`` block ``FI(f_i, f_j)`` (row ``i``, column ``j``)."""
        return self.values[:, 1:]

    def __str__(self) -> str:
        return self.text


@dataclass(frozen=True)
class FaultApplicability:
    """Theorem 1 of Li, Wang & Liu (2015) for one fault, with the exact rank facts beside it.

    Attributes
    ----------
    index, name
        The fault.
    rref_row_nonzeros : tuple of int
        Non-zeros in each non-zero row of ``rref(N_H F_i)``.
    theorem1 : bool
        The paper's criterion: every non-zero row has exactly one non-zero.
    rank : int
        ``rank(N_H F_i)`` (at most the window ``s``).
    window : int
        Number of columns of ``N_H F_i`` (the window length ``s``).
    undetectable_dim : int
        ``s - rank``: dimension of the profiles ``theta != 0`` with ``N_H F_i theta = 0``.
    theta_detectable : bool or None
        Whether the given profile has ``q_i != 0`` (``None`` when no profile was given).
    isolation_dof : int
        ``d - rank``: dimension of the left null space of ``[H F_i]``; the KL isolability of
        any fault from ``f_i`` is 0 when it is 0.
    """

    index: int
    name: str
    rref_row_nonzeros: tuple[int, ...]
    theorem1: bool
    rank: int
    window: int
    undetectable_dim: int
    theta_detectable: bool | None
    isolation_dof: int


@dataclass(frozen=True)
class ApplicabilityReport:
    """When the KL (distance-similarity) indices apply: Theorems 1-2 of Li, Wang & Liu (2015).

    Attributes
    ----------
    faults : tuple of FaultApplicability
    outputs : int
        Number of outputs ``m``.
    residual_dim : int
        ``d = dim`` of the left null space of ``H``.
    theorem1 : bool
        Theorem 1 (paper's criterion) holds for every fault.
    theorem2 : bool
        Theorem 2: more than one output (``m > 1``).
    kl_detectability : bool
        The paper's verdict for KL detectability (Theorem 1).
    kl_isolability : bool
        The paper's verdict for KL isolability (Theorems 1 and 2).
    reasons : tuple of str
        One sentence per finding, including where the paper's criterion and the exact rank
        condition disagree.
    """

    faults: tuple[FaultApplicability, ...]
    outputs: int
    residual_dim: int
    theorem1: bool
    theorem2: bool
    kl_detectability: bool
    kl_isolability: bool
    reasons: tuple[str, ...]

    def __str__(self) -> str:
        lines = [
            f"Theorem 1 (rref rows with one non-zero): {'holds' if self.theorem1 else 'fails'}",
            f"Theorem 2 (more than one output, m = {self.outputs}): "
            f"{'holds' if self.theorem2 else 'fails'}",
            f"KL detectability applicable: {self.kl_detectability}; "
            f"KL isolability applicable: {self.kl_isolability}",
        ]
        lines += [f"  - {r}" for r in self.reasons]
        return "\n".join(lines)
