"""Ours: the thermoswarm engine on the bench workload (``thermoswarm.sim.bench``)."""

from __future__ import annotations

from thermoswarm.sim import set_threads
from thermoswarm.sim.bench import DIAMETER, workload
from thermoswarm.sim.engine import threads_for

from .timing import DT, timed


def ours(n: int, phi: float, threads: int) -> dict:
    set_threads(threads)
    try:
        world, sim, state = workload(n, phi, seed=0, dt=DT)
        side = world.bounds[2]
        out = timed(lambda: sim.step(state), n, lambda: state.pos, side)
        out["engine_max_overlap_fraction"] = state.counters[1] / 1e6 / DIAMETER
        out["threads"] = threads_for(n)
        out["mean_sweeps_per_step"] = state.counters[0] / max(state.step, 1)
        return out
    finally:
        set_threads(None)
