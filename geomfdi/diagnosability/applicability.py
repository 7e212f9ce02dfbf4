"""When the KL indices apply: Theorems 1-2 of Li, Wang & Liu (2015) as a report.

See the user guide, *Theory: diagnosability* (``docs/theory/diagnosability.md``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from geomfdi.diagnosability._linalg import _rref
from geomfdi.diagnosability.results import ApplicabilityReport, FaultApplicability
from geomfdi.diagnosability.stacking import _q, _reduced
from geomfdi.diagnosability.tables import _profiles
from geomfdi.tolerance import get_rtol, rank_decision

if TYPE_CHECKING:
    from geomfdi.diagnosability._records import WindowData

__all__ = ["applicability"]


def applicability(model: WindowData, theta: Any = None) -> ApplicabilityReport:
    """Theorems 1-2 of Li, Wang & Liu (2015) as a report (when the KL indices apply).

    Parameters
    ----------
    theta : array_like, (window,) or (p, window), optional
        Fault profile(s); when given, the report says whether each is detectable.

    Returns
    -------
    ApplicabilityReport

    Notes
    -----
    Theorem 1 (paper): KL detectability applies when every non-zero row of
    ``rref(N_H F_i)`` has exactly one non-zero.  The rref depends only on the row space
    of ``N_H F_i``, hence not on the basis ``N_H``.  The exact condition for "every
    non-zero profile is detectable" is ``rank N_H F_i = s``; the paper's criterion also
    holds when ``N_H F_i`` has zero columns (a fault whose last samples do not reach the
    window's outputs), in which case profiles supported on those samples are
    undetectable: the report says so.  Theorem 2 (paper): KL isolability needs ``m > 1``;
    the exact quantity is ``d - rank N_H F_j``, the dimension of the left null space of
    ``[H F_j]`` beyond ``H``'s, which is reported per fault.
    """
    p, s = model.p, model.window
    thetas = None if theta is None else _profiles(theta, p, s)
    red = _reduced(model)
    d = red.nf.shape[0]
    faults = []
    reasons: list[str] = []
    for i in range(p):
        X = red.nf[:, i::p]
        _, sv, Vt = np.linalg.svd(X, full_matrices=False)
        dec = rank_decision(
            sv, float(red.f_norms[i]), d, what=f"N_H F_i of fault {model.fault_names[i]}"
        )
        # rref depends only on the row space: eliminate on an orthonormal basis of it
        R = _rref(Vt[: dec.rank], get_rtol(s))
        counts = tuple(int(c) for c in np.count_nonzero(R, axis=1) if c > 0)
        thm1 = all(c == 1 for c in counts)
        det = None
        if thetas is not None:
            q, tol, _ = _q(model, i, thetas[i], None)
            det = bool(np.linalg.norm(q) > tol)
        fa = FaultApplicability(
            index=i,
            name=model.fault_names[i],
            rref_row_nonzeros=counts,
            theorem1=thm1,
            rank=dec.rank,
            window=s,
            undetectable_dim=s - dec.rank,
            theta_detectable=det,
            isolation_dof=d - dec.rank,
        )
        faults.append(fa)
        nm = fa.name
        if not thm1:
            reasons.append(
                f"{nm}: Theorem 1 fails, rref(N_H F_i) has rows with {list(counts)} "
                "non-zeros; some non-zero profiles are undetectable"
            )
        elif fa.undetectable_dim > 0:
            reasons.append(
                f"{nm}: Theorem 1 holds, but rank N_H F_i = {fa.rank} < s = {s}: "
                f"profiles in a {fa.undetectable_dim}-dimensional subspace (zero columns of "
                "N_H F_i) are still undetectable"
            )
        if det is False:
            reasons.append(f"{nm}: the given profile is undetectable (q_i = 0)")
        if fa.isolation_dof == 0:
            reasons.append(
                f"{nm}: Gamma N_H F_i spans the whole residual space (d = {d}); no fault "
                f"can be KL-isolated from {nm}"
            )
    thm1_all = all(f.theorem1 for f in faults)
    thm2 = model.m > 1
    if not thm2:
        reasons.append(f"Theorem 2 fails: one output (m = {model.m}); KL isolability is 0")
    return ApplicabilityReport(
        faults=tuple(faults),
        outputs=model.m,
        residual_dim=d,
        theorem1=thm1_all,
        theorem2=thm2,
        kl_detectability=thm1_all,
        kl_isolability=thm1_all and thm2,
        reasons=tuple(reasons),
    )
