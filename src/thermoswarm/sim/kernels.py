"""Numba kernels of the engine: cell grid, Verlet lists, contact projection, elastic gas.

Why hand-written: no maintained library offers overdamped rigid-disc contact
projection with force-driven walls and movable bodies for millions of discs on a CPU
(pymunk and Box2D are inertial soft-contact solvers; JAX-MD offers soft potentials:
both are measured side by side in ``benchmarks/bench_engine.py``).  The kernels
follow JAX-MD's cell-list design, LAMMPS/HOOMD's Verlet lists with a skin and HOOMD's
habit of keeping particles sorted by cell for memory locality.

Modules (by stage; this module is their one namespace, ``kernels.X`` for any of them)
-------------------------------------------------------------------------------------
:mod:`~thermoswarm.sim.kernels_grid` the state's layout, the cell grid, re-sorting and
the Verlet lists; :mod:`~thermoswarm.sim.kernels_walls` walls, bodies and pistons;
:mod:`~thermoswarm.sim.kernels_sweep` the Jacobi sweep and the next sweep's robots;
:mod:`~thermoswarm.sim.kernels_held` the Gauss-Seidel passes of a jammed step; here:
the decision's checks, the commanded motion, the whole step
(:func:`overdamped_step`), the independent overlap check and the elastic gas.

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

import numpy as np
from numba import njit, prange

from thermoswarm.sim.kernels_grid import (  # noqa: F401  (the kernels' one namespace)
    B_COLS,
    BCX,
    BCY,
    BDRAG,
    BDX,
    BDY,
    BFX,
    BFY,
    BODY_COLUMNS,
    BODY_CONTACT_X,
    BODY_CONTACT_Y,
    BODY_DRAG,
    BODY_FORCE_X,
    BODY_FORCE_Y,
    BODY_RADIUS,
    BODY_SHARE,
    BODY_STEP_X,
    BODY_STEP_Y,
    BODY_X,
    BODY_Y,
    BR,
    BSH,
    BX,
    BY,
    GROUP,
    HEADING,
    ID,
    INF,
    MOVED,
    OVERLAPPING,
    P_COLS,
    PA,
    PC,
    PD,
    PDRAG,
    PF,
    PHI,
    PISTON_AXIS,
    PISTON_COLUMNS,
    PISTON_CONTACT,
    PISTON_DRAG,
    PISTON_FORCE,
    PISTON_HI,
    PISTON_LO,
    PISTON_MAX,
    PISTON_MIN,
    PISTON_POSITION,
    PISTON_SHARE,
    PISTON_SIDE,
    PISTON_STEP,
    PLH,
    PLL,
    PLO,
    PP,
    PS,
    PSH,
    SLOP,
    SPEED,
    TIMER,
    Grid,
    Numerics,
    _cell_range,
    _cell_xy,
    _compute_cells,
    _copy_pairs,
    _counting_sort,
    _fill_lists,
    _permute,
    _permute_pairs,
    build_lists,
    serial_twin,
    sort_by_cell,
    sort_rows,
)
from thermoswarm.sim.kernels_held import (  # noqa: F401  (the kernels' one namespace)
    _add_flagged,
    _drop_pushes,
    _gs_pass,
    _gs_solve,
    _inverse,
    _measure,
    _rebuild,
    _restore_held,
    _slot_of,
    _stash_held,
    _warm_start,
)
from thermoswarm.sim.kernels_sweep import (  # noqa: F401  (the kernels' one namespace)
    _collect_marked,
    _near_moved,
    _pair_push,
    _sweep,
    _sweep_serial,
)
from thermoswarm.sim.kernels_walls import (  # noqa: F401  (the kernels' one namespace)
    _apply_body_steps,
    _bodies_pass,
    _bodies_vs_static,
    _move_bodies,
    _seg_gap,
    _seg_push,
    _walls_and_bodies,
    _walls_held,
    flag_cells_near,
)


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


_move_serial = serial_twin(_move, "_move_serial")


@njit(cache=True)
def overdamped_step(
    pos, scratch, ref, fcols, icols, udir, lam, lamw, lamid, warm, grid, num, omega,
    wall_omega, warm_omega, warm_blind, gs_after, jam_push, lists_ready, cell, cell_start,
    perm, nbr, nnb, overflows, visits, result, mark, near, cell_flag, seg, sdisc, bodies,
    pistons, serial,
):  # fmt: skip
    """Advance the overdamped swarm by one step ``num.dt``.

    1. **Motion**: every robot moves at its commanded velocity, bodies and pistons by
       ``F_ext dt / drag``; control timers count down.
    2. **Lists**: if any robot is now farther than ``skin / 2`` from ``ref``, the robots
       are re-sorted by cell and the Verlet lists rebuilt; if the lists are not in the
       workspace yet (``lists_ready`` false: a new or resumed state) they are rebuilt
       from ``ref``, exactly as they were.  Held pushes move to the new lists' slots.
    3. **Warm start** (``warm``: the last step ended with pushes held, a jam): every
       robot takes the pushes its contacts held, scaled by ``num.keep``
       (:func:`_warm_start`); a robot they would move farther than ``skin / 2`` drops
       its pushes instead (:func:`_drop_pushes`: self-stress that a hyperstatic jam can
       build up without moving anything may not throw a robot).  Then step 5, its
       passes over-relaxed by ``warm_omega`` and its first ``warm_blind`` rounds made
       without a measure -- if the largest push held exceeds ``jam_push`` x the largest
       commanded displacement (a push carried through a pile: a jam); else the pushes
       are dropped and the step is cold (a free swarm's occasional crowd).
    4. **Projection, Jacobi** (no pushes held): parallel sweeps (:func:`_sweep`), each
       measuring the exact largest overlap of the current configuration and correcting
       it, until it is below ``num.tol`` (after at least ``num.min_sweeps`` sweeps) or
       ``gs_after`` sweeps were made.  A free swarm is done here.
    5. **Projection, Gauss-Seidel** (a jam: robots pressed into a wall or a crowd, where
       a Jacobi sweep carries a push only one robot layer further): symmetric projected
       Gauss-Seidel passes over-relaxed by ``omega`` (``wall_omega`` against walls),
       each contact's push accumulated so that an overshoot is taken back
       (:func:`_gs_solve`), until the largest overlap and the largest unneeded push are
       below ``num.tol`` and ``num.slack_tol`` or ``num.max_sweeps`` sweeps were made.

    The last sweep only measures: the configuration it measured is the result, so the
    overlap returned is that of the final positions.  After each applied sweep or pass
    the list validity is checked again and the lists rebuilt (without re-sorting) if
    needed.  The first sweep (and the first after a rebuild) visits every robot, later
    ones only the robots whose surroundings changed (marked by :func:`_sweep`).

    ``lam`` (n, capacity) float32 holds the push (mm) of each listed pair, ``lamw`` (2, n)
    float32 those off up to two walls per robot, ``lamid`` (2, n) int32 those walls'
    segment indices (the state's held pushes when ``warm``; else any arrays of those
    types, empty ones included: step 5 then makes its own).  ``scratch`` is an (n, 2)
    buffer that takes every other sweep's positions; the final positions are in
    ``scratch`` when ``in_scratch`` is true (the caller swaps the two arrays).
    ``overflows`` (1,) int64 holds the number of overflowing lists (kept with the
    lists); ``visits`` (2, n) int32 and ``result``, ``mark`` (padded to a multiple of 8
    bytes), ``near`` (n,) uint8 are work arrays.  ``serial``: the step runs on one
    thread, and calls the serial twins of the parallel loops it makes every step
    (:func:`serial_twin`; the same results, without the cost of a parallel launch).
    Returns ``(sweeps, overlap (mm), list builds, in_scratch, lam, lamw,
    lamid, held)``; ``held``: step 5 ran, and ``lam, lamw, lamid`` are the pushes it
    ended with (for the next step's warm start).
    """
    n = pos.shape[0]
    r = num.radius
    hs2 = num.half_skin * num.half_skin
    # --- stage: 1, motion (commanded velocities, bodies, pistons; timers count down)
    if serial:  # one thread: the parallel loops' serial twins (no launch cost)
        far = _move_serial(pos, udir, fcols[SPEED], icols[TIMER], ref, num.dt)
    else:
        far = _move(pos, udir, fcols[SPEED], icols[TIMER], ref, num.dt)
    _move_bodies(bodies, pistons, seg, sdisc, num.dt)

    # --- stage: 2, lists (re-sort and rebuild once a robot left its skin)
    builds = 0
    new_row = visits[1]
    if not lists_ready and (warm or far <= hs2):
        # the lists the held pushes belong to (or the ones the step will use)
        overflows[0] = build_lists(ref, ref, grid, num.cutoff, cell, cell_start, perm, nbr, nnb)
        builds += 1
    if not (far <= hs2):
        if warm:  # the held pushes move with their robots, to the new lists' slots
            sort_rows(pos, fcols, icols, udir, lamw, lamid, scratch, grid, cell, cell_start, perm)
            _inverse(perm, new_row)
        else:
            sort_rows(pos, fcols, icols, udir, lamw[:0], lamid[:0], scratch, grid, cell,
                      cell_start, perm)  # fmt: skip
        overflows[0] = _rebuild(pos, ref, grid, num, cell, cell_start, perm, nbr, nnb, lam,
                                new_row, True, warm)  # fmt: skip
        builds += 1
    # --- stage: 3, warm start from the held pushes, or drop them (no jam)
    src = pos
    dst = scratch
    in_scratch = False
    if warm:
        far, flagged, held, top = _warm_start(src, dst, ref, nbr, nnb, lam, lamw, lamid, seg,
                                              r, num.keep, hs2, result)  # fmt: skip
        while flagged:
            _drop_pushes(result, nbr, nnb, lam, lamw)
            far, flagged, held, top = _warm_start(src, dst, ref, nbr, nnb, lam, lamw, lamid,
                                                  seg, r, 1.0, hs2, result)  # fmt: skip
        # a jam: a push held larger than jam_push robots' commanded displacements (a push
        # carried through a pile); a free swarm's passes hold pushes of one or two
        vmax = 0.0
        speed = fcols[SPEED]
        for i in range(n):
            vmax = max(vmax, speed[i])
        warm = held > 0 and top > jam_push * vmax * num.dt
    # --- stage: 5 (warm), Gauss-Seidel passes from the held pushes
    if warm:
        src, dst = dst, src
        in_scratch = True
        if not (far <= hs2):
            overflows[0] = _rebuild(src, ref, grid, num, cell, cell_start, perm, nbr, nnb,
                                    lam, new_row, False, True)  # fmt: skip
            builds += 1
        sweeps, overlap, more = _gs_solve(
            src, dst, ref, lam, lamw, lamid, grid, num, warm_omega, warm_omega, cell,
            cell_start, perm, nbr, nnb, overflows, visits, mark, near, cell_flag, seg, sdisc,
            bodies, pistons, new_row, 0, n, True, warm_blind,
        )  # fmt: skip
        return sweeps, overlap, builds + more, in_scratch, lam, lamw, lamid, True
    # --- stage: 4, Jacobi sweeps (a free swarm ends here)
    sweeps, overlap, more, in_scratch, count, everyone, jam = _jacobi(
        src, dst, ref, grid, num, gs_after, cell, cell_start, perm, nbr, nnb, overflows,
        visits, mark, near, cell_flag, seg, sdisc, bodies, pistons, new_row, lam, serial,
    )  # fmt: skip
    builds += more
    if not jam:
        return sweeps, overlap, builds, in_scratch, lam, lamw, lamid, False
    # --- stage: 5 (cold), a jam: Gauss-Seidel passes, pushes from zero
    if in_scratch:
        src, dst = dst, src
    # a jam: Gauss-Seidel from here, the pushes accumulated from zero
    if lam.shape[0] == n:
        lam[:] = 0.0
        lamw[:] = 0.0
        lamid[:] = -1
    else:  # none held: made here (a free swarm never needs them)
        lam = np.zeros((n, nbr.shape[1]), np.float32)
        lamw = np.zeros((2, n), np.float32)
        lamid = np.full((2, n), -1, np.int32)
    sweeps, overlap, more = _gs_solve(
        src, dst, ref, lam, lamw, lamid, grid, num, omega, wall_omega, cell, cell_start, perm,
        nbr, nnb, overflows, visits, mark, near, cell_flag, seg, sdisc, bodies, pistons,
        new_row, sweeps, count, everyone, 0,
    )  # fmt: skip
    return sweeps, overlap, builds + more, in_scratch, lam, lamw, lamid, True


@njit(cache=True)
def _jacobi(
    pos, scratch, ref, grid, num, gs_after, cell, cell_start, perm, nbr, nnb, overflows,
    visits, mark, near, cell_flag, seg, sdisc, bodies, pistons, new_row, lam, serial,
):  # fmt: skip
    """Jacobi sweeps (step 4 of :func:`overdamped_step`), alternating between ``pos``
    and ``scratch``.  Returns ``(sweeps, overlap, list builds, in_scratch, count,
    everyone, jam)``: ``jam`` when ``gs_after`` sweeps did not reach the tolerance, the
    configuration (not measured yet) then in ``scratch`` if ``in_scratch``, and the
    robots the next sweep must visit in ``visits[0][:count]`` (every robot when
    ``everyone``)."""
    n = pos.shape[0]
    r = num.radius
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
    everyone = True
    count = n
    sweeps = 0
    builds = 0
    while True:
        _bodies_pass(src, cell_start, perm, grid, r, num.drag, num.dt, bodies, pistons, contact)
        if serial:
            overlap, far = _sweep_serial(
                src, dst, ref, nbr, nnb, cell, cell_start, perm, cell_flag, grid, num, seg,
                sdisc, bodies, pistons, visit, count, everyone, mark,
            )  # fmt: skip
        else:
            overlap, far = _sweep(
                src, dst, ref, nbr, nnb, cell, cell_start, perm, cell_flag, grid, num, seg,
                sdisc, bodies, pistons, visit, count, everyone, mark,
            )  # fmt: skip
        sweeps += 1
        if (sweeps >= num.min_sweeps and overlap < num.tol) or sweeps >= num.max_sweeps:
            mark[:] = 0
            break  # src, just measured, is the result
        # apply the sweep: dst is the configuration now, bodies and pistons take their steps
        any_moved = _apply_body_steps(bodies, pistons, contact, moved_b, moved_p, seg, sdisc)
        src, dst = dst, src
        in_scratch = not in_scratch
        if not (far <= num.half_skin * num.half_skin):
            overflows[0] = _rebuild(src, ref, grid, num, cell, cell_start, perm, nbr, nnb,
                                    lam, new_row, False, False)  # fmt: skip
            builds += 1
            everyone = True
            count = n
            mark[:] = 0
        elif overflows[0]:  # a list is incomplete: visit everyone (rare: large overlaps only)
            everyone = True
            count = n
            mark[:] = 0
        else:
            if any_moved:
                _near_moved(src, bodies, moved_b, pistons, moved_p, r, grid.cell_size, near)
            # the robots the sweep marked (see _sweep), in row order
            count = _collect_marked(mark, near, any_moved, visit_next)
            visit, visit_next = visit_next, visit
            everyone = False
        if sweeps >= gs_after and not overflows[0]:
            if not everyone:  # already in row order (_collect_marked), as the passes need
                visits[0][:count] = visit[:count]  # (visit may be either row of visits)
            return sweeps, overlap, builds, in_scratch, count, everyone, True
    return sweeps, overlap, builds, in_scratch, count, everyone, False


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
    # --- stage: ballistic flight
    for i in range(n):
        pos[i, 0] += vel[i, 0] * dt
        pos[i, 1] += vel[i, 1] * dt
    # --- stage: re-sort by cell, velocities with the robots
    sort_by_cell(pos, fcols, icols, grid, cell, cell_start, perm, tmp2)
    _permute_pairs(vel, perm, tmp2)
    # --- stage: pair collisions: rewind to contact, exchange normal velocities, advance
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
        # --- stage: wall collisions: mirror the penetration and the normal velocity
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
