"""The sampled, fused form of a residual bank that every deployment path runs.

All existing generators of a bank are stacked into one discrete-time system on the
signal ``z = [y; u]`` (measured outputs, then known inputs)::

    xi[k+1] = A xi[k] + B z[k]
    c[k]    = C xi[k] + D z[k]            (residual components of every generator)

with ``A`` block diagonal (the generators' ``F``), ``B = [-E, G]``, ``C`` block diagonal
(the ``M``) and ``D = [-H, K]``.  Bank row ``i`` reads its components ``c[k]`` as the
residual itself (one component) or as their Euclidean norm (several), like
:func:`geomfdi.simulate`; rows of missing generators are zero.

A *continuous* bank is sampled exactly for inputs linear between samples (first-order
hold, the convention of :func:`control.forced_response` and :func:`geomfdi.simulate`),
``w[k+1] = Ad w[k] + B0 z[k] + B1 z[k+1]``, and put in the standard form with the
state ``xi = w - B1 z``: ``A = Ad``, ``B = B0 + Ad B1``, ``D = D_c + C B1``.  A discrete
bank is used as it is (``xi = w``).

The same matrices drive :func:`geomfdi.evaluate` (loop-free recursion over a record),
:class:`geomfdi.Monitor` (one sample at a time) and the generated C and Python code, so
the three agree to rounding.  See the user guide, *Theory: residual evaluation*
(``docs/theory/evaluation.md``).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg

from geomfdi._validation import as_float, as_vector
from geomfdi.deployment._lti import (
    LiftedMaps,
    discretize_hold,
    lift_factor,
    lifted_maps,
    lifted_recursion,
    schur_form,
)
from geomfdi.errors import GeomFDIError, ShapeError
from geomfdi.generators.generator import ResidualBank, ResidualGenerator, stacked_matrices

__all__ = [
    "SAMPLE_LIMIT",
    "Program",
    "build_program",
    "as_bank",
    "check_initial",
    "initial_state",
    "run_program",
    "sample_valid",
]

#: Largest magnitude of a sample entry that is evaluated: a sample with an entry that is
#: not finite or larger than this (in magnitude) is *missing*.  Products of such samples
#: with the matrices of a bank stay far from overflow (``1e150 ** 2 = 1e300``), so every
#: deployment path (:class:`geomfdi.Monitor` step and chunk, :func:`geomfdi.evaluate`, the
#: generated C and Python) takes the same decisions on out-of-range data.
SAMPLE_LIMIT = 1e150


def as_bank(bank: Any) -> ResidualBank:
    """A :class:`ResidualBank` from a bank or a single generator (one row, no faults)."""
    if isinstance(bank, ResidualBank):
        return bank
    if isinstance(bank, ResidualGenerator):
        return ResidualBank(
            [bank],
            np.zeros((1, 0), dtype=bool),
            np.zeros((1, 0), dtype=bool),
            np.zeros(0, dtype=bool),
            ["ok"],
            [],
            bank.dt,
            bank.method,
        )
    raise GeomFDIError(
        f"bank: expected a ResidualBank or ResidualGenerator, got {type(bank).__name__}",
        argument="bank",
    )


@dataclass(frozen=True)
class Program:
    """The fused discrete form of a bank (module docstring).

    Attributes
    ----------
    A, B, C, D : ndarray
        ``(nw, nw)``, ``(nw, nz)``, ``(nc, nw)``, ``(nc, nz)`` with ``nz = q + m``.
    J : ndarray, (nw, nz)
        ``xi = w - J z``: the first-order-hold shift (zero for a discrete bank).
    steady : ndarray (nw, nz) or None
        ``xi = steady @ z`` is the fixed point for a constant ``z``
        (``(I - A)^-1 B``); ``None`` when ``I - A`` is singular (a pole at ``z = 1``).
    rows : tuple of (int, int) or None
        Component slice ``c[start:stop]`` of each bank row; ``None`` for missing rows.
    q, m : int
    dt : float
        The sampling period.
    hold : str
        ``"discrete"`` or ``"foh"`` (sampled from a continuous bank).
    structure : ndarray of bool, (n_rows, n_faults)
        Achieved structure used for isolation.
    basis : ndarray (nw, nw) or None
        Unitary ``Z`` of the block-diagonal Schur form ``A = Z T Z^H`` (one block per
        generator).
    lifted : LiftedMaps or None
        The lifted form on blocks of samples in those coordinates, used by the loop-free
        recursion of :func:`run_program`; ``None`` when it overflows (an unstable bank:
        then the recursion runs sample by sample, :func:`run_plain`).
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    J: np.ndarray
    steady: np.ndarray | None
    rows: tuple[tuple[int, int] | None, ...]
    q: int
    m: int
    dt: float
    hold: str
    structure: np.ndarray
    basis: np.ndarray | None = None
    lifted: LiftedMaps | None = None

    @property
    def nw(self) -> int:
        return self.A.shape[0]

    @property
    def nz(self) -> int:
        return self.q + self.m

    @property
    def nc(self) -> int:
        return self.C.shape[0]

    @property
    def n_rows(self) -> int:
        return len(self.rows)

    @property
    def present(self) -> list[int]:
        return [i for i, s in enumerate(self.rows) if s is not None]

    @property
    def scalar_rows(self) -> bool:
        """True when every bank row exists and has exactly one component, in order."""
        return all(s is not None and s == (i, i + 1) for i, s in enumerate(self.rows))

    def row_values(self, comp: np.ndarray) -> np.ndarray:
        """Bank-row residuals from components ``comp`` (``(nc, ...)``): value or norm."""
        out = np.zeros((self.n_rows, *comp.shape[1:]))
        for i, s in enumerate(self.rows):
            if s is None:
                continue
            a, b = s
            if b - a == 1:
                out[i] = comp[a]
            else:  # sequential sum of squares, the order of the generated code
                with np.errstate(over="ignore"):  # beyond float range: +inf, an alarm
                    acc = comp[a] * comp[a]
                    for c in range(a + 1, b):
                        acc = acc + comp[c] * comp[c]
                out[i] = np.sqrt(acc)
        return out


_PROGRAMS: dict[Any, Program] = {}
_PROGRAM_ENTRIES = 32


def _bank_key(bank: ResidualBank, dt: Any) -> Any:
    """A fingerprint of everything :func:`build_program` reads: the generators' matrices
    (shapes, and values as floats: one hash over the concatenated entries; missing rows
    in place), the sampling periods and the structure."""
    gens = bank.generators
    mats = [np.asarray(getattr(g, name)) for g in gens if g is not None for name in "FEGMHK"]
    h = hashlib.blake2b(
        np.concatenate([a.ravel() for a in mats], dtype=float) if mats else b"", digest_size=16
    )
    S = np.ascontiguousarray(bank.structure, dtype=bool)
    h.update(S)
    meta = (
        float(bank.dt),
        dt,
        [None if g is None else float(g.dt) for g in gens],
        [a.shape for a in mats],
        S.shape,
    )
    h.update(repr(meta).encode())
    return h.digest()


def build_program(bank: Any, dt: float | None = None) -> Program:
    """The fused discrete form of ``bank`` (module docstring).

    Parameters
    ----------
    bank : ResidualBank or ResidualGenerator
    dt : float, optional
        Sampling period.  Required for a continuous bank; for a discrete bank it must
        equal the bank's ``dt`` (relative ``1e-6``) when given.

    Returns
    -------
    Program
        Kept by the fingerprint of the bank's matrices, periods and structure (its
        arrays read-only): evaluating or monitoring the same bank again (short records,
        a monitor per stream) builds it once; a changed matrix builds another.
    """
    bank = as_bank(bank)
    key = _bank_key(bank, None if dt is None else as_float(dt, "dt"))
    hit = _PROGRAMS.get(key)
    if hit is None:
        hit = _build_program(bank, dt)
        for a in (hit.A, hit.B, hit.C, hit.D, hit.J, hit.steady, hit.structure, hit.basis):
            if a is not None:
                a.setflags(write=False)
        if len(_PROGRAMS) >= _PROGRAM_ENTRIES:
            _PROGRAMS.clear()
        _PROGRAMS[key] = hit
    return hit


def _build_program(bank: ResidualBank, dt: Any) -> Program:
    """:func:`build_program` without the cache."""
    gens = [g for g in bank.generators if g is not None]
    if not gens:
        raise GeomFDIError("bank: no residual generator exists in this bank", argument="bank")
    q, m = gens[0].q, gens[0].m
    for g in gens:
        if (g.q, g.m) != (q, m):
            raise ShapeError(
                "bank: the generators read different numbers of signals", argument="bank"
            )
    F, Bz, M, Dz = stacked_matrices(gens)
    nw, nz = F.shape[0], q + m
    bdt = float(bank.dt)
    if dt is not None:
        dt = as_float(dt, "dt")
    if bdt > 0:
        if dt is not None and abs(float(dt) - bdt) > 1e-6 * bdt:
            raise GeomFDIError(
                f"dt: {float(dt):g} differs from the discrete bank's sampling period {bdt:g}",
                argument="dt",
            )
        A, B, C, D, J, hold, step = F, Bz, M, Dz, np.zeros((nw, nz)), "discrete", bdt
    else:
        if dt is None:
            raise GeomFDIError(
                "dt: a continuous bank needs the sampling period of the data "
                "(or discretise it with bank.discretize(dt))",
                argument="dt",
            )
        step = float(dt)
        if not np.isfinite(step) or step <= 0:
            raise GeomFDIError(f"dt: must be finite and > 0, got {dt}", argument="dt")
        dis = discretize_hold(F, Bz, step, "foh")
        A, J = dis.Ad, dis.B1
        B = dis.B0 + dis.Ad @ dis.B1
        C, D = M, Dz + M @ dis.B1
        hold = "foh"
    steady = None
    if nw:
        IA = np.eye(nw) - A
        if np.linalg.cond(IA) < 1e12:
            steady = np.linalg.solve(IA, B)
    else:
        steady = np.zeros((0, nz))
    rows: list[tuple[int, int] | None] = []
    basis, lifted = _lifted_form(A, B, C, D, gens) if nw else (None, None)
    if lifted is not None and not _finite_maps(lifted):
        lifted = None  # an unstable or huge bank: run sample by sample (run_plain)
    o = 0
    for g in bank.generators:
        if g is None:
            rows.append(None)
            continue
        rows.append((o, o + g.n_outputs))
        o += g.n_outputs
    return Program(
        np.ascontiguousarray(A),
        np.ascontiguousarray(B),
        np.ascontiguousarray(C),
        np.ascontiguousarray(D),
        np.ascontiguousarray(J),
        steady,
        tuple(rows),
        q,
        m,
        step,
        hold,
        np.asarray(bank.structure, dtype=bool),
        basis,
        lifted,
    )


def _finite_maps(maps: LiftedMaps) -> bool:
    """Every matrix of the lifted form finite (powers of an unstable ``T`` overflow)."""
    parts = [maps.powers, maps.Hz, maps.Gam, maps.Psi, *maps.doubling]
    return all(np.isfinite(a).all() for a in parts)


_LIFTED_FORMS: dict[tuple, tuple[np.ndarray, LiftedMaps]] = {}


def _lifted_form(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, gens: list[ResidualGenerator]
) -> tuple[np.ndarray, LiftedMaps]:
    """:func:`_lifted_form_of`, cached by the matrices: evaluating or monitoring the same
    bank again (short records) reuses its Schur basis and lifted maps (never written)."""
    key = (tuple(g.order for g in gens),) + tuple(
        (a.shape, np.ascontiguousarray(a).tobytes()) for a in (A, B, C, D)
    )
    hit = _LIFTED_FORMS.get(key)
    if hit is None:
        hit = _lifted_form_of(A, B, C, D, gens)
        if len(_LIFTED_FORMS) >= 32:
            _LIFTED_FORMS.clear()
        _LIFTED_FORMS[key] = hit
    return hit


def _lifted_form_of(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, gens: list[ResidualGenerator]
) -> tuple[np.ndarray, LiftedMaps]:
    """Schur basis of the block-diagonal ``A`` (one generator block at a time) and the
    lifted maps of the fused system in it.

    The unitary basis keeps the rounding of the recursion at the level of the plain
    sample-by-sample update (a modal basis would amplify it by its condition number).
    """
    Ts, Zs, stops = [], [], []
    i = 0
    for g in gens:
        n = g.order
        if n:
            T, Z = schur_form(A[i : i + n, i : i + n])
            Ts.append(T)
            Zs.append(Z)
            stops += [i + n] * n
        i += n
    T = scipy.linalg.block_diag(*Ts)
    Z = scipy.linalg.block_diag(*Zs)
    M = lift_factor(A.shape[0], C.shape[0], B.shape[1])
    with np.errstate(over="ignore", invalid="ignore"):  # checked by _finite_maps
        return Z, lifted_maps(A, B, C, D, T, Z, M, np.array(stops, dtype=int))


INITIAL = ("zero", "steady")


def check_initial(initial: Any, program: Program) -> Any:
    """Validate ``initial``: ``"zero"``, ``"steady"`` or a generator state ``(nw,)``."""
    if isinstance(initial, str):
        if initial not in INITIAL:
            raise GeomFDIError(
                f"initial: must be 'zero', 'steady' or a state vector, got {initial!r}",
                argument="initial",
            )
        if initial == "steady" and program.steady is None:
            raise GeomFDIError(
                "initial: 'steady' needs I - A invertible; a generator has a pole at z = 1 "
                "(use 'zero' or an explicit state)",
                argument="initial",
            )
        return initial
    return as_vector(initial, "initial", length=program.nw, allow_empty=not program.nw).copy()


def initial_state(program: Program, initial: Any, z0: np.ndarray) -> np.ndarray:
    """``xi`` at the first sample of a segment whose first input is ``z0``.

    ``"zero"``: generator state ``w = 0``; ``"steady"``: the fixed point for ``z0`` held
    constant; an array: that generator state ``w``.  In the ``xi`` coordinates
    ``xi = w - J z0``.
    """
    if isinstance(initial, str):
        if initial == "steady":
            return program.steady @ z0
        return -(program.J @ z0)
    return initial - program.J @ z0


def restart_rule(program: Program, initial: Any) -> str:
    """How a segment after a gap of missing samples restarts: ``"zero"`` when asked
    for (or when no steady state exists), else ``"steady"``."""
    if isinstance(initial, str) and initial == "zero":
        return "zero"
    return "steady" if program.steady is not None else "zero"


def sample_valid(Z: np.ndarray) -> np.ndarray:
    """Per column of ``Z`` (``(nz, L)``): every entry finite and at most
    :data:`SAMPLE_LIMIT` in magnitude (``False``: a missing sample)."""
    return (np.abs(Z) <= SAMPLE_LIMIT).all(axis=0)


def _in_range(Z: np.ndarray) -> bool:
    """Every entry of ``Z`` valid (no temporary array: ``max``/``min`` propagate nan)."""
    return Z.size == 0 or bool(Z.max() <= SAMPLE_LIMIT and Z.min() >= -SAMPLE_LIMIT)


def _finite(a: np.ndarray) -> bool:
    """Every entry of ``a`` finite (``max``/``min`` propagate nan; no temporary)."""
    return a.size == 0 or bool(np.isfinite(a.max()) and np.isfinite(a.min()))


def run_program(
    program: Program, Z: np.ndarray, xi: np.ndarray, pending: Any, restart: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray, Any]:
    """Run the fused recursion over the samples ``Z`` (``(nz, L)``) without a time loop.

    Parameters
    ----------
    program : Program
    Z : ndarray, (nz, L)
        ``[y; u]`` per sample; a column with an entry that is not finite or beyond
        :data:`SAMPLE_LIMIT` in magnitude is a *missing* sample.
    xi : ndarray, (nw,)
        State before the first sample (ignored while ``pending`` is set).
    pending : None, str or ndarray
        ``None``: ``xi`` is valid.  Otherwise the :func:`initial_state` rule applied at
        the next valid sample.
    restart : str
        Rule for the first valid sample after missing ones.

    Returns
    -------
    comp : ndarray, (nc, L)
        Residual components; ``nan`` on missing samples (the state is not advanced
        through them: the next valid sample restarts the recursion with ``restart``).
    valid : ndarray of bool, (L,)
    xi : ndarray, (nw,)
        State after the last sample.
    pending : None or rule
        Set when the record ends on missing samples (or was empty and still pending).

    Notes
    -----
    A generator state or residual component that overflows (only an unstable bank or
    one of gain beyond ``1e150`` can get there from valid samples) makes that sample
    missing too, and the next sample restarts the generators: the chunk is then run
    sample by sample (:func:`run_plain`), the rule of the per-sample step.
    """
    L = Z.shape[1]
    # a bounded maximum and minimum prove every entry valid (cheap); else the exact test
    every = _in_range(Z)
    valid = np.ones(L, dtype=bool) if every else sample_valid(Z)
    every = every or bool(valid.all())
    comp = np.empty((program.nc, L)) if every else np.full((program.nc, L), np.nan)
    if L == 0:
        return comp, valid, xi, pending
    if program.nw and program.lifted is None:
        return run_plain(program, Z, xi, pending, restart)
    if every:
        segments = [(0, L)]
    else:
        edges = np.flatnonzero(np.diff(np.concatenate(([0], valid.astype(np.int8), [0]))))
        segments = list(zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True))
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow is handled below
        return _run_segments(program, Z, xi, pending, restart, comp, valid, segments)


def _run_segments(
    program: Program,
    Z: np.ndarray,
    xi: np.ndarray,
    pending: Any,
    restart: str,
    comp: np.ndarray,
    valid: np.ndarray,
    segments: list[tuple[int, int]],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, Any]:
    """The lifted recursion over each segment of valid samples (:func:`run_program`)."""
    L = Z.shape[1]
    xi0, pending0 = xi, pending
    xi = np.array(xi, dtype=float)
    for s, e in segments:
        if s > 0:  # missing samples before this segment
            pending = restart
        Zs = Z[:, s:e]
        if pending is not None:
            xi = initial_state(program, pending, Zs[:, 0])
            pending = None
        if program.nw:
            Zt = Zs.T if Zs.T.flags.c_contiguous else np.ascontiguousarray(Zs.T)
            Zu = program.basis
            se = lifted_recursion(program.lifted, Zt, Zu.conj().T @ xi, comp[:, s:e])
            xi = (Zu @ se).real
        else:
            comp[:, s:e] = program.D @ Zs
        if not (_finite(comp[:, s:e]) and _finite(xi)):
            return run_plain(program, Z, xi0, pending0, restart)  # an overflow
    if not valid[L - 1]:
        pending = restart
    return comp, valid, xi, pending


def run_plain(
    program: Program, Z: np.ndarray, xi: np.ndarray, pending: Any, restart: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray, Any]:
    """:func:`run_program` sample by sample (for a bank whose state overflows).

    Sample ``k`` is missing when its entries are out of range (:func:`sample_valid`) or
    when ``c[k] = C xi + D z`` or the next state ``A xi + B z`` has a non-finite entry;
    either way the state is not advanced and the next valid sample restarts it.
    """
    L = Z.shape[1]
    valid = sample_valid(Z)
    comp = np.full((program.nc, L), np.nan)
    xi = np.array(xi, dtype=float)
    with np.errstate(over="ignore", invalid="ignore"):
        for k in np.flatnonzero(valid).tolist():
            z = Z[:, k]
            if k > 0 and not valid[k - 1]:
                pending = restart
            if pending is not None:
                xi = initial_state(program, pending, z)
                pending = None
            c = program.C @ xi + program.D @ z
            nxt = program.A @ xi + program.B @ z
            if np.isfinite(c).all() and np.isfinite(nxt).all():
                comp[:, k], xi = c, nxt
            else:
                valid[k] = False
                pending = restart
    if L and not valid[-1]:
        pending = restart
    return comp, valid, xi, pending
