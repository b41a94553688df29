"""The GPU engine's device arrays (struct of arrays, float32 positions; see
:mod:`thermoswarm.sim.gpu.kernels`)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from thermoswarm.errors import ConfigError
from thermoswarm.sim import kernels as K
from thermoswarm.sim.gpu import kernels as G
from thermoswarm.sim.gpu.kernels_grid import SCAN_TILE
from thermoswarm.sim.gpu.kernels_gs import CAP
from thermoswarm.sim.gpu.runtime import cuda
from thermoswarm.sim.world import World

__all__ = ["Device"]


class Device:
    """The device arrays of one swarm (struct of arrays, float32 positions)."""

    def __init__(self, sim: Any, n: int) -> None:
        p = sim.params
        w = sim.world
        r = p.radius
        x0, y0, x1, y1 = w.bounds
        self.origin = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
        area = (x1 - x0) * (y1 - y0)
        cutoff = 2 * r * (1 + p.skin)
        cs = p.cell_size or max(cutoff, math.sqrt(area / max(n, 1)))
        self.cs = cs
        self.nx = int(math.ceil((x1 - x0) / cs)) + 2  # one cell of margin on every side
        self.ny = int(math.ceil((y1 - y0) / cs)) + 2
        ncell = self.nx * self.ny
        if ncell > 50 * max(n, 1) + 10_000:
            raise ConfigError(
                f"grid of {ncell} cells is too large for {n} robots; increase cell_size"
            )
        gx0 = x0 - cs - self.origin[0]
        gy0 = y0 - cs - self.origin[1]
        self.gx0, self.gy0 = gx0, gy0
        eps = 1e-3
        # rebuild once a robot may have moved so far that one ring no longer suffices
        self.rebuild_at = max(0.0, (cs / (1 + eps) - 2 * r) / 2)

        def z(shape, dtype):
            return cuda.to_device(np.zeros(shape, dtype))

        f4, i4 = np.float32, np.int32
        self.x = [z(n, f4), z(n, f4)]
        self.y = [z(n, f4), z(n, f4)]
        self.cur = 0
        self.xr = z(n, f4)
        self.yr = z(n, f4)
        self.heading = z(n, f4)
        self.speed = z(n, f4)
        self.timer = z(n, i4)
        self.ids = z(n, i4)
        self.group = z(n, i4)
        # counting-sort buffers (cell, rank in cell, permutation); after a sort the first
        # two and the other scratch arrays take the gathered robot arrays (swapped in)
        self.keys = z(n, i4)
        self.slot = z(n, i4)
        self.iscratch = z(n, i4)
        self.perm = z(n, i4)
        self.fscratch = z(n, f4)
        self.fscratch2 = z(n, f4)
        self.cell_start = z(ncell + 1, i4)
        self.scan = z(-(-(ncell + 1) // SCAN_TILE), i4)  # one per tile of the scan
        self.cell_flag = cuda.to_device(self._cell_flags(w, r * (1 + p.skin)))
        c2 = (2 * r - K.SLOP) ** 2
        self.geo = cuda.to_device(np.array([gx0, gy0, cs, r, eps, c2], f4))
        self.ctrl = z(G.N_CTRL, f4)
        o = self.origin
        seg = w.segments - np.concatenate([o, o])
        self.seg = cuda.to_device(np.ascontiguousarray(seg.astype(f4).reshape(-1, 4)))
        sd = w.static_discs.copy()
        sd[:, :2] -= o
        self.sdisc = cuda.to_device(np.ascontiguousarray(sd.astype(f4).reshape(-1, 3)))
        nb, npis = len(w.bodies), len(w.pistons)
        self.bodies = z((nb, K.B_COLS), f4)
        self.pistons = z((npis, K.P_COLS), f4)
        # bodies' and pistons' contact sums (count, overlap), this sweep's contact
        # forces, and whether each moved (rows: bodies, then pistons)
        self.acc = z((nb + npis, 3), np.float64)
        self.contact = z((nb + npis, 2), np.float64)
        self.moved = z(nb + npis, np.uint8)
        self.has_bodies = nb + npis > 0
        self.need_rebuild = True
        self.n = n
        # held pushes (two sets: a rebuild gathers one into the other), from the first jam
        self.tables: list | None = None
        self.tables2: list | None = None

    def alloc_tables(self) -> None:
        """The held-push tables (``nbr``, ``lam``, ``lamw``, ``lamid``; see
        :mod:`thermoswarm.sim.gpu.kernels_gs`), twice, when first needed."""
        if self.tables is not None:
            return
        n = self.n

        def one() -> list:
            return [
                cuda.to_device(np.full((n, CAP), -1, np.int32)),
                cuda.to_device(np.zeros((n, CAP), np.float32)),
                cuda.to_device(np.zeros((2, n), np.float32)),
                cuda.to_device(np.full((2, n), -1, np.int32)),
            ]

        self.tables = one()
        self.tables2 = one()

    def _cell_flags(self, w: World, reach: float) -> np.ndarray:
        """1 for the cells within ``reach`` of a static segment or disc (the CPU
        engine's rule): robots elsewhere skip the static geometry."""
        nx, ny, cs = self.nx, self.ny, self.cs
        gx0 = self.gx0 + self.origin[0]
        gy0 = self.gy0 + self.origin[1]
        flags = np.zeros((ny, nx), np.uint8)
        half_diag = 0.7072 * cs
        for xa, ya, xb, yb in w.segments:
            lo_x, hi_x = min(xa, xb) - reach, max(xa, xb) + reach
            lo_y, hi_y = min(ya, yb) - reach, max(ya, yb) + reach
            i0 = max(0, int(math.floor((lo_x - gx0) / cs)))
            i1 = min(nx - 1, int(math.floor((hi_x - gx0) / cs)))
            j0 = max(0, int(math.floor((lo_y - gy0) / cs)))
            j1 = min(ny - 1, int(math.floor((hi_y - gy0) / cs)))
            if i1 < i0 or j1 < j0:
                continue
            mx = gx0 + (np.arange(i0, i1 + 1) + 0.5) * cs
            my = gy0 + (np.arange(j0, j1 + 1) + 0.5) * cs
            MX, MY = np.meshgrid(mx, my)
            ex, ey = xb - xa, yb - ya
            l2 = ex * ex + ey * ey
            t = np.clip(((MX - xa) * ex + (MY - ya) * ey) / l2, 0, 1) if l2 > 0 else 0.0
            d = np.hypot(MX - (xa + t * ex), MY - (ya + t * ey))
            flags[j0 : j1 + 1, i0 : i1 + 1] |= (d < reach + half_diag).astype(np.uint8)
        for sx, sy, sr in w.static_discs:
            R = sr + reach
            i0 = max(0, int(math.floor((sx - R - gx0) / cs)))
            i1 = min(nx - 1, int(math.floor((sx + R - gx0) / cs)))
            j0 = max(0, int(math.floor((sy - R - gy0) / cs)))
            j1 = min(ny - 1, int(math.floor((sy + R - gy0) / cs)))
            flags[j0 : j1 + 1, i0 : i1 + 1] = 1
        return flags.ravel()

    @property
    def nbytes(self) -> int:
        total = 0
        for v in vars(self).values():
            for a in v if isinstance(v, list) else ([] if v is None else [v]):
                if hasattr(a, "copy_to_host"):  # a device array
                    total += a.size * a.dtype.itemsize
        return total
