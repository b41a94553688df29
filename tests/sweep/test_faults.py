"""Faults survived on the real engine, by the local pool and by a Dask LocalCluster.

A worker process is SIGKILLed in the middle of a run: the run is retried in another
process, resumes from its last committed block, and the sweep's tracks and metrics are
bit-identical to those of an undisturbed sweep.  The kill has no timing race: the test
waits until a run's committed-frames marker shows progress, freezes the run's process
(SIGSTOP), checks that the run is still unfinished, and only then kills it.

A run whose configuration is bad fails once, with its own error, and no other run is
charged an attempt.
"""

from __future__ import annotations

import json
import os
import signal
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from thermoswarm.scenarios.runner import open_run_tracks
from thermoswarm.sweep import SweepSpec, run_sweep
from thermoswarm.sweep.worker import committed_frames, read_attempts

# 40 robots for 40 s in 0.1 s steps, a frame every 0.5 s, committed every 4 frames:
# 81 frames in 21 blocks, about half a second of work per run.
BASE = {"n": 40, "duration": 40.0, "packing_fraction": 0.1,
        "record": {"interval": 0.5, "block": 4, "netcdf": False}}  # fmt: skip
GRID = {"kT": [10.0, 30.0]}
SEEDS = [0, 1]
N_FRAMES = 81


def _spec(out: Path, grid=GRID) -> SweepSpec:
    return SweepSpec("box", out, BASE, grid, seeds=SEEDS)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The undisturbed sweep, run in this process."""
    out = tmp_path_factory.mktemp("reference") / "s"
    with ThreadPoolExecutor(1) as ex:
        records = run_sweep(_spec(out), executor=ex, progress=False)
    assert [r.status for r in records] == ["done"] * 4
    return records


def _in_background(fn):
    box: dict = {}

    def target():
        try:
            box["result"] = fn()
        except BaseException as exc:  # handed to the test thread
            box["error"] = exc

    t = threading.Thread(target=target, daemon=True)
    t.start()
    return t, box


def _kill_one_run_midway(out: Path, sweep_thread: threading.Thread, timeout: float = 240.0):
    """SIGKILL the process of a run that has committed frames but not finished; return
    (run directory, its committed frames at the kill, the killed pid)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and sweep_thread.is_alive():
        for rdir in sorted(p for p in out.glob("*") if p.is_dir()):
            if committed_frames(rdir) < 4:
                continue
            starts = [e for e in read_attempts(rdir) if e["event"] == "start"]
            if not starts:
                continue
            pid = starts[-1]["pid"]
            try:
                os.kill(pid, signal.SIGSTOP)
            except ProcessLookupError:
                continue
            frames = committed_frames(rdir)
            ends = [e for e in read_attempts(rdir) if e["event"] != "start"]
            if frames >= N_FRAMES or ends:  # it finished before it froze: try another
                os.kill(pid, signal.SIGCONT)
                continue
            os.kill(pid, signal.SIGKILL)
            return rdir, frames, pid
        time.sleep(0.005)
    pytest.fail("no run was caught between its first committed block and its end")


def _same_results(records, reference) -> None:
    ref = {r.run_id: r for r in reference}
    assert [r.run_id for r in records] == [r.run_id for r in reference]  # same seeds: ids
    for r in records:
        assert r.status == "done", (r.run_id, r.error)
        a = open_run_tracks(Path(r.out) / "tracks.zarr")
        b = open_run_tracks(Path(ref[r.run_id].out) / "tracks.zarr")
        a.attrs.pop("source_file"), b.attrs.pop("source_file")  # where each sweep wrote
        assert a.sizes["time"] == N_FRAMES
        xr.testing.assert_identical(a, b)  # bit-identical tracks
        strip = lambda m: {k: v for k, v in m.items() if k != "performance"}  # noqa: E731
        assert json.dumps(strip(r.metrics), sort_keys=True) == json.dumps(
            strip(ref[r.run_id].metrics), sort_keys=True
        )


def _check_killed_run_resumed(rdir: Path, frames: int, pid: int) -> None:
    starts = [e for e in read_attempts(rdir) if e["event"] == "start"]
    assert len(starts) == 2  # the killed attempt and one retry
    assert starts[1]["pid"] != pid  # in another worker process
    assert starts[1]["committed_frames"] == frames > 0  # from its last committed block
    metrics = json.loads((rdir / "metrics.json").read_text())
    # the retry stepped only what was left after the committed block
    total_steps = round(BASE["duration"] / 0.1)
    assert metrics["performance"]["steps"] == total_steps - (frames - 1) * 5


def _survives_a_killed_worker(executor, tmp_path, reference):
    out = tmp_path / "s"
    thread, box = _in_background(
        lambda: run_sweep(_spec(out), executor=executor, retries=1, progress=False)
    )
    rdir, frames, pid = _kill_one_run_midway(out, thread)
    thread.join(timeout=300)
    assert not thread.is_alive() and "error" not in box, box.get("error")
    records = box["result"]
    _same_results(records, reference)
    _check_killed_run_resumed(rdir, frames, pid)
    for r in records:  # nobody else was charged an attempt
        if Path(r.out) != rdir:
            assert [e["event"] for e in read_attempts(r.out)] == ["start", "end"]
    # the table has every run, done
    import pandas as pd

    table = pd.read_parquet(out / "results.parquet")
    assert table["run_id"].tolist() == [r.run_id for r in records]
    assert (table["status"] == "done").all()
    return records, rdir


def test_local_pool_survives_a_killed_worker(tmp_path, reference, pool):
    deaths = pool.deaths
    records, rdir = _survives_a_killed_worker(pool, tmp_path, reference)
    assert pool.deaths == deaths + 1
    # the pool charged the killed run alone one attempt
    assert {r.run_id: r.attempts for r in records} == {
        r.run_id: 2 if Path(r.out) == rdir else 1 for r in records
    }


def test_dask_local_cluster_survives_a_killed_worker(tmp_path, reference, dask_executor):
    # Dask's scheduler re-runs the lost task itself: the sweep sees one attempt
    records, _ = _survives_a_killed_worker(dask_executor, tmp_path, reference)
    assert [r.attempts for r in records] == [1, 1, 1, 1]


def _bad_run_fails_once(executor, tmp_path):
    # duration 0.05 s is a valid number but shorter than one 0.1 s step: the run itself
    # refuses it on the worker
    grid = {"duration": [40.0, 0.05]}
    records = run_sweep(_spec(tmp_path / "s", grid), executor=executor, retries=0,
                        progress=False)  # fmt: skip
    by = {(r.params["duration"], r.seed): r for r in records}
    for seed in SEEDS:
        bad, good = by[(0.05, seed)], by[(40.0, seed)]
        assert bad.status == "failed" and bad.attempts == 1
        assert bad.error == "duration must be at least one time step (0.1 s)"
        assert [e["event"] for e in read_attempts(bad.out)] == ["start", "error"]
        assert good.status == "done" and good.attempts == 1  # with retries=0
    import pandas as pd

    table = pd.read_parquet(tmp_path / "s" / "results.parquet")
    failed = table[table["status"] == "failed"]
    assert len(failed) == 2 and failed["error"].str.startswith("duration must").all()
    assert failed["metrics.kT_measured"].isna().all()
    assert np.isfinite(table.loc[table["status"] == "done", "metrics.kT_measured"]).all()


def test_local_pool_reports_a_bad_run_once(tmp_path, pool):
    deaths = pool.deaths
    _bad_run_fails_once(pool, tmp_path)
    assert pool.deaths == deaths


def test_dask_reports_a_bad_run_once(tmp_path, dask_cluster_client):
    _bad_run_fails_once(dask_cluster_client, tmp_path)  # a Client is taken as it is


def test_every_worker_runs_on_the_sweeps_thread_count(tmp_path, pool, dask_executor):
    """Above SERIAL_BELOW robots the engine would pick every thread; each worker keeps one."""
    from thermoswarm.sim.engine import SERIAL_BELOW

    base = {"n": SERIAL_BELOW, "duration": 0.3, "packing_fraction": 0.1,
            "record": {"interval": 0.1, "netcdf": False}}  # fmt: skip
    for name, ex in (("pool", pool), ("dask", dask_executor)):
        spec = SweepSpec("box", tmp_path / name, base, {}, seeds=[0])
        (rec,) = run_sweep(spec, executor=ex, threads_per_run=1, progress=False)
        assert rec.status == "done", rec.error
        (end,) = [e for e in read_attempts(rec.out) if e["event"] == "end"]
        assert end["numba_threads"] == 1, name
