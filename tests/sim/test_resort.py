"""Re-sorting the rows by cell: only once rows are out of place, every per-robot row
moved together, and the user's order (by id) untouched."""

from __future__ import annotations

import math

import numpy as np

from thermoswarm.sim import kernels as K
from thermoswarm.sim import kernels_grid as G
from thermoswarm.sim.bench import workload

N = G.RESORT_LAZY_FROM  # the lazy rule's smallest swarm


def _grid(side: float) -> K.Grid:
    cs = 50.0
    nx = int(math.ceil(side / cs)) + 2
    return K.Grid(-cs, -cs, cs, nx, nx)


def _rows(pos: np.ndarray, seed: int = 0):
    """Per-robot rows tied to the positions: ids, and x, y copies in the other rows."""
    n = pos.shape[0]
    fcols = np.stack([pos[:, 0], pos[:, 1]]).copy()
    icols = np.stack([np.arange(n), np.arange(n) % 7, np.arange(n) % 3]).astype(np.int32)
    udir = np.stack([pos[:, 0], pos[:, 1]]).astype(np.float32)
    return fcols, icols, udir


def _sort(pos, fcols, icols, udir, grid):
    n = pos.shape[0]
    cell = np.empty(n, np.int32)
    cell_start = np.zeros(grid.nx * grid.ny + 1, np.int32)
    perm = np.empty(n, np.int32)
    none_f = np.zeros((0, n), np.float32)
    none_i = np.zeros((0, n), np.int32)
    moved = G.sort_rows(pos, fcols, icols, udir, none_f, none_i, np.empty((n, 2)), grid, cell,
                        cell_start, perm)  # fmt: skip
    return bool(moved), perm


def _cells(pos, grid):
    cell = np.empty(pos.shape[0], np.int32)
    K._compute_cells(pos, grid, cell)
    return cell


def test_shuffled_rows_are_sorted_by_cell_and_every_row_moves_with_its_robot():
    rng = np.random.default_rng(0)
    side = 6_000.0
    pos = rng.uniform(0, side, (N, 2))
    grid = _grid(side)
    fcols, icols, udir = _rows(pos)
    before = pos.copy()  # row k is robot k's (ids are 0 .. N - 1 in row order)
    moved, perm = _sort(pos, fcols, icols, udir, grid)
    assert moved
    assert np.all(np.diff(_cells(pos, grid)) >= 0)  # row-major cell order
    np.testing.assert_array_equal(fcols, pos.T)  # every row followed its robot
    np.testing.assert_array_equal(udir, pos.T.astype(np.float32))
    np.testing.assert_array_equal(pos, before[icols[K.ID]])
    assert sorted(perm.tolist()) == list(range(N))


def test_rows_within_a_grid_row_of_their_place_are_not_re_sorted_until_enough_stray():
    rng = np.random.default_rng(1)
    side = 6_000.0
    grid = _grid(side)
    pos = rng.uniform(0, side, (N, 2))
    fcols, icols, udir = _rows(pos)
    _sort(pos, fcols, icols, udir, grid)
    # every robot one grid row up: each still within a row of its place in memory
    near = pos.copy()
    near[:, 1] += 50.0
    f2, i2, u2 = _rows(near)
    kept = near.copy()
    moved, perm = _sort(near, f2, i2, u2, grid)
    assert not moved
    np.testing.assert_array_equal(perm, np.arange(N))
    np.testing.assert_array_equal(near, kept)
    # robots moved 10 grid rows away: out of place; up to the threshold nothing moves,
    # one more and the rows are re-sorted
    limit = int(G.RESORT_MISPLACED * N)
    for strays, expect in ((limit, False), (limit + 1, True)):
        far = pos.copy()
        # every 5th row, so that no two strays are beside each other in memory
        idx = np.arange(1, 5 * strays + 1, 5)
        far[idx, 1] = np.where(far[idx, 1] < side / 2, far[idx, 1] + 500.0, far[idx, 1] - 500.0)
        f3, i3, u3 = _rows(far)
        assert G._misplaced(_cells(far, grid), grid.nx) == strays
        assert _sort(far, f3, i3, u3, grid)[0] is expect


def test_the_engine_keeps_the_users_order_by_id_through_re_sorts():
    # the lattice start is in random row order: the first list rebuild re-sorts the rows
    world, sim, state = workload(1_200, 0.5, seed=3)
    state.group[:] = state.ids % 5  # a label tied to each robot's id
    ids0 = state.ids.copy()
    last = state.by_id(state.pos).copy()
    worst = 0.0
    while sim.list_builds < 3:
        sim.step(state)
        now = state.by_id(state.pos)
        worst = max(worst, float(np.linalg.norm(now - last, axis=1).max()))
        last = now.copy()
    assert not np.array_equal(state.ids, ids0)  # the rows were re-ordered
    np.testing.assert_array_equal(np.sort(state.ids), np.arange(1_200))
    np.testing.assert_array_equal(state.by_id(state.group), np.arange(1_200) % 5)
    # by id, each robot moved by its step (speeds of ~10 mm/s, 0.1 s) and the contact
    # corrections, never by the distance between two robots' rows (a mix-up)
    assert worst < 16.5
