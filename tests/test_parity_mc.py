"""Monte-Carlo behaviour of the parity-space tests.

Zhang, Chen & Liu (2005), Theorem 1; the experiment of Qin & Niu (1999).
"""

from __future__ import annotations

import matplotlib
import numpy as np
import pytest

import geomfdi as gf

N_FA = 200_000


def four_se(p: float, n: int) -> float:
    return 4.0 * np.sqrt(p * (1.0 - p) / n)


def random_configs():
    rng = np.random.default_rng(2024)
    out = []
    for m, n in [(5, 3), (6, 3), (7, 3), (6, 2), (8, 4)]:
        out.append(rng.standard_normal((m, n)))
    return out


@pytest.mark.parametrize("alpha", [0.05, 0.01])
@pytest.mark.parametrize(
    "H", [gf.parity.dodecahedron(), gf.parity.cone(5), *random_configs()[:2]], ids=range(4)
)
def test_glt_false_alarm_rate_matches_the_nominal_rate(H, alpha):
    pf = gf.ParityFDI(H, sigma=0.3)
    r = gf.parity.false_alarm_rate(pf, alpha, N_FA, rng=1)
    assert r.n_runs == N_FA
    assert abs(r.rate - alpha) < four_se(alpha, N_FA), r.rate
    lo, hi = r.ci(0.999)
    assert lo < alpha < hi
    # corrected OPT decides like the GLT (Theorem 4): same draws, same alarms
    r_opt = gf.parity.false_alarm_rate(pf, alpha, N_FA, rng=1, method="opt")
    assert r_opt.count == r.count


def test_theorem_1_on_the_dodecahedron():
    pf = gf.ParityFDI(gf.parity.dodecahedron(), sigma=2.0)
    for alpha in (0.05, 0.01):
        bound = gf.parity.opt_false_alarm_bound(alpha, 3)
        r = gf.parity.false_alarm_rate(pf, alpha, N_FA, rng=2, method="opt-uncorrected")
        assert r.rate > bound + four_se(bound, N_FA)
        assert r.rate > alpha + 10 * four_se(alpha, N_FA)
    # alpha = 0.05: about four times the nominal rate
    r = gf.parity.false_alarm_rate(pf, 0.05, N_FA, rng=3, method="opt-uncorrected")
    assert 0.19 < r.rate < 0.22


@pytest.mark.parametrize("H", random_configs(), ids=range(5))
def test_theorem_1_bound_on_random_configurations(H):
    alpha = 0.05
    pf = gf.ParityFDI(H)
    s = pf.s
    bound = gf.parity.opt_false_alarm_bound(alpha, s)
    r = gf.parity.false_alarm_rate(pf, alpha, N_FA, rng=4, method="opt-uncorrected")
    assert r.rate >= bound - four_se(bound, N_FA)
    assert r.rate > alpha + four_se(alpha, N_FA) + 0.02


def test_theorem_1_is_an_equality_for_a_single_parity_equation():
    # m - n = 1: all optimal parity residuals are the same up to sign
    pf = gf.ParityFDI(gf.parity.tetrahedron())
    r = gf.parity.false_alarm_rate(pf, 0.05, N_FA, rng=5, method="opt-uncorrected")
    assert abs(r.rate - 0.05) < four_se(0.05, N_FA)


def test_simulate_and_rates():
    pf = gf.ParityFDI(gf.parity.dodecahedron(), sigma=0.01)
    Z0 = gf.parity.simulate(pf, 50_000, rng=6)
    assert Z0.shape == (50_000, 6)
    np.testing.assert_allclose(pf.parity(Z0).std(axis=0), 0.01, rtol=0.03)
    f = np.array([0, 0, 0.05, 0, 0, 0])
    Z1 = gf.parity.simulate(pf, 50_000, rng=6, fault=f, x=[1.0, 2.0, 3.0])
    np.testing.assert_allclose(
        (Z1 - pf.H @ [1.0, 2.0, 3.0]).mean(axis=0), f, atol=4 * 0.01 / np.sqrt(50_000)
    )
    big = gf.parity.correct_isolation_rate(pf, 10 * f, 1e-3, 5000, rng=7)
    assert big.rate == 1.0 and big.detection.rate == 1.0
    small = gf.parity.correct_isolation_rate(pf, f / 2, 1e-3, 20000, rng=8)
    assert 0.0 < small.correct.rate < small.detection.rate < 1.0
    assert small.partial.rate >= small.correct.rate
    none = gf.parity.correct_isolation_rate(pf, np.zeros(6), 0.05, 20000, rng=9)
    assert abs(none.rate - 0.95) < four_se(0.05, 20000)  # "correct" = no alarm
    # the same seed reproduces the same counts; chunking does not change them
    a = gf.parity.correct_isolation_rate(pf, f / 2, 1e-3, 3000, rng=10, chunk=3000)
    b = gf.parity.correct_isolation_rate(pf, f / 2, 1e-3, 3000, rng=10, chunk=3000)
    assert a == b
    assert float(a.correct) == a.rate and a.correct.stderr > 0


def test_rates_vs_fault_size_and_plot():
    pf = gf.ParityFDI(gf.parity.cone(6), sigma=1.0)
    sizes = np.array([0.0, 2.0, 4.0, 7.0, 14.0])
    curve = gf.parity.rates_vs_fault_size(
        pf,
        np.eye(6)[1],
        sizes,
        0.01,
        4000,
        rng=11,
        methods=("glt", ("two-fault GLR", "glr", 1)),
    )
    for lab in ("glt", "two-fault GLR"):
        c = curve.correct[lab]
        d = curve.detection[lab]
        assert np.all(np.diff(d) > 0) and np.all(np.diff(c[1:]) > 0)
        assert d[0] == pytest.approx(0.01, abs=four_se(0.01, 4000))
        # the GLR also tests the residual after removing the isolated sensor: it rejects
        # a correct single-fault explanation with probability pfa
        assert c[-1] > (0.995 if lab == "glt" else 0.97)
    fig = curve.plot()
    assert isinstance(fig, matplotlib.figure.Figure)
    assert len(fig.axes[0].lines) == 4
    matplotlib.pyplot.close(fig)
    with pytest.raises(gf.errors.GeomFDIError) as e:
        gf.parity.rates_vs_fault_size(pf, np.eye(6)[1], sizes, 0.01, 10, methods=[(1, 2)])
    assert e.value.argument == "methods"


def test_seed_004_experiment_small_run():
    res = gf.parity.qin_niu_experiment(sigma=0.0005, n_runs=400, rng=12)
    kinds = res.kinds
    assert len(res.cases) == 12 + 3 * 15
    summ = res.summary()
    single, different, same, opposite = kinds
    for meth in res.methods:
        assert summ[single][meth]["mean"] > 0.98
        assert summ[different][meth]["mean"] > 0.85
    assert res.n_ambiguous(single) == (0, 12) and res.n_ambiguous(different) == (0, 15)
    # equal-size pairs are exactly confounded with another equal-size pair
    assert res.n_ambiguous(same) == (15, 15) and res.n_ambiguous(opposite) == (15, 15)
    glr = "two-fault GLR"
    for kind in (same, opposite):
        assert 0.42 < summ[kind][glr]["mean"] < 0.58  # a coin flip between the two pairs
        assert summ[kind][glr]["min"] > 0.3
    # the single-fault function points at a true gyro for 6 of 15 same-sign pairs and
    # 9 of 15 opposite-sign pairs (Qin & Niu 1999, Tables 3-4): the search follows it
    search = "paper search (Qin-Niu)"
    assert summ[same][search]["mean"] == pytest.approx(6 / 15, abs=0.02)
    assert summ[opposite][search]["mean"] == pytest.approx(9 / 15, abs=0.02)
    text = res.table(detail=True)
    assert "two-fault GLR" in text and "15/15" in text and "(5,6)" in text
    fig = res.plot()
    assert isinstance(fig, matplotlib.figure.Figure)
    matplotlib.pyplot.close(fig)
