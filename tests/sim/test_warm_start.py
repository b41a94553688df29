"""The experimental warm start (held contact pushes, Gauss-Seidel): a jam pushed into a
wall needs far fewer passes at the same exactly measured overlap, and the held pushes
travel with the state (a resumed run continues bit for bit)."""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from thermoswarm.maxent import kT_for_mean_speed
from thermoswarm.policy import BoltzmannUniform
from thermoswarm.sim import EngineParams, Simulator, box_world, place_lattice

R = 16.5
D = 2 * R


def kd_overlap(pos: np.ndarray, side: float) -> float:
    """Largest overlap (mm) of any pair of discs or any disc with the box walls."""
    pairs = cKDTree(pos).query_pairs(D, output_type="ndarray")
    worst = 0.0
    if len(pairs):
        worst = float((D - np.linalg.norm(pos[pairs[:, 0]] - pos[pairs[:, 1]], axis=1)).max())
    return max(worst, float((R - pos).max()), float((pos - (side - R)).max()), 0.0)


def _jam(warm: bool, n: int = 400, phi: float = 0.45, seed: int = 3):
    """Robots heading within 30 degrees of +y: they pile up against the top wall."""
    side = math.sqrt(n * math.pi * R * R / phi)
    world = box_world(side, side)
    policy = BoltzmannUniform(kT_for_mean_speed(20.0), half_width=math.pi / 6)
    sim = Simulator(world, EngineParams(dt=0.1, tau=1.0, warm_start=warm), policy)
    rng = np.random.default_rng(seed)
    return sim, sim.init(place_lattice(world.bounds, n, R, rng), rng), side


def test_warm_start_needs_fewer_passes_in_a_jam_at_the_same_exact_overlap():
    tol = EngineParams().overlap_tol * D
    sweeps = {}
    for warm in (False, True):
        sim, state, side = _jam(warm)
        for _ in range(250):  # the pile forms in ~100 steps
            sim.step(state)
        before = int(state.counters[0])
        worst = 0.0
        for _ in range(100):
            sim.step(state)
            worst = max(worst, kd_overlap(state.pos, side))
        sweeps[warm] = (int(state.counters[0]) - before) / 100
        # every step ends below the tolerance, measured independently
        assert worst < tol + 1e-9, (warm, worst / D)
        assert worst > 0.5 * tol  # a jam indeed: contacts at the tolerance
    # the cold solve needs a sweep per robot layer of the pile; the held pushes do not
    assert sweeps[True] < 0.5 * sweeps[False], sweeps


def test_warm_start_resumes_bit_for_bit():
    sim, state, _ = _jam(True, n=250)
    for _ in range(60):
        sim.step(state)
    assert state.held_pairs is not None and np.any(state.held_pairs > 0)
    copy = state.copy()
    fresh = Simulator(sim.world, sim.params, sim.policy)
    for _ in range(30):
        sim.step(state)
        fresh.step(copy)
    assert np.array_equal(state.pos, copy.pos)
    assert np.array_equal(state.held_pairs, copy.held_pairs)


def test_warm_start_keeps_a_dense_jam_inside_the_box():
    sim, state, side = _jam(True, n=300, phi=0.6)
    for _ in range(200):
        sim.step(state)
    assert np.all(state.pos > R - 0.01 * D) and np.all(state.pos < side - R + 0.01 * D)
