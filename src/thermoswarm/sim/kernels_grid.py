"""Kernels of the engine, stage 1: the state's layout, the cell grid, re-sorting robots
by cell and the Verlet neighbour lists (see :mod:`thermoswarm.sim.kernels`)."""

from __future__ import annotations

import math
import types
from typing import NamedTuple

import numpy as np
from llvmlite import ir
from numba import njit, prange
from numba import types as nbtypes
from numba.core import cgutils
from numba.extending import intrinsic

INF = np.inf

# ----------------------------------------------------------------------- layouts
#: Rows of ``SwarmState.fcols`` (float64).
HEADING, SPEED = 0, 1
#: Rows of ``SwarmState.icols`` (int32): permanent id, scenario label, steps left in the
#: current control period.
ID, GROUP, TIMER = 0, 1, 2

#: Columns of the packed movable bodies (``SwarmState.bodies``, one row per body).
BODY_X, BODY_Y, BODY_RADIUS, BODY_DRAG = 0, 1, 2, 3
BODY_FORCE_X, BODY_FORCE_Y = 4, 5  # external force, set by a scenario
BODY_CONTACT_X, BODY_CONTACT_Y = 6, 7  # the robots' mean contact force in the last step
BODY_STEP_X, BODY_STEP_Y = 8, 9  # the body's move in the current sweep (internal)
BODY_SHARE = 10  # the share of an overlap a robot touching it takes (internal)
BODY_COLUMNS = 11

#: Columns of the packed force-driven walls (``SwarmState.pistons``, one row per wall).
PISTON_AXIS, PISTON_POSITION, PISTON_SIDE, PISTON_LO, PISTON_HI = 0, 1, 2, 3, 4
PISTON_DRAG, PISTON_FORCE, PISTON_MIN, PISTON_MAX = 5, 6, 7, 8
PISTON_CONTACT = 9  # the robots' mean contact force in the last step (along the axis)
PISTON_STEP, PISTON_SHARE = 10, 11  # internal, as for bodies
PISTON_COLUMNS = 12

# The short names of the same columns, kept for code written against them.
BX, BY, BR, BDRAG, BFX, BFY, BCX, BCY, BDX, BDY, BSH = range(BODY_COLUMNS)
B_COLS = BODY_COLUMNS
PA, PP, PS, PLO, PHI, PDRAG, PF, PLL, PLH, PC, PD, PSH = range(PISTON_COLUMNS)
P_COLS = PISTON_COLUMNS

# Bits of the per-robot sweep flags.
MOVED, OVERLAPPING = 1, 2

#: Contacts closer than this to touching (mm) count as touching, not overlapping.  A
#: corrected pair ends at contact up to round-off (1e-13 mm at 1 m from the origin); without
#: this slop those round-off overlaps would be "corrected" forever, each correction too small
#: to move a robot, keeping its neighbours in every sweep.
SLOP = 1e-9


class Grid(NamedTuple):
    """The cell grid: cell ``(cx, cy)`` covers ``[x0 + cx cs, x0 + (cx + 1) cs)`` (and so
    for y); index ``cy * nx + cx``.  Positions outside are clamped to the border cells."""

    x0: float
    y0: float
    cell_size: float
    nx: int
    ny: int


class Numerics(NamedTuple):
    """What one overdamped step needs besides arrays (lengths in mm, times in s)."""

    radius: float
    drag: float
    dt: float
    tol: float  # stop sweeping once the largest overlap is below this (mm)
    relax: float
    cutoff: float  # neighbour-list reach: 2 radius + skin
    half_skin: float  # rebuild once any robot is farther than this from where it was
    min_sweeps: int
    max_sweeps: int
    slack_tol: float  # stop sweeping once no held push unneeded by more than this (mm)
    keep: float  # fraction of the last step's held pushes a jammed step starts from


def serial_twin(kernel, name: str):
    """The same kernel compiled without ``parallel``: its ``prange`` loops run as plain
    loops.  On one thread this skips the parallel launch (the scheduler, a reduction's
    per-thread arrays: ~1-3 us a call), which is most of a small swarm's fixed cost a
    step (a step makes several sweeps).  The twin is its own function, ``name``, so
    that Numba's on-disk cache, which keys a function by its qualified name and not by
    its compile flags, keeps the two apart.  Results are bit-identical: every parallel
    loop writes only its own elements (or, like the sweep's marks, the same value
    whoever writes it) and reduces by maxima only.
    """
    f = kernel.py_func
    twin = types.FunctionType(f.__code__, f.__globals__, name, f.__defaults__, f.__closure__)
    twin.__qualname__ = name
    twin.__doc__ = f"{f.__name__} on one thread (see :func:`serial_twin`)."
    return njit(cache=True)(twin)


@intrinsic
def prefetch(typingctx, arr, row):
    """Ask the CPU to start loading ``arr[row]`` (its first element: the row's cache
    line) into cache, without waiting for it: LLVM's ``llvm.prefetch`` (read, high
    locality), which Numba does not expose.  No effect on results; an index past the end
    is never dereferenced (a prefetch does not fault) but is not made here either."""
    if not isinstance(arr, nbtypes.Array):
        return None

    def codegen(context, builder, signature, args):
        aryty, rowty = signature.args
        ary = context.make_array(aryty)(context, builder, args[0])
        first = [context.cast(builder, args[1], rowty, nbtypes.intp)]
        first += [context.get_constant(nbtypes.intp, 0)] * (aryty.ndim - 1)
        ptr = cgutils.get_item_pointer2(
            context, builder, ary.data, cgutils.unpack_tuple(builder, ary.shape),
            cgutils.unpack_tuple(builder, ary.strides), aryty.layout, first,
            wraparound=False, boundscheck=False,
        )  # fmt: skip
        i32 = ir.IntType(32)
        ptr = builder.bitcast(ptr, ir.IntType(8).as_pointer())  # one declaration for all
        fnty = ir.FunctionType(ir.VoidType(), [ptr.type, i32, i32, i32])
        fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.prefetch.p0")
        builder.call(fn, [ptr, ir.Constant(i32, 0), ir.Constant(i32, 3), ir.Constant(i32, 1)])
        return context.get_dummy_value()

    return nbtypes.void(arr, row), codegen


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
def _compute_cells(pos, grid, cell):
    inv_cs = 1.0 / grid.cell_size
    for i in prange(pos.shape[0]):
        cx, cy = _cell_xy(pos[i, 0], pos[i, 1], grid.x0, grid.y0, inv_cs, grid.nx, grid.ny)
        cell[i] = cy * grid.nx + cx


@njit(cache=True)
def _counting_sort(cell, ncell, cell_start, perm):
    """Stable counting sort: ``perm[k]`` is the row of the k-th robot in cell order, and
    ``perm[cell_start[c]:cell_start[c + 1]]`` are the rows in cell ``c``."""
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
def _permute_pairs(a, perm, tmp):
    """Rows of the (n, 2) array ``a`` in the order ``perm`` (through ``tmp``, same shape)."""
    n = a.shape[0]
    for k in prange(n):
        tmp[k, 0] = a[perm[k], 0]
        tmp[k, 1] = a[perm[k], 1]
    for k in prange(n):
        a[k, 0] = tmp[k, 0]
        a[k, 1] = tmp[k, 1]


@njit(cache=True, parallel=True)
def _permute(a, perm, tmp):
    """``a`` (n,) in the order ``perm``, through the float64 buffer ``tmp`` (exact for
    float32 and int32 values)."""
    n = a.shape[0]
    for k in prange(n):
        tmp[k] = a[perm[k]]
    for k in prange(n):
        a[k] = tmp[k]


@njit(cache=True)
def sort_by_cell(pos, rows_f8, rows_i4, grid, cell, cell_start, perm, tmp2):
    """Re-order robots by grid cell.  ``rows_f8`` (k, n) and ``rows_i4`` (m, n) are
    per-robot rows re-ordered too; ``tmp2`` is an (n, 2) float64 scratch buffer.

    On return ``cell`` and ``cell_start`` describe the sorted order (``perm`` is the
    permutation that was applied)."""
    n = pos.shape[0]
    _compute_cells(pos, grid, cell)
    _counting_sort(cell, grid.nx * grid.ny, cell_start, perm)
    _permute_pairs(pos, perm, tmp2)
    tmp = tmp2.reshape(2 * n)[:n]
    for j in range(rows_f8.shape[0]):
        _permute(rows_f8[j], perm, tmp)
    for j in range(rows_i4.shape[0]):
        _permute(rows_i4[j], perm, tmp)
    _permute(cell, perm, tmp)


# ------------------------------------------------------ phase 2: neighbour lists
#: Re-sort the rows only once more than this fraction of them are out of place: in a
#: grid row two or more rows from those of both rows beside them in memory.  The
#: sweeps (in row order) and the list builds (in cell order) keep the few grid rows
#: around the current one in cache, so a robot still within a row of its place costs
#: nothing, while a re-sort streams every per-robot array twice; robots drift two
#: cells in tens to hundreds of steps, and the lists are rebuilt every few.
RESORT_MISPLACED = 1.0 / 256
#: Swarms smaller than this re-sort at every rebuild, as before the rule above: their
#: arrays stay in cache, so a re-sort costs little, and their trajectories (the
#: scenarios', the tests') stay bit-identical to those of earlier versions.
RESORT_LAZY_FROM = 20_000


@njit(cache=True)
def _misplaced(cell, nx):
    """Rows whose grid row is two or more from the grid rows of both rows beside them."""
    n = cell.shape[0]
    bad = 0
    for i in range(1, n - 1):
        cy = cell[i] // nx
        bad += (abs(cy - cell[i - 1] // nx) > 1) & (abs(cy - cell[i + 1] // nx) > 1)
    return bad


@njit(cache=True)
def sort_rows(pos, fcols, icols, udir, lamw, lamid, scratch, grid, cell, cell_start, perm):
    """Re-order every per-robot array of the state by grid cell (in place, through the
    (n, 2) float64 ``scratch``), so that neighbours are near in memory -- from
    :data:`RESORT_LAZY_FROM` robots on, only once more than :data:`RESORT_MISPLACED` of
    the rows are out of place; otherwise ``perm`` is the identity and nothing moves.
    (The held pair pushes are keyed by list slots: :func:`_restore_held` moves them.)
    Returns whether the rows were re-ordered."""
    n = pos.shape[0]
    _compute_cells(pos, grid, cell)
    if n >= RESORT_LAZY_FROM and _misplaced(cell, grid.nx) <= RESORT_MISPLACED * n:
        for k in range(n):
            perm[k] = k
        return False
    _counting_sort(cell, grid.nx * grid.ny, cell_start, perm)
    _permute_pairs(pos, perm, scratch)
    tmp = scratch.reshape(2 * n)[:n]
    for j in range(fcols.shape[0]):
        _permute(fcols[j], perm, tmp)
    for j in range(icols.shape[0]):
        _permute(icols[j], perm, tmp)
    for j in range(udir.shape[0]):
        _permute(udir[j], perm, tmp)
    for j in range(lamw.shape[0]):
        _permute(lamw[j], perm, tmp)
        _permute(lamid[j], perm, tmp)
    return True


@njit(cache=True, parallel=True)
def _fill_lists(at, grid, cell_start, perm, cutoff, nbr, nnb):
    """Every robot within ``cutoff`` of each robot, at positions ``at`` (both directions).

    Robots in cell order (``perm``) make the three cells of a grid row next to a robot one
    contiguous range: three ranges per robot instead of nine cells.  A robot with more
    neighbours than the capacity gets ``nnb = capacity + 1`` (the sweeps then scan the
    grid for it).
    """
    cap = nbr.shape[1]
    c2 = cutoff * cutoff
    nx = grid.nx
    ny = grid.ny
    overflows = 0
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
            for ki in range(a, b):
                i = perm[ki]
                px = at[i, 0]
                py = at[i, 1]
                k = 0
                for ccy in range(ya, yb + 1):
                    k0 = cell_start[ccy * nx + xa]
                    k1 = cell_start[ccy * nx + xb + 1]
                    for kj in range(k0, k1):
                        j = perm[kj]
                        dx = px - at[j, 0]
                        dy = py - at[j, 1]
                        # branch-free: write every candidate at the end of the list and
                        # keep it only if it is in reach (a third are: a branch on it
                        # mispredicts), 3.6x faster
                        if k < cap:
                            nbr[i, k] = j
                        k += (dx * dx + dy * dy < c2) & (j != i)
                nnb[i] = k if k <= cap else cap + 1
                overflows += 1 if k > cap else 0
    return overflows


@njit(cache=True, parallel=True)
def _copy_pairs(src, dst):
    for i in prange(src.shape[0]):
        dst[i, 0] = src[i, 0]
        dst[i, 1] = src[i, 1]


@njit(cache=True)
def build_lists(at, ref, grid, cutoff, cell, cell_start, perm, nbr, nnb):
    """Neighbour lists at positions ``at``; ``ref`` (may be ``at`` itself) records them.

    ``cell[i]`` is robot i's cell at ``at`` and ``perm``/``cell_start`` the cell order: the
    lists are a function of ``at`` and the row order only.  Returns the number of robots
    whose list overflowed.
    """
    _compute_cells(at, grid, cell)
    _counting_sort(cell, grid.nx * grid.ny, cell_start, perm)
    _copy_pairs(at, ref)
    return _fill_lists(at, grid, cell_start, perm, cutoff, nbr, nnb)


@njit(cache=True)
def _cell_range(lo, hi, origin, cs, ncell):
    a = int(math.floor((lo - origin) / cs))
    b = int(math.floor((hi - origin) / cs))
    return max(a, 0), min(b, ncell - 1)
