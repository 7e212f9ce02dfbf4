"""Model files (TOML): plant, design options and simulation scenarios.

A model file has four parts (sensor and input indices are 0-based)::

    name = "Hou, Wen & Chen 2011, section 4"

    [plant]                      # A, C required; B, D, Bd, Dd, Bw, Dw optional; dt = 0
                                 #   (continuous); Bw, Dw: noise inputs (not decoupled)
                                 # optional: inputs, outputs, states, disturbances, noise
                                 # (names; faults and recorded-data columns may use them),
                                 # x_op, u_op, y_op (the operating point)
    A = [[1, 1, 1], [0, 1, 0], [2, 0, 1]]
    B = [[1, 0, 1], [0, 1, 1], [0, 1, 0]]
    C = [[0, 1, 0], [0, 0, 1], [1, 0, 2]]

    [design]                     # all optional
    methods = ["paper", "exact"] # designs run side by side (default ["exact"])
    poles = [-2]                 # quotient spectrum (default: move only what must move);
                                 # a list of lists: one spectrum per row
    normalize = "markov"         # "dc" or "markov" (unit first Markov parameter)
    structure = [[1, 0, 0], ...] # default: identity (one residual per fault)
    residual_dim = 2             # exact method: rows per residual (or a list per row)
    common_poles = false         # exact method: one pole list for every row
    [design.paper]               # per-method overrides: poles, normalize, filter_pole,
    poles = [-2]                 #   margin, residual_dim, common_poles
    [[design.faults]]            # default: one sensor fault per output
    type = "sensor"              # or "actuator" (b = [...]) or "general" (Bf, Df)
    sensor = 0

    [simulation]
    t_end = 20.0
    step = 0.01
    x0 = [0.5, -0.3, 0.2]
    u = ["sin(0.5*t)", "cos(0.3*t)", "0.2"]   # numbers or expressions of t
    d = ["0.1*step(t - 3)"]      # disturbance, one entry per column of Bd / Dd (default 0)
    K = [[5, -1.5, 3], [2, 0, 2], [-2, 2.5, -2]]   # state feedback u = u(t) - K x
    threshold = 0.06             # number, list per residual, or {false_alarm_rate, runs}
    window = [8.0, 20.0]         # where the report measures max |r|
    [simulation.noise]           # optional: measurement, process, inputs (std: one number
    measurement = 0.001          # or one per sensor / state / noise input of Bw, Dw),
                                 # seed (integer >= 0)
    seed = 1

    [[scenario]]                 # optional per scenario: noise (table), d (list)
    name = "sensor 0 gain step"
    [[scenario.faults]]
    type = "gain"                # "gain" (gain, bias), "bias" (bias), "stuck" (value);
    sensor = 0                   # an index or an output name.  Also "actuator gain",
                                 # "actuator bias", "actuator stuck" (actuator = index or
                                 # input name) and "additive" (fault = a design fault's
                                 # index or name; size, slope or signal = expression of t)
    start = 8.0
    gain = 1.5                   # number or expression of t
    bias = 0.02                  # optional: end = time the fault disappears

An optional ``[campaign]`` table describes a Monte-Carlo campaign; it is read by
``geomfdi campaign`` (:mod:`geomfdi.campaign.config`) and ignored here.

Expressions of ``t`` follow the grammar of :mod:`geomfdi.io.expressions`.  A calibrated
threshold (``threshold = {false_alarm_rate = 1e-3, runs = 10}``) needs measurement or
process noise in ``[simulation.noise]``; it is computed from noise-only runs of the
healthy loop (:func:`geomfdi.calibrate_threshold`).

Every problem raises :class:`~geomfdi.errors.ModelFileError` with a one-line message
naming the file, the entry and what is wrong (a wrong shape names the matrix and the
expected shape).
"""

from __future__ import annotations

import tomllib
from collections.abc import Callable
from dataclasses import dataclass, field
from difflib import get_close_matches
from pathlib import Path
from typing import Any

import numpy as np

from geomfdi.errors import GeomFDIError, ModelFileError
from geomfdi.io.expressions import compile_expression
from geomfdi.model.faults import ActuatorFault, Fault, SensorFault
from geomfdi.model.plant import Plant
from geomfdi.synthesis.design import METHODS

__all__ = [
    "ModelSpec",
    "MethodOptions",
    "Scenario",
    "load_model",
    "parse_model",
    "MAX_SAMPLES",
    "MAX_RUNS",
    "MAX_NESTING",
]

MAX_SAMPLES = 10_000_000
"""Largest simulation grid a model file may ask for."""

MAX_RUNS = 10_000
"""Most noise-only runs a calibrated threshold (``threshold = {runs = ...}``) may ask for."""

MAX_NESTING = 3
"""Deepest nesting of arrays in a model file (a matrix is 2)."""

_FLOAT_MAX = float(np.finfo(float).max)

# "campaign" is read by geomfdi.campaign.config (``geomfdi campaign``), not here
_TOP = {"name", "description", "plant", "design", "simulation", "scenario", "campaign"}
_PLANT = {
    "A",
    "B",
    "C",
    "D",
    "Bd",
    "Dd",
    "Bw",
    "Dw",
    "dt",
    "inputs",
    "outputs",
    "states",
    "disturbances",
    "noise",
    "x_op",
    "u_op",
    "y_op",
}
_DESIGN = {
    "methods",
    "poles",
    "normalize",
    "structure",
    "faults",
    "filter_pole",
    "margin",
    "residual_dim",
    "common_poles",
    "exact",
    "full",
    "paper",
    "mvw",
}
_METHOD = {"poles", "normalize", "filter_pole", "margin", "residual_dim", "common_poles"}
_SIM = {"t_end", "step", "x0", "u", "d", "K", "threshold", "window", "noise", "t_start"}
_NOISE = {"measurement", "process", "inputs", "seed", "generator"}
_SCEN = {"name", "faults", "noise", "d"}
_FAULT_KEYS = {
    "gain": {"type", "sensor", "start", "gain", "bias", "end"},
    "bias": {"type", "sensor", "start", "bias", "end"},
    "stuck": {"type", "sensor", "start", "value", "end"},
    "actuator gain": {"type", "actuator", "start", "gain", "bias", "end"},
    "actuator bias": {"type", "actuator", "start", "bias", "end"},
    "actuator stuck": {"type", "actuator", "start", "value", "end"},
    "additive": {"type", "fault", "start", "size", "slope", "signal", "end"},
}


@dataclass
class MethodOptions:
    """Design options for one method."""

    method: str
    poles: Any = None
    normalize: str | None = None
    filter_pole: float | None = None
    margin: float | None = None
    residual_dim: int | list[int | None] | None = None
    common_poles: bool = False


@dataclass
class Scenario:
    """One simulation run: a name, its fault signals and optional overrides.

    ``noise`` and ``d`` replace the ``[simulation]`` entries for this run when given.
    """

    name: str
    faults: list[Any]
    noise: dict[str, Any] | None = None
    d: Callable[[np.ndarray], np.ndarray] | None = None


@dataclass
class ModelSpec:
    """Everything a model file describes (see the module docstring)."""

    name: str
    plant: Plant
    faults: list[Fault]
    structure: np.ndarray
    methods: list[MethodOptions]
    t: np.ndarray | None = None
    u: Callable[[np.ndarray], np.ndarray] | None = None
    d: Callable[[np.ndarray], np.ndarray] | None = None
    K: np.ndarray | None = None
    x0: np.ndarray | None = None
    threshold: Any = None
    window: tuple[float, float] | None = None
    noise: dict[str, Any] | None = None
    scenarios: list[Scenario] = field(default_factory=list)
    source: str = ""


class _Ctx:
    def __init__(self, source: str) -> None:
        self.source = source

    def err(self, where: str, msg: str) -> ModelFileError:
        return ModelFileError(f"{self.source}: {where}: {msg}", argument=where)

    def keys(self, table: Any, allowed: set[str], where: str) -> dict[str, Any]:
        if not isinstance(table, dict):
            raise self.err(where, f"expected a table, got {type(table).__name__}")
        unknown = sorted(set(table) - allowed)
        if unknown:
            close = get_close_matches(unknown[0], sorted(allowed), n=1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            raise self.err(
                where,
                f"unknown key {unknown[0]!r} ({hint}allowed: {', '.join(sorted(allowed))})",
            )
        return table

    def number(
        self, value: Any, where: str, *, positive: bool = False, nonnegative: bool = False
    ) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.err(where, f"expected a number, got {value!r}")
        if isinstance(value, int) and abs(value) > _FLOAT_MAX:
            raise self.err(where, "expected a finite number, got an integer too large for a float")
        x = float(value)
        if not np.isfinite(x) or (positive and x <= 0) or (nonnegative and x < 0):
            kind = "positive " if positive else "non-negative " if nonnegative else ""
            raise self.err(where, f"expected a {kind}finite number, got {value!r}")
        return x

    def integer(self, value: Any, where: str, *, minimum: int | None = None) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.err(where, f"expected an integer, got {value!r}")
        if minimum is not None and value < minimum:
            raise self.err(where, f"expected an integer >= {minimum}, got {value!r}")
        return int(value)

    def matrix(self, value: Any, where: str, shape: tuple[int | None, int | None]) -> np.ndarray:
        if not isinstance(value, list):
            raise self.err(where, f"expected a matrix (list of rows), got {value!r}")
        rows = value if (value and isinstance(value[0], list)) else [value] if value else []
        for r, row in enumerate(rows):
            if not isinstance(row, list):
                raise self.err(where, f"row {r} is not a list")
            for c, x in enumerate(row):
                if isinstance(x, bool) or not isinstance(x, int | float):
                    raise self.err(f"{where}[{r}][{c}]", f"expected a number, got {x!r}")
                if isinstance(x, int) and abs(x) > _FLOAT_MAX:
                    raise self.err(f"{where}[{r}][{c}]", "integer too large for a float")
        widths = {len(row) for row in rows}
        if len(widths) > 1:
            raise self.err(where, f"rows have different lengths {sorted(widths)}")
        arr = np.array(rows, dtype=float).reshape(len(rows), widths.pop() if widths else 0)
        er, ec = shape
        if (er is not None and arr.shape[0] != er) or (ec is not None and arr.shape[1] != ec):
            exp = f"({'any' if er is None else er}, {'any' if ec is None else ec})"
            raise self.err(where, f"expected shape {exp}, got {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise self.err(where, "entries must be finite")
        return arr

    def expr(self, value: Any, where: str) -> Callable[[np.ndarray], np.ndarray]:
        """A number or an expression of t (errors name the file and the entry)."""
        try:
            f = compile_expression(value, where)
        except ModelFileError as exc:
            raise ModelFileError(f"{self.source}: {exc}", argument=where) from exc

        def g(t: np.ndarray) -> np.ndarray:
            try:
                return f(t)
            except ModelFileError as exc:
                raise ModelFileError(f"{self.source}: {exc}", argument=where) from exc

        g.__name__ = "f"  # fault labels show "f(t)"
        g.expression = value  # type: ignore[attr-defined]
        return g

    def vector(
        self,
        value: Any,
        where: str,
        length: int | None = None,
        *,
        positive: bool = False,
        nonnegative: bool = False,
    ) -> np.ndarray:
        if not isinstance(value, list) or any(isinstance(v, list) for v in value):
            raise self.err(where, f"expected a list of numbers, got {value!r}")
        arr = np.array(
            [
                self.number(v, f"{where}[{k}]", positive=positive, nonnegative=nonnegative)
                for k, v in enumerate(value)
            ],
            dtype=float,
        )
        if length is not None and arr.size != length:
            raise self.err(where, f"expected {length} entries, got {arr.size}")
        return arr


def _plant(ctx: _Ctx, table: Any) -> Plant:
    t = ctx.keys(table, _PLANT, "plant")
    for req in ("A", "C"):
        if req not in t:
            raise ctx.err(f"plant.{req}", "missing (the plant needs A and C)")
    A = ctx.matrix(t["A"], "plant.A", (None, None))
    n = A.shape[0]
    if A.shape != (n, n) or n == 0:
        raise ctx.err("plant.A", f"expected a square non-empty matrix, got shape {A.shape}")
    C = ctx.matrix(t["C"], "plant.C", (None, n))
    q = C.shape[0]
    B = ctx.matrix(t["B"], "plant.B", (n, None)) if "B" in t else None
    m = 0 if B is None else B.shape[1]
    D = ctx.matrix(t["D"], "plant.D", (q, m)) if "D" in t else None
    Bd = ctx.matrix(t["Bd"], "plant.Bd", (n, None)) if "Bd" in t else None
    kd = None if Bd is None else Bd.shape[1]
    Dd = ctx.matrix(t["Dd"], "plant.Dd", (q, kd)) if "Dd" in t else None
    Bw = ctx.matrix(t["Bw"], "plant.Bw", (n, None)) if "Bw" in t else None
    kw = None if Bw is None else Bw.shape[1]
    Dw = ctx.matrix(t["Dw"], "plant.Dw", (q, kw)) if "Dw" in t else None
    dt = ctx.number(t.get("dt", 0.0), "plant.dt")
    sig: dict[str, Any] = {}
    for key in ("inputs", "outputs", "states", "disturbances", "noise"):
        if key in t:
            names = t[key]
            if not isinstance(names, list) or not all(isinstance(v, str) for v in names):
                raise ctx.err(f"plant.{key}", "expected a list of names (strings)")
            sig[key] = names
    for key in ("x_op", "u_op", "y_op"):
        if key in t:
            sig[key] = ctx.vector(t[key], f"plant.{key}")
    try:
        return Plant(A, B, C, D, Bd=Bd, Dd=Dd, Bw=Bw, Dw=Dw, dt=dt, **sig)
    except GeomFDIError as exc:
        raise ctx.err("plant", str(exc)) from exc


def _channel(ctx: _Ctx, key: Any, where: str, plant: Plant, kind: str) -> int:
    """An output or input given by its 0-based index or by the plant's name for it."""
    names = plant.outputs if kind == "output" else plant.inputs
    if isinstance(key, str):
        if key not in names:
            raise ctx.err(where, f"no {kind} named {key!r} (the {kind}s are {list(names)})")
        return list(names).index(key)
    if isinstance(key, bool) or not isinstance(key, int) or not 0 <= key < len(names):
        raise ctx.err(
            where, f"expected an {kind} index in 0..{len(names) - 1} or a name, got {key!r}"
        )
    return key


def _design_faults(ctx: _Ctx, items: Any, plant: Plant) -> list[Fault]:
    if not isinstance(items, list):
        raise ctx.err("design.faults", "expected an array of tables [[design.faults]]")
    out: list[Fault] = []
    for k, item in enumerate(items):
        where = f"design.faults[{k}]"
        if not isinstance(item, dict) or "type" not in item:
            raise ctx.err(where, "each fault needs a 'type' (sensor, actuator, general)")
        kind = item["type"]
        if kind == "sensor":
            ctx.keys(item, {"type", "sensor", "name"}, where)
            i = _channel(ctx, item.get("sensor"), f"{where}.sensor", plant, "output")
            out.append(SensorFault(i, name=item.get("name")))
        elif kind == "actuator":
            ctx.keys(item, {"type", "b", "name"}, where)
            b = ctx.matrix(item.get("b", []), f"{where}.b", (None, None))
            b = b.T if b.shape[0] == 1 and b.shape[1] == plant.n else b
            if b.shape[0] != plant.n:
                raise ctx.err(f"{where}.b", f"expected {plant.n} rows, got shape {b.shape}")
            out.append(ActuatorFault(b, name=item.get("name")))
        elif kind == "general":
            ctx.keys(item, {"type", "Bf", "Df", "name"}, where)
            Bf = ctx.matrix(item["Bf"], f"{where}.Bf", (plant.n, None)) if "Bf" in item else None
            k_ = None if Bf is None else Bf.shape[1]
            Df = ctx.matrix(item["Df"], f"{where}.Df", (plant.q, k_)) if "Df" in item else None
            if Bf is None and Df is None:
                raise ctx.err(where, "a general fault needs Bf or Df")
            out.append(Fault(Bf, Df, name=item.get("name")))
        else:
            raise ctx.err(
                f"{where}.type", f"unknown fault type {kind!r} (sensor, actuator, general)"
            )
    if not out:
        raise ctx.err("design.faults", "at least one fault is required")
    return out


def _positive_below_one(ctx: _Ctx, value: Any, where: str, plant: Plant, name: str) -> float:
    """A number ``> 0``, and ``< 1`` on a discrete plant."""
    a = ctx.number(value, where, positive=True)
    if plant.is_discrete and a >= 1:
        raise ctx.err(where, f"expected 0 < {name} < 1 for a discrete plant, got {value!r}")
    return a


def _filter_pole(ctx: _Ctx, value: Any, where: str, plant: Plant) -> float:
    """The output-filter parameter ``a``: ``a > 0`` (continuous), ``0 < a < 1`` (discrete)."""
    return _positive_below_one(ctx, value, where, plant, "filter_pole")


def _residual_dim(ctx: _Ctx, value: Any, where: str) -> int | list[int | None] | None:
    """Rows per residual: a whole number ≥ 1 for every row, or a list (0: the default)."""

    def one(v: Any, at: str) -> int:
        if isinstance(v, bool) or not isinstance(v, int) or v < 0:
            raise ctx.err(at, f"expected a whole number >= 1, got {v!r}")
        return v

    if value is None:
        return None
    if isinstance(value, list):
        return [one(v, f"{where}[{i}]") or None for i, v in enumerate(value)]
    v = one(value, where)
    if v == 0:
        raise ctx.err(where, "expected a whole number >= 1, got 0")
    return v


def _flag(ctx: _Ctx, value: Any, where: str) -> bool:
    if value is None:
        return False
    if not isinstance(value, bool):
        raise ctx.err(where, f"expected true or false, got {value!r}")
    return value


def _margin(ctx: _Ctx, value: Any, where: str, plant: Plant) -> float:
    """Stability margin: ``Re λ <= -margin`` (continuous) or ``|λ| <= margin < 1`` (discrete)."""
    return _positive_below_one(ctx, value, where, plant, "margin")


def _method_options(ctx: _Ctx, d: dict[str, Any], plant: Plant) -> list[MethodOptions]:
    methods = d.get("methods", ["exact"])
    if isinstance(methods, str):
        methods = [methods]
    if not isinstance(methods, list) or not methods:
        raise ctx.err("design.methods", f"expected a list of methods, got {methods!r}")
    out = []
    for k, meth in enumerate(methods):
        if meth not in METHODS:
            raise ctx.err(f"design.methods[{k}]", f"unknown method {meth!r} ({', '.join(METHODS)})")
        sub = ctx.keys(d.get(meth, {}), _METHOD, f"design.{meth}")
        merged = {key: d.get(key) for key in _METHOD} | sub

        norm = merged.get("normalize")
        if norm is not None and norm not in ("dc", "markov"):
            raise ctx.err(f"design.{meth}.normalize", f"expected 'dc' or 'markov', got {norm!r}")
        poles = merged.get("poles")
        if isinstance(poles, list) and poles and all(isinstance(p, list) for p in poles):
            poles = [ctx.vector(p, f"design.{meth}.poles[{r}]") for r, p in enumerate(poles)]
        elif poles is not None:
            poles = ctx.vector(poles, f"design.{meth}.poles")
        fp = merged.get("filter_pole")
        mg = merged.get("margin")
        out.append(
            MethodOptions(
                meth,
                poles,
                norm,
                None if fp is None else _filter_pole(ctx, fp, f"design.{meth}.filter_pole", plant),
                None if mg is None else _margin(ctx, mg, f"design.{meth}.margin", plant),
                _residual_dim(ctx, merged.get("residual_dim"), f"design.{meth}.residual_dim"),
                _flag(ctx, merged.get("common_poles"), f"design.{meth}.common_poles"),
            )
        )
    return out


def _fault_signal(
    ctx: _Ctx, item: Any, where: str, plant: Plant, t: np.ndarray, design: list[Fault]
) -> Any:
    from geomfdi.simulation import input_faults as inf
    from geomfdi.simulation.signals import BiasFault, GainFault, StuckFault

    kinds = ", ".join(_FAULT_KEYS)
    if not isinstance(item, dict) or "type" not in item:
        raise ctx.err(where, f"each fault needs a 'type' ({kinds})")
    kind = item["type"]
    if kind not in _FAULT_KEYS:
        raise ctx.err(f"{where}.type", f"unknown fault type {kind!r} ({kinds})")
    ctx.keys(item, _FAULT_KEYS[kind], where)
    chan = "fault" if kind == "additive" else "actuator" if "actuator" in kind else "sensor"
    for req in (chan, "start"):
        if req not in item:
            raise ctx.err(f"{where}.{req}", "missing")
    if chan == "sensor":
        s = _channel(ctx, item["sensor"], f"{where}.sensor", plant, "output")
    elif chan == "actuator":
        s = _channel(ctx, item["actuator"], f"{where}.actuator", plant, "input")
    else:
        labels = [f.name for f in design]
        s = item["fault"]
        if isinstance(s, str) and s in labels:
            s = labels.index(s)
        if isinstance(s, bool) or not isinstance(s, int) or not 0 <= s < len(design):
            raise ctx.err(
                f"{where}.fault",
                f"expected a design fault index in 0..{len(design) - 1} or one of {labels}",
            )
    start = ctx.number(item["start"], f"{where}.start")
    end = None if "end" not in item else ctx.number(item["end"], f"{where}.end")

    active = t[(t >= start) & (t < (np.inf if end is None else end))]

    def value(key: str, default: float) -> Any:
        v = item.get(key, default)
        if isinstance(v, str):
            f = ctx.expr(v, f"{where}.{key}")
            f(active)  # finite wherever the fault acts
            return f
        return ctx.number(v, f"{where}.{key}")

    def need(key: str) -> None:
        if key not in item:
            raise ctx.err(f"{where}.{key}", "missing")

    held = item.get("value")
    held = None if held is None else ctx.number(held, f"{where}.value")
    try:
        if kind in ("gain", "actuator gain"):
            need("gain")
            cls = GainFault if kind == "gain" else inf.ActuatorGainFault
            return cls(s, start=start, gain=value("gain", 1.0), bias=value("bias", 0.0), end=end)
        if kind in ("bias", "actuator bias"):
            need("bias")
            cls = BiasFault if kind == "bias" else inf.ActuatorBiasFault
            return cls(s, start=start, bias=value("bias", 0.0), end=end)
        if kind in ("stuck", "actuator stuck"):
            cls = StuckFault if kind == "stuck" else inf.ActuatorStuckFault
            return cls(s, start=start, value=held, end=end)
        sig = item.get("signal")
        return inf.AdditiveFault(
            design[s],
            start=start,
            size=ctx.number(item.get("size", 1.0), f"{where}.size"),
            slope=ctx.number(item.get("slope", 0.0), f"{where}.slope"),
            signal=None if sig is None else value("signal", 0.0),
            end=end,
        )
    except ModelFileError:
        raise
    except GeomFDIError as exc:
        raise ctx.err(where, str(exc)) from exc


def _noise(ctx: _Ctx, table: Any, where: str, plant: Plant) -> dict[str, Any]:
    t = ctx.keys(table, _NOISE, where)
    out: dict[str, Any] = {}
    if "inputs" in t and plant.nw == 0:
        raise ctx.err(f"{where}.inputs", "the plant has no noise inputs (no Bw or Dw)")
    for key, dim in (("measurement", plant.q), ("process", plant.n), ("inputs", plant.nw)):
        if key in t:
            v = t[key]
            out[key] = (
                ctx.vector(v, f"{where}.{key}", dim, nonnegative=True)
                if isinstance(v, list)
                else ctx.number(v, f"{where}.{key}", nonnegative=True)
            )
    if "seed" in t:
        out["seed"] = ctx.integer(t["seed"], f"{where}.seed", minimum=0)
    if "generator" in t:
        from geomfdi.simulation.noise import GENERATORS

        if t["generator"] not in GENERATORS:
            raise ctx.err(f"{where}.generator", f"expected one of {GENERATORS}")
        out["generator"] = t["generator"]
    return out


def _signals(ctx: _Ctx, value: Any, where: str, length: int, what: str, grid: np.ndarray) -> Any:
    """A list of ``length`` numbers / expressions of t -> f(t) of shape (length, N)."""
    if not isinstance(value, list) or len(value) != length:
        raise ctx.err(where, f"expected a list of {length} entries (one per {what}), got {value!r}")
    fns = [ctx.expr(v, f"{where}[{k}]") for k, v in enumerate(value)]
    for f in fns:
        f(grid)  # finite on the simulation grid
    return lambda t, fns=fns: np.vstack([f(t) for f in fns])


def parse_model(data: dict[str, Any], source: str = "<model>") -> ModelSpec:
    """Validate a parsed TOML document and build a :class:`ModelSpec`."""
    ctx = _Ctx(source)
    _check_nesting(ctx, data, "")
    ctx.keys(data, _TOP, "top level")
    if "plant" not in data:
        raise ctx.err("plant", "missing [plant] table")
    plant = _plant(ctx, data["plant"])
    d = ctx.keys(data.get("design", {}), _DESIGN, "design")
    faults = (
        _design_faults(ctx, d["faults"], plant)
        if "faults" in d
        else [SensorFault(i) for i in range(plant.q)]
    )
    if "structure" in d:
        S = ctx.matrix(d["structure"], "design.structure", (None, len(faults)))
        if not np.all((S == 0) | (S == 1)):
            raise ctx.err("design.structure", "entries must be 0 or 1")
    else:
        S = np.eye(len(faults))
    methods = _method_options(ctx, d, plant)
    spec = ModelSpec(
        str(data.get("name", Path(source).stem)), plant, faults, S, methods, source=source
    )
    if "simulation" in data:
        s = ctx.keys(data["simulation"], _SIM, "simulation")
        if "t_end" not in s:
            raise ctx.err("simulation.t_end", "missing")
        t0 = ctx.number(s.get("t_start", 0.0), "simulation.t_start")
        t_end = ctx.number(s["t_end"], "simulation.t_end")
        step = (
            plant.dt
            if plant.is_discrete
            else ctx.number(s.get("step", (t_end - t0) / 2000), "simulation.step", positive=True)
        )
        if (
            plant.is_discrete
            and "step" in s
            and abs(ctx.number(s["step"], "simulation.step") - plant.dt) > 1e-12
        ):
            raise ctx.err(
                "simulation.step", f"must equal plant.dt = {plant.dt} for a discrete plant"
            )
        if t_end <= t0:
            raise ctx.err("simulation.t_end", f"must exceed t_start = {t0}")
        with np.errstate(over="ignore"):
            span = (t_end - t0) / step
        if not np.isfinite(span) or span + 1 > MAX_SAMPLES:
            count = f"{span + 1:.3g}" if np.isfinite(span) else "more than 1e308"
            raise ctx.err(
                "simulation.step",
                f"the grid would hold {count} samples (at most {MAX_SAMPLES}); use a larger step",
            )
        N = int(round(span)) + 1
        if N < 2:
            raise ctx.err("simulation.step", f"must be smaller than t_end - t_start, got {step}")
        spec.t = t0 + step * np.arange(N)
        if "u" in s:
            spec.u = _signals(ctx, s["u"], "simulation.u", plant.m, "input", spec.t)
        if "d" in s:
            if plant.nd == 0:
                raise ctx.err("simulation.d", "the plant has no disturbance (no Bd or Dd)")
            spec.d = _signals(ctx, s["d"], "simulation.d", plant.nd, "disturbance", spec.t)
        if "K" in s:
            spec.K = ctx.matrix(s["K"], "simulation.K", (plant.m, plant.n))
        if "x0" in s:
            spec.x0 = ctx.vector(s["x0"], "simulation.x0", plant.n)
        if "threshold" in s:
            th = s["threshold"]
            if isinstance(th, dict):
                ctx.keys(th, {"false_alarm_rate", "runs"}, "simulation.threshold")
                far = ctx.number(
                    th.get("false_alarm_rate", 1e-3),
                    "simulation.threshold.false_alarm_rate",
                    positive=True,
                )
                if far >= 1:
                    raise ctx.err("simulation.threshold.false_alarm_rate", "must be < 1")
                runs = ctx.integer(th.get("runs", 4), "simulation.threshold.runs", minimum=1)
                if runs > MAX_RUNS:
                    raise ctx.err(
                        "simulation.threshold.runs",
                        f"at most {MAX_RUNS} calibration runs, got {runs}",
                    )
                spec.threshold = {"false_alarm_rate": far, "runs": runs}
            elif isinstance(th, list):
                spec.threshold = ctx.vector(th, "simulation.threshold", len(S), positive=True)
            else:
                spec.threshold = ctx.number(th, "simulation.threshold", positive=True)
        if "window" in s:
            w = ctx.vector(s["window"], "simulation.window", 2)
            if not (w[0] < w[1] and w[0] <= spec.t[-1] and w[1] >= spec.t[0]):
                raise ctx.err(
                    "simulation.window",
                    f"expected [start, stop] with start < stop overlapping "
                    f"[{spec.t[0]:g}, {spec.t[-1]:g}], got {s['window']!r}",
                )
            spec.window = (float(w[0]), float(w[1]))
        if "noise" in s:
            spec.noise = _noise(ctx, s["noise"], "simulation.noise", plant)
        if isinstance(spec.threshold, dict) and not any(
            np.any(np.asarray(v) > 0)
            for k, v in (spec.noise or {}).items()
            if k in ("measurement", "process", "inputs")
        ):
            raise ctx.err(
                "simulation.threshold",
                "a calibrated threshold needs non-zero measurement, process or input noise in "
                "[simulation.noise]",
            )
    scen = data.get("scenario", [])
    if not isinstance(scen, list):
        raise ctx.err("scenario", "expected an array of tables [[scenario]]")
    if scen and spec.t is None:
        raise ctx.err("simulation", "scenarios need a [simulation] table (t_end, step)")
    for k, sc in enumerate(scen):
        where = f"scenario[{k}]"
        ctx.keys(sc, _SCEN, where)
        fl = sc.get("faults", [])
        if not isinstance(fl, list):
            raise ctx.err(f"{where}.faults", "expected an array of tables")
        sigs = [
            _fault_signal(ctx, f, f"{where}.faults[{i}]", plant, spec.t, spec.faults)
            for i, f in enumerate(fl)
        ]
        noise = _noise(ctx, sc["noise"], f"{where}.noise", plant) if "noise" in sc else None
        d = None
        if "d" in sc:
            if plant.nd == 0:
                raise ctx.err(f"{where}.d", "the plant has no disturbance (no Bd or Dd)")
            d = _signals(ctx, sc["d"], f"{where}.d", plant.nd, "disturbance", spec.t)
        spec.scenarios.append(Scenario(str(sc.get("name", f"scenario {k}")), sigs, noise, d))
    return spec


def load_model(path: str | Path) -> ModelSpec:
    """Read and validate a TOML model file.

    Raises
    ------
    ModelFileError
        With a one-line message naming the file, the entry and the problem.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise ModelFileError(f"{p}: cannot read the file ({exc.strerror})") from exc
    except UnicodeDecodeError as exc:
        raise ModelFileError(f"{p}: not a UTF-8 text file ({exc.reason})") from exc
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ModelFileError(f"{p}: not valid TOML ({exc})") from exc
    except RecursionError:
        raise ModelFileError(
            f"{p}: not a usable model file (arrays or tables nested too deeply; "
            f"at most {MAX_NESTING} levels of arrays)"
        ) from None
    return parse_model(data, str(p))


def _check_nesting(ctx: _Ctx, value: Any, where: str, depth: int = 0) -> None:
    """Refuse arrays nested deeper than :data:`MAX_NESTING` (tables reset the count)."""
    if isinstance(value, dict):
        for key, item in value.items():
            _check_nesting(ctx, item, f"{where}.{key}" if where else str(key), 0)
    elif isinstance(value, list):
        if depth >= MAX_NESTING:
            raise ctx.err(where, f"arrays nested more than {MAX_NESTING} levels deep")
        for k, item in enumerate(value):
            _check_nesting(ctx, item, f"{where}[{k}]", depth + 1)
