"""Sampling a continuous residual bank: ``bank.discretize(dt, method=...)``.

Each generator ``w' = F w - E y + G u``, ``r = M w - H y + K u`` is sampled with
:func:`scipy.signal.cont2discrete` on the system with input ``[y; u]``:

* ``"zoh"`` (zero-order hold, ``y`` and ``u`` constant between samples):
  ``Fd = e^{F dt}``, ``[-Ed, Gd] = int_0^dt e^{F s} ds [-E, G]``; ``M, H, K`` unchanged;
* ``"tustin"`` (bilinear, ``s = (2/dt)(z - 1)/(z + 1)``): all six matrices change.

The decoupling of a generator is a property of its transfer from the faults; sampling
keeps it only approximately (exactly for faults entering the measured output directly
and a zero-order hold on a plant that is itself zero-order-hold sampled).  Designing
directly on the discrete plant (``gf.Plant(..., dt=dt)``) remains the first choice; a
sampled bank is for deploying a continuous design.  See the user guide, *Theory:
residual evaluation* (``docs/theory/evaluation.md``).
"""

from __future__ import annotations

from typing import Any, TypeVar

import numpy as np

from geomfdi._validation import as_positive
from geomfdi.errors import GeomFDIError
from geomfdi.generators.interfaces import BankLike, GeneratorLike

__all__ = ["METHODS", "discretize_generator", "discretize_bank"]

METHODS = ("zoh", "tustin")

Gen = TypeVar("Gen", bound=GeneratorLike)
Bank = TypeVar("Bank", bound=BankLike)


def discretize_generator(g: Gen, dt: float, method: str = "zoh") -> Gen:
    """One continuous generator sampled at ``dt`` (module docstring).

    The target, decoupled faults, method and info are kept; ``info["sampled"]`` records
    ``{"dt", "method"}``.
    """
    from scipy.signal import cont2discrete

    if g.dt > 0:
        raise GeomFDIError(
            f"bank: the generator is already discrete (dt = {g.dt:g})", argument="bank"
        )
    B = np.hstack([-g.E, g.G])
    D = np.hstack([-g.H, g.K])
    if g.order == 0:
        Fd, Bd, Md, Dd = g.F, B, g.M, D
    else:
        sel = "bilinear" if method == "tustin" else "zoh"
        Fd, Bd, Md, Dd, _ = cont2discrete((g.F, B, g.M, D), dt, method=sel)
    q = g.q
    return type(g)(
        Fd,
        -Bd[:, :q],
        Bd[:, q:],
        Md,
        -Dd[:, :q],
        Dd[:, q:],
        dt=float(dt),
        target=g.target,
        decoupled=g.decoupled,
        method=g.method,
        info={**g.info, "sampled": {"dt": float(dt), "method": method}},
    )


def discretize_bank(bank: Bank, dt: Any, method: str = "zoh") -> Bank:
    """A discrete :class:`ResidualBank` sampled at ``dt`` with ``method``.

    Parameters
    ----------
    bank : ResidualBank
        A continuous bank.
    dt : float
        Sampling period (> 0).
    method : {"zoh", "tustin"}

    Returns
    -------
    ResidualBank
        Same rows, requested and achieved structure, isolability, diagnostics, faults,
        design method and info (plus ``info["sampled"]``); generators sampled with
        :func:`discretize_generator`.
    """
    dt = as_positive(dt, "dt")
    if method not in METHODS:
        raise GeomFDIError(f"method: must be one of {METHODS}, got {method!r}", argument="method")
    if bank.dt > 0:
        raise GeomFDIError(
            f"bank: already discrete (dt = {bank.dt:g}); sample a continuous bank",
            argument="bank",
        )
    gens = [None if g is None else discretize_generator(g, dt, method) for g in bank.generators]
    return type(bank)(
        gens,
        np.array(bank.requested, copy=True),
        np.array(bank.structure, copy=True),
        np.array(bank.isolable, copy=True),
        list(bank.diagnostics),
        list(bank.faults),
        dt,
        bank.method,
        {**bank.info, "sampled": {"dt": dt, "method": method}},
    )
