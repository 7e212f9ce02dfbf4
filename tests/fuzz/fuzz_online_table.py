"""More of the fuzz table: the deployed monitor (construction, ``step``, ``feed``, its
state), generated code, and the API entry points the first table did not reach
(subspace constructors, AR monitor sizes, baselines, statistics helpers).

Used by ``test_fuzz_online.py`` with the values and the outcome classifier of
``fuzz_table.py``.
"""

from __future__ import annotations

import contextlib
import tempfile
from typing import Any

import numpy as np
from fuzz_table import BANK, PLANT, RES, STREAM, SUB, TRAINING, Entry, finite, ok_subspace

import geomfdi as gf

DT = 0.01
DBANK = BANK.discretize(DT)
Y3 = np.random.default_rng(5).standard_normal((3, 40))
U3 = np.zeros((3, 40))


def ok_step(s: Any) -> bool:
    r = np.asarray(s.residuals)
    return r.dtype == np.float64 and r.shape == (DBANK.n_residuals,) and s.alarms.dtype == bool


def ok_feed(out: Any) -> bool:
    return out.residuals.dtype == np.float64 and out.residuals.shape[0] == DBANK.n_residuals


def ok_monitor(mon: Any) -> bool:
    return ok_feed(mon.feed(Y3, U3))


def _monitor(**kw: Any) -> Any:
    return gf.Monitor(**kw)


def _fresh() -> gf.Monitor:
    return gf.Monitor(DBANK, threshold=1.0, persistence=(2, 3))


def _step(**kw: Any) -> Any:
    return _fresh().step(**kw)


def _feed(**kw: Any) -> Any:
    return _fresh().feed(**kw)


def _set_state(**kw: Any) -> Any:
    mon = _fresh()
    state = mon.state
    state.update(kw)
    mon.state = state
    return mon.step(Y3[:, 0], U3[:, 0])


def _codegen(lang: str) -> Any:
    def call(**kw: Any) -> Any:
        write = gf.codegen.c if lang == "c" else gf.codegen.python
        # inside a scratch folder: a relative out_dir ("abc") lands there
        with tempfile.TemporaryDirectory() as tmp, contextlib.chdir(tmp):
            kw.setdefault("out_dir", tmp)
            out = write(**kw)
            paths = out if isinstance(out, tuple) else (out,)
            return all(p.exists() and p.stat().st_size > 0 for p in paths)

    return call


def _evaluate(**kw: Any) -> Any:
    return gf.evaluate(DBANK, **kw)


def _ar_sizes(**kw: Any) -> Any:
    return gf.ARMonitor(**kw)


def _subspace(method: str) -> Any:
    def call(**kw: Any) -> Any:
        return getattr(gf.Subspace, method)(**kw)

    return call


def _persistence_rule(**kw: Any) -> Any:
    rule = gf.Persistence(**kw)
    return rule.alarms(np.ones((2, 10), dtype=bool)) if hasattr(rule, "alarms") else rule


ENTRIES_ONLINE = [
    Entry(
        "Monitor",
        _monitor,
        dict(bank=DBANK, threshold=1.0, persistence=(2, 3)),
        ("bank", "dt", "threshold", "persistence", "isolation", "initial"),
        ok_monitor,
    ),
    Entry(
        "Monitor.step",
        _step,
        dict(y=Y3[:, 0], u=U3[:, 0]),
        ("y", "u"),
        ok_step,
        {"y": ("y", "u"), "u": ("u", "y")},
    ),
    Entry(
        "Monitor.feed",
        _feed,
        dict(Y=Y3, U=U3),
        ("Y", "U"),
        ok_feed,
        {"Y": ("Y", "U"), "U": ("U", "Y")},
    ),
    Entry(
        "Monitor.state",
        _set_state,
        {},
        ("xi", "last_sample", "pending", "ring", "held", "quiet", "decisions", "samples"),
        ok_step,
        {
            k: ("state",)
            for k in (
                "xi",
                "last_sample",
                "pending",
                "ring",
                "held",
                "quiet",
                "decisions",
                "samples",
            )
        },  # fmt: skip
    ),
    Entry(
        "Persistence",
        _persistence_rule,
        dict(k=2, n=3),
        ("k", "n", "latch", "reset"),
    ),
    Entry(
        "codegen.c",
        _codegen("c"),
        dict(source=DBANK, name="fz", threshold=1.0),
        ("source", "name", "threshold", "persistence", "initial", "out_dir"),
        lambda written: written is True,
        {"source": ("source", "bank", "monitor"), "out_dir": ("out_dir", "out")},
    ),
    Entry(
        "codegen.python",
        _codegen("python"),
        dict(source=DBANK, name="fz", threshold=1.0),
        ("source", "name", "threshold", "persistence", "initial", "out_dir"),
        lambda written: written is True,
        {"source": ("source", "bank", "monitor"), "out_dir": ("out_dir", "out")},
    ),
    Entry(
        "evaluate",
        _evaluate,
        dict(y=Y3, u=U3, dt=DT, threshold=1.0),
        ("y", "u", "dt", "threshold", "persistence", "initial", "detection_window"),
        lambda r: r.residuals.shape == (3, 40) and r.alarms.dtype == bool,
        {"y": ("y", "u"), "u": ("u", "y")},
    ),
    Entry("Subspace.full", _subspace("full"), dict(n=3), ("n",), ok_subspace),
    Entry("Subspace.zero", _subspace("zero"), dict(n=3), ("n",), ok_subspace),
    Entry(
        "Subspace.from_orthonormal",
        _subspace("from_orthonormal"),
        dict(Q=np.eye(3)[:, :1]),
        ("Q",),
        ok_subspace,
    ),
    Entry(
        "Subspace.contains",
        lambda **kw: SUB.contains(**kw),
        dict(other=[1.0, 0.0, 0.0]),
        ("other",),
        lambda b: isinstance(b, bool),
    ),
    Entry(
        "ARMonitor sizes",
        _ar_sizes,
        dict(order=2, window=20),
        ("order", "window", "refit_every", "reset_after", "reset_keep"),
    ),
    Entry(
        "cusum",
        gf.cusum,
        dict(x=RES, drift=0.1),
        ("x", "drift", "two_sided"),
        lambda s: finite(s),
    ),
    Entry(
        "cusum_arl",
        gf.cusum_arl,
        dict(threshold=5.0, drift=0.5),
        ("threshold", "drift", "shift"),
        lambda x: finite(x) and x > 0,
    ),
    Entry(
        "glr",
        gf.glr,
        dict(residuals=RES, variances=np.ones(3)),
        ("residuals", "variances"),
        lambda s: finite(s),
    ),
    Entry(
        "glr_threshold_bound",
        gf.glr_threshold_bound,
        dict(false_alarm_rate=0.01, window=20),
        ("false_alarm_rate", "window"),
        lambda x: finite(x),
    ),
    Entry(
        "wilson_interval",
        gf.wilson_interval,
        dict(successes=3, trials=10),
        ("successes", "trials", "confidence"),
        lambda lh: finite(*lh),
    ),
    Entry(
        "windowed_sum_of_squares",
        gf.windowed_sum_of_squares,
        dict(residuals=RES, window=5),
        ("residuals", "window"),
        lambda s: finite(s),
    ),
    Entry(
        "latch_alarms",
        gf.latch_alarms,
        dict(alarm=np.array([0, 1, 0, 0], dtype=bool), hold=2),
        ("alarm", "hold"),
        lambda a: a.dtype == bool,
    ),
    Entry(
        "innovation_chi2",
        gf.innovation_chi2,
        dict(x=STREAM, sigma=1.0),
        ("x", "sigma", "pfa"),
    ),
    Entry(
        "calibrate_max",
        gf.calibrate_max,
        dict(
            statistic=np.abs(np.random.default_rng(2).standard_normal((40, 3, 50))),
            false_alarm_rate=0.1,
        ),  # fmt: skip
        ("statistic", "false_alarm_rate"),
        lambda x: finite(x),
    ),
    Entry(
        "fault_hypotheses",
        gf.fault_hypotheses,
        dict(pattern=[True, False, True], structure=BANK.structure),
        ("pattern", "structure", "max_faults"),
    ),
    Entry(
        "roc_curve",
        gf.roc_curve,
        dict(healthy=np.arange(10.0), faulty=np.arange(10.0) + 3),
        ("healthy", "faulty", "label"),
    ),
    Entry(
        "kalman_innovations",
        gf.kalman_innovations,
        dict(A=np.eye(3) * 0.5, C=np.eye(3), Q=np.eye(3), R=np.eye(3), y=Y3.T),
        ("A", "C", "Q", "R", "y", "G", "x0"),
    ),
    Entry(
        "set_blas_threads",
        lambda **kw: (gf.set_blas_threads(**kw), gf.set_blas_threads(1)),
        dict(threads=1),
        ("threads",),
    ),
    Entry(
        "ActuatorBiasFault",
        lambda **kw: gf.ActuatorBiasFault(**kw),
        dict(actuator=0, start=0.5, bias=1.0),
        ("actuator", "start", "bias", "end"),
    ),
    Entry(
        "residual_noise_model",
        gf.residual_noise_model,
        dict(
            plant=PLANT, generator=BANK.generators[0], noise=gf.Noise(measurement=0.1), step=DT
        ),  # fmt: skip
        ("plant", "generator", "noise", "step", "hold"),
    ),
]

__all__ = ["ENTRIES_ONLINE", "TRAINING"]
