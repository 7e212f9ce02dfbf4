"""One least-order residual row on a plant: balance, quotient, parity space, realise, check.

See the user guide, *Theory: least-order synthesis* (``docs/theory/least-order.md``).

Steps for a row that must see ``target`` and ignore ``decouple`` (and every disturbance):

1. **Balance** the state (:func:`geomfdi.geometry.balancing.state_scaling`): the design
   runs on ``(D⁻¹ A D, D⁻¹ [B Bd Bf], C D)``; the delivered generator reads y and u
   only and needs no change (``info["P"]`` is mapped back).
2. **Quotient** by S* of the model with decoupled feedthrough made states
   (:func:`geomfdi.synthesis.least_order.search.quotient_model`).
3. **Least-order row** (:func:`geomfdi.synthesis.least_order.search.least_order_row`), with
   the certificate in ``info["least_order"]``.
4. **Realisation**, tried in turn until one passes the checks: the partial-fraction
   functional observer (default poles scaled by ``RETRY_SCALES``) and the quotient
   observer with a Riccati stability-degree injection
   (:mod:`geomfdi.synthesis.least_order.quotient_observer`, degrees relaxed by
   :data:`geomfdi.synthesis.least_order.injection.RELAX`); a row of least order k > ``INJECT_FIRST``
   (the whole quotient) tries the quotient observer first.  ``info["realisation"]`` names
   the one delivered; a delivered order above the least order is stated in
   ``info["least_order"]["statement"]``.
5. **Checks** on the physical (unbalanced) plant: relative gain from every fault
   (:mod:`geomfdi.generators.gains`); a decoupled signal above the leakage angle
   ``ANGLE_TOL`` or a construction identity above ``IDENTITY_TOL`` makes the attempt a
   numerical failure.
6. **Strong detectability**: a least-order row that sees a target with a DC gain below
   ``FD_GAIN_TOL`` of its largest fault gain (:func:`weak_targets`) is redesigned at up
   to ``MAX_RAISE`` higher degrees; the first row that is not weak is delivered, with
   ``raised_from`` and the reason in its certificate.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

import numpy as np

from geomfdi.errors import NotIsolableError
from geomfdi.generators.gains import LEAK_TOL, Composite, PlantFactor, _gains, frequency_gains
from geomfdi.generators.generator import ResidualGenerator
from geomfdi.geometry.balancing import state_scaling
from geomfdi.geometry.subspace import _norm2
from geomfdi.model.plant import Plant
from geomfdi.synthesis.construction import IDENTITY_TOL, _NumericalDesignError
from geomfdi.synthesis.least_order.injection import RELAX
from geomfdi.synthesis.least_order.orthonormal_row import orthonormal_row
from geomfdi.synthesis.least_order.quotient import adaptive_quotient_model
from geomfdi.synthesis.least_order.quotient_observer import quotient_observer_row
from geomfdi.synthesis.least_order.search import (
    NU_PF_MAX,
    LeastOrderRow,
    Quotient,
    _Infeasible,
    least_order_row,
    parity_basis_row,
    realise_on_plant,
)
from geomfdi.synthesis.strength import reference_sizes, strength_frequencies
from geomfdi.tolerance import get_rtol

__all__ = ["build_least_order", "ANGLE_TOL", "check_angles", "weak_targets", "FD_GAIN_TOL"]

ANGLE_TOL = 1e-9
"""Largest leakage angle (the measure of :func:`geomfdi.verify`) a delivered row may have."""

FD_GAIN_TOL = 0.01
"""Strong detectability: least DC gain from a target, relative to the residual's largest
gain from any fault over frequency (Varga's ``FDGainTol``)."""

MAX_RAISE = 3
"""Degrees above the least order tried for a row whose least-order targets are weak."""


def weak_targets(
    g: ResidualGenerator,
    plant: Plant,
    sigs: list,
    factor: PlantFactor | None,
    omega: float,
    target: tuple[int, ...] | list[int],
    comp: Composite | None = None,
) -> list[int]:
    """Targets whose DC gain is below ``FD_GAIN_TOL`` × the largest gain over frequency.

    Gains are those of faults at their reference sizes σ_j
    (:func:`geomfdi.synthesis.strength.reference_sizes`: unit-free); the largest is taken
    over every fault's gain on 31 frequencies spread over ``ω·[1e-3, 1e3]`` (continuous)
    or ``π·[1e-3, 1]`` (discrete) and the DC gains.  ``g.info["dc_gain"]`` must hold the
    DC gains; ``comp``: the factored interconnection of g and the plant if at hand.
    Records ``g.info["target_strength"]``: per target, its DC and mid-band (at ω) gain
    relative to that largest gain, and ``g.info["reference_sizes"]``.
    """
    if comp is None:
        comp = factor.composite(g) if factor is not None and factor.plant is plant else None
    comp = comp if comp is not None else Composite(g, plant, factor)
    faults = g.info.get("faults") or []
    sizes = np.ones(len(sigs))
    if len(faults) == len(sigs):
        cache = getattr(factor, "_reference_sizes", None) if factor is not None else None
        key = (tuple(id(f) for f in faults), float(omega))
        if cache is not None and cache[0] == key:
            sizes = cache[1]
        else:
            sizes = reference_sizes(plant, faults, sigs, omega)
            if factor is not None:
                factor._reference_sizes = (key, sizes)
    dc = np.asarray(g.info["dc_gain"], dtype=float) * sizes
    ws = strength_frequencies(omega, plant.dt)
    peak = frequency_gains(comp, sigs, np.append(ws, np.pi / 2 if plant.dt > 0 else omega))
    mid = peak[-1] * sizes
    peak = peak * sizes[None, :]
    top = np.max(np.where(np.isfinite(peak), peak, 0.0), initial=0.0)
    top = max(top, float(np.max(np.where(np.isfinite(dc), dc, 0.0), initial=0.0)))
    ref = top if top > 0 else 1.0
    g.info["reference_sizes"] = sizes.tolist()
    g.info["target_strength"] = {
        int(j): {"dc": float(dc[j] / ref), "mid_band": float(mid[j] / ref)} for j in target
    }
    return [j for j in target if np.isfinite(dc[j]) and dc[j] < FD_GAIN_TOL * top]


def check_angles(
    g: ResidualGenerator, plant: Plant, sigs: list, factor: PlantFactor | None, row: str
) -> None:
    """Raise the numerical-failure error when a decoupled channel of g leaks (angle measure)."""
    comp = Composite(g, plant, factor)
    ang = comp.angle_gains([sigs[j] + (False,) for j in g.decoupled])
    chans = [(plant.B, plant.D, True)] if plant.m else []
    chans += [(plant.Bd, plant.Dd, False)] if plant.nd else []
    inp = float(np.max(comp.angle_gains(chans))) if chans else 0.0
    worst = max(float(np.max(ang, initial=0.0)), inp)
    g.info["leak_angle"] = worst
    if worst > ANGLE_TOL:
        raise _NumericalDesignError(
            f"{row}: the generator leaks on the physical model (angle {worst:.2g} > "
            f"{ANGLE_TOL:g}); the design is ill-conditioned",
            argument="plant",
        )


def _stack(cols: list[np.ndarray], rows: int) -> np.ndarray:
    cols = [c for c in cols if c.size]
    return np.hstack(cols) if cols else np.zeros((rows, 0))


def _unread_sensors(
    sigs: list[tuple[np.ndarray, np.ndarray]], decouple: tuple[int, ...]
) -> list[int]:
    """Outputs the row must not read: those carrying a decoupled pure sensor fault.

    A fault with ``Bf = 0`` and ``Df = e_i`` (a fault on sensor ``i`` alone) reaches the
    generator only through the ``i``-th columns of E and H:
    ``T(s) = −M (sI − F)⁻¹ E e_i − H e_i``.  For a minimal (observable) row this is
    identically zero iff ``E e_i = 0`` and ``H e_i = 0``: decoupling it means not reading
    ``y_i`` at all.
    """
    out: list[int] = []
    for j in decouple:
        Bf, Df = sigs[j]
        if Bf.size and np.any(Bf):
            continue
        for col in Df.T:
            nz = np.flatnonzero(col)
            if nz.size == 1:
                out.append(int(nz[0]))
    return sorted(set(out))


def _quotient(
    plant: Plant,
    sigs: list[tuple[np.ndarray, np.ndarray]],
    target: tuple[int, ...],
    decouple: tuple[int, ...],
    row: str,
    balance: bool,
    factor: PlantFactor | None = None,
) -> tuple[Quotient, np.ndarray]:
    """Steps 1–2: balance the state and form the decoupled quotient (module Notes)."""
    n = plant.n
    A, B, C, Du = plant.A, plant.B, plant.C, plant.D
    Ball = _stack([B, plant.Bd, *[Bf for Bf, _ in sigs]], n)
    d = state_scaling(A, Ball, C) if balance else np.ones(n)
    Ab = A * d[None, :] / d[:, None]
    Bb, Cb = B / d[:, None], C * d[None, :]
    Bw = np.hstack([plant.Bd / d[:, None], *[sigs[j][0] / d[:, None] for j in decouple]])
    Dw = np.hstack([plant.Dd, *[sigs[j][1] for j in decouple]])
    tg = [(sigs[j][0] / d[:, None], sigs[j][1]) for j in target]
    Qm = adaptive_quotient_model(Ab, Bb, Cb, Du, Bw, Dw, tg)
    if factor is not None and factor.plant is plant and np.array_equal(factor.d, d):
        Qm.plant_schur = (factor.TA, factor.UA)  # the same balanced A
    bad = {k: v for k, v in Qm.identities.items() if v > IDENTITY_TOL}
    if bad:
        raise _NumericalDesignError(
            f"{row}: quotient identities fail ({bad}); the rank decisions behind S* are "
            "ill-conditioned",
            argument="plant",
        )
    return Qm, d


def fault_numbers(text: str, target: tuple[int, ...]) -> str:
    """``text`` with the search's target positions ("targets [1]") written as the fault
    numbers of the design ("faults [5]"): the user numbers faults, not targets."""

    def repl(mt: re.Match[str]) -> str:
        pos = [int(v) for v in mt.group(1).replace(" ", "").split(",") if v]
        return f"faults {[target[i] for i in pos if 0 <= i < len(target)]}"

    return re.sub(r"\btargets \[([\d, ]*)\]", repl, text)


def _search(
    Qm: Quotient,
    plant: Plant,
    target: tuple[int, ...],
    decouple: tuple[int, ...],
    *,
    poles: Any,
    omega: float,
    row: str,
    prefix: bool,
) -> LeastOrderRow:
    """Step 3: the least-order row, or the not-isolable error with its certificate."""
    try:
        return least_order_row(Qm, poles=poles, omega=omega, dt=plant.dt, prefix=prefix)
    except _Infeasible as exc:
        unseen = exc.data.get("unseen", list(range(len(target))))
        names = [target[i] for i in unseen] if unseen else list(target)
        reason = (
            f"faults {names} are not isolable from faults {list(decouple)}"
            + (" and the disturbances" if plant.nd else "")
            + f": {fault_numbers(exc.reason, target)}"
        )
        raise NotIsolableError(f"{row}: no residual exists: {reason}", reason=reason) from None


def _finish(
    plant: Plant,
    faults: list[Any],
    sigs: list[tuple[np.ndarray, np.ndarray]],
    target: tuple[int, ...],
    decouple: tuple[int, ...],
    Qm: Quotient,
    d: np.ndarray,
    lo: LeastOrderRow,
    *,
    omega: float,
    row: str,
    factor: PlantFactor | None,
) -> tuple[ResidualGenerator, Composite]:
    """Step 4: the realised row on the plant, normalised and checked (module Notes).

    Returns the generator and its factored interconnection with the plant.

    Raises
    ------
    NotIsolableError
        A target's transfer is identically zero on the physical model.
    DesignError
        (the private numerical-failure subclass) identities or decouplings fail.
    """
    n, C, Du = plant.n, plant.C, plant.D
    mats = realise_on_plant(Qm, lo, Du)
    bad = {k: v for k, v in mats["identities"].items() if v > IDENTITY_TOL}
    if bad:
        raise _NumericalDesignError(
            f"{row}: the least-order realisation is ill-conditioned ({bad})", argument="plant"
        )
    # unit residual scale (a pure normalisation): ‖H‖ = 1 like an orthonormal
    # measurement map, or ‖M‖ ‖[E G]‖ / max(‖F‖, ω) = 1 when the row has no static part
    Fm, Em, Gm, Mm, Hm, Km = (mats[x] for x in "FEGMHK")
    size = _norm2(Hm)
    if size <= 1e-12 * max(_norm2(Mm) * _norm2(np.hstack([Em, Gm])), 1e-300):
        size = _norm2(Mm) * _norm2(np.hstack([Em, Gm])) / max(_norm2(Fm), omega, 1e-300)
    if size > 0:
        Em, Gm, Hm, Km = Em / size, Gm / size, Hm / size, Km / size
    # a decoupled sensor's columns of E and H are zero in exact arithmetic (see
    # _unread_sensors); what the SVD bases leave there is rounding, set to its exact value.
    # A column above rounding level is left alone (the leak check below rejects the row).
    rt = 1e3 * get_rtol(n + C.shape[0])
    ref = max(_norm2(Em), _norm2(Hm), 1e-300)
    for i in _unread_sensors(sigs, decouple):
        if max(np.linalg.norm(Em[:, i]), np.linalg.norm(Hm[:, i])) <= rt * ref:
            Em[:, i] = 0.0
            Hm[:, i] = 0.0
    cert = dict(lo.certificate)
    if "unseen_below" in cert:
        cert["unseen_below"] = {
            deg: [target[i] for i in pos] for deg, pos in cert["unseen_below"].items()
        }
    if isinstance(cert.get("statement"), str):
        cert["statement"] = fault_numbers(cert["statement"], target)
    cert["poles"] = lo.poles
    cert["delivered_order"] = lo.order
    least = cert.get("order")
    if least is None or least != lo.order:
        low, high = cert.get("bounds", (least, least))
        how = cert.get("realisation", "partial fractions")
        cert["statement"] = (
            f"delivered order {lo.order} ({how}) is above the least order "
            + (f"{least}" if least is not None else f"(between {low} and {high})")
            + f": {cert.get('reason', 'the least-order realisation failed numerically')}"
        )
    info = {
        "synthesis": "least_order",
        "realisation": cert.get("realisation", "partial fractions"),
        "least_order": cert,
        "S_dim": Qm.S.dim,
        "S_history": Qm.S.history,
        "W_dim": Qm.S.W.dim,
        "W_history": Qm.S.W.history,
        "min_gap": Qm.S.min_gap,
        "S_rtol": Qm.rtol,
        "quotient_order": Qm.k,
        "full_order": Qm.k,
        "design_n": Qm.n_aug,
        "augmented_states": Qm.n_aug - n,
        "P": Qm.P / d[None, :],
        "state_scaling": d,
        "identities": {**Qm.identities, **mats["identities"]},
        "poles": lo.poles,
        "faults": list(faults),
        "filter_pole": None,
        "filtered_channels": (),
    }
    g = ResidualGenerator(
        Fm,
        Em,
        Gm,
        Mm,
        Hm,
        Km,
        dt=plant.dt,
        target=target,
        decoupled=decouple,
        method="exact",
        info=info,
    )
    comp = (
        factor.composite(g)
        if factor is not None and factor.plant is plant
        else Composite(g, plant, factor)
    )
    gains, dc = _gains(comp, sigs, "points")
    for j in target:
        if not gains[j] > LEAK_TOL:
            gains[j] = _gains(comp, [sigs[j]], "krylov")[0][0]
    g.info["fault_gain"] = gains
    g.info["markov_gain"] = _first_markov(g, plant, *sigs[target[0]])
    g.info["dc_gain"] = dc
    both = comp.angle_gains([sigs[j] + (False,) for j in (*decouple, *target)])
    ang, tang = both[: len(decouple)], both[len(decouple) :]
    g.info["target_angle"] = dict(zip(target, tang.tolist(), strict=True))
    leaks = [j for j, a in zip(decouple, ang, strict=True) if a > ANGLE_TOL]
    chans = [(plant.B, plant.D, True)] if plant.m else []
    chans += [(plant.Bd, plant.Dd, False)] if plant.nd else []
    inp = float(np.max(comp.angle_gains(chans))) if chans else 0.0
    g.info["leak_angle"] = max(float(np.max(ang, initial=0.0)), inp)
    if leaks or inp > ANGLE_TOL:
        raise _NumericalDesignError(
            f"{row}: the least-order row leaks on the physical model (faults {leaks}, input "
            f"gain {inp:.2g}); the design is ill-conditioned",
            argument="plant",
        )
    blind = [j for j, a in zip(target, tang, strict=True) if not a > ANGLE_TOL]
    if blind and all(gains[j] > LEAK_TOL for j in target):
        # seen off the frequency axis only: on the frequency response the target is at
        # the level a decoupled channel counts as zero (a rounding-level detection)
        raise _NumericalDesignError(
            f"{row}: targets {blind} reach the residual only at rounding level on the "
            f"frequency response (angle <= {ANGLE_TOL:g})",
            argument="plant",
        )
    unseen = [j for j in target if not gains[j] > LEAK_TOL]
    if unseen:
        reason = (
            f"faults {unseen}: the transfer to the residual is identically zero on the "
            "physical model"
        )
        raise NotIsolableError(f"{row}: no residual exists: {reason}", reason=reason)
    return g, comp


def _first_markov(g: ResidualGenerator, plant: Plant, Bf: np.ndarray, Df: np.ndarray) -> float:
    """Norm of the first non-zero Markov parameter of the fault's transfer to r.

    ``h_0 = −H Df``, ``h_k = C_c A_c^{k−1} B_c`` on the composite
    ``A_c = [[A, 0], [−E C, F]]``, ``B_c = [Bf; −E Df]``, ``C_c = [−H C, M]``.
    """
    h0 = -g.H @ Df
    ref = max(_norm2(g.H) * _norm2(Df), 1e-300)
    if _norm2(h0) > 1e-9 * ref:
        return _norm2(h0)
    n, k = plant.n, g.order
    Ac = np.block([[plant.A, np.zeros((n, k))], [-g.E @ plant.C, g.F]])
    v = np.vstack([Bf, -g.E @ Df])
    Cc = np.hstack([-g.H @ plant.C, g.M])
    ref = max(_norm2(Cc) * _norm2(v), 1e-300)
    for _ in range(n + k):
        h = Cc @ v
        if _norm2(h) > 1e-9 * ref:
            return _norm2(h)
        v = Ac @ v
        ref *= max(_norm2(Ac), 1.0)
    return 0.0


RETRY_SCALES = (1.0, 0.25, 4.0)
"""Default-pole scales tried in turn when a partial-fraction realisation fails its checks."""

INJECT_FIRST = 4
"""A row whose least order is the quotient's dimension k (always when it reads one output
combination) is realised first as the quotient observer when ``k > INJECT_FIRST``: the
partial-fraction basis of ``k`` poles is then the ill-conditioned choice."""


def _attempts(
    lo: LeastOrderRow, k: int, rho: int, poles: Any, prefix: bool
) -> list[tuple[str, float]]:
    """Realisations tried in turn: ``("pf", pole scale)``, ``("onbp", 1)`` (the same row
    in the orthonormal parity basis), ``("onb", relaxation)`` (a single-output row of
    the whole quotient in the orthonormal basis) or ``("inj", relaxation)``."""
    pf = [("pf", sc) for sc in RETRY_SCALES] + [("onbp", 1.0)]
    inj = [("inj", r) for r in RELAX]
    if rho == 1:
        inj = [("onb", r) for r in RELAX] + inj
    if poles is not None:
        return [("pf", 1.0)]
    if not lo.realised:
        return inj
    if lo.order == k and k > INJECT_FIRST and not prefix:
        return inj + pf
    return pf + inj


def build_least_order(
    plant: Plant,
    faults: list[Any],
    sigs: list[tuple[np.ndarray, np.ndarray]],
    target: tuple[int, ...],
    decouple: tuple[int, ...],
    *,
    poles: Any,
    omega: float,
    row: str,
    factor: PlantFactor | None = None,
    balance: bool = True,
    prefix: bool = False,
    strengthen: bool = True,
) -> ResidualGenerator:
    """Design, realise and check one least-order scalar row (module Notes).

    ``strengthen=False`` delivers the least-order row even where it is weak (step 6 off).

    The realisations are tried in the order of :func:`_attempts`: the partial-fraction
    functional observer with the default poles scaled by ``RETRY_SCALES`` (the parity
    space and the order do not depend on the poles; the conditioning of the basis
    does), and the quotient observer with the Riccati injection at the stability degrees
    relaxed by :data:`geomfdi.synthesis.least_order.injection.RELAX`.  The first that passes the
    checks on the physical plant is delivered; ``info["realisation"]`` names it and
    ``info["least_order"]`` states the least order and the delivered one.

    Raises
    ------
    NotIsolableError
        No residual seeing every target while decoupling the rest exists.
    DesignError
        Bad poles; or (the private numerical-failure subclass) every attempt failed.
    """
    Qm, d = _quotient(plant, sigs, target, decouple, row, balance, factor)
    kw = {"poles": poles, "row": row, "prefix": prefix}
    lo = _search(Qm, plant, target, decouple, omega=omega, **kw)

    def finish(cur: LeastOrderRow) -> tuple[ResidualGenerator, Composite]:
        return _finish(
            plant, faults, sigs, target, decouple, Qm, d, cur, omega=omega, row=row, factor=factor
        )

    first: _NumericalDesignError | None = None
    for kind, val in _attempts(lo, Qm.k, Qm.rho, poles, prefix):
        try:
            if kind == "pf":
                cur = (
                    lo
                    if val == 1.0
                    else _search(Qm, plant, target, decouple, omega=omega * val, **kw)
                )
            elif kind == "onbp":
                cur = parity_basis_row(Qm, lo, omega=omega, dt=plant.dt)
            else:
                cert = dict(lo.certificate)
                if first is not None:
                    cert["reason"] = f"the partial-fraction realisation failed ({first})"
                if kind == "onb":
                    cur = orthonormal_row(
                        Qm, plant.D, omega=omega, dt=plant.dt, relax=val, certificate=cert
                    )
                else:
                    cur = quotient_observer_row(
                        Qm, omega=omega, dt=plant.dt, relax=val, certificate=cert
                    )
            g, comp = finish(cur)
        except _NumericalDesignError as exc:
            first = first or exc
            continue
        except np.linalg.LinAlgError as exc:
            first = first or _NumericalDesignError(f"{row}: {exc}", argument="plant")
            continue
        if kind in ("pf", "onbp"):
            g.info["pole_scale"] = val
            if poles is None and not prefix and strengthen:
                g = _strengthen(g, comp, cur, Qm, plant, sigs, target, omega, factor, finish)
        else:
            g.info["relax"] = val
        return g
    assert first is not None
    raise first


def _strengthen(
    g: ResidualGenerator,
    comp: Composite,
    lo: LeastOrderRow,
    Qm: Quotient,
    plant: Plant,
    sigs: list[tuple[np.ndarray, np.ndarray]],
    target: tuple[int, ...],
    omega: float,
    factor: PlantFactor | None,
    finish: Callable[[LeastOrderRow], tuple[ResidualGenerator, Composite]],
) -> ResidualGenerator:
    """Raise the order of a weak least-order row until every target is strongly seen.

    A row whose DC gain from some target is below ``FD_GAIN_TOL`` of its largest fault
    gain (:func:`weak_targets`) is redesigned at degrees ``ν + 1 … ν + MAX_RAISE`` (not
    above the largest observability index), with the direction chosen by the DC gains;
    the first row that is not weak is delivered, its certificate states the least order
    and why the order was raised.  Otherwise the least-order row is kept (reported weak).
    ``finish`` realises and checks a row on the plant (:func:`_finish` of this row).
    """
    weak = weak_targets(g, plant, sigs, factor, omega, target, comp)
    g.info["weak_targets"] = weak
    if not weak:
        return g
    nu = lo.order
    top = len(lo.certificate.get("staircase", {}).get("blocks", []))
    for nu2 in range(nu + 1, min(top, nu + MAX_RAISE, NU_PF_MAX) + 1):
        try:
            cur = least_order_row(Qm, omega=omega, dt=plant.dt, min_order=nu2, dc=True)
            if not cur.realised:
                break
            cert = cur.certificate
            cert.update(
                order=nu,
                unseen_below=lo.certificate["unseen_below"],
                reason=f"the least-order row sees targets {weak} only weakly (DC gain "
                f"below {FD_GAIN_TOL:g} of its largest fault gain)",
                raised_from=nu,
                weak_at_least=list(weak),
            )
            g2, comp2 = finish(cur)
        except (_NumericalDesignError, np.linalg.LinAlgError, NotIsolableError):
            continue
        weak2 = weak_targets(g2, plant, sigs, factor, omega, target, comp2)
        if not weak2:
            g2.info["weak_targets"] = []
            g2.info["pole_scale"] = 1.0
            return g2
    return g
