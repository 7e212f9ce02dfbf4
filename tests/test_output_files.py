"""Files written by geomfdi commands: never through a planted link, spreadsheet-safe
text cells, validated ``--persistence`` (geomfdi._files, geomfdi.campaign.config,
geomfdi.deployment.commands)."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import geomfdi as gf
from geomfdi._files import csv_text, replace_file, write_text
from geomfdi.campaign.config import write_csv
from geomfdi.deployment.commands import parse_persistence
from geomfdi.errors import GeomFDIError


def test_a_planted_link_is_replaced_not_followed(tmp_path: Path) -> None:
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    out = tmp_path / "out"
    out.mkdir()
    (out / "report.md").symlink_to(victim)
    write_text(out / "report.md", "new report")
    assert victim.read_text() == "precious"
    assert not (out / "report.md").is_symlink()
    assert (out / "report.md").read_text() == "new report"
    assert sorted(p.name for p in out.iterdir()) == ["report.md"]  # no temporary left


def test_a_failed_write_leaves_neither_file_nor_temporary(tmp_path: Path) -> None:
    def fail(tmp: Path) -> None:
        tmp.write_text("half")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError):
        replace_file(tmp_path / "x.csv", fail)
    assert list(tmp_path.iterdir()) == []


def test_cli_evaluate_does_not_write_through_links(tmp_path: Path) -> None:
    from geomfdi.io.cli import main

    model = tmp_path / "m.toml"
    model.write_text(
        'name = "m"\n[plant]\nA = [[0.5]]\nB = [[1.0]]\nC = [[1.0]]\ndt = 0.1\n'
        "[simulation]\nt_end = 1.0\nstep = 0.1\nthreshold = 0.5\n"
    )
    data = tmp_path / "d.csv"
    data.write_text("t,y0,u0\n" + "".join(f"{0.1 * k!r},1,1\n" for k in range(10)))
    victim = tmp_path / "victim"
    victim.write_text("precious")
    out = tmp_path / "out"
    out.mkdir()
    for name in ("residuals.csv", "alarms.csv", "report.md", "residuals.png"):
        (out / name).symlink_to(victim)
    assert main(["evaluate", str(model), str(data), "--out", str(out), "--quiet"]) == 0
    assert victim.read_text() == "precious"
    assert not any(p.is_symlink() for p in out.iterdir())


@pytest.mark.parametrize("text", ["=1+1", "@SUM(A1)", "+1", "-1+2", "\t=1"])
def test_formula_cells_are_escaped(text: str) -> None:
    assert csv_text(text) == "'" + text
    assert csv_text("sensor 0") == "sensor 0" and csv_text(-1.0) == -1.0


def test_campaign_csv_escapes_fault_and_scenario_names(tmp_path: Path) -> None:
    plant = gf.Plant([[-1.0]], [[1.0]], [[1.0]])
    bank = gf.design_sensor_bank(plant)
    bank.faults[0].name = '=HYPERLINK("http://x","y")'  # a name from a model file
    sc = gf.Scenario.sensor("bias", 0, [0.0, 1.0], [1.0], name="@cmd")
    res = gf.Campaign(
        plant, bank, [sc], gf.Noise(measurement=0.1, seed=1), t=np.linspace(0, 2, 101),
        runs=3, test=0.5,
    ).run(progress=False)  # fmt: skip
    for name, frame, index in [
        ("campaign.csv", res.table, False),
        ("summary.csv", res.summary(), True),
        ("confusion.csv", res.confusion(), True),
    ]:
        write_csv(frame, tmp_path / name, index=index)
        with (tmp_path / name).open(newline="") as fh:
            cells = [c for row in csv.reader(fh) for c in row]
        assert not [c for c in cells if c[:1] in ("=", "@")], name
        assert any(c.startswith("'=HYPERLINK") or c == "'@cmd" for c in cells), name
    back = pd.read_csv(tmp_path / "campaign.csv")
    assert len(back) == len(res.table) and np.allclose(back["score_pre"], res.table["score_pre"])


@pytest.mark.parametrize("text", ["1/1000000000", "1000000000", "1/2/1000000000", "1/0", "a/b"])
def test_persistence_option_is_validated(text: str) -> None:
    with pytest.raises(GeomFDIError, match="persistence"):
        parse_persistence(text)


def test_persistence_option_accepts_the_documented_forms() -> None:
    assert parse_persistence("3").n == 3
    rule = parse_persistence("2/3/50")
    assert (rule.k, rule.n, rule.reset) == (2, 3, 50)


def test_cli_run_does_not_write_through_links(tmp_path: Path) -> None:
    from geomfdi.io.cli import main

    model = tmp_path / "m.toml"
    model.write_text(
        'name = "m"\n[plant]\nA = [[-1.0, 0.0], [0.0, -2.0]]\nB = [[1.0], [1.0]]\n'
        "C = [[1.0, 0.0], [0.0, 1.0]]\n[simulation]\nt_end = 1.0\nstep = 0.01\n"
        'threshold = 0.5\n[[scenario]]\nname = "s"\n[[scenario.faults]]\ntype = "bias"\n'
        "sensor = 0\nstart = 0.5\nbias = 1.0\n"
    )
    victim = tmp_path / "victim"
    victim.write_text("precious")
    out = tmp_path / "out"
    out.mkdir()
    for name in ("report.md", "summary.json", "structure_exact.png", "residuals_s_exact.png"):
        (out / name).symlink_to(victim)
    assert main(["run", str(model), "--out", str(out), "--quiet", "--no-symbolic"]) == 0
    assert victim.read_text() == "precious"
    assert not any(p.is_symlink() for p in out.iterdir())
    assert (out / "residuals_s_exact.png").read_bytes()[:4] == b"\x89PNG"
