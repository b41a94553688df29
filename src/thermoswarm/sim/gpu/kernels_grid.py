"""The GPU engine's grid: robots sorted by cell, in one cooperative launch.

A rebuild (:func:`rebuild`) is a counting sort, its stages separated by grid-wide
barriers:

1. every cell's count set to zero;
2. each robot takes its cell and an arrival rank in it from an atomic counter;
3. an exclusive prefix sum over the cells turns the counts into ``cell_start``
   (:func:`scan_tiles`): each block loads a tile of ``SCAN_TILE`` counts
   with coalesced reads (consecutive threads, consecutive addresses), scans it in shared
   memory and writes the tile's total; one block scans the totals; every tile adds its
   offset, again coalesced.  (The scan it replaces gave each thread 256 consecutive
   cells: at any instant the threads of a warp read addresses 1 KB apart.)
4. a scatter places every robot; each cell's few robots are put back in their previous
   order (an insertion sort), so the order never depends on how the atomics interleaved;
5. every robot array is gathered into its second buffer in the new order (the host
   swaps the buffers), and the positions become the new build positions.

The sort is O(N + cells) and stable.
"""

from __future__ import annotations

import numpy as np
from numba import cuda

from thermoswarm.sim.gpu.kernels import CUR, D_IN, D_OUT, G_CS, G_X0, G_Y0, cell_of

#: Counts in a tile of the prefix sum (shared memory: 16 KB); a block of ``nt`` threads
#: scans ``SCAN_TILE / nt`` consecutive counts a thread (16 with 256 threads on a GPU).
SCAN_TILE = 4096
#: Largest block (threads) the scan is sized for (a power of 2 up to this).
MAX_THREADS = 256


@cuda.jit(device=True)
def block_scan(tot, tx, nt):
    """Inclusive prefix sum of ``tot[:nt]`` in shared memory (Hillis-Steele; every
    thread of the block calls it)."""
    off = 1
    while off < nt:
        v = tot[tx - off] if tx >= off else 0
        cuda.syncthreads()
        tot[tx] += v
        cuda.syncthreads()
        off *= 2


@cuda.jit(device=True)
def tile_exclusive(a, m, base, buf, tot, tx, nt):
    """Exclusive prefix sum, in place, of the tile ``a[base : base + SCAN_TILE]``
    (entries past ``m`` count as 0); returns the tile's total.  Reads and writes are
    coalesced; the per-thread runs are scanned in shared memory."""
    items = SCAN_TILE // nt
    for q in range(items):
        idx = base + q * nt + tx
        buf[q * nt + tx] = a[idx] if idx < m else 0
    cuda.syncthreads()
    s = 0
    for q in range(items):
        v = buf[tx * items + q]
        buf[tx * items + q] = s
        s += v
    tot[tx] = s
    cuda.syncthreads()
    block_scan(tot, tx, nt)
    off = tot[tx] - s
    for q in range(items):
        buf[tx * items + q] += off
    cuda.syncthreads()
    for q in range(items):
        idx = base + q * nt + tx
        if idx < m:
            a[idx] = buf[q * nt + tx]
    total = tot[nt - 1]
    cuda.syncthreads()
    return total


@cuda.jit(device=True)
def scan_tiles(g, a, m, sums):
    """Exclusive prefix sum of ``a[:m]`` in place, by the whole grid (``g``: its group;
    ``sums`` holds one entry per tile).  Every thread of the grid calls it."""
    tx = cuda.threadIdx.x
    nt = cuda.blockDim.x
    bid = cuda.blockIdx.x
    width = SCAN_TILE
    items = width // nt
    tiles = (m + width - 1) // width
    buf = cuda.shared.array(SCAN_TILE, np.int32)
    tot = cuda.shared.array(MAX_THREADS, np.int32)
    for t in range(bid, tiles, cuda.gridDim.x):
        total = tile_exclusive(a, m, t * width, buf, tot, tx, nt)
        if tx == 0:
            sums[t] = total
    g.sync()
    if bid == 0:  # one block: the tiles' totals, in order, with a running carry
        carry = 0
        for base in range(0, tiles, width):
            total = tile_exclusive(sums, tiles, base, buf, tot, tx, nt)
            for q in range(items):
                idx = base + q * nt + tx
                if idx < tiles:
                    sums[idx] += carry
            carry += total
            cuda.syncthreads()
    g.sync()
    for t in range(bid, tiles, cuda.gridDim.x):
        off = sums[t]
        for q in range(items):
            idx = t * width + q * nt + tx
            if idx < m:
                a[idx] += off


@cuda.jit
def rebuild(x, y, x2, y2, xr, yr, geo, nx, ny, keys, slot, cell_start, sums, perm,
            f_a, f_b, f_a2, f_b2, i_a, i_b, i_c, i_a2, i_b2, i_c2, ctrl, cur):  # fmt: skip
    """Sort the robots by grid cell (counting sort, stable; see the module doc) and
    gather every robot array into its second buffer in that order: positions into
    ``(x2, y2)`` and the build positions ``(xr, yr)``, the float arrays ``f_a, f_b``
    into ``f_a2, f_b2``, the int arrays ``i_a, i_b, i_c`` into ``i_a2, i_b2, i_c2``.
    ``perm[k]``: the robot now at place ``k``.  The control block's displacement bounds
    restart at 0 and its current buffer becomes ``cur``."""
    g = cuda.cg.this_grid()
    tid = cuda.grid(1)
    nth = cuda.gridsize(1)
    n = x.shape[0]
    m = cell_start.shape[0]
    for c in range(tid, m, nth):
        cell_start[c] = 0
    g.sync()
    for i in range(tid, n, nth):
        cx, cy = cell_of(x[i], y[i], geo[G_X0], geo[G_Y0], geo[G_CS], nx, ny)
        c = cy * nx + cx
        keys[i] = c
        slot[i] = cuda.atomic.add(cell_start, c, 1)
    g.sync()
    scan_tiles(g, cell_start, m, sums)  # counts -> starts; the last is n
    g.sync()
    for i in range(tid, n, nth):
        perm[cell_start[keys[i]] + slot[i]] = i
    g.sync()
    for c in range(tid, m - 1, nth):  # each cell's robots back in their previous order
        lo = cell_start[c]
        for k in range(lo + 1, cell_start[c + 1]):
            v = perm[k]
            j = k - 1
            while j >= lo and perm[j] > v:
                perm[j + 1] = perm[j]
                j -= 1
            perm[j + 1] = v
    g.sync()
    for k in range(tid, n, nth):
        j = perm[k]
        px = x[j]
        py = y[j]
        x2[k] = px
        y2[k] = py
        xr[k] = px
        yr[k] = py
        f_a2[k] = f_a[j]
        f_b2[k] = f_b[j]
        i_a2[k] = i_a[j]
        i_b2[k] = i_b[j]
        i_c2[k] = i_c[j]
    if tid == 0:
        ctrl[D_IN] = 0.0
        ctrl[D_OUT] = 0.0
        ctrl[CUR] = cur
