"""The results table: one row per run, every parameter and metric a column, written as
runs finish so that a killed sweep keeps what had finished."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pandas as pd
import pytest

from thermoswarm.scenarios.box import BoxParams
from thermoswarm.sweep import RunRecord, SweepSpec, run_sweep
from thermoswarm.sweep.table import TABLE_NAME, ResultsTable
from thermoswarm.sweep.worker import finished


def test_a_thousand_runs_make_one_tidy_table(tmp_path):
    rng = np.random.default_rng(7)
    params = {f"{i:016x}": BoxParams(n=10 + i % 7, kT=float(1 + i)) for i in range(1000)}
    table = ResultsTable(tmp_path, "box", params)
    truth = {}
    for i, rid in enumerate(reversed(list(params))):  # finishing in any order
        if i % 100 == 3:
            table.add(RunRecord(rid, {}, i, "", "failed", None, "no room for the robots", 1))
            continue
        m = {"kT_measured": float(rng.normal()), "robots_outside": i % 3,
             "diffusion": {"D": float(rng.random()), "n_windows": 5},
             "series": [1.0, 2.0, float(i)], "mode": "overdamped"}  # fmt: skip
        truth[rid] = m
        table.add(RunRecord(rid, {}, i % 4, "", "done", m, None, 1 + (i == 5)))
        table.maybe_write()
    table.write()
    df = pd.read_parquet(tmp_path / TABLE_NAME)
    assert len(df) == 1000 and df["run_id"].tolist() == list(params)  # the spec's order
    assert df["run_id"].is_unique
    # every parameter and metric is a column of its own type
    assert df["params.n"].tolist() == [p.n for p in params.values()]
    assert df["params.engine.dt"].dtype == np.float64 and (df["params.engine.dt"] == 0.1).all()
    assert df["params.record.netcdf"].dtype == bool
    done = df[df["status"] == "done"].set_index("run_id")
    assert len(done) == 990
    for col, key in (("metrics.kT_measured", "kT_measured"), ("metrics.robots_outside",
                     "robots_outside")):  # fmt: skip
        assert done[col].to_dict() == {rid: m[key] for rid, m in truth.items()}
    diffusion = {rid: m["diffusion"]["D"] for rid, m in truth.items()}
    assert done["metrics.diffusion.D"].to_dict() == diffusion
    assert [list(v) for v in done["metrics.series"]] == [truth[r]["series"] for r in done.index]
    failed = df[df["status"] == "failed"]
    assert len(failed) == 10 and failed["metrics.kT_measured"].isna().all()
    assert (failed["error"] == "no room for the robots").all()


def test_a_value_that_fits_no_column_type_is_kept_as_json(tmp_path):
    params = {"a": BoxParams(), "b": BoxParams()}
    table = ResultsTable(tmp_path, "box", params)
    table.add(RunRecord("a", {}, 0, "", "done", {"x": 1.5}))
    table.add(RunRecord("b", {}, 0, "", "done", {"x": [{"k": "v"}, 2]}))
    table.write()
    df = pd.read_parquet(tmp_path / TABLE_NAME)
    assert df["metrics.x"].tolist() == ["1.5", '[{"k": "v"}, 2]']


BASE = {"n": 30, "duration": 30.0, "packing_fraction": 0.05,
        "record": {"interval": 0.5, "block": 4, "netcdf": False}}  # fmt: skip
KTS = [5.0, 10.0, 20.0, 30.0, 40.0, 50.0]


def test_a_killed_sweep_keeps_what_finished(tmp_path):
    out = tmp_path / "s"
    cmd = [sys.executable, "-m", "thermoswarm", "sweep", "box", "--out", str(out),
           "--workers", "1", "--no-progress", "--grid", "kT=" + ",".join(map(str, KTS)),
           "--set", "n=30", "--set", "duration=30", "--set", "packing_fraction=0.05",
           "--set", "record.interval=0.5", "--set", "record.block=4",
           "--set", "record.netcdf=false"]  # fmt: skip
    proc = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)  # fmt: skip
    try:
        deadline = time.monotonic() + 240
        rows = 0
        while rows < 2 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
            try:
                rows = len(pd.read_parquet(out / TABLE_NAME))
            except (OSError, ValueError):
                continue
        os.killpg(proc.pid, signal.SIGKILL)  # the sweep and its workers, as a job kill does
    finally:
        proc.wait()
    assert proc.returncode == -signal.SIGKILL, proc.stderr.read().decode()
    assert not (out / "sweep.json").exists()  # it did not get to the end
    kept = pd.read_parquet(out / TABLE_NAME)
    assert 2 <= len(kept) < len(KTS)
    for rid, status in zip(kept["run_id"], kept["status"], strict=True):
        assert status == "done" and finished(out / rid) is not None
    # started again, the sweep skips what finished and completes the table
    with ThreadPoolExecutor(1) as ex:
        records = run_sweep(SweepSpec("box", out, BASE, {"kT": KTS}), executor=ex,
                            progress=False)  # fmt: skip
    assert {r.run_id for r in records if r.status == "skipped"} >= set(kept["run_id"])
    assert all(r.status in ("done", "skipped") for r in records)
    table = pd.read_parquet(out / TABLE_NAME)
    assert table["params.kT"].tolist() == KTS
    assert (table["metrics.kT"] == table["params.kT"]).all()
    stored = json.loads((out / "sweep.json").read_text())
    assert [r["run_id"] for r in stored["runs"]] == table["run_id"].tolist()


def test_without_pyarrow_the_sweep_runs_and_says_so(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "pyarrow", None)  # import fails
    spec = SweepSpec("box", tmp_path / "s", {**BASE, "duration": 2.0}, {}, seeds=[0])
    with ThreadPoolExecutor(1) as ex, pytest.warns(UserWarning, match="pyarrow"):
        (rec,) = run_sweep(spec, executor=ex, progress=False)
    assert rec.status == "done" and not (tmp_path / "s" / TABLE_NAME).exists()
