"""An independent exact check of overlaps on the host (SciPy's cKDTree), for tests and
benchmarks of any engine: it shares no code with the engines' pair search."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from thermoswarm.sim import kernels as K
from thermoswarm.sim.world import World

__all__ = ["exact_max_overlap"]


def _segment_overlap(pos: np.ndarray, seg: np.ndarray, r: float) -> float:
    worst = 0.0
    for x0, y0, x1, y1 in seg:
        ex, ey = x1 - x0, y1 - y0
        l2 = ex * ex + ey * ey
        t = np.clip(((pos[:, 0] - x0) * ex + (pos[:, 1] - y0) * ey) / l2, 0, 1) if l2 else 0.0
        d = np.hypot(pos[:, 0] - (x0 + t * ex), pos[:, 1] - (y0 + t * ey))
        worst = max(worst, float(np.max(r - d, initial=0.0)))
    return worst


def exact_max_overlap(
    world: World,
    pos: np.ndarray,
    radius: float,
    bodies: np.ndarray | None = None,
    pistons: np.ndarray | None = None,
) -> dict[str, float]:
    """Largest overlap (mm) of robots of ``radius`` at ``pos`` (n, 2) with each other
    (nearest neighbour from a k-d tree: exact), static segments and discs, bodies
    (packed as ``SwarmState.bodies``) and pistons (``SwarmState.pistons``).

    Returns ``{"robots", "walls", "bodies", "pistons", "max"}``.
    """
    pos = np.asarray(pos, dtype=np.float64).reshape(-1, 2)
    out = {"robots": 0.0, "walls": 0.0, "bodies": 0.0, "pistons": 0.0}
    if pos.shape[0] >= 2:
        d, _ = cKDTree(pos).query(pos, k=2, workers=-1)
        out["robots"] = max(0.0, 2 * radius - float(d[:, 1].min()))
    if pos.shape[0]:
        w = _segment_overlap(pos, world.segments, radius)
        for sx, sy, sr in world.static_discs:
            d = np.hypot(pos[:, 0] - sx, pos[:, 1] - sy)
            w = max(w, float(np.max(sr + radius - d, initial=0.0)))
        out["walls"] = w
        for b in np.zeros((0, K.B_COLS)) if bodies is None else bodies:
            d = np.hypot(pos[:, 0] - b[K.BX], pos[:, 1] - b[K.BY])
            out["bodies"] = max(out["bodies"], float(np.max(b[K.BR] + radius - d, initial=0)))
        for p in np.zeros((0, K.P_COLS)) if pistons is None else pistons:
            a = int(p[K.PA])
            q = pos[:, 1 - a]
            inside = (q >= p[K.PLO]) & (q <= p[K.PHI])
            gap = p[K.PS] * (pos[inside, a] - p[K.PP])
            out["pistons"] = max(out["pistons"], float(np.max(radius - gap, initial=0.0)))
    out["max"] = max(out.values())
    return out
