"""Kernels of the engine: the experimental warm start -- held contact pushes carried from
step to step and solved by projected Gauss-Seidel (``EngineParams.warm_start``; see
:mod:`thermoswarm.sim.kernels` and ``docs/engine_performance.md``)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from thermoswarm.sim.kernels_grid import SLOP, build_lists
from thermoswarm.sim.kernels_walls import (
    _apply_body_steps,
    _bodies_pass,
    _near_moved,
    _seg_gap,
    _walls_and_bodies,
    _walls_held,
)


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
