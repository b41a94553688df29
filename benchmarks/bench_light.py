"""Benchmark of light, shadows and TurnToAngle (thermoswarm.sim.light).

Times ``light_level``, ``turn_to_angle`` (photoresistor mode without and with noise,
ideal mode) and ``sense`` on n robots scattered around one 100 mm disc (the object) and
five wall segments, lit from +y (also a point light, a soft source and robot-on-robot
shadows for ``light_level``).  Timings on shared machines are noisy, so every timing
is also reported as a ratio to two baselines measured in the same process on the same
points:

- ``numpy_distance``: ``np.hypot(x - cx, y - cy)``, one vectorised distance per point;
- ``numpy_shadow``: the same hard-shadow test written as plain vectorised NumPy (one
  pass over all points per occluder), which also checks ``light_level``'s answer.

Same threads on both sides: NumPy's element-wise work runs on one thread, so our
kernels do too by default (``--threads 1``, Numba's thread count); ``--threads N``
times ours on N threads against the same single-threaded NumPy (the JSON's
``numba_threads`` says which).

Usage::

    python benchmarks/bench_light.py [--sizes 100000 1000000] [--repeat 3] [--threads 1]
        [--json]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time

import numba
import numpy as np

from thermoswarm.sim.geometry import Disc, Polyline, Segment, Shapes
from thermoswarm.sim.light import (
    DirectionalLight,
    PointLight,
    SensingParams,
    light_level,
    sense,
    turn_to_angle,
)

LIGHT = DirectionalLight(direction=(0.0, -1.0))
SOFT = DirectionalLight(direction=(0.0, -1.0), angular_radius_deg=2.0)
ARENA = 2000.0  # mm, square side


def scene() -> Shapes:
    """One disc (the object) and five segments (walls and a zig-zag)."""
    return Shapes.from_shapes(
        [
            Disc((0.0, 0.0), 50.0),
            Segment((-600.0, 500.0), (-200.0, 520.0)),
            Segment((300.0, -300.0), (300.0, 200.0)),
            Polyline(((-800.0, -400.0), (-600.0, -250.0), (-400.0, -400.0), (-200.0, -250.0))),
        ]
    )


def numpy_shadow(points: np.ndarray, occ: Shapes, u: np.ndarray) -> np.ndarray:
    """Hard shadows from a directional light toward ``u``, plain vectorised NumPy."""
    px, py = points[:, 0], points[:, 1]
    dark = np.zeros(len(points), dtype=bool)
    for cx, cy, r in occ.discs:
        wx, wy = cx - px, cy - py
        t = wx * u[0] + wy * u[1]
        c = u[0] * wy - u[1] * wx
        dark |= (wx * wx + wy * wy < r * r) | ((t > 0) & (c * c < r * r))
    for ax, ay, bx, by in occ.segments:
        ex, ey = bx - ax, by - ay
        den = u[0] * ey - u[1] * ex
        if den == 0:
            continue
        qx, qy = ax - px, ay - py
        t = (qx * ey - qy * ex) / den
        s = (qx * u[1] - qy * u[0]) / den
        dark |= (t > 0) & (s >= 0) & (s <= 1)
    return np.where(dark, 0.0, 1.0)


def best_time(fn, repeat: int) -> float:
    best = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def bench_size(n: int, occ: Shapes, rng: np.random.Generator, repeat: int, seed: int) -> dict:
    """All timings for ``n`` robots scattered uniformly over the arena."""
    u = np.array([0.0, 1.0])
    pts = rng.uniform(-ARENA / 2, ARENA / 2, (n, 2))
    heading = rng.uniform(-math.pi, math.pi, n)
    base_dist = best_time(lambda: np.hypot(pts[:, 0] - 10.0, pts[:, 1] - 20.0), repeat)
    base_shadow = best_time(lambda: numpy_shadow(pts, occ, u), repeat)
    level = light_level(pts, LIGHT, occ)
    row: dict = {
        "n": n,
        "lit_fraction": float(level.mean()),
        "light_level_mismatches_vs_numpy": int((level != numpy_shadow(pts, occ, u)).sum()),
        "baseline_numpy_distance_s": base_dist,
        "baseline_numpy_shadow_s": base_shadow,
        "timings": {},
    }
    lamp = PointLight(position=(0.0, 1500.0))
    cases = {
        "light_level": lambda: light_level(pts, LIGHT, occ),
        "light_level_point_light": lambda: light_level(pts, lamp, occ),
        "light_level_soft": lambda: light_level(pts, SOFT, occ),
        "light_level_robot_shadows": lambda: light_level(pts, LIGHT, occ, casters=pts),
    }
    modes = {
        "turn_photoresistor": SensingParams(),
        "turn_photoresistor_noisy": SensingParams(noise_mult=0.02, noise_add=0.02),
        "turn_ideal": SensingParams(mode="ideal"),
    }
    for name, params in modes.items():
        cases[name] = lambda p=params: turn_to_angle(
            pts, heading, LIGHT, occ, p, np.random.default_rng(seed)
        )
    cases["sense_photoresistor"] = lambda: sense(pts, heading, LIGHT, occ, SensingParams())
    for name, fn in cases.items():
        t = best_time(fn, repeat)
        row["timings"][name] = {
            "seconds": t,
            "robots_per_s": n / t,
            "ratio_to_numpy_distance": t / base_dist,
            "ratio_to_numpy_shadow": t / base_shadow,
        }
    res = turn_to_angle(pts, heading, LIGHT, occ, SensingParams())
    row["turn_mean_steps"] = float(res.steps.mean())
    row["turn_converged_fraction"] = float(res.converged.mean())
    return row


def run(
    sizes: tuple[int, ...] = (100_000, 1_000_000), repeat: int = 3, seed: int = 0, threads: int = 1
) -> dict:
    """Run the benchmark on ``threads`` Numba threads; returns the JSON-able result (keys in
    docs/light.md)."""
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    occ = scene()
    rng = np.random.default_rng(seed)
    # Warm-up (Numba loads its cache or compiles): timed once, reported separately.
    t0 = time.perf_counter()
    small = rng.uniform(-ARENA / 2, ARENA / 2, (100, 2))
    light_level(small, [LIGHT, SOFT, PointLight(position=(0.0, 1500.0))], occ, casters=small)
    sense(small, np.zeros(100), LIGHT, occ, SensingParams(noise_add=0.01), rng)
    sense(small, np.zeros(100), LIGHT, occ, SensingParams(), rng)
    turn_to_angle(small, np.zeros(100), LIGHT, occ, SensingParams(mode="ideal"))
    warmup = time.perf_counter() - t0
    return {
        "benchmark": "light",
        "python": platform.python_version(),
        "machine": platform.machine(),
        "cpu_count": os.cpu_count(),
        "numba_threads": numba.get_num_threads(),
        "repeat": repeat,
        "seed": seed,
        "scene": {"discs": occ.n_discs, "segments": occ.n_segments, "arena_mm": ARENA},
        "warmup_s": warmup,
        "sizes": [bench_size(n, occ, rng, repeat, seed) for n in sizes],
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[100_000, 1_000_000])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--threads", type=int, default=1, help="Numba threads for ours (NumPy uses one)"
    )
    ap.add_argument("--json", action="store_true", help="print the results as JSON")
    args = ap.parse_args(argv)
    if args.threads < 1:
        print(f"error: --threads {args.threads}: expected 1 or more", file=sys.stderr)
        return 2
    res = run(tuple(args.sizes), args.repeat, args.seed, args.threads)
    if args.json:
        json.dump(res, sys.stdout, indent=2)
        print()
        return 0
    print(
        f"warm-up {res['warmup_s']:.2f} s; scene {res['scene']}; "
        f"ours on {res['numba_threads']} Numba thread(s) of {res['cpu_count']} CPUs, "
        f"NumPy on one"
    )
    for row in res["sizes"]:
        print(
            f"n = {row['n']:,}: numpy distance {row['baseline_numpy_distance_s'] * 1e3:.1f} ms, "
            f"numpy shadow {row['baseline_numpy_shadow_s'] * 1e3:.1f} ms, "
            f"mismatches vs numpy: {row['light_level_mismatches_vs_numpy']}, "
            f"mean turn steps {row['turn_mean_steps']:.1f}"
        )
        for name, t in row["timings"].items():
            print(
                f"  {name:26s} {t['seconds'] * 1e3:9.1f} ms  {t['robots_per_s']:12,.0f} robots/s"
                f"  x{t['ratio_to_numpy_distance']:6.1f} distance  "
                f"x{t['ratio_to_numpy_shadow']:6.2f} numpy shadow"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
