"""The dodecahedron experiment of Qin & Niu (1999) as correct-isolation rates.

See the user guide, *Theory: parity space* (``docs/theory/parity-space.md``).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from typing import Any

import numpy as np

from geomfdi._moved import renamed as _renamed
from geomfdi._validation import as_int, as_positive
from geomfdi.parity._input import _as_rng
from geomfdi.parity.configs import dodecahedron
from geomfdi.parity.model import ParityFDI
from geomfdi.parity.montecarlo import _method_spec, correct_isolation_rate
from geomfdi.parity.multiple import _subset_info
from geomfdi.parity.results import QinNiuResult

__all__ = ["qin_niu_experiment", "QIN_NIU_KINDS", "QIN_NIU_METHODS"]


QIN_NIU_KINDS = (
    "single fault, +/-0.01",
    "two faults, very different (0.05, 0.005)",
    "two faults, equal, same sign (0.1, 0.1)",
    "two faults, equal, opposite sign (0.1, -0.1)",
)

QIN_NIU_METHODS = (
    ("paper search (Qin-Niu)", "search", 2),
    ("two-fault GLR", "glr", 2),
    ("sequential GLT", "glt", 2),
)


def _equivalent(pf: ParityFDI, f: np.ndarray) -> list[frozenset[int]]:
    """Other sets of one or two faults explaining the noise-free parity of ``f`` exactly."""
    truth = frozenset(np.flatnonzero(f).tolist())
    fd = pf.detection_statistic(f)[0]
    alts: list[frozenset[int]] = []
    for kk in (1, 2):
        stats_, subsets = pf.glr_statistics(f, kk)
        valid = _subset_info(pf.data, kk)["valid"]
        for c in np.flatnonzero(valid & (fd - stats_[0] <= 1e-9 * fd)):
            S = frozenset(subsets[c].tolist())
            if not (S >= truth or any(a <= S for a in alts)):
                alts.append(S)
    return alts


def qin_niu_experiment(
    sigma: float = 0.001,
    n_runs: int = 20000,
    rng: Any = None,
    *,
    pfa: float = 1e-3,
    methods: Sequence[Any] = QIN_NIU_METHODS,
) -> QinNiuResult:
    """Reproduce Qin & Niu (1999)'s dodecahedron experiment as correct-isolation rates.

    Six gyros on the dodecahedron (:func:`dodecahedron`, the paper's numbering), white
    noise ``sigma`` (deg/h), and the fault cases of the paper's tables (deg/h):

    * Table 1: one fault of ``+0.01`` or ``-0.01`` on each gyro (12 cases);
    * Table 2: ``0.05`` on gyro i and ``0.005`` on gyro j > i (15 cases);
    * Table 3: ``0.1`` on gyros i and j (15 cases);
    * Table 4: ``0.1`` on gyro i and ``-0.1`` on gyro j > i (15 cases).

    Parameters
    ----------
    sigma : float
        Noise standard deviation in deg/h (the paper does not state its value).
    n_runs : int
        Monte-Carlo samples per case and method.
    rng : numpy Generator, int seed or None
    pfa : float
        False-alarm rate of each detection test.
    methods : sequence
        ``(label, method, max_faults)`` tuples for :meth:`ParityFDI.diagnose`; default:
        the paper's search, the two-fault GLR and sequential GLT.

    Returns
    -------
    QinNiuResult
        ``.table()`` prints the rates; ``.plot()`` draws them.

    Notes
    -----
    The paper's tables list the gyros indicated by the maxima of ``D_j``, ``D+_ij`` and
    ``D-_ij`` over a simulation run, not rates; this experiment turns the same cases
    into correct-isolation probabilities (isolated set equal to the true faulty set).
    With faults of very different sizes the paper only isolates the large one; the
    exact-set rate counts that as a failure, :attr:`IsolationRates.partial` does not.
    """
    sigma = as_positive(sigma, "sigma")
    n_runs = as_int(n_runs, "n_runs", minimum=1)
    rng = _as_rng(rng)
    specs = [_method_spec(m) for m in methods]
    pf = ParityFDI(dodecahedron(), sigma)
    m = pf.m
    cases: list[tuple[str, dict[int, float]]] = []
    for j in range(m):
        for sgn in (1.0, -1.0):
            cases.append((QIN_NIU_KINDS[0], {j: 0.01 * sgn}))
    for i, j in itertools.combinations(range(m), 2):
        cases.append((QIN_NIU_KINDS[1], {i: 0.05, j: 0.005}))
    for i, j in itertools.combinations(range(m), 2):
        cases.append((QIN_NIU_KINDS[2], {i: 0.1, j: 0.1}))
    for i, j in itertools.combinations(range(m), 2):
        cases.append((QIN_NIU_KINDS[3], {i: 0.1, j: -0.1}))
    out = []
    for kind, fdict in cases:
        f = np.zeros(m)
        for i, v in fdict.items():
            f[i] = v
        rates = {
            lab: correct_isolation_rate(pf, f, pfa, n_runs, rng, method=meth, max_faults=mf)
            for lab, meth, mf in specs
        }
        out.append(
            {"kind": kind, "faults": fdict, "rates": rates, "alternatives": _equivalent(pf, f)}
        )
    return QinNiuResult(
        out, tuple(lab for lab, _, _ in specs), sigma, float(pfa), n_runs, QIN_NIU_KINDS
    )


__getattr__ = _renamed(__name__)  # the old names of the Qin & Niu experiment, deprecated
