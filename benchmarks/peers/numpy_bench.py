"""NumPy + SciPy cKDTree: move, then Jacobi projection sweeps over the pairs found."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from thermoswarm.maxent import SpeedLaw, kT_for_mean_speed
from thermoswarm.sim.bench import DIAMETER, MEAN_SPEED

from .timing import DT, R, side_of, start_positions, timed


def numpy_bench(n: int, phi: float, seed: int = 0) -> dict:
    """The baseline a researcher writes in an afternoon: move, then Jacobi projection
    sweeps over the pairs ``cKDTree.query_pairs`` finds (half the overlap each, walls by
    clipping) until the largest overlap is below our tolerance (0.5 % of D), at most
    500 sweeps; one thread."""
    side = side_of(n, phi)
    rng = np.random.default_rng(seed + 1)
    law = SpeedLaw(kT_for_mean_speed(MEAN_SPEED))
    pos = start_positions(n, phi).copy()
    tol = 0.005 * DIAMETER
    sweeps = [0]

    def step() -> None:
        v = law.sample(rng, n)
        th = rng.uniform(-np.pi, np.pi, n)
        pos[:, 0] += v * np.cos(th) * DT
        pos[:, 1] += v * np.sin(th) * DT
        for _ in range(500):
            np.clip(pos, R, side - R, out=pos)
            sweeps[0] += 1
            pairs = cKDTree(pos).query_pairs(DIAMETER, output_type="ndarray")
            if not len(pairs):
                break
            d = pos[pairs[:, 0]] - pos[pairs[:, 1]]
            dist = np.hypot(d[:, 0], d[:, 1])
            ov = DIAMETER - dist
            if ov.max() < tol:
                break
            corr = d * (0.5 * ov / np.maximum(dist, 1e-12))[:, None]
            for c in range(2):
                pos[:, c] += np.bincount(pairs[:, 0], corr[:, c], n)
                pos[:, c] -= np.bincount(pairs[:, 1], corr[:, c], n)

    out = timed(step, n, lambda: pos, side)
    out.update(threads=1, mean_sweeps_per_step=sweeps[0] / max(out["steps"], 1))
    return out
