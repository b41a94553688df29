"""What runs on a worker: one run of a sweep, started or resumed in its directory.

:func:`run_one` is the only function a sweep sends to an executor.  Everything it needs
is in its arguments (the run's resolved config with its seed, its directory, the thread
count and the attempt number), so any worker that sees the sweep directory can run it,
and no two calls are equal (a scheduler that merges identical calls merges nothing).

Each attempt appends a line to ``DIR/attempts.jsonl``: where it ran (host, pid), the
frames already committed when it started (0 for a fresh start), and at its end the
Numba thread count in effect or its error.
"""

from __future__ import annotations

import json
import math
import os
import socket
import time
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numba

from thermoswarm.config import from_mapping
from thermoswarm.errors import ThermoswarmError
from thermoswarm.scenarios import get, runner
from thermoswarm.sim.engine import set_threads
from thermoswarm.sim.recorder import read_marker

__all__ = ["run_one", "finished", "compile_here", "committed_frames"]

ATTEMPTS_LOG = "attempts.jsonl"


def committed_frames(out: Path) -> int:
    """Frames of the run in ``out`` that are committed to its store (0 if none)."""
    store = out / "tracks.zarr"
    if not (store / "zarr.json").is_file():
        return 0
    try:
        return int(read_marker(store).get("committed_frames", 0))
    except ThermoswarmError:
        return 0


def _log(out: Path, entry: dict[str, Any]) -> None:
    # One short write in append mode per line: lines of concurrent writers never mix.
    out.mkdir(exist_ok=True)
    with open(out / ATTEMPTS_LOG, "a", encoding="utf-8") as fh:
        fh.write(json.dumps(entry) + "\n")


def run_one(config_toml: str, out_dir: str, threads: int | None, attempt: int = 1) -> dict:
    """Run (or resume from its last committed block) one configuration; its metrics.

    ``threads`` is the Numba thread count of the run, set explicitly (None: Numba's
    default).  A :class:`ThermoswarmError` means the configuration itself is bad.
    """
    if threads is not None:  # explicit: the engine never overrides it
        set_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
    out = Path(out_dir)
    _log(out, {"event": "start", "attempt": attempt, "host": socket.gethostname(),
               "pid": os.getpid(), "time": time.time(),
               "committed_frames": committed_frames(out)})  # fmt: skip
    try:
        if (out / "tracks.zarr").is_dir():
            metrics = runner.resume(out, progress=False)
        else:
            data = tomllib.loads(config_toml)
            name, seed = data.pop("scenario"), data.pop("seed")
            cfg = runner.RunConfig(name, from_mapping(get(name).Params, data), seed)
            metrics = runner.run(cfg, out, progress=False)
    except Exception as exc:
        _log(out, {"event": "error", "attempt": attempt, "pid": os.getpid(),
                   "time": time.time(), "error": f"{type(exc).__name__}: {exc}"})  # fmt: skip
        raise
    _log(out, {"event": "end", "attempt": attempt, "pid": os.getpid(), "time": time.time(),
               "numba_threads": numba.get_num_threads()})  # fmt: skip
    return metrics


def read_attempts(out: str | Path) -> list[dict[str, Any]]:
    """The lines of a run's ``attempts.jsonl`` (a line cut by a kill is skipped)."""
    path = Path(out) / ATTEMPTS_LOG
    if not path.is_file():
        return []
    entries = []
    for line in path.read_text(encoding="utf-8").splitlines():
        try:
            entries.append(json.loads(line))
        except ValueError:
            continue
    return entries


def finished(out: Path) -> dict[str, Any] | None:
    """The metrics of the finished run in ``out`` (store marked complete), else None."""
    if not (out / "metrics.json").is_file() or not (out / "tracks.zarr").is_dir():
        return None
    try:
        if not read_marker(out / "tracks.zarr").get("complete"):
            return None
        return json.loads((out / "metrics.json").read_text())
    except (ThermoswarmError, ValueError, OSError):
        return None


def compile_here(configs: Sequence[runner.RunConfig]) -> None:
    """Build and step each distinct configuration for one control period in this process,
    so that Numba compiles (and caches) every kernel the runs need before the workers start.

    Workers that compile the same function at the same moment race on Numba's cache index
    (each numbers its entry ``.1.nbc`` and the last index written may name the other's
    code), which can load the wrong machine code.  Compiled here first, the workers only
    read the cache.  A configuration that fails to build is left for its run to report.
    """
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
