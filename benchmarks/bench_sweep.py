"""Sweep benchmark: the overhead per task of Dask against the local pool, in one process.

Both executors get two worker processes with one task each:

- ``local pool``: :func:`thermoswarm.sweep.local_pool` (the default executor);
- ``dask``: a ``distributed.LocalCluster`` as ``thermoswarm sweep --cluster local:2``
  starts it (Dask's statistical profiler off);
- ``dask default``: the same with Dask's default settings (the profiler on), as workers
  that you start yourself have them;
- ``stdlib``: :class:`concurrent.futures.ProcessPoolExecutor` for reference (a dead
  worker breaks it whole, which is why the sweep does not use it).

Two measurements per executor, after its workers have started and imported the sweep
(start-up, timed apart, includes that import):

1. dispatch: ``--tasks`` calls of a no-op (``abs(i)``) submitted at once; time per task;
2. a sweep of ``--runs`` short runs of the real engine (``box``, 10 robots, 1 s simulated,
   every run its own seed) through :func:`run_sweep`; wall time per run and the
   difference per run from the local pool.  The sweep goes in ``--rounds`` parts, the
   executors taking turns (so that a change of load on a shared machine hits them alike),
   into one directory per executor; started once more at the end, every run is skipped
   (timed: ``restart s``) and ``results.parquet`` holds all ``--runs`` rows.

Usage::

    python benchmarks/bench_sweep.py                    # 1,000 runs per executor
    python benchmarks/bench_sweep.py --runs 200 --tasks 500 --json
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor, wait
from pathlib import Path

BASE = {"n": 10, "duration": 1.0, "packing_fraction": 0.05,
        "record": {"interval": 0.5, "netcdf": False}}  # fmt: skip


def _warm(seconds: float) -> int:
    """Hold a worker for ``seconds`` (so that each worker gets one) and import the
    sweep's worker module there; its pid."""
    time.sleep(seconds)
    import thermoswarm.sweep.worker  # noqa: F401

    return os.getpid()


def _dispatch(ex, n: int) -> float:
    """Seconds per no-op task, ``n`` submitted at once (after 20 to warm up)."""
    wait([ex.submit(abs, -i) for i in range(20)])
    t0 = time.perf_counter()
    futures = [ex.submit(abs, -i) for i in range(n)]
    wait(futures)
    assert [f.result() for f in futures] == list(range(n))
    return (time.perf_counter() - t0) / n


def _sweep(ex, out: Path, seeds: range) -> tuple[float, float]:
    """Wall seconds of a sweep of one short run per seed, and the seconds spent inside
    the runs' stepping loops."""
    from thermoswarm.sweep import SweepSpec, run_sweep

    t0 = time.perf_counter()
    records = run_sweep(SweepSpec("box", out, BASE, {}, seeds=list(seeds)), executor=ex,
                        progress=False)  # fmt: skip
    wall = time.perf_counter() - t0
    assert all(r.status == "done" for r in records), [r.error for r in records][:3]
    return wall, sum(r.metrics["performance"]["wall_seconds"] for r in records)


def _start(name: str, workers: int):
    import dask
    from distributed import Client, LocalCluster

    from thermoswarm.sweep import local_pool
    from thermoswarm.sweep.cluster import LOCAL_CLUSTER_CONFIG

    if name == "local pool":
        return local_pool(workers, threads_per_run=1), None
    if name.startswith("dask"):
        # "dask": as --cluster local:N starts it; "dask default": Dask's own settings
        config = LOCAL_CLUSTER_CONFIG if name == "dask" else {}
        with dask.config.set(config):
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   dashboard_address=":0",
                                   env={"NUMBA_NUM_THREADS": "1"})  # fmt: skip
        client = Client(cluster)
        return client.get_executor(), (client, cluster)
    return ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")), None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=1000, help="short runs per executor")
    ap.add_argument("--tasks", type=int, default=2000, help="no-op tasks per executor")
    ap.add_argument("--rounds", type=int, default=4, help="rounds, executors taking turns")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    import pandas as pd

    from thermoswarm.sweep import SweepSpec, run_sweep
    from thermoswarm.sweep.spec import expand
    from thermoswarm.sweep.worker import compile_here

    # compile the kernels once, so that no executor pays for it
    compile_here([cfg for _, _, cfg in expand(SweepSpec("box", Path("x"), BASE))])
    names = ("local pool", "dask", "dask default", "stdlib")
    execs, rows = {}, {}
    for name in names:  # start every worker and import the sweep there
        t0 = time.perf_counter()
        ex, extra = execs[name] = _start(name, args.workers)
        warm = [ex.submit(_warm, 1.0 + 1e-6 * i) for i in range(args.workers)]
        assert len({f.result() for f in warm}) == args.workers  # one per process
        rows[name] = {"startup_s": time.perf_counter() - t0 - 1.0, "dispatch_s": 0.0,
                      "sweep_s": 0.0, "in_run_loop_s": 0.0}  # fmt: skip
    per = args.runs // args.rounds
    with tempfile.TemporaryDirectory(prefix="bench-sweep-") as tmp:
        # the executors take turns, so that a change of load hits them alike
        for k in range(args.rounds):
            for name in names:
                ex = execs[name][0]
                rows[name]["dispatch_s"] += _dispatch(ex, args.tasks // args.rounds) * (
                    args.tasks // args.rounds
                )
                if name != "stdlib":
                    wall, inside = _sweep(ex, Path(tmp) / name.replace(" ", "-"),
                                          range(k * per, (k + 1) * per))  # fmt: skip
                    rows[name]["sweep_s"] += wall
                    rows[name]["in_run_loop_s"] += inside
        for name in ("local pool", "dask", "dask default"):
            # the whole sweep once more: every run is skipped, and the table has them all
            out = Path(tmp) / name.replace(" ", "-")
            t0 = time.perf_counter()
            spec = SweepSpec("box", out, BASE, {}, seeds=list(range(per * args.rounds)))
            records = run_sweep(spec, executor=execs[name][0], progress=False)
            rows[name]["restart_s"] = time.perf_counter() - t0
            assert all(r.status == "skipped" for r in records)
            table = pd.read_parquet(out / "results.parquet")
            assert len(table) == per * args.rounds and table["run_id"].is_unique
            rows[name]["table"] = f"{table.shape[0]} x {table.shape[1]}"
            rows[name]["table_kB"] = (out / "results.parquet").stat().st_size / 1e3
    for ex, extra in execs.values():
        if extra:
            extra[0].close()
            extra[1].close()
        else:
            ex.shutdown()
    n_runs, n_tasks = per * args.rounds, (args.tasks // args.rounds) * args.rounds
    for r in rows.values():
        r["dispatch_ms"] = 1e3 * r["dispatch_s"] / n_tasks
        r["per_run_ms"] = 1e3 * r["sweep_s"] / n_runs if r["sweep_s"] else None
    pool, dask, dflt = rows["local pool"], rows["dask"], rows["dask default"]
    summary = {
        "dask_minus_pool_dispatch_ms": dask["dispatch_ms"] - pool["dispatch_ms"],
        "dask_minus_pool_per_run_ms": dask["per_run_ms"] - pool["per_run_ms"],
        "dask_over_pool_sweep_ratio": dask["sweep_s"] / pool["sweep_s"],
        "dask_default_minus_pool_per_run_ms": dflt["per_run_ms"] - pool["per_run_ms"],
        "runs": n_runs, "tasks": n_tasks, "workers": args.workers, "rounds": args.rounds,
        "cpus": os.cpu_count(), "load_average": os.getloadavg(),
    }  # fmt: skip
    if args.json:
        print(json.dumps({"executors": rows, "summary": summary}, indent=1))
        return
    print(f"{n_runs} short runs and {n_tasks} no-op tasks per executor in {args.rounds} "
          f"rounds, {args.workers} workers; cpus {os.cpu_count()}")  # fmt: skip
    print(f"{'executor':<12} {'start s':>8} {'no-op ms':>9} {'sweep s':>8} {'ms/run':>7} "
          f"{'in-run s':>9} {'restart s':>9}  table")  # fmt: skip
    for name, r in rows.items():
        if r["per_run_ms"] is None:
            rest = f"{'-':>8} {'-':>7} {'-':>9} {'-':>9}  -"
        else:
            rest = (f"{r['sweep_s']:8.1f} {r['per_run_ms']:7.1f} {r['in_run_loop_s']:9.1f} "
                    f"{r['restart_s']:9.2f}  {r['table']} ({r['table_kB']:.0f} kB)")  # fmt: skip
        print(f"{name:<12} {r['startup_s']:8.2f} {r['dispatch_ms']:9.3f} {rest}")
    print(f"dask - local pool: {summary['dask_minus_pool_dispatch_ms']:+.3f} ms per no-op "
          f"task, {summary['dask_minus_pool_per_run_ms']:+.1f} ms per run; sweep time ratio "
          f"dask / pool {summary['dask_over_pool_sweep_ratio']:.2f}; dask default - local "
          f"pool: {summary['dask_default_minus_pool_per_run_ms']:+.1f} ms per run; load average "
          + ", ".join(f"{x:.1f}" for x in summary["load_average"]))  # fmt: skip


if __name__ == "__main__":
    main()
