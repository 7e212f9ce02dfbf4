"""What generated code needs: the fused matrices, decisions and start-up rules.

Both generators (C and Python) emit exactly the per-sample algorithm of
:class:`geomfdi.Monitor` (see :mod:`geomfdi.deployment.online`):

1. ``z = [y; u]`` (minus the operating point ``[y_op; u_op]`` of a bank designed at one:
   the code takes physical values); if an entry is not finite or beyond ``SAMPLE_LIMIT``
   (``1e150``) in magnitude, or if the update of step 3 overflows, the sample is
   *missing*: residuals ``nan``, a raw alarm pattern of zeros enters the persistence
   window, the state is not advanced and the next valid sample restarts the generators
   (``restart`` rule);
2. at the first valid sample of a segment ``xi = S z`` (steady), ``-J z`` (zero) or
   ``w0 - J z`` (explicit ``w0``);
3. ``c = C xi + D z``, ``xi <- A xi + B z``; residual of row ``i`` = ``c[a]`` or
   ``sqrt(c[a]^2 + ... )`` (sequential sum), ``0`` for a missing generator;
4. raw alarm ``|r_i| > threshold_i``; k-of-n ring buffer of raw alarms; confirmed when the
   count reaches ``k``;
5. with ``latch``: the held pattern, the OR of the confirmed alarms since the episode
   began; a sample with a confirmed alarm sets the quiet counter to 0, otherwise it
   counts up and at ``reset`` (``0``: never) the pattern is cleared; without
   ``latch`` the pattern is the confirmed alarms;
6. isolation: the structure column equal to the pattern (``-1`` no alarm, ``-2``
   unexplained, ``-3`` ambiguous), ``-4`` (``multiple``) when the OR of the columns
   inside the pattern equals it;
7. settling (``n > 1``): a fault index or ``-4`` is returned when the pattern decision
   was the same for ``k`` of the last ``n`` samples (a ring of the last ``n - 1``
   decisions), else ``-2``.

This is the rule :class:`geomfdi.Persistence` (:mod:`geomfdi.deployment.decide`).
"""

from __future__ import annotations

import keyword
import os
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from geomfdi.errors import GeomFDIError, NotDiscreteError

__all__ = ["CodeSpec", "code_spec", "check_name", "check_out_dir", "signal_macros"]


@dataclass(frozen=True)
class CodeSpec:
    """Numbers of the generated code (module docstring)."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    J: np.ndarray
    S: np.ndarray
    W0: np.ndarray
    rows: tuple[tuple[int, int] | None, ...]
    q: int
    m: int
    dt: float
    thresholds: np.ndarray  # +inf: row never alarms
    k: int
    n: int
    latch: bool
    reset: int  # 0: never
    multiple: bool  # a persistence rule: MULTIPLE decisions and settling
    structure: np.ndarray
    initial: str  # "zero", "steady" or "explicit"
    restart: str
    orders: tuple[int, ...]  # generator orders (existing generators, in row order)
    z_op: np.ndarray | None = None  # operating point [y_op; u_op] subtracted from z (physical)
    outputs: tuple[str, ...] = ()  # signal names (the plant's), in channel order
    inputs: tuple[str, ...] = ()
    faults: tuple[str, ...] = ()  # fault names, in structure-column order

    @property
    def nw(self) -> int:
        return self.A.shape[0]

    @property
    def nc(self) -> int:
        return self.C.shape[0]

    @property
    def n_rows(self) -> int:
        return len(self.rows)

    @property
    def n_faults(self) -> int:
        return self.structure.shape[1]


#: Keywords of C (C99 to C23) and Python: never a name of generated code.
C_KEYWORDS = frozenset(
    "auto break case char const continue default do double else enum extern float for goto "
    "if inline int long register restrict return short signed sizeof static struct switch "
    "typedef union unsigned void volatile while alignas alignof bool constexpr false "
    "nullptr static_assert thread_local true typeof typeof_unqual".split()
)
#: Modules the generated Python imports (a module of that name would shadow them).
SHADOWED = frozenset({"numpy", "np", "math"})


def check_name(name: str) -> str:
    """A C identifier / Python module name (letters, digits, underscores).

    Refused: keywords of C or Python, names reserved in C (a leading underscore), and
    module names that the generated Python module would shadow when it is imported
    from its folder (``numpy``, ``math`` and the other modules of Python's standard
    library).  Internal names of the generated C carry the prefix ``name_``, so any
    accepted name (``start``, ``decide``) is free of clashes.
    """
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name):
        raise GeomFDIError(
            f"name: must be an identifier of letters, digits and _ beginning with a letter, "
            f"got {name!r:.60}",
            argument="name",
        )
    if len(name) > 64:
        raise GeomFDIError(f"name: at most 64 characters, got {len(name)}", argument="name")
    if keyword.iskeyword(name) or keyword.issoftkeyword(name) or name in C_KEYWORDS:
        raise GeomFDIError(f"name: {name!r} is a keyword of C or Python", argument="name")
    if name in SHADOWED or name in sys.stdlib_module_names:
        raise GeomFDIError(
            f"name: {name!r} would shadow the module of that name when the generated code "
            "is imported; choose another name (e.g. 'monitor_{name}')",
            argument="name",
        )
    return name


def check_out_dir(out_dir: Any) -> Path:
    """The output folder: a path (``str`` or path-like), not an existing file."""
    if not isinstance(out_dir, str | os.PathLike) or not str(out_dir).strip():
        raise GeomFDIError(
            f"out_dir: expected a folder path, got {type(out_dir).__name__}", argument="out_dir"
        )
    if "\x00" in str(out_dir):
        raise GeomFDIError("out_dir: the path holds a NUL character", argument="out_dir")
    path = Path(out_dir)
    if path.exists() and not path.is_dir():
        raise GeomFDIError(f"out_dir: {path} exists and is not a folder", argument="out_dir")
    return path


def code_spec(
    source: Any,
    *,
    threshold: Any = None,
    persistence: Any = None,
    initial: Any = "steady",
) -> CodeSpec:
    """The :class:`CodeSpec` of a :class:`~geomfdi.Monitor` or a discrete bank.

    A monitor carries its own threshold, persistence and start-up rule; for a bank they
    are given here (as for :class:`~geomfdi.Monitor`).
    """
    from geomfdi.deployment.monitor import Monitor

    if isinstance(source, Monitor):
        mon = source
    else:
        from geomfdi.deployment.program import as_bank

        bank = as_bank(source)
        if bank.dt <= 0:
            raise NotDiscreteError(
                "bank: code is generated for discrete banks only; sample this continuous "
                "bank first with bank.discretize(dt) (or design on a discrete plant)",
                argument="bank",
            )
        mon = Monitor(bank, threshold=threshold, persistence=persistence, initial=initial)
    if mon.bank.dt <= 0:
        raise NotDiscreteError(
            "monitor: code is generated for discrete banks only; build the monitor on "
            "bank.discretize(dt)",
            argument="monitor",
        )
    from geomfdi.model.signals import bank_signals

    p = mon.program
    sig = bank_signals(mon.bank)
    thr = np.full(p.n_rows, np.inf) if mon.thresholds is None else mon.thresholds
    init = mon.initial
    return CodeSpec(
        A=p.A,
        B=p.B,
        C=p.C,
        D=p.D,
        J=p.J,
        S=p.steady if p.steady is not None else np.zeros((p.nw, p.nz)),
        W0=np.zeros(p.nw) if isinstance(init, str) else np.asarray(init, dtype=float),
        rows=p.rows,
        q=p.q,
        m=p.m,
        dt=p.dt,
        thresholds=np.asarray(thr, dtype=float),
        k=mon.persistence.k,
        n=mon.persistence.n,
        latch=mon.persistence.latch,
        reset=mon.persistence.reset or 0,
        multiple=not mon.persistence.trivial,
        structure=np.asarray(p.structure, dtype=bool),
        initial=init if isinstance(init, str) else "explicit",
        restart=mon._restart,
        orders=tuple(g.order for g in mon.bank.generators if g is not None),
        z_op=sig["z_op"] if np.any(sig["z_op"] != 0) else None,
        outputs=tuple(sig["outputs"]),
        inputs=tuple(sig["inputs"]),
        faults=tuple(str(getattr(f, "name", f)) for f in mon.bank.faults),
    )


def signal_macros(spec: CodeSpec) -> list[tuple[str, int]]:
    """``(identifier, index)`` of every output (``Y_``), input (``U_``) and fault (``F_``)
    by its name, sanitised to an identifier (:func:`geomfdi.model.signals.c_identifier`);
    a repeated identifier gets the index appended."""
    from geomfdi.model.signals import c_identifier

    out: list[tuple[str, int]] = []
    seen: set[str] = set()
    for prefix, names in (("Y", spec.outputs), ("U", spec.inputs), ("F", spec.faults)):
        for i, name in enumerate(names):
            ident = f"{prefix}_{c_identifier(name).upper()}"
            if ident in seen:
                ident = f"{ident}_{i}"
            seen.add(ident)
            out.append((ident, i))
    return out
