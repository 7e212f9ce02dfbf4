"""Parity-space FDI (Zhang, Chen & Liu 2005; Qin & Niu 1999): parity matrix, GLT, OPT, pairs."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import linalg as sla
from scipy import stats

import geomfdi as gf
from geomfdi.errors import GeomFDIError, NonFiniteError, RankDeficientError, ShapeError


def random_config(seed: int, n: int, extra: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.standard_normal((n + extra, n))


configs = st.tuples(st.integers(0, 2**31 - 1), st.integers(1, 4), st.integers(1, 4)).map(
    lambda t: random_config(*t)
)


@pytest.fixture
def dodeca():
    return gf.ParityFDI(gf.parity.dodecahedron(), sigma=1.0)


# --------------------------------------------------------------------------- configurations
def test_dodecahedron_reference_facts():
    """Zhang, Chen & Liu 2005; Qin & Niu 1999:
    H^T H = 2I, w_ii = 1/2, all pairwise |cos| = 1/sqrt5."""
    H = gf.parity.dodecahedron()
    assert H.shape == (6, 3)
    np.testing.assert_allclose(H.T @ H, 2 * np.eye(3), atol=1e-14)
    pf = gf.ParityFDI(H)
    np.testing.assert_allclose(np.diag(pf.W), 0.5, atol=1e-14)
    C = H @ H.T
    iu = np.triu_indices(6, 1)
    np.testing.assert_allclose(np.abs(C[iu]), 1 / np.sqrt(5), atol=1e-14)
    cap = pf.capability()
    np.testing.assert_allclose(cap.w, 0.5)
    np.testing.assert_allclose(cap.separation_deg[iu], np.degrees(np.arccos(1 / np.sqrt(5))))
    assert cap.gdop == pytest.approx(np.sqrt(1.5))
    assert cap.isolable.all() and cap.pair_identifiable[iu].all()
    assert "isolable: 6/6" in cap.summary()


@pytest.mark.parametrize("m", [4, 5, 6, 8])
def test_cone_is_isotropic_at_the_magic_angle(m):
    H = gf.parity.cone(m)
    np.testing.assert_allclose(np.linalg.norm(H, axis=1), 1.0)
    np.testing.assert_allclose(H.T @ H, m / 3 * np.eye(3), atol=1e-12)
    H30 = gf.parity.cone(m, 30, degrees=True)
    np.testing.assert_allclose(H30[:, 2], np.cos(np.radians(30)))
    assert not np.allclose(H30.T @ H30, m / 3 * np.eye(3))


def test_cone_bad_arguments_name_the_argument():
    with pytest.raises(GeomFDIError) as e:
        gf.parity.cone(2)
    assert e.value.argument == "m"
    for bad in (0.0, -0.3, np.pi / 2, 2.0):
        with pytest.raises(GeomFDIError) as e:
            gf.parity.cone(5, bad)
        assert e.value.argument == "half_angle"


def test_tetrahedron_detects_but_cannot_isolate():
    H = gf.parity.tetrahedron()
    np.testing.assert_allclose(H.T @ H, 4 / 3 * np.eye(3), atol=1e-14)
    pf = gf.ParityFDI(H, sigma=0.1)
    assert pf.s == 1
    assert pf.detectable.all() and not pf.isolable.any()
    Z = np.zeros((3, 4))
    Z[1, 2] = 2.0
    Z[2, 0] = -2.0
    for method in ("glt", "search", "glr"):
        res = pf.diagnose(Z, 1e-3, method=method)
        assert res.detected.tolist() == [False, True, True]
        assert (res.isolated == -1).all()
        assert res.unresolved.tolist() == [False, True, True]


# --------------------------------------------------------------------------- bad input
def test_bad_input_raises_naming_the_argument(dodeca):
    cases = [
        (lambda: gf.ParityFDI([[1, 0], [2, 0], [3, 0]]), RankDeficientError, "H"),
        (lambda: gf.ParityFDI(np.eye(3)), ShapeError, "H"),
        (lambda: gf.ParityFDI(np.ones((2, 3))), ShapeError, "H"),
        (lambda: gf.ParityFDI([[1, 0], [0, 1j], [1, 1]]), GeomFDIError, "H"),
        (lambda: gf.ParityFDI(gf.parity.dodecahedron(), sigma=0), GeomFDIError, "sigma"),
        (lambda: gf.ParityFDI(gf.parity.dodecahedron(), sigma=-1), GeomFDIError, "sigma"),
        (lambda: gf.ParityFDI(gf.parity.dodecahedron(), basis="qr"), GeomFDIError, "basis"),
        (lambda: gf.ParityFDI(gf.parity.dodecahedron(), basis=np.eye(3, 6)), GeomFDIError, "basis"),
        (lambda: gf.ParityFDI(gf.parity.dodecahedron(), F=np.zeros((6, 6))), GeomFDIError, "F"),
        (lambda: gf.ParityFDI(gf.parity.dodecahedron(), D=np.ones((5, 2))), ShapeError, "D"),
        (lambda: dodeca.detection_statistic(np.zeros((10, 5))), ShapeError, "Z"),
        (lambda: dodeca.diagnose(np.zeros((10, 7)), 0.01), ShapeError, "Z"),
        (lambda: dodeca.diagnose(np.zeros(6), 0.0), GeomFDIError, "pfa"),
        (lambda: dodeca.diagnose(np.zeros(6), 1.0), GeomFDIError, "pfa"),
        (lambda: dodeca.diagnose(np.zeros(6), 1.5), GeomFDIError, "pfa"),
        (lambda: dodeca.diagnose(np.zeros(6), 0.1, method="bayes"), GeomFDIError, "method"),
        (
            lambda: dodeca.diagnose(np.zeros(6), 0.1, method="glr", max_faults=3),
            GeomFDIError,
            "max_faults",
        ),
        (
            lambda: dodeca.diagnose(np.zeros(6), 0.1, method="search", max_faults=3),
            GeomFDIError,
            "max_faults",
        ),
        (lambda: dodeca.reduced([0, 1, 2]), GeomFDIError, "remove"),
        (lambda: dodeca.reduced(6), GeomFDIError, "remove"),
        (lambda: dodeca.glr_statistics(np.zeros(6), 7), GeomFDIError, "n_faults"),
        (lambda: gf.parity.chi2_threshold(0.01, 0), GeomFDIError, "dof"),
        (lambda: gf.parity.false_alarm_rate(dodeca, 0.01, 10, rng="x"), GeomFDIError, "rng"),
    ]
    for call, exc, arg in cases:
        with pytest.raises(exc) as e:
            call()
        assert e.value.argument == arg, (arg, str(e.value))
        assert arg in str(e.value)


@pytest.mark.parametrize("method", ["glt", "opt", "opt-uncorrected", "search", "glr"])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_samples_raise_in_every_path(dodeca, method, bad):
    dodeca.chunk_size = 5
    Z = np.zeros((23, 6))
    Z[17, 3] = bad
    with pytest.raises(NonFiniteError) as e:
        dodeca.diagnose(Z, 0.01, method=method)
    assert e.value.argument == "Z" and "(17, 3)" in str(e.value)
    with pytest.raises(NonFiniteError):
        dodeca.isolation_statistics(Z)


def test_overflowing_samples_raise_instead_of_returning_inf(dodeca):
    Z = np.zeros((4, 6))
    Z[2, 0] = 1e300
    with pytest.raises(GeomFDIError, match="overflow") as e:
        dodeca.diagnose(Z, 0.01)
    assert e.value.argument == "Z"


def test_nan_on_a_non_redundant_sensor_is_still_reported():
    # sensor 0 alone measures x1: its reading never enters the parity space
    H = [[1, 0], [0, 1], [0, 1], [0, 1]]
    pf = gf.ParityFDI(H)
    Z = np.zeros((3, 4))
    Z[1, 0] = np.nan
    with pytest.raises(NonFiniteError):
        pf.diagnose(Z, 0.01)


# --------------------------------------------------------------------------- parity matrix
@given(configs)
def test_parity_matrix_properties(H):
    pf = gf.ParityFDI(H)
    m, n = H.shape
    V, W = pf.V, pf.W
    assert V.shape == (m - n, m)
    np.testing.assert_allclose(V @ H, 0, atol=1e-10 * max(1, np.abs(H).max()))
    np.testing.assert_allclose(V @ V.T, np.eye(m - n), atol=1e-12)
    np.testing.assert_allclose(V.T @ V, W, atol=1e-12)  # Lemma 2
    np.testing.assert_allclose(W @ W, W, atol=1e-12)  # Lemma 1 (a)
    np.testing.assert_allclose(W, W.T, atol=0)
    w = np.diag(W)
    assert np.all(w > -1e-12) and np.all(w < 1 + 1e-12)  # Lemma 1 (c), boundary inclusive
    np.testing.assert_allclose(w, np.sum(W * W, axis=0), atol=1e-12)  # w_ii = ||W_i||^2


@given(configs)
def test_potter_suman_form_is_upper_triangular(H):
    pf = gf.ParityFDI(H, basis="potter")
    order = pf.potter_order
    R = pf.V[:, order[: pf.s]]
    # R = Q[:s]^T holds to the QR's backward error over the leading block's smallest
    # singular value (it is kept down to 1e-6; below that the sensors are pivoted)
    sv_min = np.linalg.svd(R, compute_uv=False)[-1]
    assert sv_min > 1e-7
    np.testing.assert_allclose(
        np.tril(R, -1), 0, atol=max(1e-12, 50 * np.finfo(float).eps / sv_min)
    )
    assert np.all(np.diag(R) > 0)


def test_potter_suman_pivots_when_the_leading_rows_are_dependent():
    # sensor 0 is not redundant: W_0 = 0, the first m - n columns of W are dependent
    H = np.array([[1.0, 0], [0, 1], [0, 1], [0, 1]])
    pf = gf.ParityFDI(H)
    assert pf.potter_order[0] != 0
    np.testing.assert_allclose(pf.V @ H, 0, atol=1e-14)
    np.testing.assert_allclose(pf.V @ pf.V.T, np.eye(2), atol=1e-14)
    assert not pf.detectable[0] and pf.detectable[1:].all()
    Z = np.zeros((2, 4))
    Z[:, 0] = [50.0, -50.0]  # huge fault on the non-redundant sensor: invisible
    Z[1, 2] = 8.0
    np.testing.assert_allclose(pf.isolation_statistics(Z)[0], 0, atol=1e-20)
    res = pf.diagnose(Z, 1e-3)
    assert res.detected.tolist() == [False, True]
    assert res.isolated.tolist() == [-1, 2]


@settings(max_examples=30)
@given(configs, st.integers(0, 2**31 - 1))
def test_statistics_do_not_depend_on_the_parity_basis(H, seed):
    rng = np.random.default_rng(seed)
    m, n = H.shape
    Z = rng.standard_normal((7, m)) * 3
    pots = gf.ParityFDI(H, sigma=0.7, basis="potter")
    svd = gf.ParityFDI(H, sigma=0.7, basis="svd")
    Q = np.linalg.qr(rng.standard_normal((m - n, m - n)))[0]
    given_ = gf.ParityFDI(H, sigma=0.7, basis=Q @ svd.V)
    assert not np.allclose(pots.V, svd.V) or m - n == 1
    ref_fd = pots.detection_statistic(Z)
    ref_fi = pots.isolation_statistics(Z)
    ref_pp, ref_pm = pots.pair_statistics(Z)
    for other in (svd, given_):
        np.testing.assert_allclose(other.detection_statistic(Z), ref_fd, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(other.isolation_statistics(Z), ref_fi, rtol=1e-9, atol=1e-9)
        pp, pm = other.pair_statistics(Z)
        np.testing.assert_allclose(pp, ref_pp, rtol=1e-8, atol=1e-8)
        np.testing.assert_allclose(pm, ref_pm, rtol=1e-8, atol=1e-8)
        np.testing.assert_allclose(other.opt_statistics(Z), pots.opt_statistics(Z), atol=1e-8)


# --------------------------------------------------------------------------- GLT
def test_glt_statistics_against_the_formulas_of_seed_000(dodeca):
    rng = np.random.default_rng(3)
    Z = rng.standard_normal((5, 6))
    pf = gf.ParityFDI(gf.parity.dodecahedron(), sigma=0.3)
    V = pf.V
    fd = pf.detection_statistic(Z)
    fi = pf.isolation_statistics(Z)
    for k in range(5):
        p = V @ Z[k]
        assert fd[k] == pytest.approx(p @ p / 0.09, rel=1e-12)  # eq. 2
        for i in range(6):
            Vi = V[:, i]
            assert fi[k, i] == pytest.approx((p @ Vi) ** 2 / (Vi @ Vi) / 0.09, rel=1e-10)  # eq. 4
    # a vector input is one sample
    assert pf.detection_statistic(Z[0]).shape == (1,)
    assert pf.detection_statistic(Z[0].tolist())[0] == pytest.approx(fd[0])
    np.testing.assert_allclose(pf.parity(Z), Z @ V.T)


def test_state_does_not_enter_the_statistics(dodeca):
    rng = np.random.default_rng(4)
    E = rng.standard_normal((20, 6))
    X = rng.standard_normal((20, 3)) * 100
    Z = X @ dodeca.H.T + E
    np.testing.assert_allclose(
        dodeca.detection_statistic(Z), dodeca.detection_statistic(E), rtol=1e-8
    )
    np.testing.assert_allclose(
        dodeca.isolation_statistics(Z), dodeca.isolation_statistics(E), rtol=1e-7, atol=1e-9
    )


def test_thresholds():
    assert gf.parity.chi2_threshold(1e-4, 1) == pytest.approx(15.1367, abs=1e-4)  # chi-square table
    assert gf.parity.chi2_threshold(0.05, 3) == pytest.approx(stats.chi2.ppf(0.95, 3))
    assert gf.parity.normal_threshold(0.05) == pytest.approx(1.959964, abs=1e-6)
    assert gf.parity.opt_false_alarm_bound(0.05, 3) == pytest.approx(1 - 0.95**3)
    pf = gf.ParityFDI(gf.parity.dodecahedron())
    assert pf.detection_threshold(0.01) == pytest.approx(stats.chi2.isf(0.01, 3))


# --------------------------------------------------------------------------- OPT, Theorems 2-4
@settings(max_examples=30)
@given(configs, st.integers(0, 2**31 - 1), st.floats(0.05, 20))
def test_theorems_2_3_4_on_random_configurations(H, seed, sigma):
    rng = np.random.default_rng(seed)
    m, n = H.shape
    pf = gf.ParityFDI(H, sigma=sigma)
    Z = rng.standard_normal((9, m)) * sigma * 4 + rng.standard_normal(m) * sigma
    W = pf.W
    ok = np.diag(W) > 1e-9
    # Theorem 3: v_i = W_i / ||W_i||
    V_opt = pf.opt_vectors
    np.testing.assert_allclose(V_opt[:, ok], W[:, ok] / np.linalg.norm(W[:, ok], axis=0), atol=1e-8)
    # Theorem 2: d_i^2 = FI_GLT(i)
    d = pf.opt_statistics(Z)
    fi = pf.isolation_statistics(Z)
    scale = 1 + fi.max()
    np.testing.assert_allclose(d[:, ok] ** 2, fi[:, ok], atol=1e-9 * scale)
    # Theorem 4: FD_OPT = FD_GLT
    fd = pf.detection_statistic(Z)
    assert pf.opt_dof == m - n
    np.testing.assert_allclose(pf.opt_detection_statistic(Z), fd, rtol=1e-9, atol=1e-12)
    # the corrected OPT and the GLT take identical decisions
    a, b = pf.diagnose(Z, 0.05, method="glt"), pf.diagnose(Z, 0.05, method="opt")
    np.testing.assert_array_equal(a.detected, b.detected)
    close = np.sort(fi, axis=1)
    clear = close[:, -1] - close[:, -2] > 1e-6 * scale if m > 1 else np.ones(len(Z), bool)
    np.testing.assert_array_equal(a.isolated[clear], b.isolated[clear])


def test_general_opt_solves_the_rayleigh_quotient_of_eq_7():
    rng = np.random.default_rng(11)
    H = rng.standard_normal((7, 3))
    D = np.diag(rng.uniform(0.5, 2.0, 7))
    F = rng.standard_normal((7, 7)) * 0.3 + np.eye(7)
    pf = gf.ParityFDI(H, sigma=0.5, D=D, F=F)
    V = pf.V
    Sigma = F @ F.T
    vopt = pf.opt_vectors
    perf = pf.opt_performance
    np.testing.assert_allclose(vopt.T @ H, 0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(vopt, axis=0), 1)

    def index(v, i):
        num = (v @ D[:, i]) ** 2
        den = v @ Sigma @ v + sum((v @ D[:, j]) ** 2 for j in range(7) if j != i)
        return num / den

    for i in range(7):
        u = V @ D[:, i]
        Mi = V @ (Sigma + D @ D.T - np.outer(D[:, i], D[:, i])) @ V.T
        # generalised eigenproblem u u^T c = lambda M_i c: largest eigenvalue = S_i
        lam, vec = sla.eigh(np.outer(u, u), Mi)
        assert perf[i] == pytest.approx(lam[-1], rel=1e-9)
        assert index(vopt[:, i], i) == pytest.approx(lam[-1], rel=1e-9)
        c = vec[:, -1]
        v = V.T @ c
        assert abs(v @ vopt[:, i]) / np.linalg.norm(v) == pytest.approx(1.0, abs=1e-9)
        assert vopt[:, i] @ D[:, i] > 0
        # no other parity vector does better
        trials = V.T @ rng.standard_normal((4, 200))
        assert max(index(trials[:, t], i) for t in range(200)) <= perf[i] * (1 + 1e-9)
    # standardisation (eq. 9): d_i ~ N(0, 1) without fault
    Z = rng.standard_normal((4000, 7)) @ F.T * 0.5
    d = pf.opt_statistics(Z)
    np.testing.assert_allclose(d.std(axis=0), 1.0, atol=0.05)
    # with F != I the OPT and GLT isolation functions differ (Zhang, Chen & Liu 2005, conclusion)
    assert not np.allclose(d[:5] ** 2, pf.isolation_statistics(Z[:5]), rtol=1e-3)
    # but the corrected OPT detection function is still FD_GLT (noise-whitened)
    np.testing.assert_allclose(
        pf.opt_detection_statistic(Z[:50]), pf.detection_statistic(Z[:50]), rtol=1e-9
    )


def test_opt_with_identity_matrices_equals_the_default(dodeca):
    rng = np.random.default_rng(5)
    Z = rng.standard_normal((6, 6))
    explicit = gf.ParityFDI(gf.parity.dodecahedron(), D=np.eye(6), F=np.eye(6))
    np.testing.assert_allclose(explicit.opt_vectors, dodeca.opt_vectors, atol=1e-12)
    np.testing.assert_allclose(explicit.opt_statistics(Z), dodeca.opt_statistics(Z), atol=1e-12)
    # a scalar noise matrix only rescales: Theorem 2 still holds
    scaled = gf.ParityFDI(gf.parity.dodecahedron(), F=3 * np.eye(6))
    np.testing.assert_allclose(
        scaled.opt_statistics(Z) ** 2, scaled.isolation_statistics(Z), rtol=1e-9
    )
    np.testing.assert_allclose(scaled.detection_statistic(Z), dodeca.detection_statistic(Z) / 9)


def test_general_noise_whitening_gives_chi2_detection():
    rng = np.random.default_rng(6)
    H = gf.parity.cone(6)
    F = np.diag([1, 1, 2, 2, 0.5, 3.0])
    pf = gf.ParityFDI(H, sigma=0.2, F=F)
    Z = rng.standard_normal((200000, 6)) @ F.T * 0.2
    fd = pf.detection_statistic(Z)
    # mean and variance of chi2(3): 3 and 6
    assert fd.mean() == pytest.approx(3, abs=0.05)
    assert fd.var() == pytest.approx(6, abs=0.15)
    far = pf.diagnose(Z, 0.01).detected.mean()
    assert abs(far - 0.01) < 4 * np.sqrt(0.01 * 0.99 / 200000)


# --------------------------------------------------------------------------- pairs, GLR
def test_pair_statistics_against_seed_004_formulas():
    rng = np.random.default_rng(7)
    pf = gf.ParityFDI(gf.parity.cone(7, 0.8), sigma=0.5)
    Z = rng.standard_normal((4, 7))
    plus, minus = pf.pair_statistics(Z)
    assert plus.shape == minus.shape == (4, 7, 7)
    V = pf.V
    for k in range(4):
        p = V @ Z[k]
        for i, j in itertools.permutations(range(7), 2):
            for sgn, arr in ((1, plus), (-1, minus)):
                d = V[:, i] + sgn * V[:, j]
                assert arr[k, i, j] == pytest.approx((d @ p) ** 2 / (d @ d) / 0.25, rel=1e-9)
    assert np.all(np.diagonal(plus, axis1=1, axis2=2) == 0)
    assert np.all(np.diagonal(minus, axis1=1, axis2=2) == 0)


def test_two_fault_glr_is_the_projection_onto_the_pair_span():
    rng = np.random.default_rng(8)
    H = rng.standard_normal((7, 3))
    pf = gf.ParityFDI(H, sigma=2.0)
    Z = rng.standard_normal((5, 7)) * 2
    glr = pf.two_fault_glr(Z)
    fi = pf.isolation_statistics(Z)
    np.testing.assert_allclose(np.diagonal(glr, axis1=1, axis2=2), fi)
    plus, minus = pf.pair_statistics(Z)
    V = pf.V
    for k in range(5):
        p = V @ Z[k]
        for i, j in itertools.combinations(range(7), 2):
            VS = V[:, [i, j]]
            proj = VS @ np.linalg.lstsq(VS, p, rcond=None)[0]
            assert glr[k, i, j] == pytest.approx(proj @ proj / 4.0, rel=1e-9)
            assert glr[k, j, i] == glr[k, i, j]
    # unequal column norms: D+ + D- is not the GLR in general
    iu = np.triu_indices(7, 1)
    assert not np.allclose((plus + minus)[:, iu[0], iu[1]], glr[:, iu[0], iu[1]])
    # the k-fault GLR agrees for k = 1 and k = 2
    g1, s1 = pf.glr_statistics(Z, 1)
    np.testing.assert_allclose(g1, fi[:, s1[:, 0]], rtol=1e-10)
    g2, s2 = pf.glr_statistics(Z, 2)
    np.testing.assert_allclose(g2, glr[:, s2[:, 0], s2[:, 1]], rtol=1e-9)
    g3, s3 = pf.glr_statistics(Z, 3)
    assert s3.shape == (35, 3)
    assert np.all(g3 >= g2.max(axis=1, keepdims=True) * 0 - 1e-12)
    fd = pf.detection_statistic(Z)
    assert np.all(g3 <= fd[:, None] * (1 + 1e-12))


@pytest.mark.parametrize("H", [gf.parity.dodecahedron(), gf.parity.cone(5), gf.parity.cone(8)])
def test_glr_equals_d_plus_plus_d_minus_for_equal_norm_columns(H):
    pf = gf.ParityFDI(H, sigma=0.3)
    assert np.allclose(pf.w, pf.w[0])
    Z = np.random.default_rng(9).standard_normal((50, H.shape[0]))
    plus, minus = pf.pair_statistics(Z)
    glr = pf.two_fault_glr(Z)
    iu = np.triu_indices(H.shape[0], 1)
    np.testing.assert_allclose(
        (plus + minus)[:, iu[0], iu[1]], glr[:, iu[0], iu[1]], rtol=1e-9, atol=1e-12
    )


@settings(max_examples=30)
@given(configs, st.integers(0, 2**31 - 1))
def test_removing_sensors_equals_profiling_their_faults(H, seed):
    """FD of the reduced configuration = FD - GLR_S (the identity the search relies on)."""
    rng = np.random.default_rng(seed)
    m, n = H.shape
    pf = gf.ParityFDI(H, sigma=1.3)
    Z = rng.standard_normal((6, m)) * 2
    fd = pf.detection_statistic(Z)
    scale = 1 + fd.max()
    for size in (1, 2):
        if m - size <= n:
            break
        glr, subsets = pf.glr_statistics(Z, size)
        for c, S in enumerate(subsets):
            keep = np.setdiff1d(np.arange(m), S)
            try:
                red = pf.reduced(S.tolist())
            except RankDeficientError:
                continue
            np.testing.assert_array_equal(red.sensors, keep)
            np.testing.assert_allclose(
                red.detection_statistic(Z[:, keep]), fd - glr[:, c], atol=1e-8 * scale
            )


def test_reduction_identity_with_unequal_noise():
    rng = np.random.default_rng(10)
    H = gf.parity.cone(6)
    F = np.diag([1, 2, 0.5, 1, 3, 1.5])
    pf = gf.ParityFDI(H, sigma=0.1, F=F)
    Z = rng.standard_normal((5, 6))
    fd = pf.detection_statistic(Z)
    glr, subsets = pf.glr_statistics(Z, 2)
    for c, S in enumerate(subsets):
        keep = np.setdiff1d(np.arange(6), S)
        red = pf.reduced(S.tolist())
        np.testing.assert_allclose(red.F, F[keep])
        np.testing.assert_allclose(red.detection_statistic(Z[:, keep]), fd - glr[:, c], rtol=1e-9)


# --------------------------------------------------------------------------- Qin & Niu tables
T1 = {  # Table 1 (1-based): gyro -> (pair indicated by max D+, pair indicated by max D-)
    1: ((3, 5), (1, 5)),
    2: ((2, 3), (1, 6)),
    3: ((1, 5), (2, 6)),
    4: ((2, 5), (1, 4)),
    5: ((1, 3), (4, 6)),
    6: ((1, 2), (2, 3)),
}
T2 = {  # Table 2: (gyro with 0.05, gyro with 0.005) -> (D+ pair, D- pair)
    (1, 2): ((1, 6), (1, 5)), (1, 3): ((2, 5), (1, 4)), (1, 4): ((1, 6), (1, 3)),
    (1, 5): ((3, 4), (1, 2)), (1, 6): ((1, 6), (1, 5)), (2, 3): ((1, 5), (1, 2)),
    (2, 4): ((2, 4), (1, 6)), (2, 5): ((2, 4), (1, 2)), (2, 6): ((2, 6), (4, 5)),
    (3, 4): ((1, 5), (2, 6)), (3, 5): ((1, 4), (3, 6)), (3, 6): ((1, 5), (2, 4)),
    (4, 5): ((1, 3), (1, 4)), (4, 6): ((4, 6), (2, 3)), (5, 6): ((1, 3), (2, 4)),
}  # fmt: skip
T3_DJ = {  # Table 3 (equal size, same sign): gyros indicated by max D_j
    (1, 2): {6, 5}, (1, 3): {5, 4}, (1, 4): {6, 3}, (1, 5): {3, 2}, (1, 6): {6, 1},
    (2, 3): {2, 3}, (2, 4): {2, 4}, (2, 5): {4, 1}, (2, 6): {2, 6}, (3, 4): {2, 1},
    (3, 5): {1, 6}, (3, 6): {2, 5}, (4, 5): {4, 5}, (4, 6): {6, 4}, (5, 6): {4, 3},
}  # fmt: skip
T4_DJ = {  # Table 4 (equal size, opposite sign); (1, 6) reads {4, 1} in the OCR, see below
    (1, 2): {1, 2}, (1, 3): {1, 3}, (1, 4): {1, 4}, (1, 5): {1, 5},
    (2, 3): {6, 4}, (2, 4): {5, 3}, (2, 5): {2, 5}, (2, 6): {3, 1}, (3, 4): {3, 4},
    (3, 5): {5, 3}, (3, 6): {3, 6}, (4, 5): {2, 6}, (4, 6): {1, 5}, (5, 6): {5, 6},
}  # fmt: skip


def _maximisers(values, pairs=False):
    mx = values.max()
    hits = np.argwhere(np.isclose(values, mx, rtol=1e-9))
    if pairs:
        return {(int(i) + 1, int(j) + 1) for i, j in hits if i < j}
    return {int(i) + 1 for i in hits.ravel()}


def test_seed_004_tables_are_reproduced_noise_free():
    """The indications reported in Qin & Niu's (1999) Tables 1-4 are maximisers of our statistics.

    The configuration is symmetric, so maxima are often tied; every reported pair must be
    among the tied maximisers.  Table 3/4 list the gyros indicated by D_j over the run:
    these sets equal the noise-free tie sets exactly.  One entry of Table 4, (1, 6), reads
    "(4); (1)" where the noise-free tie set is {2, 4} (gyro 1 has FI 1528 against 4000):
    most likely a misprint, it is left out.
    """
    pf = gf.ParityFDI(gf.parity.dodecahedron(), sigma=0.001)
    for g, (pp, pm) in T1.items():
        for size in (0.01, -0.01):
            f = np.zeros(6)
            f[g - 1] = size
            plus, minus = pf.pair_statistics(f)
            assert _maximisers(pf.isolation_statistics(f)[0]) == {g}
            assert pp in _maximisers(plus[0], pairs=True)
            assert pm in _maximisers(minus[0], pairs=True)
    for (i, j), (pp, pm) in T2.items():
        f = np.zeros(6)
        f[i - 1], f[j - 1] = 0.05, 0.005
        plus, minus = pf.pair_statistics(f)
        assert _maximisers(pf.isolation_statistics(f)[0]) == {i}
        assert pp in _maximisers(plus[0], pairs=True)
        assert pm in _maximisers(minus[0], pairs=True)
    for table, sign in ((T3_DJ, 1.0), (T4_DJ, -1.0)):
        for (i, j), gyros in table.items():
            f = np.zeros(6)
            f[i - 1], f[j - 1] = 0.1, 0.1 * sign
            assert _maximisers(pf.isolation_statistics(f)[0]) == gyros, (i, j, sign)
            # the true pair maximises the matching equal-size function (eq. 15 / 16)
            plus, minus = pf.pair_statistics(f)
            assert (i, j) in _maximisers((plus if sign > 0 else minus)[0], pairs=True)


def test_equal_size_pairs_on_the_dodecahedron_are_confounded():
    """For every pair (i, j) and sign, V_i +/- V_j is parallel to V_k +/- V_l for exactly
    one disjoint pair (k, l): equal-size faults on (i, j) and on (k, l), plus a change of
    x, give identical measurements.  This exact equivalence caps the correct-isolation
    rate of any parity test on the equal-size cases of Qin & Niu's (1999) Tables 3-4."""
    pf = gf.ParityFDI(gf.parity.dodecahedron())
    V = pf.V

    def parallel(a, b):
        return abs(abs(a @ b) / np.linalg.norm(a) / np.linalg.norm(b) - 1) < 1e-12

    for sign in (1.0, -1.0):
        for i, j in itertools.combinations(range(6), 2):
            s = V[:, i] + sign * V[:, j]
            partners = [
                (k, m, sg)
                for k, m in itertools.combinations(range(6), 2)
                for sg in (1.0, -1.0)
                if {k, m}.isdisjoint({i, j}) and parallel(s, V[:, k] + sg * V[:, m])
            ]
            assert len(partners) == 1, (i, j, sign, partners)
            k, m, sg = partners[0]
            f = np.zeros(6)
            f[[i, j]] = [1.0, sign]
            g = np.zeros(6)
            g[[k, m]] = [1.0, sg]
            c = (V @ f) @ (V @ g) / ((V @ g) @ (V @ g))
            diff = f - c * g  # the measurement difference lies in range(H)
            x = np.linalg.lstsq(pf.H, diff, rcond=None)[0]
            np.testing.assert_allclose(pf.H @ x, diff, atol=1e-12)
            # and the GLR of the partner pair explains the noise-free parity completely
            glr = pf.two_fault_glr(0.1 * f)[0]
            assert glr[k, m] == pytest.approx(pf.detection_statistic(0.1 * f)[0], rel=1e-10)


# --------------------------------------------------------------------------- diagnose
def test_fast_path_equals_the_direct_rule():
    rng = np.random.default_rng(12)
    pf = gf.ParityFDI(gf.parity.cone(7, 1.0), sigma=0.5, chunk_size=13)
    Z = rng.standard_normal((1001, 7)) * 0.5
    Z[::3, 2] += 2.5
    Z[1::5, 5] -= 3.0
    res = pf.diagnose(Z, 0.02)
    fd = pf.detection_statistic(Z)
    fi = pf.isolation_statistics(Z)
    T = stats.chi2.isf(0.02, 4)
    np.testing.assert_allclose(res.statistic, fd, rtol=1e-12)
    np.testing.assert_array_equal(res.detected, fd >= T)
    np.testing.assert_array_equal(res.isolated, np.where(fd >= T, fi.argmax(axis=1), -1))
    assert res.threshold == pytest.approx(T)
    assert res.faults.shape == (1001, 1)
    assert res.detected.any() and (~res.detected).any()
    # uncorrected OPT: max |d_i| > u_{1 - alpha/2}
    ru = pf.diagnose(Z, 0.02, method="opt-uncorrected")
    d = np.abs(pf.opt_statistics(Z))
    u = stats.norm.isf(0.01)
    np.testing.assert_allclose(ru.statistic, d.max(axis=1), rtol=1e-12)
    np.testing.assert_array_equal(ru.detected, d.max(axis=1) > u)
    np.testing.assert_array_equal(ru.isolated, np.where(ru.detected, d.argmax(axis=1), -1))


@pytest.mark.parametrize("method", ["glt", "opt", "opt-uncorrected", "search", "glr"])
def test_large_single_fault_is_isolated_by_every_method(method):
    pf = gf.ParityFDI(gf.parity.dodecahedron(), sigma=0.01)
    rng = np.random.default_rng(13)
    Z = rng.standard_normal((60, 6)) * 0.01
    truth = np.arange(60) % 6
    Z[np.arange(60), truth] += np.where(np.arange(60) % 2, 0.3, -0.3)
    res = pf.diagnose(Z, 1e-3, method=method)
    assert res.detected.all()
    np.testing.assert_array_equal(res.isolated, truth)
    assert not res.unresolved.any()
    if method in ("search", "glr"):
        assert (res.faults[:, 1] == -1).all()


def test_two_faults_are_found_sequentially_search_and_glr():
    pf = gf.ParityFDI(gf.parity.dodecahedron(), sigma=0.001)
    rng = np.random.default_rng(14)
    pairs = list(itertools.combinations(range(6), 2))
    Z = rng.standard_normal((len(pairs), 6)) * 0.001
    for r, (i, j) in enumerate(pairs):
        Z[r, i] += 0.08
        Z[r, j] -= 0.03
    seq = pf.diagnose(Z, 1e-3, max_faults=2)
    assert seq.faults.shape == (15, 2)
    for method, res in (
        ("seq", seq),
        ("search", pf.diagnose(Z, 1e-3, method="search")),
        ("glr", pf.diagnose(Z, 1e-3, method="glr")),
    ):
        got = [tuple(sorted(row)) for row in res.faults.tolist()]
        assert got == pairs, method
    # sequential: the larger fault comes first
    np.testing.assert_array_equal(seq.isolated, [i for i, _ in pairs])
    # the second stage equals the diagnosis on the reduced configuration
    red = pf.reduced(0)
    rows = seq.isolated == 0
    sub = red.diagnose(Z[rows][:, 1:], 1e-3)
    np.testing.assert_array_equal(seq.faults[rows, 1], red.sensors[sub.isolated])


def test_sequential_mode_stops_without_redundancy():
    pf = gf.ParityFDI(gf.parity.cone(5), sigma=0.01)  # m - n = 2
    Z = np.zeros((1, 5))
    Z[0, 1] = 1.0
    Z[0, 3] = 0.3
    res = pf.diagnose(Z, 1e-3, max_faults=3)
    assert res.faults.shape == (1, 3)
    first = int(pf.isolation_statistics(Z).argmax())
    assert res.faults[0, 0] == first
    red = pf.reduced(first)
    assert red.s == 1 and not red.isolable.any()
    keep = np.setdiff1d(np.arange(5), [first])
    assert red.detection_statistic(Z[:, keep])[0] > red.detection_threshold(1e-3)
    # the second fault is detected on the reduced configuration but cannot be isolated
    assert res.faults[0, 1:].tolist() == [-1, -1]
    assert res.unresolved[0]


def test_diagnosis_object_and_shapes(dodeca):
    res = dodeca.diagnose(np.zeros(6), 0.01)
    assert len(res) == 1 and res.isolated.tolist() == [-1]
    assert res.n_faults.tolist() == [0] and res.max_faults == 1
    assert "ParityDiagnosis" in repr(res) and "ParityFDI" in repr(dodeca)
    empty = dodeca.diagnose(np.zeros((0, 6)), 0.01)
    assert empty.detected.shape == (0,) and empty.faults.shape == (0, 1)
    lst = dodeca.diagnose([[0, 0, 0, 0, 0, 9.0]], 0.01)
    assert lst.isolated.tolist() == [5]


def test_general_fault_matrix_hypotheses():
    H = gf.parity.cone(6)
    D = np.zeros((6, 2))
    D[[0, 1], 0] = 1.0  # hypothesis 0: common fault on sensors 0 and 1
    D[[3, 4], 1] = [1.0, -1.0]
    pf = gf.ParityFDI(H, sigma=0.01, D=D)
    assert pf.k == 2
    Z = np.zeros((2, 6))
    Z[0] = 0.2 * D[:, 0]
    Z[1] = 0.2 * D[:, 1]
    assert pf.isolation_statistics(Z).shape == (2, 2)
    assert pf.diagnose(Z, 1e-3).isolated.tolist() == [0, 1]
    assert pf.diagnose(Z, 1e-3, method="opt").isolated.tolist() == [0, 1]
    with pytest.raises(GeomFDIError) as e:
        pf.reduced(0)
    assert e.value.argument == "remove"


def test_min_detectable_fault(dodeca):
    f = dodeca.min_detectable_fault(1e-3, 0.9)
    T = stats.chi2.isf(1e-3, 3)
    lam = f**2 * 0.5
    np.testing.assert_allclose(stats.ncx2.sf(T, 3, lam), 0.9, rtol=1e-6)
    pf = gf.ParityFDI([[1, 0], [0, 1], [0, 1], [0, 1]])
    assert np.isinf(pf.min_detectable_fault(0.01)[0])


# ------------------------------------------------------------------ construction, labels
def test_isolability_matches_a_pairwise_rank_check():
    rng = np.random.default_rng(5)
    H = rng.standard_normal((7, 3))
    # five sensors in the x-y plane: only sensors 5 and 6 see z, so a z-error on them is
    # consistent with a state change and their parity signatures are parallel
    H[:5, 2] = 0.0
    pf = gf.ParityFDI(H)
    G = pf.fault_signatures
    brute = np.zeros(7, dtype=bool)
    for i in range(7):
        for j in range(7):
            if i != j:
                sv = np.linalg.svd(G[:, [i, j]], compute_uv=False)
                brute[i] |= sv[1] <= 1e-10 * sv[0]
    assert brute.tolist() == [False] * 5 + [True, True]
    assert pf.isolable.tolist() == (~brute).tolist()
    assert not gf.ParityFDI(gf.parity.tetrahedron()).isolable.any()


def test_large_configuration_statistics_match_the_projector():
    rng = np.random.default_rng(6)
    H = rng.standard_normal((400, 3))
    pf = gf.ParityFDI(H, sigma=0.5)
    Z = rng.standard_normal((3, 400))
    W = np.eye(400) - H @ np.linalg.solve(H.T @ H, H.T)
    fd = np.einsum("ij,jk,ik->i", Z, W, Z) / 0.25
    assert np.allclose(pf.detection_statistic(Z), fd, rtol=1e-9)
    fi = (Z @ W) ** 2 / np.diag(W) / 0.25
    assert np.allclose(pf.isolation_statistics(Z), fi, rtol=1e-9)
    assert pf.isolable.all()


@pytest.mark.parametrize(
    "labels, match",
    [
        ([0, 1, 2, 3, 4, 4], "distinct"),
        ([0, 1, 2, 3, 4], "6 labels"),
        ([0, 1, 2, 3, 4, -1], "non-negative"),
        ([0, 1, 2, 3, 4, 0.5], "integers"),
    ],
)
def test_sensor_labels_are_validated(labels, match):
    with pytest.raises(GeomFDIError, match=match):
        gf.ParityFDI(gf.parity.dodecahedron(), sensors=labels)


def test_confusable_pairs_are_explained_exactly_by_a_disjoint_pair():
    pf = gf.ParityFDI(gf.parity.dodecahedron())
    cap = pf.capability()
    assert cap.pair_identifiable[np.triu_indices(6, 1)].all()
    assert cap.pair_confusable[np.triu_indices(6, 1)].all()
    assert "confusable with a disjoint pair for some fault sizes: 15/15" in cap.summary()
    f = np.zeros(6)
    f[[0, 1]] = 1.0  # equal sizes, same sign (Qin & Niu, Table 3)
    fd = pf.detection_statistic(f)[0]
    glr, subsets = pf.glr_statistics(f, 2)
    explained = [tuple(S) for S, g in zip(subsets, glr[0], strict=True) if fd - g < 1e-9 * fd]
    assert (0, 1) in explained and any(not ({0, 1} & set(S)) for S in explained)
    # with five parity equations two disjoint pairs never share a direction
    cone = gf.ParityFDI(gf.parity.cone(8)).capability()
    assert cone.pair_confusable is not None and not cone.pair_confusable.any()
