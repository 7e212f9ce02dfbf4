"""Noise covariance of a residual: the generator driven by the noise model, in steady state.

A residual generator ``(F, E, G, M, H, K)`` on a plant ``(A, B, C, D)`` with state feedback
``u = u_ext - K_c x`` (or open loop) sees measurement noise ``v = L_v z_v`` on ``y`` and
process noise ``w = L_w z_w`` through ``B_w`` (:class:`geomfdi.Noise`; the plant's own noise
inputs ``Noise(inputs=...)`` join ``w``, entering also the readings through ``D_w``).  The
noise part of the residual obeys (continuous time; the same with ``x[k+1]`` for discrete
plants; ``v`` stands for ``v + D_w w``)::

    x'  = A_cl x + B_w w,             A_cl = A - B K_c,   C_cl = C - D K_c
    w_g' = F w_g + Sigma x - E v,     Sigma = -E C_cl - G K_c
    r   = M w_g + N x - H v,          N = -H C_cl - K K_c

With ``Pi`` solving the Sylvester equation ``F Pi - Pi A_cl = -Sigma`` and the generator
decoupled from the healthy loop (``M Pi + N = 0``, which a correct design satisfies), the
change of state ``w~ = w_g - Pi x`` removes the plant::

    w~' = F w~ - E v - Pi B_w w,      r = M w~ - H v

so the residual noise is stationary whenever ``F`` is stable, even on an unstable plant.
Otherwise (a generator designed on another model, say) the composite ``[x; w_g]`` is used
and must be stable.

For a continuous plant the noise samples are interpolated between the grid points with the
simulation hold (``"foh"`` or ``"zoh"``, as :func:`geomfdi.simulate` does), and the model is
discretised exactly over one step ``h``::

    s[k+1] = Phi s[k] + Gamma0 e[k] + Gamma1 e[k+1],   r[k] = C_s s[k] + D_s e[k]

(``Gamma1 = 0`` for ``"zoh"``), then rewritten with ``zeta[k] = s[k] - Gamma1 e[k]`` as a
state-space model driven by white noise ``e ~ N(0, I)``::

    zeta[k+1] = Phi zeta[k] + (Phi Gamma1 + Gamma0) e[k]
    r[k]      = C_s zeta[k] + (C_s Gamma1 + D_s) e[k]

Its stationary state covariance solves the Stein equation ``P = Phi P Phi^T + B B^T``
(:func:`scipy.linalg.solve_discrete_lyapunov`), and the autocovariance of the residual is
``gamma(0) = C P C^T + D D^T``, ``gamma(tau) = C Phi^tau P C^T + C Phi^(tau-1) B D^T``.

See the user guide, *Theory: residual evaluation* (``docs/theory/evaluation.md``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg

from geomfdi._validation import as_int, as_matrix, as_positive
from geomfdi.errors import GeomFDIError

__all__ = ["ResidualNoiseModel", "residual_noise_model", "residual_noise_models"]

_DECOUPLED = 1e-8


@dataclass(frozen=True)
class ResidualNoiseModel:
    """Discrete-time model of one residual's noise: ``s+ = Phi s + B e``, ``r = C s + D e``.

    ``e`` is standard white Gaussian noise.  ``reduced`` says whether the plant state was
    removed by the Sylvester change of state (module docstring).
    """

    Phi: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    reduced: bool = True

    @property
    def n_outputs(self) -> int:
        return self.C.shape[0]

    def state_covariance(self) -> np.ndarray:
        """Stationary state covariance ``P = Phi P Phi^T + B B^T``."""
        if self.Phi.shape[0] == 0:
            return np.zeros((0, 0))
        return scipy.linalg.solve_discrete_lyapunov(self.Phi, self.B @ self.B.T)

    def autocovariance(self, lags: int) -> np.ndarray:
        """``gamma(tau) = E[r[k+tau] r[k]^T]`` for ``tau = 0 .. lags-1``, shape (lags, p, p)."""
        lags = as_int(lags, "lags", minimum=1)
        p = self.n_outputs
        out = np.empty((lags, p, p))
        P = self.state_covariance()
        out[0] = self.C @ P @ self.C.T + self.D @ self.D.T
        cross = P @ self.C.T  # Phi^tau P C^T, advanced in place
        drive = self.B @ self.D.T  # Phi^(tau-1) B D^T
        for tau in range(1, lags):  # a loop over lags (small), not over samples
            cross = self.Phi @ cross
            out[tau] = self.C @ cross + self.C @ drive
            drive = self.Phi @ drive
        return out

    def variance(self) -> float:
        """``E ||r[k]||^2`` in steady state (trace of ``gamma(0)``)."""
        return float(np.trace(self.autocovariance(1)[0]))


def _discretize(A: np.ndarray, Bn: np.ndarray, h: float, hold: str) -> tuple[np.ndarray, ...]:
    """``Phi, Gamma0, Gamma1`` of ``s' = A s + Bn e(t)`` with e held (zoh) or linear (foh)."""
    n, k = Bn.shape
    blk = np.zeros((n + 2 * k, n + 2 * k))
    blk[:n, :n] = A * h
    blk[:n, n : n + k] = Bn * h
    blk[n : n + k, n + k :] = np.eye(k)
    ex = scipy.linalg.expm(blk)
    Phi = ex[:n, :n]
    G0 = ex[:n, n : n + k]
    if hold == "zoh":
        return Phi, G0, np.zeros_like(G0)
    G1 = ex[:n, n + k :]  # int_0^h e^{A(h-tau)} tau/h dtau Bn
    return Phi, G0 - G1, G1


def _is_stable(A: np.ndarray, discrete: bool) -> bool:
    if A.shape[0] == 0:
        return True
    ev = np.linalg.eigvals(A)
    return bool(np.all(np.abs(ev) < 1.0)) if discrete else bool(np.all(ev.real < 0.0))


def residual_noise_model(
    plant: Any,
    generator: Any,
    noise: Any,
    *,
    step: float | None = None,
    controller: Any = None,
    hold: str = "foh",
) -> ResidualNoiseModel:
    """The residual's noise model of one generator (module docstring).

    Parameters
    ----------
    plant : Plant or control.StateSpace
    generator : ResidualGenerator
    noise : Noise
        Measurement and/or process noise (the seed is not used).
    step : float, optional
        Sampling step of the simulation grid; required for a continuous plant (a discrete
        plant uses its ``dt``).
    controller : None or array (m, n)
        State feedback ``u = u_ext - K_c x`` on the true state, as in
        :func:`geomfdi.simulate`.  Dynamic output feedback is not covered.
    hold : {"foh", "zoh"}
        Interpolation of the noise samples for a continuous plant.

    Returns
    -------
    ResidualNoiseModel

    Raises
    ------
    GeomFDIError
        Without noise, for a dynamic controller, or when the residual noise is not
        stationary (generator not decoupled from an unstable loop, or ``F`` unstable).
    """
    from geomfdi.model.plant import as_plant

    plant = as_plant(plant)
    if not all(hasattr(generator, k) for k in ("F", "E", "G", "M", "H", "K")):
        raise GeomFDIError(
            f"generator: expected a ResidualGenerator, got {type(generator).__name__}",
            argument="generator",
        )
    if not callable(getattr(noise, "factors", None)):  # a Noise (simulation layer)
        raise GeomFDIError(
            "noise: a Noise with measurement or process noise is needed", argument="noise"
        )
    Lv = noise.factors(plant)[0]
    Bw, Dw, Lw = noise.input_channels(plant)
    if Lv is None and Lw is None:
        raise GeomFDIError(
            "noise: neither measurement nor process noise is given", argument="noise"
        )
    if not isinstance(hold, str) or hold not in ("foh", "zoh"):
        raise GeomFDIError(f"hold: must be 'foh' or 'zoh', got {hold!r}", argument="hold")
    n, m, q = plant.n, plant.m, plant.q
    if controller is None:
        Kc = np.zeros((m, n))
    elif hasattr(controller, "nstates") or hasattr(controller, "num"):
        raise GeomFDIError(
            "controller: the residual noise model covers open loop and state feedback only",
            argument="controller",
        )
    else:
        Kc = as_matrix(controller, "controller", rows=m, cols=n)
    discrete = plant.is_discrete
    if not discrete:
        if step is None:
            raise GeomFDIError("step: required for a continuous plant", argument="step")
        step = as_positive(step, "step")
    g = generator
    A_cl = plant.A - plant.B @ Kc
    C_cl = plant.C - plant.D @ Kc
    Sigma = -g.E @ C_cl - g.G @ Kc
    Nx = -g.H @ C_cl - g.K @ Kc
    nz_v = q if Lv is not None else 0
    Lv_ = Lv if Lv is not None else np.zeros((q, 0))
    BwLw = Bw @ Lw if Lw is not None else np.zeros((n, 0))
    DwLw = Dw @ Lw if Lw is not None else np.zeros((q, 0))
    nw = g.F.shape[0]
    Pi = None
    try:
        Pi = scipy.linalg.solve_sylvester(g.F, -A_cl, -Sigma)
    except (np.linalg.LinAlgError, ValueError):
        Pi = None
    reduced = False
    if Pi is not None and np.all(np.isfinite(Pi)):
        scale = max(np.linalg.norm(Nx), np.linalg.norm(g.M) * np.linalg.norm(Pi), 1e-300)
        reduced = np.linalg.norm(g.M @ Pi + Nx) <= _DECOUPLED * scale
    if reduced:
        Ac = g.F
        Bn = np.hstack([-g.E @ Lv_, -Pi @ BwLw - g.E @ DwLw])
        Cs = g.M
    else:
        Ac = np.block([[A_cl, np.zeros((n, nw))], [Sigma, g.F]])
        Bn = np.block([[np.zeros((n, nz_v)), BwLw], [-g.E @ Lv_, -g.E @ DwLw]])
        Cs = np.hstack([Nx, g.M])
    Ds = np.hstack([-g.H @ Lv_, -g.H @ DwLw])
    if not _is_stable(Ac, discrete):
        what = "F" if reduced else "the composite plant-generator loop"
        raise GeomFDIError(
            f"generator: the residual noise is not stationary ({what} is unstable)",
            argument="generator",
        )
    if discrete:
        return ResidualNoiseModel(Ac, Bn, Cs, Ds, bool(reduced))
    Phi, G0, G1 = _discretize(Ac, Bn, float(step), hold)
    return ResidualNoiseModel(Phi, Phi @ G1 + G0, Cs, Cs @ G1 + Ds, bool(reduced))


def residual_noise_models(
    plant: Any,
    bank: Any,
    noise: Any,
    *,
    step: float | None = None,
    controller: Any = None,
    hold: str = "foh",
) -> list[ResidualNoiseModel | None]:
    """:func:`residual_noise_model` per row of a bank (``None`` for missing generators)."""
    gens = bank.generators if hasattr(bank, "generators") else [bank]
    return [
        None
        if g is None
        else residual_noise_model(plant, g, noise, step=step, controller=controller, hold=hold)
        for g in gens
    ]
