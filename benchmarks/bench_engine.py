"""Engine benchmark: thermoswarm vs pymunk on the same workload, in one process.

Workload (issue 2): discs of 33 mm at packing fraction PHI in a square walled box, kT
chosen so that the mean speed is 10 mm/s, heading and speed re-sampled every 0.1 s,
dt = 0.1 s; compile time excluded.

pymunk (a maintained 2D physics engine, Chipmunk2D) runs the same workload the way a
user would write it: dynamic discs with infinite moment, no friction or restitution,
each body's velocity set to its commanded velocity every step (the overdamped
analogue), a spatial hash sized for the discs (faster than pymunk's default tree here),
``space.step(dt)``.  pymunk resolves contacts softly, so its overlaps are reported too.

Usage::

    python benchmarks/bench_engine.py                 # the table of issue 2
    python benchmarks/bench_engine.py --n 10000 --phi 0.5 --json
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time

import numpy as np

from thermoswarm.maxent import SpeedLaw, kT_for_mean_speed
from thermoswarm.sim.bench import DIAMETER, MEAN_SPEED, run_bench
from thermoswarm.sim.engine import place_lattice


def pymunk_bench(n: int, phi: float, steps: int, seed: int = 0, dt: float = 0.1) -> dict:
    import pymunk
    from scipy.spatial import cKDTree

    r = DIAMETER / 2
    side = math.sqrt(n * math.pi * r * r / phi)
    rng = np.random.default_rng(seed)
    pos = place_lattice((0.0, 0.0, side, side), n, r, rng)
    space = pymunk.Space()
    space.gravity = (0.0, 0.0)
    space.use_spatial_hash(2 * r * 1.25, 2 * n)
    corners = [(0, 0), (side, 0), (side, side), (0, side)]
    for a, b in zip(corners, corners[1:] + corners[:1], strict=True):
        seg = pymunk.Segment(space.static_body, a, b, 0.0)
        seg.elasticity, seg.friction = 0.0, 0.0
        space.add(seg)
    bodies = []
    for x, y in pos:
        body = pymunk.Body(1.0, math.inf)
        body.position = (float(x), float(y))
        shape = pymunk.Circle(body, r)
        shape.elasticity, shape.friction = 0.0, 0.0
        space.add(body, shape)
        bodies.append(body)
    law = SpeedLaw(kT_for_mean_speed(MEAN_SPEED))

    def command() -> None:
        v = law.sample(rng, n)
        th = rng.uniform(-np.pi, np.pi, n)
        vx, vy = (v * np.cos(th)).tolist(), (v * np.sin(th)).tolist()
        for body, a, b in zip(bodies, vx, vy, strict=True):
            body.velocity = (a, b)

    command()
    space.step(dt)  # warm-up
    t0 = time.perf_counter()
    for _ in range(steps):
        command()
        space.step(dt)
    wall = time.perf_counter() - t0
    p = np.array([b.position for b in bodies])
    d, _ = cKDTree(p).query(p, k=2)
    overlap = max(0.0, float((2 * r - d[:, 1]).max()))
    return {
        "n": n,
        "phi": phi,
        "steps": steps,
        "wall_seconds": wall,
        "robot_steps_per_second": n * steps / wall,
        "simulated_robot_seconds_per_second": n * steps * dt / wall,
        "max_overlap_fraction": overlap / DIAMETER,
    }


def one(n: int, phi: float, with_pymunk: bool = True) -> dict:
    # about 2-4 s of our engine per configuration; pymunk gets a few steps at large n
    ours = run_bench(n, phi, seconds=max(0.5, min(200.0, 3e6 / n)))
    row = {"n": n, "phi": phi, "ours": ours}
    if with_pymunk:
        steps = max(3, min(200, int(2e5 / n)))
        row["pymunk"] = pymunk_bench(n, phi, steps)
        row["speedup_vs_pymunk"] = (
            ours["robot_steps_per_second"] / row["pymunk"]["robot_steps_per_second"]
        )
    return row


def table(rows: list[dict]) -> str:
    base = {r["phi"]: r["ours"]["robot_steps_per_second"] for r in rows if r["n"] == 1200}
    out = [
        "| N | phi | robot-steps/s | sim. robot-s per s | max overlap | bytes/robot "
        "| cost vs N=1,200 | pymunk robot-steps/s | pymunk overlap | speed-up |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        o = r["ours"]
        rel = base.get(r["phi"], o["robot_steps_per_second"]) / o["robot_steps_per_second"]
        pm = r.get("pymunk")
        out.append(
            f"| {r['n']:,} | {r['phi']} | {o['robot_steps_per_second'] / 1e6:.2f} M "
            f"| {o['simulated_robot_seconds_per_second'] / 1e3:.0f} k "
            f"| {100 * o['max_overlap_fraction']:.2f} % | {o['bytes_per_robot']:.0f} "
            f"| {rel:.2f}x "
            + (
                f"| {pm['robot_steps_per_second'] / 1e6:.2f} M "
                f"| {100 * pm['max_overlap_fraction']:.1f} % "
                f"| {r['speedup_vs_pymunk']:.1f}x |"
                if pm
                else "| - | - | - |"
            )
        )
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, action="append", help="robots (repeatable)")
    ap.add_argument("--phi", type=float, action="append", help="packing fraction (repeatable)")
    ap.add_argument("--no-pymunk", action="store_true")
    ap.add_argument("--json", action="store_true", help="print JSON instead of a table")
    a = ap.parse_args(argv)
    ns = a.n or [1_200, 10_000, 100_000, 1_000_000]
    phis = a.phi or [0.18, 0.5]
    try:
        import pymunk  # noqa: F401
    except ImportError:
        if not a.no_pymunk:
            print(
                "pymunk is not installed (pip install thermoswarm[bench]); "
                "running without the baseline",
                file=sys.stderr,
            )
            a.no_pymunk = True
    rows = [one(n, phi, not a.no_pymunk) for phi in phis for n in ns]
    info = {"cpus": os.cpu_count(), "load_average": os.getloadavg()}
    if a.json:
        print(json.dumps({"engine": rows, "machine": info}))
    else:
        print(table(rows))
        print(
            f"\n(cpus: {info['cpus']}, load average at the end: "
            f"{', '.join(f'{x:.1f}' for x in info['load_average'])})"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
