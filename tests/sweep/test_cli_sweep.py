"""``thermoswarm sweep``: local processes, a LocalCluster started for the sweep, an
existing scheduler; usage errors in one line with exit status 2."""

from __future__ import annotations

import json

import pandas as pd
import pytest
from click.testing import CliRunner

from thermoswarm.cli import cli

ARGS = ["--set", "n=20", "--set", "duration=3", "--set", "record.netcdf=false",
        "--grid", "kT=10,40", "--seeds", "0-1", "--no-progress"]  # fmt: skip


def _sweep(tmp_path, *extra):
    return CliRunner().invoke(cli, ["sweep", "box", "--out", str(tmp_path / "s"), *ARGS, *extra])


def _check_table(tmp_path, summary):
    assert json.loads(summary) == {"out": str(tmp_path / "s"), "runs": 4, "done": 4,
                                   "skipped": 0, "failed": 0}  # fmt: skip
    t = pd.read_parquet(tmp_path / "s" / "results.parquet")
    assert sorted(zip(t["params.kT"], t["seed"], strict=True)) == [
        (10.0, 0),
        (10.0, 1),
        (40.0, 0),
        (40.0, 1),
    ]
    assert (t["metrics.kT"] == t["params.kT"]).all() and (t["status"] == "done").all()


def test_cli_sweep_on_an_existing_scheduler(tmp_path, dask_cluster_client):
    address = dask_cluster_client.scheduler.address
    res = _sweep(tmp_path, "--scheduler", address)
    assert res.exit_code == 0, res.output
    _check_table(tmp_path, res.stdout)
    # run again: every run is skipped
    res = _sweep(tmp_path, "--scheduler", address)
    assert json.loads(res.stdout)["skipped"] == 4


def test_cli_sweep_on_a_local_cluster_started_for_it(tmp_path):
    res = _sweep(tmp_path, "--cluster", "local:1")
    assert res.exit_code == 0, res.output
    _check_table(tmp_path, res.stdout)


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--cluster", "local:0"], "--cluster 'local:0': expected local:N with N >= 1 workers"),
        (["--cluster", "slurm:4"], "--cluster 'slurm:4': expected local:N with N >= 1 workers"),
        (["--cluster", "local:2", "--scheduler", "tcp://h:8786"],
         "give --scheduler or --cluster, not both"),
        (["--cluster", "local:2", "--workers", "2"],
         "--workers is for local processes; Dask brings its own workers"),
    ],
)  # fmt: skip
def test_cli_sweep_usage_errors(tmp_path, extra, message):
    res = _sweep(tmp_path, *extra)
    assert res.exit_code == 2
    assert res.stderr == f"error: {message}\n"
    assert not (tmp_path / "s").exists()


def test_an_unreachable_scheduler_is_one_line(tmp_path):
    from thermoswarm.errors import InputError
    from thermoswarm.sweep.cluster import dask_client

    with pytest.raises(InputError, match=r"^--scheduler 'tcp://127.0.0.1:9': cannot reach it"):
        with dask_client("tcp://127.0.0.1:9", timeout=0.5):
            pass
