"""Diagnosability of a designed residual bank: KL and probability indices of its residuals.

The bank ``w' = F w - E y + G u``, ``r = M w - H y + K u`` is driven by the plant
``x' = A x + B u + Bf f + Bw w_p``, ``y = C x + D u + Df f + v``.  With ``z = [x; w]``
the residuals obey (the known input ``u`` drops out of the fault/noise analysis)::

    z' = [[A, 0], [-E C, F]] z + [Bf; -E Df] f + [[Bw, 0], [0, -E]] [w_p; v]
    r  = [-H C, M] z       - H Df f         + [0, -H] [w_p; v]

The measurement noise ``v`` reaches both the bank's state and its output, hence the
process-noise feedthrough ``Dw`` of the :class:`~geomfdi.diagnosability.model.WindowModel`
built here.  The unknown initial state of plant and bank is projected out over the
window, exactly as for a plant (Li, Wang & Liu 2015), so the indices measure what the
residual sequence itself reveals about each fault, leaks included.  When the bank is
blind to the plant's state (``F P = P A + E C``, ``M P = H C`` for some ``P``, true of
every designed bank) the model is written in the error coordinates ``e = w - P x``::

    e' = F e - (P Bf + E Df) f - P Bw w_p - E v,        r = M e - H Df f - H v,

which gives the same indices without the plant's (possibly unstable) unobservable modes.

Continuous-time plant and bank are discretised with a zero-order hold of period ``dt``;
the noises are then sequences held over each period, with the given covariances per
sample.  See the user guide, *Theory: diagnosability* (``docs/theory/diagnosability.md``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import linalg as sla

from geomfdi._validation import as_int, as_positive, as_probability, as_real_array
from geomfdi.diagnosability._linalg import _as_covariance
from geomfdi.diagnosability.model import WindowModel
from geomfdi.diagnosability.results import DiagnosabilityTable
from geomfdi.diagnosability.tables import diagnosability_table
from geomfdi.errors import DesignError, GeomFDIError
from geomfdi.tolerance import get_rtol

__all__ = [
    "BankDiagnosability",
    "StructuredIsolability",
    "bank_diagnosability",
    "bank_structured_isolability",
    "bank_window_sweep",
]


@dataclass(frozen=True)
class BankDiagnosability:
    """Indices of a residual bank's residuals (:func:`bank_diagnosability`).

    Attributes
    ----------
    kl : DiagnosabilityTable
        KL detectability ``1/2 ||q_i||^2`` and isolability of each fault from each other.
    probability : DiagnosabilityTable
        Detection / isolation probabilities of the chi-square tests at rate ``alpha``.
    model : WindowModel
        The composite plant + bank window model the indices come from.
    window : int
    dt : float
        Sampling period of the (discretised) composite model.
    theta : ndarray, (window,)
        Fault profile used (unit step over the window by default: indices per unit fault).
    """

    kl: DiagnosabilityTable
    probability: DiagnosabilityTable
    model: WindowModel
    window: int
    dt: float
    theta: np.ndarray

    @property
    def isolable_fraction(self) -> np.ndarray:
        """``FI_KL(f_i, f_j) / FD_KL(f_i)``, (p, p): the share of fault ``i``'s divergence
        that no profile of fault ``j`` explains (1: fully isolable, 0: confounded; 0 for an
        undetectable row).  Unlike ``FI`` it does not grow with the fault size or the
        residuals' signal-to-noise ratio, so it compares the decoupling of two designs."""
        fd = self.kl.detectability[:, None]
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(fd > 0, self.kl.isolability / np.where(fd > 0, fd, 1.0), 0.0)

    def __str__(self) -> str:
        return (
            f"bank diagnosability, window {self.window}, dt = {self.dt:g}\n"
            f"KL indices:\n{self.kl.text}\n"
            f"detection / isolation probabilities:\n{self.probability.text}"
        )


def _rows(bank: Any, residuals: Any) -> list[int]:
    """Rows of ``bank`` whose generators are used (existing ones; all by default)."""
    gens = list(getattr(bank, "generators", []))
    present = [k for k, g in enumerate(gens) if g is not None]
    if residuals is None:
        return present
    rows = [as_int(r, "residuals", minimum=0) for r in np.atleast_1d(residuals).tolist()]
    bad = [r for r in rows if r not in present]
    if bad or not rows:
        raise GeomFDIError(
            f"residuals: expected a non-empty subset of the existing rows {present}, got {rows}",
            argument="residuals",
        )
    return sorted(set(rows))


def _stack_bank(bank: Any, residuals: Any = None) -> tuple[np.ndarray, ...]:
    if not hasattr(bank, "generators"):
        raise GeomFDIError("bank: expected a ResidualBank", argument="bank")
    gens = [bank.generators[k] for k in _rows(bank, residuals)]
    if not gens:
        raise GeomFDIError("bank: no residual generator exists in this bank", argument="bank")
    F = sla.block_diag(*[g.F for g in gens]) if any(g.order for g in gens) else np.zeros((0, 0))
    E = np.vstack([g.E for g in gens])
    M = sla.block_diag(*[g.M for g in gens])
    if M.shape[1] != F.shape[0]:
        M = M.reshape(M.shape[0], F.shape[0]) if F.shape[0] == 0 else M
    H = np.vstack([g.H for g in gens])
    return F, E, M, H


def _zoh(A: np.ndarray, B: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Zero-order-hold discretisation ``(exp(A dt), int_0^dt exp(A s) ds B)``."""
    n, k = B.shape
    blk = np.zeros((n + k, n + k))
    blk[:n, :n] = A * dt
    blk[:n, n:] = B * dt
    ex = sla.expm(blk)
    return ex[:n, :n], ex[:n, n:]


def _error_map(
    F: np.ndarray, E: np.ndarray, M: np.ndarray, H: np.ndarray, A: np.ndarray, C: np.ndarray
) -> np.ndarray | None:
    """``P`` with ``F P = P A + E C`` and ``M P = H C`` (the bank is blind to the state).

    Then ``e = w - P x`` obeys ``e' = F e - (P Bf + E Df) f - P Bw w_p - E v`` and
    ``r = M e - H Df f - H v``: the composite reduces to the bank's own order and the
    plant's modes, unobservable from ``r`` (unstable ones included), leave the window
    model instead of entering its rank decisions at rounding level.  ``None`` when the
    Sylvester equation is singular (common eigenvalues) or the bank is not blind to the
    state (relative residual above the tolerance policy's ``rtol``).
    """
    if F.shape[0] == 0:
        P = np.zeros((0, A.shape[0]))
    else:
        if np.min(np.abs(np.subtract.outer(np.linalg.eigvals(F), np.linalg.eigvals(A)))) < 1e-8:
            return None
        P = sla.solve_sylvester(F, -A, E @ C)
    rtol = get_rtol(A.shape[0] + F.shape[0])
    norm = np.linalg.norm
    sylv = norm(F @ P - P @ A - E @ C) <= rtol * ((norm(F) + norm(A)) * norm(P) + norm(E) * norm(C))
    blind = norm(M @ P - H @ C) <= rtol * (norm(M) * norm(P) + norm(H) * norm(C))
    return P if sylv and blind else None


def _composite(
    bank: Any,
    plant: Any,
    measurement_noise: Any,
    process_noise: Any,
    process_input: Any,
    window: int | None,
    dt: float | None,
    residuals: Any = None,
) -> tuple[WindowModel, float]:
    from geomfdi.model.faults import fault_matrices
    from geomfdi.model.plant import as_plant

    P = as_plant(plant)
    if P.nd:
        raise DesignError(
            "plant: disturbance inputs are not modelled by the window model; give the plant "
            "without them (they are decoupled by the design)",
            argument="plant",
        )
    n, q = P.n, P.q
    Fb, Eb, Mb, Hb = _stack_bank(bank, residuals)
    if Eb.shape[1] != q:
        raise GeomFDIError(
            f"bank: its generators read {Eb.shape[1]} outputs, the plant has {q}", argument="bank"
        )
    bank_dt = float(getattr(bank, "dt", 0.0))
    if bank_dt != P.dt:
        raise GeomFDIError(
            f"bank: sampling period {bank_dt:g} differs from the plant's {P.dt:g}",
            argument="bank",
        )
    sig = fault_matrices(bank.faults, n, q, argument="bank.faults")
    Bf = np.hstack([b for b, _ in sig])
    Df = np.hstack([d for _, d in sig])
    names = []
    for k, f in enumerate(bank.faults):
        base = getattr(f, "name", None) or f"f{k + 1}"
        names += [base] if f.k == 1 else [f"{base}.{c}" for c in range(f.k)]
    Bw = np.eye(n) if process_input is None else np.asarray(process_input, dtype=float)
    if Bw.ndim != 2 or Bw.shape[0] != n:
        raise GeomFDIError(f"process_input: expected {n} rows", argument="process_input")
    l = Bw.shape[1]
    Qw = (
        np.zeros((l, l))
        if process_noise is None
        else _as_covariance(process_noise, "process_noise", l)
    )
    Rv = _as_covariance(measurement_noise, "measurement_noise", q)
    nw = Fb.shape[0]
    # a fault the verification found decoupled from every residual used (the achieved
    # structure) does not reach them: drop its rounding-level route (E Df ~ 1e-17), which
    # the minimisation over all profiles of f_j would otherwise amplify into a full
    # direction and so annul every FI(i, j)
    rows = _rows(bank, residuals)
    achieved = np.asarray(bank.structure, dtype=bool)[rows]
    cols = [k for k, f in enumerate(bank.faults) for _ in range(f.k)]
    blind = np.array([not achieved[:, k].any() for k in cols])
    Pe = _error_map(Fb, Eb, Mb, Hb, P.A, P.C)
    if Pe is not None:  # error coordinates e = w - Pe x: the plant's states drop out
        Ac = Fb
        Bfc = -(Pe @ Bf) - Eb @ Df
        Bec = np.hstack([-(Pe @ Bw), -Eb])
        Cc = Mb
    else:
        Ac = np.block([[P.A, np.zeros((n, nw))], [-Eb @ P.C, Fb]])
        Bfc = np.vstack([Bf, -Eb @ Df])
        Bec = np.block([[Bw, np.zeros((n, q))], [np.zeros((nw, l)), -Eb]])
        Cc = np.hstack([-Hb @ P.C, Mb])
    Dfc = -Hb @ Df
    Bfc[:, blind] = 0.0
    Dfc[:, blind] = 0.0
    Dec = np.hstack([np.zeros((Hb.shape[0], l)), -Hb])
    if P.dt == 0.0:
        if dt is None:
            raise GeomFDIError(
                "dt: plant and bank are continuous; give the sampling period for the "
                "zero-order-hold window model",
                argument="dt",
            )
        step = as_positive(dt, "dt")
        Ad, Bd = _zoh(Ac, np.hstack([Bfc, Bec]), step)
        Bfc, Bec = Bd[:, : Bfc.shape[1]], Bd[:, Bfc.shape[1] :]
    else:
        if dt is not None and float(dt) != P.dt:
            raise GeomFDIError(
                f"dt: the plant is discrete with period {P.dt:g}, got {dt}", argument="dt"
            )
        step, Ad = P.dt, Ac
    Qe = sla.block_diag(Qw, Rv)
    model = WindowModel(
        Ad,
        None,
        Cc,
        Bf=Bfc,
        Df=Dfc,
        Bw=Bec,
        Dw=Dec,
        Dv=np.zeros((Cc.shape[0], 1)),
        Qw=Qe,
        Rv=0.0,
        window=window if window is not None else Ad.shape[0] + 1,
        fault_names=names,
    )
    return model, step


def bank_diagnosability(
    bank: Any,
    plant: Any,
    *,
    measurement_noise: Any,
    process_noise: Any = None,
    process_input: Any = None,
    window: int | None = None,
    dt: float | None = None,
    theta: Any = None,
    alpha: float = 0.01,
    residuals: Any = None,
) -> BankDiagnosability:
    """FD/FI tables (KL and probability indices) of a designed bank's residuals.

    Parameters
    ----------
    bank : ResidualBank
        From ``gf.design_sensor_bank`` / ``gf.design_bank``; its generators are stacked.
    plant : gf.Plant or control.StateSpace
        The plant the bank was designed for (without disturbance inputs).
    measurement_noise : float, array_like (q,) or (q, q)
        Covariance of the sensor noise ``v`` per sample.
    process_noise : float, array_like, optional
        Covariance of the process noise ``w_p`` per sample (default: none).
    process_input : array_like, (n, l), optional
        Its input matrix ``Bw`` (default the identity).
    window : int, optional
        Window length in samples (default: composite order + 1).
    dt : float, optional
        Sampling period for continuous plant and bank (zero-order hold); must be omitted
        or equal to the plant's for a discrete one.
    theta : array_like, (window,), optional
        Fault profile; default a unit step over the window, i.e. indices per unit fault.
    alpha : float
        False-alarm rate of the probability indices.
    residuals : sequence of int, optional
        Rows of the bank (indices into ``bank.generators``) whose residuals are used;
        default all existing ones.

    Returns
    -------
    BankDiagnosability
        ``.kl`` and ``.probability`` tables (rows: faults; column 0: detectability;
        column ``1 + j``: isolability from fault ``j``).

    Notes
    -----
    The indices are those of the *joint* residual vector, i.e. of the best test that
    uses all residuals together with their exact transfers, leaks included: a leak of a
    known transfer is not a loss of information, so it need not lower this ``FI``.  What
    the joint indices do measure is how much of the output information the bank keeps:
    a bank whose residuals are a complete set of parity relations (the paper bank of
    Hou, Wen & Chen 2011 on its own example: three first-order residuals of a
    three-state plant with invertible ``C``) has about the indices of the raw outputs,
    whereas a decoupled bank whose residuals each eliminate the whole initial state from
    one sensor (the exact bank there: orders 1, 3, 3) keeps less, and a unit step fault
    is partly explained by the extra initial-state transients.  The effect of a leak on
    *structured* isolation -- deciding from the residuals designed to be blind to fault
    ``j`` -- is measured by :func:`bank_structured_isolability`.  See the user guide,
    *Theory: diagnosability* (``docs/theory/diagnosability.md``).

    Examples
    --------
    >>> import geomfdi as gf
    >>> P = gf.Plant([[1, 1, 1], [0, 1, 0], [2, 0, 1]], [[1, 0, 1], [0, 1, 1], [0, 1, 0]],
    ...              [[0, 1, 0], [0, 0, 1], [1, 0, 2]])
    >>> d = gf.bank_diagnosability(gf.design_sensor_bank(P, method="exact"), P,
    ...                            measurement_noise=1e-4, dt=0.1, window=12)
    >>> import numpy as np
    >>> off = ~np.eye(3, dtype=bool)
    >>> bool((d.kl.isolability[off] > 0).all()), np.round(d.isolable_fraction[off], 6).tolist()
    (True, [1.0, 1.0, 1.0, 1.0, 1.0, 1.0])
    """
    alpha = as_probability(alpha, "alpha")
    model, step = _composite(
        bank, plant, measurement_noise, process_noise, process_input, window, dt, residuals
    )
    s = model.window
    th = np.ones(s) if theta is None else as_real_array(theta, "theta").reshape(-1)
    kl = diagnosability_table(model, th, "kl")
    prob = diagnosability_table(model, th, "probability", alpha=alpha)
    return BankDiagnosability(kl, prob, model, s, step, th)


def bank_window_sweep(
    bank: Any,
    plant: Any,
    windows: Any,
    *,
    measurement_noise: Any,
    process_noise: Any = None,
    process_input: Any = None,
    dt: float | None = None,
    alpha: float = 0.01,
) -> dict[int, BankDiagnosability]:
    """:func:`bank_diagnosability` for several window lengths (unit step faults).

    Returns
    -------
    dict
        Window length -> :class:`BankDiagnosability`.
    """
    out = {}
    for w in np.atleast_1d(as_real_array(windows, "windows")).astype(float):
        win = as_int(int(w) if float(w).is_integer() else w, "windows", minimum=1)
        out[win] = bank_diagnosability(
            bank,
            plant,
            measurement_noise=measurement_noise,
            process_noise=process_noise,
            process_input=process_input,
            window=win,
            dt=dt,
            alpha=alpha,
        )
    return out


@dataclass(frozen=True)
class StructuredIsolability:
    """KL indices of each fault pair on the residuals a structure dedicates to it.

    Attributes
    ----------
    fd : ndarray, (p, p)
        ``fd[i, j]``: KL detectability of fault ``i`` on the residual set ``R_ij``.
    fi : ndarray, (p, p)
        ``fi[i, j]``: KL isolability of fault ``i`` from fault ``j`` on ``R_ij`` (0 when
        ``R_ij`` is empty: the structure does not isolate ``i`` from ``j``).
    residual_sets : dict
        ``(i, j) -> tuple`` of bank rows ``R_ij``: the residuals whose structure entry
        sees fault ``i`` and ignores fault ``j``.
    structure : ndarray of bool, (rows, p)
        The structure matrix the sets come from.
    """

    fd: np.ndarray
    fi: np.ndarray
    residual_sets: dict
    structure: np.ndarray

    @property
    def fraction(self) -> np.ndarray:
        """``fi / fd`` (0 where ``fd = 0``): 1 when the residuals ``R_ij`` are truly blind
        to fault ``j``, below 1 when ``j`` leaks into them."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self.fd > 0, self.fi / np.where(self.fd > 0, self.fd, 1.0), 0.0)


def bank_structured_isolability(
    bank: Any,
    plant: Any,
    *,
    measurement_noise: Any,
    structure: str = "requested",
    process_noise: Any = None,
    process_input: Any = None,
    window: int | None = None,
    dt: float | None = None,
    theta: Any = None,
) -> StructuredIsolability:
    """KL isolability of each fault pair on the residuals that should separate them.

    For faults ``i != j`` let ``R_ij`` be the existing rows ``r`` of the bank with
    ``structure[r, i] = 1`` and ``structure[r, j] = 0`` (the residuals a structured
    decision uses to tell ``i`` from ``j``).  On the joint residual of ``R_ij`` (the true
    transfers from every fault, leaks included, as in :func:`bank_diagnosability`)

        fd[i, j] = FD_KL(f_i),      fi[i, j] = FI_KL(f_i, f_j)

    and both are 0 when ``R_ij`` is empty.  If the residuals of ``R_ij`` are blind to
    ``f_j`` no profile of ``f_j`` explains any part of ``f_i``'s signature, so
    ``fi = fd > 0``; a leak of ``f_j`` into them gives ``fi < fd``.

    Parameters
    ----------
    structure : {"requested", "achieved"}
        ``"requested"`` (default): the structure the bank was designed for, i.e. the one
        a structured decision logic assumes -- a leak then shows as ``fi < fd``.
        ``"achieved"``: the structure verified on the physical model (``bank.structure``)
        -- the leaking pairs then have no dedicated residual and ``fi = 0``.
    bank, plant, measurement_noise, process_noise, process_input, window, dt, theta
        As for :func:`bank_diagnosability` (indices per unit step fault by default).

    Returns
    -------
    StructuredIsolability
    """
    if structure not in ("requested", "achieved"):
        raise GeomFDIError(
            f"structure: expected 'requested' or 'achieved', got {structure!r}",
            argument="structure",
        )
    S = np.asarray(getattr(bank, "requested" if structure == "requested" else "structure"))
    S = S.astype(bool)
    present = _rows(bank, None)
    cols = [k for k, f in enumerate(bank.faults) for _ in range(f.k)]  # scalar column -> fault
    p = len(cols)
    fd, fi = np.zeros((p, p)), np.zeros((p, p))
    sets: dict = {}
    cache: dict = {}
    for a in range(p):
        for b in range(p):
            if a == b:
                continue
            i, j = cols[a], cols[b]
            rows = tuple(r for r in present if S[r, i] and not S[r, j])
            sets[(a, b)] = rows
            if not rows:
                continue
            if rows not in cache:
                cache[rows] = bank_diagnosability(
                    bank,
                    plant,
                    measurement_noise=measurement_noise,
                    process_noise=process_noise,
                    process_input=process_input,
                    window=window,
                    dt=dt,
                    theta=theta,
                    residuals=list(rows),
                ).kl
            fd[a, b] = cache[rows].detectability[a]
            fi[a, b] = cache[rows].isolability[a, b]
    return StructuredIsolability(fd, fi, sets, S)
