"""Per-sample decisions of the parity-space tests (:func:`diagnose`).

GLT, corrected and uncorrected OPT, sequential re-detection on the reduced
configuration, Qin & Niu's two-fault search and the k-fault GLR. See the user guide,
*Theory: parity space* (``docs/theory/parity-space.md``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from geomfdi._validation import as_int, as_probability
from geomfdi.errors import DesignError, GeomFDIError, RankDeficientError
from geomfdi.parity._construction import reduced_data
from geomfdi.parity._input import _guarded, _raise_nonfinite_block, _samples
from geomfdi.parity._records import ParityData, as_data
from geomfdi.parity.glt import _a, _check_fd, _fd, _fi_from_a
from geomfdi.parity.multiple import _glr2_from_a, _pairs_from_a, _subset_info
from geomfdi.parity.opt import _opt_data
from geomfdi.parity.results import ParityDiagnosis
from geomfdi.parity.thresholds import chi2_threshold, normal_threshold

if TYPE_CHECKING:
    pass

__all__ = ["METHODS", "diagnose"]

METHODS = ("glt", "opt", "opt-uncorrected", "search", "glr")
"""Decision rules accepted by :func:`diagnose`."""

_MAX_LABEL_BITS = 20  # argmax-by-bit-packing is used for up to 2**20 fault hypotheses


def _kernel(
    pf, Z: np.ndarray, Mdet: np.ndarray, Miso: np.ndarray, mode: str, threshold: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Chunked detection + isolation: statistic, detected, isolated (lut applied)."""
    N = Z.shape[0]
    r, k = Mdet.shape[1], Miso.shape[1]
    MT = np.ascontiguousarray(np.concatenate([Mdet, Miso], axis=1).T)
    stat = np.empty(N)
    det = np.empty(N, dtype=bool)
    iso = np.empty(N, dtype=np.intp)
    bits = max(1, (k - 1).bit_length())
    use_bits = bits <= _MAX_LABEL_BITS
    low = np.int64((1 << bits) - 1)
    labels = np.arange(k, dtype=np.int64)[:, None]
    lut_ext = np.append(pf.lut, -1).astype(np.intp)
    # finiteness: checked on the statistic when every sensor feeds it (an inf/nan
    # reading makes it non-finite), otherwise on the raw chunk
    covered = np.any(Mdet != 0, axis=1) if mode == "chi2" else np.zeros(pf.m, bool)
    raw_check = not covered.all()
    c = pf.chunk_size
    for start in range(0, N, c):
        stop = min(start + c, N)
        zc = Z[start:stop]
        if raw_check and not np.isfinite(zc).all():
            _raise_nonfinite_block(zc, start, "Z")
        Y = MT @ zc.T
        Yi = Y[r:]
        st = stat[start:stop]
        dc = det[start:stop]
        if mode == "chi2":
            Yd = Y[:r]
            np.multiply(Yd, Yd, out=Yd)
            if r:
                np.sum(Yd, axis=0, out=st)
            else:
                st[:] = 0.0
            np.greater_equal(st, threshold, out=dc)
        np.abs(Yi, out=Yi)
        if mode == "max":
            np.max(Yi, axis=0, out=st)
            np.greater(st, threshold, out=dc)
        if not np.isfinite(st).all():
            _raise_nonfinite_block(zc, start, "Z")
        if use_bits:
            # |y| >= 0 as float64 is ordered like its int64 bit pattern: pack the
            # hypothesis index into the lowest mantissa bits and take one max.  Two
            # statistics equal to ~1e-15 relative precision tie-break to the larger
            # index; otherwise this is argmax |y_i|.
            Yv = Yi.view(np.int64)
            Yv &= ~low
            Yv |= labels
            idx = np.max(Yv, axis=0)
            idx &= low
        else:
            idx = np.argmax(Yi, axis=0)
        np.take(lut_ext, np.where(dc, idx, k), out=iso[start:stop])
    return stat, det, iso


def _single(pf: ParityData, Z: np.ndarray, pfa: float, method: str) -> ParityDiagnosis:
    """One detection + isolation stage (glt, opt, opt-uncorrected)."""
    if method == "glt":
        thr = chi2_threshold(pfa, pf.s)
        stat, det, iso = _kernel(pf, Z, pf.T.T / pf.sigma, pf.Bn, "chi2", thr)
    elif method == "opt":
        od = _opt_data(pf)
        if od["U"].shape[1] == 0:
            raise DesignError("method: no fault reaches the parity space", argument="D")
        thr = chi2_threshold(pfa, od["U"].shape[1])
        stat, det, iso = _kernel(pf, Z, od["U"] / pf.sigma, od["dmat"], "chi2", thr)
    else:  # opt-uncorrected
        thr = normal_threshold(pfa)
        stat, det, iso = _kernel(pf, Z, np.zeros((pf.m, 0)), _opt_data(pf)["dmat"], "max", thr)
    return ParityDiagnosis(det, iso[:, None], stat, thr, method, pfa)


@_guarded
def diagnose(
    pf,
    Z: Any,
    pfa: float = 0.01,
    *,
    method: str = "glt",
    max_faults: int | None = None,
) -> ParityDiagnosis:
    """Detect and isolate faults in every sample.

    Parameters
    ----------
    Z : array_like, shape (N, m) or (m,)
        Measurements.
    pfa : float
        False-alarm rate of every detection test, in (0, 1).
    method : {"glt", "opt", "opt-uncorrected", "search", "glr"}
        * ``"glt"`` (default): ``FD >= chi2_{1-pfa}(m - n)``, isolate
          ``argmax FI(i)`` (Zhang, Chen & Liu (2005) eq. 3, 5).
        * ``"opt"``: corrected OPT, ``FD_OPT >= chi2_{1-pfa}`` and ``argmax |d_i|``
          (identical to ``"glt"`` when ``D = F = I``: Theorems 2 and 4).
        * ``"opt-uncorrected"``: the OPT rule of Zhang, Chen & Liu (2005) §1.2:
          ``max |d_i| > u_{1-pfa/2}``; its false-alarm rate exceeds ``pfa``
          (Theorem 1).  ``statistic`` is ``max |d_i|``.
        * ``"search"``: the two-fault search of Qin & Niu (1999) (Figure 1, reconstructed,
          see Notes).
        * ``"glr"``: k-fault GLR with sequential consistency tests (see Notes).
    max_faults : int, optional
        Width of :attr:`ParityDiagnosis.faults`.  For ``glt``/``opt``/
        ``opt-uncorrected`` (default 1) a value > 1 switches on *sequential*
        diagnosis: after isolating sensor ``i`` the samples are re-diagnosed on
        :meth:`reduced` ``(i)`` with the same rule, as long as redundancy remains.
        ``search`` handles at most 2 (default 2); ``glr`` at most ``m - n - 1``
        (default ``min(2, m - n - 1)``, at least 1).

    Returns
    -------
    ParityDiagnosis
        ``.detected`` (N,) bool, ``.isolated`` (N,) sensor or -1, ``.faults``,
        ``.unresolved``, ``.statistic``, ``.threshold``.

    Notes
    -----
    A detected sample whose isolated hypothesis is not distinguishable from another
    (parallel signatures, e.g. any sensor of the tetrahedron) is reported with
    ``isolated = -1`` and ``unresolved = True``.

    *Search* (Qin & Niu (1999) §3-§5 and its Figure 1, whose flowchart is not in the
    text; reconstruction).  With ``FD_S = FD - GLR_S`` the detection function of the
    configuration without the sensors ``S`` (re-detection after removal):

    1. ``FD < chi2_{1-pfa}(m-n)``: no fault.
    2. ``k = argmax_j D_j`` (the single-fault function).  If
       ``FD_{k} < chi2_{1-pfa}(m-n-1)`` the alarm is explained: fault on ``k``
       (one fault, or two of very different sizes whose small one is not
       detectable, Table 2).
    3. Otherwise two faults are present.  Candidate pairs are tried in turn and the
       first with ``FD_{ij} < chi2_{1-pfa}(m-n-2)`` is isolated ("sequentially
       isolating the indicated groups finds the actual faulty gyros", §5):
       first ``(k, k2)`` with ``k2`` the single-fault isolation ``D_j`` on the
       configuration without ``k`` (faults of very different sizes are analysed as
       single faults, §3), then the pairs indicated by ``max D+_ij`` and
       ``max D-_ij`` (faults of similar size, eq. 15-16), the larger maximum first.
    4. If no candidate passes, the sample is detected but unresolved.

    Step 3 needs ``m - n >= 3`` (one parity equation must remain to test a pair).

    *GLR* (the principled alternative).  For ``k = 1, 2, ...``: take the
    ``k``-subset ``S`` maximising ``GLR_S`` among identifiable subsets and accept it
    when ``FD - GLR_S < chi2_{1-pfa}(m-n-k)``.  It tests the same residual as the
    search but picks the maximum-likelihood candidate instead of the ``D+/-``
    indications.

    References
    ----------
    Zhang, Chen & Liu (2005) §1-§5; Qin & Niu (1999) §2-§5.
    """
    pf = as_data(pf)
    pfa = as_probability(pfa, "pfa")
    if not isinstance(method, str) or method not in METHODS:
        raise GeomFDIError(
            f"method: expected one of {', '.join(METHODS)} (or, for a time series, "
            f"windowed, cusum, sprt, sprt-window), got {method!r:.40}",
            argument="method",
        )
    if max_faults is not None:
        max_faults = as_int(max_faults, "max_faults", minimum=1, maximum=pf.m)
    Zs = _samples(pf, Z, check=method in ("search", "glr"))
    if method == "search":
        mf = 2 if max_faults is None else as_int(max_faults, "max_faults", minimum=1)
        if mf > 2:
            raise GeomFDIError(
                f"max_faults: the Qin & Niu search isolates at most 2 faults, got {mf}",
                argument="max_faults",
            )
        return _search(pf, Zs, pfa, mf)
    if method == "glr":
        if max_faults is None:
            mf = max(1, min(2, pf.s - 1))
        else:
            mf = as_int(max_faults, "max_faults", minimum=1)
            if mf > max(1, pf.s - 1):
                raise GeomFDIError(
                    f"max_faults: the GLR can test at most m - n - 1 = {pf.s - 1} faults, got {mf}",
                    argument="max_faults",
                )
        return _glr(pf, Zs, pfa, mf)
    mf = 1 if max_faults is None else as_int(max_faults, "max_faults", minimum=1)
    if mf > 1 and pf.D is not None:
        raise GeomFDIError(
            "max_faults: sequential diagnosis needs D = I (sensor faults)",
            argument="max_faults",
        )
    first = _single(pf, Zs, pfa, method)
    if mf == 1:
        return first
    return _sequential(pf, Zs, pfa, method, mf, first)


def _sequential(
    pf, Z: np.ndarray, pfa: float, method: str, mf: int, first: ParityDiagnosis
) -> ParityDiagnosis:
    N = Z.shape[0]
    faults = np.full((N, mf), -1, dtype=np.intp)
    faults[:, 0] = first.isolated
    unresolved = first.unresolved.copy()
    iso = first.isolated
    for i in np.unique(iso[iso >= 0]):
        try:
            red = reduced_data(pf, int(i))
        except (DesignError, RankDeficientError):
            continue  # no redundancy left: the search stops here
        rows = np.flatnonzero(iso == i)
        keep = np.setdiff1d(np.arange(pf.m), [i])
        sub_first = _single(red, Z[np.ix_(rows, keep)], pfa, method)
        sub = (
            sub_first
            if mf == 2
            else _sequential(red, Z[np.ix_(rows, keep)], pfa, method, mf - 1, sub_first)
        )
        f = sub.faults
        faults[rows, 1:] = np.where(f >= 0, keep[np.maximum(f, 0)], -1)
        unresolved[rows] |= sub.unresolved
    return ParityDiagnosis(
        first.detected, faults, first.statistic, first.threshold, method, pfa, unresolved
    )


def _detect(pf, Z: np.ndarray, pfa: float) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """Projections ``a``, the detection statistic ``FD``, its threshold and the
    detections: the start of every multiple-fault search."""
    a = _a(pf, Z)
    FD = _fd(pf, Z)
    _check_fd(FD)
    T0 = chi2_threshold(pfa, pf.s)
    return a, FD, T0, FD >= T0


def _search(pf: ParityData, Z: np.ndarray, pfa: float, mf: int) -> ParityDiagnosis:
    N, s = Z.shape[0], pf.s
    a, FD, T0, det = _detect(pf, Z, pfa)
    FI = _fi_from_a(pf, a)
    k1 = np.argmax(FI, axis=1)
    faults = np.full((N, mf), -1, dtype=np.intp)
    unresolved = np.zeros(N, dtype=bool)
    if s >= 2:
        R1 = FD - FI[np.arange(N), k1]
        ok1 = R1 < chi2_threshold(pfa, s - 1)
    else:
        ok1 = np.ones(N, dtype=bool)  # no parity left to test: single fault assumed
    single = det & ok1
    faults[single, 0] = pf.lut[k1[single]]
    unresolved |= single & (faults[:, 0] < 0)
    pend = np.flatnonzero(det & ~ok1)
    if mf >= 2 and s >= 3 and pend.size:
        ap, fdp, fip, k1p = a[pend], FD[pend], FI[pend], k1[pend]
        n_p = pend.size
        ar = np.arange(n_p)
        plus, minus = _pairs_from_a(pf, ap)
        glr = _glr2_from_a(pf, ap, fip)
        iu, ju = np.triu_indices(pf.k, 1)
        Pv, Mv = plus[:, iu, ju], minus[:, iu, ju]
        bp, bm = np.argmax(Pv, axis=1), np.argmax(Mv, axis=1)
        plus_first = Pv[ar, bp] >= Mv[ar, bm]
        c1 = np.where(plus_first, bp, bm)
        c2 = np.where(plus_first, bm, bp)
        row = glr[ar, k1p, :].copy()
        row[ar, k1p] = -np.inf
        k2 = np.argmax(row, axis=1)
        cands = [
            (np.minimum(k1p, k2), np.maximum(k1p, k2)),
            (iu[c1], ju[c1]),
            (iu[c2], ju[c2]),
        ]
        T2 = chi2_threshold(pfa, s - 2)
        info = _subset_info(pf, 2)
        pair_ok = np.zeros((pf.k, pf.k), dtype=bool)
        S = info["subsets"]
        pair_ok[S[:, 0], S[:, 1]] = info["valid"] & ~info["ambiguous"]
        accepted = np.zeros(n_p, dtype=bool)
        chosen = np.full((n_p, 2), -1, dtype=np.intp)
        for ci, cj in cands:
            ok = ~accepted & (fdp - glr[ar, ci, cj] < T2)
            chosen[ok, 0], chosen[ok, 1] = ci[ok], cj[ok]
            accepted |= ok
        good = accepted & pair_ok[np.maximum(chosen[:, 0], 0), np.maximum(chosen[:, 1], 0)]
        faults[pend[good], :2] = chosen[good]
        unresolved[pend[~good]] = True
    else:
        unresolved[pend] = True
    return ParityDiagnosis(det, faults, FD, T0, "search", pfa, unresolved)


def _glr(pf: ParityData, Z: np.ndarray, pfa: float, mf: int) -> ParityDiagnosis:
    N, s = Z.shape[0], pf.s
    a, FD, T0, det = _detect(pf, Z, pfa)
    faults = np.full((N, mf), -1, dtype=np.intp)
    unresolved = np.zeros(N, dtype=bool)
    pend = det.copy()
    for kk in range(1, min(mf, s - 1) + 1):
        idx = np.flatnonzero(pend)
        if idx.size == 0:
            break
        info = _subset_info(pf, kk)
        ai = a[idx]
        best = np.full(idx.size, -np.inf)
        arg = np.zeros(idx.size, dtype=np.intp)
        for c in np.flatnonzero(info["valid"]):
            S = info["subsets"][c]
            aS = ai[:, S]
            val = np.einsum("ni,ij,nj->n", aS, info["pinv"][c], aS)
            better = val > best
            best[better] = val[better]
            arg[better] = c
        if not np.isfinite(best).any():
            break
        ok = FD[idx] - best < chi2_threshold(pfa, s - kk)
        acc = idx[ok]
        amb = info["ambiguous"][arg[ok]]
        faults[acc[~amb], :kk] = info["subsets"][arg[ok][~amb]]
        unresolved[acc[amb]] = True
        pend[acc] = False
    unresolved |= pend
    return ParityDiagnosis(det, faults, FD, T0, "glr", pfa, unresolved)
