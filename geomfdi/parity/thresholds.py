"""Detection thresholds of the parity-space tests and the OPT false-alarm bound.

See the user guide, *Theory: parity space* (``docs/theory/parity-space.md``).
"""

from __future__ import annotations

from geomfdi._validation import as_int, as_probability

__all__ = ["chi2_threshold", "normal_threshold", "opt_false_alarm_bound"]


def chi2_threshold(pfa: float, dof: int) -> float:
    """Detection threshold ``T`` with ``P(chi2(dof) >= T) = pfa``.

    Parameters
    ----------
    pfa : float
        False-alarm rate, in (0, 1).
    dof : int
        Degrees of freedom (``m - n`` for the GLT detection function ``FD``).

    Returns
    -------
    float
        The ``1 - pfa`` quantile of ``chi2(dof)``.

    References
    ----------
    Zhang, Chen & Liu (2005), eq. 2-3: ``FD_GLT ~ chi2(m - n)`` without fault.

    Examples
    --------
    >>> round(chi2_threshold(1e-4, 1), 4)
    15.1367
    """
    pfa = as_probability(pfa, "pfa")
    dof = as_int(dof, "dof", minimum=1)
    from scipy import stats

    return float(stats.chi2.isf(pfa, dof))


def normal_threshold(pfa: float) -> float:
    """OPT threshold ``u_{1 - pfa/2}`` (two-sided standard normal quantile).

    References
    ----------
    Zhang, Chen & Liu (2005), §1.2, decision step (1).

    Examples
    --------
    >>> round(normal_threshold(0.05), 3)
    1.96
    """
    pfa = as_probability(pfa, "pfa")
    from scipy import stats

    return float(stats.norm.isf(pfa / 2.0))


def opt_false_alarm_bound(pfa: float, s: int) -> float:
    """Theorem 1 lower bound ``1 - (1 - pfa)^s`` on the uncorrected OPT false-alarm rate.

    Parameters
    ----------
    pfa : float
        Nominal false-alarm rate ``alpha`` used for ``u_{1 - alpha/2}``.
    s : int
        Number of independent parity residuals, ``m - n``.

    Notes
    -----
    Zhang, Chen & Liu (2005)'s proof takes ``s`` of the standardised OPT residuals ``d_i`` to be
    mutually independent, which holds only when ``s`` of the optimal parity vectors are
    orthogonal (e.g. not for the dodecahedron, where every pair has ``|cos| = 1/sqrt 5``).
    The inequality is nevertheless observed on every configuration the test suite draws
    (it becomes an equality when ``s`` residuals are orthogonal and the others duplicate
    them); when ``s`` residuals are correlated, Sidak's inequality only gives the reverse
    bound for that subset, so the statement is checked numerically, not proven here.

    Examples
    --------
    >>> round(opt_false_alarm_bound(0.05, 3), 6)
    0.142625
    """
    pfa = as_probability(pfa, "pfa")
    s = as_int(s, "s", minimum=1)
    return 1.0 - (1.0 - pfa) ** s
