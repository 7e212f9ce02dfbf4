"""The outcome of a campaign: a tidy table, summaries, ROC and detection curves."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from geomfdi.errors import GeomFDIError

__all__ = ["CampaignResult"]

_KEYS = ["scenario", "size", "residual"]


@dataclass
class CampaignResult:
    """Tidy table of a campaign: one row per run and residual (and ``"bank"``).

    Columns: ``run, model, scenario, size, onset, repetition, residual, score_pre,
    score_post, false_alarm, detected, delay`` (see :mod:`geomfdi.campaign.runner`).
    """

    table: Any
    residual_labels: list[str]
    info: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def from_parts(cls, campaign: Any, parts: list[dict[str, np.ndarray]]) -> CampaignResult:
        import pandas as pd

        g = campaign.grid()
        run = np.concatenate([p["run"] for p in parts])
        order = np.argsort(run, kind="stable")
        run = run[order]
        if not np.array_equal(run, g["run"]):
            raise GeomFDIError(
                "campaign: some runs are missing from the results", argument="executor"
            )
        labels = [f"r[{k}]" for k in range(campaign.n_residuals)] + ["bank"]
        cols = {
            k: np.concatenate([p[k] for p in parts])[order]
            for k in ("score_pre", "score_post", "delay")
        }
        n = len(labels)
        names = [s.name for s in campaign.scenarios]
        table = pd.DataFrame(
            {
                "run": np.repeat(run, n),
                "model": np.repeat(g["model"], n),
                "scenario": pd.Categorical(
                    np.repeat(np.asarray(names, dtype=object)[g["scenario"]], n),
                    categories=list(dict.fromkeys(names)),
                ),
                "size": np.repeat(g["size"], n),
                "onset": np.repeat(g["onset"], n),
                "repetition": np.repeat(g["repetition"], n),
                "residual": pd.Categorical(np.tile(labels, run.size), categories=labels),
                "score_pre": cols["score_pre"].ravel(),
                "score_post": cols["score_post"].ravel(),
                "delay": cols["delay"].ravel(),
            }
        )
        table["false_alarm"] = table["score_pre"] > 1.0
        table["detected"] = table["score_post"] > 1.0
        info = {
            "test": getattr(campaign.test, "name", type(campaign.test).__name__),
            "window": campaign.window,
            "models": len(campaign.plants),
            "runs": campaign.runs,
        }
        return cls(table, labels, info)

    def summary(self) -> Any:
        """Per scenario, size and residual: runs, ``pd`` (with Wilson 95 % bounds),
        ``far`` (pre-onset window), delay mean / median / 90th percentile."""
        from geomfdi.evaluation.roc import wilson_interval

        grp = self.table.groupby(_KEYS, observed=True)
        out = grp.agg(
            runs=("run", "size"),
            pd=("detected", "mean"),
            far=("false_alarm", "mean"),
            delay_mean=("delay", "mean"),
            delay_median=("delay", "median"),
            delay_p90=("delay", lambda s: s.quantile(0.9)),
        )
        lo, hi = wilson_interval(out["pd"] * out["runs"], out["runs"])
        out.insert(2, "pd_low", lo)
        out.insert(3, "pd_high", hi)
        return out

    def _select(self, scenario: str | None, residual: str) -> Any:
        if residual not in self.residual_labels:
            raise GeomFDIError(
                f"residual: one of {self.residual_labels}, got {residual!r}", argument="residual"
            )
        tb = self.table[self.table["residual"] == residual]
        if scenario is not None:
            tb = tb[tb["scenario"] == scenario]
            if tb.empty:
                raise GeomFDIError(f"scenario: no runs named {scenario!r}", argument="scenario")
        return tb

    def roc(self, size: float, *, scenario: str | None = None, residual: str = "bank") -> Any:
        """ROC at one fault size: healthy scores before the onset, faulty ones after.

        The healthy scores are the pre-onset maxima, one per (model, onset, noise seed);
        the faulty ones the maxima over the detection window of the runs of ``size``.
        """
        from geomfdi.evaluation.roc import roc_curve

        tb = self._select(scenario, residual)
        faulty = tb[np.isclose(tb["size"], size)]
        if faulty.empty:
            raise GeomFDIError(f"size: no runs of size {size}", argument="size")
        label = f"{residual}, size {size:g}" + ("" if scenario is None else f" ({scenario})")
        # before the onset, runs of one model, onset and noise seed are the same run
        # (common random numbers): count each healthy window once
        healthy = tb.drop_duplicates(["model", "onset", "repetition"])["score_pre"]
        return roc_curve(healthy.to_numpy(), faulty["score_post"].to_numpy(), label)

    def detection_curve(self, *, scenario: str | None = None, residual: str = "bank") -> Any:
        """``pd`` (with bounds) and delays versus fault size (a DataFrame indexed by size)."""
        from geomfdi.evaluation.roc import wilson_interval

        tb = self._select(scenario, residual)
        grp = tb.groupby("size")
        out = grp.agg(
            runs=("run", "size"),
            pd=("detected", "mean"),
            delay_median=("delay", "median"),
            delay_p90=("delay", lambda s: s.quantile(0.9)),
        )
        out["pd_low"], out["pd_high"] = wilson_interval(out["pd"] * out["runs"], out["runs"])
        return out

    def plot_roc(
        self, sizes: Any, *, scenario: str | None = None, residuals: Any = None, **kwargs: Any
    ) -> Any:
        """ROC curves (one per size and residual) as a matplotlib Figure."""
        from geomfdi.plotting.curves import plot_roc

        res = ["bank"] if residuals is None else list(residuals)
        curves = [self.roc(z, scenario=scenario, residual=r) for r in res for z in sizes]
        return plot_roc(curves, **kwargs)

    def plot_detection(
        self, *, scenario: str | None = None, residuals: Any = None, **kwargs: Any
    ) -> Any:
        """``P_d`` and median delay versus fault size as a matplotlib Figure."""
        from geomfdi.plotting.curves import plot_detection

        res = ["bank"] if residuals is None else list(residuals)
        curves = {r: self.detection_curve(scenario=scenario, residual=r) for r in res}
        return plot_detection(curves, **kwargs)
