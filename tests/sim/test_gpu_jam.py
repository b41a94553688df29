"""The GPU engine's jam solve against the CPU engine's (issue 34 item 3).

Robots heading up (within 30 degrees) pile into the top wall of a narrow box: a push
must cross the pile, which Jacobi sweeps carry one robot layer a sweep.  Both engines
hand over to warm-started, over-relaxed Gauss-Seidel passes after ``GS_AFTER`` Jacobi
sweeps (the GPU engine's over coloured cells, in numba-cuda's simulator here), with the
same sweep budget and overlap tolerance.  Checked after every step of the jammed half of
the run: the exact largest overlap (SciPy's k-d tree and the walls, independent of both
engines) is below the tolerance on both; the GPU engine's passes ran and held pushes;
its sweeps per step are of the CPU engine's order.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from thermoswarm.maxent import kT_for_mean_speed
from thermoswarm.policy import BoltzmannUniform
from thermoswarm.sim.engine import EngineParams, Simulator, place_lattice
from thermoswarm.sim.gpu import GpuSimulator
from thermoswarm.sim.gpu.check import exact_max_overlap
from thermoswarm.sim.gpu.runtime import simulated
from thermoswarm.sim.world import box_world

R = 16.5
TOL = EngineParams().overlap_tol * 2 * R


def _run(make, n, width, height, steps, seed=3):
    """Sweeps per step and the exact overlap after each step of the second half."""
    world = box_world(width, height)
    policy = BoltzmannUniform(kT_for_mean_speed(20.0), half_width=math.pi / 6)
    sim = make(world, EngineParams(dt=0.1, tau=1.0, radius=R), policy)
    pos = place_lattice(world.bounds, n, R, np.random.default_rng(seed + 1))
    state = sim.init(pos, np.random.default_rng(seed))
    sweeps, worst, held = [], [], []
    for k in range(steps):
        before = int(state.counters[0])
        sim.step(state)
        sweeps.append(int(state.counters[0]) - before)
        if k >= steps // 2:
            worst.append(exact_max_overlap(world, state.pos, R)["max"])
            held.append(getattr(sim, "_held", state.held_pairs is not None))
    return np.array(sweeps[steps // 2 :]), np.array(worst), np.array(held)


def test_a_jam_on_the_gpu_engine_is_solved_as_on_the_cpu_engine():
    # 24 robots, 3 abreast in a 100 mm box: a pile of 8 layers forms within 1-2 s
    case = (24, 100.0, 350.0, 26)
    cpu, cpu_worst, cpu_held = _run(Simulator, *case)
    gpu, gpu_worst, gpu_held = _run(GpuSimulator, *case)
    # a jam on both: the Gauss-Seidel passes ran and held pushes into the next step, on
    # a third of the steps or more (a pile resolved by them lets go of its pushes)
    assert cpu_held.mean() > 0.3 and gpu_held.mean() > 0.3, (cpu_held, gpu_held)
    # every step ends below the tolerance, measured independently (float32 positions
    # on the GPU: rounding of 1e-5 mm); and at it: contacts pressed to the tolerance
    assert cpu_worst.max() <= TOL + 1e-9 and gpu_worst.max() <= TOL + 2e-4, gpu_worst
    assert gpu_worst.max() > 0.5 * TOL
    # within the sweep budget, and of the CPU engine's order (the same solve; the robots
    # visited in another order, colour by colour, in float32)
    assert gpu.max() < EngineParams().max_iterations
    assert gpu.mean() < 2.0 * cpu.mean(), (gpu, cpu)


def test_a_free_step_is_two_launches_and_one_read_back():
    # issue 34 item 4: the decisions and motion, then every sweep in one cooperative
    # launch; a rebuild is one more launch
    world = box_world(600.0, 600.0)
    sim = GpuSimulator(world, EngineParams(dt=0.1, tau=0.1, radius=R), BoltzmannUniform(60.0))
    state = sim.init(place_lattice(world.bounds, 60, R, np.random.default_rng(1)),
                     np.random.default_rng(0))  # fmt: skip
    sim.step(state)
    launches, reads, rebuilds, sweeps = sim.launches, sim.readbacks, sim.rebuilds, 0
    for _ in range(6):
        before = int(state.counters[0])
        sim.step(state)
        sweeps += int(state.counters[0]) - before
    assert sim.readbacks - reads == 6
    assert sim.launches - launches == 2 * 6 + (sim.rebuilds - rebuilds)
    assert sweeps >= 2 * 6  # the sweeps (at least `iterations` a step) were all in them


@pytest.mark.slow
@pytest.mark.skipif(simulated(), reason="hours in numba-cuda's simulator: on a GPU only")
def test_the_mechanism_studys_jam_on_the_gpu_engine():
    """The mechanism study's slowest run (``benchmarks/engine_jam.py``'s combination:
    600 robots pressed into the arena's walls), shortened to 60 s: the same checks.
    In the simulator it would take hours (600 robots, ~25 sweeps a step, 600 steps:
    ~300 times the small jam above), so it runs where the engine runs on a GPU."""
    from thermoswarm.scenarios.runner import build, resolve
    from thermoswarm.studies.mechanism import SETTINGS

    base = dict(SETTINGS["quick"]["base"], duration=60.0)
    sets = [f"{k}={str(v).lower() if isinstance(v, bool) else v}" for k, v in base.items()]
    slowest = ["mapping=lit_hot", "heading_law=persistent", "sensor.mode=ideal"]
    out = {}
    for backend in ("cpu", "gpu"):
        cfg = resolve("transport-free", overrides=[*sets, *slowest,
                      f"engine.backend='{backend}'"], seed=0)  # fmt: skip
        scen, setup, sim, state = build(cfg)
        acc = scen.init_acc(setup, sim, state)
        sweeps, worst = [], 0.0
        steps = int(round(60.0 / sim.params.dt))
        for k in range(steps):
            before = int(state.counters[0])
            sim.step(state)
            scen.observe(sim, state, acc)
            sweeps.append(int(state.counters[0]) - before)
            if k >= steps // 2:
                worst = max(worst, exact_max_overlap(sim.world, state.pos, sim.params.radius,
                                                     state.bodies)["max"])  # fmt: skip
        out[backend] = np.array(sweeps[steps // 2 :]), worst
    (cpu, cpu_worst), (gpu, gpu_worst) = out["cpu"], out["gpu"]
    assert cpu_worst <= TOL + 1e-9 and gpu_worst <= TOL + 2e-4, (cpu_worst, gpu_worst)
    assert gpu.max() < EngineParams().max_iterations
    assert gpu.mean() < 2.0 * cpu.mean(), (gpu.mean(), cpu.mean())
