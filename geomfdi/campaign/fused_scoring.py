"""A campaign block simulated and judged in one compiled pass: :func:`fused_block`.

With a fused plan (:mod:`geomfdi.simulation.fused`) for a chi-square test, the statistic
of a block's runs is never written out: the kernel judges it sample by sample (the
scores before and after each run's onset, the first sample over the threshold in the
detection window, the alarm pattern of every sample up to the last detection window, and
whether a run diverged), and the first isolation decision of each run is taken from its
alarm patterns by the same rule (``gffused_isolate``).  The columns equal those of
:func:`~geomfdi.campaign.scoring.evaluate_runs` and
:func:`~geomfdi.campaign.scoring.isolate_runs` on the statistic: the same comparisons of
the same numbers (the windows and the decision tables are computed here by their code).

:func:`fused_block` returns ``None`` when it cannot judge the block this way: a run
diverged (its statistic must be cut, :func:`~geomfdi.campaign.runner.cut_divergent`),
a threshold that is not positive, more than 8 residuals, or a rule window over
:data:`MAX_RULE_WINDOW` samples; the caller then evaluates the statistic with numpy.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi.campaign.scoring import onset_windows

__all__ = ["MAX_RULE_WINDOW", "fused_block"]

#: Longest confirmation window of a decision rule judged in the compiled pass (the
#: settling counts its window sample by sample).
MAX_RULE_WINDOW = 64


def _windows(
    t: np.ndarray, onsets: np.ndarray, window: float, eval_start: float
) -> tuple[np.ndarray, ...]:
    """Per run, ``[kpre0, kon)`` and ``[kon, kpost1)``: the samples of
    :func:`~geomfdi.campaign.scoring.evaluate_runs`'s two windows (the same masks)."""
    R = onsets.size
    kpre0, kon, kpost1 = (np.zeros(R, dtype=np.int64) for _ in range(3))
    for _, rows, pre, post in onset_windows(t, onsets, window, eval_start):
        kpre0[rows] = pre[0]
        # the first window ends where the second begins (the same boundary on the grid)
        kon[rows] = pre[-1] + 1
        kpost1[rows] = post[-1] + 1 if post.size else pre[-1] + 1
    return kpre0, kon, kpost1


def fused_block(
    job: dict[str, Any],
    plan: Any,
    fault_lists: list[list[Any]],
    seeds: list[Any],
    onsets: np.ndarray,
    truths: list[tuple[int, frozenset[int]]] | None,
    run_ids: np.ndarray,
    diverged_ratio: float,
) -> dict[str, np.ndarray] | None:
    """The table columns of a block's runs (``run_ids``; their fault lists, noise seeds,
    onsets and true structure columns), or ``None`` (module docstring).  A statistic
    ``diverged_ratio`` times its threshold (or non-finite) marks a diverged run."""
    from geomfdi.evaluation.decision import MULTIPLE, isolate
    from geomfdi.evaluation.persistence import _decide_patterns, every_pattern
    from geomfdi.simulation.fused import evaluation_struct, fused_runs, isolate_codes

    test, t = job["test"], job["t"]
    rule, structure = job["persistence"], job["structure"]
    n = plan.n_rows
    if n > 8 or (rule is not None and rule.n > MAX_RULE_WINDOW):
        return None
    R = len(seeds)
    thr_all = np.asarray(test.thresholds, dtype=float)
    if not np.all(thr_all > 0):  # (the kernel divides the windows' largest statistic)
        return None
    rows = plan.rdst[: plan.rbeg.size - 1]
    thr = np.ascontiguousarray(thr_all[rows])
    # cut_divergent's limits (DIVERGED_RATIO); the largest double stands for no limit, so
    # that a non-finite statistic is caught by the same comparison
    lim = np.where(np.isfinite(thr), diverged_ratio * thr, np.finfo(float).max)
    kpre0, kon, kpost1 = _windows(t, onsets, job["window"], job["eval_start"])
    tol = 1e-9 * max(1.0, float(np.abs(t).max()))
    kal0 = int(np.searchsorted(t, job["eval_start"] - tol, side="left"))
    kend = int(kpost1.max()) if kpost1.size and kpost1.max() > 0 else 1
    nr = rows.size
    arrays = {
        "thr": thr,
        "lim": np.ascontiguousarray(lim),
        "kal0": kal0,
        "kend": kend,
        "codes": np.zeros((R, kend), dtype=np.uint8),
        "kpre0": kpre0,
        "kon": kon,
        "kpost1": kpost1,
        "spre": np.full((R, nr), -np.inf),
        "spost": np.full((R, nr), -np.inf),
        "fhit": np.full((R, nr), -1, dtype=np.int64),
        "bad": np.zeros(R, dtype=np.uint8),
    }
    fused_runs(plan, fault_lists, seeds, evaluation=evaluation_struct(arrays))
    if arrays["bad"].any():
        return None
    # ---- scores and delays, the bank last (evaluate_runs)
    score_pre = np.full((R, n + 1), -np.inf)
    score_post = np.full((R, n + 1), -np.inf)
    delay = np.full((R, n + 1), np.nan)
    missing = np.flatnonzero(~np.isin(np.arange(n), rows))
    has_post = kpost1 > kon
    score_pre[:, rows] = arrays["spre"]
    score_pre[:, missing] = 0.0  # z = 0 on a missing row (an infinite threshold)
    score_post[:, rows] = arrays["spost"]
    score_post[np.ix_(has_post, missing)] = 0.0
    score_pre[:, n] = score_pre[:, :n].max(axis=1)
    score_post[:, n] = np.where(has_post, score_post[:, :n].max(axis=1), -np.inf)
    fh = arrays["fhit"]
    hit = fh >= 0
    delay[:, rows] = np.where(hit, t[np.where(hit, fh, 0)] - onsets[:, None], np.nan)
    fmin = np.where(hit, fh, np.iinfo(np.int64).max).min(axis=1, initial=np.iinfo(np.int64).max)
    anyhit = fmin < np.iinfo(np.int64).max
    delay[:, n] = np.where(anyhit, t[np.where(anyhit, fmin, 0)] - onsets, np.nan)
    out = {"score_pre": score_pre, "score_post": score_post, "delay": delay}
    out["run"] = run_ids
    out["diverged"] = np.zeros(R, dtype=bool)
    if structure is None or truths is None:
        return out
    # ---- the first isolation decision (isolate_runs)
    truth = np.array([tr for tr, _ in truths], dtype=np.int64)
    # the decision of every alarm pattern: the same for every block of the campaign,
    # made once per process
    table = job["fused"].get(("patterns", n))
    if table is None:
        pats = every_pattern(n)
        table = job["fused"][("patterns", n)] = (
            isolate(pats, structure)
            if rule is None or rule.trivial
            else _decide_patterns(pats, structure)
        )
    right_lut = None
    multi = np.flatnonzero(truth == MULTIPLE)
    if multi.size:
        right_lut = np.zeros((R, table.suspects.shape[1]), dtype=np.uint8)
        for r in multi:
            want = np.zeros(structure.shape[1], dtype=bool)
            want[list(truths[r][1])] = True
            right_lut[r] = np.all(table.suspects == want[:, None], axis=0)
    first, dec, right = isolate_codes(
        plan,
        arrays["codes"],
        table.isolated,
        rule,
        structure.shape[1],
        kon,
        kpost1,
        truth,
        right_lut,
    )
    has = first >= 0
    ok = right >= 0
    out["decision"] = np.where(has, dec, -1).astype(np.int64)
    out["truth"] = truth
    out["outcome"] = np.where(~has, 2, np.where((right == first) & (truth != -1), 0, 1)).astype(
        np.int64
    )
    out["iso_delay"] = np.where(ok, t[np.where(ok, right, 0)] - onsets, np.nan)
    return out
