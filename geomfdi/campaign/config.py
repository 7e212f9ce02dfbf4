"""The ``[campaign]`` table of a TOML model file, and the campaign it describes.

The rest of the file is the model file of :mod:`geomfdi.io.modelfile` (plant, design,
``[simulation]`` with its ``[simulation.noise]``); the campaign table adds::

    [campaign]
    runs = 200                      # noise seeds per (model, scenario, size, onset)
    method = "exact"                # which designed bank (default: the first method)
    sizes = [0.0, 0.01, 0.05]       # bias = size, gain = 1 + size
    onsets = [4.0]
    faults = [{type = "bias", sensor = 0}, {type = "gain", sensor = 2}]   # one scenario each
    detection_window = 2.0          # seconds (default: onset to the end)
    eval_start = 0.5                # ignore start-up samples
    block_size = 64
    seed = 1                        # default: the noise seed
    test = {type = "chi2", window = 20, false_alarm_rate = 1e-3}
    # or {type = "abs", threshold = 0.05}, {type = "cusum", drift = 0.5, arl = 1e4},
    #    {type = "glr", window = 20, false_alarm_rate = 1e-3}
    uncertainty = {relative = 0.02, samples = 4, seed = 0}
    persistence = [3, 5]            # isolation rule: k of n samples (or n), held pattern;
                                    # or {k = 3, n = 5, reset = 500, latch = true}

Without ``faults`` every sensor gets a bias scenario.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from geomfdi._files import csv_text, replace_file
from geomfdi.errors import GeomFDIError, ModelFileError

__all__ = [
    "CampaignConfig",
    "read_campaign",
    "build_campaign",
    "write_outputs",
    "campaign_report",
    "write_csv",
    "save_partial",
]

_KEYS = {
    "runs",
    "method",
    "sizes",
    "onsets",
    "faults",
    "detection_window",
    "eval_start",
    "block_size",
    "seed",
    "test",
    "uncertainty",
    "persistence",
}
_TESTS = {
    "chi2": {"type", "window", "false_alarm_rate", "method"},
    "abs": {"type", "threshold"},
    "cusum": {"type", "drift", "arl"},
    "glr": {"type", "window", "false_alarm_rate"},
}


@dataclass
class CampaignConfig:
    """A model file's campaign: the model spec, the chosen bank and the Campaign."""

    spec: Any
    method: str
    bank: Any
    campaign: Any


def _err(source: str, where: str, msg: str) -> ModelFileError:
    return ModelFileError(f"{source}: campaign.{where}: {msg}")


def _int(src: str, where: str, value: Any, minimum: int | None = None) -> int:
    """An integer entry (an integral float such as ``1e3`` too; ``2.7`` and ``true`` not)."""
    ok = isinstance(value, int | float) and not isinstance(value, bool)
    if ok and isinstance(value, float):
        ok = bool(np.isfinite(value)) and float(value).is_integer()
    if not ok:
        raise _err(src, where, f"must be an integer, got {value!r:.40}")
    n = int(value)
    if minimum is not None and n < minimum:
        raise _err(src, where, f"must be >= {minimum}, got {n}")
    return n


def _float(src: str, where: str, value: Any, *, positive: bool = False) -> float:
    """A finite number entry (``> 0`` if ``positive``)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise _err(src, where, f"must be a number, got {value!r:.40}")
    x = float(value)
    if not np.isfinite(x) or (positive and x <= 0):
        raise _err(
            src, where, f"must be a finite{' positive' if positive else ''} number, got {x!r}"
        )
    return x


def _floats(src: str, where: str, value: Any) -> list[float]:
    """A non-empty list of finite numbers."""
    if not isinstance(value, list) or not value:
        raise _err(src, where, f"must be a non-empty list of numbers, got {value!r:.40}")
    return [_float(src, f"{where}[{i}]", v) for i, v in enumerate(value)]


def _test(source: str, tab: Any, spec: Any, bank: Any, noise: Any) -> Any:
    from geomfdi.evaluation.covariance import residual_noise_models
    from geomfdi.evaluation.statistics import ChiSquareTest, CusumTest, GLRTest

    if not isinstance(tab, dict) or tab.get("type") not in _TESTS:
        raise _err(source, "test", f"expected a table with type one of {sorted(_TESTS)}")
    kind = tab["type"]
    extra = set(tab) - _TESTS[kind]
    if extra:
        raise _err(source, "test", f"unknown keys {sorted(extra)} for type {kind!r}")
    if kind == "abs":
        th = tab.get("threshold", spec.threshold)
        if th is None or isinstance(th, dict):
            raise _err(source, "test.threshold", "a number or one per residual is needed")
        if isinstance(th, list):
            return [_float(source, "test.threshold", v, positive=True) for v in th]
        return _float(source, "test.threshold", th, positive=True)
    window = _int(source, "test.window", tab.get("window", 20), minimum=1)
    rate = _float(source, "test.false_alarm_rate", tab.get("false_alarm_rate", 1e-3), positive=True)
    if rate >= 1:
        raise _err(source, "test.false_alarm_rate", f"must be in (0, 1), got {rate!r}")
    step = None if spec.plant.is_discrete else float(spec.t[1] - spec.t[0])
    models = residual_noise_models(spec.plant, bank, noise, step=step, controller=spec.K)
    if kind == "chi2":
        method = tab.get("method", "imhof")
        if not isinstance(method, str):
            raise _err(source, "test.method", f"must be a string, got {method!r:.40}")
        return ChiSquareTest.design(models, window, rate, method)
    if kind == "cusum":
        drift = _float(source, "test.drift", tab.get("drift", 0.5), positive=True)
        arl = _float(source, "test.arl", tab.get("arl", 1e4), positive=True)
        return CusumTest.design(models, drift, arl)
    return GLRTest.design(models, window, rate)


def read_campaign(path: str | Path) -> tuple[dict[str, Any], Any]:
    """``(campaign table, ModelSpec)`` of a model file with a ``[campaign]`` table.

    Raises :class:`geomfdi.errors.ModelFileError` (one line naming the file and entry).
    """
    from geomfdi.io.modelfile import parse_model

    p = Path(path)
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ModelFileError(f"{p}: cannot read the model file ({exc})") from exc
    src = str(p)
    camp = data.pop("campaign", None)
    if not isinstance(camp, dict):
        raise ModelFileError(f"{src}: no [campaign] table")
    extra = set(camp) - _KEYS
    if extra:
        raise _err(src, "", f"unknown keys {sorted(extra)}")
    spec = parse_model(data, src)
    if spec.t is None or not spec.noise:
        raise ModelFileError(f"{src}: a campaign needs [simulation] and [simulation.noise]")
    return camp, spec


def _scenario(src: Any, f: Any, where: str, spec: Any, sizes: Any, onsets: Any) -> Any:
    """One campaign fault entry: ``{type, sensor | actuator | fault}`` (indices or names)."""
    from geomfdi.campaign.spec import Scenario, _SizedFaults

    kind = f.get("type") if isinstance(f, dict) else None
    if kind not in _SizedFaults.KINDS:
        raise _err(src, where, f"expected a type among {list(_SizedFaults.KINDS)}")
    key = "fault" if kind == "additive" else "actuator" if "actuator" in kind else "sensor"
    if key not in f:
        raise _err(src, f"{where}.{key}", "missing")
    ch = f[key]
    try:
        if key == "sensor":
            ch = spec.plant.output_index(ch, f"{where}.sensor")
        elif key == "actuator":
            ch = spec.plant.input_index(ch, f"{where}.actuator")
        else:
            names = [x.name for x in spec.faults]
            j = names.index(ch) if isinstance(ch, str) and ch in names else ch
            if isinstance(j, bool) or not isinstance(j, int) or not 0 <= j < len(spec.faults):
                raise _err(src, f"{where}.fault", f"a design fault index or one of {names}")
            ch = spec.faults[j]
    except GeomFDIError as exc:
        if isinstance(exc, ModelFileError):
            raise
        raise _err(src, where, str(exc)) from exc
    if kind in ("gain", "bias") and key == "sensor":
        return Scenario.sensor(kind, ch, sizes, onsets)
    return Scenario.of_kind(kind, ch, sizes, onsets)


def build_campaign(
    camp: dict[str, Any], spec: Any, banks: dict[str, Any], *, runs: int | None = None
) -> CampaignConfig:
    """The :class:`Campaign` of a campaign table, on the bank of ``campaign.method``.

    ``banks`` maps design methods to banks (as designed from ``spec``); ``runs``
    overrides ``campaign.runs``.
    """
    src = spec.source
    try:
        return _build(camp, spec, banks, runs)
    except GeomFDIError:
        raise
    except (TypeError, ValueError, OverflowError, KeyError) as exc:  # (a value not foreseen)
        raise _err(src, "", f"invalid value ({type(exc).__name__}: {exc})") from exc


def _build(camp: dict[str, Any], spec: Any, banks: dict[str, Any], runs: int | None) -> Any:
    from geomfdi.campaign.runner import Campaign
    from geomfdi.campaign.spec import Uncertainty
    from geomfdi.evaluation.persistence import Persistence, as_persistence
    from geomfdi.simulation.noise import Noise

    src = spec.source
    method = camp.get("method", next(iter(banks)))
    if not isinstance(method, str) or method not in banks:
        raise _err(src, "method", f"{method!r:.40} is not a designed method ({sorted(banks)})")
    bank = banks[method]
    noise_kw = dict(spec.noise)
    if "seed" in camp:
        noise_kw["seed"] = _int(src, "seed", camp["seed"], minimum=0)
    noise = Noise(**noise_kw)
    sizes = _floats(src, "sizes", camp.get("sizes", [0.0, 1.0]))
    onsets = _floats(src, "onsets", camp.get("onsets", [float(spec.t[len(spec.t) // 2])]))
    faults = camp.get("faults", [{"type": "bias", "sensor": i} for i in range(spec.plant.q)])
    if not isinstance(faults, list) or not faults:
        raise _err(src, "faults", "expected a non-empty list of {type, sensor} tables")
    scenarios = []
    for i, f in enumerate(faults):
        if not isinstance(f, dict):
            raise _err(src, f"faults[{i}]", "expected a table {type, sensor | actuator | fault}")
        scenarios.append(_scenario(src, f, f"faults[{i}]", spec, sizes, onsets))
    unc = camp.get("uncertainty")
    uncertainty = None
    if unc is not None:
        if not isinstance(unc, dict) or set(unc) - {"relative", "samples", "seed", "matrices"}:
            raise _err(src, "uncertainty", "expected {relative, samples, seed, matrices}")
        matrices = unc.get("matrices", ["A", "B"])
        if not isinstance(matrices, list) or not all(isinstance(x, str) for x in matrices):
            raise _err(src, "uncertainty.matrices", "expected a list of matrix names")
        relative = _float(src, "uncertainty.relative", unc.get("relative", 0.0))
        if relative < 0:
            raise _err(src, "uncertainty.relative", f"must be >= 0, got {relative!r}")
        uncertainty = Uncertainty(
            relative=relative,
            samples=_int(src, "uncertainty.samples", unc.get("samples", 1), minimum=1),
            matrices=tuple(matrices),
            seed=_int(src, "uncertainty.seed", unc.get("seed", 0), minimum=0),
        )
    persistence = camp.get("persistence")
    if persistence is not None:
        try:
            if isinstance(persistence, dict):
                extra = set(persistence) - {"k", "n", "reset", "latch"}
                if extra:
                    raise GeomFDIError(f"unknown keys {sorted(extra)}")
                kw = {
                    k: _int(src, f"persistence.{k}", v, minimum=1)
                    for k, v in persistence.items()
                    if k != "latch"
                }
                if "latch" in persistence:
                    if not isinstance(persistence["latch"], bool):
                        raise GeomFDIError("latch must be true or false")
                    kw["latch"] = persistence["latch"]
                persistence = Persistence(**kw)
            else:
                if isinstance(persistence, list):
                    persistence = tuple(
                        _int(src, f"persistence[{i}]", v, minimum=1)
                        for i, v in enumerate(persistence)
                    )
                else:
                    persistence = _int(src, "persistence", persistence, minimum=1)
                persistence = as_persistence(persistence)
        except (GeomFDIError, TypeError) as exc:
            raise _err(
                src,
                "persistence",
                f"expected n, [k, n] or {{k, n, reset, latch}} with 1 <= k <= n ({exc})",
            ) from exc
    if persistence is not None and max(persistence.n, persistence.reset or 0) > spec.t.size:
        raise _err(src, "persistence", f"a rule over more samples than the record's {spec.t.size}")
    test = _test(src, camp.get("test", {"type": "chi2"}), spec, bank, noise)
    c = Campaign(
        spec.plant,
        bank,
        scenarios,
        noise,
        t=spec.t,
        uncertainty=uncertainty,
        runs=runs if runs is not None else _int(src, "runs", camp.get("runs", 100), minimum=1),
        test=test,
        u=spec.u,
        d=spec.d,
        controller=spec.K,
        x0=spec.x0,
        detection_window=(
            None
            if camp.get("detection_window") is None
            else _float(src, "detection_window", camp["detection_window"], positive=True)
        ),
        eval_start=_float(src, "eval_start", camp.get("eval_start", 0.0)),
        block_size=_int(src, "block_size", camp.get("block_size", 64), minimum=1),
        persistence=persistence,
    )
    return CampaignConfig(spec, method, bank, c)


def write_outputs(result: Any, out: Path, *, plots: bool = True, name: str = "") -> list[Path]:
    """``campaign.csv``, ``summary.csv``, ``confusion.csv`` (with a bank) and, per
    scenario, ROC and P_d-vs-size PNGs (and the confusion matrix as a PNG)."""
    import re

    out.mkdir(parents=True, exist_ok=True)
    files = [out / "campaign.csv", out / "summary.csv"]
    write_csv(result.table, files[0], index=False)
    write_csv(result.summary(), files[1])
    if result.has_isolation:
        files.append(out / "confusion.csv")
        write_csv(result.confusion(), files[-1])
    if not plots:
        return files
    if result.has_isolation:
        fig = result.plot_confusion(title=f"{name}\nisolation (first decision in the window)")
        files.append(_png(fig, out / "confusion.png"))
    for scen in result.table["scenario"].cat.categories:
        slug = re.sub(r"[^a-z0-9]+", "-", str(scen).lower()).strip("-")
        tb = result.table[result.table["scenario"] == scen]
        sizes = sorted(float(z) for z in tb["size"].unique() if z != 0)
        if sizes:  # three sizes spread over the sweep
            pick = sorted({sizes[int(round(i))] for i in np.linspace(0, len(sizes) - 1, 3)})
            fig = result.plot_roc(pick, scenario=scen, title=f"{name}\n{scen}: ROC of the bank")
            files.append(_png(fig, out / f"roc_{slug}.png"))
        fig = result.plot_detection(
            scenario=scen, residuals=result.residual_labels, title=f"{name}\n{scen}"
        )
        files.append(_png(fig, out / f"detection_{slug}.png"))
    return files


def _png(fig: Any, path: Path) -> Path:
    return replace_file(path, lambda tmp: fig.savefig(tmp, dpi=120, format="png"))


def write_csv(frame: Any, path: Path, *, index: bool = True) -> Path:
    """``frame.to_csv(path)`` with text cells and labels that a spreadsheet would take for
    a formula escaped (:func:`geomfdi._files.csv_text`), written through
    :func:`geomfdi._files.replace_file`."""
    import pandas as pd

    def safe(values: Any) -> Any:
        if isinstance(values, pd.MultiIndex):
            return pd.MultiIndex.from_tuples(
                [tuple(csv_text(v) for v in row) for row in values], names=values.names
            )
        return pd.Index([csv_text(v) for v in values], name=values.name)

    frame = frame.copy()
    for col in frame.columns:
        if frame[col].dtype == object or isinstance(frame[col].dtype, pd.CategoricalDtype):
            frame[col] = frame[col].map(csv_text).astype(object)
    frame.index = safe(frame.index)
    frame.columns = safe(frame.columns)
    return replace_file(path, lambda tmp: frame.to_csv(tmp, index=index))


def save_partial(exc: Any, out: Path) -> str:
    """Write the runs done of a :class:`~geomfdi.errors.CampaignIncompleteError` to
    ``out/campaign.incomplete.csv``; returns the note for the error line."""
    if getattr(exc, "partial", None) is None:
        return ""
    out.mkdir(parents=True, exist_ok=True)
    path = write_csv(exc.partial.table, out / "campaign.incomplete.csv", index=False)
    return f"; the runs done are in {path} (incomplete)"


def campaign_report(cfg: CampaignConfig, result: Any, files: list[Path]) -> str:
    """The text report of ``geomfdi campaign``: summary of the bank, confusion matrix."""
    import pandas as pd

    c = cfg.campaign
    rule = c.persistence
    lines = [
        f"campaign: {cfg.spec.name}, bank {cfg.method!r}, test {result.info['test']}, "
        f"{len(c.grid()['run'])} runs x {c.t.size} samples, {len(c.plants)} model(s)"
    ]
    summ = result.summary().xs("bank", level="residual")
    with pd.option_context("display.width", 120, "display.max_rows", 200):
        cols = ["runs", "pd", "pd_low", "pd_high", "far", "delay_mean", "delay_median"]
        cols += ["delay_p90"]
        lines.append(summ[cols].round(4).to_string())
        if result.has_isolation:
            how = (
                "per-sample decisions"
                if rule is None
                else f"{rule.k} of {rule.n} samples, pattern held over the alarm episode"
                if rule.latch
                else f"{rule.k} of {rule.n} samples"
            )
            lines.append(f"isolation ({how}): first decision in the detection window")
            iso = ["iso_correct", "iso_correct_low", "iso_correct_high", "iso_wrong"]
            iso += ["iso_none", "iso_multiple", "iso_delay_mean", "iso_delay_median"]
            iso += ["iso_delay_p90"]
            lines.append(summ[iso].round(4).to_string())
            lines.append("confusion (runs; rows: true fault, columns: first decision):")
            lines.append(result.confusion().to_string())
    lines.append("written: " + ", ".join(str(f) for f in files))
    return "\n".join(lines)
