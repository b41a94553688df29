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


# ------------------------------------------------------- overdamped projection
# Column layout of the packed body and piston arrays (see engine._pack_*).
BX, BY, BR, BDRAG, BFX, BFY, BCX, BCY, BDX, BDY, BSH = range(11)
B_COLS = 11
PA, PP, PS, PLO, PHI, PDRAG, PF, PLL, PLH, PC, PD, PSH = range(12)
P_COLS = 12


@njit(cache=True, parallel=True)
def _predict(pos, udir, speed, timer, dt, x0, y0, inv_cs, nx, ny, cell):
    """Commanded motion for one step; count the control timers down; grid cells.

    ``udir`` (2, n) float32 holds each robot's unit direction (cos, sin of its heading),
    computed once per decision, so that no trigonometry is done per step.
    """
    for i in prange(pos.shape[0]):
        x = pos[i, 0] + speed[i] * udir[0, i] * dt
        y = pos[i, 1] + speed[i] * udir[1, i] * dt
        pos[i, 0] = x
        pos[i, 1] = y
        timer[i] -= 1
        cx, cy = _cell_xy(x, y, x0, y0, inv_cs, nx, ny)
        cell[i] = cy * nx + cx


@njit(cache=True, parallel=True)
def _gather_all(pos, fcols, icols, udir, pos2, fcols2, icols2, udir2, perm):
    """Write every per-robot column in sorted order into the second buffers (one pass)."""
    nf = fcols.shape[0]
    ni = icols.shape[0]
    for k in prange(pos.shape[0]):
        j = perm[k]
        pos2[k, 0] = pos[j, 0]
        pos2[k, 1] = pos[j, 1]
        udir2[0, k] = udir[0, j]
        udir2[1, k] = udir[1, j]
        for c in range(nf):
            fcols2[c, k] = fcols[c, j]
        for c in range(ni):
            icols2[c, k] = icols[c, j]


@njit(cache=True, parallel=True)
def _build_neighbours(pos, cell_start, nx, ny, cutoff, nbr, nnb, flag):
    """Fixed-capacity neighbour lists: every j within ``cutoff`` of i (both directions).

    Robots are sorted by cell, so the three cells of a grid row next to robot i hold
    one contiguous range of robots: three ranges per robot instead of nine cells.
    ``flag[i] = 1`` when robot i has more neighbours than the capacity (overflow).
    """
    cap = nbr.shape[1]
    c2 = cutoff * cutoff
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
            for i in range(a, b):
                px = pos[i, 0]
                py = pos[i, 1]
                k = 0
                over = 0
                for ccy in range(ya, yb + 1):
                    j0 = cell_start[ccy * nx + xa]
                    j1 = cell_start[ccy * nx + xb + 1]
                    for j in range(j0, j1):
                        dx = px - pos[j, 0]
                        dy = py - pos[j, 1]
                        if dx * dx + dy * dy < c2 and j != i:
                            if k < cap:
                                nbr[i, k] = j
                                k += 1
                            else:
                                over = 1
                nnb[i] = k
                flag[i] = over


@njit(cache=True, inline="always")
def _walls_and_bodies(i, px, py, r, cell_flag_i, seg, sdisc, bodies, pistons):
    """Correction (mx, my) and largest overlap of robot i against walls, bodies, pistons."""
    mx = 0.0
    my = 0.0
    w = 0.0
    if cell_flag_i:
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
    for b in range(bodies.shape[0]):
        dx = px - bodies[b, BX]
        dy = py - bodies[b, BY]
        R = bodies[b, BR] + r
        d2 = dx * dx + dy * dy
        if d2 < R * R:
            d = math.sqrt(d2)
            if R - d > w:
                w = R - d
            if d > 1e-12:
                f = bodies[b, BSH] * (R - d) / d
                mx += f * dx
                my += f * dy
    for p in range(pistons.shape[0]):
        a = int(pistons[p, PA])
        q = py if a == 0 else px
        if q < pistons[p, PLO] or q > pistons[p, PHI]:
            continue
        v = px if a == 0 else py
        gap = pistons[p, PS] * (v - pistons[p, PP])
        if gap < r:
            if r - gap > w:
                w = r - gap
            corr = pistons[p, PSH] * (r - gap) * pistons[p, PS]
            if a == 0:
                mx += corr
            else:
                my += corr
    return mx, my, w


@njit(cache=True, parallel=True)
def _sweep_list(
    src,
    dst,
    nbr,
    nnb,
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
    bodies,
    pistons,
    moved_prev,
    moved_cur,
    near_moved_body,
    first,
    worst,
):
    """One Jacobi sweep over the neighbour lists.

    After the first sweep a robot is recomputed only if it, a neighbour, or a body or
    piston it may touch moved in the previous sweep; otherwise its position is already
    right in both buffers and its overlaps are zero.
    """
    n = src.shape[0]
    d_rr = 2.0 * r
    for i in prange(n):
        active = True
        if not first:
            active = moved_prev[i] != 0 or near_moved_body[i] != 0
            if not active:
                for k in range(nnb[i]):
                    if moved_prev[nbr[i, k]] != 0:
                        active = True
                        break
        w = 0.0
        if active:
            px = src[i, 0]
            py = src[i, 1]
            cx, cy = _cell_xy(px, py, x0, y0, inv_cs, nx, ny)
            mx, my, w = _walls_and_bodies(
                i, px, py, r, cell_flag[cy * nx + cx], seg, sdisc, bodies, pistons
            )
            for k in range(nnb[i]):
                j = nbr[i, k]
                dx = px - src[j, 0]
                dy = py - src[j, 1]
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
            dst[i, 0] = px + mx
            dst[i, 1] = py + my
            moved_cur[i] = 1 if (mx != 0.0 or my != 0.0) else 0
        else:
            moved_cur[i] = 0
        worst[i] = w


@njit(cache=True, parallel=True)
def _sweep_cells(
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
    bodies,
    pistons,
    moved_cur,
    worst,
):
    """One Jacobi sweep scanning the cell grid (the fallback when a list overflows)."""
    n = src.shape[0]
    d_rr = 2.0 * r
    for i in prange(n):
        px = src[i, 0]
        py = src[i, 1]
        cx, cy = _cell_xy(px, py, x0, y0, inv_cs, nx, ny)
        mx, my, w = _walls_and_bodies(
            i, px, py, r, cell_flag[cy * nx + cx], seg, sdisc, bodies, pistons
        )
        for ccy in range(max(cy - 1, 0), min(cy + 2, ny)):
            for ccx in range(max(cx - 1, 0), min(cx + 2, nx)):
                c = ccy * nx + ccx
                for j in range(cell_start[c], cell_start[c + 1]):
                    if j == i:
                        continue
                    dx = px - src[j, 0]
                    dy = py - src[j, 1]
                    d2 = dx * dx + dy * dy
                    if d2 < d_rr * d_rr:
                        d = math.sqrt(d2)
                        if d_rr - d > w:
                            w = d_rr - d
                        if d > 1e-12:
                            f = 0.5 * relax * (d_rr - d) / d
                            mx += f * dx
                            my += f * dy
                        else:
                            mx += 0.5 * relax * d_rr * (1.0 if i < j else -1.0)
        dst[i, 0] = px + mx
        dst[i, 1] = py + my
        moved_cur[i] = 1 if (mx != 0.0 or my != 0.0) else 0
        worst[i] = w


@njit(cache=True)
def _cell_range(lo, hi, origin, cs, ncell):
    a = int(math.floor((lo - origin) / cs))
    b = int(math.floor((hi - origin) / cs))
    return max(a, 0), min(b, ncell - 1)


@njit(cache=True)
def _bodies_pass(pos, cell_start, x0, y0, cs, nx, ny, r, gamma_r, dt, bodies, pistons):
    """Serial pass: displacement of each movable body and piston from its current contacts.

    A body with drag ``g_b`` touched by ``k`` robots of drag ``g_r`` moves by
    ``sum(g_r * overlap * n) / (k g_r + g_b)`` -- the exact rigid solution when the
    robots push together -- and each robot takes the share ``g_b / (k g_r + g_b)`` of its
    overlap.  The force that robots exert (``g_r`` x the robots' correction / ``dt``) is
    added to the body's contact-force columns.  The scan covers one extra cell so that
    robots that moved during earlier sweeps are still found.
    """
    for b in range(bodies.shape[0]):
        R = bodies[b, BR] + r
        reach = R + cs
        cxa, cxb = _cell_range(bodies[b, BX] - reach, bodies[b, BX] + reach, x0, cs, nx)
        cya, cyb = _cell_range(bodies[b, BY] - reach, bodies[b, BY] + reach, y0, cs, ny)
        k = 0
        sx = 0.0
        sy = 0.0
        for cy in range(cya, cyb + 1):
            for cx in range(cxa, cxb + 1):
                c = cy * nx + cx
                for i in range(cell_start[c], cell_start[c + 1]):
                    dx = pos[i, 0] - bodies[b, BX]
                    dy = pos[i, 1] - bodies[b, BY]
                    d2 = dx * dx + dy * dy
                    if d2 < R * R:
                        d = math.sqrt(d2)
                        if d < 1e-12:
                            continue
                        ov = R - d
                        k += 1
                        sx -= ov * dx / d
                        sy -= ov * dy / d
        drag = bodies[b, BDRAG]
        if k == 0:
            bodies[b, BDX] = 0.0
            bodies[b, BDY] = 0.0
            bodies[b, BSH] = 1.0
            continue
        if math.isinf(drag):
            share = 1.0
            bodies[b, BDX] = 0.0
            bodies[b, BDY] = 0.0
        else:
            den = k * gamma_r + drag
            share = drag / den
            bodies[b, BDX] = gamma_r * sx / den
            bodies[b, BDY] = gamma_r * sy / den
        bodies[b, BSH] = share
        bodies[b, BCX] += gamma_r * share * sx / dt
        bodies[b, BCY] += gamma_r * share * sy / dt
    for p in range(pistons.shape[0]):
        a = int(pistons[p, PA])
        side = pistons[p, PS]
        ppos = pistons[p, PP]
        if a == 0:
            ca, cb = _cell_range(ppos - r - cs, ppos + r + cs, x0, cs, nx)
            oa, ob = _cell_range(pistons[p, PLO] - r, pistons[p, PHI] + r, y0, cs, ny)
        else:
            ca, cb = _cell_range(ppos - r - cs, ppos + r + cs, y0, cs, ny)
            oa, ob = _cell_range(pistons[p, PLO] - r, pistons[p, PHI] + r, x0, cs, nx)
        o = 1 - a
        k = 0
        s = 0.0
        for u in range(ca, cb + 1):
            for w in range(oa, ob + 1):
                c = w * nx + u if a == 0 else u * nx + w
                for i in range(cell_start[c], cell_start[c + 1]):
                    q = pos[i, o]
                    if q < pistons[p, PLO] or q > pistons[p, PHI]:
                        continue
                    gap = side * (pos[i, a] - ppos)
                    if gap < r:
                        k += 1
                        s += r - gap
        drag = pistons[p, PDRAG]
        if k == 0:
            pistons[p, PD] = 0.0
            pistons[p, PSH] = 1.0
            continue
        if math.isinf(drag):
            share = 1.0
            pistons[p, PD] = 0.0
        else:
            den = k * gamma_r + drag
            share = drag / den
            pistons[p, PD] = -side * gamma_r * s / den  # pushed away from the robots
        pistons[p, PSH] = share
        pistons[p, PC] += -side * gamma_r * share * s / dt


@njit(cache=True)
def _bodies_vs_static(bodies, seg, sdisc):
    """Keep movable bodies out of static walls and obstacles (walls do not yield)."""
    for b in range(bodies.shape[0]):
        R = bodies[b, BR]
        for s in range(seg.shape[0]):
            ov, nxs, nys = _seg_push(
                bodies[b, BX], bodies[b, BY], seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3], R
            )
            if ov > 0.0:
                bodies[b, BX] += ov * nxs
                bodies[b, BY] += ov * nys
        for s in range(sdisc.shape[0]):
            dx = bodies[b, BX] - sdisc[s, 0]
            dy = bodies[b, BY] - sdisc[s, 1]
            RR = R + sdisc[s, 2]
            d2 = dx * dx + dy * dy
            if d2 < RR * RR:
                d = math.sqrt(d2)
                if d > 1e-12:
                    bodies[b, BX] += (RR - d) * dx / d
                    bodies[b, BY] += (RR - d) * dy / d


@njit(cache=True, parallel=True)
def _near_moved(pos, bodies, moved_b, pistons, moved_p, r, reach, out):
    """Flag robots within ``reach`` of a body or piston that moved in the last sweep."""
    nb = bodies.shape[0]
    npis = pistons.shape[0]
    for i in prange(pos.shape[0]):
        f = 0
        for b in range(nb):
            if moved_b[b]:
                dx = pos[i, 0] - bodies[b, BX]
                dy = pos[i, 1] - bodies[b, BY]
                R = bodies[b, BR] + r + reach
                if dx * dx + dy * dy < R * R:
                    f = 1
        for p in range(npis):
            if moved_p[p]:
                a = int(pistons[p, PA])
                if abs(pos[i, a] - pistons[p, PP]) < r + reach:
                    f = 1
        out[i] = f


@njit(cache=True, parallel=True)
def _copy2(src, dst):
    for i in prange(src.shape[0]):
        dst[i, 0] = src[i, 0]
        dst[i, 1] = src[i, 1]


@njit(cache=True)
def overdamped_step(
    pos,
    fcols,
    icols,
    udir,
    pos2,
    fcols2,
    icols2,
    udir2,
    gf,
    gi,
    pp,
    cell,
    cell_start,
    perm,
    nbr,
    nnb,
    moved,
    cell_flag,
    seg,
    sdisc,
    bodies,
    pistons,
):
    """Advance the overdamped swarm by one step ``dt``.

    Arguments: ``fcols`` rows (heading, speed); ``icols`` rows (id, group, timer);
    ``udir`` (2, n) float32 unit directions of the headings; ``pos2``, ``fcols2``,
    ``icols2``, ``udir2`` second buffers of the same shapes, which receive the
    new state (the caller swaps the references); ``gf`` = (x0, y0, cs); ``gi`` = (nx, ny,
    min_sweeps, max_sweeps); ``pp`` = (r, drag, dt, tol, relax, cutoff); ``bodies`` and
    ``pistons`` packed as in the column constants above; the rest are work arrays.

    1. every robot moves at its commanded velocity, bodies and pistons by
       ``F_ext dt / drag``; timers count down;
    2. robots are re-sorted by grid cell into the second buffers, and neighbour lists
       within ``cutoff`` are built;
    3. Jacobi sweeps project the configuration onto non-overlap with robots, static
       walls, bodies and pistons (mass-weighted shares for bodies and pistons): at least
       ``min_sweeps``, then until the largest overlap found is below ``tol`` (mm), at
       most ``max_sweeps``.  The first buffers serve as scratch space.

    Returns ``(sweeps, largest overlap seen by the last sweep, overflowed)``.
    """
    n = pos.shape[0]
    x0, y0, cs = gf[0], gf[1], gf[2]
    inv_cs = 1.0 / cs
    nx, ny, min_iter, max_iter = gi[0], gi[1], gi[2], gi[3]
    r, gamma_r, dt, tol, relax, cutoff = pp[0], pp[1], pp[2], pp[3], pp[4], pp[5]
    _predict(pos, udir, fcols[1], icols[2], dt, x0, y0, inv_cs, nx, ny, cell)
    for b in range(bodies.shape[0]):
        bodies[b, BCX] = 0.0
        bodies[b, BCY] = 0.0
        if not math.isinf(bodies[b, BDRAG]):
            bodies[b, BX] += bodies[b, BFX] * dt / bodies[b, BDRAG]
            bodies[b, BY] += bodies[b, BFY] * dt / bodies[b, BDRAG]
    _bodies_vs_static(bodies, seg, sdisc)
    for p in range(pistons.shape[0]):
        pistons[p, PC] = 0.0
        if not math.isinf(pistons[p, PDRAG]):
            x = pistons[p, PP] + pistons[p, PS] * pistons[p, PF] * dt / pistons[p, PDRAG]
            pistons[p, PP] = min(max(x, pistons[p, PLL]), pistons[p, PLH])
    _counting_sort(cell, nx * ny, cell_start, perm)
    _gather_all(pos, fcols, icols, udir, pos2, fcols2, icols2, udir2, perm)
    moved_prev = moved[0]
    moved_cur = moved[1]
    near = moved[2]
    _build_neighbours(pos2, cell_start, nx, ny, cutoff, nbr, nnb, near)
    overflow = False
    for i in range(n):
        if near[i]:
            overflow = True
            near[:] = 0
            break
    nb = bodies.shape[0]
    npis = pistons.shape[0]
    moved_b = np.zeros(nb, np.uint8)
    moved_p = np.zeros(npis, np.uint8)
    src = pos2
    dst = pos  # the old positions and headings are free scratch now
    worst = fcols[0]
    sweeps = 0
    seen = 0.0
    while sweeps < max_iter:
        _bodies_pass(src, cell_start, x0, y0, cs, nx, ny, r, gamma_r, dt, bodies, pistons)
        if overflow:
            _sweep_cells(
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
                bodies,
                pistons,
                moved_cur,
                worst,
            )
        else:
            _sweep_list(
                src,
                dst,
                nbr,
                nnb,
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
                bodies,
                pistons,
                moved_prev,
                moved_cur,
                near,
                sweeps == 0,
                worst,
            )
        seen = 0.0
        for i in range(n):  # max is order-independent: deterministic
            if worst[i] > seen:
                seen = worst[i]
        any_moved = False
        for b in range(nb):
            moved_b[b] = 1 if (bodies[b, BDX] != 0.0 or bodies[b, BDY] != 0.0) else 0
            bodies[b, BX] += bodies[b, BDX]
            bodies[b, BY] += bodies[b, BDY]
            any_moved = any_moved or moved_b[b] != 0
        _bodies_vs_static(bodies, seg, sdisc)
        for p in range(npis):
            moved_p[p] = 1 if pistons[p, PD] != 0.0 else 0
            pistons[p, PP] += pistons[p, PD]
            any_moved = any_moved or moved_p[p] != 0
        src, dst = dst, src
        moved_prev, moved_cur = moved_cur, moved_prev
        sweeps += 1
        if sweeps >= min_iter and seen < tol:
            break
        if any_moved:
            _near_moved(src, bodies, moved_b, pistons, moved_p, r, cs, near)
        elif sweeps == 1 or nb + npis > 0:
            near[:] = 0
    if sweeps % 2 == 1:
        _copy2(pos, pos2)  # the latest positions are in the scratch buffer
    return sweeps, seen, overflow


@njit(cache=True, parallel=True)
def max_overlap(pos, cell_start, x0, y0, cs, nx, ny, r, seg, sdisc, bodies, pistons):
    """Largest overlap (mm) of any robot with a robot, wall, body or piston.

    ``pos`` must be sorted by cell with ``cell_start`` built on it.
    """
    n = pos.shape[0]
    inv_cs = 1.0 / cs
    d_rr = 2.0 * r
    worst = np.zeros(n)
    for i in prange(n):
        px = pos[i, 0]
        py = pos[i, 1]
        cx, cy = _cell_xy(px, py, x0, y0, inv_cs, nx, ny)
        _, _, m = _walls_and_bodies(i, px, py, r, True, seg, sdisc, bodies, pistons)
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
