"""Parameter sweeps over any :class:`concurrent.futures.Executor`.

A sweep is a scenario, a base configuration, a grid of values for some keys (their
Cartesian product) and a list of seeds.  Every combination is one run, written to
``OUT/<run_id>/`` by :func:`thermoswarm.scenarios.runner.run`; ``run_id`` is a hash of
the run's fully resolved configuration, so

- a finished run (``metrics.json`` written and the store marked complete) is skipped
  when the sweep is started again -- unless the simulation code changed since (the run
  id includes a fingerprint of the engine, policies and scenarios);
- a killed run is resumed from its last committed block;
- two sweeps that share a run share its directory and its result.

The default executor is a local process pool (``spawn`` start method: forking a process
that has started OpenMP threads can hang) whose workers each use one Numba thread; a
crashed worker (``BrokenProcessPool``) gets a fresh pool and the run is retried.  For a
cluster pass any executor, e.g. ``dask.distributed.Client(...).get_executor()`` (or
dask-jobqueue for SLURM); seeds are explicit in every task, so a scheduler that merges
identical calls cannot merge different runs.

Results are also written to ``OUT/sweep.json`` (atomically).
"""

from __future__ import annotations

import hashlib
import itertools
import math
import multiprocessing
import os
import traceback
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor, Future, ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from thermoswarm.config import parse_overrides
from thermoswarm.errors import ConfigError, ThermoswarmError
from thermoswarm.fsutil import atomic_write_json

__all__ = ["SweepSpec", "RunRecord", "expand", "run_sweep", "run_id"]


@dataclass(frozen=True)
class SweepSpec:
    """What to run.

    Attributes
    ----------
    scenario : str
        Registered scenario name.
    out : Path
        Directory of the sweep (created with its parents).
    base : mapping
        Parameters shared by every run (nested dicts or dotted keys).
    grid : mapping of dotted key -> sequence
        Values to sweep; runs are the Cartesian product.
    seeds : sequence of int
        Seeds; every grid point runs once per seed.
    """

    scenario: str
    out: Path
    base: Mapping[str, Any] = field(default_factory=dict)
    grid: Mapping[str, Sequence[Any]] = field(default_factory=dict)
    seeds: Sequence[int] = (0,)


@dataclass
class RunRecord:
    """One run of a sweep: its grid point, seed, directory, status and metrics."""

    run_id: str
    params: dict[str, Any]
    seed: int
    out: str
    status: str  # "done", "skipped" (already finished), "failed"
    metrics: dict[str, Any] | None = None
    error: str | None = None


def _set_dotted(data: dict[str, Any], key: str, value: Any) -> None:
    node = data
    parts = key.split(".")
    for part in parts[:-1]:
        node = node.setdefault(part, {})
        if not isinstance(node, dict):
            raise ConfigError(f"sweep key {key!r}: {part!r} is not a section")
    node[parts[-1]] = value


def _flatten_base(base: Mapping[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in base.items():
        if "." in k:
            _set_dotted(out, k, v)
        elif isinstance(v, Mapping):
            out[k] = _flatten_base(v)
        else:
            out[k] = v
    return out


def code_fingerprint() -> str:
    """SHA-256 of the simulation code (engine, policies, laws, scenarios).

    Part of every run id, so that a sweep restarted after the code changed reruns its
    runs instead of skipping them as finished.
    """
    global _FINGERPRINT
    if _FINGERPRINT is None:
        import thermoswarm

        root = Path(thermoswarm.__file__).parent
        files = sorted([*(root / "sim").glob("*.py"), *(root / "scenarios").glob("*.py"),
                        root / "policy.py", root / "maxent.py"])  # fmt: skip
        h = hashlib.sha256(thermoswarm.__version__.encode())
        for f in files:
            h.update(f.name.encode())
            h.update(f.read_bytes())
        _FINGERPRINT = h.hexdigest()
    return _FINGERPRINT


_FINGERPRINT: str | None = None


def run_id(config_toml: str) -> str:
    """The id of a run: 16 hex digits of the SHA-256 of its resolved config and of the
    code that runs it (:func:`code_fingerprint`)."""
    return hashlib.sha256((code_fingerprint() + config_toml).encode()).hexdigest()[:16]


def expand(spec: SweepSpec) -> list[tuple[dict[str, Any], int, Any]]:
    """All runs of a sweep as ``(grid point, seed, RunConfig)``, validated up front.

    A bad key or value anywhere raises :class:`ConfigError` before anything runs.
    """
    from thermoswarm.config import from_mapping
    from thermoswarm.scenarios import get
    from thermoswarm.scenarios.runner import RunConfig

    cls = get(spec.scenario)
    keys = list(spec.grid)
    for k in keys:
        if isinstance(spec.grid[k], str) or not isinstance(spec.grid[k], Sequence):
            raise ConfigError(f"sweep grid {k!r} must be a list of values")
    if not spec.seeds:
        raise ConfigError("sweep needs at least one seed")
    runs = []
    for values in itertools.product(*(spec.grid[k] for k in keys)):
        point = dict(zip(keys, values, strict=True))
        data = _flatten_base(spec.base)
        for k, v in point.items():
            _set_dotted(data, k, v)
        params = from_mapping(cls.Params, data, source=f"sweep point {point}")
        for seed in spec.seeds:
            if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
                raise ConfigError(f"sweep seeds must be non-negative integers, got {seed!r}")
            runs.append((point, int(seed), RunConfig(spec.scenario, params, int(seed))))
    return runs


def _run_one(config_toml: str, out_dir: str, threads: int | None) -> dict[str, Any]:
    """Worker: run (or resume) one configuration; returns its metrics."""
    if threads is not None:
        import numba

        numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    import tomllib

    from thermoswarm.config import from_mapping
    from thermoswarm.scenarios import get, runner

    out = Path(out_dir)
    if (out / "tracks.zarr").is_dir():
        return runner.resume(out, progress=False)
    data = tomllib.loads(config_toml)
    name, seed = data.pop("scenario"), data.pop("seed")
    cfg = runner.RunConfig(name, from_mapping(get(name).Params, data), seed)
    return runner.run(cfg, out, progress=False)


def _compile_here(configs: Sequence[Any]) -> None:
    """Build and step each distinct configuration for one control period in this process,
    so that Numba compiles (and caches) every kernel the runs need before the workers start.

    Workers that compile the same function at the same moment race on Numba's cache index
    (each numbers its entry ``.1.nbc`` and the last index written may name the other's
    code), which can load the wrong machine code.  Compiled here first, the workers only
    read the cache.  A configuration that fails to build is left for its run to report.
    """
    from thermoswarm.scenarios import runner

    seen: set[str] = set()
    for cfg in configs:
        key = runner.RunConfig(cfg.scenario, cfg.params, 0).to_toml()
        if key in seen:
            continue
        seen.add(key)
        try:
            scen, setup, sim, state = runner.build(cfg)
            acc = scen.init_acc(setup, sim, state)
            steps = int(math.ceil(sim.params.tau / sim.params.dt)) + 1
            for _ in range(min(steps, runner._steps(scen, sim)[0])):
                sim.step(state)
                scen.observe(sim, state, acc)
            scen.frame(sim, state, acc)
        except ThermoswarmError:
            continue


def _finished(out: Path) -> dict[str, Any] | None:
    import json

    from thermoswarm.sim.recorder import read_marker

    if not (out / "metrics.json").is_file() or not (out / "tracks.zarr").is_dir():
        return None
    try:
        if not read_marker(out / "tracks.zarr").get("complete"):
            return None
        return json.loads((out / "metrics.json").read_text())
    except (ThermoswarmError, ValueError, OSError):
        return None


def _default_executor(max_workers: int | None) -> ProcessPoolExecutor:
    return ProcessPoolExecutor(
        max_workers=max_workers or os.cpu_count() or 1,
        mp_context=multiprocessing.get_context("spawn"),
    )


def run_sweep(
    spec: SweepSpec,
    executor: Executor | None = None,
    *,
    retries: int = 2,
    max_workers: int | None = None,
    threads_per_run: int | None = 1,
    progress: bool | None = None,
    overrides: Sequence[str] = (),
) -> list[RunRecord]:
    """Run every combination of ``spec``; return one :class:`RunRecord` per run.

    Parameters
    ----------
    spec : SweepSpec
    executor : Executor, optional
        Where runs execute; default a local process pool of ``max_workers`` processes.
    retries : int
        Attempts after the first for a run that raised (or whose worker died).  Errors
        caused by the configuration are not retried.
    threads_per_run : int or None
        Numba threads inside each run (default 1: the pool provides the parallelism).
    overrides : sequence of "key=value"
        Applied to ``spec.base`` (as ``--set`` does).
    """
    from tqdm import tqdm

    from thermoswarm.fsutil import check_output_dir

    out = check_output_dir(spec.out)
    if overrides:
        base = _flatten_base(spec.base)
        for k, v in parse_overrides(overrides).items():
            base[k] = v if not isinstance(v, dict) else {**base.get(k, {}), **v}
        spec = SweepSpec(spec.scenario, spec.out, base, spec.grid, spec.seeds)
    runs = expand(spec)
    out.mkdir(parents=True, exist_ok=True)
    records: dict[str, RunRecord] = {}
    todo: list[tuple[str, str]] = []
    for point, seed, cfg in runs:
        text = cfg.to_toml()
        rid = run_id(text)
        rdir = out / rid
        done = _finished(rdir)
        if done is not None:
            records[rid] = RunRecord(rid, point, seed, str(rdir), "skipped", done)
        elif rid not in records:
            records[rid] = RunRecord(rid, point, seed, str(rdir), "pending")
            todo.append((rid, text))
    own = executor is None
    if todo:
        todo_ids = {rid for rid, _ in todo}
        _compile_here([cfg for _, _, cfg in runs if run_id(cfg.to_toml()) in todo_ids])
    ex = _default_executor(max_workers) if own else executor
    attempts = dict.fromkeys((rid for rid, _ in todo), 0)
    texts = dict(todo)
    pending = list(texts)
    bar = tqdm(
        total=len(records),
        initial=len(records) - len(pending),
        unit="run",
        disable=None if progress is None else not progress,
        leave=False,
    )
    try:
        while pending:
            futures: dict[Future, str] = {}
            for rid in pending:
                attempts[rid] += 1
                futures[ex.submit(_run_one, texts[rid], records[rid].out, threads_per_run)] = rid
            pending = []
            broken = False
            for fut in as_completed(futures):
                rid = futures[fut]
                rec = records[rid]
                try:
                    rec.metrics = fut.result()
                    rec.status, rec.error = "done", None
                    bar.update(1)
                except ThermoswarmError as exc:  # the configuration itself: no retry
                    rec.status, rec.error = "failed", str(exc)
                    bar.update(1)
                except BrokenProcessPool:
                    broken = True
                    rec.error = "worker process died"
                    _retry_or_fail(rec, attempts[rid], retries, pending, bar)
                except Exception as exc:  # a crash inside the run: retry
                    rec.error = "".join(traceback.format_exception_only(exc)).strip()
                    _retry_or_fail(rec, attempts[rid], retries, pending, bar)
            if broken and own:
                ex.shutdown(wait=False, cancel_futures=True)
                ex = _default_executor(max_workers)
    finally:
        bar.close()
        if own:
            ex.shutdown(wait=True, cancel_futures=True)
    result = [records[run_id(cfg.to_toml())] for _, _, cfg in runs]
    atomic_write_json(out / "sweep.json", {
        "scenario": spec.scenario, "grid": {k: list(v) for k, v in spec.grid.items()},
        "seeds": list(spec.seeds), "runs": [asdict(r) for r in result],
    })  # fmt: skip
    return result


def _retry_or_fail(
    rec: RunRecord, attempt: int, retries: int, pending: list[str], bar: Any
) -> None:
    if attempt <= retries:
        pending.append(rec.run_id)
    else:
        rec.status = "failed"
        bar.update(1)
