"""Figures of ``geomfdi run``: structure matrices and residual traces drawn in worker
processes while the simulations run, from traces decimated to the minimum and maximum of
each pixel column (peaks are kept)."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from geomfdi.synthesis.generator import ResidualBank

__all__ = ["decimate_minmax", "FIGURE_DPI", "FIGURE_COLUMNS"]

FIGURE_DPI = 100
FIGURE_COLUMNS = 800
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


def _draw_structure(kwargs: dict[str, Any], path: Path) -> str:
    """Worker: the structure figure of one bank, saved as PNG."""
    from geomfdi.plotting.residuals import plot_structure, save_png

    return save_png(plot_structure(**kwargs), path, dpi=FIGURE_DPI).name


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
    from geomfdi.plotting.residuals import plot_residuals, save_png

    fig = plot_residuals(**kwargs)
    w, h = fig.get_size_inches()
    fig.set_layout_engine(None)  # no layout engine: ``savefig`` draws the figure once
    top = 0.55 if kwargs.get("title") else 0.2
    fig.subplots_adjust(left=0.9 / w, right=1 - 0.2 / w, bottom=0.55 / h, top=1 - top / h)
    return save_png(fig, path, dpi=FIGURE_DPI).name


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
    fig.savefig(io.BytesIO(), dpi=FIGURE_DPI, format="png")


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


class _Figures:
    """PNG figures drawn by worker processes while the main process goes on.

    One worker per core but one (the main process keeps a core for the design, the
    simulations and the proofs); the first starts at once and loads matplotlib while the
    main process designs, the others start when figures are waiting; once done, the main
    process draws too.  Falls back to drawing in this process when no process pool can be
    started.
    """

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled
        self.pool: Any = None
        self.jobs: list[tuple[Any, Any]] = []
        self.calls: dict[Any, tuple[Callable[..., str], tuple[Any, ...]]] = {}
        if enabled:
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor

            methods = multiprocessing.get_all_start_methods()
            ctx = multiprocessing.get_context("fork" if "fork" in methods else None)
            # the main process keeps one core for the design, simulations and proofs
            workers = max(1, min(4, (os.cpu_count() or 1) - 1))
            try:
                self.pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx)
                self.pool.submit(_warm_up)
            except (OSError, NotImplementedError, ValueError, RuntimeError):
                self.pool = None

    def submit(self, key: Any, fn: Callable[..., str], *args: Any) -> None:
        """Draw a figure (``fn(*args)`` returns its file name), when figures are on."""
        if not self.enabled:
            return
        if self.pool is not None:
            try:
                self.jobs.append((key, self.pool.submit(fn, *args)))
                self.calls[key] = (fn, args)
                return
            except RuntimeError:  # the pool broke: draw here
                self.pool = None
        self.jobs.append((key, _Done(fn(*args))))

    def results(self) -> dict[Any, str]:
        """Wait for every figure; ``{key: file name}``.

        The main process, done with its own work, draws the figures no worker has
        started yet (from the last one back, while the workers go on from the front).
        """
        try:
            for k in range(len(self.jobs) - 1, -1, -1):
                key, job = self.jobs[k]
                if not isinstance(job, _Done) and job.cancel():
                    fn, args = self.calls[key]
                    self.jobs[k] = (key, _Done(fn(*args)))
            return {key: job.result() for key, job in self.jobs}
        finally:
            self.close()

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=True, cancel_futures=True)
            self.pool = None


class _Done:
    """The value of a job run in this process (the ``result()`` of a future)."""

    def __init__(self, value: Any) -> None:
        self.value = value

    def result(self) -> Any:
        return self.value
