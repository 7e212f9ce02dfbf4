"""Pole lists of a least-order row: the default spectrum from the plant's time scale, the
user's poles checked, conjugate pairs ordered.

See the user guide, *Theory: least-order synthesis* (``docs/theory/least-order.md``,
section 5).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi.errors import DesignError
from geomfdi.geometry.subspace import _norm2

__all__ = ["validate_poles", "plant_scale", "default_pole_sequence"]

_GOLD = 0.6180339887498949


def plant_scale(A: np.ndarray, dt: float, *, eigenvalues: np.ndarray | None = None) -> float:
    """The plant's frequency scale ω for the default spectrum: its own time scale.

    Continuous: the geometric mean of the moduli of A's non-zero eigenvalues
    (``exp(mean(log|λ_i|))`` over ``|λ_i| > 1e-8 ρ``, ρ the spectral radius), and at least
    the modulus of its fastest unstable eigenvalue (``Re λ > 0``: the residual must not be
    slower than the drift it has to cancel).  A slow plant gets slow residual poles, a
    stiff one (fast actuators next to slow rigid-body modes) poles in the middle of its
    time scales rather than at its fastest mode; ``‖A‖₂`` if every eigenvalue is 0 and 1
    if ``A = 0``.  Discrete: ``1`` (the unit circle sets the scale).  Scaling time
    (``A → c A``, c > 0) scales ω by c.  ``eigenvalues``: A's spectrum when it is at hand
    (e.g. the diagonal of a Schur form of A or of a diagonal similarity of it).
    """
    if dt > 0 or A.size == 0:
        return 1.0
    lam = np.linalg.eigvals(A) if eigenvalues is None else np.asarray(eigenvalues)
    mod = np.abs(lam)
    rho = float(np.max(mod))
    if rho > 1e-12 * max(_norm2(A), 1e-300):
        keep = mod > 1e-8 * rho
        mean = float(np.exp(np.mean(np.log(mod[keep]))))
        unstable = mod[keep & (lam.real > 1e-8 * rho)]
        return max(mean, float(np.max(unstable, initial=0.0)))
    nA = _norm2(A)
    return nA if nA > 0 else 1.0


def default_pole_sequence(count: int, omega: float, dt: float) -> np.ndarray:
    """Distinct real stable poles, geometrically spread: the default generator spectrum.

    Continuous: ``λ_i = −ω · 10^{2 ({i φ} − 1/2)}`` ({·}: fractional part, φ the golden
    ratio conjugate), i.e. in ``[−10ω, −ω/10]``; discrete:
    ``z_i = exp(−0.7 ω · 10^{2 ({i φ} − 1/2)})``, i.e. in ``[0.001, 0.93]`` for the
    default ω = 1.  Every prefix is spread over the interval (a low-discrepancy
    sequence).  A wide geometric spread keeps the partial-fraction
    (rational Krylov) basis of the parity space well conditioned: clustered poles make
    its coefficients large and cancelling.
    """
    i = np.arange(1, count + 1)
    frac = np.mod(i * _GOLD, 1.0)
    spread = 10.0 ** (2.0 * (frac - 0.5))
    if dt > 0:
        return np.exp(-0.7 * omega * spread)
    return -omega * spread


def _check_poles(
    poles: np.ndarray, A0: np.ndarray, dt: float, eig: np.ndarray | None = None
) -> np.ndarray:
    """Order conjugate pairs as (λ, λ̄) with Im λ > 0; distinct; not in spec(A0).

    ``eig``: the eigenvalues of ``A0`` when the caller has them (a search checks many
    candidate pole sets against one ``A0``)."""
    out: list[complex] = []
    rest = list(np.asarray(poles, dtype=complex))
    while rest:
        lam = rest.pop(0)
        if abs(lam.imag) <= 1e-14 * max(1.0, abs(lam)):
            out.append(complex(lam.real, 0.0))
            continue
        j = int(np.argmin([abs(x - np.conj(lam)) for x in rest])) if rest else -1
        if j < 0 or abs(rest[j] - np.conj(lam)) > 1e-9 * max(1.0, abs(lam)):
            raise DesignError("poles: complex poles must come in conjugate pairs", argument="poles")
        rest.pop(j)
        lam = complex(lam.real, abs(lam.imag))
        out += [lam, lam.conjugate()]
    arr = np.array(out, dtype=complex)
    scale = max(1.0, float(np.max(np.abs(arr)))) if arr.size else 1.0
    for a in range(arr.size):
        for b in range(a + 1, arr.size):
            if abs(arr[a] - arr[b]) <= 1e-9 * scale:
                raise DesignError(
                    "poles: the least-order realisation needs distinct poles "
                    f"(got {arr[a]:.6g} twice)",
                    argument="poles",
                )
    if A0.size and arr.size:
        eig = np.linalg.eigvals(A0) if eig is None else eig
        near = np.min(np.abs(arr[:, None] - eig[None, :]), axis=1)
        if np.any(near <= 1e-9 * max(scale, _norm2(A0))):
            raise DesignError(
                "poles: a requested pole coincides with an eigenvalue of the decoupled "
                "quotient; choose other poles",
                argument="poles",
            )
    return arr


def validate_poles(poles: Any, dt: float) -> np.ndarray:
    """User poles as a complex array: numbers, finite, stable, closed under conjugation."""
    try:
        arr = np.atleast_1d(np.asarray(poles, dtype=complex))
    except (TypeError, ValueError, OverflowError) as exc:
        raise DesignError(f"poles: must be numbers, got {poles!r:.60}", argument="poles") from exc
    if arr.ndim != 1:
        raise DesignError("poles: must be a flat list of numbers", argument="poles")
    if not np.all(np.isfinite(arr)):
        raise DesignError("poles: must be finite", argument="poles")
    stable = np.abs(arr) < 1 if dt > 0 else arr.real < 0
    if not np.all(stable):
        where = "inside the unit circle" if dt > 0 else "in the open left half-plane"
        raise DesignError(
            f"poles: every pole must lie {where}; got {arr[~stable].tolist()}", argument="poles"
        )
    if not np.allclose(np.sort_complex(arr), np.sort_complex(arr.conj()), rtol=1e-12, atol=0):
        raise DesignError("poles: complex poles must come in conjugate pairs", argument="poles")
    return arr
