"""Model files of physical plants: names, operating point, every fault kind, row poles."""

from __future__ import annotations

import numpy as np
import pytest

import geomfdi as gf
from geomfdi.errors import ModelFileError
from geomfdi.io.cli import design_all, main
from geomfdi.io.modelfile import load_model

MODEL = """
name = "tanks"
[plant]
A = [[-1.0, 0.5, 0.0], [0.0, -2.0, 0.5], [0.2, 0.0, -1.5]]
B = [[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]]
C = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
inputs = ["Q1", "Q2"]
outputs = ["level 1", "level 2", "level 3"]
y_op = [0.5, 0.3, 0.4]
u_op = [1.0, 2.0]
[design]
poles = [[-3.0, -3.5], [-4.0], [-5.0]]
structure = [[0, 1, 1], [1, 0, 1], [1, 1, 0]]
[[design.faults]]
type = "sensor"
sensor = "level 1"
[[design.faults]]
type = "sensor"
sensor = "level 2"
[[design.faults]]
type = "actuator"
b = [0.0, 0.0, -1.0]
name = "leak"
[simulation]
t_end = 10.0
step = 0.01
threshold = [0.01, 0.01, 0.01]
[[scenario]]
name = "every kind"
[[scenario.faults]]
type = "gain"
sensor = "level 2"
start = 2.0
gain = 0.9
[[scenario.faults]]
type = "stuck"
sensor = 0
start = 8.0
[[scenario.faults]]
type = "actuator gain"
actuator = "Q1"
start = 3.0
gain = 0.8
[[scenario.faults]]
type = "actuator bias"
actuator = 1
start = 4.0
bias = 0.1
[[scenario.faults]]
type = "actuator stuck"
actuator = "Q2"
start = 9.0
value = 2.5
[[scenario.faults]]
type = "additive"
fault = "leak"
start = 5.0
signal = "0.01*(t - 5)"
"""


def test_names_operating_point_every_fault_kind_and_row_poles(tmp_path):
    path = tmp_path / "tanks.toml"
    path.write_text(MODEL, encoding="utf-8")
    spec = load_model(path)
    assert spec.plant.outputs == ("level 1", "level 2", "level 3") and spec.plant.named
    np.testing.assert_array_equal(spec.plant.u_op, [1.0, 2.0])
    assert [f.i for f in spec.faults[:2]] == [0, 1]
    kinds = [type(f).__name__ for f in spec.scenarios[0].faults]
    assert kinds == ["GainFault", "StuckFault", "ActuatorGainFault", "ActuatorBiasFault",
                     "ActuatorStuckFault", "AdditiveFault"]  # fmt: skip
    assert spec.scenarios[0].faults[0].sensor == 1 and spec.scenarios[0].faults[2].actuator == 0
    bank = design_all(spec)["exact"]
    assert [f.name for f in bank.faults] == ["level 1", "level 2", "leak"]
    poles = [np.linalg.eigvals(g.F) for g in bank.generators]
    for got, want in zip(poles, (-3.0, -4.0, -5.0), strict=True):
        assert got.size >= 1 and np.isclose(got, want).any()
    assert main(["simulate", str(path), "--out", str(tmp_path / "out"), "--quiet",
                 "--no-plots", "--no-symbolic"]) == 0  # fmt: skip


def test_an_unknown_signal_name_is_named_in_the_error(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(MODEL.replace('actuator = "Q1"', 'actuator = "Q9"'), encoding="utf-8")
    with pytest.raises(ModelFileError, match=r"actuator: no input named 'Q9'"):
        load_model(path)
    assert isinstance(gf.Plant, type)


CAMPAIGN = """
[simulation.noise]
measurement = 0.001
seed = 1
[campaign]
runs = 2
sizes = [0.0, 0.5]
onsets = [5.0]
faults = [{type = "actuator gain", actuator = "Q1"}, {type = "additive", fault = "leak"},
          {type = "stuck", sensor = "level 3"}, {type = "bias", sensor = "level 2"}]
test = {type = "chi2", window = 20, false_alarm_rate = 1e-3}
"""


def test_campaign_tables_take_every_fault_kind_by_name(tmp_path):
    import pickle

    from geomfdi.io.cli import load_campaign

    path = tmp_path / "tanks.toml"
    path.write_text(MODEL + CAMPAIGN, encoding="utf-8")
    cfg = load_campaign(path)
    names = [s.name for s in cfg.campaign.scenarios]
    assert names == ["actuator gain on 0", "additive on leak", "stuck on 2", "bias on sensor 1"]
    acts = cfg.campaign.scenarios[0].faults(0.5, 5.0)
    assert type(acts[0]).__name__ == "ActuatorGainFault" and acts[0].gain == 1.5
    assert cfg.campaign.scenarios[1].faults(0.0, 5.0) == []  # size 0: no fault
    pickle.dumps(cfg.campaign.scenarios)  # picklable for process and Dask workers
    res = cfg.campaign.run()
    assert set(res.table["scenario"].astype(str)) == set(names)
    bad = tmp_path / "bad.toml"
    bad.write_text((MODEL + CAMPAIGN).replace('actuator = "Q1"}', 'actuator = "Q7"}'))
    with pytest.raises(ModelFileError, match="no input named 'Q7'"):
        load_campaign(bad)
