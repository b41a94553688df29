"""numba-cuda kernels of the GPU engine (the same kernels run in numba-cuda's simulator).

The physics is the CPU engine's (:mod:`thermoswarm.sim.engine`): commanded motion,
then Jacobi sweeps of mass-weighted position projection against robots, static walls
and discs, movable bodies and force-driven walls, and, in a jam, warm-started
Gauss-Seidel passes (:mod:`thermoswarm.sim.gpu.kernels_gs`).  Every contact rule is
the CPU engine's own function, compiled a second time for CUDA from the same Python
source: robot pairs (``kernels_walls._pair_core``, ``_gs_pair_step``), walls, discs,
bodies and pistons (``_walls_and_bodies``, ``_walls_held``, ``_seg_push``, ``_seg_gap``),
the warm start's held pushes (``_held_decay``), the bodies' contacts, steps and moves
(``_body_contact``, ``_piston_contact``, ``_body_finish``, ``_piston_finish``,
``_apply_body_steps``, ``_move_bodies``).  What differs is the data layout, the neighbour
search and the launch structure, chosen for a GPU:

- **struct of arrays, float32**: ``x``, ``y`` (two buffers each: a Jacobi sweep reads
  one and writes the other), ``heading``, ``speed``, ``timer``, ``ids``, ``group``;
  positions relative to the world's centre, which halves their rounding step;
- **cell-sorted order** (:mod:`thermoswarm.sim.gpu.kernels_grid`): robots are re-ordered
  by grid cell whenever the grid is rebuilt; ``cell_start[c]:cell_start[c + 1]`` are
  the robots of cell ``c``, so a row of cells is one contiguous range;
- **a grid rebuilt only when needed** (Verlet skin): each robot keeps the position it
  had at the last build (``xr``, ``yr``); ``D`` is the largest distance any robot has
  moved since.  Two robots in contact now were less than ``2 r + 2 D`` apart at the
  build, so scanning ``ceil((2 r + 2 D) / cs)`` rings of cells around a robot's build
  cell finds every contact, whatever ``D`` is; the host rebuilds once one ring no longer
  suffices;
- **two launches a step**: :func:`begin_step` (the device policy's draws and the
  commanded motion) and :func:`jacobi` -- one *cooperative* kernel that makes every
  sweep of the step, separated by grid-wide barriers (``cuda.cg.this_grid().sync()``),
  with the convergence test, the bodies' steps and the sweep count done on the device;
  then one read back of the control block.  A rebuild is one more cooperative kernel,
  a jam one more (the Gauss-Seidel passes).

Every per-robot loop is grid-stride, so any launch shape covers all robots (the
simulator runs one block of two threads, a GPU as many blocks as fit at once, which a
cooperative launch requires).  Sums over robots (forces on bodies and walls) and the
largest overlap use atomics: on a GPU the order of the float additions onto bodies and
walls varies from run to run.
"""

from __future__ import annotations

import math
import types

import numpy as np
from numba import cuda

from thermoswarm.sim import kernels as K
from thermoswarm.sim import kernels_walls as W
from thermoswarm.sim.gpu.runtime import simulated

# packed body / piston columns: the CPU engine's layout (SwarmState.bodies / pistons)
BX, BY, BR = K.BX, K.BY, K.BR
PA, PP, PS, PLO, PHI = K.PA, K.PP, K.PS, K.PLO, K.PHI

# the control block (one float32 array: read back in one copy; integers below 2**24)
SEEN = 0  # largest overlap found by the current sweep (mm)
D_IN = 1  # displacement bound used by the sweeps (mm)
D_OUT = 2  # largest displacement written by the current sweep (mm)
LAST_SEEN = 3  # the overlap the step ended with (mm)
OVERLAP = 4  # max_overlap's result (mm)
SWEEPS = 5  # sweeps (and passes, and measures) made in this step
STATUS = 6  # RUNNING, DONE, JAM, REBUILD, COLD
CUR = 7  # the position buffer (0, 1) that holds the result
ROUNDS = 8  # Gauss-Seidel rounds made in this step
VMAX = 9  # largest commanded displacement of the step (mm)
HELD = 10  # pushes held after the warm start (count, float)
TOP = 11  # largest push held after the warm start (mm)
FLAGGED = 12  # robots the warm start would move too far
SLACK = 13  # largest held push no longer needed (mm)
STEP_V = 14  # VMAX of this step, taken at the start of its projection (mm)
N_CTRL = 15

RUNNING, DONE, JAM, REBUILD, COLD = 0.0, 1.0, 2.0, 3.0, 4.0

# geometry parameters (geo array, float32)
G_X0 = 0  # grid origin (relative coordinates, mm)
G_Y0 = 1
G_CS = 2  # cell size (mm)
G_R = 3  # robot radius (mm)
G_EPS = 4  # relative slack on the ring count (float rounding)
G_C2 = 5  # squared contact distance, (2 r - SLOP)^2 (mm^2)
N_GEO = 6

MASK32 = 0xFFFFFFFF


def _twin(cpu_fn, scalar=False, **callees):
    """The CPU engine's function ``cpu_fn`` compiled for CUDA from the same source, the
    CPU functions it calls with arrays replaced by their CUDA twins ``callees`` (by
    name; numba-cuda's simulator cannot pass its arrays to a CPU function).  In the
    simulator a ``scalar`` function (numbers in, numbers out) is the CPU function itself,
    compiled: the simulator's own calls cost tens of microseconds each."""
    if scalar and simulated():
        return cpu_fn
    f = cpu_fn.py_func
    if callees:
        f = types.FunctionType(f.__code__, {**f.__globals__, **callees}, f.__name__,
                               f.__defaults__, f.__closure__)  # fmt: skip
    return cuda.jit(device=True)(f)


# The CPU engine's contact functions, compiled for CUDA from the same source.
bodies_vs_static = _twin(W._bodies_vs_static)
pair_core = _twin(W._pair_core, scalar=True)
seg_gap = _twin(W._seg_gap, scalar=True)
walls_and_bodies = _twin(W._walls_and_bodies)
walls_held = _twin(W._walls_held)
body_contact = _twin(W._body_contact, scalar=True)
piston_contact = _twin(W._piston_contact, scalar=True)
body_finish = _twin(W._body_finish)
piston_finish = _twin(W._piston_finish)
apply_body_steps = _twin(W._apply_body_steps, _bodies_vs_static=bodies_vs_static)
move_bodies = _twin(W._move_bodies, _bodies_vs_static=bodies_vs_static)


@cuda.jit(device=True)
def cell_of(x, y, x0, y0, cs, nx, ny):
    """Grid cell (cx, cy) of a point, clamped to the grid."""
    cx = int(math.floor((x - x0) / cs))
    cy = int(math.floor((y - y0) / cs))
    return min(max(cx, 0), nx - 1), min(max(cy, 0), ny - 1)


@cuda.jit(device=True)
def rings_for(d_bound, geo, nmax):
    """Cell rings to scan so that no pair within 2 r is missed (see the module doc)."""
    reach = (2.0 * geo[G_R] + 2.0 * d_bound) * (1.0 + geo[G_EPS])
    k = int(math.ceil(reach / geo[G_CS]))
    return min(max(k, 1), nmax)


# ------------------------------------------------------------------------ random numbers
@cuda.jit(device=True)
def mix32(h):
    """A 32-bit integer hash (xor-shift-multiply; both multipliers below 2**31, so that
    every product fits a signed 64-bit integer on the device and in Python)."""
    h = int(h) & MASK32
    h ^= h >> 16
    h = (h * 0x21F0AAAD) & MASK32
    h ^= h >> 15
    h = (h * 0x735A2D97) & MASK32
    h ^= h >> 15
    return h


@cuda.jit(device=True)
def uniform(stream, k):
    """The ``k``-th uniform number in (0, 1) of a counter-based stream (24 bits)."""
    h = mix32(stream + k * 0x61C88647)
    return ((h >> 8) + 0.5) * (1.0 / 16777216.0)


# ------------------------------------------------------------------------ one step
@cuda.jit
def begin_step(x, y, xr, yr, heading, speed, timer, ids, draw, key, zero, half_width, kT,
               half_normal, tau_steps, everyone, dt, ctrl):  # fmt: skip
    """Per robot: the device policy's decision if its control period is over (``draw``:
    the policy runs on the device; ``everyone``: every robot decides), then the
    commanded motion for one step; timers count down; the displacement since the build
    and the largest commanded displacement go to the control block.

    Decision: a uniform heading in ``zero +- half_width`` and a speed at temperature
    ``kT``, Rayleigh (``v = sqrt(2 E)``, ``E ~ Exponential(kT)``) or half-normal
    (``|N(0, kT)|``, Box-Muller), from a counter-based hash stream keyed by the step's
    ``key`` (drawn from the run's NumPy generator) and the robot's id.
    """
    for i in range(cuda.grid(1), x.shape[0], cuda.gridsize(1)):
        if draw != 0 and (everyone != 0 or timer[i] <= 0):
            stream = mix32(mix32(key) ^ int(ids[i]))
            h = zero + half_width * (2.0 * uniform(stream, 1) - 1.0)
            if half_normal != 0:
                z = math.sqrt(-2.0 * math.log(uniform(stream, 2)))
                v = abs(z * math.cos(2.0 * math.pi * uniform(stream, 3))) * math.sqrt(kT)
            else:
                v = math.sqrt(-2.0 * kT * math.log(uniform(stream, 2)))
            heading[i] = h
            speed[i] = v
            timer[i] = tau_steps
        if dt == 0.0:  # the first decision of init: no motion
            continue
        s = speed[i] * dt
        h = heading[i]
        px = x[i] + s * math.cos(h)
        py = y[i] + s * math.sin(h)
        x[i] = px
        y[i] = py
        timer[i] = timer[i] - 1
        d = math.sqrt((px - xr[i]) ** 2 + (py - yr[i]) ** 2)
        if d > ctrl[D_OUT]:  # read first: few threads reach the atomic
            cuda.atomic.max(ctrl, D_OUT, np.float32(d))
        if s > ctrl[VMAX]:
            cuda.atomic.max(ctrl, VMAX, np.float32(s))


@cuda.jit(device=True)
def robot_contacts(i, px, py, sx, sy, xr, yr, cell_start, nx, ny, geo, k, half, mx, my, w):
    """Robot ``i`` at ``(px, py)`` against every robot of ``(sx, sy)`` in the ``k``
    rings of cells around its build cell (:func:`pair_core`, the CPU engine's rule):
    its share ``half`` of each overlap added to ``(mx, my)``, the largest overlap to
    ``w``; returns the three."""
    d_rr = geo[G_R] + geo[G_R]
    c2 = geo[G_C2]
    bx, by = cell_of(xr[i], yr[i], geo[G_X0], geo[G_Y0], geo[G_CS], nx, ny)
    xa = max(bx - k, 0)
    xb = min(bx + k, nx - 1)
    for cy in range(max(by - k, 0), min(by + k, ny - 1) + 1):
        for j in range(cell_start[cy * nx + xa], cell_start[cy * nx + xb + 1]):
            if j != i:
                mx, my, w = pair_core(px, py, sx[j], sy[j], i, j, c2, d_rr, half, mx, my, w)
    return mx, my, w


@cuda.jit(device=True)
def body_sums(tid, nth, x, y, r, bodies, pistons, acc):
    """Per robot: its contacts with bodies and pistons added to their sums (count,
    summed overlap vector; row b: body b, row B + p: piston p)."""
    nb = bodies.shape[0]
    for i in range(tid, x.shape[0], nth):
        px = x[i]
        py = y[i]
        for b in range(nb):
            hit, ox, oy = body_contact(px, py, bodies[b, BX], bodies[b, BY], bodies[b, BR] + r)
            if hit:
                cuda.atomic.add(acc, (b, 0), 1.0)
                cuda.atomic.add(acc, (b, 1), ox)
                cuda.atomic.add(acc, (b, 2), oy)
        for p in range(pistons.shape[0]):
            ov = piston_contact(px, py, int(pistons[p, PA]), pistons[p, PS], pistons[p, PP],
                                pistons[p, PLO], pistons[p, PHI], r)  # fmt: skip
            if ov > 0.0:
                cuda.atomic.add(acc, (nb + p, 0), 1.0)
                cuda.atomic.add(acc, (nb + p, 1), ov)


@cuda.jit(device=True)
def solve_bodies(bodies, pistons, acc, gamma_r, dt, contact):
    """One thread: each body's and piston's step and the robots' share from the sums
    (the CPU engine's ``_body_finish`` / ``_piston_finish``); the sums are cleared."""
    nb = bodies.shape[0]
    for b in range(nb):
        body_finish(bodies, b, acc[b, 0], acc[b, 1], acc[b, 2], gamma_r, dt, contact)
        acc[b, 0] = 0.0
        acc[b, 1] = 0.0
        acc[b, 2] = 0.0
    for p in range(pistons.shape[0]):
        piston_finish(pistons, p, nb, acc[nb + p, 0], acc[nb + p, 1], gamma_r, dt, contact)
        acc[nb + p, 0] = 0.0
        acc[nb + p, 1] = 0.0


@cuda.jit(device=True)
def sweep_robots(tid, nth, sx, sy, dx_, dy_, xr, yr, cell_start, cell_flag, nx, ny, geo,
                 half, seg, sdisc, bodies, pistons, ctrl):  # fmt: skip
    """One Jacobi sweep over the robots: each moves by its share of every overlap it
    has (read from ``(sx, sy)``, written to ``(dx_, dy_)``); the largest overlap and
    displacement go to the control block."""
    k = rings_for(ctrl[D_IN], geo, max(nx, ny))
    r = geo[G_R]
    movables = bodies.shape[0] + pistons.shape[0] > 0
    for i in range(tid, sx.shape[0], nth):
        px = sx[i]
        py = sy[i]
        ccx, ccy = cell_of(px, py, geo[G_X0], geo[G_Y0], geo[G_CS], nx, ny)
        near = cell_flag[ccy * nx + ccx] != 0
        mx = 0.0
        my = 0.0
        w = 0.0
        if near or movables:  # most robots are far from any wall
            mx, my, w = walls_and_bodies(px, py, r, near, seg, sdisc, bodies, pistons)
        mx, my, w = robot_contacts(i, px, py, sx, sy, xr, yr, cell_start, nx, ny, geo, k,
                                   half, mx, my, w)  # fmt: skip
        qx = px + mx
        qy = py + my
        dx_[i] = qx
        dy_[i] = qy
        if w > ctrl[SEEN]:
            cuda.atomic.max(ctrl, SEEN, np.float32(w))
        dd = math.sqrt((qx - xr[i]) ** 2 + (qy - yr[i]) ** 2)
        if dd > ctrl[D_OUT]:
            cuda.atomic.max(ctrl, D_OUT, np.float32(dd))


@cuda.jit(device=True)
def start_solve(bodies, pistons, seg, sdisc, dt, ctrl):
    """One thread, first thing in a step's projection: bodies and pistons move under
    their external force (the CPU engine's ``_move_bodies``); counters reset."""
    ctrl[SWEEPS] = 0.0
    ctrl[ROUNDS] = 0.0
    ctrl[SEEN] = 0.0
    ctrl[STATUS] = RUNNING
    ctrl[D_IN] = max(ctrl[D_IN], ctrl[D_OUT])
    ctrl[STEP_V] = ctrl[VMAX]
    ctrl[VMAX] = 0.0
    move_bodies(bodies, pistons, seg, sdisc, dt)


@cuda.jit
def jacobi(x0, y0, x1, y1, xr, yr, cell_start, cell_flag, nx, ny, geo, half, seg, sdisc,
           bodies, pistons, acc, contact, moved, gamma_r, dt, min_sweeps, max_sweeps,
           gs_after, tol, start, ctrl):  # fmt: skip
    """The step's Jacobi sweeps, all in one cooperative launch (grid-wide barriers
    between them), as the CPU engine's ``_jacobi``: each sweep measures the exact
    largest overlap of its input and corrects it; the step ends on the first sweep that
    measures less than ``tol`` (after ``min_sweeps``), or at ``max_sweeps`` -- the
    measured configuration is the result (``ctrl[CUR]``) -- or, after ``gs_after``
    applied sweeps, hands over to the Gauss-Seidel passes (``ctrl[STATUS] = JAM``).
    ``start`` (1): begin the step (bodies move under external force).  The current
    positions are in buffer ``ctrl[CUR]``."""
    g = cuda.cg.this_grid()
    tid = cuda.grid(1)
    nth = cuda.gridsize(1)
    nb = bodies.shape[0]
    movables = nb + pistons.shape[0] > 0
    if tid == 0:
        if start != 0:
            start_solve(bodies, pistons, seg, sdisc, dt, ctrl)
        ctrl[STATUS] = RUNNING
    g.sync()
    while True:
        even = int(ctrl[CUR]) == 0
        sx = x0 if even else x1
        sy = y0 if even else y1
        dx_ = x1 if even else x0
        dy_ = y1 if even else y0
        if movables:
            body_sums(tid, nth, sx, sy, geo[G_R], bodies, pistons, acc)
            g.sync()
            if tid == 0:
                solve_bodies(bodies, pistons, acc, gamma_r, dt, contact)
            g.sync()
        sweep_robots(tid, nth, sx, sy, dx_, dy_, xr, yr, cell_start, cell_flag, nx, ny, geo,
                     half, seg, sdisc, bodies, pistons, ctrl)  # fmt: skip
        g.sync()
        if tid == 0:
            seen = ctrl[SEEN]
            n_sw = ctrl[SWEEPS] + 1.0
            ctrl[SWEEPS] = n_sw
            ctrl[SEEN] = 0.0
            ctrl[D_IN] = max(ctrl[D_IN], ctrl[D_OUT])
            if (n_sw >= min_sweeps and seen < tol) or n_sw >= max_sweeps:
                ctrl[STATUS] = DONE  # the input, just measured, is the result
                ctrl[LAST_SEEN] = seen
            else:  # apply the sweep: bodies and pistons take their steps
                apply_body_steps(bodies, pistons, contact, moved[:nb], moved[nb:], seg, sdisc)
                ctrl[CUR] = 1.0 - ctrl[CUR]
                if n_sw >= gs_after:
                    ctrl[STATUS] = JAM
        g.sync()
        if ctrl[STATUS] != RUNNING:
            return


# ------------------------------------------------------------------------ checks
@cuda.jit
def max_overlap(x, y, xr, yr, cell_start, nx, ny, geo, seg, sdisc, bodies, pistons, ctrl):
    """Largest overlap (mm) of any robot with a robot, wall, body or piston, into
    ``ctrl[OVERLAP]`` (the same pair search as the sweeps: no pair is missed)."""
    k = rings_for(ctrl[D_IN], geo, max(nx, ny))
    for i in range(cuda.grid(1), x.shape[0], cuda.gridsize(1)):
        px = x[i]
        py = y[i]
        _mx, _my, w = walls_and_bodies(px, py, geo[G_R], True, seg, sdisc, bodies, pistons)
        _mx, _my, w = robot_contacts(i, px, py, x, y, xr, yr, cell_start, nx, ny, geo, k,
                                     np.float32(0.0), 0.0, 0.0, w)  # fmt: skip
        if w > ctrl[OVERLAP]:
            cuda.atomic.max(ctrl, OVERLAP, np.float32(w))


@cuda.jit
def set_value(a, i, v):
    """One thread: ``a[i] = v``."""
    a[i] = v
