"""numba-cuda kernels of the GPU engine (the same kernels run in numba-cuda's simulator).

The physics is the CPU engine's (:mod:`thermoswarm.sim.engine`): commanded motion,
then Jacobi sweeps of mass-weighted position projection against robots, static walls
and discs, movable bodies and force-driven walls.  The robots' contacts with walls,
discs, bodies and pistons are the CPU engine's own device functions
(``kernels._walls_and_bodies`` and ``kernels._seg_push``, compiled a second time for
CUDA from the same Python source).  What differs is the data layout and the neighbour
search, chosen for a GPU:

- **struct of arrays, float32**: ``x``, ``y`` (two buffers each: a sweep reads one and
  writes the other), ``heading``, ``speed``, ``timer``, ``ids``, ``group``; positions
  are stored relative to the world's centre, which halves their rounding step;
- **cell-sorted order**: robots are physically re-ordered by grid cell whenever the grid
  is rebuilt (a counting sort: one atomic count per robot, a prefix sum over cells, a
  scatter, then each cell's few robots put back in their previous order, so the order
  does not depend on the order of the atomics); ``cell_start[c]:cell_start[c + 1]`` are
  the robots of cell ``c``;
- **a grid rebuilt only when needed** (Verlet skin): each robot keeps the position it had
  at the last build (``xr``, ``yr``); ``D`` is the largest distance any robot has moved
  since the build.  Two robots in contact now were less than ``2 r + 2 D`` apart at the
  build, so scanning ``ceil((2 r + 2 D) / cs)`` rings of cells around a robot's build
  cell finds every contact: the rule cannot miss a pair, whatever ``D`` is (it only
  scans more cells when ``D`` outgrows the skin).  The host rebuilds the grid once ``D``
  passes half the skin, so normally one ring (3 x 3 cells);
- **no host round trip inside a step**: every sweep's bookkeeping (largest overlap,
  sweep count, convergence, moving bodies and walls) is done by one-thread kernels on
  the device; sweep kernels launched after convergence return at once.

Every per-robot kernel is a grid-stride loop, so any launch shape covers all robots
(the simulator runs few threads, a GPU many).  Contact sums over robots (forces on
bodies and walls, the largest overlap) use atomics: on a GPU the order of the float
additions onto bodies and walls varies from run to run.
"""

from __future__ import annotations

import math

import numpy as np
from numba import cuda

from thermoswarm.sim import kernels as K

# packed body / piston columns: the CPU engine's layout (SwarmState.bodies / pistons)
BX, BY, BR, BDRAG, BFX, BFY, BCX, BCY, BDX, BDY, BSH = (
    K.BX, K.BY, K.BR, K.BDRAG, K.BFX, K.BFY, K.BCX, K.BCY, K.BDX, K.BDY, K.BSH,
)  # fmt: skip
PA, PP, PS, PLO, PHI, PDRAG, PF, PLL, PLH, PC, PD, PSH = (
    K.PA, K.PP, K.PS, K.PLO, K.PHI, K.PDRAG, K.PF, K.PLL, K.PLH, K.PC, K.PD, K.PSH,
)  # fmt: skip

# float control slots (ctrl_f)
SEEN = 0  # largest overlap found by the current sweep (mm)
D_IN = 1  # displacement bound used by the sweeps (mm)
D_OUT = 2  # largest displacement written by the current sweep (mm)
LAST_SEEN = 3  # largest overlap found by the step's last sweep (mm)
MAX_SEEN = 4  # largest LAST_SEEN since the counters were read
OVERLAP = 5  # max_overlap's result
N_CTRL_F = 6
# int control slots (ctrl_i)
DONE = 0  # 1 once the step's sweeps have converged (or hit the maximum)
SWEEPS = 1  # sweeps done in this step
N_CTRL_I = 2

# geometry parameters (geo array, float32)
G_X0 = 0  # grid origin (relative coordinates, mm)
G_Y0 = 1
G_CS = 2  # cell size (mm)
G_R = 3  # robot radius (mm)
G_EPS = 4  # relative slack on the ring count (float rounding)
N_GEO = 5

INF = math.inf
MASK32 = 0xFFFFFFFF

# The CPU engine's contact functions, compiled for CUDA from the same source.
seg_push = cuda.jit(device=True)(K._seg_push.py_func)
walls_and_bodies = cuda.jit(device=True)(K._walls_and_bodies.py_func)


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


@cuda.jit
def decide_uniform(heading, speed, timer, ids, key, zero, half_width, kT, half_normal,
                   tau_steps, everyone):  # fmt: skip
    """A uniform heading in ``zero +- half_width`` and a speed at temperature ``kT`` for
    every robot whose control period is over (``timer <= 0``), or for all (``everyone``).

    Speed: Rayleigh (``v = sqrt(2 E)``, ``E ~ Exponential(kT)``) or half-normal
    (``|N(0, kT)|``, Box-Muller).  Random numbers: a counter-based hash stream keyed by
    the step's key (drawn from the run's NumPy generator) and the robot's id.
    """
    for i in range(cuda.grid(1), heading.shape[0], cuda.gridsize(1)):
        if everyone == 0 and timer[i] > 0:
            continue
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


# ------------------------------------------------------------------------ one step
@cuda.jit
def predict(x, y, xr, yr, heading, speed, timer, dt, ctrl_f):
    """Commanded motion for one step; timers count down; displacement since the build."""
    for i in range(cuda.grid(1), x.shape[0], cuda.gridsize(1)):
        h = heading[i]
        v = speed[i] * dt
        px = x[i] + v * math.cos(h)
        py = y[i] + v * math.sin(h)
        x[i] = px
        y[i] = py
        timer[i] = timer[i] - 1
        d = math.sqrt((px - xr[i]) ** 2 + (py - yr[i]) ** 2)
        if d > ctrl_f[D_OUT]:  # read first: few threads reach the atomic
            cuda.atomic.max(ctrl_f, D_OUT, np.float32(d))


@cuda.jit(device=True)
def bodies_vs_static(bodies, seg, sdisc):
    """Keep movable bodies out of static walls and obstacles (walls do not yield)."""
    for b in range(bodies.shape[0]):
        R = bodies[b, BR]
        for s in range(seg.shape[0]):
            ov, nxs, nys = seg_push(
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
                if d > 1.0e-12:
                    bodies[b, BX] += (RR - d) * dx / d
                    bodies[b, BY] += (RR - d) * dy / d


@cuda.jit
def move_bodies_external(bodies, pistons, seg, sdisc, dt, ctrl_f, ctrl_i):
    """One thread: start of a step's sweeps; bodies and walls move under external force."""
    ctrl_i[DONE] = 0
    ctrl_i[SWEEPS] = 0
    ctrl_f[SEEN] = 0.0
    ctrl_f[D_IN] = max(ctrl_f[D_IN], ctrl_f[D_OUT])
    for b in range(bodies.shape[0]):
        bodies[b, BCX] = 0.0
        bodies[b, BCY] = 0.0
        if bodies[b, BDRAG] < INF:
            bodies[b, BX] += bodies[b, BFX] * dt / bodies[b, BDRAG]
            bodies[b, BY] += bodies[b, BFY] * dt / bodies[b, BDRAG]
    bodies_vs_static(bodies, seg, sdisc)
    for p in range(pistons.shape[0]):
        pistons[p, PC] = 0.0
        if pistons[p, PDRAG] < INF:
            q = pistons[p, PP] + pistons[p, PS] * pistons[p, PF] * dt / pistons[p, PDRAG]
            pistons[p, PP] = min(max(q, pistons[p, PLL]), pistons[p, PLH])


@cuda.jit
def contacts_with_bodies(x, y, r, bodies, pistons, acc_b, acc_p, ctrl_i):
    """Per robot: add its contacts with movable bodies and walls to their sums
    (count, summed overlap vector) for this sweep's shares."""
    if ctrl_i[DONE] != 0:
        return
    for i in range(cuda.grid(1), x.shape[0], cuda.gridsize(1)):
        px = x[i]
        py = y[i]
        for b in range(bodies.shape[0]):
            dx = px - bodies[b, BX]
            dy = py - bodies[b, BY]
            R = bodies[b, BR] + r
            d2 = dx * dx + dy * dy
            if d2 < R * R:
                d = math.sqrt(d2)
                if d >= 1.0e-12:
                    ov = R - d
                    cuda.atomic.add(acc_b, (b, 0), 1.0)
                    cuda.atomic.add(acc_b, (b, 1), -ov * dx / d)
                    cuda.atomic.add(acc_b, (b, 2), -ov * dy / d)
        for p in range(pistons.shape[0]):
            a = int(pistons[p, PA])
            q = px if a == 1 else py
            v = py if a == 1 else px
            if q >= pistons[p, PLO] and q <= pistons[p, PHI]:
                gap = pistons[p, PS] * (v - pistons[p, PP])
                if gap < r:
                    cuda.atomic.add(acc_p, (p, 0), 1.0)
                    cuda.atomic.add(acc_p, (p, 1), r - gap)


@cuda.jit(device=True)
def solve_one(k, drag, gamma_r):
    """Shared displacement factor and the robots' share of a contact set with ``k``
    contacts on a body or wall of ``drag`` (the CPU engine's ``_bodies_pass``):
    returns (step factor, share); step = factor * summed overlap."""
    if drag < INF:
        den = k * gamma_r + drag
        return gamma_r / den, drag / den
    return 0.0, 1.0


@cuda.jit
def solve_bodies(bodies, pistons, acc_b, acc_p, gamma_r, dt, ctrl_i):
    """One thread: each body's and wall's displacement and the robots' share of the
    overlap, from this sweep's contacts (the CPU engine's ``_bodies_pass``)."""
    if ctrl_i[DONE] != 0:
        return
    for b in range(bodies.shape[0]):
        k, sx, sy = acc_b[b, 0], acc_b[b, 1], acc_b[b, 2]
        acc_b[b, 0] = 0.0
        acc_b[b, 1] = 0.0
        acc_b[b, 2] = 0.0
        if k == 0.0:
            bodies[b, BDX] = 0.0
            bodies[b, BDY] = 0.0
            bodies[b, BSH] = 1.0
        else:
            f, share = solve_one(k, bodies[b, BDRAG], gamma_r)
            bodies[b, BDX] = f * sx
            bodies[b, BDY] = f * sy
            bodies[b, BSH] = share
            bodies[b, BCX] += gamma_r * share * sx / dt
            bodies[b, BCY] += gamma_r * share * sy / dt
    for p in range(pistons.shape[0]):
        k, s = acc_p[p, 0], acc_p[p, 1]
        acc_p[p, 0] = 0.0
        acc_p[p, 1] = 0.0
        side = pistons[p, PS]
        if k == 0.0:
            pistons[p, PD] = 0.0
            pistons[p, PSH] = 1.0
        else:
            f, share = solve_one(k, pistons[p, PDRAG], gamma_r)
            pistons[p, PD] = -side * f * s  # pushed away from the robots
            pistons[p, PSH] = share
            pistons[p, PC] += -side * gamma_r * share * s / dt


@cuda.jit(device=True)
def robot_contacts(i, px, py, src_x, src_y, xr, yr, cell_start, nx, ny, geo, d_bound,
                   half, mx, my, w):  # fmt: skip
    """Robot ``i`` at ``(px, py)`` against every robot it may touch: its share ``half``
    of each overlap added to ``(mx, my)``, the largest overlap to ``w``; returns the
    three.  Scans the build cell and ``k`` rings around it (robots are sorted by build
    cell, so each row of cells is one contiguous range of robots)."""
    # float32 pair arithmetic (positions are float32; float64 is slow on most GPUs)
    d_rr = geo[G_R] + geo[G_R]
    c2 = d_rr * d_rr
    half = np.float32(half)
    bx, by = cell_of(xr[i], yr[i], geo[G_X0], geo[G_Y0], geo[G_CS], nx, ny)
    k = rings_for(d_bound, geo, max(nx, ny))
    xa = max(bx - k, 0)
    xb = min(bx + k, nx - 1)
    for cy in range(max(by - k, 0), min(by + k, ny - 1) + 1):
        for j in range(cell_start[cy * nx + xa], cell_start[cy * nx + xb + 1]):
            if j == i:
                continue
            dx = px - src_x[j]
            dy = py - src_y[j]
            d2 = dx * dx + dy * dy
            if d2 < c2:
                d = math.sqrt(d2)
                w = max(w, d_rr - d)
                if d > 1.0e-12:
                    f = half * (d_rr - d) / d
                    mx += f * dx
                    my += f * dy
                else:  # coincident centres: separate along x by index order
                    mx += half * d_rr * (1.0 if i < j else -1.0)
    return mx, my, w


@cuda.jit
def sweep(src_x, src_y, dst_x, dst_y, xr, yr, cell_start, cell_flag, nx, ny, geo, relax,
          seg, sdisc, bodies, pistons, ctrl_f, ctrl_i):  # fmt: skip
    """One Jacobi sweep: each robot moves by its share of every overlap it has."""
    if ctrl_i[DONE] != 0:
        return
    d_bound = ctrl_f[D_IN]
    for i in range(cuda.grid(1), src_x.shape[0], cuda.gridsize(1)):
        px = src_x[i]
        py = src_y[i]
        ccx, ccy = cell_of(px, py, geo[G_X0], geo[G_Y0], geo[G_CS], nx, ny)
        near = cell_flag[ccy * nx + ccx] != 0
        mx, my, w = walls_and_bodies(px, py, geo[G_R], near, seg, sdisc, bodies, pistons)
        mx, my, w = robot_contacts(i, px, py, src_x, src_y, xr, yr, cell_start, nx, ny, geo,
                                   d_bound, 0.5 * relax, mx, my, w)  # fmt: skip
        qx = px + mx
        qy = py + my
        dst_x[i] = qx
        dst_y[i] = qy
        if w > ctrl_f[SEEN]:
            cuda.atomic.max(ctrl_f, SEEN, np.float32(w))
        dd = math.sqrt((qx - xr[i]) ** 2 + (qy - yr[i]) ** 2)
        if dd > ctrl_f[D_OUT]:
            cuda.atomic.max(ctrl_f, D_OUT, np.float32(dd))


@cuda.jit
def end_sweep(bodies, pistons, seg, sdisc, min_sweeps, max_sweeps, tol, ctrl_f, ctrl_i):
    """One thread after each sweep: move bodies and walls, count, test convergence."""
    if ctrl_i[DONE] != 0:
        return
    for b in range(bodies.shape[0]):
        bodies[b, BX] += bodies[b, BDX]
        bodies[b, BY] += bodies[b, BDY]
    bodies_vs_static(bodies, seg, sdisc)
    for p in range(pistons.shape[0]):
        pistons[p, PP] += pistons[p, PD]
    n_sw = ctrl_i[SWEEPS] + 1
    ctrl_i[SWEEPS] = n_sw
    seen = ctrl_f[SEEN]
    ctrl_f[LAST_SEEN] = seen
    ctrl_f[SEEN] = 0.0
    ctrl_f[D_IN] = max(ctrl_f[D_IN], ctrl_f[D_OUT])
    if (n_sw >= min_sweeps and seen < tol) or n_sw >= max_sweeps:
        ctrl_i[DONE] = 1
        ctrl_f[MAX_SEEN] = max(ctrl_f[MAX_SEEN], seen)


# ------------------------------------------------------------------------ the grid
@cuda.jit
def cell_keys(x, y, geo, nx, ny, keys, slot, counts):
    """Each robot's cell, and its arrival rank in that cell (an atomic count)."""
    for i in range(cuda.grid(1), x.shape[0], cuda.gridsize(1)):
        cx, cy = cell_of(x[i], y[i], geo[G_X0], geo[G_Y0], geo[G_CS], nx, ny)
        c = cy * nx + cx
        keys[i] = c
        slot[i] = cuda.atomic.add(counts, c, 1)


@cuda.jit
def chunk_sums(a, m, chunk, sums):
    """``sums[t]``: the sum of ``a[t * chunk : (t + 1) * chunk]`` (first ``m`` only)."""
    for t in range(cuda.grid(1), sums.shape[0], cuda.gridsize(1)):
        s = 0
        for c in range(t * chunk, min((t + 1) * chunk, m)):
            s += a[c]
        sums[t] = s


@cuda.jit
def scan_serial(a, m):
    """One thread: exclusive prefix sum of ``a[:m]`` in place."""
    s = 0
    for c in range(m):
        v = a[c]
        a[c] = s
        s += v


@cuda.jit
def chunk_apply(a, m, chunk, sums):
    """Exclusive prefix sum of each chunk of ``a[:m]`` in place, offset by the chunk's
    exclusive prefix ``sums[t]``."""
    for t in range(cuda.grid(1), sums.shape[0], cuda.gridsize(1)):
        s = sums[t]
        for c in range(t * chunk, min((t + 1) * chunk, m)):
            v = a[c]
            a[c] = s
            s += v


@cuda.jit
def scatter(keys, slot, cell_start, perm):
    """``perm[k]``: the robot that goes to sorted place ``k``."""
    for i in range(cuda.grid(1), keys.shape[0], cuda.gridsize(1)):
        perm[cell_start[keys[i]] + slot[i]] = i


@cuda.jit
def order_cells(cell_start, perm):
    """Within each cell, robots back in their previous order (an insertion sort of a
    few entries), so that the sort is stable whatever order the atomics took."""
    for c in range(cuda.grid(1), cell_start.shape[0] - 1, cuda.gridsize(1)):
        lo = cell_start[c]
        for k in range(lo + 1, cell_start[c + 1]):
            v = perm[k]
            j = k - 1
            while j >= lo and perm[j] > v:
                perm[j + 1] = perm[j]
                j -= 1
            perm[j + 1] = v


@cuda.jit
def gather_xy(perm, x, y, x2, y2, xr, yr):
    """Sorted positions into the other buffers; they become the new build positions."""
    for k in range(cuda.grid(1), perm.shape[0], cuda.gridsize(1)):
        j = perm[k]
        px = x[j]
        py = y[j]
        x2[k] = px
        y2[k] = py
        xr[k] = px
        yr[k] = py


@cuda.jit
def gather(perm, a, out):
    """``out[k] = a[perm[k]]``."""
    for k in range(cuda.grid(1), perm.shape[0], cuda.gridsize(1)):
        out[k] = a[perm[k]]


@cuda.jit
def set_float(a, i, v):
    """One thread: ``a[i] = v``."""
    a[i] = v


# ------------------------------------------------------------------------ checks
@cuda.jit
def max_overlap(x, y, xr, yr, cell_start, nx, ny, geo, seg, sdisc, bodies, pistons, ctrl_f):
    """Largest overlap (mm) of any robot with a robot, wall, body or piston, into
    ``ctrl_f[OVERLAP]`` (the same pair search as the sweeps: no pair is missed)."""
    d_bound = ctrl_f[D_IN]
    for i in range(cuda.grid(1), x.shape[0], cuda.gridsize(1)):
        px = x[i]
        py = y[i]
        _mx, _my, w = walls_and_bodies(px, py, geo[G_R], True, seg, sdisc, bodies, pistons)
        _mx, _my, w = robot_contacts(i, px, py, x, y, xr, yr, cell_start, nx, ny, geo,
                                     d_bound, 0.0, 0.0, 0.0, w)  # fmt: skip
        if w > ctrl_f[OVERLAP]:
            cuda.atomic.max(ctrl_f, OVERLAP, np.float32(w))


@cuda.jit
def fill_int(a, v):
    """``a[:] = v``."""
    for k in range(cuda.grid(1), a.shape[0], cuda.gridsize(1)):
        a[k] = v
