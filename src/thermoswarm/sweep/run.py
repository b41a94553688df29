"""``run_sweep``: every run of a spec through an executor, with retries, into one table."""

from __future__ import annotations

import os
import queue
import traceback
from collections.abc import Sequence
from concurrent.futures import Executor, Future
from concurrent.futures.process import BrokenProcessPool
from dataclasses import asdict
from pathlib import Path
from typing import Any

from thermoswarm.errors import ConfigError, ThermoswarmError
from thermoswarm.fsutil import atomic_write_json, check_output_dir
from thermoswarm.sweep.pool import LocalPool, WorkerDied
from thermoswarm.sweep.spec import RunRecord, SweepSpec, expand, run_id, with_overrides
from thermoswarm.sweep.table import ResultsTable
from thermoswarm.sweep.worker import compile_here, finished, run_one

__all__ = ["run_sweep", "local_pool"]


def local_pool(max_workers: int | None = None, threads_per_run: int | None = 1) -> LocalPool:
    """The default executor: ``max_workers`` (default: all cores) local processes, each
    started with ``NUMBA_NUM_THREADS = threads_per_run``."""
    env = {} if threads_per_run is None else {"NUMBA_NUM_THREADS": str(int(threads_per_run))}
    return LocalPool(max_workers or os.cpu_count() or 1, env=env)


def _worker_lost(exc: BaseException) -> bool:
    """Did the task fail because its worker went away (not because of the run)?"""
    if isinstance(exc, WorkerDied | BrokenProcessPool):
        return True
    # Dask: the scheduler already re-ran the task on other workers and gave up
    return type(exc).__name__ == "KilledWorker"


def run_sweep(
    spec: SweepSpec,
    executor: Executor | Any | None = None,
    *,
    retries: int = 2,
    max_workers: int | None = None,
    threads_per_run: int | None = 1,
    progress: bool | None = None,
    overrides: Sequence[str] = (),
) -> list[RunRecord]:
    """Run every combination of ``spec``; return one :class:`RunRecord` per run.

    Writes ``OUT/<run_id>/`` per run, ``OUT/results.parquet`` (one row per run, see
    :mod:`thermoswarm.sweep.table`) as runs finish, and ``OUT/sweep.json`` at the end.

    Parameters
    ----------
    spec : SweepSpec
    executor : Executor or dask.distributed.Client, optional
        Where runs execute: any :class:`concurrent.futures.Executor` (e.g.
        ``client.get_executor()``; a ``Client`` itself is accepted too); default a
        :class:`~thermoswarm.sweep.pool.LocalPool` of ``max_workers`` processes.
    retries : int
        Further attempts of a run whose worker died or that crashed; each attempt
        resumes the run from its last committed block.  A :class:`ThermoswarmError`
        (the configuration itself) is not retried.  One run's attempts never count
        against another's.
    threads_per_run : int or None
        Numba threads inside each run, passed explicitly to every run (default 1: the
        workers provide the parallelism).  None leaves Numba's default.
    overrides : sequence of "key=value"
        Applied to ``spec.base`` (as ``--set`` does).
    """
    from tqdm import tqdm

    if retries < 0:
        raise ConfigError(f"retries must be >= 0, got {retries}")
    out = check_output_dir(spec.out)
    spec = with_overrides(spec, overrides)
    runs = expand(spec)
    out.mkdir(parents=True, exist_ok=True)
    if hasattr(executor, "get_executor"):  # a dask.distributed.Client
        executor = executor.get_executor()
    records, order, texts, todo, configs = _plan(runs, out)
    table = ResultsTable(out, spec.scenario, {rid: c.params for rid, c in configs.items()})
    for rec in records.values():
        if rec.status == "skipped":
            table.add(rec)
    table.write()
    if todo:
        compile_here([configs[rid] for rid in todo])
    own = executor is None
    ex = local_pool(max_workers, threads_per_run) if own else executor
    bar = tqdm(total=len(records), initial=len(records) - len(todo), unit="run",
               disable=None if progress is None else not progress, leave=False)  # fmt: skip
    clean = False
    try:
        _drive(ex, [records[rid] for rid in todo], texts, threads_per_run, retries, table, bar)
        clean = True
    finally:
        bar.close()
        table.write()
        if own:  # interrupted: do not wait for the runs in flight
            ex.shutdown(wait=clean, cancel_futures=True)
    if table.unavailable:
        import warnings

        warnings.warn(f"{out / 'results.parquet'} not written: {table.unavailable}", stacklevel=2)
    result = [records[rid] for rid in order]
    atomic_write_json(out / "sweep.json", {
        "scenario": spec.scenario, "grid": {k: list(v) for k, v in spec.grid.items()},
        "seeds": list(spec.seeds), "runs": [asdict(r) for r in result],
    })  # fmt: skip
    return result


def _plan(
    runs: Sequence[tuple[dict[str, Any], int, Any]], out: Path
) -> tuple[dict[str, RunRecord], list[str], dict[str, str], list[str], dict[str, Any]]:
    """``(records, order, texts, todo, configs)`` of the expanded ``runs``: one record per
    distinct run id (``"skipped"`` when ``OUT/<run_id>`` holds a finished run, else
    ``"pending"``), every run's id in grid order, the TOML of each pending run, the
    pending ids, and each id's configuration."""
    records: dict[str, RunRecord] = {}
    order: list[str] = []
    texts: dict[str, str] = {}
    todo: list[str] = []
    configs = {}
    for point, seed, cfg in runs:
        text = cfg.to_toml()
        rid = run_id(text)
        order.append(rid)
        if rid in records:
            continue
        rdir = out.absolute() / rid  # workers elsewhere need the whole path
        configs[rid] = cfg
        done = finished(rdir)
        if done is not None:
            records[rid] = RunRecord(rid, point, seed, str(rdir), "skipped", done)
        else:
            records[rid] = RunRecord(rid, point, seed, str(rdir), "pending")
            texts[rid] = text
            todo.append(rid)
    return records, order, texts, todo, configs


def _drive(
    ex: Any,
    todo: Sequence[RunRecord],
    texts: dict[str, str],
    threads_per_run: int | None,
    retries: int,
    table: ResultsTable,
    bar: Any,
) -> None:
    """Submit every run of ``todo`` to ``ex`` and collect them as they finish: a run
    whose worker died or that crashed is submitted again while it has attempts left
    (``retries``), a :class:`ThermoswarmError` fails it at once; each finished run goes
    into ``table`` and ticks ``bar``."""
    futures: dict[Future, RunRecord] = {}
    # futures report here as they finish: O(1) per run, however many are in flight
    finished_q: queue.SimpleQueue[Future] = queue.SimpleQueue()

    def submit(rec: RunRecord) -> None:
        rec.attempts += 1
        # the attempt number makes every call distinct (Dask merges equal calls)
        try:
            fut = ex.submit(run_one, texts[rec.run_id], rec.out, threads_per_run, rec.attempts)
        except Exception as exc:  # e.g. a broken ProcessPoolExecutor refuses work
            fut = Future()
            fut.set_exception(exc)
        futures[fut] = rec
        fut.add_done_callback(finished_q.put)

    def finish(rec: RunRecord, status: str) -> None:
        rec.status = status
        table.add(rec)
        bar.update(1)

    for rec in todo:
        submit(rec)
    while futures:
        try:
            fut = finished_q.get(timeout=1.0)  # a timeout lets Ctrl-C through
        except queue.Empty:
            continue
        rec = futures.pop(fut)
        try:
            rec.metrics = fut.result()
        except ThermoswarmError as exc:  # the configuration itself: no retry
            rec.error = str(exc)
            finish(rec, "failed")
        except Exception as exc:  # a dead worker or a crash inside the run
            if _worker_lost(exc):
                rec.error = f"worker lost: {exc}"
            else:
                rec.error = "".join(traceback.format_exception_only(exc)).strip()
            if rec.attempts <= retries:
                submit(rec)
            else:
                finish(rec, "failed")
        else:
            rec.error = None
            finish(rec, "done")
        table.maybe_write()
