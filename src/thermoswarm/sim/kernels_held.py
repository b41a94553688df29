"""Kernels of the engine: the contact solve of a jammed step -- symmetric projected
Gauss-Seidel passes, over-relaxed, with each contact's push accumulated within the
step so that an overshoot can be taken back (see :mod:`thermoswarm.sim.kernels` and
``docs/engine_performance.md``, "Jammed swarms")."""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from thermoswarm.sim.kernels_grid import SLOP, build_lists
from thermoswarm.sim.kernels_sweep import _near_moved
from thermoswarm.sim.kernels_walls import (
    _applied_steps,
    _apply_body_steps,
    _bodies_pass,
    _gs_pair_step,
    _held_decay,
    _movables_applied,
    _seg_gap,
    _walls_and_bodies,
    _walls_held,
)


@njit(cache=True, parallel=True)
def _warm_start(src, dst, ref, nbr, nnb, lam, lamw, lamid, seg, r, keep, big2, flag):
    """Every robot takes the pushes its contacts held at the end of the last step
    (``lam`` along each listed pair's present normal, ``lamw`` off its held walls), the
    held pushes first scaled by ``keep`` (< 1: pushes that only cancel each other, which
    a jam can pile up without moving anything, decay instead of growing step by step;
    below ``HELD_MIN`` they are dropped; :func:`~thermoswarm.sim.kernels_walls._held_decay`,
    which the GPU engine shares): the starting guess of the projection (pushes no longer
    needed are taken back by the passes).  Writes ``dst``; ``flag[i]`` is set where robot
    i would move farther than ``sqrt(big2)``.  Returns the largest squared distance from
    ``ref``, the number of robots flagged, the number of pushes still held and the largest
    (mm)."""
    cap = nbr.shape[1]
    sx = src[:, 0]
    sy = src[:, 1]
    far = 0.0
    big = 0
    held = 0
    top = 0.0
    for i in prange(src.shape[0]):
        px = src[i, 0]
        py = src[i, 1]
        m = nnb[i] if nnb[i] <= cap else 0
        mx, my, h, t = _held_decay(i, px, py, sx, sy, nbr, lam, m, lamw, lamid, seg, r, keep)
        top = max(top, t)
        x = px + mx
        y = py + my
        dst[i, 0] = x
        dst[i, 1] = y
        ex = x - ref[i, 0]
        ey = y - ref[i, 1]
        far = max(far, ex * ex + ey * ey)
        f = mx * mx + my * my > big2
        flag[i] = f
        big += f
        held += h
    return far, big, held, top


@njit(cache=True)
def _drop_pushes(flag, nbr, nnb, lam, lamw):
    """The flagged robots' held pushes (both copies of each pair's) are dropped."""
    cap = nbr.shape[1]
    for i in range(flag.shape[0]):
        if flag[i]:
            lamw[0, i] = 0.0
            lamw[1, i] = 0.0
            if nnb[i] <= cap:
                for kk in range(nnb[i]):
                    if lam[i, kk] != 0.0:
                        lam[i, kk] = 0.0
                        j = nbr[i, kk]
                        sj = _slot_of(nbr, nnb, j, i)
                        if sj >= 0:
                            lam[j, sj] = 0.0


@njit(cache=True, inline="always")
def _slot_of(nbr, nnb, j, i):
    """The slot of ``i`` in ``j``'s list (-1 if absent)."""
    for kk in range(nnb[j]):
        if nbr[j, kk] == i:
            return kk
    return -1


@njit(cache=True)
def _gs_pass(
    pos, other, ref, nbr, nnb, lam, lamw, lamid, cell, cell_flag, num, omega, wall_omega, seg,
    sdisc, bodies, pistons, applied, active, count, everyone, backward, mark, out,
):  # fmt: skip
    """One projected Gauss-Seidel pass, serial and in place, over-relaxed by ``omega``.

    For each robot of ``active[:count]`` (every robot when ``everyone``), in that order
    (reversed when ``backward``): its walls (:func:`_walls_held`, over-relaxed by
    ``wall_omega``), static discs, bodies and pistons (:func:`_movables_applied`, their
    corrections added to ``applied`` as they are made), then each listed pair, both
    robots moving at once by ``omega`` x half the overlap each or, apart with a push
    held (``lam``, accumulated within the step), taking back up to ``omega`` x half the
    gap: projected successive over-relaxation of the contact impulses, which can undo
    an overshoot.  Both copies of the held push are updated.  The order is fixed: the
    result does not depend on the number of threads.  Each move is mirrored into
    ``other``.  A robot whose list overflowed pushes only (its pairs are not held).

    Writes into ``out`` the robots the next pass must visit -- every robot that moved and
    every robot on its list -- and returns ``(how many (-1: everyone), largest squared
    distance from ref of any robot that moved)``.
    """
    cap = nbr.shape[1]
    r = num.radius
    d_rr = 2.0 * r
    c2 = (d_rr - SLOP) * (d_rr - SLOP)
    half = 0.5 * omega
    movables = bodies.shape[0] + pistons.shape[0] > 0
    far = 0.0
    k = 0
    for qq in range(count):
        q = count - 1 - qq if backward else qq
        i = np.int64(q) if everyone else np.int64(active[q])
        # --- stage: walls, static discs, bodies and pistons of robot i
        near = cell_flag[cell[i]] != 0
        mx = 0.0
        my = 0.0
        if near or lamw[0, i] != 0.0 or lamw[1, i] != 0.0:
            mx, my, _, _ = _walls_held(pos[i, 0], pos[i, 1], r, i, lamw, lamid, wall_omega, seg)
        if near or movables:
            ax, ay = _movables_applied(
                pos[i, 0] + mx, pos[i, 1] + my, r, near, sdisc, bodies, pistons, applied
            )
            mx += ax
            my += ay
        moved = mx != 0.0 or my != 0.0
        pos[i, 0] += mx
        pos[i, 1] += my
        # --- stage: each listed pair: push apart, or take back a held push
        m = nnb[i]
        for kk in range(min(m, cap)):
            j = nbr[i, kk]
            dx = pos[i, 0] - pos[j, 0]
            dy = pos[i, 1] - pos[j, 1]
            d2 = dx * dx + dy * dy
            L = np.float64(lam[i, kk]) if m <= cap else 0.0
            step, ux, uy = _gs_pair_step(dx, dy, d2, L, c2, d_rr, half, omega, i, j)
            if step == 0.0:
                continue
            held = m <= cap and nnb[j] <= cap
            if not held and step < 0.0:
                continue
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
        # --- stage: mirror robot i into other; mark it if it moved
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
    # --- stage: the next pass's robots: the movers and everyone on their lists
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
    if not full:
        out[:k].sort()  # row order (cells): the next pass sweeps across the swarm
    return (-1 if full else k), far


@njit(cache=True, parallel=True)
def _measure(
    pos, nbr, nnb, lam, lamw, lamid, cell, cell_start, perm, cell_flag, grid, num, seg, sdisc,
    bodies, pistons, active, count, everyone,
):  # fmt: skip
    """Read-only: the largest overlap (exact: the lists are valid) and the largest held
    push no longer needed (``min(push, gap)``, mm) of the robots ``active[:count]``
    (every robot when ``everyone``), for the Gauss-Seidel solve (:func:`_gs_solve`)."""
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
def _gs_solve(
    src, dst, ref, lam, lamw, lamid, grid, num, omega, wall_omega, cell, cell_start, perm,
    nbr, nnb, overflows, visits, mark, near, cell_flag, seg, sdisc, bodies, pistons, new_row,
    sweeps, count, everyone, blind,
):  # fmt: skip
    """The projection by symmetric Gauss-Seidel: measure (:func:`_measure`) the robots
    ``visits[0][:count]`` (every robot when ``everyone``), and while the largest overlap
    or unneeded push is above its tolerance, a forward and a backward over-relaxed pass
    (:func:`_gs_pass`) over the robots whose surroundings changed, bodies and pistons
    taking their steps after each.  The first ``blind`` rounds (forward + backward) go
    without a measure before them: a warm-started step of a jam needs a few rounds
    anyway, and a measure that cannot end the step is a sweep paid for nothing.  The
    step still ends only on a measure, so the overlap returned is that of the final
    positions.  Positions stay in ``src`` (mirrored into ``dst``); ``sweeps`` were made
    before.  Returns ``(sweeps, overlap, list builds)``; a sweep is a measure or a
    pass."""
    n = src.shape[0]
    r = num.radius
    nb = bodies.shape[0]
    npis = pistons.shape[0]
    moved_b = np.zeros(nb, np.uint8)
    moved_p = np.zeros(npis, np.uint8)
    contact = np.zeros((nb + npis, 2))
    applied = np.zeros((nb + npis, 2))
    visit = visits[0]
    visit_next = visits[1]
    builds = 0
    rounds = 0
    while True:
        # (the last rounds before the sweep limit are measured: the step ends on a measure)
        if rounds >= blind or sweeps >= num.max_sweeps - 2 * blind - 1:
            overlap, slack = _measure(
                src, nbr, nnb, lam, lamw, lamid, cell, cell_start, perm, cell_flag, grid,
                num, seg, sdisc, bodies, pistons, visit, count, everyone,
            )  # fmt: skip
            sweeps += 1
            done = overlap < num.tol and slack < num.slack_tol
            if (sweeps >= num.min_sweeps and done) or sweeps >= num.max_sweeps:
                return sweeps, overlap, builds
        rounds += 1
        for backward in (False, True):
            _bodies_pass(src, cell_start, perm, grid, r, num.drag, num.dt, bodies, pistons,
                         contact)  # fmt: skip
            applied[:] = 0.0
            k, far = _gs_pass(
                src, dst, ref, nbr, nnb, lam, lamw, lamid, cell, cell_flag, num, omega,
                wall_omega, seg, sdisc, bodies, pistons, applied, visit, count, everyone,
                backward, mark, visit_next,
            )  # fmt: skip
            sweeps += 1
            _applied_steps(bodies, pistons, applied, num.drag, num.dt, contact)
            any_moved = _apply_body_steps(bodies, pistons, contact, moved_b, moved_p, seg,
                                          sdisc)  # fmt: skip
            if not (far <= num.half_skin * num.half_skin):
                overflows[0] = _rebuild(src, ref, grid, num, cell, cell_start, perm, nbr, nnb,
                                        lam, new_row, False, True)  # fmt: skip
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
            if sweeps >= num.max_sweeps - 1:
                break


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
def _rebuild(at, ref, grid, num, cell, cell_start, perm, nbr, nnb, lam, new_row, renumber,
             carry):  # fmt: skip
    """Rebuild the lists at ``at`` (recorded in ``ref``), carrying the held pushes over
    when ``carry`` (rows renumbered by ``new_row`` when ``renumber``).  Returns the
    overflow count."""
    si, sj, sl = _stash_held(nbr, nnb, lam, carry)
    overflows = build_lists(at, ref, grid, num.cutoff, cell, cell_start, perm, nbr, nnb)
    if carry:
        _restore_held(si, sj, sl, new_row, renumber, nbr, nnb, lam)
    return overflows


@njit(cache=True)
def _inverse(perm, out):
    for k in range(perm.shape[0]):
        out[perm[k]] = k
