"""Quantitative diagnosability (Li, Wang & Liu 2015; docs/theory/diagnosability.md).

Tables, conventions, null-space paths.
"""

from __future__ import annotations

import doctest
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

import geomfdi as gf
import geomfdi.diagnosability.window as diag
from geomfdi.errors import DesignError, GeomFDIError, RankDeficientError, ShapeError

PATHS = ("structured", "direct")
THETA = [1.0, 1.0, 1.0]

# Table 1 of Li, Wang & Liu (2015) (KL): rows f1..f4, columns FD, f1..f4
TABLE1 = np.array(
    [
        [0.1613, 0, 0, 0.1087, 0.0549],
        [0.1613, 0, 0, 0.1087, 0.0549],
        [1.0179, 1.0000, 1.0000, 0, 0.0549],
        [1.0717, 1.0000, 1.0000, 0.1087, 0],
    ]
)
# Table 2 of Li, Wang & Liu (2015) (directional)
TABLE2 = np.array(
    [
        [0.9789, 0, 0, 0.1800, 0.1687],
        [0.9789, 0, 0, 0.1800, 0.1687],
        [0.9909, 0.1800, 0.1800, 0, 0.0614],
        [0.9914, 0.1687, 0.1687, 0.0614, 0],
    ]
)


def model23(nullspace: str = "structured", **kw) -> gf.WindowModel:
    args = dict(
        Bf=[[0, 0, 0, 0], [1, 1, 0, 0]],
        Df=[[0, 0, 1, 0], [0, 0, 0, 1]],
        Bw=[[0], [1]],
        Dv=np.eye(2),
        Qw=0.1,
        Rv=[1.0, 0.5],
    )
    args.update(kw)
    return gf.WindowModel(
        [[1, 1], [-1, 1]], [[0], [1]], [[1, 0], [1, 0]], nullspace=nullspace, **args
    )


def satellite(nullspace: str = "structured") -> gf.WindowModel:
    dt, tau = 0.1, 1 / 11
    return gf.WindowModel(
        [[1, -dt, -dt], [0, 1 - dt / tau, 0], [0, 0, 1]],
        dt * np.eye(3),
        [1, 0, 0],
        Bf=[[dt, 0], [0, 0], [0, 0]],
        Df=[0, 1],
        Bw=np.eye(3),
        Dv=1,
        Qw=[1e-6, 1e-5, 1e-4],
        Rv=1e-4,
        nullspace=nullspace,
    )


def random_model(seed: int, nullspace: str = "structured") -> gf.WindowModel:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 5))
    m = int(rng.integers(1, 4))
    p = int(rng.integers(1, 4))
    nu = int(rng.integers(0, 3))
    window = n + 1 + int(rng.integers(0, 2))
    return gf.WindowModel(
        rng.standard_normal((n, n)) / math.sqrt(n),
        rng.standard_normal((n, nu)) if nu else None,
        rng.standard_normal((m, n)),
        rng.standard_normal((m, nu)) if nu else None,
        Bf=rng.standard_normal((n, p)),
        Df=rng.standard_normal((m, p)) * (rng.random((m, p)) < 0.5),
        Qw=float(rng.uniform(0.01, 1.0)),
        Rv=rng.uniform(0.01, 1.0, m),
        window=window,
        nullspace=nullspace,
    )


def simulate(dm: gf.WindowModel, runs: int, rng, fault=None, theta=None, *, noise=True):
    """Vectorised simulation over ``runs`` windows; returns z_s, x_s, f_s, e_s stacks."""
    n, m, s, p = dm.n, dm.m, dm.window, dm.p
    nu, l, t = dm.B.shape[1], dm.Bw.shape[1], dm.Dv.shape[1]

    def sqrtm(S):
        w, V = np.linalg.eigh(S)
        return V * np.sqrt(np.clip(w, 0, None)) * float(noise)

    W = rng.standard_normal((runs, s, l)) @ sqrtm(dm.Qw).T
    V = rng.standard_normal((runs, s, t)) @ sqrtm(dm.Rv).T
    U = rng.standard_normal((runs, s, nu))
    Fs = np.zeros((runs, s, p))
    if fault is not None:
        Fs[:, :, fault] = theta
    X = np.zeros((runs, s + 1, n))
    X[:, 0] = 5.0 * rng.standard_normal((runs, n))
    Y = np.zeros((runs, s, m))
    for k in range(s):
        Y[:, k] = X[:, k] @ dm.C.T + U[:, k] @ dm.D.T + Fs[:, k] @ dm.Df.T + V[:, k] @ dm.Dv.T
        X[:, k + 1] = X[:, k] @ dm.A.T + U[:, k] @ dm.B.T + Fs[:, k] @ dm.Bf.T + W[:, k] @ dm.Bw.T
    z = np.hstack([Y.reshape(runs, -1), U.reshape(runs, -1)])
    e = np.hstack([W.reshape(runs, -1), V.reshape(runs, -1)])
    return z, X.reshape(runs, -1), Fs.reshape(runs, -1), e


# --------------------------------------------------------------------------- Tables 1-2
@pytest.mark.parametrize("path", PATHS)
def test_table1_kl_reproduced(path):
    tab = model23(path).table(THETA, "kl")
    np.testing.assert_allclose(tab.values, TABLE1, atol=5e-5, rtol=0)
    # the exact fractions of the paper
    np.testing.assert_allclose(
        tab.detectability, [5 / 31, 5 / 31, 284 / 279, 299 / 279], rtol=1e-12
    )
    assert tab.isolability[0, 1] == 0.0 and tab.isolability[1, 0] == 0.0  # FI(f1, f2) = 0
    # KL isolability is not symmetric (FI(f1, f3) = 0.1087, FI(f3, f1) = 1)
    assert abs(tab.isolability[0, 2] - tab.isolability[2, 0]) > 0.5


@pytest.mark.parametrize("path", PATHS)
def test_table2_directional_reproduced(path):
    tab = model23(path).table(THETA, "directional")
    # the paper prints 0.0614 for FI(f3, f4); the value is 0.06134
    np.testing.assert_allclose(tab.values, TABLE2, atol=1e-4, rtol=0)
    assert tab.isolability[2, 3] == pytest.approx(0.06134, abs=1e-5)
    others = np.ones_like(TABLE2, dtype=bool)
    others[2, 4] = others[3, 3] = False
    np.testing.assert_allclose(tab.values[others], TABLE2[others], atol=5e-5, rtol=0)
    np.testing.assert_array_equal(tab.isolability, tab.isolability.T)  # symmetric
    assert tab.isolability[0, 1] == 0.0  # collinear fault vectors: FI(f1, f2) = 0
    assert np.all(np.diag(tab.isolability) == 0.0)


def test_table2_needs_absolute_cosine():
    dm = model23()
    signed = dm.table(THETA, "directional", cosine="signed").isolability
    absolute = dm.table(THETA, "directional", cosine="absolute").isolability
    # q3 and q4 point into opposite half-spaces: only |cos| gives the paper's 0.0613
    q3, q4 = dm.fault_vector(2, THETA), dm.fault_vector(3, THETA)
    assert q3 @ q4 < 0
    assert signed[2, 3] == pytest.approx(0.2463, abs=5e-5)
    assert np.all(signed >= absolute - 1e-15)
    assert signed[0, 2] == absolute[0, 2]  # positive cosines: both conventions agree


def test_directional_formula_matches_cosine():
    dm = model23()
    q1, q3 = dm.fault_vector(0, THETA), dm.fault_vector(2, THETA)
    c = abs(q1 @ q3) / np.linalg.norm(q1) / np.linalg.norm(q3)
    for kappa in (1.0, 3.0, 5.0):
        expected = 1 / (kappa * math.sqrt(2 / (1 - c)) + 1)
        assert dm.directional_isolability(0, 2, THETA, kappa) == pytest.approx(expected)
    assert dm.directional_isolability(0, 2, THETA, 1.0) > dm.directional_isolability(
        0, 2, THETA, 5.0
    )
    d = dm.residual_dim
    fd = 1 / ((2 * math.pi) ** (-d / 2) * math.exp(-0.5 * q1 @ q1) + 1)
    assert dm.directional_detectability(0, THETA) == pytest.approx(fd)


# --------------------------------------------------------------------------- Theorems 1-2
def test_applicability_model23():
    rep = model23().applicability(THETA)
    # the paper: model (23) satisfies Theorems 1 and 2, so both methods apply
    assert rep.theorem1 and rep.theorem2
    assert rep.kl_detectability and rep.kl_isolability
    assert rep.outputs == 2 and rep.residual_dim == 4
    assert [f.rref_row_nonzeros for f in rep.faults] == [(1,), (1,), (1, 1, 1), (1, 1, 1)]
    # beside the paper: f1, f2 reach the outputs only through their first sample
    assert [f.rank for f in rep.faults] == [1, 1, 3, 3]
    assert [f.undetectable_dim for f in rep.faults] == [2, 2, 0, 0]
    assert all(f.theta_detectable for f in rep.faults)
    assert any("f1" in r and "undetectable" in r for r in rep.reasons)
    dm = model23()
    assert dm.kl_detectability(0, [0.0, 1.0, 1.0]) == pytest.approx(0.0, abs=1e-24)
    assert "Theorem 1" in str(rep) and "holds" in str(rep)


def test_applicability_satellite():
    rep = satellite().applicability([0.1] * 4)
    # the paper: rref(N_H F_i) rows carry 3 and 4 non-zeros, and m = 1
    assert [f.rref_row_nonzeros for f in rep.faults] == [(3,), (4,)]
    assert not rep.theorem1 and not rep.theorem2
    assert not rep.kl_detectability and not rep.kl_isolability
    assert [f.theta_detectable for f in rep.faults] == [False, False]
    assert [f.isolation_dof for f in rep.faults] == [0, 0]
    rep_ramp = satellite().applicability([0.1, 0.3, 0.7, 0.9])
    assert [f.theta_detectable for f in rep_ramp.faults] == [True, True]


def test_applicability_same_for_both_paths():
    for seed in range(5):
        a = random_model(seed, "structured").applicability()
        b = random_model(seed, "direct").applicability()
        assert a.faults == b.faults and a.theorem1 == b.theorem1


# --------------------------------------------------------------------------- satellite
@pytest.mark.parametrize("path", PATHS)
def test_satellite_tables_3_and_4(path):
    dm = satellite(path)
    assert dm.residual_dim == 1
    t3 = dm.table([0.1] * 4, "directional")
    np.testing.assert_allclose(t3.detectability, [0.7148, 0.7148], atol=5e-5)
    np.testing.assert_array_equal(t3.isolability, 0.0)
    t4 = dm.table([0.1, 0.3, 0.7, 0.9], "directional", cosine="signed")
    np.testing.assert_allclose(t4.detectability, [0.9300, 1.0000], atol=5e-5)
    np.testing.assert_allclose(t4.isolability, [[0, 0.25], [0.25, 0]], atol=1e-12)
    # absolute cosine: in d = 1 every pair is collinear, so Table 4's 0.25 is lost
    t4a = dm.table([0.1, 0.3, 0.7, 0.9], "directional", cosine="absolute")
    np.testing.assert_array_equal(t4a.isolability, 0.0)
    # KL: nothing isolable (m = 1), constant biases undetectable
    np.testing.assert_allclose(dm.table([0.1] * 4, "kl").values, 0.0, atol=1e-20)


def test_flaw_directional_fd_of_undetectable_fault():
    """docs/theory/diagnosability.md:
    q = 0 gives 1/((2 pi)^(-d/2) + 1), not 0; P_D gives alpha, index 0."""
    for dm, i, theta in ((satellite(), 0, [0.1] * 4), (model23(), 0, [0.0, 1.0, 1.0])):
        d = dm.residual_dim
        assert np.allclose(dm.fault_vector(i, theta), 0.0, atol=1e-12)
        fd = dm.directional_detectability(i, theta)
        assert fd == pytest.approx(1 / ((2 * math.pi) ** (-d / 2) + 1), rel=1e-12)
        assert fd > 0.7  # 0.7148 for d = 1 (Table 3), 0.9753 for d = 4
        assert dm.detection_probability(i, theta, 0.05) == pytest.approx(0.05, rel=1e-9)
        assert dm.probabilistic_detectability(i, theta, 0.05) == 0.0
        assert dm.kl_detectability(i, theta) == pytest.approx(0.0, abs=1e-20)
    assert satellite().directional_detectability(0, [0.1] * 4) == pytest.approx(0.7148, abs=5e-5)


# --------------------------------------------------------------------------- probabilities
def test_probability_indices_formulas():
    dm = model23()
    alpha = 0.01
    q3 = dm.fault_vector(2, THETA)
    thr = stats.chi2.isf(alpha, 4)
    assert dm.detection_probability(2, THETA, alpha) == pytest.approx(
        stats.ncx2.sf(thr, 4, q3 @ q3)
    )
    # non-centrality = 2 FD_KL; isolation non-centrality = 2 FI_KL with d - rank dof
    lam = 2 * dm.kl_isolability(2, 0, THETA)
    dof = 4 - np.linalg.matrix_rank(dm.fault_matrix(0))
    assert dm.isolation_probability(2, 0, THETA, alpha) == pytest.approx(
        stats.ncx2.sf(stats.chi2.isf(alpha, dof), dof, lam)
    )
    # f1, f2 indistinguishable: isolation probability is the false-alarm rate
    assert dm.isolation_probability(0, 1, THETA, alpha) == pytest.approx(alpha)
    assert dm.probabilistic_isolability(0, 1, THETA, alpha) == 0.0
    # monotone in the fault size, -> 1
    pds = [dm.detection_probability(2, a * np.ones(3), alpha) for a in (0.5, 1, 2, 4, 8)]
    assert np.all(np.diff(pds) > 0) and pds[-1] > 0.999
    # satellite d = 1: no isolation test exists, probability alpha
    sat = satellite()
    assert sat.isolation_probability(1, 0, [0.1, 0.3, 0.7, 0.9], 0.02) == 0.02


def test_monte_carlo_detection_and_isolation_rates():
    """Simulated windows: r = R z_s ~ N(q_i, I); empirical rates match P_D, P_I, alpha."""
    dm = model23()
    rng = np.random.default_rng(7)
    runs, alpha = 20000, 0.05
    R = dm.residual_generator()
    theta = 2.5 * np.ones(3)
    d = dm.residual_dim
    thr = stats.chi2.isf(alpha, d)

    def close(rate, p):
        return abs(rate - p) < 4.5 * math.sqrt(p * (1 - p) / runs)

    z, *_ = simulate(dm, runs, rng)
    r0 = z @ R.T
    assert close(np.mean(np.sum(r0**2, axis=1) > thr), alpha)
    np.testing.assert_allclose(np.cov(r0.T), np.eye(d), atol=0.05)

    z, *_ = simulate(dm, runs, rng, fault=2, theta=theta)
    r = z @ R.T
    np.testing.assert_allclose(r.mean(axis=0), dm.fault_vector(2, theta), atol=0.05)
    assert close(np.mean(np.sum(r**2, axis=1) > thr), dm.detection_probability(2, theta, alpha))

    # isolation test of f3 against f1: project out Im Phi_1
    U, sv, _ = np.linalg.svd(dm.fault_matrix(0))
    P = U[:, np.sum(sv > 1e-10) :]  # orthonormal basis of the complement of Im Phi_1
    thr_j = stats.chi2.isf(alpha, P.shape[1])
    assert close(
        np.mean(np.sum((r @ P) ** 2, axis=1) > thr_j),
        dm.isolation_probability(2, 0, theta, alpha),
    )
    # f1 with an arbitrary (large) profile: rejected only at the false-alarm rate
    z, *_ = simulate(dm, runs, rng, fault=0, theta=[30.0, -12.0, 7.0])
    r1 = z @ R.T
    assert close(np.mean(np.sum((r1 @ P) ** 2, axis=1) > thr_j), alpha)


@pytest.mark.parametrize("path", PATHS)
def test_stacked_model_equation_2_holds_on_simulation(path):
    dm = random_model(3, path)
    z, x, f, e = simulate(dm, 5, np.random.default_rng(1))
    stw = dm.stacked()
    n, m, s, p = dm.n, dm.m, dm.window, dm.p
    assert stw.H.shape == ((n + m) * s, n * (s + 1))
    assert stw.F.shape == ((n + m) * s, p * s)
    lhs = z @ stw.L.T
    rhs = x @ stw.H.T + f @ stw.F.T + e @ stw.E.T
    np.testing.assert_allclose(lhs, rhs, atol=1e-9 * (1 + np.abs(lhs).max()))
    # noise-free windows: the residual removes the state and the known input, and a
    # fault leaves exactly its vector q_i (same basis as fault_vector)
    R = dm.residual_generator()
    rng = np.random.default_rng(2)
    z0, *_ = simulate(dm, 4, rng, noise=False)
    np.testing.assert_allclose(z0 @ R.T, 0.0, atol=1e-9 * np.abs(z0).max())
    theta = rng.standard_normal(s)
    z1, *_ = simulate(dm, 4, rng, fault=p - 1, theta=theta, noise=False)
    q = dm.fault_vector(p - 1, theta)
    np.testing.assert_allclose(z1 @ R.T, np.tile(q, (4, 1)), atol=1e-8 * np.abs(z1).max())


# --------------------------------------------------------------------------- null spaces
@pytest.mark.parametrize("make", [model23, satellite])
def test_null_space_paths_same_projector(make):
    Nd = make().left_null_basis("direct")
    Ns = make().left_null_basis("structured")
    H = make().stacked().H
    for N in (Nd, Ns):
        np.testing.assert_allclose(N @ N.T, np.eye(N.shape[0]), atol=1e-12)
        np.testing.assert_allclose(N @ H, 0.0, atol=1e-12)
    np.testing.assert_allclose(Nd.T @ Nd, Ns.T @ Ns, atol=1e-12)


@settings(max_examples=25)
@given(seed=st.integers(0, 10_000))
def test_paths_agree_on_random_plants(seed):
    a, b = random_model(seed, "structured"), random_model(seed, "direct")
    Na, Nb = a.left_null_basis(), b.left_null_basis()
    assert Na.shape == Nb.shape
    assert (
        a.residual_dim
        == b.residual_dim
        == a.m * a.window - np.linalg.matrix_rank(a.observability_matrix())
    )
    np.testing.assert_allclose(Na.T @ Na, Nb.T @ Nb, atol=1e-9)
    theta = np.random.default_rng(seed).standard_normal(a.window)
    for method in ("kl", "directional", "probability"):
        ta, tb = a.table(theta, method), b.table(theta, method)
        np.testing.assert_allclose(ta.values, tb.values, rtol=1e-7, atol=1e-9)
    # the fault vectors differ by a rotation: same Gram matrix
    Qa = np.column_stack([a.fault_vector(i, theta) for i in range(a.p)])
    Qb = np.column_stack([b.fault_vector(i, theta) for i in range(b.p)])
    np.testing.assert_allclose(Qa.T @ Qa, Qb.T @ Qb, rtol=1e-7, atol=1e-9)


@settings(max_examples=25)
@given(seed=st.integers(0, 10_000))
def test_kl_isolability_is_minimum_over_profiles_of_fj(seed):
    dm = random_model(seed)
    rng = np.random.default_rng(seed)
    theta = rng.standard_normal(dm.window)
    i, j = int(rng.integers(dm.p)), int(rng.integers(dm.p))
    fi = dm.kl_isolability(i, j, theta)
    q = dm.fault_vector(i, theta)
    Phi = dm.fault_matrix(j)
    best, *_ = np.linalg.lstsq(Phi, q, rcond=None)
    assert 0.5 * np.sum((q - Phi @ best) ** 2) == pytest.approx(fi, rel=1e-6, abs=1e-9)
    for _ in range(5):
        other = best + rng.standard_normal(dm.window)
        assert 0.5 * np.sum((q - Phi @ other) ** 2) >= fi - 1e-9
    assert fi <= dm.kl_detectability(i, theta) + 1e-12
    assert dm.kl_isolability(i, i, theta) == pytest.approx(0.0, abs=1e-9)


@settings(max_examples=20)
@given(seed=st.integers(0, 10_000))
def test_directional_isolability_symmetric_and_bounded(seed):
    dm = random_model(seed)
    theta = np.random.default_rng(seed).standard_normal(dm.window)
    for cosine in ("absolute", "signed"):
        fi = dm.table(theta, "directional", cosine=cosine).isolability
        np.testing.assert_allclose(fi, fi.T, atol=1e-12)
        assert np.all((fi >= 0) & (fi < 1))
        assert np.all(np.diag(fi) == 0)


def test_structured_path_handles_long_window_quickly():
    rng = np.random.default_rng(0)
    n = 60
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    dm = gf.WindowModel(
        0.95 * Q,
        None,
        rng.standard_normal((2, n)),
        Bf=rng.standard_normal((n, 2)),
        Qw=0.01,
        Rv=0.1,
    )
    tab = dm.table(np.ones(n + 1), "kl")
    assert dm.residual_dim == 2 * (n + 1) - n
    assert np.all(np.isfinite(tab.values)) and np.all(tab.detectability > 0)


# --------------------------------------------------------------------------- tables, plots
def test_table_object_and_text():
    dm = model23(fault_names=["a1", "a2", "s1", "s2"])
    tab = dm.table(THETA, "kl")
    assert tab.values.shape == (4, 5)
    assert tab.fault_names == ("a1", "a2", "s1", "s2")
    lines = str(tab).splitlines()
    assert lines[0].split() == ["FD", "a1", "a2", "s1", "s2"]
    assert lines[1].split() == ["a1", "0.1613", "0.0000", "0.0000", "0.1087", "0.0549"]
    # one profile per fault equals the individual calls
    thetas = np.array([[1, 1, 1], [0, 1, 0], [1, 2, 3], [-1, 0, 1]], dtype=float)
    per = gf.diagnosability_table(dm, thetas, "directional", kappa=2.0)
    assert per.values[2, 0] == pytest.approx(dm.directional_detectability(2, thetas[2]))
    assert per.values[2, 4] == pytest.approx(
        dm.directional_isolability(2, 3, thetas[2], 2.0, theta_j=thetas[3])
    )
    assert per.options["kappa"] == 2.0
    idx = dm.table(THETA, "probability_index", alpha=0.05).values
    raw = dm.table(THETA, "probability", alpha=0.05).values
    np.testing.assert_allclose(idx, (raw - 0.05) / 0.95, atol=1e-12)


def test_plot_isolability_heat_map():
    import matplotlib.figure

    tab = model23().table(THETA, "directional")
    fig = gf.plot_isolability(tab)
    assert isinstance(fig, matplotlib.figure.Figure)
    ax = fig.axes[0]
    np.testing.assert_array_equal(ax.images[0].get_array(), tab.isolability)
    assert len(ax.texts) == 16
    assert [t.get_text() for t in ax.get_xticklabels()] == ["f1", "f2", "f3", "f4"]
    zero = satellite().table([0.1] * 4, "kl")
    assert isinstance(gf.plot_isolability(zero), matplotlib.figure.Figure)
    with pytest.raises(GeomFDIError) as exc:
        gf.plot_isolability(tab.values)
    assert exc.value.argument == "table"


def test_doctest_examples():
    res = doctest.testmod(diag, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert res.attempted > 0 and res.failed == 0


# --------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("kwargs", "argument"),
    [
        ({"Qw": [[0.1, 0.0], [0.0, -0.1]], "Bw": np.eye(2)}, "Qw"),  # not PSD
        ({"Qw": -0.1}, "Qw"),
        ({"Rv": [1.0, -0.5]}, "Rv"),
        ({"Rv": [[1.0, 2.0], [2.0, 1.0]]}, "Rv"),  # symmetric, indefinite
        ({"Rv": [[1.0, 0.3], [0.0, 1.0]]}, "Rv"),  # not symmetric
        ({"Rv": [1.0, 0.5, 0.2]}, "Rv"),  # wrong size
        ({"Qw": [[np.nan]]}, "Qw"),
        ({"window": 0}, "window"),
        ({"window": -3}, "window"),
        ({"window": 2.5}, "window"),
        ({"Bf": np.ones((3, 2))}, "Bf"),
        ({"Df": np.ones((2, 3))}, "Df"),
        ({"fault_names": ["a"]}, "fault_names"),
        ({"nullspace": "qr"}, "nullspace"),
    ],
)
def test_bad_model_input(kwargs, argument):
    with pytest.raises(GeomFDIError) as exc:
        model23(**kwargs)
    assert exc.value.argument == argument
    assert argument in str(exc.value)


def test_bad_call_input():
    dm = model23()
    cases = [
        (lambda: dm.kl_detectability(4, THETA), "i"),
        (lambda: dm.kl_detectability(-1, THETA), "i"),
        (lambda: dm.kl_isolability(0, 7, THETA), "j"),
        (lambda: dm.directional_isolability(5, 0, THETA), "i"),
        (lambda: dm.kl_detectability(0, [1.0, 1.0]), "theta"),
        (lambda: dm.directional_detectability(0, np.ones(4)), "theta"),
        (lambda: dm.directional_isolability(0, 2, THETA, theta_j=[1.0]), "theta_j"),
        (lambda: dm.directional_isolability(0, 2, THETA, kappa=0.0), "kappa"),
        (lambda: dm.directional_isolability(0, 2, THETA, cosine="cos"), "cosine"),
        (lambda: dm.detection_probability(0, THETA, alpha=1.0), "alpha"),
        (lambda: dm.table(THETA, "bayes"), "method"),
        (lambda: dm.table(np.ones((3, 3)), "kl"), "theta"),
        (lambda: dm.left_null_basis("eig"), "method"),
        (lambda: gf.diagnosability_table("model", THETA), "model"),
    ]
    for call, argument in cases:
        with pytest.raises(GeomFDIError) as exc:
            call()
        assert exc.value.argument == argument, argument
        assert argument in str(exc.value)


def test_noise_free_residual_and_short_window():
    with pytest.raises(RankDeficientError) as exc:
        model23(Qw=0.0, Rv=[0.0, 0.0]).kl_detectability(0, THETA)
    assert exc.value.argument == "Rv"
    # one output, two states, window 1: no parity relation
    dm = gf.WindowModel([[1, 1], [0, 1]], None, [[1, 0]], Bf=[[1], [0]], Qw=1, Rv=1, window=1)
    with pytest.raises(DesignError) as exc2:
        dm.kl_detectability(0, [1.0])
    assert exc2.value.argument == "window"
    with pytest.raises(ShapeError):
        gf.WindowModel([[1, 1], [0, 1]], None, [[1, 0, 0]], Bf=[[1], [0]], Qw=1, Rv=1)


# ------------------------------------------------------------------ numerics at extreme sizes
@pytest.mark.parametrize("size", [1e-150, 1e-20, 1e10, 1e100, 1e150])
def test_indices_scale_exactly_with_the_fault_size(size):
    dm = model23()
    ref = gf.diagnosability_table(dm, THETA, "kl").values
    big = gf.diagnosability_table(dm, np.asarray(THETA) * size, "kl").values
    assert np.allclose(big, ref * size**2, rtol=1e-12, atol=0)
    # the directional isolability depends on directions only; the probabilities saturate
    dref = gf.diagnosability_table(dm, THETA, "directional").isolability
    dbig = gf.diagnosability_table(dm, np.asarray(THETA) * size, "directional").isolability
    assert np.allclose(dref, dbig, rtol=1e-12, atol=1e-15)
    prob = gf.diagnosability_table(dm, np.asarray(THETA) * size, "probability").values
    assert np.isfinite(prob).all() and np.all(prob >= 0.01 - 1e-15) and np.all(prob <= 1)
    if size >= 1e10:
        assert prob[2, 0] == pytest.approx(1.0) and prob[3, 1 + 2] == pytest.approx(1.0)
    if size <= 1e-20:
        assert np.allclose(prob, 0.01, atol=1e-12)


@pytest.mark.parametrize("size", [1e155, 1e-170])
def test_kl_index_outside_the_float_range_is_a_named_error(size):
    with pytest.raises(GeomFDIError, match="theta"):
        gf.diagnosability_table(model23(), np.asarray(THETA) * size, "kl")
    # the other indices stay meaningful: directional by direction, probability saturates
    prob = gf.diagnosability_table(model23(), np.asarray(THETA) * size, "probability")
    assert np.isfinite(prob.values).all()


@pytest.mark.parametrize("window", [0, -1, 2.5, "x"])
def test_bad_window_is_a_named_error(window):
    with pytest.raises(GeomFDIError, match="window"):
        gf.WindowModel(
            [[1, 1], [-1, 1]],
            [[0], [1]],
            [[1, 0], [1, 0]],
            Bf=[[0], [1]],
            Qw=0.1,
            Rv=1,
            window=window,
        )
