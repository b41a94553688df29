"""Numba kernels of the engine: cell grid, Verlet lists, contact projection, elastic gas.

Why hand-written: no maintained library offers overdamped rigid-disc contact
projection with force-driven walls and movable bodies for millions of discs on a CPU
(pymunk and Box2D are inertial soft-contact solvers; JAX-MD offers soft potentials:
both are measured side by side in ``benchmarks/bench_engine.py``).  The kernels
follow JAX-MD's cell-list design, LAMMPS/HOOMD's Verlet lists with a skin and HOOMD's
habit of keeping particles sorted by cell for memory locality.

Layout
------
Per-robot data live in the state's arrays (:class:`thermoswarm.sim.SwarmState`):
``pos`` (n, 2) float64, ``fcols`` (2, n) float64 with rows :data:`HEADING` and
:data:`SPEED`, ``icols`` (3, n) int32 with rows :data:`ID`, :data:`GROUP` and
:data:`TIMER`, ``udir`` (2, n) float32 unit directions, and ``ref`` (n, 2): where each
robot was when the neighbour lists were last built.  Movable bodies and force-driven
walls (pistons) are packed one per row, columns ``BODY_*`` and ``PISTON_*`` below.
The grid is a :class:`Grid`; the step's numerical parameters a :class:`Numerics`.

Contacts: Verlet lists with a skin
----------------------------------
The lists hold, for every robot, each robot within ``cutoff = 2 r + skin`` of it when
they were built (at the positions saved in ``ref``).  They stay valid -- they contain
every pair in contact -- for as long as no robot has moved more than ``skin / 2`` from
``ref``: a pair that was farther apart than ``2 r + skin`` cannot have closed the gap.
That is checked after the commanded motion of every step *and after every projection
sweep within a step* (a sweep's corrections move robots too), and the lists are rebuilt
the moment it fails.  So no contact is ever missed, and the largest overlap each sweep
measures is exact.  At the start of a step a rebuild also re-sorts the robots by grid
cell (locality); a rebuild within a step does not re-order anything (it goes through a
permutation), so the state changes only between steps.

Determinism
-----------
Every parallel loop writes only its own elements; sums over robots (forces on bodies and
walls) are done in serial loops in a fixed order, and maxima are order-independent.
Whether lists are rebuilt is a function of the state (``ref`` travels with it), and a
list is a function of ``ref`` and the row order.  Results are therefore bit-identical
whatever the number of threads, and a run resumed from a checkpoint rebuilds exactly the
lists it had.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit, prange

INF = np.inf

# ----------------------------------------------------------------------- layouts
#: Rows of ``SwarmState.fcols`` (float64).
HEADING, SPEED = 0, 1
#: Rows of ``SwarmState.icols`` (int32): permanent id, scenario label, steps left in the
#: current control period.
ID, GROUP, TIMER = 0, 1, 2

#: Columns of the packed movable bodies (``SwarmState.bodies``, one row per body).
BODY_X, BODY_Y, BODY_RADIUS, BODY_DRAG = 0, 1, 2, 3
BODY_FORCE_X, BODY_FORCE_Y = 4, 5  # external force, set by a scenario
BODY_CONTACT_X, BODY_CONTACT_Y = 6, 7  # the robots' mean contact force in the last step
BODY_STEP_X, BODY_STEP_Y = 8, 9  # the body's move in the current sweep (internal)
BODY_SHARE = 10  # the share of an overlap a robot touching it takes (internal)
BODY_COLUMNS = 11

#: Columns of the packed force-driven walls (``SwarmState.pistons``, one row per wall).
PISTON_AXIS, PISTON_POSITION, PISTON_SIDE, PISTON_LO, PISTON_HI = 0, 1, 2, 3, 4
PISTON_DRAG, PISTON_FORCE, PISTON_MIN, PISTON_MAX = 5, 6, 7, 8
PISTON_CONTACT = 9  # the robots' mean contact force in the last step (along the axis)
PISTON_STEP, PISTON_SHARE = 10, 11  # internal, as for bodies
PISTON_COLUMNS = 12

# The short names of the same columns, kept for code written against them.
BX, BY, BR, BDRAG, BFX, BFY, BCX, BCY, BDX, BDY, BSH = range(BODY_COLUMNS)
B_COLS = BODY_COLUMNS
PA, PP, PS, PLO, PHI, PDRAG, PF, PLL, PLH, PC, PD, PSH = range(PISTON_COLUMNS)
P_COLS = PISTON_COLUMNS

# Bits of the per-robot sweep flags.
MOVED, OVERLAPPING = 1, 2

#: Contacts closer than this to touching (mm) count as touching, not overlapping.  A
#: corrected pair ends at contact up to round-off (1e-13 mm at 1 m from the origin); without
#: this slop those round-off overlaps would be "corrected" forever, each correction too small
#: to move a robot, keeping its neighbours in every sweep.
SLOP = 1e-9


class Grid(NamedTuple):
    """The cell grid: cell ``(cx, cy)`` covers ``[x0 + cx cs, x0 + (cx + 1) cs)`` (and so
    for y); index ``cy * nx + cx``.  Positions outside are clamped to the border cells."""

    x0: float
    y0: float
    cell_size: float
    nx: int
    ny: int


class Numerics(NamedTuple):
    """What one overdamped step needs besides arrays (lengths in mm, times in s)."""

    radius: float
    drag: float
    dt: float
    tol: float  # stop sweeping once the largest overlap is below this (mm)
    relax: float
    cutoff: float  # neighbour-list reach: 2 radius + skin
    half_skin: float  # rebuild once any robot is farther than this from where it was
    min_sweeps: int
    max_sweeps: int
    warm: bool  # keep each contact's accumulated correction and warm-start the next step
    pull: float  # fraction of a held contact's opened gap closed per sweep (warm only)
    slack_tol: float  # stop sweeping once no held push unneeded by more than this (mm)
    keep: float  # fraction of the last step's held pushes a step starts from (warm only)


# --------------------------------------------------------------------------- grid
@njit(cache=True, inline="always")
def _cell_xy(x, y, x0, y0, inv_cs, nx, ny):
    cx = int(math.floor((x - x0) * inv_cs))
    cy = int(math.floor((y - y0) * inv_cs))
    if cx < 0:
        cx = 0
    elif cx >= nx:
        cx = nx - 1
    if cy < 0:
        cy = 0
    elif cy >= ny:
        cy = ny - 1
    return cx, cy


@njit(cache=True, parallel=True)
def _compute_cells(pos, grid, cell):
    inv_cs = 1.0 / grid.cell_size
    for i in prange(pos.shape[0]):
        cx, cy = _cell_xy(pos[i, 0], pos[i, 1], grid.x0, grid.y0, inv_cs, grid.nx, grid.ny)
        cell[i] = cy * grid.nx + cx


@njit(cache=True)
def _counting_sort(cell, ncell, cell_start, perm):
    """Stable counting sort: ``perm[k]`` is the row of the k-th robot in cell order, and
    ``perm[cell_start[c]:cell_start[c + 1]]`` are the rows in cell ``c``."""
    n = cell.shape[0]
    for c in range(ncell + 1):
        cell_start[c] = 0
    for i in range(n):
        cell_start[cell[i] + 1] += 1
    for c in range(ncell):
        cell_start[c + 1] += cell_start[c]
    # place robots; use cell_start[c] as a running cursor, then shift back
    for i in range(n):
        c = cell[i]
        perm[cell_start[c]] = i
        cell_start[c] += 1
    for c in range(ncell, 0, -1):
        cell_start[c] = cell_start[c - 1]
    cell_start[0] = 0


@njit(cache=True, parallel=True)
def _permute_pairs(a, perm, tmp):
    """Rows of the (n, 2) array ``a`` in the order ``perm`` (through ``tmp``, same shape)."""
    n = a.shape[0]
    for k in prange(n):
        tmp[k, 0] = a[perm[k], 0]
        tmp[k, 1] = a[perm[k], 1]
    for k in prange(n):
        a[k, 0] = tmp[k, 0]
        a[k, 1] = tmp[k, 1]


@njit(cache=True, parallel=True)
def _permute(a, perm, tmp):
    """``a`` (n,) in the order ``perm``, through the float64 buffer ``tmp`` (exact for
    float32 and int32 values)."""
    n = a.shape[0]
    for k in prange(n):
        tmp[k] = a[perm[k]]
    for k in prange(n):
        a[k] = tmp[k]


@njit(cache=True)
def sort_by_cell(pos, rows_f8, rows_i4, grid, cell, cell_start, perm, tmp2):
    """Re-order robots by grid cell.  ``rows_f8`` (k, n) and ``rows_i4`` (m, n) are
    per-robot rows re-ordered too; ``tmp2`` is an (n, 2) float64 scratch buffer.

    On return ``cell`` and ``cell_start`` describe the sorted order (``perm`` is the
    permutation that was applied)."""
    n = pos.shape[0]
    _compute_cells(pos, grid, cell)
    _counting_sort(cell, grid.nx * grid.ny, cell_start, perm)
    _permute_pairs(pos, perm, tmp2)
    tmp = tmp2.reshape(2 * n)[:n]
    for j in range(rows_f8.shape[0]):
        _permute(rows_f8[j], perm, tmp)
    for j in range(rows_i4.shape[0]):
        _permute(rows_i4[j], perm, tmp)
    _permute(cell, perm, tmp)


# ------------------------------------------------------------------ geometry bits
@njit(cache=True, inline="always")
def _seg_push(px, py, x0, y0, x1, y1, r):
    """Overlap and unit normal (from segment to point) of a disc of radius r on a segment."""
    ex = x1 - x0
    ey = y1 - y0
    l2 = ex * ex + ey * ey
    t = 0.0
    if l2 > 0.0:
        t = ((px - x0) * ex + (py - y0) * ey) / l2
        if t < 0.0:
            t = 0.0
        elif t > 1.0:
            t = 1.0
    qx = x0 + t * ex
    qy = y0 + t * ey
    dx = px - qx
    dy = py - qy
    d2 = dx * dx + dy * dy
    if d2 >= r * r:
        return 0.0, 0.0, 0.0
    d = math.sqrt(d2)
    if d > 1e-12:
        return r - d, dx / d, dy / d
    # centre exactly on the segment: push along the segment's left normal
    ln = math.sqrt(l2) if l2 > 0 else 1.0
    return r, -ey / ln, ex / ln


@njit(cache=True)
def flag_cells_near(seg, sdisc, grid, reach, flags):
    """Mark the cells within ``reach`` of any static segment or static disc."""
    x0, y0, cs, nx, ny = grid.x0, grid.y0, grid.cell_size, grid.nx, grid.ny
    for c in range(nx * ny):
        flags[c] = 0
    for s in range(seg.shape[0]):
        xa = min(seg[s, 0], seg[s, 2]) - reach
        xb = max(seg[s, 0], seg[s, 2]) + reach
        ya = min(seg[s, 1], seg[s, 3]) - reach
        yb = max(seg[s, 1], seg[s, 3]) + reach
        cxa = max(0, int(math.floor((xa - x0) / cs)))
        cxb = min(nx - 1, int(math.floor((xb - x0) / cs)))
        cya = max(0, int(math.floor((ya - y0) / cs)))
        cyb = min(ny - 1, int(math.floor((yb - y0) / cs)))
        for cy in range(cya, cyb + 1):
            for cx in range(cxa, cxb + 1):
                # distance from the cell's centre to the segment, minus the half diagonal
                mx = x0 + (cx + 0.5) * cs
                my = y0 + (cy + 0.5) * cs
                ov, _, _ = _seg_push(
                    mx, my, seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3], reach + 0.7072 * cs
                )
                if ov > 0.0:
                    flags[cy * nx + cx] = 1
    for s in range(sdisc.shape[0]):
        R = sdisc[s, 2] + reach
        cxa = max(0, int(math.floor((sdisc[s, 0] - R - x0) / cs)))
        cxb = min(nx - 1, int(math.floor((sdisc[s, 0] + R - x0) / cs)))
        cya = max(0, int(math.floor((sdisc[s, 1] - R - y0) / cs)))
        cyb = min(ny - 1, int(math.floor((sdisc[s, 1] + R - y0) / cs)))
        for cy in range(cya, cyb + 1):
            for cx in range(cxa, cxb + 1):
                flags[cy * nx + cx] = 1


@njit(cache=True)
def check_action(heading, speed):
    """One pass over a policy's output: 0 if every heading is finite and every speed
    finite and >= 0 (1 non-finite heading, 2 bad speed), and the largest |heading|."""
    big = 0.0
    for i in range(heading.shape[0]):
        h = heading[i]
        if not math.isfinite(h):
            return 1, big
        a = abs(h)
        if a > big:
            big = a
        v = speed[i]
        if not (v >= 0.0) or not math.isfinite(v):
            return 2, big
    return 0, big


@njit(cache=True)
def due_robots(timer, tau_steps):
    """The robots whose control period is over (``timer <= 0``), in row order, their
    timers refilled with ``tau_steps``.  Returns ``(rows, everyone)``; when every robot
    is due, ``everyone`` is true and ``rows`` empty (no index of n is made)."""
    n = timer.shape[0]
    m = 0
    for i in range(n):
        m += timer[i] <= 0
    if m == n:
        timer[:] = tau_steps
        return np.empty(0, np.int64), True
    rows = np.empty(m, np.int64)
    k = 0
    for i in range(n):
        if timer[i] <= 0:
            rows[k] = i
            k += 1
            timer[i] = tau_steps
    return rows, False


# -------------------------------------------------- phase 1: the commanded motion
@njit(cache=True, parallel=True)
def _move(pos, udir, speed, timer, ref, dt):
    """Every robot moves at its commanded velocity for ``dt``; control timers count down.

    ``udir`` (2, n) float32 holds each robot's unit direction (cos, sin of its heading),
    computed once per decision, so that no trigonometry is done per step.  Returns the
    largest squared distance of any robot from ``ref`` (for the list-validity check).
    """
    far = 0.0
    for i in prange(pos.shape[0]):
        x = pos[i, 0] + speed[i] * udir[0, i] * dt
        y = pos[i, 1] + speed[i] * udir[1, i] * dt
        pos[i, 0] = x
        pos[i, 1] = y
        timer[i] -= 1
        dx = x - ref[i, 0]
        dy = y - ref[i, 1]
        far = max(far, dx * dx + dy * dy)
    return far


@njit(cache=True)
def _move_bodies(bodies, pistons, seg, sdisc, dt):
    """Bodies and pistons move under their external force (``F dt / drag``); the contact
    forces of the new step start at zero."""
    for b in range(bodies.shape[0]):
        bodies[b, BODY_CONTACT_X] = 0.0
        bodies[b, BODY_CONTACT_Y] = 0.0
        if not math.isinf(bodies[b, BODY_DRAG]):
            bodies[b, BODY_X] += bodies[b, BODY_FORCE_X] * dt / bodies[b, BODY_DRAG]
            bodies[b, BODY_Y] += bodies[b, BODY_FORCE_Y] * dt / bodies[b, BODY_DRAG]
    _bodies_vs_static(bodies, seg, sdisc)
    for p in range(pistons.shape[0]):
        pistons[p, PISTON_CONTACT] = 0.0
        if not math.isinf(pistons[p, PISTON_DRAG]):
            x = pistons[p, PISTON_POSITION] + (
                pistons[p, PISTON_SIDE] * pistons[p, PISTON_FORCE] * dt / pistons[p, PISTON_DRAG]
            )
            pistons[p, PISTON_POSITION] = min(
                max(x, pistons[p, PISTON_MIN]), pistons[p, PISTON_MAX]
            )


@njit(cache=True)
def _bodies_vs_static(bodies, seg, sdisc):
    """Keep movable bodies out of static walls and obstacles (walls do not yield)."""
    for b in range(bodies.shape[0]):
        R = bodies[b, BODY_RADIUS]
        for s in range(seg.shape[0]):
            ov, nxs, nys = _seg_push(
                bodies[b, BODY_X], bodies[b, BODY_Y], seg[s, 0], seg[s, 1], seg[s, 2],
                seg[s, 3], R,
            )  # fmt: skip
            if ov > 0.0:
                bodies[b, BODY_X] += ov * nxs
                bodies[b, BODY_Y] += ov * nys
        for s in range(sdisc.shape[0]):
            dx = bodies[b, BODY_X] - sdisc[s, 0]
            dy = bodies[b, BODY_Y] - sdisc[s, 1]
            RR = R + sdisc[s, 2]
            d2 = dx * dx + dy * dy
            if d2 < RR * RR:
                d = math.sqrt(d2)
                if d > 1e-12:
                    bodies[b, BODY_X] += (RR - d) * dx / d
                    bodies[b, BODY_Y] += (RR - d) * dy / d


# ------------------------------------------------------ phase 2: neighbour lists
@njit(cache=True)
def sort_rows(pos, fcols, icols, udir, lamw, lamid, scratch, grid, cell, cell_start, perm):
    """Re-order every per-robot array of the state by grid cell (in place, through the
    (n, 2) float64 ``scratch``), so that neighbours are near in memory.  (The held pair
    pushes are keyed by list slots: :func:`_restore_held` moves them.)"""
    n = pos.shape[0]
    _compute_cells(pos, grid, cell)
    _counting_sort(cell, grid.nx * grid.ny, cell_start, perm)
    _permute_pairs(pos, perm, scratch)
    tmp = scratch.reshape(2 * n)[:n]
    for j in range(fcols.shape[0]):
        _permute(fcols[j], perm, tmp)
    for j in range(icols.shape[0]):
        _permute(icols[j], perm, tmp)
    for j in range(udir.shape[0]):
        _permute(udir[j], perm, tmp)
    for j in range(lamw.shape[0]):
        _permute(lamw[j], perm, tmp)
        _permute(lamid[j], perm, tmp)


@njit(cache=True, parallel=True)
def _fill_lists(at, grid, cell_start, perm, cutoff, nbr, nnb):
    """Every robot within ``cutoff`` of each robot, at positions ``at`` (both directions).

    Robots in cell order (``perm``) make the three cells of a grid row next to a robot one
    contiguous range: three ranges per robot instead of nine cells.  A robot with more
    neighbours than the capacity gets ``nnb = capacity + 1`` (the sweeps then scan the
    grid for it).
    """
    cap = nbr.shape[1]
    c2 = cutoff * cutoff
    nx = grid.nx
    ny = grid.ny
    overflows = 0
    for cy in prange(ny):
        ya = max(cy - 1, 0)
        yb = min(cy + 1, ny - 1)
        for cx in range(nx):
            c = cy * nx + cx
            a = cell_start[c]
            b = cell_start[c + 1]
            if a == b:
                continue
            xa = max(cx - 1, 0)
            xb = min(cx + 1, nx - 1)
            for ki in range(a, b):
                i = perm[ki]
                px = at[i, 0]
                py = at[i, 1]
                k = 0
                for ccy in range(ya, yb + 1):
                    k0 = cell_start[ccy * nx + xa]
                    k1 = cell_start[ccy * nx + xb + 1]
                    for kj in range(k0, k1):
                        j = perm[kj]
                        dx = px - at[j, 0]
                        dy = py - at[j, 1]
                        # branch-free: write every candidate at the end of the list and
                        # keep it only if it is in reach (a third are: a branch on it
                        # mispredicts), 3.6x faster
                        if k < cap:
                            nbr[i, k] = j
                        k += (dx * dx + dy * dy < c2) & (j != i)
                nnb[i] = k if k <= cap else cap + 1
                overflows += 1 if k > cap else 0
    return overflows


@njit(cache=True, parallel=True)
def _copy_pairs(src, dst):
    for i in prange(src.shape[0]):
        dst[i, 0] = src[i, 0]
        dst[i, 1] = src[i, 1]


@njit(cache=True)
def build_lists(at, ref, grid, cutoff, cell, cell_start, perm, nbr, nnb):
    """Neighbour lists at positions ``at``; ``ref`` (may be ``at`` itself) records them.

    ``cell[i]`` is robot i's cell at ``at`` and ``perm``/``cell_start`` the cell order: the
    lists are a function of ``at`` and the row order only.  Returns the number of robots
    whose list overflowed.
    """
    _compute_cells(at, grid, cell)
    _counting_sort(cell, grid.nx * grid.ny, cell_start, perm)
    _copy_pairs(at, ref)
    return _fill_lists(at, grid, cell_start, perm, cutoff, nbr, nnb)


# --------------------------------------------------------- phase 3: projection
# Not inlined by Numba (``inline="always"`` breaks the max reductions of the parallel
# loops that call it, "unexpected cycle in lookup()"); LLVM inlines it anyway.
@njit(cache=True)
def _walls_and_bodies(px, py, r, near_static, seg, sdisc, bodies, pistons):
    """Correction (mx, my) and largest overlap of a robot against walls, bodies, pistons."""
    mx = 0.0
    my = 0.0
    w = 0.0
    if near_static:
        for s in range(seg.shape[0]):
            ov, nxs, nys = _seg_push(px, py, seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3], r)
            if ov > SLOP:
                mx += ov * nxs
                my += ov * nys
                if ov > w:
                    w = ov
        for s in range(sdisc.shape[0]):
            dx = px - sdisc[s, 0]
            dy = py - sdisc[s, 1]
            R = sdisc[s, 2] + r
            d2 = dx * dx + dy * dy
            if d2 < (R - SLOP) * (R - SLOP):
                d = math.sqrt(d2)
                if R - d > w:
                    w = R - d
                if d > 1e-12:
                    mx += (R - d) * dx / d
                    my += (R - d) * dy / d
    for b in range(bodies.shape[0]):
        dx = px - bodies[b, BODY_X]
        dy = py - bodies[b, BODY_Y]
        R = bodies[b, BODY_RADIUS] + r
        d2 = dx * dx + dy * dy
        if d2 < (R - SLOP) * (R - SLOP):
            d = math.sqrt(d2)
            if R - d > w:
                w = R - d
            if d > 1e-12:
                f = bodies[b, BODY_SHARE] * (R - d) / d
                mx += f * dx
                my += f * dy
    for p in range(pistons.shape[0]):
        a = int(pistons[p, PISTON_AXIS])
        q = py if a == 0 else px
        if q < pistons[p, PISTON_LO] or q > pistons[p, PISTON_HI]:
            continue
        v = px if a == 0 else py
        gap = pistons[p, PISTON_SIDE] * (v - pistons[p, PISTON_POSITION])
        if gap < r - SLOP:
            if r - gap > w:
                w = r - gap
            corr = pistons[p, PISTON_SHARE] * (r - gap) * pistons[p, PISTON_SIDE]
            if a == 0:
                mx += corr
            else:
                my += corr
    return mx, my, w


@njit(cache=True, inline="always")
def _pair_push(px, py, src, i, j, c2, d_rr, half, mx, my, w):
    """Robot ``i`` at ``(px, py)`` against robot ``j`` of ``src``: if they overlap, ``i``'s
    share of the separation added to ``(mx, my)`` and the overlap to the running maximum
    ``w``; returns the three."""
    dx = px - src[j, 0]
    dy = py - src[j, 1]
    d2 = dx * dx + dy * dy
    if d2 < c2:
        d = math.sqrt(d2)
        if d_rr - d > w:
            w = d_rr - d
        if d > 1e-12:
            f = half * (d_rr - d) / d
            mx += f * dx
            my += f * dy
        else:  # coincident centres: separate along x by row order
            mx += half * d_rr * (1.0 if i < j else -1.0)
    return mx, my, w


@njit(cache=True, inline="always")
def _seg_gap(px, py, x0, y0, x1, y1, r):
    """Signed gap (centre distance minus r, mm) of a disc to a segment, and the unit
    normal from the segment to the centre."""
    ex = x1 - x0
    ey = y1 - y0
    l2 = ex * ex + ey * ey
    t = 0.0
    if l2 > 0.0:
        t = ((px - x0) * ex + (py - y0) * ey) / l2
        if t < 0.0:
            t = 0.0
        elif t > 1.0:
            t = 1.0
    dx = px - (x0 + t * ex)
    dy = py - (y0 + t * ey)
    d = math.sqrt(dx * dx + dy * dy)
    if d > 1e-12:
        return d - r, dx / d, dy / d
    ln = math.sqrt(l2) if l2 > 0 else 1.0
    return -r, -ey / ln, ex / ln


@njit(cache=True)
def _walls_held(px, py, r, i, lw, lid, pull, seg):
    """Static segments with held pushes: every overlap is pushed out in full (as in
    :func:`_walls_and_bodies`) and, for up to two segments per robot, accumulated in
    ``lw[:, i]`` (mm) with the segment's index in ``lid[:, i]``; a held segment no longer
    touched takes back up to ``pull`` x the gap of its push (a wall pushes, never pulls:
    a held push it no longer needs is undone).  Writes only column ``i``.

    Returns ``(mx, my, largest overlap, slack)``; ``slack = min(held push, gap)`` is how
    far the robot stands off a wall on account of a push it no longer needs."""
    mx = 0.0
    my = 0.0
    w = 0.0
    slack = 0.0
    for s in range(seg.shape[0]):
        g, nxs, nys = _seg_gap(px, py, seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3], r)
        slot = 0 if lid[0, i] == s else (1 if lid[1, i] == s else -1)
        if -g > SLOP:
            mx -= g * nxs
            my -= g * nys
            if -g > w:
                w = -g
            if slot < 0:  # a free slot (nothing held) takes this segment
                slot = 0 if lw[0, i] == 0.0 else (1 if lw[1, i] == 0.0 else -1)
                if slot >= 0:
                    lid[slot, i] = s
            if slot >= 0:
                lw[slot, i] = lw[slot, i] - g
        elif slot >= 0 and lw[slot, i] > 0.0 and g > SLOP:
            L = np.float64(lw[slot, i])
            if min(L, g) > slack:
                slack = min(L, g)
            dl = min(L, pull * g)
            mx -= dl * nxs
            my -= dl * nys
            lw[slot, i] = L - dl
    return mx, my, w, slack


@njit(cache=True, inline="always")
def _pair_held(px, py, src, i, j, L, c2, d_rr, half, pull, mx, my, w, s):
    """:func:`_pair_push` with the pair's held correction ``L`` (mm each robot moved
    apart along the pair's normal, this step and the warm start): an overlap adds its
    push to ``L``; a pair apart with ``L > 0`` takes back up to ``pull`` x half the gap
    (the push it no longer needs), and ``s`` keeps the largest such unneeded push,
    ``min(L, gap / 2)``.  Both robots of a pair compute the same update from the same
    numbers, so the two copies of ``L`` stay equal.  Returns ``(mx, my, w, s, L)``."""
    dx = px - src[j, 0]
    dy = py - src[j, 1]
    d2 = dx * dx + dy * dy
    if d2 < c2:
        d = math.sqrt(d2)
        if d_rr - d > w:
            w = d_rr - d
        if d > 1e-12:
            f = half * (d_rr - d) / d
            mx += f * dx
            my += f * dy
            L += half * (d_rr - d)
        else:  # coincident centres: separate along x by row order
            mx += half * d_rr * (1.0 if i < j else -1.0)
            L += half * d_rr
    elif L > 0.0:
        d = math.sqrt(d2)
        g = 0.5 * (d - d_rr)
        if g > SLOP:
            if min(L, g) > s:
                s = min(L, g)
            dl = min(L, pull * g)
            mx -= dl * dx / d
            my -= dl * dy / d
            L -= dl
    return mx, my, w, s, L


@njit(cache=True, parallel=True)
def _sweep(
    src, dst, ref, nbr, nnb, lam, lamw, lamid, cell, cell_start, perm, cell_flag, grid, num,
    seg, sdisc, bodies, pistons, active, count, everyone, any_overflow, result,
):  # fmt: skip
    """One Jacobi sweep: measure every overlap of ``src`` and write the corrected
    positions to ``dst``.

    Each overlapping pair moves apart by half its overlap each (times ``relax``); walls,
    bodies and pistons as in :func:`_walls_and_bodies`.  With ``num.warm`` each listed
    pair's accumulated push is held in ``lam`` (row i, the slot of its neighbour) and
    each robot's pushes off up to two walls in ``lamw`` (segment indices ``lamid``):
    pushes add to them, and a pair or wall no longer touching takes back the push it no
    longer needs
    (:func:`_pair_held`, :func:`_walls_held`).  The sweep visits every robot
    (``everyone``) or the ``count`` robots ``active[:count]`` -- the others have nothing
    to correct and ``dst`` already holds their position (see :func:`_next_active`).
    ``result[k]`` gets the :data:`MOVED` and :data:`OVERLAPPING` bits of the k-th robot
    visited.

    Returns the largest overlap of ``src`` (exact: the lists are valid), the largest
    squared distance from ``ref`` of any robot that moved, and the largest unneeded
    held push (mm; 0 without ``num.warm``).
    """
    cap = nbr.shape[1]
    r = num.radius
    d_rr = 2.0 * r
    c2 = (d_rr - SLOP) * (d_rr - SLOP)
    half = 0.5 * num.relax
    pull = num.pull
    held = num.warm
    nx = grid.nx
    ny = grid.ny
    movables = bodies.shape[0] + pistons.shape[0] > 0
    worst = 0.0
    far = 0.0
    slack = 0.0
    for k in prange(count):
        i = np.int64(k) if everyone else np.int64(active[k])
        fl = 0
        fi = 0.0  # squared distance from ref, if it moves
        px = src[i, 0]
        py = src[i, 1]
        c = cell[i]
        mx = 0.0
        my = 0.0
        w = 0.0
        sl = 0.0
        near = cell_flag[c] != 0
        if held and (near or lamw[0, i] != 0.0 or lamw[1, i] != 0.0):
            mx, my, w, sl = _walls_held(px, py, r, i, lamw, lamid, pull, seg)
            if near or movables:
                ax, ay, aw = _walls_and_bodies(px, py, r, near, seg[:0], sdisc, bodies, pistons)
                mx += ax
                my += ay
                w = max(w, aw)
        elif near or movables:  # most robots are far from any wall
            mx, my, w = _walls_and_bodies(px, py, r, near, seg, sdisc, bodies, pistons)
        m = nnb[i]
        if m <= cap:
            if held:
                for kk in range(m):
                    j = nbr[i, kk]
                    if any_overflow and nnb[j] > cap:  # j scans the grid: no held push
                        lam[i, kk] = 0.0
                        mx, my, w = _pair_push(px, py, src, i, j, c2, d_rr, half, mx, my, w)
                        continue
                    mx, my, w, sl, L = _pair_held(
                        px, py, src, i, j, np.float64(lam[i, kk]), c2, d_rr, half, pull,
                        mx, my, w, sl,
                    )  # fmt: skip
                    lam[i, kk] = L
            else:
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
        result[k] = fl
        worst = max(worst, w)
        far = max(far, fi)
        slack = max(slack, sl)
    return worst, far, slack


@njit(cache=True, parallel=True)
def _warm_start(src, dst, ref, nbr, nnb, lam, lamw, lamid, seg, r, keep):
    """Every robot takes the pushes its contacts held at the end of the last step
    (``lam`` along each listed pair's present normal, ``lamw`` off its held walls), the
    held pushes first scaled by ``keep`` (< 1: pushes that only cancel each other, which
    a jam can pile up without moving anything, decay instead of growing step by step):
    the starting guess of the projection (pushes no longer needed are taken back by the
    sweeps).  Writes ``dst``; returns the largest squared distance from ``ref``."""
    cap = nbr.shape[1]
    far = 0.0
    for i in prange(src.shape[0]):
        px = src[i, 0]
        py = src[i, 1]
        mx = 0.0
        my = 0.0
        m = nnb[i]
        if m <= cap:
            for kk in range(m):
                L = np.float32(keep * lam[i, kk])
                lam[i, kk] = L
                if L != 0.0:
                    j = nbr[i, kk]
                    dx = px - src[j, 0]
                    dy = py - src[j, 1]
                    d = math.sqrt(dx * dx + dy * dy)
                    if d > 1e-12:
                        mx += L * dx / d
                        my += L * dy / d
        for slot in range(2):
            lw = np.float32(keep * lamw[slot, i])
            lamw[slot, i] = lw
            if lw != 0.0:
                s = lamid[slot, i]
                _, nxs, nys = _seg_gap(px, py, seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3], r)
                mx += lw * nxs
                my += lw * nys
        x = px + mx
        y = py + my
        dst[i, 0] = x
        dst[i, 1] = y
        ex = x - ref[i, 0]
        ey = y - ref[i, 1]
        far = max(far, ex * ex + ey * ey)
    return far


@njit(cache=True, inline="always")
def _slot_of(nbr, nnb, j, i):
    """The slot of ``i`` in ``j``'s list (-1 if absent)."""
    for kk in range(nnb[j]):
        if nbr[j, kk] == i:
            return kk
    return -1


@njit(cache=True)
def _gs_pass(
    pos, other, ref, nbr, nnb, lam, lamw, lamid, cell, cell_flag, num, seg, sdisc, bodies,
    pistons, active, count, everyone, mark, out,
):  # fmt: skip
    """One projected Gauss-Seidel pass with held pushes (``num.warm``), serial and in place.

    For each robot of ``active[:count]`` (every robot when ``everyone``), in that order:
    its walls (:func:`_walls_held`), static discs, bodies and pistons, then each listed
    pair, both robots moving at once by half the overlap each (times ``relax``) or, apart
    with a held push, taking back up to ``pull`` x half the gap; both copies of the held
    push are updated.  Sequential updates cannot ratchet the held pushes the way
    simultaneous (Jacobi) ones do, and the order is fixed: the result does not depend on
    the number of threads.  Each move is mirrored into ``other`` (the second position
    buffer stays equal for every robot not visited).  A robot whose list overflowed
    pushes only (its pairs are not held).

    Writes into ``out`` the robots the next pass must visit -- every robot that moved and
    every robot on its list -- and returns ``(how many, largest squared distance from
    ref of any robot that moved)``.
    """
    cap = nbr.shape[1]
    r = num.radius
    d_rr = 2.0 * r
    c2 = (d_rr - SLOP) * (d_rr - SLOP)
    half = 0.5 * num.relax
    pull = num.pull
    movables = bodies.shape[0] + pistons.shape[0] > 0
    far = 0.0
    k = 0
    for q in range(count):
        i = np.int64(q) if everyone else np.int64(active[q])
        near = cell_flag[cell[i]] != 0
        mx = 0.0
        my = 0.0
        if near or lamw[0, i] != 0.0 or lamw[1, i] != 0.0:
            mx, my, _, _ = _walls_held(pos[i, 0], pos[i, 1], r, i, lamw, lamid, pull, seg)
        if near or movables:
            ax, ay, _ = _walls_and_bodies(
                pos[i, 0], pos[i, 1], r, near, seg[:0], sdisc, bodies, pistons
            )
            mx += ax
            my += ay
        moved = mx != 0.0 or my != 0.0
        pos[i, 0] += mx
        pos[i, 1] += my
        m = nnb[i]
        for kk in range(min(m, cap)):
            j = nbr[i, kk]
            dx = pos[i, 0] - pos[j, 0]
            dy = pos[i, 1] - pos[j, 1]
            d2 = dx * dx + dy * dy
            L = np.float64(lam[i, kk]) if m <= cap else 0.0
            step = 0.0
            d = 1.0
            if d2 < c2:
                d = math.sqrt(d2)
                step = half * (d_rr - d)
                if d <= 1e-12:
                    dx = 1.0 if i < j else -1.0
                    dy = 0.0
                    d = 1.0
            elif L > 0.0:
                d = math.sqrt(d2)
                g = 0.5 * (d - d_rr)
                if g > SLOP:
                    step = -min(L, pull * g)
            if step == 0.0:
                continue
            held = m <= cap and nnb[j] <= cap
            if not held and step < 0.0:
                continue
            ux = step * dx / d
            uy = step * dy / d
            pos[i, 0] += ux
            pos[i, 1] += uy
            pos[j, 0] -= ux
            pos[j, 1] -= uy
            other[j, 0] = pos[j, 0]
            other[j, 1] = pos[j, 1]
            moved = True
            if mark[j] == 0:
                mark[j] = 2
                out[k] = j
                k += 1
            ex = pos[j, 0] - ref[j, 0]
            ey = pos[j, 1] - ref[j, 1]
            far = max(far, ex * ex + ey * ey)
            if held:
                lam[i, kk] = L + step
                sj = _slot_of(nbr, nnb, j, i)
                if sj >= 0:
                    lam[j, sj] = L + step
        other[i, 0] = pos[i, 0]
        other[i, 1] = pos[i, 1]
        if moved:
            if mark[i] == 0:
                mark[i] = 2
                out[k] = i
                k += 1
            ex = pos[i, 0] - ref[i, 0]
            ey = pos[i, 1] - ref[i, 1]
            far = max(far, ex * ex + ey * ey)
    # the movers (out[:k], in the order they first moved) and everyone on their lists
    movers = k
    full = False
    for q in range(movers):
        i = out[q]
        for kk in range(min(nnb[i], cap)):
            j = nbr[i, kk]
            if mark[j] == 0:
                mark[j] = 1
                out[k] = j
                k += 1
        if nnb[i] > cap:  # an overflowing list: the next pass visits everyone
            full = True
    for q in range(k):
        mark[out[q]] = 0
    return (-1 if full else k), far


@njit(cache=True, parallel=True)
def _measure(
    pos, nbr, nnb, lam, lamw, lamid, cell, cell_start, perm, cell_flag, grid, num, seg, sdisc,
    bodies, pistons, active, count, everyone,
):  # fmt: skip
    """Read-only: the largest overlap (exact: the lists are valid) and the largest held
    push no longer needed (``min(push, gap)``, mm) of the robots ``active[:count]``
    (every robot when ``everyone``), for the Gauss-Seidel solve (:func:`_held_solve`)."""
    cap = nbr.shape[1]
    r = num.radius
    d_rr = 2.0 * r
    c2 = (d_rr - SLOP) * (d_rr - SLOP)
    nx = grid.nx
    ny = grid.ny
    movables = bodies.shape[0] + pistons.shape[0] > 0
    worst = 0.0
    slack = 0.0
    for k in prange(count):
        i = np.int64(k) if everyone else np.int64(active[k])
        px = pos[i, 0]
        py = pos[i, 1]
        c = cell[i]
        near = cell_flag[c] != 0
        w = 0.0
        sl = 0.0
        if near or lamw[0, i] != 0.0 or lamw[1, i] != 0.0:
            for s in range(seg.shape[0]):
                g, _, _ = _seg_gap(px, py, seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3], r)
                if -g > SLOP:
                    w = max(w, -g)
                elif g > SLOP:
                    for slot in range(2):
                        if lamid[slot, i] == s and lamw[slot, i] > 0.0:
                            sl = max(sl, min(np.float64(lamw[slot, i]), g))
        if near or movables:
            _, _, aw = _walls_and_bodies(px, py, r, near, seg[:0], sdisc, bodies, pistons)
            w = max(w, aw)
        m = nnb[i]
        if m <= cap:
            for kk in range(m):
                j = nbr[i, kk]
                dx = px - pos[j, 0]
                dy = py - pos[j, 1]
                d2 = dx * dx + dy * dy
                if d2 < c2:
                    w = max(w, d_rr - math.sqrt(d2))
                elif lam[i, kk] > 0.0:
                    g = 0.5 * (math.sqrt(d2) - d_rr)
                    if g > SLOP:
                        sl = max(sl, min(np.float64(lam[i, kk]), g))
        else:  # overflowing list: the 3 x 3 cells around the cell it was listed in
            cy = c // nx
            cx = c - cy * nx
            for ccy in range(max(cy - 1, 0), min(cy + 2, ny)):
                for ccx in range(max(cx - 1, 0), min(cx + 2, nx)):
                    cc = ccy * nx + ccx
                    for kj in range(cell_start[cc], cell_start[cc + 1]):
                        j = perm[kj]
                        if j != i:
                            dx = px - pos[j, 0]
                            dy = py - pos[j, 1]
                            d2 = dx * dx + dy * dy
                            if d2 < c2:
                                w = max(w, d_rr - math.sqrt(d2))
        worst = max(worst, w)
        slack = max(slack, sl)
    return worst, slack


@njit(cache=True)
def _add_flagged(flag, out, k, mark):
    """Append to ``out[:k]`` every robot with ``flag`` set that is not in it yet; returns
    the new length (``mark``, all zero, is scratch)."""
    for q in range(k):
        mark[out[q]] = 1
    m = k
    for i in range(flag.shape[0]):
        if flag[i] and mark[i] == 0:
            out[m] = i
            m += 1
    for q in range(k):
        mark[out[q]] = 0
    return m


@njit(cache=True)
def _held_solve(
    src, dst, ref, lam, lamw, lamid, grid, num, cell, cell_start, perm, nbr, nnb, overflows,
    visits, mark, near, cell_flag, seg, sdisc, bodies, pistons, new_row,
):  # fmt: skip
    """The projection with held pushes: measure (:func:`_measure`), and while the largest
    overlap or unneeded held push is above its tolerance, one Gauss-Seidel pass
    (:func:`_gs_pass`) over the robots whose surroundings changed, bodies and pistons
    taking their steps after it.  Positions stay in ``src`` (mirrored into ``dst``).
    Returns ``(sweeps, overlap, list builds)``; a sweep is a measure or a pass."""
    n = src.shape[0]
    r = num.radius
    nb = bodies.shape[0]
    npis = pistons.shape[0]
    moved_b = np.zeros(nb, np.uint8)
    moved_p = np.zeros(npis, np.uint8)
    contact = np.zeros((nb + npis, 2))
    visit = visits[0]
    visit_next = visits[1]
    everyone = True
    count = n
    sweeps = 0
    builds = 0
    while True:
        overlap, slack = _measure(
            src, nbr, nnb, lam, lamw, lamid, cell, cell_start, perm, cell_flag, grid, num,
            seg, sdisc, bodies, pistons, visit, count, everyone,
        )  # fmt: skip
        sweeps += 1
        done = overlap < num.tol and slack < num.slack_tol
        if (sweeps >= num.min_sweeps and done) or sweeps >= num.max_sweeps:
            return sweeps, overlap, builds
        _bodies_pass(src, cell_start, perm, grid, r, num.drag, num.dt, bodies, pistons, contact)
        k, far = _gs_pass(
            src, dst, ref, nbr, nnb, lam, lamw, lamid, cell, cell_flag, num, seg, sdisc,
            bodies, pistons, visit, count, everyone, mark, visit_next,
        )  # fmt: skip
        sweeps += 1
        any_moved = _apply_body_steps(bodies, pistons, contact, moved_b, moved_p, seg, sdisc)
        if not (far <= num.half_skin * num.half_skin):
            overflows[0] = _rebuild(src, ref, grid, num, cell, cell_start, perm, nbr, nnb,
                                    lam, new_row, False)  # fmt: skip
            builds += 1
            everyone = True
            count = n
        elif overflows[0] or k < 0:  # an incomplete list: visit everyone (rare)
            everyone = True
            count = n
        else:
            if any_moved:  # and the robots near a body or piston that moved
                _near_moved(src, bodies, moved_b, pistons, moved_p, r, grid.cell_size, near)
                k = _add_flagged(near, visit_next, k, mark)
            visit, visit_next = visit_next, visit
            count = k
            everyone = False


@njit(cache=True)
def _stash_held(nbr, nnb, lam, held):
    """The nonzero held pushes as ``(row, neighbour row, push)`` arrays (before the lists
    are rebuilt); empty unless ``held``."""
    n = nbr.shape[0] if held else 0
    cap = nbr.shape[1]
    m = 0
    for i in range(n):
        if nnb[i] <= cap:
            for kk in range(nnb[i]):
                m += lam[i, kk] != 0.0
    si = np.empty(m, np.int32)
    sj = np.empty(m, np.int32)
    sl = np.empty(m, np.float32)
    q = 0
    for i in range(n):
        if nnb[i] <= cap:
            for kk in range(nnb[i]):
                if lam[i, kk] != 0.0:
                    si[q] = i
                    sj[q] = nbr[i, kk]
                    sl[q] = lam[i, kk]
                    q += 1
    return si, sj, sl


@njit(cache=True)
def _restore_held(si, sj, sl, new_row, renumber, nbr, nnb, lam):
    """Held pushes back into the rebuilt lists' slots; rows renumbered by ``new_row``
    (old row -> new row) when ``renumber``.  A pair no longer listed loses its push."""
    cap = nbr.shape[1]
    lam[:] = 0.0
    for q in range(si.shape[0]):
        i = new_row[si[q]] if renumber else si[q]
        j = new_row[sj[q]] if renumber else sj[q]
        if nnb[i] <= cap:
            for kk in range(nnb[i]):
                if nbr[i, kk] == j:
                    lam[i, kk] = sl[q]
                    break


@njit(cache=True)
def _next_active(
    active, count, everyone, result, pos, contact2, nbr, nnb, lam, held, near, use_near, mark,
    out,
):  # fmt: skip
    """The robots the next sweep must visit, into ``out``; returns how many.

    Those that moved in the last sweep, those that still overlap something, every robot
    on a mover's list that the mover now overlaps (squared distance below ``contact2`` at
    ``pos``, the configuration the next sweep starts from) or holds a push with (``lam``
    nonzero: both copies of a held push must be updated in the same sweep), and
    (``use_near``) those near a body or piston that moved.  Any other robot has no
    overlap: nothing it overlaps moved (its pairs with robots that did not move, and
    with static walls, are as the last sweep that visited it found them: free), so the
    next sweep would leave it where it is and measure nothing.  Serial, over the robots
    visited last (a few per cent of the swarm after the first sweep); ``mark`` (all
    zero) is scratch.
    """
    k = 0
    for q in range(count):
        fl = result[q]
        if fl == 0:
            continue
        i = np.int64(q) if everyone else np.int64(active[q])
        if mark[i] == 0:
            mark[i] = 1
            out[k] = i
            k += 1
        if fl & MOVED:
            px = pos[i, 0]
            py = pos[i, 1]
            for kk in range(nnb[i]):  # lists never overflow here (see the caller)
                j = nbr[i, kk]
                if mark[j] == 0:
                    # the sweep's own test, from j's side (the same rounding)
                    dx = pos[j, 0] - px
                    dy = pos[j, 1] - py
                    if dx * dx + dy * dy < contact2 or (held and lam[i, kk] != 0.0):
                        mark[j] = 1
                        out[k] = j
                        k += 1
    if use_near:
        for i in range(near.shape[0]):
            if near[i] and mark[i] == 0:
                mark[i] = 1
                out[k] = i
                k += 1
    for q in range(k):
        mark[out[q]] = 0
    return k


@njit(cache=True)
def _cell_range(lo, hi, origin, cs, ncell):
    a = int(math.floor((lo - origin) / cs))
    b = int(math.floor((hi - origin) / cs))
    return max(a, 0), min(b, ncell - 1)


@njit(cache=True)
def _bodies_pass(pos, cell_start, perm, grid, r, gamma_r, dt, bodies, pistons, contact):
    """Serial pass: each movable body's and piston's step from its current contacts.

    A body with drag ``g_b`` touched by ``k`` robots of drag ``g_r`` moves by
    ``sum(g_r * overlap * n) / (k g_r + g_b)`` -- the exact rigid solution when the
    robots push together -- and each robot takes the share ``g_b / (k g_r + g_b)`` of its
    overlap.  The force robots exert in this sweep (``g_r`` x their correction / ``dt``)
    goes to ``contact`` (row b for body b, row B + p for piston p); it is added to the
    contact-force columns only if the sweep's corrections are applied.  The scan reaches
    one cell beyond the body: robots are within ``skin / 2`` of the cells they were
    listed in.
    """
    x0, y0, cs, nx, ny = grid.x0, grid.y0, grid.cell_size, grid.nx, grid.ny
    nb = bodies.shape[0]
    for b in range(nb):
        R = bodies[b, BODY_RADIUS] + r
        reach = R + cs
        bx = bodies[b, BODY_X]
        by = bodies[b, BODY_Y]
        cxa, cxb = _cell_range(bx - reach, bx + reach, x0, cs, nx)
        cya, cyb = _cell_range(by - reach, by + reach, y0, cs, ny)
        k = 0
        sx = 0.0
        sy = 0.0
        for cy in range(cya, cyb + 1):
            for cx in range(cxa, cxb + 1):
                c = cy * nx + cx
                for kk in range(cell_start[c], cell_start[c + 1]):
                    i = perm[kk]
                    dx = pos[i, 0] - bx
                    dy = pos[i, 1] - by
                    d2 = dx * dx + dy * dy
                    if d2 < (R - SLOP) * (R - SLOP):
                        d = math.sqrt(d2)
                        if d < 1e-12:
                            continue
                        ov = R - d
                        k += 1
                        sx -= ov * dx / d
                        sy -= ov * dy / d
        drag = bodies[b, BODY_DRAG]
        contact[b, 0] = 0.0
        contact[b, 1] = 0.0
        if k == 0:
            bodies[b, BODY_STEP_X] = 0.0
            bodies[b, BODY_STEP_Y] = 0.0
            bodies[b, BODY_SHARE] = 1.0
            continue
        if math.isinf(drag):
            share = 1.0
            bodies[b, BODY_STEP_X] = 0.0
            bodies[b, BODY_STEP_Y] = 0.0
        else:
            den = k * gamma_r + drag
            share = drag / den
            bodies[b, BODY_STEP_X] = gamma_r * sx / den
            bodies[b, BODY_STEP_Y] = gamma_r * sy / den
        bodies[b, BODY_SHARE] = share
        contact[b, 0] = gamma_r * share * sx / dt
        contact[b, 1] = gamma_r * share * sy / dt
    for p in range(pistons.shape[0]):
        a = int(pistons[p, PISTON_AXIS])
        side = pistons[p, PISTON_SIDE]
        ppos = pistons[p, PISTON_POSITION]
        lo = pistons[p, PISTON_LO]
        hi = pistons[p, PISTON_HI]
        if a == 0:
            ca, cb = _cell_range(ppos - r - cs, ppos + r + cs, x0, cs, nx)
            oa, ob = _cell_range(lo - r - cs, hi + r + cs, y0, cs, ny)
        else:
            ca, cb = _cell_range(ppos - r - cs, ppos + r + cs, y0, cs, ny)
            oa, ob = _cell_range(lo - r - cs, hi + r + cs, x0, cs, nx)
        o = 1 - a
        k = 0
        s = 0.0
        for u in range(ca, cb + 1):
            for w in range(oa, ob + 1):
                c = w * nx + u if a == 0 else u * nx + w
                for kk in range(cell_start[c], cell_start[c + 1]):
                    i = perm[kk]
                    q = pos[i, o]
                    if q < lo or q > hi:
                        continue
                    gap = side * (pos[i, a] - ppos)
                    if gap < r - SLOP:
                        k += 1
                        s += r - gap
        drag = pistons[p, PISTON_DRAG]
        contact[nb + p, 0] = 0.0
        if k == 0:
            pistons[p, PISTON_STEP] = 0.0
            pistons[p, PISTON_SHARE] = 1.0
            continue
        if math.isinf(drag):
            share = 1.0
            pistons[p, PISTON_STEP] = 0.0
        else:
            den = k * gamma_r + drag
            share = drag / den
            pistons[p, PISTON_STEP] = -side * gamma_r * s / den  # away from the robots
        pistons[p, PISTON_SHARE] = share
        contact[nb + p, 0] = -side * gamma_r * share * s / dt


@njit(cache=True)
def _apply_body_steps(bodies, pistons, contact, moved_b, moved_p, seg, sdisc):
    """Bodies and pistons take the steps of the sweep just applied; their contact forces
    get its share.  Returns whether any moved."""
    nb = bodies.shape[0]
    any_moved = False
    for b in range(nb):
        sx = bodies[b, BODY_STEP_X]
        sy = bodies[b, BODY_STEP_Y]
        moved_b[b] = 1 if (sx != 0.0 or sy != 0.0) else 0
        bodies[b, BODY_X] += sx
        bodies[b, BODY_Y] += sy
        bodies[b, BODY_CONTACT_X] += contact[b, 0]
        bodies[b, BODY_CONTACT_Y] += contact[b, 1]
        any_moved = any_moved or moved_b[b] != 0
    if nb:
        _bodies_vs_static(bodies, seg, sdisc)
    for p in range(pistons.shape[0]):
        moved_p[p] = 1 if pistons[p, PISTON_STEP] != 0.0 else 0
        pistons[p, PISTON_POSITION] += pistons[p, PISTON_STEP]
        pistons[p, PISTON_CONTACT] += contact[nb + p, 0]
        any_moved = any_moved or moved_p[p] != 0
    return any_moved


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


# ----------------------------------------------------------------- the whole step
@njit(cache=True)
def _rebuild(at, ref, grid, num, cell, cell_start, perm, nbr, nnb, lam, new_row, renumber):
    """Rebuild the lists at ``at`` (recorded in ``ref``), carrying the held pushes over
    (rows renumbered by ``new_row`` when ``renumber``).  Returns the overflow count."""
    si, sj, sl = _stash_held(nbr, nnb, lam, num.warm)
    overflows = build_lists(at, ref, grid, num.cutoff, cell, cell_start, perm, nbr, nnb)
    if num.warm:
        _restore_held(si, sj, sl, new_row, renumber, nbr, nnb, lam)
    return overflows


@njit(cache=True)
def _inverse(perm, out):
    for k in range(perm.shape[0]):
        out[perm[k]] = k


@njit(cache=True)
def overdamped_step(
    pos, scratch, ref, fcols, icols, udir, lam, lamw, lamid, grid, num, lists_ready, cell,
    cell_start, perm, nbr, nnb, overflows, visits, result, mark, near, cell_flag, seg, sdisc,
    bodies, pistons,
):  # fmt: skip
    """Advance the overdamped swarm by one step ``num.dt``.

    1. **Motion**: every robot moves at its commanded velocity, bodies and pistons by
       ``F_ext dt / drag``; control timers count down.
    2. **Lists**: if any robot is now farther than ``skin / 2`` from ``ref``, the robots
       are re-sorted by cell and the Verlet lists rebuilt; if the lists are not in the
       workspace yet (``lists_ready`` false: a new or resumed state) they are rebuilt
       from ``ref``, exactly as they were.  Held pushes move to the new lists' slots.
    3. **Warm start** (``num.warm``): every robot takes the pushes its contacts held at
       the end of the last step (:func:`_warm_start`).  A jammed swarm pushed by the same
       commands as in the last step then starts next to its solution instead of one
       robot layer of it per sweep.
    4. **Projection**: Jacobi sweeps (:func:`_sweep`), each measuring the exact largest
       overlap of the current configuration (and, warm, the largest push held that is
       no longer needed), until they are below ``num.tol`` and ``num.slack_tol`` (after
       at least ``num.min_sweeps`` sweeps) or ``num.max_sweeps`` sweeps were made.  The last
       sweep only measures: the configuration it measured is the result, so the overlap
       returned is that of the final positions.  After each applied sweep the list
       validity is checked again and the lists rebuilt (without re-sorting) if needed.
       The first sweep (and the first after a rebuild) visits every robot, later ones
       only the robots whose surroundings changed (:func:`_next_active`).

    ``lam`` (n, capacity) float32 holds the push (mm) of each listed pair, ``lamw`` (2, n)
    float32 those off up to two walls per robot, ``lamid`` (2, n) int32 those walls'
    segment indices (state: they travel with it).  ``scratch`` is an
    (n, 2) buffer that takes every other sweep's positions; the final positions are in
    ``scratch`` when the last value returned is true (the caller swaps the two arrays).
    ``overflows`` (1,) int64 holds the number of overflowing lists (kept with the
    lists); ``visits`` (2, n) int32 and ``result``, ``mark``, ``near`` (n,) uint8 are
    work arrays.  Returns ``(sweeps, overlap (mm), list builds, in_scratch)``.
    """
    n = pos.shape[0]
    r = num.radius
    held = num.warm
    contact2 = (2.0 * r - SLOP) * (2.0 * r - SLOP)  # as in _sweep
    far = _move(pos, udir, fcols[SPEED], icols[TIMER], ref, num.dt)
    _move_bodies(bodies, pistons, seg, sdisc, num.dt)

    builds = 0
    new_row = visits[1]
    if not lists_ready and (held or far <= num.half_skin * num.half_skin):
        # the lists the state's held pushes belong to (or the ones the step will use)
        overflows[0] = build_lists(ref, ref, grid, num.cutoff, cell, cell_start, perm, nbr, nnb)
        builds += 1
    if not (far <= num.half_skin * num.half_skin):
        sort_rows(pos, fcols, icols, udir, lamw, lamid, scratch, grid, cell, cell_start, perm)
        _inverse(perm, new_row)
        overflows[0] = _rebuild(pos, ref, grid, num, cell, cell_start, perm, nbr, nnb, lam,
                                new_row, True)  # fmt: skip
        builds += 1

    nb = bodies.shape[0]
    npis = pistons.shape[0]
    moved_b = np.zeros(nb, np.uint8)
    moved_p = np.zeros(npis, np.uint8)
    contact = np.zeros((nb + npis, 2))
    visit = visits[0]
    visit_next = visits[1]
    src = pos
    dst = scratch
    in_scratch = False
    if held:
        far = _warm_start(src, dst, ref, nbr, nnb, lam, lamw, lamid, seg, r, num.keep)
        src, dst = dst, src
        in_scratch = True
        if not (far <= num.half_skin * num.half_skin):
            overflows[0] = _rebuild(src, ref, grid, num, cell, cell_start, perm, nbr, nnb,
                                    lam, new_row, False)  # fmt: skip
            builds += 1
    if held:
        sweeps, overlap, more = _held_solve(
            src, dst, ref, lam, lamw, lamid, grid, num, cell, cell_start, perm, nbr, nnb,
            overflows, visits, mark, near, cell_flag, seg, sdisc, bodies, pistons, new_row,
        )  # fmt: skip
        return sweeps, overlap, builds + more, in_scratch
    everyone = True
    count = n
    sweeps = 0
    overlap = 0.0
    while True:
        _bodies_pass(src, cell_start, perm, grid, r, num.drag, num.dt, bodies, pistons, contact)
        overlap, far, slack = _sweep(
            src, dst, ref, nbr, nnb, lam, lamw, lamid, cell, cell_start, perm, cell_flag, grid,
            num, seg, sdisc, bodies, pistons, visit, count, everyone, overflows[0] > 0, result,
        )  # fmt: skip
        sweeps += 1
        done = overlap < num.tol and slack < num.slack_tol
        if (sweeps >= num.min_sweeps and done) or sweeps >= num.max_sweeps:
            break  # src is the result; its overlaps were just measured
        # apply the sweep: dst is the configuration now, bodies and pistons take their steps
        any_moved = _apply_body_steps(bodies, pistons, contact, moved_b, moved_p, seg, sdisc)
        src, dst = dst, src
        in_scratch = not in_scratch
        if not (far <= num.half_skin * num.half_skin):
            overflows[0] = _rebuild(src, ref, grid, num, cell, cell_start, perm, nbr, nnb,
                                    lam, new_row, False)  # fmt: skip
            builds += 1
            everyone = True
            count = n
        elif overflows[0]:  # a list is incomplete: visit everyone (rare: large overlaps only)
            everyone = True
            count = n
        else:
            if any_moved:
                _near_moved(src, bodies, moved_b, pistons, moved_p, r, grid.cell_size, near)
            count = _next_active(
                visit, count, everyone, result, src, contact2, nbr, nnb, lam, held, near,
                any_moved, mark, visit_next,
            )  # fmt: skip
            visit, visit_next = visit_next, visit
            everyone = False
    return sweeps, overlap, builds, in_scratch


@njit(cache=True, parallel=True)
def max_overlap(pos, cell_start, grid, r, seg, sdisc, bodies, pistons):
    """Largest overlap (mm) of any robot with a robot, wall, body or piston.

    ``pos`` must be sorted by cell with ``cell_start`` built on it (cells at least 2 r).
    """
    n = pos.shape[0]
    x0, y0, cs, nx, ny = grid.x0, grid.y0, grid.cell_size, grid.nx, grid.ny
    inv_cs = 1.0 / cs
    d_rr = 2.0 * r
    out = 0.0
    for i in prange(n):
        px = pos[i, 0]
        py = pos[i, 1]
        cx, cy = _cell_xy(px, py, x0, y0, inv_cs, nx, ny)
        _, _, m = _walls_and_bodies(px, py, r, True, seg, sdisc, bodies, pistons)
        for ccy in range(max(cy - 1, 0), min(cy + 2, ny)):
            for ccx in range(max(cx - 1, 0), min(cx + 2, nx)):
                c = ccy * nx + ccx
                for j in range(cell_start[c], cell_start[c + 1]):
                    if j == i:
                        continue
                    dx = px - pos[j, 0]
                    dy = py - pos[j, 1]
                    d2 = dx * dx + dy * dy
                    if d2 < d_rr * d_rr:
                        ov = d_rr - math.sqrt(d2)
                        if ov > m:
                            m = ov
        out = max(out, m)
    return out


# ------------------------------------------------------------- inertial (elastic)
@njit(cache=True)
def inertial_step(
    pos,
    vel,
    fcols,
    icols,
    grid,
    cell,
    cell_start,
    perm,
    tmp2,
    r,
    dt,
    seg,
    counters,
):
    """Advance elastic hard discs of equal mass by ``dt``.

    Ballistic motion, then every overlapping, approaching pair (in cell order) is moved
    back to its moment of contact, exchanges the normal components of its velocities
    (an exactly energy- and momentum-conserving elastic collision) and moves on for the
    rest of the step; discs reflect elastically off static segments the same way.
    ``vel`` is re-ordered with the robots.  ``counters[0]`` counts pair collisions and
    ``counters[1]`` wall collisions.
    """
    n = pos.shape[0]
    x0, y0, nx, ny = grid.x0, grid.y0, grid.nx, grid.ny
    inv_cs = 1.0 / grid.cell_size
    for i in range(n):
        pos[i, 0] += vel[i, 0] * dt
        pos[i, 1] += vel[i, 1] * dt
    sort_by_cell(pos, fcols, icols, grid, cell, cell_start, perm, tmp2)
    _permute_pairs(vel, perm, tmp2)
    d_rr = 2.0 * r
    for i in range(n):
        cx, cy = _cell_xy(pos[i, 0], pos[i, 1], x0, y0, inv_cs, nx, ny)
        for ccy in range(max(cy - 1, 0), min(cy + 2, ny)):
            for ccx in range(max(cx - 1, 0), min(cx + 2, nx)):
                c = ccy * nx + ccx
                for j in range(cell_start[c], cell_start[c + 1]):
                    if j <= i:
                        continue
                    dx = pos[i, 0] - pos[j, 0]
                    dy = pos[i, 1] - pos[j, 1]
                    d2 = dx * dx + dy * dy
                    if d2 >= d_rr * d_rr:
                        continue
                    dvx = vel[i, 0] - vel[j, 0]
                    dvy = vel[i, 1] - vel[j, 1]
                    b = dx * dvx + dy * dvy
                    if b >= 0.0:
                        continue  # already separating
                    # time back to contact: |dx - dv t| = 2r, smallest t >= 0
                    v2 = dvx * dvx + dvy * dvy
                    disc = b * b - v2 * (d2 - d_rr * d_rr)
                    tb = 0.0
                    if v2 > 0.0 and disc >= 0.0:
                        tb = (b + math.sqrt(disc)) / v2  # b < 0 -> this is the entry time
                        tb = -tb if tb < 0.0 else tb
                        if tb > dt:
                            tb = dt
                    # rewind, collide, advance
                    pos[i, 0] -= vel[i, 0] * tb
                    pos[i, 1] -= vel[i, 1] * tb
                    pos[j, 0] -= vel[j, 0] * tb
                    pos[j, 1] -= vel[j, 1] * tb
                    ex = pos[i, 0] - pos[j, 0]
                    ey = pos[i, 1] - pos[j, 1]
                    el = math.sqrt(ex * ex + ey * ey)
                    if el < 1e-12:
                        continue
                    ex /= el
                    ey /= el
                    vn = dvx * ex + dvy * ey
                    vel[i, 0] -= vn * ex
                    vel[i, 1] -= vn * ey
                    vel[j, 0] += vn * ex
                    vel[j, 1] += vn * ey
                    pos[i, 0] += vel[i, 0] * tb
                    pos[i, 1] += vel[i, 1] * tb
                    pos[j, 0] += vel[j, 0] * tb
                    pos[j, 1] += vel[j, 1] * tb
                    counters[0] += 1
        for s in range(seg.shape[0]):
            ov, ex, ey = _seg_push(
                pos[i, 0], pos[i, 1], seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3], r
            )
            if ov <= 0.0:
                continue
            vn = vel[i, 0] * ex + vel[i, 1] * ey
            if vn >= 0.0:
                continue
            # mirror the penetration and the normal velocity
            pos[i, 0] += 2.0 * ov * ex
            pos[i, 1] += 2.0 * ov * ey
            vel[i, 0] -= 2.0 * vn * ex
            vel[i, 1] -= 2.0 * vn * ey
            counters[1] += 1
