"""Kernel launches and device-to-host reads per step of the GPU engine, counted in
numba-cuda's simulator (the engine's launcher and every ``copy_to_host`` instrumented).

    python benchmarks/gpu_launches.py                      # this tree
    git archive e33dc8e src | tar -x -C /tmp/old && \\
        python benchmarks/gpu_launches.py --src /tmp/old/src   # another revision

Workloads (steps after a warm-up of ``--warmup`` steps): ``free`` (the engine
benchmark's: discs of 33 mm at packing ``--phi`` in a walled box, mean speed 10 mm/s,
re-drawn every 0.1 s) and ``jam`` (``tests/sim/test_gpu_jam.py``'s: 24 robots heading
up within 30 degrees into the top wall of a 100 x 350 mm box, 20 mm/s, 1 s control
periods; use ``--warmup 13 --steps 13`` for its jammed half).  Prints one JSON line
per workload: launches, reads and sweeps per step (their means).  Launch overhead is what these
counts cost on a GPU: about 5-10 us a launch on an H100 plus numba-cuda's Python-side
argument handling (tens of us), and a read back waits for the device.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--src", help="the src/ folder of the revision to count (default: this tree)")
    ap.add_argument("--n", type=int, default=300)
    ap.add_argument("--phi", type=float, default=0.5)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--warmup", type=int, default=5)
    ap.add_argument("--workload", action="append", choices=["free", "jam"])
    a = ap.parse_args(argv)
    here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src")
    sys.path.insert(0, os.path.abspath(a.src or here))
    os.environ["THERMOSWARM_GPU_DEVICE"] = "simulator"
    os.environ["NUMBA_ENABLE_CUDASIM"] = "1"

    import numpy as np
    from numba.cuda.simulator.cudadrv import devicearray as fake

    from thermoswarm.maxent import kT_for_mean_speed
    from thermoswarm.policy import BoltzmannUniform
    from thermoswarm.sim.engine import EngineParams, place_lattice
    from thermoswarm.sim.gpu import engine as E
    from thermoswarm.sim.world import box_world

    count = {"launches": 0, "reads": 0}
    methods = [m for m in ("_launch", "_launch_coop") if hasattr(E.GpuSimulator, m)]

    def counting(orig):
        def launch(self, *args, **kw):
            count["launches"] += 1
            return orig(self, *args, **kw)

        return launch

    for m in methods:
        setattr(E.GpuSimulator, m, counting(getattr(E.GpuSimulator, m)))
    to_host = fake.FakeCUDAArray.copy_to_host

    def reading(self, *args, **kw):
        count["reads"] += 1
        return to_host(self, *args, **kw)

    fake.FakeCUDAArray.copy_to_host = reading
    r = 16.5
    for workload in a.workload or ["free", "jam"]:
        if workload == "free":
            side = math.sqrt(a.n * math.pi * r * r / a.phi)
            world, n, area = box_world(side, side), a.n, None
            params = EngineParams(dt=0.1, tau=0.1, radius=r)
            policy = BoltzmannUniform(kT_for_mean_speed(10.0))
        else:
            world, n, area = box_world(100.0, 350.0), 24, None
            params = EngineParams(dt=0.1, tau=1.0, radius=r)
            policy = BoltzmannUniform(kT_for_mean_speed(20.0), half_width=math.pi / 6)
        sim = E.GpuSimulator(world, params, policy)
        rng = np.random.default_rng(3)
        state = sim.init(place_lattice(area or world.bounds, n, r, np.random.default_rng(4)),
                         rng)  # fmt: skip
        for _ in range(a.warmup):
            sim.step(state)
        count.update(launches=0, reads=0)
        sweeps0 = int(state.counters[0])
        for _ in range(a.steps):
            sim.step(state)
        per = {k: v / a.steps for k, v in count.items()}
        print(json.dumps({"workload": workload, "n": n, "steps": a.steps,
                          "launches_per_step": per["launches"],
                          "reads_per_step": per["reads"],
                          "sweeps_per_step": (int(state.counters[0]) - sweeps0) / a.steps,
                          "src": a.src or "this tree"}))  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
