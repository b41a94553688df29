"""The engine benchmark workload on the GPU backend (``thermoswarm bench --backend gpu``).

The workload of :mod:`thermoswarm.sim.bench` (discs of 33 mm at packing fraction ``phi``
in a walled square box, mean speed 10 mm/s, heading and speed re-drawn every 0.1 s,
``dt = 0.1 s``), with the policy's draws made on the device.  Reported:
``robot_steps_per_second`` (timed over whole steps, the device synchronised at both
ends; compilation and the first step excluded), ``exact_max_overlap_fraction`` (the
final state's largest overlap by an independent SciPy k-d tree on the host, or the
device's exhaustive pair search without ``exact_check``), ``max_overlap_fraction``
(the largest of that, of the overlap left by any step's sweeps and of the device's
checks during the run), ``device_bytes_per_robot`` (every device array of the
engine, divided by n), ``device`` (the GPU's name, or numba-cuda's simulator),
``mean_sweeps_per_step``, ``launches_per_step``, ``rebuilds_per_step``,
``bytes_per_robot_step`` (the device-memory traffic the kernels make, counted in
:data:`STEP_BYTES`, with the run's sweeps and rebuilds) and ``bandwidth_share`` (that
traffic at the measured speed over the card's peak bandwidth; None in the simulator).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from thermoswarm.maxent import kT_for_mean_speed
from thermoswarm.policy import BoltzmannUniform
from thermoswarm.sim.engine import EngineParams, place_lattice
from thermoswarm.sim.gpu.check import exact_max_overlap
from thermoswarm.sim.gpu.engine import GpuSimulator
from thermoswarm.sim.gpu.runtime import cuda, device_name, simulated
from thermoswarm.sim.world import box_world

__all__ = ["bytes_per_robot_step", "peak_bandwidth", "run_bench_gpu"]

#: Device-memory bytes a robot moves in each part of a step, counted from the kernels
#: (reads + writes of its own entries; a neighbour's position, read by the ~9 robots
#: around it from memory sorted by cell, counted once, as it comes from the L2 cache).
STEP_BYTES = {
    # x, y, xr, yr, heading, speed, timer, ids read; x, y, heading, speed, timer written
    "begin_step": 32 + 20,
    # per sweep: source position, build position, cell_start (~1 entry), cell flag read;
    # corrected position written
    "sweep": 8 + 8 + 4 + 1 + 8,
    # per rebuild: zero counts, keys (positions read, cell and rank written, an atomic
    # read-modify-write), the scan (counts read and written twice), the scatter, the
    # in-cell order, the gather of the 9 robot arrays (read and written) and the perm
    "rebuild": 4 + 8 + 8 + 8 + 16 + 16 + 12 + 4 + 36 + 36,
}


def bytes_per_robot_step(sweeps: float, rebuilds_per_step: float) -> float:
    """Device-memory traffic (bytes) of one robot-step with ``sweeps`` Jacobi sweeps a
    step and a grid rebuild every ``1 / rebuilds_per_step`` steps (:data:`STEP_BYTES`).
    A lower bound: scattered reads that miss the cache cost whole 32-byte sectors."""
    b = STEP_BYTES
    return b["begin_step"] + sweeps * b["sweep"] + rebuilds_per_step * b["rebuild"]


def peak_bandwidth() -> float | None:
    """The current GPU's peak memory bandwidth (bytes/s: 2 x memory clock x bus width),
    or None in the simulator."""
    if simulated():
        return None
    dev = cuda.get_current_device()
    return 2.0 * dev.MEMORY_CLOCK_RATE * 1e3 * dev.GLOBAL_MEMORY_BUS_WIDTH / 8


DIAMETER = 33.0
MEAN_SPEED = 10.0
TAU = 0.1


def run_bench_gpu(
    n: int,
    phi: float,
    seconds: float | None = None,
    *,
    seed: int = 0,
    dt: float = 0.1,
    checks: int = 3,
    device: str | None = None,
    exact_check: bool = True,
    host_policy: bool = False,
) -> dict[str, Any]:
    """Run the workload for ``seconds`` simulated seconds (default: 2e9 robot-steps on
    a CUDA GPU, 2e4 in numba-cuda's simulator; 20 to 2,000 steps).

    ``checks`` device overlap checks are spread over the run (not timed); with
    ``exact_check`` the final state is also checked by SciPy's k-d tree on the host.
    """
    r = DIAMETER / 2
    side = math.sqrt(n * math.pi * r * r / phi)
    world = box_world(side, side)
    params = EngineParams(dt=dt, tau=TAU, radius=r)
    policy = BoltzmannUniform(kT_for_mean_speed(MEAN_SPEED))
    sim = GpuSimulator(world, params, policy, device=device, host_policy=host_policy)
    rng = np.random.default_rng(seed)
    t0 = time.perf_counter()
    state = sim.init(place_lattice(world.bounds, n, r, rng), rng)
    sim.step(state)  # warm-up: compilation excluded
    sim.max_overlap(state)
    cuda.synchronize()
    setup = time.perf_counter() - t0
    state.counters[:] = 0
    rebuilds0 = sim.rebuilds
    launches0 = sim.launches
    if seconds is None:
        budget = 2e4 if simulated() else 2e9
        steps = min(2000, max(20, int(budget / max(n, 1))))
    else:
        steps = max(1, round(seconds / dt))
    check_at = set(np.linspace(0, steps - 1, checks).astype(int).tolist()) if checks else set()
    wall = 0.0
    worst_device = 0.0
    for k in range(steps):
        t0 = time.perf_counter()
        sim.step(state)
        cuda.synchronize()
        wall += time.perf_counter() - t0
        if k in check_at:
            worst_device = max(worst_device, sim.max_overlap(state))
    out: dict[str, Any] = {
        "backend": "gpu",
        "device": device_name(),
        "device_alias": sim.device,
        "n": n,
        "phi": phi,
        "dt": dt,
        "tau": TAU,
        "steps": steps,
        "setup_seconds": setup,
        "wall_seconds": wall,
        "robot_steps_per_second": n * steps / wall,
        "simulated_robot_seconds_per_second": n * steps * dt / wall,
        "mean_sweeps_per_step": float(state.counters[0]) / steps,
        "device_bytes_per_robot": sim.workspace_bytes() / max(n, 1),
        "policy_on_device": not host_policy,
        "launches_per_step": (sim.launches - launches0) / steps,
        "rebuilds_per_step": (sim.rebuilds - rebuilds0) / steps,
    }
    out["bytes_per_robot_step"] = bytes_per_robot_step(
        out["mean_sweeps_per_step"], out["rebuilds_per_step"]
    )
    bw = peak_bandwidth()
    out["peak_bandwidth_bytes_per_second"] = bw
    out["bandwidth_share"] = (
        None if bw is None else out["robot_steps_per_second"] * out["bytes_per_robot_step"] / bw
    )
    seen = float(state.counters[1]) / 1e6
    final_device = sim.max_overlap(state)
    out["device_max_overlap_fraction"] = max(worst_device, final_device) / DIAMETER
    if exact_check:
        t0 = time.perf_counter()
        exact = exact_max_overlap(world, state.pos, r, state.bodies, state.pistons)
        out["exact_max_overlap_fraction"] = exact["max"] / DIAMETER
        out["exact_check"] = "scipy cKDTree on the host, final state"
        out["exact_check_seconds"] = time.perf_counter() - t0
    else:
        out["exact_max_overlap_fraction"] = final_device / DIAMETER
        out["exact_check"] = "device pair search, final state"
    out["max_overlap_fraction"] = max(
        seen / DIAMETER, out["device_max_overlap_fraction"], out["exact_max_overlap_fraction"]
    )
    return out
