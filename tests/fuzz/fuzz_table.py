"""The fuzz table: bad values, entry points and the outcome classifier.

Used by ``test_fuzz_api.py`` and ``test_fuzz_online.py``; kept apart so the table reads as data.
"""

from __future__ import annotations

import contextlib
import math
import signal
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import pytest

import geomfdi as gf
from geomfdi.errors import GeomFDIError

NAN, INF = float("nan"), float("inf")
TIMEOUT = 60  # seconds per case (generous for loaded CI machines); a hang is a failure

BAD_VALUES: dict[str, Any] = {
    "nan": NAN,
    "inf": INF,
    "-inf": -INF,
    "complex": 1 + 2j,
    "text": "abc",
    "none": None,
    "negative": -1,
    "zero": 0,
    "fraction": 2.5,
    "bool": True,
    "bigint": 10**400,
    "huge_count": 10**12,
    "empty": [],
    "ragged": [[1.0, 2.0], [3.0]],
    "deep": [[[[1.0]]]],
    "nan_matrix": [[NAN, 1.0], [1.0, 1.0]],
    "bigint_matrix": [[10**400, 0], [0, 1]],
    "object_array": np.array([object(), 1.0], dtype=object),
    "dict": {"a": 1},
}

# ----------------------------------------------------------------------------- fixtures
A3 = [[1, 1, 1], [0, 1, 0], [2, 0, 1]]
B3 = [[1, 0, 1], [0, 1, 1], [0, 1, 0]]
C3 = [[0, 1, 0], [0, 0, 1], [1, 0, 2]]
PLANT = gf.Plant(A3, B3, C3)
BANK = gf.design_sensor_bank(PLANT)
GEN = BANK.generators[0]
T = np.linspace(0.0, 1.0, 51)
SIM = gf.simulate(PLANT, BANK, T)
RES = SIM.residuals
SUB = gf.image([[1.0], [0.0], [0.0]])
BATCH = gf.simulate_batch(PLANT, BANK, T, runs=2, faults=[gf.BiasFault(0, start=0.5, bias=1.0)],
                          threshold=0.5, progress=False)  # fmt: skip
H6 = gf.parity.dodecahedron()
FDI = gf.ParityFDI(H6)
Z6 = np.random.default_rng(0).standard_normal((20, 6))
WINDOW_ARGS = dict(
    Bf=[[0, 0, 0, 0], [1, 1, 0, 0]],
    Df=[[0, 0, 1, 0], [0, 0, 0, 1]],
    Bw=[[0], [1]],
    Dv=np.eye(2),
    Qw=0.1,
    Rv=[1.0, 0.5],
)
WM = gf.WindowModel([[1, 1], [-1, 1]], [[0], [1]], [[1, 0], [1, 0]], **WINDOW_ARGS)
THETA = np.ones(WM.window)
TRAINING = gf.synthetic_innovations(20, n_series=5, rng=1)
STREAM = gf.synthetic_innovations(60, rng=2)


def fitted_monitor() -> gf.ARMonitor:
    return gf.ARMonitor(order=2, window=20).fit(TRAINING)


# ------------------------------------------------------------------------------ checks
def finite(*arrays: Any) -> bool:
    for a in arrays:
        arr = np.asarray(a)
        if arr.dtype.kind in "fc" and not np.all(np.isfinite(arr)):
            return False
        if arr.dtype == object:
            return False
    return True


def ok_subspace(S: Any) -> bool:
    if type(S).__name__ == "ExactSubspace":  # exact=True: rational basis (sympy)
        return 0 <= S.dim <= S.n
    return finite(S.basis) and S.basis.shape[1] == S.dim


def ok_generator(g: Any) -> bool:
    return finite(g.F, g.E, g.G, g.M, g.H, g.K)


def ok_bank(b: Any) -> bool:
    return all(ok_generator(g) for g in b.generators if g is not None)


def ok_sim(r: Any) -> bool:
    return finite(r.residuals, r.y, r.u) and r.residuals.shape[-1] == r.t.size


def ok_batch(r: Any) -> bool:
    return finite(r.peak) and (r.residuals is None or finite(r.residuals))


def ok_figure(fig: Any) -> bool:
    ok = fig is not None
    plt.close("all")
    return ok


def ok_ar(res: Any) -> bool:
    return finite(res.statistic[res.valid]) and np.isfinite(res.threshold)


def ok_any(_: Any) -> bool:
    return True


@dataclass
class Entry:
    """One public entry point: ``call(**kwargs)`` with valid ``base`` arguments."""

    name: str
    call: Callable[..., Any]
    base: dict[str, Any]
    args: tuple[str, ...]
    check: Callable[[Any], bool] = ok_any
    aliases: dict[str, tuple[str, ...]] = field(default_factory=dict)


def _methodcall(factory: Callable[[], Any], method: str) -> Callable[..., Any]:
    def call(**kw: Any) -> Any:
        return getattr(factory(), method)(**kw)

    return call


def _sig(cls: type) -> Callable[..., Any]:
    def call(**kw: Any) -> Any:
        return cls(**kw).signatures(3, 3)

    return call


def _fault_apply(cls: type) -> Callable[..., Any]:
    def call(**kw: Any) -> Any:
        return cls(**kw).apply(T, SIM.y_healthy)

    return call


def _window_model_kl(**kw: Any) -> Any:
    model = gf.WindowModel(**kw)
    return model.kl_detectability(0, np.ones(model.window))


def _save_png(**kw: Any) -> Any:
    import tempfile

    fig = plt.figure(figsize=(1, 1))
    with tempfile.TemporaryDirectory() as tmp:
        return gf.save_png(fig, f"{tmp}/f.png", **kw)


def _noise_sim(**kw: Any) -> Any:
    return gf.simulate(PLANT, BANK, T, noise=gf.Noise(**kw))


def _threshold_alarms(**kw: Any) -> Any:
    return gf.Threshold(**kw).alarms(RES)


def _tolerance_block(rtol: Any) -> Any:
    with gf.tolerance.tolerance(rtol):
        return gf.min_conditioned_invariant(A3, C3, [[1.0], [0.0], [0.0]])


def _set_rtol(rtol: Any) -> Any:
    try:
        gf.set_rtol(rtol)
        return gf.tolerance.get_rtol(3)
    finally:
        gf.set_rtol(None)


def _set_limits(**kw: Any) -> Any:
    try:
        return gf.limits.set_limits(**kw)
    finally:
        gf.limits.reset_limits()


SF = [gf.SensorFault(0), gf.SensorFault(1)]
ENTRIES = [
    # model
    Entry(
        "Plant",
        gf.Plant,
        dict(A=A3, B=B3, C=C3),
        ("A", "B", "C", "D", "Bd", "dt"),
        lambda p: finite(p.A, p.B, p.C, p.D),
    ),
    Entry(
        "SensorFault",
        _sig(gf.SensorFault),
        dict(i=0),
        ("i", "name"),
        lambda s: finite(*s),
        {"i": ("i", "fault", "sensor")},
    ),
    Entry(
        "ActuatorFault",
        _sig(gf.ActuatorFault),
        dict(b=[1, 0, 0]),
        ("b", "name"),
        lambda s: finite(*s),
        {"b": ("b", "fault")},
    ),
    Entry(
        "Fault",
        _sig(gf.Fault),
        dict(Bf=[[1], [0], [0]]),
        ("Bf", "Df", "name"),
        lambda s: finite(*s),
        {"Bf": ("Bf", "fault"), "Df": ("Df", "fault")},
    ),
    # geometry
    Entry("Subspace", gf.Subspace, dict(M=[[1.0], [0.0]]), ("M", "scale"), ok_subspace),
    Entry("kernel", gf.kernel, dict(M=C3), ("M",), ok_subspace),
    Entry("image", gf.image, dict(M=C3), ("M",), ok_subspace),
    Entry("preimage", gf.preimage, dict(A=A3, S=SUB), ("A", "S"), ok_subspace),
    Entry("apply", gf.apply, dict(A=A3, S=SUB), ("A", "S"), ok_subspace),
    Entry(
        "principal_angles", gf.principal_angles, dict(S=SUB, T=SUB), ("S", "T"), lambda a: finite(a)
    ),
    Entry(
        "min_conditioned_invariant",
        gf.min_conditioned_invariant,
        dict(A=A3, C=C3, L=[[1.0], [0.0], [0.0]]),
        ("A", "C", "L", "exact"),
        ok_subspace,
    ),
    Entry(
        "min_unobservability_subspace",
        gf.min_unobservability_subspace,
        dict(A=A3, C=C3, L=[[1.0], [0.0], [0.0]]),
        ("A", "C", "L", "exact"),
        ok_subspace,
    ),
    Entry(
        "unobservable_subspace", gf.unobservable_subspace, dict(A=A3, C=C3), ("A", "C"), ok_subspace
    ),
    Entry("friend", gf.friend, dict(A=A3, C=C3, S=SUB), ("A", "C", "S"), lambda D: finite(D)),
    # synthesis
    Entry(
        "design_residual_generator",
        gf.design_residual_generator,
        dict(plant=PLANT, faults=SF, target=0),
        (
            "plant",
            "faults",
            "target",
            "decouple",
            "poles",
            "method",
            "filter_pole",
            "margin",
            "minimal",
        ),
        ok_generator,
    ),
    Entry(
        "design_bank",
        gf.design_bank,
        dict(plant=PLANT, faults=SF, structure=[[1, 0], [0, 1]]),
        ("plant", "faults", "structure", "poles", "method", "filter_pole", "margin", "minimal"),
        ok_bank,
    ),
    Entry(
        "design_sensor_bank",
        gf.design_sensor_bank,
        dict(plant=PLANT),
        ("plant", "method", "poles", "filter_pole", "margin", "minimal"),
        ok_bank,
    ),
    Entry(
        "ResidualGenerator",
        gf.ResidualGenerator,
        dict(F=GEN.F, E=GEN.E, G=GEN.G, M=GEN.M, H=GEN.H, K=GEN.K),
        ("F", "E", "G", "M", "H", "K", "dt"),
        ok_generator,
    ),
    Entry(
        "ResidualGenerator.normalized",
        _methodcall(lambda: GEN, "normalized"),
        {},
        ("kind",),
        ok_generator,
    ),
    Entry(
        "ResidualGenerator.scaled",
        _methodcall(lambda: GEN, "scaled"),
        dict(c=2.0),
        ("c",),
        ok_generator,
    ),
    Entry(
        "ResidualBank.normalized", _methodcall(lambda: BANK, "normalized"), {}, ("kind",), ok_bank
    ),
    Entry(
        "pseudo_actuator_model",
        gf.pseudo_actuator_model,
        dict(plant=PLANT, faults=SF),
        ("plant", "faults", "method", "filter_pole"),
        ok_any,
    ),
    # verification
    Entry(
        "verify",
        gf.verify,
        dict(bank_or_generator=BANK, plant=PLANT),
        ("bank_or_generator", "plant", "faults", "method", "tol"),
        lambda r: finite(r.leakage, r.gain) and r.ok,
        {"bank_or_generator": ("bank_or_generator", "bank", "generator")},
    ),
    Entry(
        "verify_symbolic",
        gf.verify_symbolic,
        dict(bank_or_generator=GEN, plant=PLANT),
        ("bank_or_generator", "plant", "faults"),
        lambda r: r.ok,
        {"bank_or_generator": ("bank_or_generator", "bank", "generator")},
    ),
    # simulation
    Entry(
        "simulate",
        gf.simulate,
        dict(plant=PLANT, bank=BANK, t=T),
        (
            "plant",
            "bank",
            "t",
            "u",
            "faults",
            "x0",
            "noise",
            "threshold",
            "hold",
            "consistent_init",
            "keep_states",
            "progress",
        ),
        ok_sim,
    ),
    Entry(
        "simulate_batch",
        gf.simulate_batch,
        dict(plant=PLANT, bank=BANK, t=T, runs=2),
        ("t", "u", "runs", "seeds", "noise", "x0", "store", "chunk_size", "progress"),
        ok_batch,
    ),
    Entry(
        "simulate_lti",
        gf.simulate_lti,
        dict(A=A3, B=B3, C=C3, D=np.zeros((3, 3)), u=np.zeros((3, T.size)), t=T),
        ("A", "B", "C", "D", "u", "t", "x0", "dt", "hold"),
        lambda r: finite(*r),
    ),
    Entry(
        "Noise",
        _noise_sim,
        dict(measurement=0.01, seed=1),
        ("measurement", "process", "process_input", "seed"),
        ok_sim,
        {"seed": ("seed", "noise")},
    ),
    Entry(
        "GainFault",
        _fault_apply(gf.GainFault),
        dict(sensor=0, start=0.5, gain=2.0),
        ("sensor", "start", "gain", "bias", "end"),
        lambda y: finite(y),
    ),
    Entry(
        "BiasFault",
        _fault_apply(gf.BiasFault),
        dict(sensor=0, start=0.5, bias=1.0),
        ("sensor", "start", "bias", "end"),
        lambda y: finite(y),
    ),
    Entry(
        "StuckFault",
        _fault_apply(gf.StuckFault),
        dict(sensor=0, start=0.5),
        ("sensor", "start", "value", "end"),
        lambda y: finite(y),
    ),
    Entry(
        "apply_faults",
        gf.apply_faults,
        dict(faults=[gf.BiasFault(0, start=0.5, bias=1.0)], t=T, y0=SIM.y_healthy),
        ("faults", "t", "y0"),
        lambda y: finite(y),
    ),
    # evaluation
    Entry(
        "Threshold",
        _threshold_alarms,
        dict(values=np.ones(3)),
        ("values", "statistic", "window", "false_alarm_rate"),
        lambda a: a.dtype == bool,
        # a valid one-value threshold meets residuals of 3 rows
        {"values": ("values", "residuals")},
    ),
    Entry(
        "Threshold.alarms",
        _methodcall(lambda: gf.Threshold(np.ones(3)), "alarms"),
        dict(residuals=RES),
        ("residuals",),
        lambda a: a.dtype == bool,
    ),
    Entry(
        "isolate",
        gf.isolate,
        dict(alarms=np.ones((3, 4), dtype=bool), structure=BANK.structure),
        ("alarms", "structure"),
        lambda i: finite(i.isolated),
    ),
    Entry(
        "calibrate_threshold",
        gf.calibrate_threshold,
        dict(
            plant=PLANT,
            bank=BANK,
            t=T,
            noise=gf.Noise(measurement=0.01, seed=3),
            false_alarm_rate=0.05,
            runs=2,
        ),
        (
            "plant",
            "bank",
            "t",
            "noise",
            "false_alarm_rate",
            "runs",
            "statistic",
            "window",
            "per",
            "skip",
        ),
        lambda thr: finite(thr.values),
    ),
    # parity
    Entry(
        "ParityFDI",
        gf.ParityFDI,
        dict(H=H6),
        ("H", "sigma", "D", "basis", "chunk_size", "sensors"),
        lambda f: finite(f.H),
    ),
    Entry(
        "ParityFDI.diagnose",
        _methodcall(lambda: FDI, "diagnose"),
        dict(Z=Z6),
        ("Z", "pfa", "method", "max_faults"),
        lambda d: finite(d.statistic),
    ),
    Entry(
        "ParityFDI.detection_statistic",
        _methodcall(lambda: FDI, "detection_statistic"),
        dict(Z=Z6),
        ("Z",),
        lambda s: finite(s),
    ),
    Entry(
        "ParityFDI.detection_threshold",
        _methodcall(lambda: FDI, "detection_threshold"),
        dict(pfa=0.01),
        ("pfa", "dof"),
        lambda x: finite(x),
    ),
    Entry(
        "ParityFDI.min_detectable_fault",
        _methodcall(lambda: FDI, "min_detectable_fault"),
        dict(pfa=0.01),
        ("pfa", "pd"),
        lambda x: finite(x),
    ),
    Entry(
        "ParityFDI.reduced",
        _methodcall(lambda: FDI, "reduced"),
        dict(remove=0),
        ("remove",),
        lambda f: finite(f.H),
    ),
    Entry(
        "ParityFDI.isolation_statistics",
        _methodcall(lambda: FDI, "isolation_statistics"),
        dict(Z=Z6),
        ("Z",),
        lambda s: finite(s),
    ),
    # diagnosability
    Entry(
        "WindowModel",
        _window_model_kl,
        dict(A=[[1, 1], [-1, 1]], B=[[0], [1]], C=[[1, 0], [1, 0]], **WINDOW_ARGS),
        ("A", "C", "Bf", "Df", "Qw", "Rv", "window", "fault_names", "nullspace"),
        lambda x: finite(x) and x >= 0,
    ),
    Entry(
        "WindowModel.kl_detectability",
        _methodcall(lambda: WM, "kl_detectability"),
        dict(i=0, theta=THETA),
        ("i", "theta", "method"),
        lambda x: finite(x) and x >= 0,
    ),
    Entry(
        "WindowModel.detection_probability",
        _methodcall(lambda: WM, "detection_probability"),
        dict(i=0, theta=THETA),
        ("i", "theta", "alpha"),
        lambda x: finite(x) and 0 <= x <= 1,
    ),
    Entry(
        "WindowModel.directional_isolability",
        _methodcall(lambda: WM, "directional_isolability"),
        dict(i=0, j=1, theta=THETA),
        ("i", "j", "theta", "kappa", "cosine"),
        lambda x: finite(x),
    ),
    Entry(
        "diagnosability_table",
        gf.diagnosability_table,
        dict(model=WM, theta=THETA),
        ("model", "theta", "method", "kappa", "alpha", "digits"),
        lambda tb: finite(tb.values),
    ),
    # monitoring
    Entry(
        "ARMonitor",
        lambda **kw: gf.ARMonitor(**kw).fit(TRAINING).run(STREAM),
        dict(order=2, window=20),
        ("order", "window", "coefficient", "pfa", "reset_after", "reset_keep", "refit_every"),
        ok_ar,
    ),
    Entry(
        "ARMonitor.fit",
        lambda **kw: gf.ARMonitor(order=2, window=20).fit(**kw).run(STREAM),
        dict(training=TRAINING),
        ("training", "step"),
        ok_ar,
    ),
    Entry(
        "ARMonitor.run", _methodcall(fitted_monitor, "run"), dict(stream=STREAM), ("stream",), ok_ar
    ),
    Entry(
        "ARMonitor.update",
        _methodcall(fitted_monitor, "update"),
        dict(x=0.5),
        ("x",),
        lambda r: finite(r[0]) or math.isnan(r[0]),
    ),
    Entry(
        "synthetic_innovations",
        gf.synthetic_innovations,
        dict(n_samples=30, rng=0),
        ("n_samples", "sigma", "ar", "fault", "size", "start", "stop", "n_series", "rng"),
        lambda x: finite(x),
    ),
    Entry(
        "innovation_fault",
        gf.innovation_fault,
        dict(n_samples=30),
        ("n_samples", "kind", "size", "start", "stop", "sigma"),
        lambda x: finite(x),
    ),
    # plotting
    Entry(
        "plot_residuals",
        gf.plot_residuals,
        dict(t=T, residuals=RES),
        ("t", "residuals", "threshold", "labels", "statistic"),
        ok_figure,
    ),
    Entry(
        "plot_structure",
        gf.plot_structure,
        dict(structure=BANK.structure),
        ("structure", "requested", "fault_labels"),
        ok_figure,
    ),
    # more geometry, synthesis and evaluation helpers
    Entry(
        "friends", gf.friends, dict(A=A3, C=C3, S=SUB), ("A", "C", "S"), lambda fs: finite(fs.D0)
    ),
    Entry(
        "is_conditioned_invariant",
        gf.is_conditioned_invariant,
        dict(A=A3, C=C3, W=SUB),
        ("A", "C", "W"),
        lambda b: isinstance(b, bool),
    ),
    Entry(
        "is_unobservability_subspace",
        gf.is_unobservability_subspace,
        dict(A=A3, C=C3, S=SUB),
        ("A", "C", "S"),
        lambda b: isinstance(b, bool),
    ),
    Entry(
        "measurement_map", gf.measurement_map, dict(C=C3, S=SUB), ("C", "S"), lambda H: finite(H)
    ),
    Entry(
        "minimal_realization",
        gf.minimal_realization,
        dict(A=A3, B=B3, C=C3, D=np.zeros((3, 3))),
        ("A", "B", "C", "D"),
        lambda r: finite(r.A, r.B, r.C, r.D),
    ),
    Entry("reachable_subspace", gf.reachable_subspace, dict(A=A3, B=B3), ("A", "B"), ok_subspace),
    Entry(
        "Threshold.from_residuals",
        gf.Threshold.from_residuals,
        dict(residuals=np.random.default_rng(1).standard_normal((3, 400)), false_alarm_rate=0.05),
        ("residuals", "false_alarm_rate", "statistic", "window", "per", "skip"),
        lambda thr: finite(thr.values),
    ),
    Entry(
        "SimulationResult.max_abs",
        _methodcall(lambda: SIM, "max_abs"),
        {},
        ("start", "stop"),
        lambda x: finite(x),
    ),
    Entry(
        "BatchResult.detection_rate",
        _methodcall(lambda: BATCH, "detection_rate"),
        {},
        ("which",),
        lambda x: finite(x),
    ),
    Entry(
        "WindowModel.kl_isolability",
        _methodcall(lambda: WM, "kl_isolability"),
        dict(i=0, j=1, theta=THETA),
        ("i", "j", "theta"),
        lambda x: finite(x) and x >= 0,
    ),
    Entry(
        "WindowModel.isolation_probability",
        _methodcall(lambda: WM, "isolation_probability"),
        dict(i=0, j=1, theta=THETA),
        ("i", "j", "theta", "alpha"),
        lambda x: finite(x) and 0 <= x <= 1,
    ),
    Entry(
        "WindowModel.applicability",
        _methodcall(lambda: WM, "applicability"),
        {},
        ("theta",),
        ok_any,
    ),
    Entry(
        "ARMonitor.set_normal",
        _methodcall(fitted_monitor, "set_normal"),
        dict(normal=np.zeros(19)),  # window - 1 samples
        ("normal",),
        ok_any,
    ),
    Entry(
        "plot_isolability",
        gf.plot_isolability,
        dict(table=WM.table(THETA)),
        ("table", "cmap", "annotate", "title"),
        ok_figure,
    ),
    Entry(
        "plot_ar_monitor",
        gf.plot_ar_monitor,
        dict(result=fitted_monitor().run(STREAM)),
        ("result", "time", "row", "logy"),
        ok_figure,
    ),
    Entry("save_png", _save_png, dict(dpi=50), ("dpi",), ok_any),
    # policy modules
    Entry("set_rtol", _set_rtol, dict(rtol=1e-9), ("rtol",), lambda x: 0 < x < 1),
    Entry("tolerance", _tolerance_block, dict(rtol=1e-9), ("rtol",), ok_subspace),
    Entry(
        "limits.set_limits",
        _set_limits,
        dict(max_runs=10),
        ("max_runs", "max_samples", "max_memory", "max_symbolic_size"),
        ok_any,
    ),
]


def _valid_alone(value: Any) -> bool:
    """A finite real number or array: valid in isolation, so an error naming the other
    argument of a conflicting pair (``A`` is 1 x 1 but ``C`` has 3 columns) is right."""
    if isinstance(value, bool | str | dict) or value is None:
        return False
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError, OverflowError):
        return False
    return arr.size > 0 and bool(np.all(np.isfinite(arr)))


class _Timeout(Exception):
    pass


@contextlib.contextmanager
def _time_limit(seconds: int):
    def handler(signum: int, frame: Any) -> None:
        raise _Timeout(f"no answer after {seconds} s")

    old = signal.signal(signal.SIGALRM, handler)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def outcome(entry: Entry, arg: str, value: Any) -> tuple[str, str]:
    """Run one case; return (class, detail) with class ``named``/``correct``/other."""
    kwargs = dict(entry.base)
    kwargs[arg] = value
    names = entry.aliases.get(arg, (arg,))
    try:
        with warnings.catch_warnings(), _time_limit(TIMEOUT):
            warnings.simplefilter("ignore")
            warnings.simplefilter("error", RuntimeWarning)
            result = entry.call(**kwargs)
            good = entry.check(result)
    except GeomFDIError as err:
        named = err.argument or ""
        if any(n in named or n in str(err) for n in names):
            return "named", ""
        if named in entry.args and _valid_alone(value):
            return "named", f"conflict with {named}"
        return "unnamed error", f"{type(err).__name__}(argument={err.argument!r}): {err}"
    except _Timeout as err:
        return "hang", str(err)
    except Exception as err:  # noqa: BLE001 - the point is to classify anything
        return "raw", f"{type(err).__name__}: {str(err)[:300]}"
    finally:
        plt.close("all")
    return ("correct", "") if good else ("wrong result", repr(result)[:300])


def cases(entries: list[Entry]) -> list[Any]:
    """One pytest case per (entry point, argument) of ``entries``."""
    return [pytest.param(e, arg, id=f"{e.name}-{arg}") for e in entries for arg in e.args]


def bad_value_failures(entry: Entry, arg: str) -> list[str]:
    """Every value of :data:`BAD_VALUES` in place of ``arg``: the ones whose outcome is
    neither ``named`` nor ``correct``, with what happened."""
    failures = []
    for value_name, value in BAD_VALUES.items():
        kind, detail = outcome(entry, arg, value)
        if kind not in ("named", "correct"):
            failures.append(f"{value_name}: {kind}: {detail}")
    return failures


def base_call_holds(entry: Entry) -> bool:
    """Whether the unmodified call passes the entry point's check (warnings silenced)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return bool(entry.check(entry.call(**entry.base)))
