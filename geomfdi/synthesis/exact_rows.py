"""Least-order rows re-derived in exact rational arithmetic (for symbolic proofs).

See the user guide, *Theory: least-order synthesis* (``docs/theory/least-order.md``) and
*Theory: verification* (``docs/theory/verification.md``).

The construction of :mod:`geomfdi.synthesis.least_order` is repeated with sympy: S* of
the model with decoupled feedthrough made states, the quotient with a rational basis,
the degree-ν parity space at the (rationalised) poles of the numeric design, and the
functional-observer realisation.  The parity vector is the exact null vector nearest to
the numeric one (its coefficients in the exact null basis, rationalised), so the exact
generator has exactly zero decoupled transfers and the numeric design's pole set.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from geomfdi.model.faults import fault_matrices
from geomfdi.model.plant import Plant
from geomfdi.synthesis.generator import ResidualGenerator

__all__ = ["exact_least_order"]


def exact_least_order(g: ResidualGenerator, plant: Plant, faults: list[Any]) -> dict[str, Any]:
    """Exact ``(F, E, G, M, H, K)`` of a least-order row and the exact plant data."""
    import sympy as sp

    from geomfdi.geometry import exact as ex

    A = ex.to_rational(plant.A, "A")
    B = ex.to_rational(plant.B, "B", rows=plant.n)
    C = ex.to_rational(plant.C, "C")
    D = ex.to_rational(plant.D, "D", rows=plant.q)
    Bd = ex.to_rational(plant.Bd, "Bd", rows=plant.n)
    Dd = ex.to_rational(plant.Dd, "Dd", rows=plant.q)
    sigs = [
        (ex.to_rational(Bf, "Bf"), ex.to_rational(Df, "Df"))
        for Bf, Df in fault_matrices(faults, plant.n, plant.q)
    ]
    n, q = plant.n, plant.q
    Bw = sp.Matrix.hstack(Bd, *[sigs[j][0] for j in g.decoupled])
    Dw = sp.Matrix.hstack(Dd, *[sigs[j][1] for j in g.decoupled])
    direct = [c for c in range(Dw.cols) if not Dw[:, c].is_zero_matrix]
    state = [c for c in range(Dw.cols) if Dw[:, c].is_zero_matrix]
    na = len(direct)
    Aa = sp.zeros(n + na, n + na)
    Aa[:n, :n] = A
    Ca = sp.zeros(q, n + na)
    Ca[:, :n] = C
    La = sp.zeros(n + na, len(state) + na)
    for i, c in enumerate(direct):
        Aa[:n, n + i] = Bw[:, c]
        Ca[:, n + i] = Dw[:, c]
        La[n + i, len(state) + i] = 1
    for i, c in enumerate(state):
        La[:n, i] = Bw[:, c]
    Ba = B.col_join(sp.zeros(na, B.cols))
    S = ex.min_unobservability_subspace(Aa, Ca, La)
    P = S.complement_rows()
    Q = ex.right_inverse(P) if P.rows else sp.zeros(n + na, 0)
    D0 = ex.friend(Aa, Ca, S, P) if P.rows else sp.zeros(n + na, q)
    if S.dim:
        vecs = (Ca * S.basis).T.nullspace()
        H = sp.Matrix.hstack(*vecs).T if vecs else sp.zeros(0, q)
    else:
        H = sp.eye(q)
    M = H * Ca * Q
    A0 = P * (Aa + D0 * Ca) * Q
    k, rho = A0.rows, H.rows
    cert = g.info["least_order"]
    poles = [_small_rational(p) for p in np.asarray(cert["poles"], dtype=complex)]
    kinds = cert["blocks"]
    blocks, res = [M], {}
    for kind, i in zip(kinds[1:], _indices(kinds[1:]), strict=True):
        if i not in res:
            R = M * (poles[i] * sp.eye(k) - A0).inv() if k else sp.zeros(rho, 0)
            res[i] = R.applyfunc(sp.expand_complex)
        R = res[i]
        blocks.append(R.applyfunc(sp.re) if kind in ("r", "re") else R.applyfunc(sp.im))
    Rst = sp.Matrix.vstack(*blocks)
    vecs = Rst.T.nullspace()
    N = sp.Matrix.hstack(*vecs)
    # the exact null vector nearest to the numeric one, matched through x_i H (in y-space)
    Nf = np.array(N.tolist(), dtype=float).reshape(N.rows, N.cols)
    Hf = np.array(H.tolist(), dtype=float).reshape(rho, q)
    lhs = np.vstack([Hf.T @ Nf[b * rho : (b + 1) * rho] for b in range(len(blocks))])
    rhs = np.concatenate([np.asarray(v, dtype=float) for v in cert["row_in_y"]])
    beta = np.linalg.lstsq(lhs, rhs, rcond=None)[0]
    beta = beta / np.max(np.abs(beta))
    bq = sp.Matrix([sp.Rational(float(b)).limit_denominator(10**4) for b in beta])
    x = N * bq
    parts = [x[b * rho : (b + 1) * rho, 0].T for b in range(len(blocks))]
    nu = len(poles)
    F, Gs, T, c = sp.zeros(nu, nu), sp.zeros(nu, rho), sp.zeros(nu, k), sp.zeros(1, nu)
    h = parts[0]
    b = 1
    for kind, i in zip(kinds[1:], _indices(kinds[1:]), strict=True):
        if kind == "im":
            continue
        lam = poles[i]
        if kind == "r":
            F[i, i] = sp.re(lam)
            T[i, :] = parts[b] * res[i].applyfunc(sp.re)
            Gs[i, :] = -parts[b]
            c[0, i] = 1
            b += 1
        else:
            xp = (parts[b] - sp.I * parts[b + 1]) / 2
            t = (xp * res[i]).applyfunc(sp.expand_complex)
            a_, w_ = sp.re(lam), sp.im(lam)
            F[i, i], F[i, i + 1], F[i + 1, i], F[i + 1, i + 1] = a_, -w_, w_, a_
            T[i, :], T[i + 1, :] = t.applyfunc(sp.re), t.applyfunc(sp.im)
            Gs[i, :], Gs[i + 1, :] = (-xp).applyfunc(sp.re), (-xp).applyfunc(sp.im)
            c[0, i] = 2
            b += 2
    Bqy = -P * D0
    Bqu = P * Ba + P * D0 * D
    E = -(Gs * H + T * Bqy)
    G = T * Bqu - Gs * H * D
    out = {
        "F": F,
        "E": E,
        "G": G,
        "M": c,
        "H": -(h * H),
        "K": -(h * H * D),
        "S_dim": S.dim,
        "A": A,
        "B": B,
        "C": C,
        "D": D,
        "Bd": Bd,
        "Dd": Dd,
        "sigs": sigs,
    }
    return {
        key: (v.applyfunc(sp.expand) if isinstance(v, sp.MatrixBase) else v)
        for key, v in out.items()
    }


def _small_rational(p: complex) -> Any:
    """A pole as a Gaussian rational with denominators ≤ 1000 (the decoupling is exact for
    any pole values, and small rationals keep the symbolic transfers cheap)."""
    import sympy as sp

    re_ = sp.Rational(float(p.real)).limit_denominator(10**3)
    im_ = sp.Rational(float(p.imag)).limit_denominator(10**3)
    return re_ + sp.I * im_


def _indices(kinds: list[str]) -> list[int]:
    """Pole index of each block kind ("r": one pole; "re", "im": one pair)."""
    out, i = [], 0
    for kind in kinds:
        out.append(i)
        if kind == "r":
            i += 1
        elif kind == "im":
            i += 2
    return out
