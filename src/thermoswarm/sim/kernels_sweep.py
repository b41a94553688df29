"""Kernels of the engine: the Jacobi projection sweep and the choice of the robots the
next sweep visits (see :mod:`thermoswarm.sim.kernels`)."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from thermoswarm.sim.kernels_grid import (
    BODY_RADIUS,
    BODY_X,
    BODY_Y,
    MOVED,
    OVERLAPPING,
    PISTON_AXIS,
    PISTON_POSITION,
    SLOP,
    prefetch,
    serial_twin,
)
from thermoswarm.sim.kernels_walls import _pair_core, _walls_and_bodies


@njit(cache=True, inline="always")
def _pair_push(px, py, src, i, j, c2, d_rr, half, mx, my, w):
    """Robot ``i`` at ``(px, py)`` against robot ``j`` of ``src``: if they overlap, ``i``'s
    share of the separation added to ``(mx, my)`` and the overlap to the running maximum
    ``w``; returns the three (:func:`~thermoswarm.sim.kernels_walls._pair_core`, which
    the GPU engine shares)."""
    return _pair_core(px, py, src[j, 0], src[j, 1], i, j, c2, d_rr, half, mx, my, w)


#: How many visits ahead a later sweep starts loading a robot's rows (see
#: :func:`_prefetch_visit`).
AHEAD = 8


@njit(cache=True, inline="always")
def _prefetch_visit(src, dst, ref, nbr, nnb, cell, active, k, cap):
    """Start loading what the visits ``AHEAD`` and ``AHEAD / 2`` ahead of visit ``k``
    read: the robot's own rows at ``AHEAD``, its neighbours' positions at ``AHEAD / 2``
    (their indices were loaded by the first).  A later sweep visits a few per cent of
    the robots, spread over the swarm: at a million robots each visit would otherwise
    wait for memory, twice in a chain (the list row, then the neighbours)."""
    a = active[k + AHEAD]
    prefetch(src, a)
    prefetch(dst, a)
    prefetch(ref, a)
    prefetch(nbr, a)
    prefetch(nnb, a)
    prefetch(cell, a)
    b = active[k + AHEAD // 2]
    for kk in range(min(nnb[b], cap)):
        prefetch(src, nbr[b, kk])


@njit(cache=True, parallel=True)
def _sweep(
    src, dst, ref, nbr, nnb, cell, cell_start, perm, cell_flag, grid, num, seg, sdisc,
    bodies, pistons, active, count, everyone, mark,
):  # fmt: skip
    """One Jacobi sweep: measure every overlap of ``src`` and write the corrected
    positions to ``dst``.

    Each overlapping pair moves apart by half its overlap each (times ``relax``); walls,
    bodies and pistons as in :func:`_walls_and_bodies`.  The sweep visits every robot
    (``everyone``) or the ``count`` robots ``active[:count]`` -- the others have no
    overlap and ``dst`` already holds their position (see ``mark`` below).
    ``mark`` (all zero on entry) gets a 1 for each robot the next sweep must
    visit (collected by :func:`_collect_marked`): those that moved or overlap, and each
    robot on a mover's list that the mover now overlaps -- in the next sweep's
    configuration, where a robot that did not move is at its ``src`` position (one that
    moved is marked by its own visit).  Any other robot has no overlap: nothing it
    overlaps moved, so the next sweep would leave it where it is and measure nothing.
    The set is found while the neighbours' positions are still in cache, not in a
    second pass over the scattered robots.  Threads may write the same 1 to the same
    byte: the result does not depend on their order.

    Returns the largest overlap of ``src`` (exact: the lists are valid) and the largest
    squared distance from ``ref`` of any robot that moved.
    """
    cap = nbr.shape[1]
    r = num.radius
    d_rr = 2.0 * r
    c2 = (d_rr - SLOP) * (d_rr - SLOP)
    half = 0.5 * num.relax
    nx = grid.nx
    ny = grid.ny
    movables = bodies.shape[0] + pistons.shape[0] > 0
    worst = 0.0
    far = 0.0
    for k in prange(count):
        if not everyone and k + AHEAD < count:
            _prefetch_visit(src, dst, ref, nbr, nnb, cell, active, k, cap)
        i = np.int64(k) if everyone else np.int64(active[k])
        fl = 0
        fi = 0.0  # squared distance from ref, if it moves
        px = src[i, 0]
        py = src[i, 1]
        c = cell[i]
        mx = 0.0
        my = 0.0
        w = 0.0
        # --- stage: walls, static discs, bodies and pistons
        if cell_flag[c] != 0 or movables:  # most robots are far from any wall
            mx, my, w = _walls_and_bodies(
                px, py, r, cell_flag[c] != 0, seg, sdisc, bodies, pistons
            )
        # --- stage: pairs: the Verlet list, or the 3 x 3 cells when it overflowed
        m = nnb[i]
        if m <= cap:
            for kk in range(m):
                mx, my, w = _pair_push(px, py, src, i, nbr[i, kk], c2, d_rr, half, mx, my, w)
        else:  # overflowing list: the 3 x 3 cells around the cell it was listed in
            cy = c // nx
            cx = c - cy * nx
            for ccy in range(max(cy - 1, 0), min(cy + 2, ny)):
                for ccx in range(max(cx - 1, 0), min(cx + 2, nx)):
                    cc = ccy * nx + ccx
                    for kj in range(cell_start[cc], cell_start[cc + 1]):
                        j = perm[kj]
                        if j != i:
                            mx, my, w = _pair_push(px, py, src, i, j, c2, d_rr, half, mx, my, w)
        # --- stage: write the corrected position; flag moved / overlapping
        x = px + mx
        y = py + my
        dst[i, 0] = x
        dst[i, 1] = y
        if x != px or y != py:
            fl = MOVED
            ex = x - ref[i, 0]
            ey = y - ref[i, 1]
            fi = ex * ex + ey * ey
        if w > 0.0:
            fl |= OVERLAPPING
        # --- stage: mark robot i and the neighbours it now overlaps for the next sweep
        if fl != 0:
            mark[i] = 1
            if fl & MOVED and m <= cap:  # (an overflowing list: every robot is visited next)
                for kk in range(m):
                    j = nbr[i, kk]
                    ex = src[j, 0] - x  # the sweep's own test, from j's side
                    ey = src[j, 1] - y
                    if ex * ex + ey * ey < c2:
                        mark[j] = 1
        worst = max(worst, w)
        far = max(far, fi)
    return worst, far


_sweep_serial = serial_twin(_sweep, "_sweep_serial")


@njit(cache=True)
def _collect_marked(mark, near, use_near, out):
    """The rows ``mark`` flags (and, ``use_near``, those ``near`` flags), in ascending
    order, into ``out``; clears ``mark``; returns how many.  ``mark``'s length is a
    multiple of 8 (padded with zeros): it is read 8 bytes at a time, so the rows a
    later sweep skips (most of them) cost an eighth of a read each."""
    k = 0
    if use_near:  # a body or piston moved (rare): byte by byte
        for i in range(near.shape[0]):
            if mark[i] != 0 or near[i] != 0:
                out[k] = i
                k += 1
            mark[i] = 0
        return k
    words = mark.view(np.uint64)
    for w in range(words.shape[0]):
        if words[w] != 0:
            for i in range(8 * w, 8 * w + 8):
                if mark[i] != 0:
                    out[k] = i
                    k += 1
                    mark[i] = 0
    return k


@njit(cache=True, parallel=True)
def _near_moved(pos, bodies, moved_b, pistons, moved_p, r, reach, out):
    """Flag robots within ``reach`` of a body or piston that moved in the last sweep."""
    nb = bodies.shape[0]
    npis = pistons.shape[0]
    for i in prange(pos.shape[0]):
        f = 0
        for b in range(nb):
            if moved_b[b]:
                dx = pos[i, 0] - bodies[b, BODY_X]
                dy = pos[i, 1] - bodies[b, BODY_Y]
                R = bodies[b, BODY_RADIUS] + r + reach
                if dx * dx + dy * dy < R * R:
                    f = 1
        for p in range(npis):
            if moved_p[p]:
                a = int(pistons[p, PISTON_AXIS])
                if abs(pos[i, a] - pistons[p, PISTON_POSITION]) < r + reach:
                    f = 1
        out[i] = f
