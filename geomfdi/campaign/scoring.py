"""The columns of a campaign's table for a block of runs: scores, delays, isolation.

:func:`evaluate_runs` gives each run's scores before and after its onset and its
detection delay per residual and for the bank, :func:`isolate_runs` its first isolation
decision under the campaign's rule and whether it was right (the definitions are in
:mod:`geomfdi.campaign.runner`).  Both work on the statistics of all runs of a block at
once: the windows are read as slices shared by the runs of one onset, and the decision
rule's distinct alarm patterns are decided once
(:func:`geomfdi.evaluation.persistence.pattern_table`).  See the user guide, *Theory:
residual evaluation* (``docs/theory/evaluation.md``).
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np

from geomfdi.errors import GeomFDIError

__all__ = ["evaluate_runs", "isolate_runs"]


def onset_windows(
    t: np.ndarray, onsets: np.ndarray, window: float, eval_start: float
) -> Iterator[tuple[float, np.ndarray, np.ndarray, np.ndarray]]:
    """Per distinct onset ``on`` (a loop over the onsets, not the runs): ``(on, rows,
    pre, post)``, its runs and the samples of its two windows, ``max(eval_start, on -
    window) <= t < on`` and ``on <= t < on + window`` (to a tolerance of 1e-9 of the
    grid's magnitude).

    Raises
    ------
    GeomFDIError
        An onset without samples before it (after ``eval_start``).
    """
    tol = 1e-9 * max(1.0, float(np.abs(t).max()))
    values, which = np.unique(onsets, return_inverse=True)
    for o, on in enumerate(values):
        rows = np.flatnonzero(which.ravel() == o)
        pre = np.flatnonzero((t < on - tol) & (t >= max(eval_start, on - window) - tol))
        post = np.flatnonzero((t >= on - tol) & (t < on + window - tol))
        if not pre.size:
            raise GeomFDIError(
                "onsets: every onset needs samples before it (after eval_start)",
                argument="onsets",
            )
        yield float(on), rows, pre, post


def evaluate_runs(
    t: np.ndarray,
    statistic: np.ndarray,
    thresholds: np.ndarray,
    onsets: np.ndarray,
    window: float,
    eval_start: float,
) -> dict[str, np.ndarray]:
    """Scores and delays (:mod:`geomfdi.campaign.runner`) of runs ``(R, n, N)``; bank last,
    ``(R, n+1)``.

    Only the samples of the two windows are read: the runs of one onset share them
    (a campaign has few onsets), and ``z = s / h`` is formed there alone.
    """
    thr = np.asarray(thresholds, dtype=float)
    finite = np.isfinite(thr)[:, None]
    R, n = statistic.shape[0], statistic.shape[1]
    score_pre = np.full((R, n + 1), -np.inf)
    score_post = np.full((R, n + 1), -np.inf)
    delay = np.full((R, n + 1), np.nan)
    for on, rows, pre, post in onset_windows(t, onsets, window, eval_start):
        for idx, score in ((pre, score_pre), (post, score_post)):
            if not idx.size:
                continue
            # each window is one interval of the grid: a slice
            sl = slice(int(idx[0]), int(idx[-1]) + 1)
            with np.errstate(divide="ignore", invalid="ignore"):
                z = np.where(finite, statistic[rows, :, sl] / thr[:, None], 0.0)
            zmax = z.max(axis=-1)
            score[rows, :n] = zmax
            score[rows, n] = zmax.max(axis=-1)
            if score is score_post:
                hit = z > 1.0
                hit_any = z.max(axis=-2) > 1.0  # the bank: its largest residual
                first = np.argmax(hit, axis=-1)
                first_any = np.argmax(hit_any, axis=-1)
                dt = t[sl]
                delay[rows, :n] = np.where(hit.any(axis=-1), dt[first] - on, np.nan)
                delay[rows, n] = np.where(hit_any.any(axis=-1), dt[first_any] - on, np.nan)
    return {"score_pre": score_pre, "score_post": score_post, "delay": delay}


def isolate_runs(
    t: np.ndarray,
    statistic: np.ndarray,
    thresholds: np.ndarray,
    structure: np.ndarray,
    rule: Any,
    truth: np.ndarray,
    true_sets: list[frozenset[int]],
    onsets: np.ndarray,
    window: float,
    eval_start: float = -np.inf,
) -> dict[str, np.ndarray]:
    """Isolation of runs ``(R, n, N)``: first decision, outcome, delay
    (:mod:`geomfdi.campaign.runner`).

    Alarms before ``eval_start`` (start-up transients) are ignored, as in the scores.
    Every stage of a decision rule is causal (a decision at a sample depends on the
    samples up to it), so the samples after the last detection window are not read.
    """
    from geomfdi.evaluation.decision import MULTIPLE

    thr = np.asarray(thresholds, dtype=float)
    R = statistic.shape[0]
    truth = np.asarray(truth)
    tol = 1e-9 * max(1.0, float(np.abs(t).max()))
    ends = np.flatnonzero(_window_mask(t, np.unique(onsets), window, tol).any(axis=0))
    kend = int(ends[-1]) + 1 if ends.size else 1
    t, statistic = t[:kend], statistic[..., :kend]
    alarms = statistic > thr[:, None]  # +inf (missing rows): never
    alarms &= t >= eval_start - tol
    dec, suspects = _decisions(alarms, structure, rule)
    post = _window_mask(t, onsets, window, tol)
    made = post & ((dec >= 0) | (dec == MULTIPLE))
    first = np.argmax(made, axis=-1)
    rows = np.arange(R)
    has = made[rows, first]
    decision = np.where(has, dec[rows, first], -1)
    # a decision is right: the true single fault, or MULTIPLE with the true suspects
    right = (dec == truth[:, None]) & (truth >= 0)[:, None]
    multi = np.flatnonzero(truth == MULTIPLE)
    if multi.size:
        want = np.zeros((multi.size, structure.shape[1]), dtype=bool)
        for w, r in zip(want, multi, strict=True):
            w[list(true_sets[r])] = True
        right[multi] = (dec[multi] == MULTIPLE) & suspects(multi, want)
    right &= post
    k_right = np.argmax(right, axis=-1)
    ok = right[rows, k_right]
    iso_delay = np.where(ok, t[k_right] - onsets, np.nan)
    outcome = np.where(~has, 2, np.where(right[rows, first] & (truth != -1), 0, 1))
    return {
        "decision": decision.astype(np.int64),
        "truth": np.asarray(truth, dtype=np.int64),
        "outcome": outcome.astype(np.int64),
        "iso_delay": iso_delay,
    }


def _window_mask(t: np.ndarray, onsets: np.ndarray, window: float, tol: float) -> np.ndarray:
    """``(R, N)``: the samples of each run's detection window ``[onset, onset + W)``."""
    return (t[None, :] >= onsets[:, None] - tol) & (t[None, :] < onsets[:, None] + window - tol)


def _decisions(alarms: np.ndarray, structure: np.ndarray, rule: Any) -> tuple[np.ndarray, Any]:
    """Isolation decisions ``(R, N)`` of alarms ``(R, n, N)`` under ``rule``, and
    ``suspects(rows, want) -> (len(rows), N)``: whether the suspects of those runs equal
    ``want`` (len(rows), n_faults) sample by sample.

    Under a persistence rule each distinct held pattern is decided once
    (:func:`~geomfdi.evaluation.persistence.pattern_table`) and only the decisions are
    gathered per sample (the suspects only for the runs that ask).
    """
    from geomfdi.evaluation.decision import isolate
    from geomfdi.evaluation.persistence import held_pattern, pattern_table, settle

    coded = None
    if rule is not None and not rule.trivial:
        confirmed = rule.apply(alarms)
        pattern = held_pattern(confirmed, rule.reset) if rule.latch else confirmed
        coded = pattern_table(pattern, structure)
    if coded is None:
        iso = (
            isolate(alarms, structure)
            if rule is None or rule.trivial
            else rule.isolation(rule.apply(alarms), structure)
        )

        def full(rows: np.ndarray, want: np.ndarray) -> np.ndarray:
            return np.all(iso.suspects[rows] == want[:, :, None], axis=1)

        return iso.isolated, full

    index, table = coded
    small = table.isolated.astype(np.int8) if structure.shape[1] < 127 else table.isolated
    dec = small[index]  # (bytes when they hold the decisions: cheaper passes below)
    if not (rule.k == 1 and rule.n == 1):
        dec = settle(dec, rule.k, rule.n, structure.shape[1])

    def by_pattern(rows: np.ndarray, want: np.ndarray) -> np.ndarray:
        same = np.all(table.suspects.T[None, :, :] == want[:, None, :], axis=-1)  # (rows, U)
        return np.take_along_axis(same, index[rows], axis=-1)

    return dec, by_pattern
