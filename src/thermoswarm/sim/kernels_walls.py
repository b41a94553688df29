"""Kernels of the engine: static walls, movable bodies and force-driven walls (pistons):
their geometry, their corrections of a robot, and the bodies' own steps (see
:mod:`thermoswarm.sim.kernels`)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from thermoswarm.sim.kernels_grid import (
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
    PISTON_AXIS,
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
    SLOP,
    _cell_range,
)


# ------------------------------------------------ contacts shared with the GPU engine
# No positions array of the CPU engine's layout (scalars, or x and y apart): the CPU
# kernels call them, and the GPU engine (:mod:`thermoswarm.sim.gpu.kernels`) compiles the
# same source for CUDA, so the two engines' contact rules cannot drift apart.
@njit(cache=True, inline="always")
def _pair_core(px, py, qx, qy, i, j, c2, d_rr, half, mx, my, w):
    """Robot ``i`` at ``(px, py)`` against robot ``j`` at ``(qx, qy)``: if they overlap
    (squared distance below ``c2``), ``i``'s share ``half`` of the separation added to
    ``(mx, my)`` and the overlap (``d_rr`` minus the distance, mm) to the running maximum
    ``w``; returns the three."""
    dx = px - qx
    dy = py - qy
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
def _gs_pair_step(dx, dy, d2, L, c2, d_rr, half, omega, i, j):
    """One pair of a Gauss-Seidel pass (:func:`~thermoswarm.sim.kernels_held._gs_pass`):
    robots ``i`` and ``j`` with ``(dx, dy)`` from ``j`` to ``i``, squared distance
    ``d2`` and push ``L`` (mm) held between them.  Overlapping, each moves ``half`` x
    the overlap; apart with a push held, each takes back up to ``omega`` x half the gap.
    Returns ``(step, ux, uy)``: the push added (mm, < 0: taken back) and ``i``'s
    displacement (``j`` moves by minus it); ``step`` is 0 when nothing moves."""
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
            step = -min(L, omega * g)
    if step == 0.0:
        return 0.0, 0.0, 0.0
    return step, step * dx / d, step * dy / d


#: Held pushes decay by ``keep`` a step; below this (mm) they are dropped: a jam ends.
HELD_MIN = 1e-4


@njit(cache=True)  # not inlined: parallel max reductions call it (see _walls_and_bodies)
def _held_decay(i, px, py, qx, qy, nbr, lam, m, lamw, lamid, seg, r, keep):
    """Both engines' warm start of robot ``i`` at ``(px, py)``: its held pushes -- the ``m``
    pairs ``lam[i, :m]`` with robots ``nbr[i, :m]`` at ``(qx, qy)``, the walls ``lamw[:, i]``
    (segments ``lamid[:, i]``) -- scaled by ``keep``, dropped below :data:`HELD_MIN`, in
    place.  Returns ``(mx, my, held, top)``: ``i``'s move along their present normals (mm),
    the pushes still held and the largest (mm)."""
    mx, my, h, top = 0.0, 0.0, 0, 0.0
    for kk in range(m):
        L = np.float32(keep * lam[i, kk])
        L = np.float32(0.0) if L < HELD_MIN else L
        lam[i, kk] = L
        if L != 0.0:
            h += 1
            top = max(top, np.float64(L))
            j = nbr[i, kk]
            dx, dy = px - qx[j], py - qy[j]
            d = math.sqrt(dx * dx + dy * dy)
            if d > 1e-12:
                mx += L * dx / d
                my += L * dy / d
    for slot in range(2):
        lw = np.float32(keep * lamw[slot, i])
        lw = np.float32(0.0) if lw < HELD_MIN else lw
        lamw[slot, i] = lw
        if lw != 0.0:
            h += 1
            top = max(top, np.float64(lw))
            s = lamid[slot, i]
            _, nxs, nys = _seg_gap(px, py, seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3], r)
            mx += lw * nxs
            my += lw * nys
    return mx, my, h, top


@njit(cache=True, inline="always")
def _body_contact(px, py, bx, by, R):
    """A robot at ``(px, py)`` against a body at ``(bx, by)`` (``R``: the sum of the
    radii, mm): ``(1, ox, oy)`` with the overlap vector pushing the body away from the
    robot when they touch, else ``(0, 0, 0)``."""
    dx = px - bx
    dy = py - by
    d2 = dx * dx + dy * dy
    if d2 < (R - SLOP) * (R - SLOP):
        d = math.sqrt(d2)
        if d < 1e-12:
            return 0, 0.0, 0.0
        ov = R - d
        return 1, -ov * dx / d, -ov * dy / d
    return 0, 0.0, 0.0


@njit(cache=True, inline="always")
def _piston_contact(px, py, a, side, ppos, lo, hi, r):
    """A robot of radius ``r`` at ``(px, py)`` against a piston (axis ``a``, ``side``,
    position ``ppos``, extent ``lo..hi``): its overlap (mm) when they touch, else 0."""
    q = py if a == 0 else px
    if q < lo or q > hi:
        return 0.0
    gap = side * ((px if a == 0 else py) - ppos)
    if gap < r - SLOP:
        return r - gap
    return 0.0


@njit(cache=True, inline="always")
def _contact_solve(k, sx, sy, drag, gamma_r):
    """The step of a body or piston of ``drag`` touched by ``k`` >= 1 robots of drag
    ``gamma_r`` whose overlaps sum to ``(sx, sy)`` (mm), and the robots' share of each
    overlap: ``(step x, step y, share)`` (see :func:`_bodies_pass`)."""
    if math.isinf(drag):
        return 0.0, 0.0, 1.0
    den = k * gamma_r + drag
    return gamma_r * sx / den, gamma_r * sy / den, drag / den


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


@njit(cache=True)
def _walls_held(px, py, r, i, lw, lid, pull, seg):
    """Static segments with held pushes: every overlap is pushed out, over-relaxed by
    ``pull`` (1: in full, as in :func:`_walls_and_bodies`), and, for up to two segments
    per robot, accumulated in ``lw[:, i]`` (mm) with the segment's index in
    ``lid[:, i]``; a held segment no longer touched takes back up to ``pull`` x the gap
    of its push (a wall pushes, never pulls: a held push it no longer needs is undone).
    Writes only column ``i``.

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
            mx -= pull * g * nxs
            my -= pull * g * nys
            if -g > w:
                w = -g
            if slot < 0:  # a free slot (nothing held) takes this segment
                slot = 0 if lw[0, i] == 0.0 else (1 if lw[1, i] == 0.0 else -1)
                if slot >= 0:
                    lid[slot, i] = s
            if slot >= 0:
                lw[slot, i] = lw[slot, i] - pull * g
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
def _body_finish(bodies, b, k, sx, sy, gamma_r, dt, contact):
    """Body ``b``'s step and the robots' share from its ``k`` contacts, whose overlaps
    sum to ``(sx, sy)``; the robots' force on it in this sweep into ``contact[b]``."""
    contact[b, 0] = 0.0
    contact[b, 1] = 0.0
    if k == 0:
        bodies[b, BODY_STEP_X] = 0.0
        bodies[b, BODY_STEP_Y] = 0.0
        bodies[b, BODY_SHARE] = 1.0
        return
    stx, sty, share = _contact_solve(k, sx, sy, bodies[b, BODY_DRAG], gamma_r)
    bodies[b, BODY_STEP_X] = stx
    bodies[b, BODY_STEP_Y] = sty
    bodies[b, BODY_SHARE] = share
    contact[b, 0] = gamma_r * share * sx / dt
    contact[b, 1] = gamma_r * share * sy / dt


@njit(cache=True, inline="always")
def _piston_finish(pistons, p, nb, k, s, gamma_r, dt, contact):
    """Piston ``p``'s step and the robots' share from its ``k`` contacts, whose overlaps
    sum to ``s``; the robots' force on it in this sweep into ``contact[nb + p, 0]``."""
    contact[nb + p, 0] = 0.0
    if k == 0:
        pistons[p, PISTON_STEP] = 0.0
        pistons[p, PISTON_SHARE] = 1.0
        return
    side = pistons[p, PISTON_SIDE]
    st, _, share = _contact_solve(k, s, 0.0, pistons[p, PISTON_DRAG], gamma_r)
    pistons[p, PISTON_STEP] = 0.0 if st == 0.0 else -side * st  # away from the robots
    pistons[p, PISTON_SHARE] = share
    contact[nb + p, 0] = -side * gamma_r * share * s / dt


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
                    hit, ox, oy = _body_contact(pos[i, 0], pos[i, 1], bx, by, R)
                    if hit:
                        k += 1
                        sx += ox
                        sy += oy
        _body_finish(bodies, b, k, sx, sy, gamma_r, dt, contact)
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
        k = 0
        s = 0.0
        for u in range(ca, cb + 1):
            for w in range(oa, ob + 1):
                c = w * nx + u if a == 0 else u * nx + w
                for kk in range(cell_start[c], cell_start[c + 1]):
                    i = perm[kk]
                    ov = _piston_contact(pos[i, 0], pos[i, 1], a, side, ppos, lo, hi, r)
                    if ov > 0.0:
                        k += 1
                        s += ov
        _piston_finish(pistons, p, nb, k, s, gamma_r, dt, contact)


@njit(cache=True)
def _movables_applied(px, py, r, near_static, sdisc, bodies, pistons, applied):
    """Correction (mx, my) of a robot against static discs (``near_static``), bodies and
    pistons, as :func:`_walls_and_bodies` (static segments excepted), each body's and
    piston's part added to ``applied`` as it is applied (row b: body b's (x, y); row
    B + p, column 0: piston p's, along its axis), so that the contact force of a
    Gauss-Seidel pass is that of the corrections the robots actually received."""
    mx = 0.0
    my = 0.0
    if near_static:
        for s in range(sdisc.shape[0]):
            dx = px - sdisc[s, 0]
            dy = py - sdisc[s, 1]
            R = sdisc[s, 2] + r
            d2 = dx * dx + dy * dy
            if d2 < (R - SLOP) * (R - SLOP):
                d = math.sqrt(d2)
                if d > 1e-12:
                    mx += (R - d) * dx / d
                    my += (R - d) * dy / d
    nb = bodies.shape[0]
    for b in range(nb):
        dx = px + mx - bodies[b, BODY_X]
        dy = py + my - bodies[b, BODY_Y]
        R = bodies[b, BODY_RADIUS] + r
        d2 = dx * dx + dy * dy
        if d2 < (R - SLOP) * (R - SLOP):
            d = math.sqrt(d2)
            if d > 1e-12:
                f = bodies[b, BODY_SHARE] * (R - d) / d
                mx += f * dx
                my += f * dy
                applied[b, 0] += f * dx
                applied[b, 1] += f * dy
    for p in range(pistons.shape[0]):
        a = int(pistons[p, PISTON_AXIS])
        q = py + my if a == 0 else px + mx
        if q < pistons[p, PISTON_LO] or q > pistons[p, PISTON_HI]:
            continue
        v = px + mx if a == 0 else py + my
        gap = pistons[p, PISTON_SIDE] * (v - pistons[p, PISTON_POSITION])
        if gap < r - SLOP:
            corr = pistons[p, PISTON_SHARE] * (r - gap) * pistons[p, PISTON_SIDE]
            if a == 0:
                mx += corr
            else:
                my += corr
            applied[nb + p, 0] += corr
    return mx, my


@njit(cache=True)
def _applied_steps(bodies, pistons, applied, gamma_r, dt, contact):
    """After a Gauss-Seidel pass: each body's and piston's contact force from the
    corrections its robots received in the pass (``applied``, mm; force ``-g_r x
    correction / dt``) into ``contact``, and its step from that force (``force x dt /
    drag``: the step and the force agree exactly, as in :func:`_bodies_pass`)."""
    nb = bodies.shape[0]
    for b in range(nb):
        drag = bodies[b, BODY_DRAG]
        for c in range(2):
            contact[b, c] = -gamma_r * applied[b, c] / dt
        fin = not math.isinf(drag)
        bodies[b, BODY_STEP_X] = contact[b, 0] * dt / drag if fin else 0.0
        bodies[b, BODY_STEP_Y] = contact[b, 1] * dt / drag if fin else 0.0
    for p in range(pistons.shape[0]):
        drag = pistons[p, PISTON_DRAG]
        contact[nb + p, 0] = -gamma_r * applied[nb + p, 0] / dt
        fin = not math.isinf(drag)
        pistons[p, PISTON_STEP] = contact[nb + p, 0] * dt / drag if fin else 0.0


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
