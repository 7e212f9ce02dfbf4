"""``geomfdi campaign MODEL.toml`` and the campaign example script."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pandas as pd
import pytest

from geomfdi.io.cli import main

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_cli_campaign_writes_tables_and_figures(tmp_path, capsys):
    out = tmp_path / "c"
    code = main(
        [
            "campaign",
            str(ROOT / "examples" / "discrete_disturbance.toml"),
            "--runs",
            "3",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    text = capsys.readouterr().out
    assert "bias on sensor 1" in text and "gain on sensor 2" in text
    tb = pd.read_csv(out / "campaign.csv")
    # 2 scenarios x 6 sizes x 1 onset x 3 runs, 4 residuals + bank each
    assert len(tb) == 2 * 6 * 3 * 5
    summ = pd.read_csv(out / "summary.csv")
    assert {"pd", "far", "delay_median", "iso_correct", "iso_wrong", "iso_none"} <= set(
        summ.columns
    )
    assert {"true_fault", "isolated", "isolation", "isolation_delay"} <= set(tb.columns)
    conf = pd.read_csv(out / "confusion.csv", index_col=0)
    assert list(conf.columns)[-2:] == ["multiple", "none"]
    assert conf.to_numpy().sum() == 2 * 6 * 3  # every run once
    assert "confusion (runs; rows: true fault" in text
    assert (out / "confusion.png").read_bytes()[:4] == b"\x89PNG"
    for name in ("roc_bias-on-sensor-1", "detection_gain-on-sensor-2"):
        assert (out / f"{name}.png").read_bytes()[:4] == b"\x89PNG"


def test_cli_campaign_errors(tmp_path, capsys):
    assert (
        main(["campaign", str(ROOT / "examples" / "hou_wen_chen.toml"), "--out", str(tmp_path)])
        == 2
    )
    assert "no [campaign] table" in capsys.readouterr().err
    bad = tmp_path / "bad.toml"
    text = (ROOT / "examples" / "discrete_disturbance.toml").read_text()
    bad.write_text(text.replace("runs = 100", "runs = 100\nbogus = 1"))
    assert main(["campaign", str(bad), "--out", str(tmp_path)]) == 2
    assert "bogus" in capsys.readouterr().err
    bad.write_text(text.replace('test = {type = "chi2"', 'test = {type = "sprt"'))
    assert main(["campaign", str(bad), "--out", str(tmp_path)]) == 2


def test_campaign_persistence_entry(tmp_path, capsys):
    import geomfdi as gf
    from geomfdi.io.cli import load_campaign

    text = (ROOT / "examples" / "discrete_disturbance.toml").read_text()
    path = tmp_path / "p.toml"
    path.write_text(
        text.replace("runs = 100", "runs = 2\npersistence = {k = 2, n = 3, reset = 50}")
    )
    assert load_campaign(path).campaign.persistence == gf.Persistence(2, 3, reset=50)
    path.write_text(text.replace("runs = 100", "runs = 2\npersistence = [2, 4]"))
    assert load_campaign(path).campaign.persistence == gf.Persistence(2, 4)
    for bad in ("[3, 2]", '"x"', "{k = 2, n = 3, hold = 1}"):
        path.write_text(text.replace("runs = 100", f"runs = 2\npersistence = {bad}"))
        assert main(["campaign", str(path), "--out", str(tmp_path)]) == 2
        assert "campaign.persistence" in capsys.readouterr().err


@pytest.mark.slow
def test_campaign_example_script_saves_the_figures(tmp_path):
    spec = importlib.util.spec_from_file_location(
        "campaign_roc", ROOT / "examples" / "campaign_roc.py"
    )
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    results = mod.main([str(tmp_path), "--runs", "2"])
    assert set(results) == {"hou_wen_chen", "hou_wen_chen_uncertain", "discrete_disturbance"}
    pngs = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*.png"))
    assert "hou_wen_chen/roc_bias-on-sensor-0.png" in pngs
    assert "discrete_disturbance/detection_gain-on-sensor-2.png" in pngs
    # ROC and detection figures per scenario, and one confusion matrix per campaign
    assert "hou_wen_chen/confusion.png" in pngs
    assert len(pngs) == 3 * 2 + 2 + 2 * 2 + 3
    # a large bias on sensor 1 of Hou, Wen & Chen (2011) is always detected
    s = results["hou_wen_chen"].summary().xs("bank", level="residual")
    assert s.loc[("bias on sensor 1", 0.03), "pd"] == 1.0


@pytest.mark.slow
def test_cli_campaign_from_a_saved_bank_with_progress(tmp_path, capsys):
    from geomfdi.io.cli import design_all
    from geomfdi.io.modelfile import load_model

    model = ROOT / "examples" / "discrete_disturbance.toml"
    bank = next(iter(design_all(load_model(model)).values()))
    bank.save(tmp_path / "bank.json")
    args = ["campaign", str(model), "--runs", "2", "--no-plots", "--progress"]
    assert main([*args, "--out", str(tmp_path / "a"), "--bank", str(tmp_path / "bank.json")]) == 0
    assert main([*args, "--out", str(tmp_path / "b")]) == 0
    a = pd.read_csv(tmp_path / "a" / "campaign.csv")
    b = pd.read_csv(tmp_path / "b" / "campaign.csv")
    pd.testing.assert_frame_equal(a, b)  # the saved bank is the designed one
    (tmp_path / "bad.json").write_text("{}")
    bad = main([*args, "--out", str(tmp_path / "c"), "--bank", str(tmp_path / "bad.json")])
    assert bad == 2 and "bad.json" in capsys.readouterr().err


@pytest.mark.slow
def test_cli_campaign_on_a_local_dask_cluster_gives_the_serial_table(tmp_path):
    pytest.importorskip("distributed")
    model = str(ROOT / "examples" / "discrete_disturbance.toml")
    args = ["campaign", model, "--runs", "2", "--no-plots", "--quiet"]
    assert main([*args, "--out", str(tmp_path / "s"), "--executor", "serial"]) == 0
    dask_args = ["--executor", "dask", "--workers", "2"]
    assert main([*args, "--out", str(tmp_path / "d"), *dask_args]) == 0
    a = pd.read_csv(tmp_path / "s" / "campaign.csv")
    b = pd.read_csv(tmp_path / "d" / "campaign.csv")
    pd.testing.assert_frame_equal(a, b, check_exact=True)
