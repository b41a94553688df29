# ruff: noqa: UP018, E402
# (Warp needs float(0.0) / int(-1) to make a variable mutable in branches and loops;
# the banner switch must precede the imports that define kernels)
"""Warp kernels of the GPU engine (the same kernels run on Warp's CPU device).

The physics is the CPU engine's (:mod:`thermoswarm.sim.engine`): commanded motion,
then Jacobi sweeps of mass-weighted position projection against robots, static walls
and discs, movable bodies and force-driven walls.  What differs is the data layout and
the neighbour search, chosen for a GPU:

- **struct of arrays, float32**: ``x``, ``y`` (two buffers each: a sweep reads one and
  writes the other), ``heading``, ``speed``, ``timer``, ``ids``, ``group``; positions
  are stored relative to the world's centre, which halves their rounding step;
- **cell-sorted order**: robots are physically re-ordered by grid cell whenever the grid
  is rebuilt (radix sort of cell keys), so that the robots a thread reads are close in
  memory; ``cell_start[c]:cell_start[c + 1]`` are the robots of cell ``c``;
- **a grid rebuilt only when needed** (Verlet skin): each robot keeps the position it had
  at the last build (``xr``, ``yr``) and its build cell; ``D`` is the largest distance
  any robot has moved since the build.  Two robots in contact now were less than
  ``2 r + 2 D`` apart at the build, so scanning ``ceil((2 r + 2 D) / cs)`` rings of
  cells around a robot's build cell finds every contact: the rule cannot miss a pair,
  whatever ``D`` is (it only scans more cells when ``D`` outgrows the skin).  The host
  rebuilds the grid once ``D`` passes half the skin, so normally one ring (3 x 3 cells);
- **no host round trip inside a step**: every sweep's bookkeeping (largest overlap,
  sweep count, convergence, moving bodies and walls) is done by one-thread kernels on
  the device; sweep kernels launched after convergence return at once.

Contact sums over robots (forces on bodies and walls, the largest overlap) use atomics.
On the CPU device Warp runs a kernel's threads in order, so results are reproducible
there; on a GPU the order of the float additions onto bodies and walls varies.
"""

from __future__ import annotations

import warp as wp

wp.config.quiet = True  # no start-up banner or module-load lines (set before Warp starts)
if getattr(wp.config, "log_level", None) is not None:
    wp.config.log_level = max(wp.config.log_level, wp.LOG_WARNING)

from thermoswarm.sim import kernels as K

# packed body / piston columns: the CPU engine's layout (SwarmState.bodies / pistons)
BX = wp.constant(K.BX)
BY = wp.constant(K.BY)
BR = wp.constant(K.BR)
BDRAG = wp.constant(K.BDRAG)
BFX = wp.constant(K.BFX)
BFY = wp.constant(K.BFY)
BCX = wp.constant(K.BCX)
BCY = wp.constant(K.BCY)
BDX = wp.constant(K.BDX)
BDY = wp.constant(K.BDY)
BSH = wp.constant(K.BSH)
PA = wp.constant(K.PA)
PP = wp.constant(K.PP)
PS = wp.constant(K.PS)
PLO = wp.constant(K.PLO)
PHI = wp.constant(K.PHI)
PDRAG = wp.constant(K.PDRAG)
PF = wp.constant(K.PF)
PLL = wp.constant(K.PLL)
PLH = wp.constant(K.PLH)
PC = wp.constant(K.PC)
PD = wp.constant(K.PD)
PSH = wp.constant(K.PSH)

# float control slots (ctrl_f)
SEEN = wp.constant(0)  # largest overlap found by the current sweep (mm)
D_IN = wp.constant(1)  # displacement bound used by the sweeps (mm)
D_OUT = wp.constant(2)  # largest displacement written by the current sweep (mm)
LAST_SEEN = wp.constant(3)  # largest overlap found by the step's last sweep (mm)
MAX_SEEN = wp.constant(4)  # largest LAST_SEEN since the counters were read
OVERLAP = wp.constant(5)  # max_overlap's result
N_CTRL_F = 6
# int control slots (ctrl_i)
DONE = wp.constant(0)  # 1 once the step's sweeps have converged (or hit the maximum)
SWEEPS = wp.constant(1)  # sweeps done in this step
N_CTRL_I = 2

# geometry parameters (geo array, float32)
G_X0 = wp.constant(0)  # grid origin (relative coordinates)
G_Y0 = wp.constant(1)
G_CS = wp.constant(2)  # cell size
G_R = wp.constant(3)  # robot radius
G_EPS = wp.constant(4)  # relative slack on the ring count (float rounding)
N_GEO = 5

INF = wp.constant(float("inf"))


@wp.func
def cell_of(x: float, y: float, x0: float, y0: float, cs: float, nx: int, ny: int):
    cx = int(wp.floor((x - x0) / cs))
    cy = int(wp.floor((y - y0) / cs))
    cx = wp.clamp(cx, 0, nx - 1)
    cy = wp.clamp(cy, 0, ny - 1)
    return cx, cy


@wp.func
def seg_push(px: float, py: float, x0: float, y0: float, x1: float, y1: float, r: float):
    """Overlap and unit normal (segment -> point) of a disc of radius r on a segment."""
    ex = x1 - x0
    ey = y1 - y0
    l2 = ex * ex + ey * ey
    t = float(0.0)
    if l2 > 0.0:
        t = wp.clamp(((px - x0) * ex + (py - y0) * ey) / l2, 0.0, 1.0)
    dx = px - (x0 + t * ex)
    dy = py - (y0 + t * ey)
    d2 = dx * dx + dy * dy
    ov = float(0.0)
    nxs = float(0.0)
    nys = float(0.0)
    if d2 < r * r:
        d = wp.sqrt(d2)
        if d > 1.0e-12:
            ov = r - d
            nxs = dx / d
            nys = dy / d
        else:  # centre exactly on the segment: push along its left normal
            ln = wp.sqrt(l2)
            if ln <= 0.0:
                ln = 1.0
            ov = r
            nxs = -ey / ln
            nys = ex / ln
    return ov, nxs, nys


@wp.func
def walls_and_bodies(
    px: float,
    py: float,
    r: float,
    near_static: int,
    seg: wp.array2d(dtype=wp.float32),
    sdisc: wp.array2d(dtype=wp.float32),
    bodies: wp.array2d(dtype=wp.float32),
    pistons: wp.array2d(dtype=wp.float32),
):
    """Correction (mx, my) and largest overlap w of a robot against walls, bodies, pistons."""
    mx = float(0.0)
    my = float(0.0)
    w = float(0.0)
    if near_static != 0:
        for s in range(seg.shape[0]):
            ov, nxs, nys = seg_push(px, py, seg[s, 0], seg[s, 1], seg[s, 2], seg[s, 3], r)
            if ov > 0.0:
                mx += ov * nxs
                my += ov * nys
                w = wp.max(w, ov)
        for s in range(sdisc.shape[0]):
            dx = px - sdisc[s, 0]
            dy = py - sdisc[s, 1]
            R = sdisc[s, 2] + r
            d2 = dx * dx + dy * dy
            if d2 < R * R:
                d = wp.sqrt(d2)
                w = wp.max(w, R - d)
                if d > 1.0e-12:
                    mx += (R - d) * dx / d
                    my += (R - d) * dy / d
    for b in range(bodies.shape[0]):
        dx = px - bodies[b, BX]
        dy = py - bodies[b, BY]
        R = bodies[b, BR] + r
        d2 = dx * dx + dy * dy
        if d2 < R * R:
            d = wp.sqrt(d2)
            w = wp.max(w, R - d)
            if d > 1.0e-12:
                f = bodies[b, BSH] * (R - d) / d
                mx += f * dx
                my += f * dy
    for p in range(pistons.shape[0]):
        a = int(pistons[p, PA])
        q = py
        v = px
        if a == 1:
            q = px
            v = py
        if q >= pistons[p, PLO] and q <= pistons[p, PHI]:
            gap = pistons[p, PS] * (v - pistons[p, PP])
            if gap < r:
                w = wp.max(w, r - gap)
                corr = pistons[p, PSH] * (r - gap) * pistons[p, PS]
                if a == 0:
                    mx += corr
                else:
                    my += corr
    return mx, my, w


@wp.func
def rings_for(d_bound: float, geo: wp.array(dtype=wp.float32), nmax: int):
    """Cell rings to scan so that no pair within 2 r is missed (see the module doc)."""
    reach = (2.0 * geo[G_R] + 2.0 * d_bound) * (1.0 + geo[G_EPS])
    k = int(wp.ceil(reach / geo[G_CS]))
    return wp.clamp(k, 1, nmax)


# ------------------------------------------------------------------------ decisions
@wp.kernel
def decide_uniform(
    heading: wp.array(dtype=wp.float32),
    speed: wp.array(dtype=wp.float32),
    timer: wp.array(dtype=wp.int32),
    ids: wp.array(dtype=wp.int32),
    key: int,
    zero: float,
    half_width: float,
    kT: float,
    half_normal: int,
    tau_steps: int,
    everyone: int,
):
    """A uniform heading in ``zero +- half_width`` and a speed at temperature ``kT`` for
    every robot whose control period is over (``timer <= 0``), or for all (``everyone``).

    Speed: Rayleigh (``v = sqrt(2 E)``, ``E ~ Exponential(kT)``) or half-normal
    (``|N(0, kT)|``).  Random numbers: Warp's counter-based generator keyed by the
    step's key (drawn from the run's NumPy generator) and the robot's id.
    """
    i = wp.tid()
    if everyone == 0 and timer[i] > 0:
        return
    st = wp.rand_init(key, ids[i])
    u = wp.randf(st)
    h = zero + half_width * (2.0 * u - 1.0)
    v = float(0.0)
    if half_normal != 0:
        v = wp.abs(wp.randn(st)) * wp.sqrt(kT)
    else:
        e = -kT * wp.log(1.0 - wp.randf(st))
        v = wp.sqrt(2.0 * e)
    heading[i] = h
    speed[i] = v
    timer[i] = tau_steps


# ------------------------------------------------------------------------ one step
@wp.kernel
def predict(
    x: wp.array(dtype=wp.float32),
    y: wp.array(dtype=wp.float32),
    xr: wp.array(dtype=wp.float32),
    yr: wp.array(dtype=wp.float32),
    heading: wp.array(dtype=wp.float32),
    speed: wp.array(dtype=wp.float32),
    timer: wp.array(dtype=wp.int32),
    dt: float,
    ctrl_f: wp.array(dtype=wp.float32),
):
    """Commanded motion for one step; timers count down; displacement since the build."""
    i = wp.tid()
    h = heading[i]
    v = speed[i] * dt
    px = x[i] + v * wp.cos(h)
    py = y[i] + v * wp.sin(h)
    x[i] = px
    y[i] = py
    timer[i] = timer[i] - 1
    dx = px - xr[i]
    dy = py - yr[i]
    d = wp.sqrt(dx * dx + dy * dy)
    if d > ctrl_f[D_OUT]:  # read first: few threads reach the atomic
        wp.atomic_max(ctrl_f, D_OUT, d)


@wp.func
def bodies_vs_static(
    bodies: wp.array2d(dtype=wp.float32),
    seg: wp.array2d(dtype=wp.float32),
    sdisc: wp.array2d(dtype=wp.float32),
):
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
                d = wp.sqrt(d2)
                if d > 1.0e-12:
                    bodies[b, BX] += (RR - d) * dx / d
                    bodies[b, BY] += (RR - d) * dy / d


@wp.kernel
def move_bodies_external(
    bodies: wp.array2d(dtype=wp.float32),
    pistons: wp.array2d(dtype=wp.float32),
    seg: wp.array2d(dtype=wp.float32),
    sdisc: wp.array2d(dtype=wp.float32),
    dt: float,
    ctrl_f: wp.array(dtype=wp.float32),
    ctrl_i: wp.array(dtype=wp.int32),
):
    """One thread: start of a step's sweeps; bodies and walls move under external force."""
    ctrl_i[DONE] = 0
    ctrl_i[SWEEPS] = 0
    ctrl_f[SEEN] = 0.0
    ctrl_f[D_IN] = wp.max(ctrl_f[D_IN], ctrl_f[D_OUT])
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
            pistons[p, PP] = wp.clamp(q, pistons[p, PLL], pistons[p, PLH])


@wp.kernel
def contacts_with_bodies(
    x: wp.array(dtype=wp.float32),
    y: wp.array(dtype=wp.float32),
    r: float,
    bodies: wp.array2d(dtype=wp.float32),
    pistons: wp.array2d(dtype=wp.float32),
    acc_b: wp.array2d(dtype=wp.float64),
    acc_p: wp.array2d(dtype=wp.float64),
    ctrl_i: wp.array(dtype=wp.int32),
):
    """Per robot: add its contacts with movable bodies and walls to their sums
    (count, summed overlap vector) for this sweep's shares."""
    i = wp.tid()
    if ctrl_i[DONE] != 0:
        return
    px = x[i]
    py = y[i]
    for b in range(bodies.shape[0]):
        dx = px - bodies[b, BX]
        dy = py - bodies[b, BY]
        R = bodies[b, BR] + r
        d2 = dx * dx + dy * dy
        if d2 < R * R:
            d = wp.sqrt(d2)
            if d >= 1.0e-12:
                ov = R - d
                wp.atomic_add(acc_b, b, 0, wp.float64(1.0))
                wp.atomic_add(acc_b, b, 1, wp.float64(-ov * dx / d))
                wp.atomic_add(acc_b, b, 2, wp.float64(-ov * dy / d))
    for p in range(pistons.shape[0]):
        a = int(pistons[p, PA])
        q = py
        v = px
        if a == 1:
            q = px
            v = py
        if q >= pistons[p, PLO] and q <= pistons[p, PHI]:
            gap = pistons[p, PS] * (v - pistons[p, PP])
            if gap < r:
                wp.atomic_add(acc_p, p, 0, wp.float64(1.0))
                wp.atomic_add(acc_p, p, 1, wp.float64(r - gap))


@wp.kernel
def solve_bodies(
    bodies: wp.array2d(dtype=wp.float32),
    pistons: wp.array2d(dtype=wp.float32),
    acc_b: wp.array2d(dtype=wp.float64),
    acc_p: wp.array2d(dtype=wp.float64),
    gamma_r: float,
    dt: float,
    ctrl_i: wp.array(dtype=wp.int32),
):
    """One thread: each body's and wall's displacement and the robots' share of the
    overlap, from this sweep's contacts (the CPU engine's ``_bodies_pass``)."""
    if ctrl_i[DONE] != 0:
        return
    for b in range(bodies.shape[0]):
        k = float(acc_b[b, 0])
        sx = float(acc_b[b, 1])
        sy = float(acc_b[b, 2])
        acc_b[b, 0] = wp.float64(0.0)
        acc_b[b, 1] = wp.float64(0.0)
        acc_b[b, 2] = wp.float64(0.0)
        drag = bodies[b, BDRAG]
        if k == 0.0:
            bodies[b, BDX] = 0.0
            bodies[b, BDY] = 0.0
            bodies[b, BSH] = 1.0
        else:
            share = float(1.0)
            if drag < INF:
                den = k * gamma_r + drag
                share = drag / den
                bodies[b, BDX] = gamma_r * sx / den
                bodies[b, BDY] = gamma_r * sy / den
            else:
                bodies[b, BDX] = 0.0
                bodies[b, BDY] = 0.0
            bodies[b, BSH] = share
            bodies[b, BCX] += gamma_r * share * sx / dt
            bodies[b, BCY] += gamma_r * share * sy / dt
    for p in range(pistons.shape[0]):
        k = float(acc_p[p, 0])
        s = float(acc_p[p, 1])
        acc_p[p, 0] = wp.float64(0.0)
        acc_p[p, 1] = wp.float64(0.0)
        side = pistons[p, PS]
        drag = pistons[p, PDRAG]
        if k == 0.0:
            pistons[p, PD] = 0.0
            pistons[p, PSH] = 1.0
        else:
            share = float(1.0)
            if drag < INF:
                den = k * gamma_r + drag
                share = drag / den
                pistons[p, PD] = -side * gamma_r * s / den  # pushed away from the robots
            else:
                pistons[p, PD] = 0.0
            pistons[p, PSH] = share
            pistons[p, PC] += -side * gamma_r * share * s / dt


@wp.kernel
def sweep(
    src_x: wp.array(dtype=wp.float32),
    src_y: wp.array(dtype=wp.float32),
    dst_x: wp.array(dtype=wp.float32),
    dst_y: wp.array(dtype=wp.float32),
    xr: wp.array(dtype=wp.float32),
    yr: wp.array(dtype=wp.float32),
    cell_start: wp.array(dtype=wp.int32),
    cell_flag: wp.array(dtype=wp.uint8),
    nx: int,
    ny: int,
    geo: wp.array(dtype=wp.float32),
    relax: float,
    seg: wp.array2d(dtype=wp.float32),
    sdisc: wp.array2d(dtype=wp.float32),
    bodies: wp.array2d(dtype=wp.float32),
    pistons: wp.array2d(dtype=wp.float32),
    ctrl_f: wp.array(dtype=wp.float32),
    ctrl_i: wp.array(dtype=wp.int32),
):
    """One Jacobi sweep: each robot moves by its share of every overlap it has."""
    i = wp.tid()
    if ctrl_i[DONE] != 0:
        return
    x0 = geo[G_X0]
    y0 = geo[G_Y0]
    cs = geo[G_CS]
    r = geo[G_R]
    d_rr = 2.0 * r
    px = src_x[i]
    py = src_y[i]
    ccx, ccy = cell_of(px, py, x0, y0, cs, nx, ny)
    mx, my, w = walls_and_bodies(
        px, py, r, int(cell_flag[ccy * nx + ccx]), seg, sdisc, bodies, pistons
    )
    # contacts: the build cell and `k` rings around it (robots are sorted by build
    # cell, so each row of cells is one contiguous range of robots)
    bx, by = cell_of(xr[i], yr[i], x0, y0, cs, nx, ny)
    k = rings_for(ctrl_f[D_IN], geo, wp.max(nx, ny))
    xa = wp.max(bx - k, 0)
    xb = wp.min(bx + k, nx - 1)
    for cy in range(wp.max(by - k, 0), wp.min(by + k, ny - 1) + 1):
        j0 = cell_start[cy * nx + xa]
        j1 = cell_start[cy * nx + xb + 1]
        for j in range(j0, j1):
            if j != i:
                dx = px - src_x[j]
                dy = py - src_y[j]
                d2 = dx * dx + dy * dy
                if d2 < d_rr * d_rr:
                    d = wp.sqrt(d2)
                    w = wp.max(w, d_rr - d)
                    if d > 1.0e-12:
                        f = 0.5 * relax * (d_rr - d) / d
                        mx += f * dx
                        my += f * dy
                    else:  # coincident centres: separate along x by index order
                        if i < j:
                            mx += 0.5 * relax * d_rr
                        else:
                            mx -= 0.5 * relax * d_rr
    qx = px + mx
    qy = py + my
    dst_x[i] = qx
    dst_y[i] = qy
    if w > ctrl_f[SEEN]:
        wp.atomic_max(ctrl_f, SEEN, w)
    ex = qx - xr[i]
    ey = qy - yr[i]
    dd = wp.sqrt(ex * ex + ey * ey)
    if dd > ctrl_f[D_OUT]:
        wp.atomic_max(ctrl_f, D_OUT, dd)


@wp.kernel
def end_sweep(
    bodies: wp.array2d(dtype=wp.float32),
    pistons: wp.array2d(dtype=wp.float32),
    seg: wp.array2d(dtype=wp.float32),
    sdisc: wp.array2d(dtype=wp.float32),
    min_sweeps: int,
    max_sweeps: int,
    tol: float,
    ctrl_f: wp.array(dtype=wp.float32),
    ctrl_i: wp.array(dtype=wp.int32),
):
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
    ctrl_f[D_IN] = wp.max(ctrl_f[D_IN], ctrl_f[D_OUT])
    if (n_sw >= min_sweeps and seen < tol) or n_sw >= max_sweeps:
        ctrl_i[DONE] = 1
        ctrl_f[MAX_SEEN] = wp.max(ctrl_f[MAX_SEEN], seen)


# ------------------------------------------------------------------------ the grid
@wp.kernel
def compute_keys(
    x: wp.array(dtype=wp.float32),
    y: wp.array(dtype=wp.float32),
    geo: wp.array(dtype=wp.float32),
    nx: int,
    ny: int,
    keys: wp.array(dtype=wp.int32),
    vals: wp.array(dtype=wp.int32),
):
    i = wp.tid()
    cx, cy = cell_of(x[i], y[i], geo[G_X0], geo[G_Y0], geo[G_CS], nx, ny)
    keys[i] = cy * nx + cx
    vals[i] = i


@wp.kernel
def cell_bounds(
    keys: wp.array(dtype=wp.int32), n: int, ncell: int, cell_start: wp.array(dtype=wp.int32)
):
    """``cell_start`` from sorted cell keys: robot k opens every cell after the previous
    robot's cell up to its own (empty cells start where the next robot does)."""
    k = wp.tid()
    if k < n:
        lo = int(-1)
        if k > 0:
            lo = keys[k - 1]
        for c in range(lo + 1, keys[k] + 1):
            cell_start[c] = k
    else:  # one extra thread closes the cells after the last robot
        lo = int(-1)
        if n > 0:
            lo = keys[n - 1]
        for c in range(lo + 1, ncell + 1):
            cell_start[c] = n


@wp.kernel
def gather_xy(
    perm: wp.array(dtype=wp.int32),
    x: wp.array(dtype=wp.float32),
    y: wp.array(dtype=wp.float32),
    x2: wp.array(dtype=wp.float32),
    y2: wp.array(dtype=wp.float32),
    xr: wp.array(dtype=wp.float32),
    yr: wp.array(dtype=wp.float32),
):
    """Sorted positions into the other buffers; they become the new build positions."""
    k = wp.tid()
    j = perm[k]
    px = x[j]
    py = y[j]
    x2[k] = px
    y2[k] = py
    xr[k] = px
    yr[k] = py


@wp.kernel
def gather_f(perm: wp.array(dtype=wp.int32), a: wp.array(dtype=wp.float32),
             out: wp.array(dtype=wp.float32)):  # fmt: skip
    k = wp.tid()
    out[k] = a[perm[k]]


@wp.kernel
def gather_i(perm: wp.array(dtype=wp.int32), a: wp.array(dtype=wp.int32),
             out: wp.array(dtype=wp.int32)):  # fmt: skip
    k = wp.tid()
    out[k] = a[perm[k]]


# ------------------------------------------------------------------------ checks
@wp.kernel
def max_overlap(
    x: wp.array(dtype=wp.float32),
    y: wp.array(dtype=wp.float32),
    xr: wp.array(dtype=wp.float32),
    yr: wp.array(dtype=wp.float32),
    cell_start: wp.array(dtype=wp.int32),
    nx: int,
    ny: int,
    geo: wp.array(dtype=wp.float32),
    seg: wp.array2d(dtype=wp.float32),
    sdisc: wp.array2d(dtype=wp.float32),
    bodies: wp.array2d(dtype=wp.float32),
    pistons: wp.array2d(dtype=wp.float32),
    ctrl_f: wp.array(dtype=wp.float32),
):
    """Largest overlap (mm) of any robot with a robot, wall, body or piston, into
    ``ctrl_f[OVERLAP]`` (the same pair search as the sweeps: no pair is missed)."""
    i = wp.tid()
    r = geo[G_R]
    d_rr = 2.0 * r
    px = x[i]
    py = y[i]
    _mx, _my, w = walls_and_bodies(px, py, r, 1, seg, sdisc, bodies, pistons)
    bx, by = cell_of(xr[i], yr[i], geo[G_X0], geo[G_Y0], geo[G_CS], nx, ny)
    k = rings_for(ctrl_f[D_IN], geo, wp.max(nx, ny))
    xa = wp.max(bx - k, 0)
    xb = wp.min(bx + k, nx - 1)
    for cy in range(wp.max(by - k, 0), wp.min(by + k, ny - 1) + 1):
        for j in range(cell_start[cy * nx + xa], cell_start[cy * nx + xb + 1]):
            if j != i:
                dx = px - x[j]
                dy = py - y[j]
                d2 = dx * dx + dy * dy
                if d2 < d_rr * d_rr:
                    w = wp.max(w, d_rr - wp.sqrt(d2))
    if w > ctrl_f[OVERLAP]:
        wp.atomic_max(ctrl_f, OVERLAP, w)
