"""Campaigns that lose a worker: the tasks of a killed process pool worker or Dask worker
run again and the table equals the serial one; when the workers keep dying, a named
error carries the runs that were done (geomfdi.campaign.runner)."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pandas as pd
import pytest
from small_campaign import small_campaign

import geomfdi as gf
from geomfdi.campaign.spec import _SensorFaults
from geomfdi.errors import CampaignIncompleteError


class _Killer(_SensorFaults):
    """Sensor faults that end their worker process the first time(s) a run of size
    ``size`` is built (a marker file per kill: ``times`` kills in all)."""

    def __init__(self, marker: str, size: float, times: int = 1) -> None:
        super().__init__("bias", 0)
        self.marker, self.size, self.times = marker, size, times
        self.parent = os.getpid()  # (never kill the test process: serial runs)

    def __call__(self, size: float, onset: float) -> list:
        if size == self.size and os.getpid() != self.parent:
            for k in range(self.times):
                mark = Path(f"{self.marker}.{k}")
                try:
                    mark.touch(exist_ok=False)
                except FileExistsError:
                    continue
                os._exit(1)  # the worker dies (a crash, an OOM kill)
        return super().__call__(size, onset)


def _campaign(faults: object) -> gf.Campaign:
    return small_campaign(faults, block_size=4)


def _table(result: gf.CampaignResult) -> pd.DataFrame:
    return result.table.sort_values(["run", "residual"]).reset_index(drop=True)


SERIAL = None


def _serial() -> pd.DataFrame:
    global SERIAL
    if SERIAL is None:
        SERIAL = _table(_campaign(_SensorFaults("bias", 0)).run("serial", progress=False))
    return SERIAL


def test_a_killed_pool_worker_is_retried(tmp_path: Path) -> None:
    res = _campaign(_Killer(str(tmp_path / "kill"), 1.0)).run(
        "processes", workers=2, progress=False
    )
    assert (tmp_path / "kill.0").exists()  # a worker did die
    assert res.info["complete"]
    pd.testing.assert_frame_equal(_table(res), _serial())


def test_workers_that_keep_dying_give_the_runs_done(tmp_path: Path) -> None:
    killer = _Killer(str(tmp_path / "kill"), 1.0, times=100)  # every attempt dies
    with pytest.raises(CampaignIncompleteError, match="workers lost") as info:
        _campaign(killer).run("processes", workers=2, progress=False)
    part = info.value.partial
    assert part is not None and not part.info["complete"]
    done = _table(part)
    assert 0 < done["run"].nunique() < 24
    assert not (done["size"] == 1.0).any()  # the tasks that kill never finish
    serial = _serial()
    pd.testing.assert_frame_equal(
        done, serial[serial["run"].isin(done["run"])].reset_index(drop=True)
    )


def test_cli_saves_the_completed_part_marked_incomplete(tmp_path, monkeypatch, capsys) -> None:
    from geomfdi.campaign.runner import Campaign
    from geomfdi.io import cli

    cfg = cli.load_campaign(
        Path(__file__).parents[1] / "examples" / "discrete_disturbance.toml", runs=12
    )

    def broken(self, *args, **kwargs):  # one task done, then the workers are lost
        from geomfdi.campaign.runner import _run_task

        done = {0: _run_task(self._job(), self.blocks()[:1])}
        raise CampaignIncompleteError("executor: workers lost", partial=self._partial(done))

    monkeypatch.setattr(cli, "load_campaign", lambda *a, **k: cfg)
    monkeypatch.setattr(Campaign, "run", broken)
    assert cli.main(["campaign", "x.toml", "--out", str(tmp_path), "--no-plots"]) == 2
    err = capsys.readouterr().err
    assert "workers lost" in err and "incomplete" in err
    part = pd.read_csv(tmp_path / "campaign.incomplete.csv")
    assert 0 < part["run"].nunique() < len(cfg.campaign.grid()["run"])
    assert not (tmp_path / "campaign.csv").exists()


@pytest.mark.slow
@pytest.mark.parametrize("n_workers", [1, 2])
def test_a_killed_dask_worker_is_retried(tmp_path: Path, n_workers: int) -> None:
    pytest.importorskip("distributed")
    import cloudpickle
    import dask

    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    from geomfdi.campaign.executors import DASK_THROUGHPUT, local_dask_client

    with local_dask_client(n_workers) as client:
        res = _campaign(_Killer(str(tmp_path / "kill"), 1.0)).run(client, progress=False)
        # the worker started again in place of the killed one has the settings too
        client.wait_for_workers(n_workers, timeout=30)
        settings = client.run(lambda: {k: dask.config.get(k) for k in DASK_THROUGHPUT})
        threads = client.nthreads()
    assert (tmp_path / "kill.0").exists()
    pd.testing.assert_frame_equal(_table(res), _serial())
    assert len(settings) == n_workers and all(v == DASK_THROUGHPUT for v in settings.values())
    assert sorted(threads.values()) == [1] * n_workers
