"""Initial positions: non-overlapping discs on a jittered triangular lattice.

:mod:`thermoswarm.sim.engine` re-exports :func:`place_lattice`.  Units: mm.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from thermoswarm.errors import ConfigError

__all__ = ["place_lattice"]


def place_lattice(
    bounds: tuple[float, float, float, float],
    n: int,
    radius: float,
    rng: np.random.Generator,
    *,
    inside: Callable[[np.ndarray], np.ndarray] | None = None,
    jitter: bool = True,
) -> np.ndarray:
    """Place ``n`` non-overlapping discs on a jittered triangular lattice (mm).

    The lattice spacing is the largest that gives at least ``n`` admissible sites in the
    rectangle ``bounds`` shrunk by ``radius`` (and satisfying ``inside(points)`` when given,
    which should also keep discs clear of walls); ``n`` sites are drawn at random and each
    is jittered inside the free space around it, so no two discs overlap.  Raises
    :class:`ConfigError` when ``n`` discs cannot be placed (packing fraction too high).
    """
    if n < 0:
        raise ConfigError(f"number of robots must be non-negative, got {n}")
    if n == 0:
        return np.zeros((0, 2))
    x0, y0, x1, y1 = bounds
    x0, y0, x1, y1 = x0 + radius, y0 + radius, x1 - radius, y1 - radius
    if x1 < x0 or y1 < y0:
        raise ConfigError(f"region {bounds} is smaller than one robot of radius {radius}")

    def sites(a: float) -> np.ndarray:
        dy = a * math.sqrt(3) / 2
        nyr = int(math.floor((y1 - y0) / dy)) + 1
        nxr = int(math.floor((x1 - x0) / a)) + 1
        if nxr * nyr > 50 * n + 1_000_000:
            return np.zeros((nxr * nyr, 2))  # plenty: only the count matters here
        gy, gx = np.mgrid[0:nyr, 0:nxr].astype(np.float64)
        px = x0 + gx * a + (gy % 2) * a / 2
        py = y0 + gy * dy
        pts = np.column_stack([px.ravel(), py.ravel()])
        pts = pts[(pts[:, 0] <= x1) & (pts[:, 1] <= y1)]
        if inside is not None and len(pts):
            pts = pts[inside(pts)]
        return pts

    d = 2 * radius
    hi = math.sqrt((x1 - x0 + d) * (y1 - y0 + d) * 2 / (math.sqrt(3) * n)) * 2 + d
    if len(sites(d * 1.0001)) < n:
        area = (bounds[2] - bounds[0]) * (bounds[3] - bounds[1])
        phi = n * math.pi * radius**2 / area
        raise ConfigError(
            f"cannot place {n} robots of radius {radius} mm in {bounds}: packing fraction "
            f"{phi:.3f} is above what fits (at most {len(sites(d * 1.0001))} robots)"
        )
    lo = d * 1.0001
    for _ in range(60):  # bisection on the spacing
        mid = 0.5 * (lo + hi)
        if len(sites(mid)) >= n:
            lo = mid
        else:
            hi = mid
    a = lo
    pts = sites(a)
    pick = rng.choice(len(pts), size=n, replace=False)
    pts = pts[np.sort(pick)]
    if jitter and a > d:
        room = 0.5 * (a - d) * 0.999
        rr = room * np.sqrt(rng.random(n))
        th = rng.uniform(0, 2 * np.pi, n)
        cand = pts + np.column_stack([rr * np.cos(th), rr * np.sin(th)])
        ok = (cand[:, 0] >= x0) & (cand[:, 0] <= x1) & (cand[:, 1] >= y0) & (cand[:, 1] <= y1)
        if inside is not None:
            ok &= inside(cand)
        pts[ok] = cand[ok]
    return pts
