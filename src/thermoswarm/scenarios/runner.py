"""Run a scenario into a directory, resumably.

``run(config, DIR)`` writes

- ``DIR/config.toml``  the fully resolved config (scenario, seed, every parameter);
- ``DIR/tracks.zarr``  frames streamed during the run (see :mod:`thermoswarm.sim.recorder`);
- ``DIR/metrics.json`` the scenario's metrics, plus a ``performance`` section;
- ``DIR/tracks.nc``    the trajectories in the exchange format (netCDF).

Everything is validated before anything is written (missing parents of ``DIR`` are then
created): a bad key or value, a swarm that cannot be placed, or an output path under a
file raises a one-line
:class:`~thermoswarm.errors.ThermoswarmError` and leaves no files behind.
``resume(DIR)`` continues a killed run from its last committed block; the result is
identical to an uninterrupted run with the same seed.
"""

from __future__ import annotations

import json
import math
import shutil
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm import __version__
from thermoswarm.config import (
    apply_overrides,
    check_magnitudes,
    dumps_toml,
    from_mapping,
    load_toml,
    parse_overrides,
    shown,
    to_dict,
)
from thermoswarm.errors import ConfigError, InputError, OutputError
from thermoswarm.fsutil import atomic_path, atomic_write_json, atomic_write_text, check_output_dir
from thermoswarm.scenarios import get
from thermoswarm.scenarios.base import Scenario, Setup, build_simulator, overlap_metrics
from thermoswarm.sim.engine import Simulator, SwarmState
from thermoswarm.sim.memory import check_run_memory
from thermoswarm.sim.recorder import ZarrRecorder, load_checkpoint, read_marker

__all__ = ["RunConfig", "resolve", "run", "resume", "open_run_tracks", "build"]


@dataclass(frozen=True)
class RunConfig:
    """A scenario name, its validated parameters and the seed."""

    scenario: str
    params: Any
    seed: int = 0

    def to_toml(self) -> str:
        return dumps_toml({"scenario": self.scenario, "seed": self.seed, **to_dict(self.params)})


def resolve(
    scenario: str | None = None,
    *,
    config_file: str | Path | None = None,
    overrides: tuple[str, ...] | list[str] = (),
    seed: int | None = None,
) -> RunConfig:
    """Merge a TOML file, ``--set`` overrides and ``--seed`` into a validated RunConfig."""
    data: dict[str, Any] = dict(load_toml(config_file)) if config_file else {}
    file_name = data.pop("scenario", None)
    file_seed = data.pop("seed", None)
    over = parse_overrides(overrides)
    over_seed = over.pop("seed", None)
    over.pop("scenario", None)
    name = scenario or file_name
    if name is None:
        raise ConfigError("no scenario given (pass SCENARIO or set scenario = ... in the config)")
    if scenario and file_name and scenario != file_name:
        raise ConfigError(f"{config_file}: scenario = {file_name!r} but {scenario!r} was asked")
    cls = get(str(name))
    source = (
        " and ".join(
            s for s in (str(config_file) if config_file else "", "--set" if overrides else "") if s
        )
        or None
    )
    params = from_mapping(cls.Params, apply_overrides(data, over), source=source)
    s = seed if seed is not None else over_seed if over_seed is not None else file_seed
    s = 0 if s is None else s
    if isinstance(s, bool) or not isinstance(s, int) or not 0 <= s < 2**63:
        raise ConfigError(f"seed must be an integer from 0 to 2**63 - 1, got {shown(s)}")
    check_run_params(params, source or "config")
    return RunConfig(str(name), params, int(s))


#: Largest magnitude of a finite number in a scenario's parameters: far beyond any
#: arena (mm), time (s) or temperature (mm^2/s^2) of the paper, and small enough that
#: areas, speeds and step counts made from it stay finite in float64.
MAX_PARAM = 1e12
#: Smallest non-zero magnitude (engine.dt = 1e-300 asks for 1e301 steps).
MIN_PARAM = 1e-9
#: Most time steps of one run.
MAX_STEPS = 10**12


def check_run_params(params: Any, source: str) -> None:
    """Refuse a float parameter outside [:data:`MIN_PARAM`, :data:`MAX_PARAM`] (or 0),
    naming its key, before the scenario computes with it."""
    # a long duration is refused by the memory check (its recorded frames) and by
    # MAX_STEPS, with the numbers
    check_magnitudes(params, source, smallest=MIN_PARAM, largest=MAX_PARAM,
                     what="the range the simulator handles", unbounded=("duration",))  # fmt: skip


def build(cfg: RunConfig) -> tuple[Scenario, Setup, Simulator, SwarmState]:
    """Build the scenario and the initial state (all draws from the seed's generator)."""
    scen = get(cfg.scenario)(cfg.params)
    key, n = scen.robot_count()
    rec = scen.recording
    n_frames = int(min(scen.duration / rec.interval, 2**62)) + 1
    check_run_memory(n, n_frames, rec.block, key=key)  # before any array is allocated
    rng = np.random.default_rng(cfg.seed)
    setup = scen.build(rng)
    sim = build_simulator(setup, getattr(getattr(cfg.params, "engine", None), "backend", "cpu"))
    state = sim.init(
        setup.positions,
        rng,
        headings=setup.headings,
        group=setup.group,
        velocities=setup.velocities,
    )
    return scen, setup, sim, state


def _steps(scen: Scenario, sim: Simulator) -> tuple[int, int]:
    dt = sim.params.dt
    if not scen.duration / dt <= MAX_STEPS:
        raise ConfigError(
            f"duration / engine.dt = {scen.duration:g} / {dt:g}: more than {MAX_STEPS:.0e} "
            "time steps in one run"
        )
    total = int(math.floor(scen.duration / dt + 1e-9))
    every = scen.recording.interval / dt
    if not every <= MAX_STEPS:
        raise ConfigError(
            f"record.interval = {scen.recording.interval:g}: more than {MAX_STEPS:.0e} "
            f"time steps of {dt:g} s between frames"
        )
    if abs(every - round(every)) > 1e-6 * max(1.0, every) or round(every) < 1:
        raise ConfigError(
            f"record.interval must be a multiple of engine.dt = {dt}, "
            f"got {scen.recording.interval}"
        )
    if total < 1:
        raise ConfigError(f"duration must be at least one time step ({dt} s)")
    return total, int(round(every))


def _checkpoint(cfg: RunConfig, state: SwarmState, acc: dict[str, np.ndarray]) -> dict[str, Any]:
    out: dict[str, Any] = dict(state.to_arrays())
    out.update({f"acc:{k}": v for k, v in acc.items()})
    out["json:rng"] = state.rng.bit_generator.state
    out["json:meta"] = {"scenario": cfg.scenario, "seed": cfg.seed, "step": state.step}
    return out


def _restore(ck: dict[str, Any]) -> tuple[SwarmState, dict[str, np.ndarray]]:
    bitgen = np.random.PCG64()
    bitgen.state = ck["json:rng"]
    state = SwarmState.from_arrays(ck, np.random.Generator(bitgen))
    acc = {k[4:]: np.array(v) for k, v in ck.items() if k.startswith("acc:")}
    return state, acc


def open_run_tracks(store: str | Path) -> xr.Dataset:
    """The committed frames of a run's Zarr store as a loaded trajectory dataset."""
    from thermoswarm.io.zarrstore import read

    ds = read(Path(store))
    for k in ("committed_frames", "checkpoint_file", "checkpoint_step", "complete"):
        ds.attrs.pop(k, None)
    return ds


def _check_out_dir(out: Path, *, resume: bool) -> None:
    check_output_dir(out)  # missing parents are created once the config is valid
    if not resume and (out / "tracks.zarr").exists():
        raise OutputError(f"{out} already holds a run; use --resume {out} or another --out")


def run(cfg: RunConfig, out_dir: str | Path, *, progress: bool | None = None) -> dict[str, Any]:
    """Run ``cfg`` into ``out_dir`` (see the module docstring); returns the metrics."""
    out = Path(out_dir)
    _check_out_dir(out, resume=False)
    scen, setup, sim, state = build(cfg)  # may raise ConfigError: nothing written yet
    total, every = _steps(scen, sim)
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "config.toml", cfg.to_toml())
    acc = scen.init_acc(setup, sim, state)
    return _loop(cfg, scen, setup, sim, state, acc, out, total, every, progress, fresh=True)


def resume(out_dir: str | Path, *, progress: bool | None = None) -> dict[str, Any]:
    """Continue the run in ``out_dir`` from its last committed block."""
    out = Path(out_dir)
    if not (out / "config.toml").is_file():
        raise InputError(f"{out}: no run to resume (no config.toml)")
    cfg = resolve(config_file=out / "config.toml")
    store = out / "tracks.zarr"
    marker = read_marker(store) if (store / "zarr.json").is_file() else {}
    if marker.get("complete") and (out / "metrics.json").is_file():
        return json.loads((out / "metrics.json").read_text())
    scen, setup, sim, state = build(cfg)
    total, every = _steps(scen, sim)
    ck_file = marker.get("checkpoint_file")
    # checkpoints other than the marker's are left-overs of a kill mid-commit
    for stale in out.glob("checkpoint-*.npz"):
        if stale.name != ck_file:
            stale.unlink()
    if not ck_file:  # killed before the first committed block: start again
        if store.exists():
            shutil.rmtree(store)
        acc = scen.init_acc(setup, sim, state)
        return _loop(cfg, scen, setup, sim, state, acc, out, total, every, progress, fresh=True)
    state, acc = _restore(load_checkpoint(out / ck_file))
    return _loop(cfg, scen, setup, sim, state, acc, out, total, every, progress, fresh=False)


def _recorder(
    cfg: RunConfig,
    scen: Scenario,
    setup: Setup,
    sim: Simulator,
    state: SwarmState,
    acc: dict[str, np.ndarray],
    store: Path,
    n_frames: int,
    every: int,
    *,
    fresh: bool,
) -> ZarrRecorder:
    """The run's Zarr recorder (``n_frames`` frames, one every ``every`` steps), opened
    to resume unless ``fresh``; a fresh run records its first frame at once."""
    fps = 1.0 / (every * sim.params.dt)
    attrs = {
        "fps": fps,
        "scenario": cfg.scenario,
        "seed": cfg.seed,
        "thermoswarm_version": __version__,
        "config": cfg.to_toml(),
        "dt": sim.params.dt,
        "tau": sim.params.tau,
        "radius": sim.params.radius,
        # what the analysis reads (thermoswarm.analysis.recording): the period of the
        # robots' re-draws and what the recorded ``speed`` variable holds
        "speed_kind": "instantaneous" if sim.params.mode == "inertial" else "commanded",
    }
    if sim.params.mode != "inertial":
        attrs["control_period"] = sim.params.tau
    rec = ZarrRecorder(
        store,
        n=state.n,
        n_frames=n_frames,
        block=scen.recording.block,
        extras=scen.extras(setup),
        extra_coords=scen.extra_coords(setup),
        attrs=attrs,
        dtype=scen.recording.dtype,
        resume=not fresh,
    )
    if fresh:
        rec.add(state.time, state.by_id(state.pos), scen.frame(sim, state, acc))
        if rec.pending == rec.block:
            rec.flush(_checkpoint(cfg, state, acc), step=state.step)
    return rec


def _performance(n: int, steps_run: int, dt: float, wall: float, jit: Any) -> dict[str, Any]:
    """``metrics["performance"]``: wall seconds of stepping (compiling apart), steps
    run and robot-steps (and simulated robot-seconds) per wall second."""
    return {
        "wall_seconds": wall,
        "compile_seconds": jit.seconds,
        "compiled": jit.compiled,
        "steps": steps_run,
        "robot_steps_per_second": n * steps_run / wall if wall > 0 else None,
        "simulated_robot_seconds_per_second": n * steps_run * dt / wall if wall > 0 else None,
    }


def _loop(
    cfg: RunConfig,
    scen: Scenario,
    setup: Setup,
    sim: Simulator,
    state: SwarmState,
    acc: dict[str, np.ndarray],
    out: Path,
    total: int,
    every: int,
    progress: bool | None,
    *,
    fresh: bool,
) -> dict[str, Any]:
    from tqdm import tqdm

    store = out / "tracks.zarr"
    rec = _recorder(cfg, scen, setup, sim, state, acc, store, total // every + 1, every,
                    fresh=fresh)  # fmt: skip
    from thermoswarm.cache import jit_timer

    t0 = time.perf_counter()
    start_step = state.step
    with (
        jit_timer() as jit,
        tqdm(
            total=total,
            initial=state.step,
            disable=None if progress is None else not progress,
            unit="step",
            mininterval=0.5,
            leave=False,
        ) as bar,
    ):
        while state.step < total:
            sim.step(state)
            scen.observe(sim, state, acc)
            if state.step % every == 0:
                if rec.add(state.time, state.by_id(state.pos), scen.frame(sim, state, acc)):
                    rec.flush(_checkpoint(cfg, state, acc), step=state.step)
            bar.update(1)
    # compiling (or loading) Numba kernels is not stepping: it is reported apart
    wall = max(time.perf_counter() - t0 - jit.seconds, 0.0)
    rec.flush(_checkpoint(cfg, state, acc), step=state.step)
    tracks = open_run_tracks(store)
    metrics = scen.metrics(setup, acc, tracks, sim, state)
    metrics.update(overlap_metrics(sim, state))  # every scenario, one definition
    if sim.params.mode == "overdamped" and "speed" in tracks and "heading" in tracks:
        from thermoswarm.sim.robot_model import limit_report, paper_robot, warn_limits

        lim = limit_report(tracks["speed"], tracks["heading"], scen.recording.interval,
                           sim.params.tau, paper_robot)  # fmt: skip
        metrics["robot_limits"] = {"robot": "paper_robot", **lim}
        warn_limits(lim)
    metrics["performance"] = _performance(
        state.n, state.step - start_step, sim.params.dt, wall, jit
    )
    atomic_write_json(out / "metrics.json", metrics)
    if scen.recording.netcdf:
        with atomic_path(out / "tracks.nc", suffix=".nc") as tmp:
            tracks.to_netcdf(tmp, engine="h5netcdf")
    ck = rec.group.attrs.get("checkpoint_file")
    rec.set_attrs(complete=True)
    if ck:
        (out / ck).unlink(missing_ok=True)
    return metrics
