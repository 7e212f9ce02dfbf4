"""Simulation of a plant with faults and a bank of residual generators.

:func:`simulate` runs one scenario, :func:`~geomfdi.simulate_batch` many Monte-Carlo runs
(noise seeds, fault sizes) in one vectorised call.  Both use the exact, loop-free LTI
recursion of :mod:`geomfdi.simulation.lifting`.  Faults: sensor gain, bias and stuck
faults on the readings; actuator gain (loss of effectiveness), bias and stuck faults and
general additive faults ``Fault(Bf, Df)`` driven by a signal enter the plant as extra
input channels (:mod:`geomfdi.simulation.input_faults`), except actuator gain and stuck
faults under feedback, which act on the commanded input inside the loop.  Decisions:
thresholds, an optional persistence rule (k-of-n confirmation, isolation from the alarm
pattern held over the episode, ``MULTIPLE`` for several faults) and a detection window
(:mod:`geomfdi.evaluation.persistence`, :mod:`geomfdi.evaluation.metrics`).

Model::

    plant       x' = A x + B u + Bd d + Bw w          (x[k+1] = ... when dt > 0)
                y0 = C x + D u + Dd d + v              healthy reading, v: measurement noise
    faults      y_i = eta_i(t) y0_i + lambda_i(t)       (geomfdi.simulation.signals)
    generators  w_g' = F w_g - E y + G u,   r_g = M w_g - H y + K u     (measured y)
    controller  None:   u = u_ext(t)
                K:      u = u_ext(t) - K x             (state feedback, true state)
                system: u = u_ext(t) + K(s) y           (output feedback on the faulty y)

How it is computed
------------------
*Open loop and state feedback.*  The plant does not see the sensor faults, so its state
is simulated once over the whole horizon (and all runs).  The generators are driven
exactly: over one sampling interval the composite system ``[plant; generator]`` is
discretised with the hold of the exogenous inputs, so the generator's update uses the
plant *state* ``x[k]`` rather than an interpolation of the sampled ``y`` (a healthy
residual is therefore zero to rounding, not to ``O(dt^2)``).  A sensor fault enters as
``y_i = delta_i y0_i + rho_i`` with ``delta_i`` the gain over the interval (exact for
abrupt gains; the interval mean of ``eta`` for a time-varying gain, an ``O(dt^2)``
approximation) and ``rho_i`` (bias, held value, scaled noise) interpolated with the hold.
Each gain-faulty sensor adds one extra exact "channel" (one more matrix exponential).
When every generator has a ``Pi`` with ``F Pi - Pi A_cl = -Sigma`` (below; relative
residual <= 1e-12), the bank is simulated in the coordinates ``w~ = w - Pi x``, which obey
``w~' = F w~ + (Gamma - Pi B_cl) e - E rho``: the plant state drops out of the drive (an
exact change of state, fewer drive channels) and comes back in the output through
``M Pi x``.  Otherwise the composite ``[plant; bank]`` is discretised and the plant state
samples drive the bank.  ``res.info["plant_state_decoupled"]`` says which was used.
The whole bank is discretised with one matrix exponential and advanced together (block-
diagonal modal or Schur form, one ``lfilter`` call per generator state, on the lifted
system of blocks of ``M`` samples for large banks, time processed in chunks), see
:func:`geomfdi.simulation.lifting.block_recursion`.  A discrete plant drives its generators with the
measured samples directly, which is exact.

*Output feedback, and actuator gain/stuck faults under feedback.*  The loop sees the
faulty readings (or applies the faulty input), so a gain fault changes the loop
dynamics.  For abrupt faults the closed loop is piecewise LTI: the horizon is cut at
every fault switching instant and each segment (plant + controller + all generators) is
simulated exactly with the fast recursion, the state carried over.  A time-varying gain
makes the loop time-varying: its segments fall back to a **stepping scheme** (one matrix
exponential and one step per sample, ``eta`` frozen at its interval mean) that is
correct to ``O(dt^2)`` but much slower (a Python loop over the samples; a progress bar
is shown on a terminal).

*Switching instants* are sample times: a fault starting at ``t_s`` is active from the
first sample ``t_k >= t_s``; with the first-order hold its jump happens exactly at that
sample (the interval before it uses the left limit), not spread over the interval.

*Initial states.*  With ``consistent_init=True`` (default) each generator starts at
``w0 = Pi X0`` where ``X`` is the healthy loop state (plant, with controller states under
output feedback) and ``Pi`` solves ``F Pi - Pi A_cl = -Sigma`` (Sigma: the coupling of the
healthy loop into the generator), so that healthy data give no start-up transient.  The
Sylvester equation is solved by :func:`scipy.linalg.solve_sylvester` when the spectra of
``F`` and ``A_cl`` are disjoint, else in least squares together with the output condition
``M Pi + N = 0``; when that condition fails (relative residual > 1e-8) an
:class:`InitialStateWarning` gives the number: the generator is then not decoupled from
the healthy loop.

*Discrete plants* (``dt > 0``): the same, with the sampled model itself; a time-varying
gain is then exact (stepping uses ``eta(t_k)``).

*Noise.*  :class:`Noise`: measurement noise ``v`` (i.i.d. per sample) and process noise
``w`` (i.i.d. samples entering through ``Bw``, interpolated with the same hold as ``u``
for continuous plants: for a white-noise intensity ``Q`` use covariance ``Q / dt``).
The plant's own noise inputs (``Plant(..., Bw=, Dw=)``) are given as a signal ``w=``
(simulated like ``d``) or drawn at random with ``Noise(inputs=...)`` (like the process
noise, with ``Dw`` also in the readings).
The standard-normal draws are made in blocks of 65 536 samples
(:class:`~geomfdi.simulation.noise.NoiseStream`), or by the counter generator
(``Noise(generator="counter")``, :mod:`geomfdi.simulation.counter_normal`: each normal a
pure function of the seed, stream, row and sample), so a sample's noise depends only on
the seed and its index.

*Time chunks.*  The time axis is processed in chunks sized from the memory budget
``gf.limits.get_limits().chunk_memory`` (:mod:`geomfdi.limits`, default 64 MiB;
:func:`geomfdi.simulation.streaming.chunk_plan`).  The recursion is linear: the final
state of a chunk (plant, controller and generator states, and the held readings of
stuck sensors) is the initial state of the next, so a chunked run equals the
unchunked one to rounding (about 1e-15 relative; the same noise, decisions and events).
Residuals, alarms and decisions are written into the result arrays, allocated once; the
decisions of a chunk see the history that a moving-RMS statistic and the k-of-n counts
need, and the state of the current alarm episode (the residuals held in its pattern, the
quiet samples since its last alarm), so that they equal the whole record's
(:class:`geomfdi.simulation.streaming.DecisionStream`).  Peak memory is
the returned arrays plus about the budget, whatever the record's length; with
``simulate_batch(store="summary")`` it does not grow with the record.  (Additive input
faults' signals and the exogenous ``u`` and ``d`` are still formed over the whole
record.)

*Multiple outputs per generator.*  ``residuals`` has one row per bank row; a generator
with several residual components contributes their Euclidean norm (the components are in
``residual_vectors``).  Rows of missing generators (``None`` in ``bank.generators``)
are zero and never alarm.

Modules: :mod:`~geomfdi.simulation.context` (checked inputs),
:mod:`~geomfdi.simulation.open_loop` and :mod:`~geomfdi.simulation.closed_loop` (the two
engines), :mod:`~geomfdi.simulation.streaming` (chunks, decisions and summaries chunk by
chunk), :mod:`~geomfdi.simulation.initial_state`, :mod:`~geomfdi.simulation.results`,
:mod:`~geomfdi.simulation.batch` (Monte-Carlo runs).

References
----------
Hou, Wen & Chen (2011): sensor fault model (their eq. 3-5), residual generator (eq. 23)
driven by the *measured* output, and the simulation of their section 4.  See the user
guide, *Theory: sensor-fault transforms* (``docs/theory/sensor-fault-transforms.md``),
and *Theory: evaluation* (``docs/theory/evaluation.md``) for thresholds and decisions.
"""

from __future__ import annotations

from collections.abc import Sequence
from concurrent.futures import wait
from typing import Any

import numpy as np

from geomfdi._threads import limit_blas_threads, thread_pool
from geomfdi._validation import as_bool
from geomfdi.errors import GeomFDIError
from geomfdi.evaluation.decision import (
    NO_ALARM,
    as_threshold,
    detection_events,
)
from geomfdi.evaluation.persistence import as_persistence
from geomfdi.generators.generator import ResidualBank, ResidualGenerator
from geomfdi.model.plant import Plant, as_plant
from geomfdi.simulation.closed_loop import FeedbackRuns, split_actuator_faults
from geomfdi.simulation.context import (
    Context,
    detection_window_of,
    from_balanced,
    prepare,
    residual_labels_of,
    state_vector,
    to_balanced,
    unbalance_states,
    with_input_faults,
)
from geomfdi.simulation.noise import (
    CounterStream,
    Noise,
    NoiseStream,
    counter_normals,
    noise_stream,
)
from geomfdi.simulation.open_loop import OpenLoopEngine
from geomfdi.simulation.result_memory import empty
from geomfdi.simulation.results import (
    SimulationResult,
)
from geomfdi.simulation.schedule import FaultSchedule, fault_schedule, structure_columns
from geomfdi.simulation.signals import FaultSignal
from geomfdi.simulation.streaming import (
    DecisionStream,
    Workspace,
    chunk_plan,
    thread_workspace,
    time_chunks,
)


def stop_divergent(
    t: np.ndarray,
    x: np.ndarray,
    faults: Sequence[Any],
    bound: float | None,
    res: np.ndarray,
    alarms: np.ndarray,
    isolated: np.ndarray,
    candidates: np.ndarray,
    suspects: np.ndarray,
) -> float | None:
    """Blank the decisions of a diverged run from its first divergent sample (in place).

    Divergence: a non-finite state or ``max |x| > bound`` (default ``1e6 (1 + max |x|)``
    before the first fault onset).  Returns the time of divergence (``None``: none) and
    warns with :class:`~geomfdi.simulation.nonlinear.DivergenceWarning`.
    """
    import warnings

    from geomfdi.evaluation.decision import NO_ALARM
    from geomfdi.simulation.nonlinear import DivergenceWarning

    if bound is None and x.size:
        # the default bound is 1e6 (1 + max |x| before the first onset): when the largest
        # |x| of the record is below 1e6 (1 + its smallest possible value), nothing diverged
        top = max(float(np.max(x)), -float(np.min(x)))
        if np.isfinite(top) and top <= 1e6:
            return None
    if x.shape[0]:  # max |x| per sample without a temporary |x| of the record's size
        mag = np.maximum(np.max(x, axis=0), -np.min(x, axis=0))
        mag[np.isnan(mag)] = np.inf  # max propagates nan: a non-finite state is inf here
    else:
        mag = np.zeros(t.size)
    if bound is None:
        onsets = [f.start for f in faults if getattr(f, "start", None) is not None]
        k_on = int(np.searchsorted(t, min(onsets))) if onsets else t.size
        ref = float(np.max(mag[: max(k_on, 1)]))
        bound = 1e6 * (1.0 + (ref if np.isfinite(ref) else 0.0))
    hit = np.flatnonzero(mag > bound)
    if not hit.size:
        return None
    k = int(hit[0])
    res[:, k:] = np.nan
    alarms[:, k:] = False
    isolated[k:] = NO_ALARM
    candidates[:, k:] = False
    suspects[:, k:] = False
    warnings.warn(
        f"the run diverged at t = {t[k]:g} (state non-finite or max |x| > {bound:g}); no "
        "alarms or decisions after it",
        DivergenceWarning,
        stacklevel=3,
    )
    return float(t[k])


def noise_streams(
    ctx: Context,
    rngs: list[Any],
    pool: dict[int, list[np.ndarray]] | None = None,
    parts: int = 1,
) -> list[NoiseStream | CounterStream] | None:
    """One stream per run (``None`` without noise): a :class:`NoiseStream` of a numpy
    generator or a :class:`CounterStream` (:meth:`Noise.source`); ``pool``: buffers
    shared with the streams of other chunks of runs (see :func:`noise_window`), one
    list per part of the runs (:func:`run_parts` with ``parts`` parts: the parts are
    drawn by different threads, so their streams never share a buffer)."""
    if ctx.Lv is None and ctx.Lw is None:
        return None
    rv = ctx.plant.q if ctx.Lv is not None else 0
    rw = ctx.Lw.shape[1] if ctx.Lw is not None else 0
    streams = [noise_stream(rng, rv, rw, ctx.N) for rng in rngs]
    if pool is not None:
        for k, part in enumerate(run_parts(len(streams), parts)):
            for st in streams[part]:
                st.pool = pool.setdefault(k, [])
    return streams


#: Fewest runs a thread of its own draws the noise for (:func:`run_parts`).
MIN_RUNS_PER_PART = 4


def run_parts(runs: int, parts: int) -> list[slice]:
    """Contiguous slices of ``runs`` runs, at most ``parts`` of them, each of at least
    :data:`MIN_RUNS_PER_PART` runs (one slice when there are too few runs to share)."""
    k = max(1, min(int(parts), runs // MIN_RUNS_PER_PART))
    edges = [round(i * runs / k) for i in range(k + 1)]
    return [slice(a, b) for a, b in zip(edges[:-1], edges[1:], strict=True)]


def noise_window(
    ctx: Context,
    streams: list[NoiseStream | CounterStream] | None,
    s: int,
    e1: int,
    workspace: Workspace | None = None,
    parts: int = 1,
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Measurement ``(q, R, L)`` and process ``(k, R, L)`` noise of samples ``s .. e1-1``.

    Each run's draws are scaled straight into the window (``L_v z``, ``L_w z``) before
    the next run's stream is read (streams sharing a buffer pool reuse released blocks).
    With ``workspace`` the windows are its arrays (valid until the next window).  With
    ``parts > 1`` the runs are split by :func:`run_parts` (as the streams' pools were,
    :func:`noise_streams`) and the parts drawn on as many threads
    (:func:`geomfdi._threads.thread_pool`): numpy's generators and the scaling release
    the interpreter lock, every run keeps its own generator, so the values are the
    same as drawn one run after the other.  Counter streams (:class:`CounterStream`)
    fill the normals of all runs of a part at once (:func:`counter_normals`), straight
    into the windows when the scaling is diagonal.
    """
    if streams is None:
        return None, None
    L, R = e1 - s, len(streams)

    def new(name: str, shape: tuple[int, ...]) -> np.ndarray:
        return np.empty(shape) if workspace is None else workspace.get(name, shape)

    v = new("noise v", (ctx.plant.q, R, L)) if ctx.Lv is not None else None
    w = new("noise w", (ctx.Lw.shape[0], R, L)) if ctx.Lw is not None else None
    scale = [_scaling(ctx.Lv), _scaling(ctx.Lw)]
    if isinstance(streams[0], CounterStream):
        rows = [ctx.plant.q if v is not None else 0, ctx.Lw.shape[1] if w is not None else 0]
        diag = [_diagonal(ctx.Lv), _diagonal(ctx.Lw)]
        # the normals go into the window itself (diagonal scaling, in place) or a buffer
        zbuf = [
            None if dest is None else dest if d is not None else new(f"noise z{k}", (n, R, L))
            for k, (dest, d, n) in enumerate(zip((v, w), diag, rows, strict=True))
        ]

        def draw(part: slice) -> None:
            zp = [None if z is None else z[:, part] for z in zbuf]
            counter_normals(streams[part], s, e1, zp[0], zp[1])  # type: ignore[arg-type]
            for dest, z, d, Lf in zip((v, w), zp, diag, (ctx.Lv, ctx.Lw), strict=True):
                if dest is None:
                    continue
                if d is not None:  # the product each row's scaling forms, in place
                    np.multiply(d, z, out=z)
                else:
                    _combine(np.asarray(Lf), z, dest[:, part])
    else:

        def draw(part: slice) -> None:
            for r in range(part.start, part.stop):
                for dest, z, f in zip((v, w), streams[r].take(s, e1), scale, strict=True):
                    if dest is not None:
                        f(z, out=dest[:, r])

    split = run_parts(R, parts)
    if len(split) == 1:
        draw(split[0])
    else:
        futures = [thread_pool(len(split)).submit(draw, part) for part in split]
        wait(futures)  # every part done before an error is raised
        for f in futures:
            f.result()
    return v, w


def _combine(Lf: np.ndarray, z: np.ndarray, out: np.ndarray) -> None:
    """``out[i] = sum_k Lf[i, k] z[k]`` term by term in the order of ``k`` (zeros
    skipped): each element's rounding depends on its own values only, not on the
    shape of the window (a matrix product's blocking may), so the counter generator's
    scaled noise is the same bits for any chunks and runs."""
    tmp = np.empty(z.shape[1:])
    for i in range(Lf.shape[0]):
        ks = np.flatnonzero(Lf[i])
        if not ks.size:
            out[i] = 0.0
            continue
        np.multiply(Lf[i, ks[0]], z[ks[0]], out=out[i])
        for k in ks[1:]:
            np.multiply(Lf[i, k], z[k], out=tmp)
            out[i] += tmp


def _diagonal(Lf: np.ndarray | None) -> np.ndarray | None:
    """``diag(Lf)`` as a (k, 1, 1) column when ``Lf`` is diagonal with non-zero entries
    (the case :func:`_scaling` multiplies row-wise), else ``None``."""
    if Lf is None:
        return None
    Lf = np.asarray(Lf)
    if Lf.ndim == 2 and Lf.shape[0] == Lf.shape[1]:
        d = np.diagonal(Lf)
        if np.all(d != 0) and np.count_nonzero(Lf) == d.size:
            return np.ascontiguousarray(d)[:, None, None]
    return None


def _scaling(Lf: np.ndarray | None) -> Any:
    """``z -> Lf z`` with ``out=``: a row-wise product when ``Lf`` is diagonal with
    non-zero entries (independent noise channels; each entry ``d_i z_i`` is then the
    product the matrix product forms, the other terms being exact zeros), else the
    matrix product."""
    if Lf is None:
        return None
    d = _diagonal(Lf)
    if d is not None:
        col = d[:, :, 0]
        return lambda z, out: np.multiply(col, z, out=out)
    L = np.asarray(Lf)
    return lambda z, out: np.matmul(L, z, out=out)


def in_loop(ctx: Context, schedules: Sequence[FaultSchedule]) -> bool:
    """The runs are simulated as a closed loop with faults inside it: output feedback,
    or actuator gain/stuck faults (which act on the commanded input) under state
    feedback."""
    if ctx.ctrl.mode == "output":
        return True
    return ctx.ctrl.mode != "open" and any(sc.needs_input for sc in schedules)


def chunk_width(
    ctx: Context, *, keep_states: bool = False, stored: int = 0, loop: bool = False
) -> float:
    """Working bytes per run and sample of one time chunk (an upper estimate).

    Doubles: the exogenous samples and noise draws, the plant state and outputs, the
    noisy and faulty readings, the fault profiles and the per-interval drives of the
    sensors, the residual rows and vector components (and generator states); bytes: the
    alarms, decisions and persistence counters; ``stored``: bytes of the caller's own
    per-sample copies; ``loop``: the closed-loop engine is used (:func:`in_loop`).
    Half again as margin for the temporaries of numpy expressions.
    """
    p, view = ctx.plant, ctx.view
    gens = [g for g in view.generators if g is not None]
    nres, nf = len(view.generators), view.structure.shape[1]
    doubles = (
        p.m
        + p.nd
        + 2 * ctx.nwp
        + p.n
        + 16 * p.q
        + nres
        + 2
        + sum(g.n_outputs for g in gens if g.n_outputs > 1)
        + (sum(g.order for g in gens) if keep_states else 0)
    )
    if loop or ctx.ctrl.mode == "output":  # loop inputs, states, outputs, segment copies
        ne = 2 * p.m + p.nd + ctx.nwp + 2 * p.q
        nS = p.n + ctx.ctrl.nc + sum(g.order for g in gens)
        nout = 2 * p.q + p.m + sum(g.n_outputs for g in gens)
        doubles += 3 * (ne + nS + nout)
    return 1.5 * (8.0 * doubles + 10.0 * nres + 3.0 * nf + 16.0 + stored)


def make_engine(
    ctx: Context,
    x0: np.ndarray,
    xc0: np.ndarray,
    schedules: list[FaultSchedule],
    shared: bool,
    runs: int,
    chunk: int,
) -> OpenLoopEngine | FeedbackRuns:
    """The engine that advances ``runs`` runs over the record chunk by chunk: open loop
    and state feedback (:class:`OpenLoopEngine`), or a closed loop with faults inside it
    (:class:`FeedbackRuns`: output feedback, and actuator gain or stuck faults under
    state feedback, which act on the commanded input); ``schedules``: one shared, or one
    per run."""
    sensor = [sc.sensor for sc in schedules]
    if in_loop(ctx, schedules):
        split = [split_actuator_faults(sc) for sc in (schedules[:1] if shared else schedules)]
        acts = [inside for _, inside in split]
        if shared:
            ctx1 = with_input_faults(ctx, [split[0][0]])
            return FeedbackRuns(ctx1, x0, xc0, sensor[:1], True, runs, actuator_lists=acts)
        ctxs = [with_input_faults(ctx, [rest]) for rest, _ in split]
        return FeedbackRuns(ctx, x0, xc0, sensor, False, runs, contexts=ctxs, actuator_lists=acts)
    ctx1 = with_input_faults(ctx, schedules[:1] if shared else schedules)
    return OpenLoopEngine(ctx1, x0, sensor, shared, runs, chunk)


@limit_blas_threads
def simulate(
    plant: Plant,
    bank: ResidualBank | ResidualGenerator,
    t: Any,
    u: Any = None,
    *,
    faults: Sequence[FaultSignal] | FaultSignal = (),
    x0: Any = None,
    noise: Noise | None = None,
    controller: Any = None,
    threshold: Any = None,
    d: Any = None,
    xc0: Any = None,
    hold: str = "foh",
    consistent_init: bool = True,
    keep_states: bool = False,
    w: Any = None,
    persistence: Any = None,
    detection_window: float | None = None,
    progress: bool | None = None,
    bound: float | None = None,
) -> SimulationResult:
    """Simulate the plant with sensor faults and run the residual bank on its output.

    Parameters
    ----------
    plant : Plant or control.NonlinearIOSystem
        Continuous (``dt = 0``) or discrete.  A python-control nonlinear system is
        simulated in physical units with the bank designed on its linearisation
        (:func:`geomfdi.simulation.nonlinear.simulate_nonlinear`; ``u``, ``x0`` and the
        results physical, ``d`` the system's other inputs).
    bank : ResidualBank or ResidualGenerator
        The generators, same ``dt`` as the plant.
    t : array_like, (N,)
        Uniform time grid; for a discrete plant its step must equal ``plant.dt``.
    u : array_like (m, N), callable or None
        External input ``u_ext`` (a vectorised function of the time array is accepted;
        ``None``: zero).  With a controller the applied input is ``u_ext - K x`` or
        ``u_ext + K(s) y``.
    faults : sequence of fault signals
        Sensor faults (:class:`GainFault`, :class:`BiasFault`, :class:`StuckFault`;
        composed in order on one sensor), actuator faults (:class:`ActuatorGainFault`,
        :class:`ActuatorBiasFault`, :class:`ActuatorStuckFault`) and general additive
        faults (:class:`AdditiveFault`), any number.  ``u`` in the result is the
        commanded input (what the bank reads), not the faulty applied one.
    x0 : array_like (n,), optional
        Initial plant state (zero by default).
    noise : Noise, optional
        Measurement and process noise with a seed.
    controller : None, array (m, n), or python-control system
        None: open loop.  An array ``K``: state feedback ``u = u_ext - K x`` on the true
        state.  A python-control ``StateSpace``/``TransferFunction`` from the measured
        (faulty) ``y`` (q inputs) to ``u`` (m outputs): output feedback
        ``u = u_ext + K(s) y``.
    threshold : None, float, (n_residuals,) or Threshold
        Decision thresholds on ``|r|`` (or a calibrated :class:`Threshold`).  ``None``:
        no decision (no alarms).
    d : array_like (nd, N), callable or None
        Disturbance signal (decoupled by design).
    w : array_like (nw, N), callable or None
        Signal of the plant's noise inputs (``Plant(..., Bw=, Dw=)``), simulated like
        ``d`` (``None``: zero).  Random noise inputs: ``Noise(inputs=...)``.  A nonlinear
        system's noise inputs are among its other inputs, given in ``d``.
    xc0 : array_like, optional
        Initial controller state (output feedback; zero by default).
    hold : {"foh", "zoh"}
        Interpolation of the sampled exogenous signals for continuous plants.  ``"foh"``
        (linear between samples) is the convention of :func:`control.forced_response`.
    consistent_init : bool
        Start the generators at the state consistent with the healthy loop (module
        docstring); False: at zero.
    keep_states : bool
        Also return the generator states ``w`` (``res.w``); off by default to save
        memory (always kept under output feedback, where they come for free).
    persistence : None, int, (k, n) or Persistence
        Alarms and isolation decisions only when they hold ``k`` of ``n`` samples
        (an int ``n``: a minimum duration of ``n`` samples), isolation from the alarm
        pattern held over the alarm episode; see :class:`geomfdi.Persistence`.
    detection_window : float, optional
        Seconds after each onset within which an alarm counts as a detection (and a
        decision as an isolation); ``None``: to the end of the run.  An alarm before the
        onset is a false alarm, never a detection.
    progress : bool, optional
        Progress bar for the stepping scheme (default: when stderr is a terminal).
    bound : float, optional
        Divergence bound on ``max |x|``: from the first sample where the state is
        non-finite or beyond it, the run's residuals are ``nan`` and there are no alarms
        and no decisions; ``res.info["diverged"]`` / ``["diverged_at"]`` say so and a
        :class:`~geomfdi.simulation.nonlinear.DivergenceWarning` is issued.  Default
        ``1e6 (1 + max |x|)`` over the samples before the first fault onset.

    Returns
    -------
    SimulationResult

    Notes
    -----
    Fault model: Hou, Wen & Chen (2011), eq. (3)-(5); generator: their eq. (23) driven by
    the measured y (the correction is in the user guide, *Theory: errata*,
    ``docs/theory/errata.md``).  See the module docstring for how the simulation is exact
    for abrupt faults and what is approximated for time-varying gains.

    Examples
    --------
    >>> import numpy as np, geomfdi as gf
    >>> p = gf.Plant([[-1.0]], [[1.0]], [[1.0]])
    >>> g = gf.ResidualGenerator([[-2.0]], [[-1.0]], [[1.0]], [[1.0]], [[1.0]], [[0.0]])
    >>> f = gf.BiasFault(0, start=2.0, bias=0.1)
    >>> res = gf.simulate(p, g, np.linspace(0, 4, 401), faults=[f], threshold=0.05)
    >>> bool(res.max_abs(stop=1.99)[0] < 1e-12), res.events[0].detection_delay
    (True, 0.0)
    """
    from geomfdi.simulation.nonlinear import is_nonlinear, simulate_nonlinear

    if is_nonlinear(plant):  # a python-control nonlinear plant: geomfdi.simulation.nonlinear
        if w is not None:
            raise GeomFDIError(
                "w: a nonlinear system's noise inputs are among its other inputs; give their "
                "signals in d= (a mapping from input name to signal)",
                argument="w",
            )
        return simulate_nonlinear(
            plant,
            bank,
            t,
            u,
            faults=faults,
            x0=x0,
            d=d,
            noise=noise,
            controller=controller,
            threshold=threshold,
            persistence=persistence,
            detection_window=detection_window,
            bound=bound,
        )
    keep_states = as_bool(keep_states, "keep_states")
    plant = as_plant(plant)
    ctx = prepare(plant, bank, t, u, d, noise, controller, hold, consistent_init, progress, w)
    ctx.keep_states = keep_states
    sched = fault_schedule(faults, plant)
    x0a = state_vector(x0, plant.n, "x0")
    xc0a = state_vector(xc0, ctx.ctrl.nc, "xc0")
    view = ctx.view
    thr = as_threshold(threshold, len(view.generators), view.present)
    rule = as_persistence(persistence)
    window = detection_window_of(detection_window)
    rng = noise.source(noise.seed, noise.process_rows(plant)) if noise is not None else None
    cols = structure_columns(sched.faults, view.design_faults, plant)
    out = _stream_one(ctx, to_balanced(ctx, x0a), xc0a, rng, sched, thr, rule)
    res, alarms, isolated, candidates, suspects, x, y, yh, u, vectors, ws, xc = out
    diverged_at = stop_divergent(ctx.t, x, sched.faults, bound, res, alarms, isolated,
                                 candidates, suspects)  # fmt: skip
    events = detection_events(
        ctx.t, alarms, isolated, sched.faults, cols, window=window, suspects=suspects
    )
    return SimulationResult(
        t=ctx.t,
        x=x,
        y=y,
        y_healthy=np.ascontiguousarray(yh),
        u=np.ascontiguousarray(u),
        residuals=res,
        residual_vectors=vectors,
        alarms=alarms,
        isolated=isolated,
        candidates=candidates,
        suspects=suspects,
        threshold=thr,
        events=events,
        faults=list(sched.faults),
        persistence=rule,
        structure=view.structure,
        requested=view.requested,
        fault_labels=view.fault_labels,
        residual_labels=residual_labels_of(view),
        xc=xc,
        w=unbalance_states(view, ctx.info, ws),
        info={
            **ctx.info,
            "signals": plant.signal_info(),
            "diverged": diverged_at is not None,
            "diverged_at": diverged_at,
        },
        vector_rows=[g is not None and g.n_outputs > 1 for g in view.generators],
    )


def _stream_one(
    ctx: Context,
    x0: np.ndarray,
    xc0: np.ndarray,
    rng: np.random.Generator | None,
    sched: FaultSchedule,
    thr: Any,
    rule: Any,
) -> tuple[Any, ...]:
    """One run in time chunks written into the result.

    Every returned array is allocated once at its full size; the chunk's signals,
    noise draws and decisions are temporaries of the chunk's size (module
    :mod:`geomfdi.simulation.streaming`).
    """
    p, view, N = ctx.plant, ctx.view, ctx.N
    gens = view.generators
    nres, nf = len(gens), view.structure.shape[1]
    feedback = ctx.ctrl.mode == "output"
    loop = in_loop(ctx, [sched])  # generator states come for free in the loop engine
    keep = ctx.keep_states or loop
    _, L = chunk_plan(N, 1, chunk_width(ctx, keep_states=keep, loop=loop))
    eng = make_engine(ctx, x0, xc0, [sched], True, 1, L)
    streams = noise_streams(ctx, [rng])
    rows = empty((1, nres, N))
    for k, g in enumerate(gens):  # every other row is written by the engine
        if g is None:
            rows[:, k] = 0.0
    alarms = empty((nres, N), dtype=bool)
    isolated = empty((N,), dtype=int)
    candidates = empty((nf, N), dtype=bool)
    suspects = empty((nf, N), dtype=bool)
    ds = DecisionStream(thr, view.structure, rule)
    chunks = time_chunks(N, L)
    if len(chunks) == 1 and isinstance(eng, OpenLoopEngine) and eng.workspace is None:
        # one chunk covers the record: the engine's arrays are the result's
        eng.result_alloc = lambda shape, name: empty(shape)
        v, wp = noise_window(ctx, streams, 0, N)
        pc = eng.advance(0, N, v, wp, rows)
        y, yh = pc.y[:, 0], pc.y0n[:, 0]
        if np.may_share_memory(y, yh):  # the faulty readings are the healthy ones
            y = empty(yh.shape)
            y[...] = yh
        parts = [from_balanced(ctx, pc.X[:, 0]), y, yh, pc.u[:, 0]]
        x, y, yh, u = (a if a.flags.c_contiguous else np.ascontiguousarray(a) for a in parts)
        vectors = [None if a is None else a[:, 0] for a in pc.vectors]
        ws = [None if a is None else a[:, 0] for a in pc.ws]
        if thr is None:  # no threshold: no alarm, no decision
            alarms[...], isolated[...] = False, NO_ALARM
            candidates[...], suspects[...] = False, False
        else:
            al, iso = ds.step(rows)
            alarms[:] = al[0]
            isolated[:] = iso.isolated[0]
            candidates[:] = iso.candidates[0]
            suspects[:] = iso.suspects[0]
        for k, g in enumerate(gens):  # a scalar residual's component is its row
            if g is not None and g.n_outputs == 1:
                vectors[k] = rows[0, k : k + 1]
        return rows[0], alarms, isolated, candidates, suspects, x, y, yh, u, vectors, ws, None
    x, y = empty((p.n, N)), empty((p.q, N))
    yh, u = empty((p.q, N)), empty((p.m, N))
    vectors = [None if g is None or g.n_outputs == 1 else np.empty((g.n_outputs, N)) for g in gens]
    ws = [None if g is None or not keep else np.empty((g.order, N)) for g in gens]
    xc = np.empty((ctx.ctrl.nc, N)) if feedback else None
    if isinstance(eng, OpenLoopEngine) and eng.workspace is None:
        # the chunks' signals are copied into the result: work arrays kept by the thread
        work = thread_workspace("single run")
        eng.workspace = work
        eng.result_alloc = lambda shape, name: work.get(name, shape)
    else:
        work = None
    for s, e, e1 in chunks:
        v, wp = noise_window(ctx, streams, s, e1, work)
        pc = eng.advance(s, e1, v, wp, rows[:, :, s:e1])
        x[:, s:e1], y[:, s:e1] = from_balanced(ctx, pc.X[:, 0]), pc.y[:, 0]
        yh[:, s:e1], u[:, s:e1] = pc.y0n[:, 0], pc.u[:, 0]
        for k, a in enumerate(pc.vectors):
            if a is not None:
                vectors[k][:, s:e1] = a[:, 0]
        for k, a in enumerate(pc.ws):
            if a is not None:
                ws[k][:, s:e1] = a[:, 0]
        if xc is not None:
            xc[:, s:e1] = pc.xc[:, 0]
        al, iso = ds.step(rows[:, :, s:e])
        alarms[:, s:e] = al[0]
        isolated[s:e] = iso.isolated[0]
        candidates[:, s:e] = iso.candidates[0]
        suspects[:, s:e] = iso.suspects[0]
    for k, g in enumerate(gens):  # a scalar residual's component is its row
        if g is not None and g.n_outputs == 1:
            vectors[k] = rows[0, k : k + 1]
    return rows[0], alarms, isolated, candidates, suspects, x, y, yh, u, vectors, ws, xc
