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
``mean_sweeps_per_step``.
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

__all__ = ["run_bench_gpu"]

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
    }
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
