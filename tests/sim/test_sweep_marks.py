"""The sweep's marks: the robots a later sweep visits (kernels_sweep._sweep, _collect_marked).

A later sweep visits only the robots the sweep before marked, and measures the largest
overlap only among them: a robot that overlaps something after a sweep but was not
marked would hide an overlap from the engine.  Checked here against an independent
KD-tree on the configuration the sweep wrote, and the collection against NumPy.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from thermoswarm.maxent import kT_for_mean_speed
from thermoswarm.policy import BoltzmannUniform
from thermoswarm.sim import EngineParams, Simulator, box_world, place_lattice
from thermoswarm.sim import kernels as K

R = 16.5


@pytest.mark.parametrize("n", [1, 7, 8, 9, 1000, 4099])
@pytest.mark.parametrize("use_near", [False, True])
def test_collect_marked_gives_every_marked_row_in_order_and_clears_the_marks(n, use_near):
    rng = np.random.default_rng(n)
    padded = -(-n // 8) * 8
    mark = np.zeros(padded, np.uint8)
    mark[:n] = rng.random(n) < 0.05
    near = (rng.random(n) < 0.03).astype(np.uint8)
    expected = np.flatnonzero(mark[:n] | (near if use_near else 0))
    out = np.full(n, -1, np.int32)
    k = K._collect_marked(mark, near, use_near, out)
    assert np.array_equal(out[:k], expected)
    assert not mark.any()


def _crowd(n: int, seed: int) -> tuple[Simulator, object, np.ndarray]:
    """A swarm at packing 0.5 after some steps, then moved once more by hand, so that
    the first sweep of the next step has overlaps to resolve."""
    side = math.sqrt(n * math.pi * R * R / 0.5)
    world = box_world(side, side)
    sim = Simulator(world, EngineParams(tau=0.1), BoltzmannUniform(kT_for_mean_speed(10.0)))
    rng = np.random.default_rng(seed)
    state = sim.init(place_lattice(world.bounds, n, R, rng), rng)
    for _ in range(30):
        sim.step(state)
    pos = state.pos + rng.normal(0.0, 1.0, state.pos.shape)  # ~1 mm: a step's motion
    return sim, state, pos


def _must_be_marked(pos: np.ndarray, bounds) -> np.ndarray:
    """Independent of the engine: every robot in a pair closer than a diameter, or
    closer than a radius to a wall of the box (a KD-tree and the box's sides)."""
    pairs = cKDTree(pos).query_pairs(2 * R - 1e-6, output_type="ndarray")
    x0, y0, x1, y1 = bounds
    must = (
        (pos[:, 0] < x0 + R - 1e-6) | (pos[:, 0] > x1 - R + 1e-6)
        | (pos[:, 1] < y0 + R - 1e-6) | (pos[:, 1] > y1 - R + 1e-6)
    )  # fmt: skip
    must[pairs.ravel()] = True
    return must


@pytest.mark.parametrize("serial", [True, False])
def test_every_robot_that_overlaps_after_a_sweep_is_marked_for_the_next(serial):
    sim, state, pos = _crowd(3000, seed=4)
    ws, w = sim._ensure_ws(state), sim.world
    num, n, mark = ws.numerics, state.n, ws.mark
    ref = pos.copy()
    K.build_lists(pos, ref, ws.grid, num.cutoff, ws.cell, ws.cell_start, ws.perm,
                  ws.neighbours, ws.n_neighbours)  # fmt: skip
    sweep = K._sweep_serial if serial else K._sweep

    def sweep_once(src, dst, active, count, everyone):
        sweep(src, dst, ref, ws.neighbours, ws.n_neighbours, ws.cell, ws.cell_start,
              ws.perm, ws.cell_near_static, ws.grid, num, w.segments, w.static_discs,
              state.bodies, state.pistons, active, count, everyone, mark)  # fmt: skip
        must = _must_be_marked(dst, w.bounds)
        assert must.sum() > 10  # the check has something to check
        missed = np.flatnonzero(must & (mark[:n] == 0))
        assert missed.size == 0, f"overlapping robots not marked: {missed[:10]}"

    mark[:] = 0
    first = pos.copy()
    sweep_once(pos, first, ws.visits[0], n, True)  # every robot
    count = K._collect_marked(mark, ws.near_moved, False, ws.visits[1])
    assert 0 < count < n // 2  # the next sweep is sparse
    # the next sweep visits only those; the others are where they were in both buffers
    second = pos.copy()
    sweep_once(first, second, ws.visits[1], count, False)
    mark[:] = 0
