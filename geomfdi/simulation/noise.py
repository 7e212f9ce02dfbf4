"""Measurement and process noise of a simulation: :class:`Noise` and its square-root factors."""

from __future__ import annotations

import numbers
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg

from geomfdi._validation import as_matrix, as_real_array
from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.model.plant import Plant
from geomfdi.simulation.pcg64_normal import standard_normal


# =================================================================== noise
def _factor(value: Any, dim: int, name: str) -> np.ndarray | None:
    """A square-root factor ``L`` (dim, dim) of a noise description (std or covariance)."""
    if value is None:
        return None
    arr = as_real_array(value, name)
    if arr.ndim == 0:
        if arr < 0:
            raise GeomFDIError(
                f"{name}: a standard deviation must be >= 0, got {arr}", argument=name
            )
        L = float(arr) * np.eye(dim)
    elif arr.ndim == 1:
        if arr.shape[0] != dim:
            raise ShapeError(
                f"{name}: expected {dim} standard deviations, got length {arr.shape[0]}",
                argument=name,
            )
        if np.any(arr < 0):
            raise GeomFDIError(f"{name}: standard deviations must be >= 0", argument=name)
        L = np.diag(arr)
    elif arr.ndim == 2:
        if arr.shape != (dim, dim):
            raise ShapeError(
                f"{name}: a covariance must be ({dim}, {dim}), got shape {arr.shape}",
                argument=name,
            )
        scale = max(float(np.max(np.abs(arr))), 1e-300)
        if np.max(np.abs(arr - arr.T)) > 1e-10 * scale:
            raise GeomFDIError(f"{name}: a covariance must be symmetric", argument=name)
        lam, V = np.linalg.eigh((arr + arr.T) / 2)
        if lam.min() < -1e-10 * scale:
            raise GeomFDIError(
                f"{name}: a covariance must be positive semidefinite (eigenvalue {lam.min():.3g})",
                argument=name,
            )
        L = V * np.sqrt(np.clip(lam, 0, None))
    else:
        raise ShapeError(f"{name}: expected a number, a vector or a matrix", argument=name)
    return None if not np.any(L) else L


@dataclass(frozen=True)
class Noise:
    """Measurement and process noise with a seed.

    Parameters
    ----------
    measurement : float, (q,) or (q, q), optional
        Measurement noise ``v`` added to the healthy readings: one standard deviation for
        all sensors, one per sensor, or a covariance matrix.  Sensor faults act on the
        noisy reading (a gain scales the noise, a stuck sensor freezes it).
    process : float, (k,) or (k, k), optional
        Process noise ``w`` entering ``x' = ... + Bw w`` (standard deviation(s) or
        covariance of the samples).  For a continuous plant the samples are interpolated
        with the simulation hold; the covariance of a sampled white noise of intensity
        ``Q`` is ``Q / dt``.
    process_input : (n, k), optional
        ``Bw``; the identity (noise on every state) by default.
    inputs : float, (nw,) or (nw, nw), optional
        The plant's own noise inputs ``w`` (``Plant(..., Bw=, Dw=)``: they enter the state
        through the plant's ``Bw`` and the readings through its ``Dw``), i.i.d. samples
        with these standard deviation(s) or covariance, interpolated like the process
        noise.  Drawn after the process noise of each block (rows appended to its draws),
        so adding them leaves the measurement and process noise of a seed unchanged.
    seed : int, numpy SeedSequence or None
        The seed of a run.  In :func:`simulate_batch` run ``i`` uses the ``i``-th child
        of ``SeedSequence(seed)`` unless seeds are given.  The noise of a sample depends
        on the seed and its index only, not on how the simulation cuts its time axis
        into chunks or its runs into threads.
    generator : {"numpy", "counter"}
        How a seed becomes standard normals.  ``"numpy"`` (default):
        :func:`numpy.random.default_rng` of the seed, drawn in blocks of
        :data:`NOISE_BLOCK` samples (:class:`NoiseStream`).  ``"counter"``: each normal
        is a pure function of the run's seed, the stream (measurement, process, plant
        noise inputs), the row and the sample index (Philox4x32-10 of Salmon et al.
        2011 and Box & Muller 1958, :mod:`geomfdi.simulation.counter_normal`), drawn by
        a compiled kernel several times faster than numpy's generator, with the same
        bits from its numpy fallback and on every IEEE-754 machine.  See the user
        guide, *Simulation* (``docs/guide/simulation.md``).

    Examples
    --------
    >>> import geomfdi as gf
    >>> gf.Noise(measurement=0.01, seed=1).measurement
    0.01
    """

    measurement: Any = None
    process: Any = None
    process_input: Any = None
    seed: Any = None
    inputs: Any = None
    generator: str = "numpy"

    def __post_init__(self) -> None:
        check_seed(self.seed, "noise.seed")
        if not isinstance(self.generator, str) or self.generator not in GENERATORS:
            raise GeomFDIError(
                f"noise.generator: expected one of {GENERATORS}, got {self.generator!r}",
                argument="noise.generator",
            )

    def source(self, seed: Any, process_rows: int = -1) -> Any:
        """What draws one run's normals: ``numpy.random.default_rng(seed)``, or with
        ``generator="counter"`` a :class:`CounterSource` (the run's key, and
        ``process_rows``: :meth:`process_rows`, the process-noise rows before the
        noise inputs' rows; ``-1``: all rows are process noise)."""
        if self.generator == "numpy":
            return np.random.default_rng(seed)
        from geomfdi.simulation.counter_normal import run_key

        return CounterSource(run_key(seed), int(process_rows))

    def process_rows(self, plant: Plant) -> int:
        """Rows of the process noise ``Lw z`` in the process draws (0: none; ``-1`` for
        the numpy generator, which does not need them)."""
        if self.generator == "numpy":
            return -1
        Lw = self.factors(plant)[2]
        return 0 if Lw is None else Lw.shape[1]

    def factors(
        self, plant: Plant
    ) -> tuple[np.ndarray | None, np.ndarray | None, np.ndarray | None]:
        """``(Lv, Bw, Lw)``: ``v = Lv z``, process noise ``Bw Lw z`` (z standard normal)."""
        Lv = _factor(self.measurement, plant.q, "noise.measurement")
        if self.process_input is None:
            Bw = np.eye(plant.n)
        else:
            Bw = as_matrix(
                self.process_input, "noise.process_input", rows=plant.n, vector_as="column"
            )
        Lw = _factor(self.process, Bw.shape[1], "noise.process")
        return Lv, (Bw if Lw is not None else None), Lw

    def input_channels(
        self, plant: Plant
    ) -> tuple[np.ndarray | None, np.ndarray | None, np.ndarray | None]:
        """``(Bx, Dy, L)``: process noise and the plant's noise inputs together.

        The state is driven by ``Bx L z`` and the readings by ``Dy L z`` (z standard
        normal): ``Bx = [Bw_process, plant.Bw]``, ``Dy = [0, plant.Dw]``, ``L`` block
        diagonal; ``(None, None, None)`` when neither is given.
        """
        _, Bp, Lp = self.factors(plant)
        if self.inputs is not None and plant.nw == 0:
            raise GeomFDIError(
                "noise.inputs: the plant has no noise inputs (Plant(..., Bw=, Dw=))",
                argument="noise.inputs",
            )
        Li = _factor(self.inputs, plant.nw, "noise.inputs") if plant.nw else None
        Bx, Dy, Ls = [], [], []
        if Lp is not None:
            Bx.append(Bp)
            Dy.append(np.zeros((plant.q, Bp.shape[1])))
            Ls.append(Lp)
        if Li is not None:
            Bx.append(np.asarray(plant.Bw, dtype=float))
            Dy.append(np.asarray(plant.Dw, dtype=float))
            Ls.append(Li)
        if not Ls:
            return None, None, None
        return np.hstack(Bx), np.hstack(Dy), scipy.linalg.block_diag(*Ls)


#: The noise generators of :class:`Noise` (``generator=``).
GENERATORS = ("numpy", "counter")


@dataclass(frozen=True)
class CounterSource:
    """The counter generator's view of one run: its key (:func:`~geomfdi.simulation.
    counter_normal.run_key`) and the rows of process noise before the noise inputs'
    rows in the process draws (``-1``: every row is process noise)."""

    key: np.ndarray
    process_rows: int


#: Samples per block of noise draws (see :class:`NoiseStream`); part of what a seed means.
NOISE_BLOCK = 2**16


class NoiseStream:
    """The standard-normal draws of one run, served by time range, in fixed blocks.

    The record is cut into blocks of :data:`NOISE_BLOCK` samples (the last one shorter);
    block ``b`` draws ``rng.standard_normal((rows_v, L_b))`` for the measurement noise,
    then ``rng.standard_normal((rows_w, L_b))`` for the process noise.  The draws of a
    sample therefore depend only on the seed and on the sample's index, never on how a
    simulation cuts its time axis into chunks: a chunked run equals the unchunked one for
    the same seed.  A record of at most one block draws exactly what
    ``rng.standard_normal((rows, N))`` would.

    Ranges must be asked for in increasing order (a range may start in the last block
    of the previous one); only the blocks of the last range are kept.

    Parameters
    ----------
    rng : numpy.random.Generator
    rows_v, rows_w : int
        Rows of the measurement and process draws (0: none drawn).
    N : int
        Samples in the record.
    block : int
        Samples per block (tests only; the default defines the stream).
    pool : list of ndarray, optional
        Buffers shared by several streams (:meth:`release` returns a finished
        stream's blocks to it).
    """

    def __init__(
        self,
        rng: np.random.Generator,
        rows_v: int,
        rows_w: int,
        N: int,
        block: int = NOISE_BLOCK,
        pool: list[np.ndarray] | None = None,
    ) -> None:
        self.rng = rng
        self.rows = (int(rows_v), int(rows_w))
        self.N = int(N)
        self.block = int(block)
        self._blocks: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._next = 0  # next block to draw
        #: buffers of released blocks, shared by the streams of one simulation and
        #: drawn into again (no fresh memory per run and block); with a pool, the
        #: ranges :meth:`take` returns are views to use before the next ``take`` of
        #: any stream of the pool
        self.pool = pool

    def _buffer(self, rows: int, L: int) -> np.ndarray:
        for k, buf in enumerate(self.pool or ()):
            if buf.shape == (rows, L):
                return self.pool.pop(k)  # type: ignore[union-attr]
        return np.empty((rows, L))

    def _draw(self) -> None:
        b = self._next
        L = min(self.block, self.N - b * self.block)
        rv, rw = self.rows
        # straight into the block's buffer: the values of rng.standard_normal((rows, L)),
        # drawn by the compiled loop for PCG64 (geomfdi.simulation.pcg64_normal)
        zv = standard_normal(self.rng, self._buffer(rv, L)) if rv else np.zeros((0, L))
        zw = standard_normal(self.rng, self._buffer(rw, L)) if rw else np.zeros((0, L))
        self._blocks[b] = (zv, zw)
        self._next += 1

    def release(self) -> None:
        """Return the kept blocks' buffers to the pool (the stream is done)."""
        for b in list(self._blocks):
            self._free(b)

    def _free(self, b: int) -> None:
        zv, zw = self._blocks.pop(b)
        if self.pool is not None:
            self.pool.extend(z for z in (zv, zw) if z.size)

    def take(self, s: int, e: int) -> tuple[np.ndarray, np.ndarray]:
        """Draws of samples ``s .. e-1``: ``(zv (rows_v, e-s), zw (rows_w, e-s))``."""
        if not 0 <= s <= e <= self.N:
            raise GeomFDIError(f"noise: range {s}..{e} outside 0..{self.N}", argument="noise")
        B = self.block
        b0, b1 = s // B, max(s, e - 1) // B
        if b0 < self._next - len(self._blocks) or (b0 not in self._blocks and b0 < self._next):
            raise GeomFDIError("noise: draws are served in increasing time order", argument="noise")
        while self._next <= b1:
            self._draw()
        for b in [b for b in self._blocks if b < b0]:
            self._free(b)
        if b0 == b1:
            zv, zw = self._blocks[b0]
            return zv[:, s - b0 * B : e - b0 * B], zw[:, s - b0 * B : e - b0 * B]
        parts_v, parts_w = [], []
        for b in range(b0, b1 + 1):
            zv, zw = self._blocks[b]
            lo, hi = max(s - b * B, 0), min(e - b * B, zv.shape[1])
            parts_v.append(zv[:, lo:hi])
            parts_w.append(zw[:, lo:hi])
        return np.concatenate(parts_v, axis=1), np.concatenate(parts_w, axis=1)


class CounterStream:
    """The normals of one run from the counter generator, served by time range.

    The interface of :class:`NoiseStream` (``take``, ``release``, ``pool``), but any
    range in any order: a normal is a pure function of (key, stream, row, sample)
    (:mod:`geomfdi.simulation.counter_normal`).  Measurement rows are stream 0, the
    process rows stream 1, the plant's noise-input rows (after the process rows in
    ``zw``) stream 2, each numbered from 0.  :func:`counter_normals` fills the windows
    of many runs at once.
    """

    def __init__(self, source: CounterSource, rows_v: int, rows_w: int, N: int) -> None:
        self.key = np.asarray(source.key, dtype=np.uint32)
        self.rows = (int(rows_v), int(rows_w))
        kp = source.process_rows
        self.split = int(rows_w) if kp < 0 else min(int(kp), int(rows_w))
        self.N = int(N)
        self.pool: Any = None

    def take(self, s: int, e: int) -> tuple[np.ndarray, np.ndarray]:
        """Normals of samples ``s .. e-1``: ``(zv (rows_v, e-s), zw (rows_w, e-s))``."""
        if not 0 <= s <= e <= self.N:
            raise GeomFDIError(f"noise: range {s}..{e} outside 0..{self.N}", argument="noise")
        zv = np.empty((self.rows[0], 1, e - s))
        zw = np.empty((self.rows[1], 1, e - s))
        counter_normals([self], s, e, zv, zw)
        return zv[:, 0], zw[:, 0]

    def release(self) -> None:
        """Nothing is kept (the interface of :meth:`NoiseStream.release`)."""


def counter_normals(
    streams: Sequence[CounterStream],
    s: int,
    e: int,
    zv: np.ndarray | None,
    zw: np.ndarray | None,
) -> None:
    """The normals of samples ``s .. e-1`` of many runs, in place: ``zv`` (rows_v, R, L)
    and ``zw`` (rows_w, R, L) (the samples contiguous), one kernel call per stream.

    The streams share their row counts (one simulation's runs).
    """
    from geomfdi.simulation.counter_normal import STREAMS, fill_normals

    if not streams:
        return
    keys = np.stack([st.key for st in streams])
    kp = streams[0].split
    if zv is not None and zv.shape[0]:
        fill_normals(keys, STREAMS["measurement"], 0, s, e, zv.transpose(1, 0, 2))
    if zw is not None and zw.shape[0]:
        if kp:
            fill_normals(keys, STREAMS["process"], 0, s, e, zw[:kp].transpose(1, 0, 2))
        if kp < zw.shape[0]:
            fill_normals(keys, STREAMS["inputs"], 0, s, e, zw[kp:].transpose(1, 0, 2))


def noise_stream(
    source: Any, rows_v: int, rows_w: int, N: int, pool: list[np.ndarray] | None = None
) -> NoiseStream | CounterStream:
    """The stream of one run: a :class:`NoiseStream` of a numpy generator, or a
    :class:`CounterStream` of a :class:`CounterSource` (:meth:`Noise.source`)."""
    if isinstance(source, CounterSource):
        return CounterStream(source, rows_v, rows_w, N)
    return NoiseStream(source, rows_v, rows_w, N, pool=pool)


def check_seed(seed: Any, name: str, argument: str | None = None) -> Any:
    """A reproducible seed: an integer >= 0 or a ``numpy.random.SeedSequence``."""
    argument = argument or name
    if seed is None or isinstance(seed, np.random.SeedSequence):
        return seed
    if isinstance(seed, numbers.Integral) and not isinstance(seed, bool):
        if seed < 0:
            raise GeomFDIError(f"{name}: a seed must be >= 0, got {seed}", argument=argument)
        return int(seed)
    raise GeomFDIError(
        f"{name}: expected an integer >= 0, a numpy SeedSequence or None, got {seed!r}",
        argument=argument,
    )


def run_seeds(noise: Noise | None, seeds: Any, runs: int) -> list[Any]:
    """The per-run seeds of a batch: given (checked), or spawned from ``noise.seed``."""
    if noise is None:
        if seeds is not None:
            raise GeomFDIError("seeds: per-run seeds need a noise model", argument="seeds")
        return [None] * runs
    if seeds is None:
        ss = (
            noise.seed
            if isinstance(noise.seed, np.random.SeedSequence)
            else np.random.SeedSequence(noise.seed)
        )
        return list(ss.spawn(runs))
    if isinstance(seeds, str | bytes) or not isinstance(seeds, Sequence | np.ndarray):
        raise GeomFDIError(f"seeds: expected a sequence of {runs} seeds", argument="seeds")
    if len(seeds) != runs:
        raise ShapeError(f"seeds: expected {runs} seeds, got {len(seeds)}", argument="seeds")
    out = []
    for i, s in enumerate(seeds):
        # None: fresh OS entropy for that run (numpy's convention), not "no noise"
        s = np.random.SeedSequence() if s is None else s
        out.append(check_seed(s, f"seeds[{i}]", "seeds"))
    return out
