"""Figures of ``geomfdi run``: structure matrices and residual traces drawn in worker
processes while the simulations run, from traces decimated to the minimum and maximum of
each pixel column (peaks are kept)."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # (not loaded: the figure worker starts before the design stack)
    from geomfdi.generators.generator import ResidualBank

__all__ = ["decimate_minmax", "FIGURE_DPI", "FIGURE_COLUMNS"]

FIGURE_DPI = 100
PNG_COMPRESS_LEVEL = 1
"""zlib level of the PNG files (lossless at every level: the same pixels as the default 6,
files about 15 % larger, encoded several times faster)."""
FIGURE_COLUMNS = 800
POLL_SECONDS = 0.5
"""How often an idle figure process checks that its parent is still there."""
"""Pixel columns of a residual figure: traces keep at most their min and max per column."""


def decimate_minmax(t: Any, r: Any, columns: int = FIGURE_COLUMNS) -> np.ndarray:
    """Indices of the samples that draw ``r`` (rows: traces over ``t``) at ``columns`` pixels.

    The samples are split into ``columns`` consecutive buckets; each bucket keeps its first
    sample and, for every trace, the sample of its minimum and of its maximum, so the
    drawn envelope (and every peak) is the one of the full trace.  Returns the sorted
    indices (all of them when there are at most ``2 * columns`` samples).

    Examples
    --------
    >>> import numpy as np
    >>> r = np.zeros((1, 10_000)); r[0, 1234] = 5.0
    >>> idx = decimate_minmax(np.arange(10_000), r, columns=100)
    >>> bool(1234 in idx), bool(len(idx) <= 301)
    (True, True)
    """
    r = np.atleast_2d(np.asarray(r))
    n = r.shape[1]
    if n <= 2 * columns:
        return np.arange(n)
    width = n // columns
    body = columns * width
    blocks = r[:, :body].reshape(r.shape[0], columns, width)
    offset = np.arange(columns) * width
    keep = [
        offset,
        (blocks.argmin(axis=2) + offset).ravel(),
        (blocks.argmax(axis=2) + offset).ravel(),
    ]
    keep.append(np.arange(body, n))  # the tail that does not fill a bucket
    keep.append(np.array([n - 1]))
    return np.unique(np.concatenate(keep))


def _save(fig: Any, path: Path) -> str:
    """``fig`` written to ``path`` (a checked output file) as PNG, through a temporary file
    renamed over it (a link at ``path`` is replaced, never followed); returns the name."""
    from geomfdi._files import replace_file

    def write(tmp: Path) -> None:
        fig.savefig(
            tmp, dpi=FIGURE_DPI, format="png", pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL}
        )

    replace_file(path, write)
    return path.name


def _draw_structure(kwargs: dict[str, Any], path: Path) -> str:
    """Worker: the structure figure of one bank, saved as PNG."""
    from geomfdi.plotting.residuals import plot_structure

    return _save(plot_structure(**kwargs), path)


def _structure_figure_args(bank: ResidualBank, title: str) -> dict[str, Any]:
    """The arguments of :func:`plot_structure` for ``bank`` (plain arrays and labels, so a
    worker does not load the synthesis code to unpickle a bank)."""
    return {
        "structure": np.asarray(bank.structure),
        "requested": np.asarray(bank.requested),
        "fault_labels": [getattr(f, "name", f"fault {j}") for j, f in enumerate(bank.faults)],
        "title": title,
    }


def _draw_residuals(kwargs: dict[str, Any], path: Path) -> str:
    """Worker: one residual figure from (decimated) traces, saved as PNG.

    The stacked axes get fixed margins (in inches) and no layout engine: with one (even a
    placeholder), ``savefig`` draws the figure twice.
    """
    from geomfdi.plotting.residuals import plot_residuals

    fig = plot_residuals(**kwargs)
    w, h = fig.get_size_inches()
    fig.set_layout_engine(None)  # no layout engine: ``savefig`` draws the figure once
    top = 0.55 if kwargs.get("title") else 0.2
    fig.subplots_adjust(left=0.9 / w, right=1 - 0.2 / w, bottom=0.55 / h, top=1 - top / h)
    return _save(fig, path)


def _warm_up() -> None:
    """Worker: load the plotting stack before the first figure arrives.

    Besides the imports, one small figure with text is drawn to memory: the fonts, the
    renderer and the PNG encoder are set up on a first drawing, which would otherwise
    fall on the first real figure.
    """
    import io

    import matplotlib.backends.backend_agg  # noqa: F401

    import geomfdi.evaluation.decision  # noqa: F401
    from geomfdi.plotting.residuals import plot_residuals

    t = np.linspace(0.0, 1.0, 8)
    fig = plot_residuals(t, np.vstack([t, -t]), threshold=0.5, onsets=[0.5], title="warm-up")
    fig.set_layout_engine(None)
    fig.savefig(
        io.BytesIO(),
        dpi=FIGURE_DPI,
        format="png",
        pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL},
    )


def _residual_figure_args(res: Any, title: str) -> dict[str, Any]:
    """The arguments of :func:`plot_residuals` for ``res``, traces decimated per pixel."""
    th = res.threshold
    alarms = res.alarms if th is not None else None
    t, r = res.t, res.residuals
    if getattr(th, "statistic", "abs") == "abs" and t.size > 2 * FIGURE_COLUMNS:
        # (a moving statistic needs every sample: drawn in full)
        idx = decimate_minmax(t, r)
        if alarms is not None:  # an alarm anywhere in a bucket shades its kept samples
            a = np.asarray(alarms, dtype=bool)
            width = t.size // FIGURE_COLUMNS
            anyb = np.logical_or.reduceat(a, np.arange(FIGURE_COLUMNS) * width, axis=1)
            alarms = anyb[:, np.minimum(idx // width, FIGURE_COLUMNS - 1)]
        t, r = t[idx], r[:, idx]
    return {
        "t": t,
        "residuals": r,
        "threshold": th,
        "onsets": sorted(set(res.onsets)),
        "labels": res.residual_labels,
        "alarms": alarms,
        "title": title,
    }


def _worker(todo: Any, done: Any, help_wanted: Any) -> None:
    """Figure process: warm up, then draw the jobs of ``todo`` until a ``None``.

    Each job ``(key, fn, args)`` gives ``(key, True, fn(*args))`` on ``done``, or
    ``(key, False, exception)``.  As soon as more than one job waits (or
    ``help_wanted`` is set: the main process is done with its own work), the process
    forks once: the copy starts warm (matplotlib loaded, fonts set up) and draws from
    the same queue, so that figures are drawn two at a time without a second matplotlib
    start-up; the original waits for it before exiting, and exits non-zero if it failed.

    No drawing process outlives its parent: a process whose parent is gone stops at the
    next poll of the queue (every :data:`POLL_SECONDS`), and the original, when
    orphaned or terminated (an early end of ``geomfdi run``), ends its copy first.
    """
    import queue
    import signal

    parent = os.getppid()
    helper = 0
    is_helper = orphaned = False

    def _stop(signum: int, frame: Any) -> None:  # SIGTERM from the main process
        if helper and not is_helper:
            try:
                os.kill(helper, signal.SIGKILL)
                os.waitpid(helper, 0)
            except OSError:
                pass
        os._exit(1)

    signal.signal(signal.SIGTERM, _stop)
    _warm_up()
    while True:
        try:
            job = todo.get(timeout=POLL_SECONDS)
        except queue.Empty:
            if os.getppid() != parent:  # the parent is gone: nobody waits for figures
                orphaned = True
                break
            continue
        if job is None:
            break
        more = help_wanted.is_set() or not todo.empty()  # more than this job to draw
        if more and not helper and not is_helper and hasattr(os, "fork"):
            helper = os.fork()
            if helper == 0:  # the copy: the job in hand is the original's
                is_helper = True
                parent = os.getppid()
                signal.signal(signal.SIGTERM, signal.SIG_DFL)
                continue
        key, fn, args = job
        try:
            done.put((key, True, fn(*args)))
        except Exception as exc:  # reported to the main process, which raises it
            try:
                done.put((key, False, exc))
            except Exception:  # an exception that cannot be pickled
                done.put((key, False, RuntimeError(f"{type(exc).__name__}: {exc}")))
    if is_helper:
        os._exit(0)
    if helper:
        if orphaned:  # the copy's parent (this process) is there: it would wait on
            os.kill(helper, signal.SIGKILL)
        _, status = os.waitpid(helper, 0)
        if status:
            raise SystemExit(1)


class _Figures:
    """PNG figures drawn in a separate process while the main process goes on.

    The process starts at once (``geomfdi run`` starts it before loading the design
    stack) and loads matplotlib while the main process designs, simulates and verifies;
    jobs are queued as they come (pickled arguments: plain arrays and labels).  When the
    main process is done (:meth:`results`), the figure process forks a warm copy of
    itself, so that both cores draw what is left without a second matplotlib start-up.
    Jobs a failed process left undrawn are drawn in the main process; so is everything
    when no process can be started.
    """

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled
        self.jobs: list[Any] = []  # the keys, in order
        self.calls: dict[Any, tuple[Callable[..., str], tuple[Any, ...]]] = {}
        self.drawn: dict[Any, str] = {}
        self.proc: Any = None
        if enabled:
            import multiprocessing

            methods = multiprocessing.get_all_start_methods()
            ctx = multiprocessing.get_context("fork" if "fork" in methods else None)
            try:
                # jobs through a queue with a feeder thread (a put never waits for the
                # process), results (file names) through a plain pipe
                self.todo = ctx.Queue()
                self.todo.cancel_join_thread()  # never wait for it at exit
                self.done = ctx.SimpleQueue()
                self.help = ctx.Event()
                self.proc = ctx.Process(
                    target=_worker, args=(self.todo, self.done, self.help), daemon=True
                )
                self.proc.start()
            except (OSError, NotImplementedError, ValueError, RuntimeError):
                self.proc = None

    def submit(self, key: Any, fn: Callable[..., str], *args: Any) -> None:
        """Draw a figure (``fn(*args)`` returns its file name), when figures are on."""
        if not self.enabled:
            return
        self.jobs.append(key)
        self.calls[key] = (fn, args)
        if self.proc is not None:
            try:
                self.todo.put((key, fn, args))
                return
            except (OSError, ValueError):  # the process is gone: draw here
                self.close()
        self.drawn[key] = fn(*args)

    def results(self) -> dict[Any, str]:
        """Wait for every figure; ``{key: file name}``."""
        from multiprocessing.connection import wait

        ok = False
        try:
            if self.proc is not None:
                self.help.set()
                for _ in range(2):  # one stop for each drawing process
                    self.todo.put(None)
                reader = self.done._reader
                while len(self.drawn) < len(self.jobs):
                    ready = wait([reader, self.proc.sentinel])
                    if reader in ready:
                        key, ok, value = self.done.get()
                        if not ok:
                            raise value
                        self.drawn[key] = value
                    elif not reader.poll():  # the process ended, nothing left to read
                        break
            for key in self.jobs:  # left undrawn by a failed process
                if key not in self.drawn:
                    fn, args = self.calls[key]
                    self.drawn[key] = fn(*args)
            ok = True
            return {key: self.drawn[key] for key in self.jobs}
        finally:
            self.close(stop=not ok)

    def close(self, stop: bool = True) -> None:
        """End the figure process: at once (``stop``, an early end), or when it is done."""
        if self.proc is not None:
            proc, self.proc = self.proc, None
            if stop and proc.is_alive():
                proc.terminate()  # (a helper, if any, ends at its stop mark)
            proc.join()
