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
    score_post, false_alarm, detected, delay, diverged`` (a run stopped by
    :func:`geomfdi.campaign.runner.cut_divergent`) and, for a bank (on its ``"bank"`` rows;
    missing on the residuals' rows), the isolation of the run: ``true_fault`` (a fault
    label, ``"multiple"`` for simultaneous faults, ``"no fault"`` for size 0),
    ``isolated`` (the first decision in the detection window: a fault label,
    ``"multiple"`` or ``"none"``), ``isolation`` (``"correct"``, ``"wrong"``, ``"none"``)
    and ``isolation_delay`` (seconds to the first correct decision; NaN if none).  See
    :mod:`geomfdi.campaign.runner`.
    """

    table: Any
    residual_labels: list[str]
    info: dict[str, Any] = field(default_factory=dict)

    @classmethod
    def from_parts(
        cls, campaign: Any, parts: list[dict[str, np.ndarray]], *, partial: bool = False
    ) -> CampaignResult:
        """The result of the block outcomes ``parts`` (every run, unless ``partial``:
        the runs there are, ``info["complete"]`` False)."""
        import pandas as pd

        grid = campaign.grid()
        run = np.concatenate([p["run"] for p in parts])
        order = np.argsort(run, kind="stable")
        run = run[order]
        g = {k: v[run] for k, v in grid.items()}
        if not partial and not np.array_equal(run, grid["run"]):
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
        if all("diverged" in p for p in parts):  # runs a fault destabilised (runner)
            div = np.concatenate([p["diverged"] for p in parts])[order]
            table["diverged"] = np.repeat(div, n)
            if div.any():
                import warnings

                from geomfdi.simulation.nonlinear import DivergenceWarning

                warnings.warn(
                    f"{int(div.sum())} of {div.size} runs diverged; their decisions stop "
                    "there (column 'diverged')",
                    DivergenceWarning,
                    stacklevel=3,
                )
        table["false_alarm"] = table["score_pre"] > 1.0
        table["detected"] = table["score_post"] > 1.0
        if campaign.structure is not None:
            iso = {
                k: np.concatenate([p[k] for p in parts])[order]
                for k in ("decision", "truth", "outcome", "iso_delay")
            }
            _isolation_columns(table, iso, campaign.fault_labels, n)
        info = {
            "test": getattr(campaign.test, "name", type(campaign.test).__name__),
            "window": campaign.window,
            "models": len(campaign.plants),
            "runs": campaign.runs,
            "fault_labels": list(campaign.fault_labels),
            "persistence": campaign.persistence,
            "complete": bool(np.array_equal(run, grid["run"])),
        }
        return cls(table, labels, info)

    @property
    def has_isolation(self) -> bool:
        """The table has isolation columns (the campaign's bank has a structure)."""
        return "isolation" in self.table.columns

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
        if self.has_isolation:
            out = _isolation_summary(self.table, out)
        return out

    def confusion(
        self, *, scenario: str | None = None, size: float | None = None, normalize: bool = False
    ) -> Any:
        """Confusion matrix of the isolation: true fault (rows) x first decision (columns).

        Rows: the true faults met in the runs (fault labels, ``"multiple"``, ``"no
        fault"``); columns: every fault label, then ``"multiple"`` and ``"none"``.
        ``normalize``: fractions of each row's runs instead of counts.
        """
        import pandas as pd

        if not self.has_isolation:
            raise GeomFDIError(
                "confusion: the campaign's bank has no structure matrix", argument="campaign"
            )
        tb = self.table[self.table["residual"] == "bank"]
        if scenario is not None:
            tb = tb[tb["scenario"] == scenario]
            if tb.empty:
                raise GeomFDIError(f"scenario: no runs named {scenario!r}", argument="scenario")
        if size is not None:
            tb = tb[np.isclose(tb["size"], size)]
            if tb.empty:
                raise GeomFDIError(f"size: no runs of size {size}", argument="size")
        C = pd.crosstab(tb["true_fault"], tb["isolated"], dropna=False)
        rows = [r for r in tb["true_fault"].cat.categories if r in set(tb["true_fault"])]
        C = C.reindex(index=rows, columns=list(tb["isolated"].cat.categories), fill_value=0)
        C.index.name, C.columns.name = "true fault", "isolated"
        if normalize:
            C = C.div(C.sum(axis=1).replace(0, 1), axis=0)
        return C

    def plot_confusion(
        self, *, scenario: str | None = None, size: float | None = None, **kwargs: Any
    ) -> Any:
        """The confusion matrix (row fractions, with counts) as a matplotlib Figure."""
        from geomfdi.plotting.curves import plot_confusion

        what = "isolation" + ("" if size is None else f", size {size:g}")
        kwargs.setdefault("title", self._title(scenario, what))
        return plot_confusion(self.confusion(scenario=scenario, size=size), **kwargs)

    def _title(self, scenario: str | None, what: str) -> str:
        """A figure's default title: the scenario (every scenario when ``None``) and what
        the figure shows."""
        if scenario is None:
            names = list(dict.fromkeys(self.table["scenario"].astype(str)))
            scenario = names[0] if len(names) == 1 else "all scenarios"
        return f"{scenario}: {what}"

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
        """``pd`` (with bounds) and delays versus fault size (a DataFrame indexed by size).

        At size 0 (no fault) ``pd`` is the false-alarm rate of the window and the delays
        are ``nan``.
        """
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
        # size 0 is the healthy plant: its alarms are false alarms, not detections with a delay
        healthy = np.isclose(np.asarray(out.index, dtype=float), 0.0)
        out.loc[healthy, ["delay_median", "delay_p90"]] = np.nan
        return out

    def plot_roc(
        self, sizes: Any, *, scenario: str | None = None, residuals: Any = None, **kwargs: Any
    ) -> Any:
        """ROC curves (one per size and residual) as a matplotlib Figure."""
        from geomfdi.plotting.curves import plot_roc

        res = ["bank"] if residuals is None else list(residuals)
        curves = [self.roc(z, scenario=scenario, residual=r) for r in res for z in sizes]
        kwargs.setdefault("title", self._title(scenario, "ROC"))
        return plot_roc(curves, **kwargs)

    def plot_detection(
        self, *, scenario: str | None = None, residuals: Any = None, **kwargs: Any
    ) -> Any:
        """``P_d`` and median delay versus fault size as a matplotlib Figure."""
        from geomfdi.plotting.curves import plot_detection

        res = ["bank"] if residuals is None else list(residuals)
        curves = {r: self.detection_curve(scenario=scenario, residual=r) for r in res}
        kwargs.setdefault("title", self._title(scenario, "detection versus fault size"))
        return plot_detection(curves, **kwargs)


_OUTCOMES = ["correct", "wrong", "none"]


def _isolation_columns(table: Any, iso: dict[str, np.ndarray], faults: list[str], n: int) -> None:
    """Add the isolation columns (values on the ``"bank"`` rows, the last of each run)."""
    import pandas as pd

    from geomfdi.evaluation.decision import MULTIPLE

    decided = [*faults, "multiple", "none"]
    truths = [*faults, "multiple", "no fault", "unmodelled"]

    def label(codes: np.ndarray, none: str, unknown: str) -> np.ndarray:
        out = np.empty(codes.size, dtype=object)
        for i, c in enumerate(codes.tolist()):
            out[i] = (
                faults[c]
                if c >= 0
                else "multiple"
                if c == MULTIPLE
                else none
                if c == -1
                else unknown
            )
        return out

    bank = np.zeros(len(table), dtype=bool)
    bank[n - 1 :: n] = True

    def on_bank(values: np.ndarray, cats: list[str] | None) -> Any:
        full = np.full(len(table), np.nan, dtype=object if cats else float)
        full[bank] = values
        if cats is None:
            return full
        full[~bank] = None
        return pd.Categorical(full, categories=cats)

    table["true_fault"] = on_bank(label(iso["truth"], "no fault", "unmodelled"), truths)
    table["isolated"] = on_bank(label(iso["decision"], "none", "none"), decided)
    table["isolation"] = on_bank(np.asarray(_OUTCOMES, dtype=object)[iso["outcome"]], _OUTCOMES)
    table["isolation_delay"] = on_bank(iso["iso_delay"].astype(float), None)


def _isolation_summary(table: Any, out: Any) -> Any:
    """Isolation rates (Wilson 95 % bounds) and delays on the ``"bank"`` rows of ``out``."""
    from geomfdi.evaluation.roc import wilson_interval

    tb = table[table["residual"] == "bank"]
    grp = tb.groupby(["scenario", "size"], observed=True)
    iso = grp.agg(
        iso_runs=("run", "size"),
        iso_correct=("isolation", lambda s: float(np.mean(s == "correct"))),
        iso_wrong=("isolation", lambda s: float(np.mean(s == "wrong"))),
        iso_none=("isolation", lambda s: float(np.mean(s == "none"))),
        iso_multiple=("isolated", lambda s: float(np.mean(s == "multiple"))),
        iso_delay_mean=("isolation_delay", "mean"),
        iso_delay_median=("isolation_delay", "median"),
        iso_delay_p90=("isolation_delay", lambda s: s.quantile(0.9)),
    )
    for k in _OUTCOMES:
        lo, hi = wilson_interval(iso[f"iso_{k}"] * iso["iso_runs"], iso["iso_runs"])
        iso[f"iso_{k}_low"], iso[f"iso_{k}_high"] = lo, hi
    order = ["iso_correct", "iso_correct_low", "iso_correct_high", "iso_wrong", "iso_wrong_low"]
    order += ["iso_wrong_high", "iso_none", "iso_none_low", "iso_none_high", "iso_multiple"]
    order += ["iso_delay_mean", "iso_delay_median", "iso_delay_p90"]
    iso = iso[order]
    joined = out.join(iso, on=["scenario", "size"])
    not_bank = joined.index.get_level_values("residual") != "bank"
    joined.loc[not_bank, order] = np.nan
    return joined
