"""Checked inputs of a simulation: the bank, the controller, the exogenous signals, the context.

:func:`prepare` validates everything once and returns a :class:`Context` that the
open-loop and closed-loop engines read; :class:`Piece` holds the arrays of one time
chunk that they return (:class:`RawRuns`: the closed loop's own layout).
"""

from __future__ import annotations

import copy
import hashlib
import numbers
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from geomfdi._validation import as_bool, as_choice, as_matrix, as_real_array
from geomfdi.errors import GeomFDIError, NonFiniteError, ShapeError
from geomfdi.generators.generator import ResidualBank, ResidualGenerator
from geomfdi.model.plant import Plant, as_plant
from geomfdi.simulation.discretization import HOLDS, Discretization, discretize, uniform_step
from geomfdi.simulation.initial_state import state_scaling
from geomfdi.simulation.noise import Noise
from geomfdi.simulation.schedule import FaultSchedule, input_channels


@dataclass
class BankView:
    generators: list[ResidualGenerator | None]
    structure: np.ndarray
    requested: np.ndarray | None
    design_faults: list[Any]
    fault_labels: list[str]
    bank: Any

    scales: list[np.ndarray | None] = field(default_factory=list)
    keys: list[bytes | None] = field(default_factory=list)

    @property
    def present(self) -> list[int]:
        return [k for k, g in enumerate(self.generators) if g is not None]


def balanced_generator(g: ResidualGenerator) -> tuple[ResidualGenerator, np.ndarray]:
    """``g`` in balanced state coordinates ``w = diag(e) w_b`` (the residual is unchanged).

    A generator designed in badly scaled coordinates has a badly scaled ``F``; its
    simulation (Schur form, matrix exponential) is accurate relative to ``||F||``, so the
    state is balanced first (``scipy.linalg.matrix_balance``, powers of 2: exact).
    """
    if g.order == 0:
        return g, np.ones(0)
    # the scaling depends on F only, cached: repeated simulations of a bank balance once
    e = state_scaling(np.asarray(g.F, dtype=float))
    if np.all(e == 1.0):
        return g, e
    gb = replace(
        g,
        F=g.F * e[None, :] / e[:, None],
        E=g.E / e[:, None],
        G=g.G / e[:, None],
        M=g.M * e[None, :],
    )
    return gb, e


_CHECKED: dict[bytes, tuple[dict[str, np.ndarray] | None, np.ndarray]] = {}
_CHECKED_ENTRIES = 256
_MATRICES = ("F", "E", "G", "M", "H", "K")


def generator_key(g: ResidualGenerator) -> bytes:
    """A fingerprint of the matrices of ``g``: their shapes and their values as floats
    (what the simulation reads), one hash over the concatenated entries."""
    h = hashlib.blake2b(digest_size=16)
    shapes = []
    for name in _MATRICES:  # the entries in turn: the digest of their concatenation
        a = getattr(g, name)
        if not (isinstance(a, np.ndarray) and a.dtype == np.float64 and a.flags.c_contiguous):
            a = np.ascontiguousarray(a, dtype=float)
        h.update(a)
        shapes.append(a.shape)
    h.update(repr(shapes).encode())
    return h.digest()


def _checked_generator(
    k: int, g: ResidualGenerator, key: bytes
) -> tuple[ResidualGenerator, np.ndarray]:
    """Generator ``k`` checked for finite entries and balanced (:func:`balanced_generator`).

    Both depend on the matrices only: the outcome is kept by their fingerprint ``key``
    (read-only balanced matrices), so a bank simulated again, with unchanged matrices,
    is neither checked nor balanced again (short records, Monte-Carlo loops); changed
    matrices have another key and are checked.
    """
    hit = _CHECKED.get(key)
    if hit is None:
        for name in _MATRICES:
            if not np.all(np.isfinite(np.asarray(getattr(g, name), dtype=float))):
                raise NonFiniteError(
                    f"bank: generator {k} has a non-finite entry in {name}", argument="bank"
                )
        gb, e = balanced_generator(g)
        mats = None
        if gb is not g:
            mats = {name: getattr(gb, name) for name in "FEGM"}
            for a in mats.values():
                a.setflags(write=False)
        if len(_CHECKED) >= _CHECKED_ENTRIES:
            _CHECKED.clear()
        _CHECKED[key] = hit = (mats, e)
    mats, e = hit
    if mats is None:
        return g, e
    gb = copy.copy(g)  # the checked matrices of a valid generator: no re-validation
    for name, a in mats.items():
        setattr(gb, name, a)
    return gb, e


def bank_view(bank: Any, plant: Plant) -> BankView:
    """The bank's generators checked against the plant and balanced, with its fault
    structure and labels (``keys``: the fingerprint of each generator's matrices)."""
    if isinstance(bank, ResidualGenerator):
        idx = set(bank.target) | set(bank.decoupled)
        nf = max(idx) + 1 if idx else 1
        S = np.zeros((1, nf), dtype=bool)
        for j in bank.target:
            S[0, j] = True
        view = BankView([bank], S, S.copy(), [], [f"fault {j}" for j in range(nf)], bank)
    elif isinstance(bank, ResidualBank):
        S = np.asarray(bank.structure, dtype=bool)
        labels = [getattr(f, "name", None) or f"fault {j}" for j, f in enumerate(bank.faults)]
        labels += [f"fault {j}" for j in range(len(labels), S.shape[1])]
        req = None if bank.requested is None else np.asarray(bank.requested, dtype=bool)
        view = BankView(list(bank.generators), S, req, list(bank.faults), labels, bank)
    else:
        raise GeomFDIError(
            f"bank: expected a ResidualBank or a ResidualGenerator, got {type(bank).__name__}",
            argument="bank",
        )
    if not view.present:
        raise GeomFDIError("bank: no residual generator exists in this bank", argument="bank")
    view.scales = [None] * len(view.generators)
    view.keys = [None] * len(view.generators)
    for k in view.present:
        g = view.generators[k]
        key = generator_key(g)
        gb, e = _checked_generator(k, g, key)
        if g.q != plant.q or g.m != plant.m:
            raise ShapeError(
                f"bank: generator {k} reads {g.q} outputs and {g.m} inputs, the plant has "
                f"{plant.q} and {plant.m}",
                argument="bank",
            )
        if abs(g.dt - plant.dt) > 1e-12 * max(1.0, plant.dt):
            raise GeomFDIError(
                f"bank: generator {k} has dt={g.dt:g}, the plant dt={plant.dt:g}",
                argument="bank",
            )
        view.generators[k], view.scales[k], view.keys[k] = gb, e, key
    return view


def unbalance_states(view: BankView, info: dict, ws: list[np.ndarray | None]) -> list:
    """Generator states (and ``info["w0"]``) back in the bank's own coordinates.

    The arrays of ``ws`` (the simulator's own, full-record) are scaled in place: no
    second copy of the states.
    """
    out: list[np.ndarray | None] = []
    for k, w in enumerate(ws):
        e = view.scales[k] if k < len(view.scales) else None
        if w is not None and e is not None:
            np.multiply(w, e[:, None], out=w)
        out.append(w)
    for k, w0 in info.get("w0", {}).items():
        e = view.scales[k]
        if e is not None:
            info["w0"][k] = w0 * e
    return out


@dataclass
class Controller:
    mode: str  # "open", "state", "output"
    K: np.ndarray | None = None
    Ac: np.ndarray | None = None
    Bc: np.ndarray | None = None
    Cc: np.ndarray | None = None
    Dc: np.ndarray | None = None

    @property
    def nc(self) -> int:
        return 0 if self.Ac is None else self.Ac.shape[0]


def as_controller(controller: Any, plant: Plant) -> Controller:
    if controller is None:
        return Controller("open")
    # an LTI object implies python-control is loaded: no import (about 0.3 s) for a gain
    control = sys.modules.get("control")
    if control is not None and isinstance(controller, control.LTI):
        try:
            ss = control.ss(controller)
        except Exception as exc:  # non-proper transfer function, ...
            raise GeomFDIError(
                f"controller: cannot be realised as a state-space system ({exc})",
                argument="controller",
            ) from exc
        if ss.ninputs != plant.q or ss.noutputs != plant.m:
            raise ShapeError(
                f"controller: must read the {plant.q} measured outputs and produce the "
                f"{plant.m} inputs, got {ss.ninputs} inputs and {ss.noutputs} outputs",
                argument="controller",
            )
        cdt = ss.dt
        if plant.is_discrete:
            ok = cdt is None or cdt is True or (cdt and abs(cdt - plant.dt) <= 1e-12 * plant.dt)
        else:
            ok = cdt is None or cdt == 0
        if not ok:
            raise GeomFDIError(
                f"controller: dt={cdt} does not match the plant (dt={plant.dt:g})",
                argument="controller",
            )
        nc = ss.nstates
        return Controller(
            "output",
            Ac=np.asarray(ss.A, dtype=float).reshape(nc, nc),
            Bc=np.asarray(ss.B, dtype=float).reshape(nc, plant.q),
            Cc=np.asarray(ss.C, dtype=float).reshape(plant.m, nc),
            Dc=np.asarray(ss.D, dtype=float).reshape(plant.m, plant.q),
        )
    K = as_matrix(controller, "controller", rows=plant.m, cols=plant.n)
    return Controller("state", K=K)


def exogenous_signal(value: Any, t: np.ndarray, rows: int, name: str) -> np.ndarray:
    """An exogenous signal as a (rows, N) array: None, array or vectorised callable."""
    N = t.shape[0]
    if value is None:
        return np.zeros((rows, N))
    if rows == 0:
        raise GeomFDIError(f"{name}: the plant has no such input", argument=name)
    if callable(value):
        try:
            value = value(t)
        except Exception as exc:
            raise GeomFDIError(
                f"{name}: calling it on the time array failed ({type(exc).__name__}: {exc}); "
                "the function must accept a numpy array of times",
                argument=name,
            ) from exc
    arr = as_real_array(value, name)
    if arr.ndim == 0:
        return np.full((rows, N), float(arr))
    if arr.ndim == 1 and rows == 1 and arr.shape[0] == N:
        return arr[None].copy()
    if arr.ndim == 1 and arr.shape[0] == rows:
        return np.repeat(arr[:, None], N, axis=1)
    if arr.shape != (rows, N):
        raise ShapeError(f"{name}: expected shape ({rows}, {N}), got {arr.shape}", argument=name)
    return arr


def batched_matmul(Mat: np.ndarray, arr: np.ndarray) -> np.ndarray:
    """``Mat @ arr[r]`` for each run of ``arr`` (R, k, L) -> (R, p, L)."""
    if arr.shape[0] == 1:
        return (Mat @ arr[0])[None]
    return np.matmul(Mat, arr)


# ================================================================== context
@dataclass
class Context:
    plant: Plant
    view: BankView
    ctrl: Controller
    t: np.ndarray
    step: float
    hold: str
    u_ext: np.ndarray  # (m, N)
    d: np.ndarray  # (nd, N)
    Lv: np.ndarray | None
    Bw: np.ndarray | None
    Lw: np.ndarray | None
    consistent: bool
    progress: bool
    keep_states: bool = False
    info: dict[str, Any] = field(default_factory=dict)
    original: Plant | None = None  # the user's plant (``plant`` is balanced)
    Dwp: np.ndarray | None = None  # (q, nwp): random noise inputs in the readings
    x_scale: np.ndarray | None = None  # x = diag(x_scale) x_balanced

    @property
    def discrete(self) -> bool:
        return self.plant.is_discrete

    @property
    def N(self) -> int:
        return self.t.shape[0]

    @property
    def nwp(self) -> int:
        return 0 if self.Bw is None else self.Bw.shape[1]

    def discretize(self, A: np.ndarray, B: np.ndarray) -> Discretization:
        if self.discrete:
            return Discretization(A, B, np.zeros_like(B), self.step, "discrete")
        return discretize(A, B, self.step, self.hold)


@dataclass
class RawRuns:
    """Arrays of the output-feedback engine for one time chunk (leading axis: runs)."""

    x: np.ndarray
    xc: np.ndarray | None
    y: np.ndarray
    y_healthy: np.ndarray
    u: np.ndarray
    r_vectors: list[np.ndarray | None]
    w: list[np.ndarray | None]


@dataclass
class Piece:
    """The signals of one time chunk, samples ``s .. s + L - 1``, state-major ``(k, R, L)``.

    ``vectors[k]`` holds the components of a vector residual (bank row ``k``), ``ws[k]``
    the generator states (with ``keep_states``); the residual rows were written into the
    caller's array.
    """

    s: int
    X: np.ndarray
    y: np.ndarray
    y0n: np.ndarray
    u: np.ndarray
    vectors: list[np.ndarray | None]
    ws: list[np.ndarray | None]
    xc: np.ndarray | None = None


def progress_bar(enabled: bool, total: int, desc: str) -> Any:
    if not enabled:
        return None
    from tqdm.auto import tqdm

    return tqdm(total=total, desc=desc, leave=False)


# ============================================================ entry points
def prepare(
    plant: Any,
    bank: Any,
    t: Any,
    u: Any,
    d: Any,
    noise: Any,
    controller: Any,
    hold: str,
    consistent_init: bool,
    progress: Any,
    w: Any = None,
) -> Context:
    """Check the inputs of a simulation once.

    The plant's noise inputs ``w`` (``Plant(..., Bw=, Dw=)``) given as a signal ``w``
    are simulated as further disturbance channels (``Bd' = [Bd, Bw]``, ``d' = [d; w]``);
    drawn at random (``Noise(inputs=...)``) they join the process-noise channels, with
    ``Dw`` in the readings (``Dwp``).
    """
    hold = as_choice(hold, "hold", HOLDS)
    consistent_init = as_bool(consistent_init, "consistent_init")
    progress = None if progress is None else as_bool(progress, "progress")
    plant = as_plant(plant)
    view = bank_view(bank, plant)
    ctrl = as_controller(controller, plant)
    t, step = uniform_step(t)
    if plant.is_discrete and abs(step - plant.dt) > 1e-6 * plant.dt:
        raise GeomFDIError(
            f"t: the grid step {step:g} must equal the plant's sampling period {plant.dt:g}",
            argument="t",
        )
    if noise is not None and not isinstance(noise, Noise):
        raise GeomFDIError(
            f"noise: expected a geomfdi Noise, got {type(noise).__name__}", argument="noise"
        )
    Lv = noise.factors(plant)[0] if noise is not None else None
    Bw, Dwp, Lw = noise.input_channels(plant) if noise is not None else (None, None, None)
    d_all = exogenous_signal(d, t, plant.nd, "d")
    if w is not None:
        w_sig = exogenous_signal(w, t, plant.nw, "w")
        d_all = np.vstack([d_all, w_sig])
        plant = Plant(
            plant.A,
            plant.B,
            plant.C,
            plant.D,
            Bd=np.hstack([plant.Bd, plant.Bw]),
            Dd=np.hstack([plant.Dd, plant.Dw]),
            dt=plant.dt,
        )
    if progress is None:
        progress = sys.stderr.isatty()
    # the state in balanced units (x = diag(xs) x_b): a plant in badly scaled coordinates
    # is simulated as accurately as the same plant in good ones (exact: powers of 2)
    original = plant
    xs = plant_scaling(plant)
    if xs is not None:
        plant = Plant(
            plant.A * xs[None, :] / xs[:, None],
            plant.B / xs[:, None],
            plant.C * xs[None, :],
            plant.D,
            Bd=plant.Bd / xs[:, None],
            Dd=plant.Dd,
            dt=plant.dt,
        )
        if ctrl.K is not None:
            ctrl = replace(ctrl, K=ctrl.K * xs[None, :])
        if Bw is not None:
            Bw = Bw / xs[:, None]
    return Context(
        plant,
        view,
        ctrl,
        t,
        step,
        hold,
        exogenous_signal(u, t, plant.m, "u"),
        d_all,
        Lv,
        Bw,
        Lw,
        bool(consistent_init),
        bool(progress),
        info={
            "mode": {"open": "open loop", "state": "state feedback", "output": "output feedback"}[
                ctrl.mode
            ],
            "hold": "discrete" if plant.is_discrete else hold,
        },
        original=original,
        x_scale=xs,
        Dwp=Dwp,
    )


def plant_scaling(plant: Plant) -> np.ndarray | None:
    """Diagonal state scaling that balances ``A`` (``None`` when already balanced)."""
    if plant.n == 0:
        return None
    xs = state_scaling(np.asarray(plant.A, dtype=float))  # cached by the matrix
    return None if np.all(xs == 1.0) else xs


def to_balanced(ctx: Context, x0: np.ndarray) -> np.ndarray:
    """Initial states (runs, n) in the balanced units of ``ctx``."""
    return x0 if ctx.x_scale is None else x0 / ctx.x_scale[None, :]


def from_balanced(ctx: Context, x: np.ndarray) -> np.ndarray:
    """Plant states (..., n, N) back in the user's units."""
    return x if ctx.x_scale is None else x * ctx.x_scale[:, None]


def state_vector(value: Any, n: int, name: str, runs: int | None = None) -> np.ndarray:
    if value is None:
        return np.zeros((1, n))
    arr = as_real_array(value, name)
    if arr.ndim == 1:
        if arr.shape[0] != n:
            raise ShapeError(f"{name}: expected length {n}, got {arr.shape[0]}", argument=name)
        return arr[None]
    if arr.ndim == 2 and runs is not None and arr.shape == (runs, n):
        return arr
    expect = f"({n},)" if runs is None else f"({n},) or ({runs}, {n})"
    raise ShapeError(f"{name}: expected shape {expect}, got {arr.shape}", argument=name)


def residual_labels_of(view: BankView) -> list[str]:
    return [f"r[{k}]" for k in range(len(view.generators))]


def with_input_faults(ctx: Context, schedules: Sequence[FaultSchedule]) -> Context:
    """``ctx`` with the additive faults of ``schedules`` as extra disturbance channels.

    The plant gets ``Bd' = [Bd, Bphi]``, ``Dd' = [Dd, Dphi]`` and the disturbance samples
    ``d' = [d; phi]`` (per run, ``(R, nd', N)``, when the runs' signals differ).  An
    actuator gain or stuck fault becomes such a channel only in open loop, where the
    commanded input is ``u_ext``; under feedback it acts inside the loop and the caller
    passes the schedules without it
    (:func:`geomfdi.simulation.closed_loop.split_actuator_faults`).
    """
    if ctx.ctrl.mode != "open" and any(s.needs_input for s in schedules):
        raise GeomFDIError(
            "faults: under feedback actuator gain and stuck faults act on the commanded "
            "input inside the loop, not as exogenous input channels; split them off the "
            "schedule first (split_actuator_faults)",
            argument="faults",
        )
    ch = input_channels(schedules, ctx.original or ctx.plant, ctx.t, ctx.u_ext)
    if ch is None:
        return ctx
    Bphi, Dphi, phi = ch
    if ctx.x_scale is not None:
        Bphi = Bphi / ctx.x_scale[:, None]
    p = ctx.plant
    aug = Plant(p.A, p.B, p.C, p.D, Bd=np.hstack([p.Bd, Bphi]), Dd=np.hstack([p.Dd, Dphi]), dt=p.dt)
    if phi.shape[0] == 1:
        d = np.vstack([ctx.d, phi[0]])
    else:
        R, N = phi.shape[0], ctx.N
        d = np.concatenate([np.broadcast_to(ctx.d, (R, p.nd, N)), phi], axis=1)
    return replace(ctx, plant=aug, d=d)


def detection_window_of(window: Any) -> float | None:
    """Check a detection window (seconds, > 0) or None."""
    if window is None:
        return None
    if isinstance(window, bool) or not isinstance(window, numbers.Real):
        raise GeomFDIError(
            f"detection_window: must be a number of seconds or None, got {window!r}",
            argument="detection_window",
        )
    w = float(window)
    if not (np.isfinite(w) and w > 0):
        raise GeomFDIError(
            f"detection_window: must be finite and > 0, got {w}", argument="detection_window"
        )
    return w
