"""Runs: bit-identical reproducibility, kill -9 and resume, and the CLI's bad input."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numba
import numpy as np
import pytest
import xarray as xr
from click.testing import CliRunner

from thermoswarm.cli import cli
from thermoswarm.scenarios import runner

SMALL = (
    "n=120",
    "packing_fraction=0.3",
    "duration=30",
    "tau=0.5",
    "record.interval=0.5",
    "record.block=8",
)


def _run(tmp_path: Path, name: str, seed: int = 3, extra=()) -> Path:
    cfg = runner.resolve("box", overrides=SMALL + tuple(extra), seed=seed)
    runner.run(cfg, tmp_path / name, progress=False)
    return tmp_path / name


def test_same_seed_gives_bit_identical_tracks_whatever_the_thread_count(tmp_path):
    a = _run(tmp_path, "a")
    prev = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        b = _run(tmp_path, "b")
    finally:
        numba.set_num_threads(prev)
    c = _run(tmp_path, "c", seed=4)
    ta, tb, tc = (xr.open_dataset(p / "tracks.nc") for p in (a, b, c))
    for var in ("position", "heading", "speed", "time"):
        assert np.array_equal(ta[var].values, tb[var].values, equal_nan=True), var
    # and a different seed really differs (the comparison is not vacuous)
    assert not np.array_equal(ta["position"].values, tc["position"].values)
    assert (a / "config.toml").read_text() == (b / "config.toml").read_text()


def test_inertial_mode_is_reproducible_too(tmp_path):
    extra = ("mode='inertial'", "engine.dt=0.25")
    a = _run(tmp_path, "a", extra=extra)
    b = _run(tmp_path, "b", extra=extra)
    pa = xr.open_dataset(a / "tracks.nc")["position"].values
    pb = xr.open_dataset(b / "tracks.nc")["position"].values
    assert np.array_equal(pa, pb, equal_nan=True)


def _committed(store: Path) -> int:
    import json

    meta = store / "zarr.json"
    try:
        return int(json.loads(meta.read_text())["attributes"].get("committed_frames", 0))
    except (FileNotFoundError, ValueError, KeyError):
        return 0


def test_kill_9_then_resume_gives_the_uninterrupted_result(tmp_path):
    args = ["box", "--seed", "5", "--no-progress"]
    sets = ["n=300", "duration=400", "tau=1.0", "record.interval=0.5", "record.block=10"]
    for s in sets:
        args += ["--set", s]
    ref = tmp_path / "ref"
    runner.run(runner.resolve("box", overrides=sets, seed=5), ref, progress=False)

    out = tmp_path / "killed"
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    proc = subprocess.Popen(
        [sys.executable, "-m", "thermoswarm", "simulate", *args, "--out", str(out)], env=env
    )
    try:
        deadline = time.time() + 120
        while _committed(out / "tracks.zarr") < 200 and time.time() < deadline:
            if proc.poll() is not None:
                break
            time.sleep(0.02)
        assert proc.poll() is None, "the run finished before it could be killed"
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    finally:
        if proc.poll() is None:
            proc.kill()
    killed_at = _committed(out / "tracks.zarr")
    assert 0 < killed_at < 801  # killed mid-run, with committed frames kept
    assert not (out / "metrics.json").exists()
    # every committed frame is readable as is, before resuming
    from thermoswarm.io import read_tracks

    partial = read_tracks(out / "tracks.zarr")
    assert partial.sizes["time"] == killed_at
    runner.resume(out, progress=False)
    a = xr.open_dataset(out / "tracks.nc")
    b = xr.open_dataset(ref / "tracks.nc")
    assert a.sizes["time"] == 801
    for var in ("position", "heading", "speed", "time"):
        assert np.array_equal(a[var].values, b[var].values, equal_nan=True), var
    ma = (out / "metrics.json").read_text()
    mb = (ref / "metrics.json").read_text()
    import json

    ja, jb = json.loads(ma), json.loads(mb)
    ja.pop("performance"), jb.pop("performance")
    assert ja == jb


@pytest.mark.parametrize(
    "sets, needle",
    [
        (["bogus=1"], "unknown key 'bogus'"),
        (["n='ten'"], "n must be an integer"),
        (["n=2.5"], "n must be an integer"),
        (["n=-5"], "n must be a positive integer"),
        (["packing_fraction=0.85", "n=500"], "cannot place 500 robots"),
        (["engine.dt=-0.1"], "dt must be a positive number"),
        (["engine.wat=1"], "unknown key 'engine.wat'"),
        (["mode='quantum'"], "mode must be one of"),
    ],
)
def test_bad_config_is_one_line_exit_2_and_writes_nothing(tmp_path, sets, needle):
    args = ["simulate", "box", "--out", str(tmp_path / "out")]
    for s in sets:
        args += ["--set", s]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), res.output
    assert needle in lines[0]
    assert "Traceback" not in res.output
    assert not (tmp_path / "out").exists()


def test_bad_config_file_names_the_file(tmp_path):
    cfg = tmp_path / "box.toml"
    cfg.write_text("n = 10\npacking_fraction = 'high'\n")
    res = CliRunner().invoke(
        cli, ["simulate", "box", "--out", str(tmp_path / "o"), "--config", str(cfg)]
    )
    assert res.exit_code == 2
    assert str(cfg) in res.output and "packing_fraction" in res.output
    assert not (tmp_path / "o").exists()


def test_output_parents_are_created_a_file_in_the_way_and_unknown_scenario(tmp_path):
    out = tmp_path / "runs" / "deeper" / "box"
    res = CliRunner().invoke(cli, ["simulate", "box", "--out", str(out), "--set", "n=5",
                                   "--set", "duration=1"])  # fmt: skip
    assert res.exit_code == 0, res.output
    assert (out / "metrics.json").is_file()
    # a bad value creates no parent
    bad = tmp_path / "other" / "box"
    res = CliRunner().invoke(cli, ["simulate", "box", "--out", str(bad), "--set", "n=-1"])
    assert res.exit_code == 2 and not (tmp_path / "other").exists()
    (tmp_path / "file").write_text("")
    res = CliRunner().invoke(cli, ["simulate", "box", "--out", str(tmp_path / "file" / "x")])
    assert res.exit_code == 2 and "is a file, not a directory" in res.output
    res = CliRunner().invoke(cli, ["simulate", "warp", "--out", str(tmp_path / "o")])
    assert res.exit_code == 2 and "unknown scenario 'warp'" in res.output
    res = CliRunner().invoke(cli, ["simulate", "--resume", str(tmp_path)])
    assert res.exit_code == 2 and "no run to resume" in res.output


def test_an_existing_run_is_not_overwritten(tmp_path):
    out = _run(tmp_path, "a")
    before = (out / "metrics.json").read_bytes()
    res = CliRunner().invoke(cli, ["simulate", "box", "--out", str(out), "--set", "n=5"])
    assert res.exit_code == 2 and "already holds a run" in res.output
    assert (out / "metrics.json").read_bytes() == before
