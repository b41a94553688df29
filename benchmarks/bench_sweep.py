"""Sweep benchmark: the overhead per task of Dask against the local pool, in one process.

Both executors get two worker processes with one task each:

- ``local pool``: :func:`thermoswarm.sweep.local_pool` (the default executor);
- ``dask``: a ``distributed.LocalCluster`` (``thermoswarm sweep --cluster local:2``);
- ``stdlib``: :class:`concurrent.futures.ProcessPoolExecutor` for reference (a dead
  worker breaks it whole, which is why the sweep does not use it).

Two measurements per executor, after its workers have started and imported the sweep
(start-up, timed apart, includes that import):

1. dispatch: ``--tasks`` calls of a no-op (``abs(i)``) submitted at once; time per task;
2. a sweep of ``--runs`` short runs of the real engine (``box``, 10 robots, 1 s simulated,
   every run its own seed) through :func:`run_sweep`, each into a fresh directory,
   ending with one ``results.parquet`` of ``--runs`` rows; wall time per run and the
   difference per run from the local pool.

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


def _sweep(ex, out: Path, runs: int) -> dict:
    import pandas as pd

    from thermoswarm.sweep import SweepSpec, run_sweep

    spec = SweepSpec("box", out, BASE, {}, seeds=list(range(runs)))
    t0 = time.perf_counter()
    records = run_sweep(spec, executor=ex, progress=False)
    wall = time.perf_counter() - t0
    assert all(r.status == "done" for r in records), [r.error for r in records][:3]
    t1 = time.perf_counter()
    table = pd.read_parquet(out / "results.parquet")
    read = time.perf_counter() - t1
    assert len(table) == runs and table["run_id"].is_unique
    in_run = float(table["metrics.performance.wall_seconds"].sum())
    return {"sweep_s": wall, "per_run_ms": 1e3 * wall / runs, "in_run_loop_s": in_run,
            "table_rows": len(table), "table_columns": table.shape[1],
            "table_bytes": (out / "results.parquet").stat().st_size,
            "table_read_s": read}  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=1000, help="short runs per sweep")
    ap.add_argument("--tasks", type=int, default=2000, help="no-op tasks for dispatch")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()

    from distributed import Client, LocalCluster

    from thermoswarm.sweep import local_pool

    # compile the kernels once, so that no executor pays for it
    from thermoswarm.sweep.spec import SweepSpec, expand
    from thermoswarm.sweep.worker import compile_here

    compile_here([cfg for _, _, cfg in expand(SweepSpec("box", Path("x"), BASE))])
    rows = {}
    with tempfile.TemporaryDirectory(prefix="bench-sweep-") as tmp:
        for name in ("local pool", "dask", "stdlib"):
            t0 = time.perf_counter()
            cluster = client = None
            if name == "local pool":
                ex = local_pool(args.workers, threads_per_run=1)
            elif name == "dask":
                cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1,
                                       processes=True, dashboard_address=":0",
                                       env={"NUMBA_NUM_THREADS": "1"})  # fmt: skip
                client = Client(cluster)
                ex = client.get_executor()
            else:
                spawn = multiprocessing.get_context("spawn")
                ex = ProcessPoolExecutor(args.workers, mp_context=spawn)
            # start every worker and import the sweep there (one task each, held 1 s)
            warm = [ex.submit(_warm, 1.0 + 1e-6 * i) for i in range(args.workers)]
            assert len({f.result() for f in warm}) == args.workers  # one per process
            start = time.perf_counter() - t0 - 1.0
            row = {"startup_s": start, "dispatch_ms": 1e3 * _dispatch(ex, args.tasks)}
            if name != "stdlib":
                row.update(_sweep(ex, Path(tmp) / name.replace(" ", "-"), args.runs))
            rows[name] = row
            if client is not None:
                client.close()
                cluster.close()
            else:
                ex.shutdown()
    pool, dask = rows["local pool"], rows["dask"]
    summary = {
        "dask_minus_pool_dispatch_ms": dask["dispatch_ms"] - pool["dispatch_ms"],
        "dask_minus_pool_per_run_ms": dask["per_run_ms"] - pool["per_run_ms"],
        "dask_over_pool_sweep_ratio": dask["sweep_s"] / pool["sweep_s"],
        "runs": args.runs, "tasks": args.tasks, "workers": args.workers,
        "cpus": os.cpu_count(), "load_average": os.getloadavg(),
    }  # fmt: skip
    if args.json:
        print(json.dumps({"executors": rows, "summary": summary}, indent=1))
        return
    print(f"{args.runs} short runs and {args.tasks} no-op tasks per executor, "
          f"{args.workers} workers; cpus {os.cpu_count()}")  # fmt: skip
    print(f"{'executor':<11} {'start s':>8} {'no-op ms':>9} {'sweep s':>8} {'ms/run':>7} "
          f"{'in-run s':>9} {'table':>12}")  # fmt: skip
    for name, r in rows.items():
        sweep = (f"{r['sweep_s']:8.1f} {r['per_run_ms']:7.1f} {r['in_run_loop_s']:9.1f} "
                 f"{r['table_rows']:>5} x {r['table_columns']:<3}" if "sweep_s" in r
                 else f"{'-':>8} {'-':>7} {'-':>9} {'-':>12}")  # fmt: skip
        print(f"{name:<11} {r['startup_s']:8.2f} {r['dispatch_ms']:9.3f} {sweep}")
    print(f"dask - local pool: {summary['dask_minus_pool_dispatch_ms']:+.3f} ms per no-op "
          f"task, {summary['dask_minus_pool_per_run_ms']:+.1f} ms per run; sweep time ratio "
          f"dask / pool {summary['dask_over_pool_sweep_ratio']:.2f}; load average "
          + ", ".join(f"{x:.1f}" for x in summary["load_average"]))  # fmt: skip


if __name__ == "__main__":
    main()
