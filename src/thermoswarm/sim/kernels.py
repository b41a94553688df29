"""Numba kernels of the engine: cell grid, contact projection, elastic collisions.

Why hand-written: no maintained library offers overdamped rigid-disc contact
projection with force-driven walls and movable bodies on a sorted cell grid for
millions of discs on a CPU (pymunk and Box2D are inertial, single-threaded and an
order of magnitude slower here: see ``benchmarks/``; JAX-MD needs JAX and soft
potentials).  The kernels follow JAX-MD's cell-list design and HOOMD's habit of
keeping particles sorted by cell for memory locality.

Layout
------
Robots live in arrays that the kernels re-order every step so that robots of the
same grid cell are contiguous (a stable counting sort).  ``ids`` carries each robot's
permanent id through the re-ordering.  ``cell_start[c]:cell_start[c+1]`` are the
robots of cell ``c``; cells are ``cs >= 2 r + skin`` wide, so every contact is between
robots in the same or adjacent cells.

Determinism
-----------
Every parallel loop writes only its own elements; sums over robots (forces on
bodies and walls) are done in serial loops in a fixed order.  Results are therefore
bit-identical for a given input whatever the number of threads.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

INF = np.inf


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
def _compute_cells(pos, x0, y0, inv_cs, nx, ny, cell):
    for i in prange(pos.shape[0]):
        cx, cy = _cell_xy(pos[i, 0], pos[i, 1], x0, y0, inv_cs, nx, ny)
        cell[i] = cy * nx + cx


@njit(cache=True)
def _counting_sort(cell, ncell, cell_start, perm):
    """Stable counting sort: ``perm[k]`` is the old index of the robot now at ``k``."""
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
def _gather_f2(a, perm, tmp):
    n = a.shape[0]
    for k in prange(n):
        tmp[k, 0] = a[perm[k], 0]
        tmp[k, 1] = a[perm[k], 1]
    for k in prange(n):
        a[k, 0] = tmp[k, 0]
        a[k, 1] = tmp[k, 1]


@njit(cache=True, parallel=True)
def _gather_f1(a, perm, tmp):
    n = a.shape[0]
    for k in prange(n):
        tmp[k] = a[perm[k]]
    for k in prange(n):
        a[k] = tmp[k]


@njit(cache=True, parallel=True)
def _gather_i1(a, perm, tmp):
    n = a.shape[0]
    for k in prange(n):
        tmp[k] = a[perm[k]]
    for k in prange(n):
        a[k] = tmp[k]


@njit(cache=True)
def sort_by_cell(
    pos, fcols, icols, x0, y0, inv_cs, nx, ny, cell, cell_start, perm, tmpf2, tmpf, tmpi
):
    """Re-order robots by grid cell; ``fcols``/``icols`` are per-robot columns re-ordered too.

    ``fcols`` is a 2D float array (k, n) and ``icols`` a 2D int64 array (m, n).
    """
    ncell = nx * ny
    _compute_cells(pos, x0, y0, inv_cs, nx, ny, cell)
    _counting_sort(cell, ncell, cell_start, perm)
    _gather_f2(pos, perm, tmpf2)
    for j in range(fcols.shape[0]):
        _gather_f1(fcols[j], perm, tmpf)
    for j in range(icols.shape[0]):
        _gather_i1(icols[j], perm, tmpi)


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
def flag_cells_near(seg, sdisc, x0, y0, cs, nx, ny, reach, flags):
    """Mark the cells within ``reach`` of any static segment or static disc."""
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


# ------------------------------------------------------- overdamped projection
@njit(cache=True)
def _bodies_pass(
    pos,
    cell_start,
    x0,
    y0,
    cs,
    nx,
    ny,
    r,
    gamma_r,
    dt,
    bpos,
    brad,
    bdrag,
    bdisp,
    bshare,
    bforce,
    paxis,
    ppos,
    pside,
    plo,
    phi,
    pdrag,
    pdisp,
    pshare,
    pforce,
):
    """Serial pass: displacement of each movable body and piston from its current contacts.

    A body with drag ``g_b`` touched by ``k`` robots of drag ``g_r`` moves by
    ``sum(g_r * overlap * n) / (k g_r + g_b)`` -- the exact rigid solution when the
    robots push together -- and each robot takes the share ``g_b / (k g_r + g_b)`` of its
    overlap.  The force that robots exert is accumulated from the robots' side.
    """
    for b in range(bpos.shape[0]):
        R = brad[b] + r
        cxa = max(0, int(math.floor((bpos[b, 0] - R - x0) / cs)))
        cxb = min(nx - 1, int(math.floor((bpos[b, 0] + R - x0) / cs)))
        cya = max(0, int(math.floor((bpos[b, 1] - R - y0) / cs)))
        cyb = min(ny - 1, int(math.floor((bpos[b, 1] + R - y0) / cs)))
        k = 0
        sx = 0.0
        sy = 0.0
        for cy in range(cya, cyb + 1):
            for cx in range(cxa, cxb + 1):
                c = cy * nx + cx
                for i in range(cell_start[c], cell_start[c + 1]):
                    dx = pos[i, 0] - bpos[b, 0]
                    dy = pos[i, 1] - bpos[b, 1]
                    d2 = dx * dx + dy * dy
                    if d2 < R * R:
                        d = math.sqrt(d2)
                        if d < 1e-12:
                            continue
                        ov = R - d
                        k += 1
                        sx -= ov * dx / d
                        sy -= ov * dy / d
        if k == 0:
            bdisp[b, 0] = 0.0
            bdisp[b, 1] = 0.0
            bshare[b] = 1.0
            continue
        if math.isinf(bdrag[b]):
            share = 1.0
            bdisp[b, 0] = 0.0
            bdisp[b, 1] = 0.0
        else:
            den = k * gamma_r + bdrag[b]
            share = bdrag[b] / den
            bdisp[b, 0] = gamma_r * sx / den
            bdisp[b, 1] = gamma_r * sy / den
        bshare[b] = share
        # force on the body = minus the force on the robots = g_r * (robot correction) / dt
        bforce[b, 0] += gamma_r * share * sx / dt
        bforce[b, 1] += gamma_r * share * sy / dt
    for p in range(paxis.shape[0]):
        a = paxis[p]
        o = 1 - a
        # rows of cells within r of the piston line
        if a == 0:
            ca = max(0, int(math.floor((ppos[p] - r - x0) / cs)))
            cb = min(nx - 1, int(math.floor((ppos[p] + r - x0) / cs)))
            oa = max(0, int(math.floor((plo[p] - r - y0) / cs)))
            ob = min(ny - 1, int(math.floor((phi[p] + r - y0) / cs)))
        else:
            ca = max(0, int(math.floor((ppos[p] - r - y0) / cs)))
            cb = min(ny - 1, int(math.floor((ppos[p] + r - y0) / cs)))
            oa = max(0, int(math.floor((plo[p] - r - x0) / cs)))
            ob = min(nx - 1, int(math.floor((phi[p] + r - x0) / cs)))
        k = 0
        s = 0.0
        for u in range(ca, cb + 1):
            for w in range(oa, ob + 1):
                c = w * nx + u if a == 0 else u * nx + w
                for i in range(cell_start[c], cell_start[c + 1]):
                    q = pos[i, o]
                    if q < plo[p] or q > phi[p]:
                        continue
                    gap = pside[p] * (pos[i, a] - ppos[p])
                    if gap < r:
                        k += 1
                        s += r - gap
        if k == 0:
            pdisp[p] = 0.0
            pshare[p] = 1.0
            continue
        if math.isinf(pdrag[p]):
            share = 1.0
            pdisp[p] = 0.0
        else:
            den = k * gamma_r + pdrag[p]
            share = pdrag[p] / den
            # robots push the wall away from their side
            pdisp[p] = -pside[p] * gamma_r * s / den
        pshare[p] = share
        # force on the piston along its axis (positive = away from the robots' side)
        pforce[p] += -pside[p] * gamma_r * share * s / dt


@njit(cache=True, parallel=True)
def _jacobi_sweep(
    pos,
    out,
    cell_start,
    cell_flag,
    x0,
    y0,
    inv_cs,
    nx,
    ny,
    r,
    relax,
    seg,
    sdisc,
    bpos,
    brad,
    bshare,
    paxis,
    ppos,
    pside,
    plo,
    phi,
    pshare,
    worst,
):
    """One Jacobi sweep: each robot's correction from the positions of this sweep.

    ``worst[i]`` receives the largest overlap robot ``i`` had before the correction.
    """
    n = pos.shape[0]
    d_rr = 2.0 * r
    for i in prange(n):
        px = pos[i, 0]
        py = pos[i, 1]
        cx, cy = _cell_xy(px, py, x0, y0, inv_cs, nx, ny)
        mx = 0.0
        my = 0.0
        w = 0.0
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
                        d = math.sqrt(d2)
                        if d_rr - d > w:
                            w = d_rr - d
                        if d > 1e-12:
                            f = 0.5 * relax * (d_rr - d) / d
                            mx += f * dx
                            my += f * dy
                        else:  # coincident centres: separate along x by index order
                            mx += 0.5 * relax * d_rr * (1.0 if i < j else -1.0)
        c0 = cy * nx + cx
        if cell_flag[c0]:
            for s in range(seg.shape[0]):
                ov, nxs, nys = _seg_push(px, py, seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3], r)
                if ov > 0.0:
                    mx += ov * nxs
                    my += ov * nys
                    if ov > w:
                        w = ov
            for s in range(sdisc.shape[0]):
                dx = px - sdisc[s, 0]
                dy = py - sdisc[s, 1]
                R = sdisc[s, 2] + r
                d2 = dx * dx + dy * dy
                if d2 < R * R:
                    d = math.sqrt(d2)
                    if R - d > w:
                        w = R - d
                    if d > 1e-12:
                        mx += (R - d) * dx / d
                        my += (R - d) * dy / d
        for b in range(bpos.shape[0]):
            dx = px - bpos[b, 0]
            dy = py - bpos[b, 1]
            R = brad[b] + r
            d2 = dx * dx + dy * dy
            if d2 < R * R:
                d = math.sqrt(d2)
                if R - d > w:
                    w = R - d
                if d > 1e-12:
                    f = bshare[b] * (R - d) / d
                    mx += f * dx
                    my += f * dy
        for p in range(paxis.shape[0]):
            a = paxis[p]
            q = py if a == 0 else px
            if q < plo[p] or q > phi[p]:
                continue
            v = px if a == 0 else py
            gap = pside[p] * (v - ppos[p])
            if gap < r:
                if r - gap > w:
                    w = r - gap
                corr = pshare[p] * (r - gap) * pside[p]
                if a == 0:
                    mx += corr
                else:
                    my += corr
        out[i, 0] = px + mx
        out[i, 1] = py + my
        worst[i] = w


@njit(cache=True, parallel=True)
def _predict(pos, heading, speed, timer, dt):
    for i in prange(pos.shape[0]):
        pos[i, 0] += speed[i] * math.cos(heading[i]) * dt
        pos[i, 1] += speed[i] * math.sin(heading[i]) * dt
        timer[i] -= 1


@njit(cache=True)
def overdamped_step(
    pos,
    heading,
    speed,
    fcols,
    icols,
    timer_row,
    x0,
    y0,
    cs,
    nx,
    ny,
    cell,
    cell_start,
    perm,
    tmpf2,
    tmpf,
    tmpi,
    buf,
    cell_flag,
    r,
    gamma_r,
    dt,
    min_iter,
    max_iter,
    tol,
    relax,
    seg,
    sdisc,
    bpos,
    brad,
    bdrag,
    bdisp,
    bshare,
    bforce,
    paxis,
    ppos,
    pside,
    plo,
    phi,
    pdrag,
    pforce_ext,
    pdisp,
    pshare,
    pforce,
    plimit_lo,
    plimit_hi,
):
    """Advance the overdamped swarm by one step ``dt``.

    1. every robot moves at its commanded velocity (``speed``, ``heading``); pistons move
       by ``F_ext dt / drag``; timers count down;
    2. robots are re-sorted by cell (``fcols``/``icols`` re-ordered along; ``heading`` and
       ``speed`` must be rows of ``fcols`` and the timer the row ``timer_row`` of ``icols``);
    3. Jacobi sweeps project the configuration onto non-overlap with robots, static
       walls, bodies and pistons, moving bodies and pistons by the mass-weighted share of
       each contact: at least ``min_iter`` sweeps, then until the largest overlap found
       by a sweep is below ``tol`` (mm), at most ``max_iter``.

    Returns ``(sweeps, largest overlap seen by the last sweep)``.

    ``bforce``/``pforce`` receive the mean contact force that robots exert during the step
    (N per unit drag: drag x mm/s).  Returns nothing; arrays are updated in place.
    """
    n = pos.shape[0]
    inv_cs = 1.0 / cs
    _predict(pos, heading, speed, icols[timer_row], dt)
    for p in range(paxis.shape[0]):
        if not math.isinf(pdrag[p]):
            # external force pushes toward the robots' side
            ppos[p] += pside[p] * pforce_ext[p] * dt / pdrag[p]
            if ppos[p] < plimit_lo[p]:
                ppos[p] = plimit_lo[p]
            if ppos[p] > plimit_hi[p]:
                ppos[p] = plimit_hi[p]
    sort_by_cell(
        pos, fcols, icols, x0, y0, inv_cs, nx, ny, cell, cell_start, perm, tmpf2, tmpf, tmpi
    )
    for b in range(bforce.shape[0]):
        bforce[b, 0] = 0.0
        bforce[b, 1] = 0.0
    for p in range(pforce.shape[0]):
        pforce[p] = 0.0
    src = pos
    dst = buf
    worst = tmpf
    sweeps = 0
    seen = 0.0
    while sweeps < max_iter:
        _bodies_pass(
            src,
            cell_start,
            x0,
            y0,
            cs,
            nx,
            ny,
            r,
            gamma_r,
            dt,
            bpos,
            brad,
            bdrag,
            bdisp,
            bshare,
            bforce,
            paxis,
            ppos,
            pside,
            plo,
            phi,
            pdrag,
            pdisp,
            pshare,
            pforce,
        )
        _jacobi_sweep(
            src,
            dst,
            cell_start,
            cell_flag,
            x0,
            y0,
            inv_cs,
            nx,
            ny,
            r,
            relax,
            seg,
            sdisc,
            bpos,
            brad,
            bshare,
            paxis,
            ppos,
            pside,
            plo,
            phi,
            pshare,
            worst,
        )
        for b in range(bpos.shape[0]):
            bpos[b, 0] += bdisp[b, 0]
            bpos[b, 1] += bdisp[b, 1]
        for p in range(paxis.shape[0]):
            ppos[p] += pdisp[p]
        src, dst = dst, src
        sweeps += 1
        seen = 0.0
        for i in range(n):  # max is order-independent: deterministic
            if worst[i] > seen:
                seen = worst[i]
        if sweeps >= min_iter and seen < tol:
            break
    if sweeps % 2 == 1:
        for i in range(n):
            pos[i, 0] = buf[i, 0]
            pos[i, 1] = buf[i, 1]
    return sweeps, seen


@njit(cache=True, parallel=True)
def max_overlap(
    pos, cell_start, x0, y0, cs, nx, ny, r, seg, sdisc, bpos, brad, paxis, ppos, pside, plo, phi
):
    """Largest overlap (mm) of any robot with a robot, wall, body or piston.

    ``pos`` must be sorted by cell with ``cell_start`` built on it (true after a step).
    """
    n = pos.shape[0]
    inv_cs = 1.0 / cs
    d_rr = 2.0 * r
    worst = np.zeros(n)
    for i in prange(n):
        px = pos[i, 0]
        py = pos[i, 1]
        cx, cy = _cell_xy(px, py, x0, y0, inv_cs, nx, ny)
        m = 0.0
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
                        m = max(m, d_rr - math.sqrt(d2))
        for s in range(seg.shape[0]):
            ov, _, _ = _seg_push(px, py, seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3], r)
            m = max(m, ov)
        for s in range(sdisc.shape[0]):
            dx = px - sdisc[s, 0]
            dy = py - sdisc[s, 1]
            m = max(m, sdisc[s, 2] + r - math.sqrt(dx * dx + dy * dy))
        for b in range(bpos.shape[0]):
            dx = px - bpos[b, 0]
            dy = py - bpos[b, 1]
            m = max(m, brad[b] + r - math.sqrt(dx * dx + dy * dy))
        for p in range(paxis.shape[0]):
            a = paxis[p]
            q = py if a == 0 else px
            if q < plo[p] or q > phi[p]:
                continue
            v = px if a == 0 else py
            m = max(m, r - pside[p] * (v - ppos[p]))
        worst[i] = m
    out = 0.0
    for i in range(n):
        if worst[i] > out:
            out = worst[i]
    return out


# ------------------------------------------------------------- inertial (elastic)
@njit(cache=True)
def inertial_step(
    pos,
    vel,
    fcols,
    icols,
    x0,
    y0,
    cs,
    nx,
    ny,
    cell,
    cell_start,
    perm,
    tmpf2,
    tmpf,
    tmpi,
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
    inv_cs = 1.0 / cs
    for i in range(n):
        pos[i, 0] += vel[i, 0] * dt
        pos[i, 1] += vel[i, 1] * dt
    sort_by_cell(
        pos, fcols, icols, x0, y0, inv_cs, nx, ny, cell, cell_start, perm, tmpf2, tmpf, tmpi
    )
    _gather_f2(vel, perm, tmpf2)
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
