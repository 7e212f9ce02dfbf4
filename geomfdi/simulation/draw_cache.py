"""The noise draws a process keeps for the runs that read them again.

A campaign's runs of one repetition draw the same noise in every cell (common random
numbers, :mod:`geomfdi.campaign.runner`); the fused pass (:mod:`geomfdi.simulation.fused`)
keeps a run's standard-normal draws here, by seed, and the runs of the other cells read
them instead of drawing again.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from typing import Any

import numpy as np

__all__ = ["DrawCache"]


class DrawCache:
    """The standard-normal draws of the runs met, by seed, within a byte budget.

    A campaign's runs of one repetition have the same seed in every (scenario, size,
    onset) (common random numbers): their draws are made once per process and read
    again by the runs of the other cells.  The arrays are the drawn values themselves
    (copies of the stream's buffers), so the results are those of drawing again.  When
    the budget is full the draws used longest ago make room (a campaign runs its blocks
    by ranges of repetitions, :meth:`geomfdi.Campaign.blocks`: a range's draws are
    read by the blocks of every cell, then not again).

    Threads running blocks at once share the cache: a run being drawn by one thread is
    *reserved* (:meth:`reserve`), and another thread needing it waits for those draws
    instead of drawing them again.
    """

    def __init__(self, budget: float) -> None:
        self.arrays: OrderedDict[Any, np.ndarray] = OrderedDict()
        self.nbytes = 0
        self.budget = float(budget)
        self._lock = threading.Lock()  # blocks of a serial campaign run on threads
        self._pending: dict[Any, threading.Event | None] = {}

    def get(self, key: Any) -> np.ndarray | None:
        if key is None:
            return None
        with self._lock:
            z = self.arrays.get(key)
            if z is not None:
                self.arrays.move_to_end(key)
            return z

    def reserve(self, key: Any) -> tuple[np.ndarray | None, threading.Event | None]:
        """``(draws, None)`` when kept; ``(None, None)``: not kept, and now reserved by
        the caller, who draws and :meth:`put` s them (or :meth:`release` s the key);
        ``(None, event)``: being drawn by another thread, kept once ``event`` is set
        (then :meth:`get` them; None if the budget did not allow)."""
        return self.reserve_all([key])[0]

    def reserve_all(
        self, keys: list[Any]
    ) -> list[tuple[np.ndarray | None, threading.Event | None]]:
        """:meth:`reserve` of every key, under one lock (an event is made only for a
        key another thread waits for)."""
        out: list[tuple[np.ndarray | None, threading.Event | None]] = []
        with self._lock:
            for key in keys:
                z = self.arrays.get(key) if key is not None else None
                if z is not None:
                    self.arrays.move_to_end(key)
                    out.append((z, None))
                elif key is None or key not in self._pending:
                    if key is not None:
                        self._pending[key] = None  # reserved; no one waits yet
                    out.append((None, None))
                else:
                    event = self._pending[key]
                    if event is None:
                        event = self._pending[key] = threading.Event()
                    out.append((None, event))
        return out

    def release(self, key: Any) -> None:
        """End a reservation (the threads waiting for it go on)."""
        with self._lock:
            event = self._pending.pop(key, None)
        if event is not None:
            event.set()

    def put(self, key: Any, z: np.ndarray) -> np.ndarray:
        """``z`` kept under ``key`` (a copy) when it fits the budget, after dropping
        the draws used longest ago; the array to read.  Ends ``key``'s reservation."""
        if key is None:
            return z
        try:
            with self._lock:
                kept = self.arrays.get(key)
                if kept is not None:  # (another thread drew the same run meanwhile)
                    return kept
                if z.nbytes > self.budget:
                    return z
                while self.arrays and self.nbytes + z.nbytes > self.budget:
                    # (a thread still reading a dropped array holds its own reference)
                    self.nbytes -= self.arrays.popitem(last=False)[1].nbytes
                kept = self.arrays[key] = np.array(z, order="C")
                self.nbytes += kept.nbytes
                return kept
        finally:
            self.release(key)
