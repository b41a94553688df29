"""The engine benchmark workload (``thermoswarm bench``, ``benchmarks/bench_engine.py``).

Workload: discs of 33 mm at packing fraction ``phi`` in a square walled box, ``kT`` chosen
so that the mean speed is 10 mm/s, heading and speed re-sampled every 0.1 s
(``tau = dt = 0.1 s``), Algorithm 3.

Reported by :func:`run_bench`: ``robot_steps_per_second`` and
``simulated_robot_seconds_per_second`` (timed steps only: no compilation, no checks),
``compile_seconds`` (the first step, which compiles the kernels or loads them from
Numba's cache, minus a timed step), ``max_overlap_fraction`` (the largest overlap any
timed step left, from the engine's exact per-step measure, and never less than the
independent cell-scan checks of sampled states), ``bytes_per_robot`` (the arrays held by
the state and the engine plus the largest allocation made within one step -- the
policy's temporaries -- traced with :mod:`tracemalloc`, divided by n; no recording),
``threads`` (Numba threads the steps ran on), ``n``, ``phi``, ``dt``.
"""

from __future__ import annotations

import math
import time
import tracemalloc
from typing import Any

import numpy as np

from thermoswarm.maxent import kT_for_mean_speed
from thermoswarm.policy import BoltzmannUniform
from thermoswarm.sim.engine import EngineParams, Simulator, place_lattice, threads_for
from thermoswarm.sim.world import box_world

DIAMETER = 33.0
MEAN_SPEED = 10.0
TAU = 0.1
#: Wall seconds the timed part of a default run aims at.
TARGET_WALL = 2.0


def workload(n: int, phi: float, seed: int = 0, dt: float = 0.1, **params: Any):
    """The benchmark's world, simulator and initial state."""
    r = DIAMETER / 2
    side = math.sqrt(n * math.pi * r * r / phi)
    world = box_world(side, side)
    sim = Simulator(
        world,
        EngineParams(dt=dt, tau=TAU, radius=r, **params),
        BoltzmannUniform(kT_for_mean_speed(MEAN_SPEED)),
    )
    rng = np.random.default_rng(seed)
    state = sim.init(place_lattice(world.bounds, n, r, rng), rng)
    return world, sim, state


def run_bench(
    n: int,
    phi: float,
    seconds: float | None = None,
    *,
    seed: int = 0,
    dt: float = 0.1,
    checks: int = 3,
    memory_steps: int = 3,
) -> dict[str, Any]:
    """Run the workload for ``seconds`` simulated seconds (default: ~2 s of wall time).

    Parameters
    ----------
    n, phi : robots and packing fraction.
    seconds : simulated seconds to time; by default as many steps as take about
        :data:`TARGET_WALL` wall seconds at the speed of the first steps (at least 5).
    checks : independent exact overlap checks spread over the run (not timed).
    memory_steps : steps traced with :mod:`tracemalloc` after the timed run.
    """
    world, sim, state = workload(n, phi, seed, dt)
    t0 = time.perf_counter()
    sim.step(state)  # compiles the kernels, or loads them from Numba's cache
    first = time.perf_counter() - t0
    t0 = time.perf_counter()
    sim.step(state)
    one = time.perf_counter() - t0
    sim.max_overlap(state)  # compile the check too
    state.counters[:] = 0
    if seconds is None:
        steps = max(5, int(TARGET_WALL / max(one, 1e-6)))
    else:
        steps = max(1, int(round(seconds / dt)))
    check_at = set(np.linspace(0, steps - 1, checks).astype(int).tolist()) if checks else set()
    wall = 0.0
    worst_checked = 0.0
    builds0 = sim.list_builds
    for k in range(steps):
        t0 = time.perf_counter()
        sim.step(state)
        wall += time.perf_counter() - t0
        if k in check_at:
            worst_checked = max(worst_checked, sim.max_overlap(state))
    builds = sim.list_builds - builds0
    per_step = state.counters.copy()
    # memory, in a separate pass (tracing slows every allocation down, so it is not on
    # while timing): the arrays the state and engine hold, plus the largest transient
    # allocation within one step (peak during the step minus memory in use before it)
    tracemalloc.start()
    transient = 0
    for _ in range(memory_steps):
        before = tracemalloc.get_traced_memory()[0]
        tracemalloc.reset_peak()
        sim.step(state)
        transient = max(transient, tracemalloc.get_traced_memory()[1] - before)
    tracemalloc.stop()
    state_bytes = sum(a.nbytes for a in state.to_arrays().values())
    held = state_bytes + sim.workspace_bytes()
    return {
        "n": n,
        "phi": phi,
        "dt": dt,
        "tau": TAU,
        "threads": threads_for(n),
        "steps": steps,
        "wall_seconds": wall,
        "compile_seconds": max(0.0, first - one),
        "robot_steps_per_second": n * steps / wall,
        "simulated_robot_seconds_per_second": n * steps * dt / wall,
        "max_overlap_fraction": max(float(per_step[1]) / 1e6, worst_checked) / DIAMETER,
        "checked_overlap_fraction": worst_checked / DIAMETER,
        "mean_sweeps_per_step": float(per_step[0]) / steps,
        "list_builds_per_step": builds / steps,
        "bytes_per_robot": (held + transient) / n,
        "held_bytes_per_robot": held / n,
        "step_transient_bytes_per_robot": transient / n,
    }
