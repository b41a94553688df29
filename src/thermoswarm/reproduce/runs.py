"""Running the experiments: one worker pool for every sweep, the progress log, and a
scenario run that reuses a finished run in its directory."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from concurrent.futures import Executor
from pathlib import Path
from typing import Any

from thermoswarm.reproduce.plans import Plan
from thermoswarm.reproduce.progress import Estimate, Usage, measure, meter


def _duration(seconds: float) -> str:
    seconds = max(0.0, seconds)
    if seconds < 90:
        return f"{seconds:.0f} s"
    m, s = divmod(int(round(seconds)), 60)
    return f"{m} min {s:02d} s" if m < 60 else f"{m // 60} h {m % 60:02d} min"


class _Pool(Executor):
    """One pool for every sweep of a ``reproduce`` (compression, regime, mechanism,
    scaling).

    A pool per sweep started fresh worker processes (each importing the engine, SciPy
    and xarray) 17 times in the compression step alone.  Processes: the sweeps' local
    pool (a worker that dies fails only its own run, which the sweep retries).
    ``workers == 1`` runs everything in this process, one run at a time.
    """

    def __init__(self, workers: int | None) -> None:
        self.workers = workers
        self._ex: Executor | None = None

    def _make(self) -> Executor:
        if self.workers == 1:
            from concurrent.futures import ThreadPoolExecutor

            return ThreadPoolExecutor(max_workers=1)
        from thermoswarm.sweep import local_pool

        return local_pool(self.workers)

    def submit(self, fn, /, *args, **kwargs):  # type: ignore[override]
        from concurrent.futures.process import BrokenProcessPool

        if self._ex is None:
            self._ex = self._make()
        try:
            return self._ex.submit(fn, *args, **kwargs)
        except BrokenProcessPool:
            self._ex.shutdown(wait=False, cancel_futures=True)
            self._ex = self._make()
            return self._ex.submit(fn, *args, **kwargs)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        if self._ex is not None:
            self._ex.shutdown(wait=wait, cancel_futures=cancel_futures)
            self._ex = None


class _Log:
    """One line per finished step with the time it took and an estimate of what is left
    (:class:`~thermoswarm.reproduce.progress.Estimate`: the plan's CPU seconds per step at
    this machine's measured speed and load); on a terminal also a line when a step
    starts, and the runs' progress bars.  ``clock`` and ``usage`` are the wall clock and
    the CPU meter, ``cores`` the machine's (default: those this process may use)."""

    def __init__(
        self,
        verbose: bool,
        plan: Plan,
        steps: list[str],
        workers: int | None = None,
        clock: Callable[[], float] = time.perf_counter,
        usage: Callable[[], Usage | None] = measure,
        cores: int | None = None,
    ) -> None:
        import os
        import sys

        self.verbose = verbose
        self.tty = verbose and sys.stdout.isatty()
        self.clock, self.usage = clock, usage
        self.t0 = clock()
        self.times: dict[str, float] = {}
        self.cpu: dict[str, list[float]] = {}  # CPU seconds: this process, the workers
        self.steps = steps
        if cores is None and hasattr(os, "sched_getaffinity"):
            cores = len(os.sched_getaffinity(0))
        cores = cores or os.cpu_count() or 1
        cost = {s: plan.cost.get(s, (1.0, 0.0)) for s in steps}
        self.estimate = Estimate(cost, cores, workers or os.cpu_count() or 1)

    @property
    def bars(self) -> bool | None:
        """``progress`` for runs and studies: bars on a terminal, nothing in a log (the
        step lines are the log) or when quiet."""
        return None if self.tty else False

    def start_up(self) -> None:
        """Import what every step needs before the first step starts, so that the first
        step's pace is its own work; the machine's load before the first step is
        measured on these imports."""
        since = meter(self.clock, self.usage)
        import matplotlib.pyplot  # noqa: F401
        import scipy.stats  # noqa: F401
        import xarray  # noqa: F401

        import thermoswarm.analysis.study  # noqa: F401
        import thermoswarm.report.analysis_figures  # noqa: F401
        import thermoswarm.scenarios.runner  # noqa: F401

        wall, used = since()
        self.start_up_s = round(wall, 1)
        if used is not None and used.machine_busy is not None and wall > 0:
            others = max(0.0, used.machine_busy - used.own - used.children) / wall
            self.estimate.start_share = max(0.1, self.estimate.cores - others)

    def left(self) -> float:
        """Wall seconds left: the steps not finished at the measured speed and load."""
        return self.estimate.left(self.steps)

    def step(self, name: str) -> Callable[[], None]:
        """Start step ``name``; returns the function that marks it done."""
        since = meter(self.clock, self.usage)
        k = self.steps.index(name) + 1 if name in self.steps else 0
        if self.tty:
            print(f"[{_duration(self.clock() - self.t0):>11s}] {k}/{len(self.steps)} {name} "
                  f"... (about {_duration(self.left())} left)", flush=True)  # fmt: skip

        def done() -> None:
            took, used = since()
            self.times[name] = round(took, 1)
            if used is not None:
                self.cpu[name] = [round(used.own, 1), round(used.children, 1)]
            self.estimate.finish(name, took, used)
            if self.verbose:
                left = self.left()
                tail = (f"; about {_duration(left)} left (this run gets "
                        f"{self.estimate.share():.2g} of {self.estimate.cores} cores)"
                        if left > 0 else "")  # fmt: skip
                print(f"[{_duration(self.clock() - self.t0):>11s}] {k}/{len(self.steps)} "
                      f"{name} done in {_duration(took)}{tail}", flush=True)  # fmt: skip

        return done


def _run(name: str, out: Path, overrides: dict[str, Any] | None = None, seed: int = 0,
         progress: bool | None = False):  # fmt: skip
    """Run (or reuse the finished run in) ``out``; returns (metrics, tracks, setup info)."""
    import xarray as xr

    from thermoswarm.config import from_mapping
    from thermoswarm.scenarios import get
    from thermoswarm.scenarios.runner import RunConfig, build, open_run_tracks, resume, run
    from thermoswarm.sweep import _flatten_base

    cls = get(name)
    cfg = RunConfig(name, from_mapping(cls.Params, _flatten_base(overrides or {})), seed)
    out.parent.mkdir(parents=True, exist_ok=True)
    if (out / "metrics.json").is_file() and (out / "config.toml").read_text() == cfg.to_toml():
        metrics = json.loads((out / "metrics.json").read_text())
    elif (out / "tracks.zarr").is_dir() and (out / "config.toml").read_text() == cfg.to_toml():
        metrics = resume(out, progress=progress)
    else:
        if out.exists():
            import shutil

            shutil.rmtree(out)
        metrics = run(cfg, out, progress=progress)
    nc = out / "tracks.nc"
    tracks = xr.open_dataset(nc).load() if nc.is_file() else open_run_tracks(out / "tracks.zarr")
    _, setup, _, _ = build(cfg)
    return metrics, tracks, setup.info
