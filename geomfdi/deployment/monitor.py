"""Online residual evaluation: :class:`Monitor`.

A monitor runs a bank sample by sample (:meth:`Monitor.step`) or chunk by chunk
(:meth:`Monitor.feed`) with the same fused recursion, start-up rule, missing-sample
handling, threshold, persistence rule (:class:`geomfdi.Persistence`: k-of-n
confirmation, the pattern held over the alarm episode, settled decisions) and isolation
as :func:`geomfdi.evaluate` and :func:`geomfdi.simulate`, so
step-by-step, chunked and recorded evaluation agree (residuals to rounding, decisions
exactly).  Its :attr:`Monitor.state` is a plain dict (JSON-serialisable) and
:meth:`Monitor.save` writes the whole monitor to a versioned JSON file.  See the user
guide, *Theory: residual evaluation* (``docs/theory/evaluation.md``).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from geomfdi._threads import limit_blas_threads
from geomfdi._validation import as_bool, as_real_array
from geomfdi.deployment.decide import as_persistence, threshold_values
from geomfdi.deployment.online import (
    MonitorOutput,
    MonitorState,
    MonitorStep,
    make_feed,
    make_step,
)
from geomfdi.deployment.program import (
    SAMPLE_LIMIT,
    Program,
    as_bank,
    build_program,
    check_initial,
    restart_rule,
)
from geomfdi.errors import GeomFDIError, NonFiniteError, ShapeError
from geomfdi.evaluation.decision import AMBIGUOUS, MULTIPLE, NO_ALARM, UNEXPLAINED
from geomfdi.evaluation.persistence import Persistence
from geomfdi.generators.bankfile import _enc_float, _write, bank_to_dict, encode
from geomfdi.model.signals import bank_signals

__all__ = ["Monitor", "MonitorStep", "MonitorOutput"]


class Monitor:
    """Online state machine evaluating a residual bank one sample at a time.

    Parameters
    ----------
    bank : ResidualBank or ResidualGenerator
        Discrete, or continuous with ``dt`` (sampled with a first-order hold).
    dt : float, optional
        Sampling period (required for a continuous bank).
    threshold : None, float, (n_residuals,) or Threshold
        Alarm when ``|r_i| > threshold_i`` (the ``"abs"`` statistic).
    persistence : None, int, (k, n) or Persistence
        The decision rule (:class:`geomfdi.Persistence`, as in :func:`geomfdi.simulate`;
        :mod:`geomfdi.deployment.decide`); ``None``: per-sample alarms and isolation.
    isolation : bool
        Compute the isolation decision per sample.
    initial : {"steady", "zero"} or array_like
        Generator state at the first sample, as in :func:`geomfdi.evaluate`.
    backend : {"numpy", "c"}
        ``"c"``: step and feed the generated C code of :func:`geomfdi.codegen.c`,
        compiled once with the system's C compiler and cached
        (:mod:`geomfdi.deployment.compiled`); the same decisions, residuals to rounding.
        Falls back to ``"numpy"`` with a :class:`RuntimeWarning` for a continuous bank
        or without a working compiler (:attr:`backend` says which one runs).  The C
        state is kept in C: :attr:`state` and :meth:`save` need the numpy backend.

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> g = gf.ResidualGenerator([[0.5]], [[-0.5]], [[0.0]], [[1.0]], [[1.0]], [[0.0]], dt=0.1)
    >>> mon = gf.Monitor(g, threshold=0.4, persistence=2)
    >>> [bool(mon.step([y], [0.0]).alarms[0]) for y in (1.0, 1.0, 2.0, 2.0, 2.0)]
    [False, False, False, True, False]
    """

    @limit_blas_threads
    def __init__(
        self,
        bank: Any,
        dt: float | None = None,
        threshold: Any = None,
        persistence: Any = None,
        isolation: bool = True,
        initial: Any = "steady",
        backend: str = "numpy",
    ) -> None:
        from geomfdi._validation import as_choice
        from geomfdi.deployment.compiled import BACKENDS

        self.backend = as_choice(backend, "backend", BACKENDS)
        self.bank = as_bank(bank)
        self.program = build_program(self.bank, dt)
        self.dt = self.program.dt
        self.thresholds = threshold_values(threshold, self.program.n_rows, self.program.present)
        self.persistence = as_persistence(persistence)
        self.isolation = as_bool(isolation, "isolation")
        self.initial = check_initial(initial, self.program)
        self._restart = restart_rule(self.program, self.initial)
        sig = bank_signals(self.bank)
        #: output and input names (the plant's), the order of ``y`` and ``u``
        self.outputs, self.inputs = sig["outputs"], sig["inputs"]
        self._y_op = sig["y_op"] if np.any(sig["z_op"] != 0) else None
        self._u_op = sig["u_op"]
        self.reset()

    @property
    def n_residuals(self) -> int:
        return self.program.n_rows

    def reset(self) -> None:
        """Back to the state before the first sample."""
        self._state = MonitorState(self.program, self.persistence, self.initial)
        args = (
            self.program,
            self._state,
            self.thresholds,
            self.persistence,
            self.isolation,
            self._restart,
        )
        self._step = make_step(*args)
        self._feed = make_feed(*args)
        if self.backend == "c":
            from geomfdi.deployment.compiled import compiled_paths

            paths = compiled_paths(self)
            if paths is None:
                self.backend = "numpy"
            else:
                self._step, self._feed = paths
        # the compiled step's builtin function, called first by step() (it returns None
        # when y or u is not a float64 vector); the compiled code subtracts the operating
        # point itself (physical samples in)
        self._fast = getattr(self._step, "fast", None)

    def step(self, y: Any, u: Any = None) -> MonitorStep:
        """One sample ``y`` (q,), ``u`` (m,): residual per bank row, confirmed alarms and
        the isolation decision.

        A sample is *missing* when an entry is ``nan``, infinite or beyond
        :data:`~geomfdi.deployment.program.SAMPLE_LIMIT` (``1e150``) in magnitude, or
        when its update overflows (an unstable bank): it gives ``nan`` residuals and no
        raw alarm, leaves the generator state as it was and restarts the generators at
        the next valid sample.  :meth:`feed`, :func:`geomfdi.evaluate` and the generated
        C and Python code apply the same rule.  Complex or text samples are refused.

        ``y`` may be a mapping ``{name: value}`` holding every output (and then every input
        unless ``u`` is given) by the plant's names.  Physical values: a bank designed at
        an operating point subtracts ``y_op`` and ``u_op`` itself.
        """
        fast = self._fast
        if fast is not None:  # the compiled step on float64 vectors, else None
            out = fast(y, u)
            if out is not None:
                return out
        if self._y_op is not None or (type(y) is not np.ndarray and isinstance(y, Mapping)):
            y, u = self._deviations(y, u, 1)  # (an array is never a mapping: no ABC check)
        return self._step(y, u)

    def _deviations(self, y: Any, u: Any, ndim: int) -> tuple[Any, Any]:
        """Named samples in channel order, minus the operating point (errors name the
        arguments of :meth:`step`, ``y``/``u``, or of :meth:`feed`, ``Y``/``U``)."""
        if isinstance(y, Mapping):
            src = y
            ay, au = ("y", "u") if ndim == 1 else ("Y", "U")
            y = _by_name(src, self.outputs, ay)
            if u is None and self.inputs:
                u = _by_name(src, self.inputs, au)
        if self._y_op is None or self.backend == "c":  # C: subtracted in the C step
            return y, u
        return _minus(y, self._y_op, ndim), _minus(u, self._u_op, ndim)

    @limit_blas_threads
    def feed(self, Y: Any, U: Any = None) -> MonitorOutput:
        """A chunk of samples ``Y`` (q, L), ``U`` (m, L), without a per-sample loop.

        Like the other entry points of geomfdi it runs with the BLAS limited to
        :func:`geomfdi.get_blas_threads` threads (one by default): its products are small.
        Named and physical samples as for :meth:`step` (a mapping of rows).
        """
        if isinstance(Y, Mapping) or self._y_op is not None:
            Y, U = self._deviations(Y, U, 2)
        return self._feed(Y, U)

    @property
    def state(self) -> dict[str, Any]:
        """The current state as plain lists: generator state ``xi``, last sample,
        pending start-up rule, raw alarms of the last ``n`` samples oldest first
        (``ring``), the held pattern of the alarm episode (``held``, 0/1 per row), the
        samples since its last confirmed alarm (``quiet``), the pattern decisions of the
        last ``n - 1`` samples (``decisions``) and the samples seen."""
        if self.backend != "numpy":
            raise GeomFDIError("state: kept in C with backend='c'", argument="backend")
        return state_dict(self._state, self.program)

    @state.setter
    def state(self, value: dict[str, Any]) -> None:
        if self.backend != "numpy":
            raise GeomFDIError("state: kept in C with backend='c'", argument="backend")
        set_state(self._state, self.program, self.persistence, value)

    def save(self, path: str | Path) -> Path:
        """Write the monitor (bank, settings and state) to a versioned JSON file."""
        return save_monitor(self, path)

    def __repr__(self) -> str:
        p = self.persistence
        thr = "set" if self.thresholds is not None else None
        return (
            f"Monitor(rows={self.n_residuals}, order={self.program.nw}, dt={self.dt:g}, "
            f"persistence={p.k}-of-{p.n} latch={p.latch} reset={p.reset}, threshold={thr})"
        )


def _minus(x: Any, op: np.ndarray, ndim: int) -> Any:
    """``x - op`` for real samples; anything else is passed on for the sample checks of
    :mod:`geomfdi.deployment.online` to judge (complex or text samples are refused)."""
    if x is None or not len(op):
        return x
    arr = np.asarray(x)
    if arr.dtype.kind not in "fiu":
        return x
    return arr - (op if ndim == 1 or arr.ndim == 1 else op[:, None])


def _by_name(src: Mapping[str, Any], names: tuple[str, ...], argument: str) -> np.ndarray:
    missing = [n for n in names if n not in src]
    if missing:
        raise ShapeError(
            f"{argument}: no values for {missing} (the bank reads {list(names)})",
            argument=argument,
        )
    return np.asarray([src[n] for n in names], dtype=float)


def _pending_json(pending: Any) -> Any:
    if pending is None or isinstance(pending, str):
        return pending
    return [float(x) for x in pending]


def state_dict(state: MonitorState, program: Program) -> dict[str, Any]:
    """The state of a monitor as a JSON-ready dict (see :attr:`Monitor.state`)."""
    return {
        "xi": [float(x) for x in state.xi],
        "last_sample": [float(x) for x in state.last],
        "pending": _pending_json(state.pending),
        "ring": state.ordered_ring().astype(int).tolist(),
        "held": state.held_rows().astype(int).tolist(),
        "quiet": int(state.quiet),
        "decisions": [int(d) for d in state.decisions],
        "samples": int(state.samples),
    }


_RULE_STATE = {"held", "quiet", "decisions"}


def set_state(state: MonitorState, program: Any, persistence: Any, value: Any) -> None:
    """Restore a state written by :func:`state_dict` (checked).

    A state without the entries of the held pattern and the decisions (``held``,
    ``quiet``, ``decisions``: written before the persistence rule had them) starts them
    afresh: no episode, no past decision.
    """
    if not isinstance(value, dict):
        raise GeomFDIError("state: expected a dict", argument="state")
    need = {"xi", "last_sample", "pending", "ring", "samples"}
    if set(value) not in (need, need | _RULE_STATE):
        raise GeomFDIError(
            f"state: expected the keys {sorted(need | _RULE_STATE)}", argument="state"
        )
    held, quiet, decisions = _rule_state(value, program, persistence)
    xi = _state_vector(value["xi"], "xi")
    last = _state_vector(value["last_sample"], "last_sample")
    if last.size and not np.abs(last).max() <= SAMPLE_LIMIT:
        raise NonFiniteError(
            f"state: last_sample has an entry beyond {SAMPLE_LIMIT:g} in magnitude "
            "(such a sample is missing and never stored)",
            argument="state",
        )
    ring = _state_bits(value["ring"], "ring")
    if xi.shape != (program.nw,) or last.shape != (program.nz,):
        raise ShapeError(
            f"state: xi must have {program.nw} and last_sample {program.nz} entries",
            argument="state",
        )
    if ring.shape != (persistence.n, program.n_rows) or not np.isin(ring, (0, 1)).all():
        raise ShapeError(
            f"state: ring must be a 0/1 array of shape ({persistence.n}, {program.n_rows})",
            argument="state",
        )
    pending = value["pending"]
    if pending is not None and not isinstance(pending, str):
        pending = _state_vector(pending, "pending")
        if pending.shape != (program.nw,):
            raise ShapeError(
                f"state: pending state must have {program.nw} entries", argument="state"
            )
    elif isinstance(pending, str) and pending not in ("zero", "steady"):
        raise GeomFDIError(f"state: unknown pending rule {pending!r}", argument="state")
    samples = value["samples"]
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 0:
        raise GeomFDIError("state: samples must be an integer >= 0", argument="state")
    state.xi = xi
    state.last = last
    state.pending = pending
    state.set_ring(ring.astype(bool))
    state.set_held(held)
    state.quiet = quiet
    state.decisions = deque(decisions)
    state.samples = samples


def _state_vector(value: Any, key: str) -> np.ndarray:
    """A numeric entry of a state: real and finite (named errors, ``argument="state"``).

    A state never holds ``nan``: a missing sample leaves the generator state as it was
    and sets the pending start-up rule instead, so a ``nan`` in a state can only come
    from outside, and it would silence the monitor for good (every later sample would
    look missing).  It is refused, like ``inf``.
    """
    try:
        return as_real_array(value, f"state.{key}")
    except GeomFDIError as exc:
        exc.argument = "state"
        raise


def _state_bits(value: Any, key: str) -> np.ndarray:
    """A 0/1 array entry of a state (its shape is checked by the caller)."""
    try:
        return np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise ShapeError(f"state: {key} must be an array of 0/1 ({exc})", argument="state") from exc


def _rule_state(value: dict[str, Any], program: Any, persistence: Any) -> tuple:
    """``held``, ``quiet``, ``decisions`` of a state dict, checked (defaults when absent)."""
    rows, n = program.n_rows, persistence.n
    if "held" not in value:
        return np.zeros(rows, dtype=bool), 0, [NO_ALARM] * (n - 1)
    held = _state_bits(value["held"], "held")
    if held.shape != (rows,) or not np.isin(held, (0, 1)).all():
        raise ShapeError(f"state: held must be {rows} values 0 or 1", argument="state")
    quiet = value["quiet"]
    limit = persistence.reset if persistence.latch and persistence.reset is not None else 1
    if isinstance(quiet, bool) or not isinstance(quiet, int) or not 0 <= quiet < limit:
        raise GeomFDIError(f"state: quiet must be an integer in [0, {limit})", argument="state")
    if held.any() and not persistence.latch:
        raise GeomFDIError("state: a held pattern needs a latching rule", argument="state")
    dec = value["decisions"]
    codes = (NO_ALARM, UNEXPLAINED, AMBIGUOUS, MULTIPLE)
    nf = program.structure.shape[1]
    if (
        not isinstance(dec, list)
        or len(dec) != n - 1
        or not all(
            isinstance(d, int) and not isinstance(d, bool) and (0 <= d < nf or d in codes)
            for d in dec
        )
    ):
        raise GeomFDIError(
            f"state: decisions must be {n - 1} decision codes (fault index, -1 .. -4)",
            argument="state",
        )
    return held.astype(bool), quiet, list(dec)


def persistence_dict(rule: Persistence) -> dict[str, Any]:
    """The rule as it is stored in a monitor file."""
    return {"k": rule.k, "n": rule.n, "latch": rule.latch, "reset": rule.reset}


def persistence_from(value: Any) -> Persistence:
    """The rule stored in a monitor file.

    Files written before the rule had its memory store ``[k, n]``: that was k-of-n
    confirmation with per-sample isolation, loaded as ``Persistence(k, n,
    latch=False)`` (the same alarms; decisions now settle for ``k`` of ``n`` samples).
    """
    if isinstance(value, list) and len(value) == 2:
        return Persistence(value[0], value[1], latch=False)
    if not isinstance(value, dict) or set(value) != {"k", "n", "latch", "reset"}:
        raise GeomFDIError(
            "persistence: expected {k, n, latch, reset} (or [k, n])", argument="persistence"
        )
    if any(isinstance(value[x], float) for x in ("k", "n", "reset")):
        raise GeomFDIError("persistence: k, n, reset must be integers", argument="persistence")
    return Persistence(value["k"], value["n"], value["latch"], value["reset"])


def save_monitor(monitor: Any, path: str | Path) -> Path:
    """Write a :class:`~geomfdi.Monitor` (bank, settings, current state) to ``path``."""
    initial = monitor.initial
    payload = {
        "bank": bank_to_dict(monitor.bank),
        "dt": _enc_float(float(monitor.dt)),
        "threshold": None if monitor.thresholds is None else encode(monitor.thresholds),
        "persistence": persistence_dict(monitor.persistence),
        "isolation": monitor.isolation,
        "initial": initial if isinstance(initial, str) else encode(initial),
        "state": encode(state_dict(monitor._state, monitor.program)),
    }
    return _write(path, "geomfdi.monitor", payload)
