"""ROC curves, binomial intervals and the curve plots."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.stats import norm

import geomfdi as gf
from geomfdi.errors import GeomFDIError


def test_roc_hand_case():
    c = gf.roc_curve([0.1, 0.2, 0.3, 0.4], [0.25, 0.35, 0.5], label="x")
    # thresholds from +inf down through every score; alarm when score > threshold
    assert c.thresholds[0] == np.inf and c.far[0] == 0 and c.pd[0] == 0
    i = list(c.thresholds).index(0.3)  # scores > 0.3: healthy 0.4; faulty 0.35, 0.5
    assert c.far[i] == pytest.approx(0.25) and c.pd[i] == pytest.approx(2 / 3)
    assert c.far[-1] == pytest.approx(0.0 + 3 / 4)  # lowest threshold 0.1: 3 of 4 healthy
    assert c.pd_at(0.25) == pytest.approx(2 / 3)
    # AUC = P(faulty > healthy): pairs (0.25>0.1,0.2), (0.35>0.1..0.3), (0.5>all) = 9/12
    assert c.auc == pytest.approx(9 / 12)


def test_roc_auc_of_gaussian_shift():
    rng = np.random.default_rng(0)
    h, f = rng.standard_normal(4000), rng.standard_normal(4000) + 1.0
    assert gf.roc_curve(h, f).auc == pytest.approx(norm.cdf(1 / np.sqrt(2)), abs=0.015)
    assert gf.roc_curve(h, h.copy()).auc == pytest.approx(0.5, abs=1e-12)


def test_wilson_interval():
    lo, hi = gf.wilson_interval(0, 20)
    assert lo == pytest.approx(0.0, abs=1e-12) and hi == pytest.approx(0.1611, abs=1e-3)
    lo, hi = gf.wilson_interval(np.array([10, 50]), np.array([20, 100]))
    assert np.all(lo < 0.5) and np.all(hi > 0.5) and (hi - lo)[1] < (hi - lo)[0]
    with pytest.raises(GeomFDIError):
        gf.wilson_interval(3, 2)


def test_curve_plots_are_saved(tmp_path):
    from PIL import Image

    c1 = gf.roc_curve([0.1, 0.2, 0.3], [0.25, 0.5, 0.7], label="a")
    c2 = gf.roc_curve([0.1, 0.2, 0.3], [0.05, 0.15, 0.7], label="b")
    fig = gf.plot_roc([c1, c2], title="ROC")
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert labels == [f"a (AUC {c1.auc:.3f})", f"b (AUC {c2.auc:.3f})"]
    p = gf.save_png(fig, tmp_path / "roc")
    assert Image.open(p).size[0] > 300
    df = pd.DataFrame(
        {
            "pd": [0.01, 0.5, 1.0],
            "pd_low": [0, 0.4, 0.9],
            "pd_high": [0.05, 0.6, 1.0],
            "delay_median": [np.nan, 0.3, 0.1],
        },
        index=pd.Index([0.0, 0.5, 1.0], name="size"),
    )
    fig = gf.plot_detection({"bank": df})
    assert len(fig.axes) == 2
    np.testing.assert_allclose(fig.axes[0].lines[0].get_ydata(), df["pd"])
    assert gf.save_png(fig, tmp_path / "det.png").exists()
    with pytest.raises(GeomFDIError):
        gf.plot_roc([])
