"""The GPU engine's jam solve: warm-started, over-relaxed Gauss-Seidel passes over
coloured cells (the CPU engine's ``kernels_held``, on a GPU).

A Jacobi sweep carries a push one robot layer per sweep; robots pressed into a wall or a
crowd need the CPU engine's Gauss-Seidel passes (see :mod:`thermoswarm.sim.engine`,
"Jams").  A Gauss-Seidel pass moves each robot against positions its neighbours have
already corrected in the same pass, which is serial by nature.  On the GPU the cells
are **coloured**: a cell's colour is ``(cx mod 3) + 3 (cy mod 3)``, so two cells of one
colour are at least three cells apart, and while no robot has moved far enough from its
build cell to need a second ring of cells (checked after every pass; a rebuild is made
otherwise), the robots one cell's thread moves (its own and those in the 3 x 3 cells
around it) are never touched by another thread of the same colour.  A pass is nine
phases, one per colour, separated by grid-wide barriers; within a cell the robots go in
row order (reversed, and the colours too, in a backward pass: symmetric Gauss-Seidel).

Pushes held: as on the CPU each contact's push is accumulated within the step, so that
an overshoot is taken back, and a jammed step's pushes start the next step (the warm
start).  The CPU engine keeps them in its neighbour lists' slots; the GPU engine has no
lists, so each robot has a small table of :data:`CAP` slots (``nbr``: the neighbour's
row, ``lam``: the push, mm; a slot is free when its push is 0), both copies of a pair's
push updated together; and up to two held wall pushes (``lamw``, ``lamid``: the CPU
engine's layout and function, ``_walls_held``).  A pair that finds no free slot pushes
without holding (as a CPU robot whose list overflowed).  The tables are allocated at
the first jam (``8 x CAP + 16`` bytes a robot).

The same parameters, sweep budget and tolerances as the CPU engine: passes over-relaxed
by ``OMEGA`` (``WARM_OMEGA`` when warm-started, the first ``WARM_BLIND`` rounds without
a measure), pushes kept by ``KEEP``, a warm start only when the largest push held
exceeds ``JAM_PUSH`` commanded displacements, the step ending on a measure that finds
the largest overlap below ``overlap_tol`` and the largest unneeded push below the slack
tolerance, or at ``max_iterations`` sweeps (a pass and a measure each count one).
Bodies and pistons take their shares and steps as in the Jacobi sweeps, before and
after each pass (the CPU passes apply a body's correction as each robot reaches it).
"""

from __future__ import annotations

import math

import numpy as np
from numba import cuda

from thermoswarm.sim import kernels as K
from thermoswarm.sim import kernels_walls as W
from thermoswarm.sim.gpu.kernels import (
    COLD,
    CUR,
    D_IN,
    D_OUT,
    DONE,
    FLAGGED,
    G_C2,
    G_CS,
    G_R,
    G_X0,
    G_Y0,
    HELD,
    LAST_SEEN,
    REBUILD,
    ROUNDS,
    RUNNING,
    SEEN,
    SLACK,
    STATUS,
    STEP_V,
    SWEEPS,
    TOP,
    _twin,
    apply_body_steps,
    body_sums,
    cell_of,
    rings_for,
    robot_contacts,
    seg_gap,
    solve_bodies,
    start_solve,
    walls_and_bodies,
    walls_held,
)

#: Held-push slots per robot (a disc touches at most 6 equal discs).
CAP = 8
#: Launch modes of :func:`gauss_seidel`.
RESUME, WARM, COLD_START = 0, 1, 2

SLOP = K.SLOP
gs_pair_step = _twin(W._gs_pair_step, scalar=True)
held_decay = _twin(W._held_decay)


@cuda.jit(device=True)
def find_slot(nbr, lam, i, j):
    """The slot of ``j`` in ``i``'s table (-1: none)."""
    for s in range(nbr.shape[1]):
        if lam[i, s] != 0.0 and nbr[i, s] == j:
            return s
    return -1


@cuda.jit(device=True)
def free_slot(lam, i):
    """A free slot of ``i``'s table (-1: none)."""
    for s in range(lam.shape[1]):
        if lam[i, s] == 0.0:
            return s
    return -1


@cuda.jit(device=True)
def pair_update(i, j, xi, yi, x, y, xr, yr, nbr, lam, dx, dy, d2, si, L, geo, omega, ctrl):
    """Robot ``i`` (at ``xi, yi``, not yet stored) against robot ``j``: the CPU engine's
    pair step (:func:`gs_pair_step`), both robots moving, the push held in both tables
    when both have a slot.  Returns ``i``'s new position and whether it moved."""
    d_rr = geo[G_R] + geo[G_R]
    step, ux, uy = gs_pair_step(dx, dy, d2, L, geo[G_C2], d_rr, 0.5 * omega, omega, i, j)
    if step == 0.0:
        return xi, yi, False
    if si < 0:
        si = free_slot(lam, i) if step > 0.0 else -1
    sj = find_slot(nbr, lam, j, i) if si >= 0 else -1
    if si >= 0 and sj < 0 and step > 0.0:
        sj = free_slot(lam, j)
    held = si >= 0 and sj >= 0
    if not held and step < 0.0:
        return xi, yi, False
    xi += ux
    yi += uy
    qx = x[j] - ux
    qy = y[j] - uy
    x[j] = qx
    y[j] = qy
    dd = math.sqrt((qx - xr[j]) ** 2 + (qy - yr[j]) ** 2)
    if dd > ctrl[D_OUT]:
        cuda.atomic.max(ctrl, D_OUT, np.float32(dd))
    if held:
        v = np.float32(L + step)
        lam[i, si] = v
        nbr[i, si] = j
        lam[j, sj] = v
        nbr[j, sj] = i
    return xi, yi, True


@cuda.jit(device=True)
def gs_robot(i, x, y, xr, yr, cell_start, cell_flag, nx, ny, geo, omega, wall_omega, seg,
             sdisc, bodies, pistons, nbr, lam, lamw, lamid, ctrl):  # fmt: skip
    """One robot of a Gauss-Seidel pass, in place: its walls (held pushes), discs,
    bodies and pistons, then every robot it overlaps in the 3 x 3 cells around its
    build cell, then the pushes it holds with robots it no longer overlaps."""
    r = geo[G_R]
    c2 = geo[G_C2]
    px = x[i]
    py = y[i]
    ccx, ccy = cell_of(px, py, geo[G_X0], geo[G_Y0], geo[G_CS], nx, ny)
    near = cell_flag[ccy * nx + ccx] != 0
    mx = 0.0
    my = 0.0
    if near or lamw[0, i] != 0.0 or lamw[1, i] != 0.0:
        mx, my, _w, _s = walls_held(px, py, r, i, lamw, lamid, wall_omega, seg)
    if near or bodies.shape[0] + pistons.shape[0] > 0:
        ax, ay, _w = walls_and_bodies(px + mx, py + my, r, near, seg[:0], sdisc, bodies,
                                      pistons)  # fmt: skip
        mx += ax
        my += ay
    moved = mx != 0.0 or my != 0.0
    xi = px + mx
    yi = py + my
    bx, by = cell_of(xr[i], yr[i], geo[G_X0], geo[G_Y0], geo[G_CS], nx, ny)
    xa = max(bx - 1, 0)
    xb = min(bx + 1, nx - 1)
    for cy in range(max(by - 1, 0), min(by + 1, ny - 1) + 1):
        for j in range(cell_start[cy * nx + xa], cell_start[cy * nx + xb + 1]):
            if j == i:
                continue
            dx = xi - x[j]
            dy = yi - y[j]
            d2 = dx * dx + dy * dy
            if d2 >= c2:
                continue
            si = find_slot(nbr, lam, i, j)
            L = np.float64(lam[i, si]) if si >= 0 else 0.0
            xi, yi, m = pair_update(i, j, xi, yi, x, y, xr, yr, nbr, lam, dx, dy, d2, si, L,
                                    geo, omega, ctrl)  # fmt: skip
            moved = moved or m
    for si in range(nbr.shape[1]):
        L = np.float64(lam[i, si])
        if L <= 0.0:
            continue
        j = nbr[i, si]
        dx = xi - x[j]
        dy = yi - y[j]
        d2 = dx * dx + dy * dy
        if d2 < c2:
            continue  # overlapping: done above
        xi, yi, m = pair_update(i, j, xi, yi, x, y, xr, yr, nbr, lam, dx, dy, d2, si, L,
                                geo, omega, ctrl)  # fmt: skip
        moved = moved or m
    x[i] = xi
    y[i] = yi
    if moved:
        dd = math.sqrt((xi - xr[i]) ** 2 + (yi - yr[i]) ** 2)
        if dd > ctrl[D_OUT]:
            cuda.atomic.max(ctrl, D_OUT, np.float32(dd))


@cuda.jit(device=True)
def measure_robot(i, x, y, xr, yr, cell_start, cell_flag, nx, ny, geo, k, seg, sdisc,
                  bodies, pistons, nbr, lam, lamw, lamid):  # fmt: skip
    """Read-only: robot ``i``'s largest overlap (exact: ``k`` rings) and largest held
    push no longer needed (``min(push, gap)``, mm), as the CPU engine's ``_measure``."""
    r = geo[G_R]
    c2 = geo[G_C2]
    d_rr = r + r
    px = x[i]
    py = y[i]
    ccx, ccy = cell_of(px, py, geo[G_X0], geo[G_Y0], geo[G_CS], nx, ny)
    near = cell_flag[ccy * nx + ccx] != 0
    w = 0.0
    sl = 0.0
    if near or lamw[0, i] != 0.0 or lamw[1, i] != 0.0:
        for s in range(seg.shape[0]):
            g, _nx, _ny = seg_gap(px, py, seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3], r)
            if -g > SLOP:
                w = max(w, -g)
            elif g > SLOP:
                for slot in range(2):
                    if lamid[slot, i] == s and lamw[slot, i] > 0.0:
                        sl = max(sl, min(np.float64(lamw[slot, i]), g))
    if near or bodies.shape[0] + pistons.shape[0] > 0:
        _ax, _ay, aw = walls_and_bodies(px, py, r, near, seg[:0], sdisc, bodies, pistons)
        w = max(w, aw)
    _mx, _my, w = robot_contacts(i, px, py, x, y, xr, yr, cell_start, nx, ny, geo, k,
                                 np.float32(0.0), 0.0, 0.0, w)  # fmt: skip
    for s in range(nbr.shape[1]):
        L = lam[i, s]
        if L > 0.0:
            j = nbr[i, s]
            dx = px - x[j]
            dy = py - y[j]
            d2 = dx * dx + dy * dy
            if d2 >= c2:
                g = 0.5 * (math.sqrt(d2) - d_rr)
                if g > SLOP:
                    sl = max(sl, min(np.float64(L), g))
    return w, sl


@cuda.jit(device=True)
def warm_robot(i, sx, sy, dx_, dy_, xr, yr, seg, r, nbr, lam, lamw, lamid, keep, big2,
               flag, ctrl):  # fmt: skip
    """Robot ``i`` takes the pushes it held, scaled by ``keep`` (dropped below
    ``HELD_MIN``), along the present normals (the CPU engine's ``_warm_start``, sharing
    its ``kernels_walls._held_decay``): reads ``(sx, sy)``, writes ``(dx_, dy_)``;
    ``flag[i]``: it would move farther than ``sqrt(big2)``."""
    px = sx[i]
    py = sy[i]
    mx, my, h, top = held_decay(i, px, py, sx, sy, nbr, lam, nbr.shape[1], lamw, lamid, seg,
                                r, keep)  # fmt: skip
    qx = px + mx
    qy = py + my
    dx_[i] = qx
    dy_[i] = qy
    dd = math.sqrt((qx - xr[i]) ** 2 + (qy - yr[i]) ** 2)
    if dd > ctrl[D_OUT]:
        cuda.atomic.max(ctrl, D_OUT, np.float32(dd))
    f = mx * mx + my * my > big2
    flag[i] = 1 if f else 0
    if f:
        cuda.atomic.add(ctrl, FLAGGED, 1.0)
    if h > 0:
        cuda.atomic.max(ctrl, HELD, 1.0)
    if top > ctrl[TOP]:
        cuda.atomic.max(ctrl, TOP, np.float32(top))


@cuda.jit(device=True)
def drop_robot(i, nbr, lam, lamw, flag):
    """A flagged robot's held pushes, both copies of each pair's, are dropped."""
    if flag[i] == 0:
        return
    lamw[0, i] = 0.0
    lamw[1, i] = 0.0
    for s in range(nbr.shape[1]):
        if lam[i, s] != 0.0:
            j = nbr[i, s]
            sj = find_slot(nbr, lam, j, i)
            lam[i, s] = 0.0
            if sj >= 0:
                lam[j, sj] = 0.0


@cuda.jit(device=True)
def colour_phase(tid, nth, colour, backward, x, y, xr, yr, cell_start, cell_flag, nx, ny,
                 geo, omega, wall_omega, seg, sdisc, bodies, pistons, nbr, lam, lamw, lamid,
                 ctrl):  # fmt: skip
    """The cells of one colour, one thread a cell, each cell's robots in row order
    (reversed when ``backward``)."""
    cx0 = colour % 3
    cy0 = colour // 3
    mx = (nx - cx0 + 2) // 3
    my = (ny - cy0 + 2) // 3
    for t in range(tid, mx * my, nth):
        c = (cy0 + 3 * (t // mx)) * nx + cx0 + 3 * (t % mx)
        lo = cell_start[c]
        hi = cell_start[c + 1]
        for q in range(hi - lo):
            i = hi - 1 - q if backward else lo + q
            gs_robot(i, x, y, xr, yr, cell_start, cell_flag, nx, ny, geo, omega, wall_omega,
                     seg, sdisc, bodies, pistons, nbr, lam, lamw, lamid, ctrl)  # fmt: skip


@cuda.jit(device=True)
def warm_start(tid, nth, x0, y0, x1, y1, xr, yr, seg, r, nbr, lam, lamw, lamid, keep, big2,
               jam_push, flag, ctrl):  # fmt: skip
    """Every thread: the warm start (:func:`warm_robot`), again with ``keep = 1`` after
    the robots it would throw drop their pushes (:func:`drop_robot`), as often as
    needed; then a jam (the configuration becomes the warm-started one) or not
    (``ctrl[STATUS] = COLD``)."""
    g = cuda.cg.this_grid()
    n = x0.shape[0]
    kp = keep
    while True:
        even = int(ctrl[CUR]) == 0
        sx = x0 if even else x1
        sy = y0 if even else y1
        dx_ = x1 if even else x0
        dy_ = y1 if even else y0
        for i in range(tid, n, nth):
            warm_robot(i, sx, sy, dx_, dy_, xr, yr, seg, r, nbr, lam, lamw, lamid, kp, big2,
                       flag, ctrl)  # fmt: skip
        g.sync()
        if ctrl[FLAGGED] == 0.0:
            break
        for i in range(tid, n, nth):
            drop_robot(i, nbr, lam, lamw, flag)
        g.sync()
        if tid == 0:
            ctrl[FLAGGED] = 0.0
            ctrl[HELD] = 0.0
            ctrl[TOP] = 0.0
        g.sync()
        kp = 1.0
    if tid == 0:
        if ctrl[HELD] > 0.0 and ctrl[TOP] > jam_push * ctrl[STEP_V]:
            ctrl[CUR] = 1.0 - ctrl[CUR]  # a jam: the warm-started configuration
        else:
            ctrl[STATUS] = COLD


@cuda.jit(device=True)
def measure(tid, nth, x, y, xr, yr, cell_start, cell_flag, nx, ny, geo, seg, sdisc, bodies,
            pistons, nbr, lam, lamw, lamid, min_sweeps, max_sweeps, tol, slack_tol,
            ctrl):  # fmt: skip
    """Every thread: a measure (one sweep) of every robot; ``ctrl[STATUS] = DONE`` when
    the largest overlap and unneeded push are below their tolerances (after
    ``min_sweeps``) or the budget is spent."""
    g = cuda.cg.this_grid()
    k = rings_for(ctrl[D_IN], geo, max(nx, ny))
    for i in range(tid, x.shape[0], nth):
        w, sl = measure_robot(i, x, y, xr, yr, cell_start, cell_flag, nx, ny, geo, k, seg,
                              sdisc, bodies, pistons, nbr, lam, lamw, lamid)  # fmt: skip
        if w > ctrl[SEEN]:
            cuda.atomic.max(ctrl, SEEN, np.float32(w))
        if sl > ctrl[SLACK]:
            cuda.atomic.max(ctrl, SLACK, np.float32(sl))
    g.sync()
    if tid == 0:
        sweeps = ctrl[SWEEPS] + 1.0
        ctrl[SWEEPS] = sweeps
        fine = ctrl[SEEN] < tol and ctrl[SLACK] < slack_tol
        if (sweeps >= min_sweeps and fine) or sweeps >= max_sweeps:
            ctrl[STATUS] = DONE
            ctrl[LAST_SEEN] = ctrl[SEEN]
        ctrl[SEEN] = 0.0
        ctrl[SLACK] = 0.0


@cuda.jit(device=True)
def gs_pass(tid, nth, backward, x, y, xr, yr, cell_start, cell_flag, nx, ny, geo, seg, sdisc,
            bodies, pistons, acc, contact, moved, nbr, lam, lamw, lamid, gamma_r, dt, omega,
            wall_omega, ctrl):  # fmt: skip
    """Every thread: one pass (one sweep): the bodies' shares, the nine colours in order
    (reversed when ``backward``), the bodies' steps; ``ctrl[STATUS] = REBUILD`` when a
    robot has moved too far from its build cell for the colouring."""
    g = cuda.cg.this_grid()
    nb = bodies.shape[0]
    if nb + pistons.shape[0] > 0:
        body_sums(tid, nth, x, y, geo[G_R], bodies, pistons, acc)
        g.sync()
        if tid == 0:
            solve_bodies(bodies, pistons, acc, gamma_r, dt, contact)
        g.sync()
    for cc in range(9):
        colour_phase(tid, nth, 8 - cc if backward else cc, backward, x, y, xr, yr, cell_start,
                     cell_flag, nx, ny, geo, omega, wall_omega, seg, sdisc, bodies, pistons,
                     nbr, lam, lamw, lamid, ctrl)  # fmt: skip
        g.sync()
    if tid == 0:
        if backward == 0:
            ctrl[ROUNDS] += 1.0
        ctrl[SWEEPS] += 1.0
        apply_body_steps(bodies, pistons, contact, moved[:nb], moved[nb:], seg, sdisc)
        ctrl[D_IN] = max(ctrl[D_IN], ctrl[D_OUT])
        if rings_for(ctrl[D_IN], geo, max(nx, ny)) > 1:
            ctrl[STATUS] = REBUILD


@cuda.jit
def gauss_seidel(x0, y0, x1, y1, xr, yr, cell_start, cell_flag, nx, ny, geo, seg, sdisc,
                 bodies, pistons, acc, contact, moved, nbr, lam, lamw, lamid, flag, gamma_r,
                 dt, omega, wall_omega, keep, big2, jam_push, blind, min_sweeps, max_sweeps,
                 tol, slack_tol, mode, ctrl):  # fmt: skip
    """The Gauss-Seidel solve of a jammed step, in one cooperative launch (the CPU
    engine's ``_gs_solve``; see the module doc): a measure before each round of a
    forward and a backward pass (the first ``blind`` rounds unmeasured).

    ``mode``: :data:`WARM` (begin the step: bodies move under external force, then the
    warm start from the held pushes; ``ctrl[STATUS] = COLD`` when they carry no jam,
    the positions untouched: the host runs the Jacobi sweeps), :data:`COLD_START` (after
    the Jacobi sweeps gave up: pushes from zero), :data:`RESUME` (after a rebuild).
    Ends with ``ctrl[STATUS]`` = ``DONE`` or ``REBUILD`` (a robot moved so far from its
    build cell that the colouring no longer separates the threads: rebuild, resume).
    Positions are in buffer ``ctrl[CUR]``, corrected in place."""
    g = cuda.cg.this_grid()
    tid = cuda.grid(1)
    nth = cuda.gridsize(1)
    if tid == 0:
        if mode == WARM:
            start_solve(bodies, pistons, seg, sdisc, dt, ctrl)
        for slot in (FLAGGED, HELD, TOP, SEEN, SLACK):
            ctrl[slot] = 0.0
        ctrl[STATUS] = RUNNING
    g.sync()
    if mode == COLD_START:
        for i in range(tid, x0.shape[0], nth):
            for s in range(nbr.shape[1]):
                lam[i, s] = 0.0
                nbr[i, s] = -1
            for s in range(2):
                lamw[s, i] = 0.0
                lamid[s, i] = -1
    if mode == WARM:
        warm_start(tid, nth, x0, y0, x1, y1, xr, yr, seg, geo[G_R], nbr, lam, lamw, lamid,
                   keep, big2, jam_push, flag, ctrl)  # fmt: skip
    if tid == 0 and ctrl[STATUS] == RUNNING:
        ctrl[D_IN] = max(ctrl[D_IN], ctrl[D_OUT])
        if rings_for(ctrl[D_IN], geo, max(nx, ny)) > 1:
            ctrl[STATUS] = REBUILD
    g.sync()
    if ctrl[STATUS] != RUNNING:
        return
    even = int(ctrl[CUR]) == 0
    x = x0 if even else x1
    y = y0 if even else y1
    while True:
        if ctrl[ROUNDS] >= blind or ctrl[SWEEPS] >= max_sweeps - 2 * blind - 1:
            measure(tid, nth, x, y, xr, yr, cell_start, cell_flag, nx, ny, geo, seg, sdisc,
                    bodies, pistons, nbr, lam, lamw, lamid, min_sweeps, max_sweeps, tol,
                    slack_tol, ctrl)  # fmt: skip
            g.sync()
            if ctrl[STATUS] != RUNNING:
                return
        for backward in range(2):
            gs_pass(tid, nth, backward, x, y, xr, yr, cell_start, cell_flag, nx, ny, geo, seg,
                    sdisc, bodies, pistons, acc, contact, moved, nbr, lam, lamw, lamid,
                    gamma_r, dt, omega, wall_omega, ctrl)  # fmt: skip
            g.sync()
            if ctrl[STATUS] != RUNNING:
                return
            if ctrl[SWEEPS] >= max_sweeps - 1:
                break


@cuda.jit
def gather_tables(perm, inv, nbr, lam, lamw, lamid, nbr2, lam2, lamw2, lamid2):
    """After a rebuild: the held-push tables in the new row order (``perm[k]``: the robot
    now at row ``k``), neighbours renumbered, into the second set of tables."""
    g = cuda.cg.this_grid()
    tid = cuda.grid(1)
    nth = cuda.gridsize(1)
    n = perm.shape[0]
    for k in range(tid, n, nth):
        inv[perm[k]] = k
    g.sync()
    for k in range(tid, n, nth):
        j = perm[k]
        for s in range(nbr.shape[1]):
            v = lam[j, s]
            lam2[k, s] = v
            nbr2[k, s] = inv[nbr[j, s]] if v != 0.0 else -1
        lamw2[0, k] = lamw[0, j]
        lamw2[1, k] = lamw[1, j]
        lamid2[0, k] = lamid[0, j]
        lamid2[1, k] = lamid[1, j]
