"""Jammed swarms: the contact solve of the mechanism study's slowest combination.

Runs one ``transport-free`` run of the mechanism study's ``quick`` setting (600 robots in
a 1270 mm square arena, the object held for a 100 s warm-up, then free) with the
combination given (default: persistent headings, ``lit_hot``, ideal sensor: the robots
press into the arena's walls and into one another), stepping the engine exactly as the
scenario runner does, and reports per step:

- projection sweeps (mean, 99th percentile, largest, steps that hit ``max_iterations``);
- the exact largest overlap after the step, measured independently: robot pairs by a
  KD-tree (scipy's cKDTree), robots against the arena's segments and against the object;
- wall seconds of the run and microseconds a robot-step (timing, so it lives here and
  not in the tests; the machine is shared: compare ratios from one command);
- the steps that ended holding pushes (warm-started next), and a SHA-256 of the final
  state (positions, headings and speeds in id order, the bodies): two revisions, run
  with ``PYTHONPATH`` at each one's ``src``, solve the jam identically if it matches.

Three solves, one after the other from the same seed: ``jacobi`` (Jacobi sweeps only:
the engine's solve before the Gauss-Seidel passes, bit for bit), ``first`` (the
Gauss-Seidel passes as first made: warm-started steps over-relaxed as cold ones,
``OMEGA``, and measured before every round: the engine at bbd506a, bit for bit) and
``default`` (the engine's solve: warm-started steps over-relaxed by ``WARM_OMEGA``, their
first ``WARM_BLIND`` rounds unmeasured).  A markdown table of the solves run ends the
output.

Usage::

    python benchmarks/engine_jam.py                       # the slowest combination, all
    python benchmarks/engine_jam.py --solve first --solve default
    python benchmarks/engine_jam.py --solve default --duration 150 --set heading_law=uniform
"""

from __future__ import annotations

import argparse
import hashlib
import json
import time

import numpy as np
from scipy.spatial import cKDTree

import thermoswarm.sim.engine as engine
from thermoswarm.scenarios.runner import build, resolve
from thermoswarm.studies.mechanism import SETTINGS

SLOWEST = ("mapping=lit_hot", "heading_law=persistent", "sensor.mode=ideal")


def exact_overlap(pos: np.ndarray, r: float, segments: np.ndarray, bodies: np.ndarray) -> float:
    """Largest overlap (mm) of robots at ``pos`` with each other (KD-tree), with the
    static ``segments`` (x0, y0, x1, y1) and with the movable discs ``bodies`` (x, y, R)."""
    worst = 0.0
    pairs = cKDTree(pos).query_pairs(2 * r, output_type="ndarray")
    if len(pairs):
        d = np.linalg.norm(pos[pairs[:, 0]] - pos[pairs[:, 1]], axis=1)
        worst = float((2 * r - d).max())
    for x0, y0, x1, y1 in segments:
        e = np.array([x1 - x0, y1 - y0])
        t = np.clip(((pos - [x0, y0]) @ e) / max(e @ e, 1e-300), 0.0, 1.0)
        d = np.linalg.norm(pos - ([x0, y0] + t[:, None] * e), axis=1)
        worst = max(worst, float((r - d).max()))
    for bx, by, br in bodies:
        d = np.hypot(pos[:, 0] - bx, pos[:, 1] - by)
        worst = max(worst, float((r + br - d).max()))
    return max(worst, 0.0)


def run(overrides: list[str], duration: float, seed: int, check_every: int) -> dict:
    base = dict(SETTINGS["quick"]["base"])
    base["duration"] = duration
    sets = [f"{k}={str(v).lower() if isinstance(v, bool) else v}" for k, v in base.items()]
    cfg = resolve("transport-free", overrides=[*sets, *SLOWEST, *overrides], seed=seed)
    scen, setup, sim, state = build(cfg)
    acc = scen.init_acc(setup, sim, state)
    r = sim.params.radius
    total = int(round(duration / sim.params.dt))
    sim.step(state)  # compiles (or loads) the kernels: not timed
    scen.observe(sim, state, acc)
    sweeps = np.zeros(total - 1, np.int64)
    worst = 0.0
    wall = 0.0
    held_steps = 0
    for k in range(total - 1):
        before = int(state.counters[0])
        t0 = time.perf_counter()
        sim.step(state)
        scen.observe(sim, state, acc)
        wall += time.perf_counter() - t0
        sweeps[k] = int(state.counters[0]) - before
        held_steps += state.held_pairs is not None
        if k % check_every == 0 or sweeps[k] >= sim.params.max_iterations:
            b = state.bodies[:, [0, 1, 2]]
            worst = max(worst, exact_overlap(state.pos, r, sim.world.segments, b))
    return {
        "robots": state.n,
        "steps": int(total - 1),
        "sweeps_mean": float(sweeps.mean()),
        "sweeps_p99": float(np.percentile(sweeps, 99)),
        "sweeps_max": int(sweeps.max()),
        "steps_at_limit": int((sweeps >= sim.params.max_iterations).sum()),
        "exact_overlap_pct": 100 * worst / (2 * r),
        "engine_overlap_pct": 100 * state.counters[1] / 1e6 / (2 * r),
        "wall_s": wall,
        "us_per_robot_step": 1e6 * wall / (state.n * (total - 1)),
        "held_steps": held_steps,
        "digest": digest(state),
    }


def digest(state) -> str:
    """SHA-256 of the final state: positions, headings and speeds in id order, bodies."""
    h = hashlib.sha256()
    for a in (state.by_id(state.pos), state.by_id(state.heading), state.by_id(state.speed)):
        h.update(np.ascontiguousarray(a).tobytes())
    h.update(np.ascontiguousarray(state.bodies).tobytes())
    return h.hexdigest()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=400.0, help="simulated s (study: 400)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--set", action="append", default=[], help="extra KEY=VALUE overrides")
    ap.add_argument("--check-every", type=int, default=5, help="KD-tree check every K steps")
    ap.add_argument(
        "--solve", action="append", choices=tuple(SOLVES), help="repeatable (default: all)"
    )
    a = ap.parse_args(argv)
    print(" ".join([*SLOWEST, *a.set]), f"seed {a.seed}, {a.duration:g} s")
    rows = []
    for solve in a.solve or SOLVES:
        saved = {k: getattr(engine, k) for k in SOLVES[solve]}
        try:
            for k, v in SOLVES[solve].items():
                setattr(engine, k, getattr(engine, v) if isinstance(v, str) else v)
            out = run(a.set, a.duration, a.seed, a.check_every)
        finally:
            for k, v in saved.items():
                setattr(engine, k, v)
        print(solve, json.dumps(out), flush=True)
        rows.append((solve, out))
    print(table(rows))
    return 0


#: Each solve as the engine's constants it sets (a string: another constant's value).
SOLVES: dict[str, dict[str, object]] = {
    # the Gauss-Seidel passes would start after more sweeps than allowed
    "jacobi": {"GS_AFTER": 10**9},
    "first": {"WARM_OMEGA": "OMEGA", "WARM_BLIND": 0},
    "default": {},
}


def table(rows: list[tuple[str, dict]]) -> str:
    """The solves' results as a markdown table."""
    out = [
        "| solve | sweeps a step: mean / p99 / max | steps at the limit | exact overlap "
        "(KD-tree) | wall s a run | us a robot-step |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for name, r in rows:
        out.append(
            f"| {name} | {r['sweeps_mean']:.1f} / {r['sweeps_p99']:.0f} / {r['sweeps_max']} "
            f"| {r['steps_at_limit']} | {r['exact_overlap_pct']:.5f} % | {r['wall_s']:.1f} "
            f"| {r['us_per_robot_step']:.1f} |"
        )
    return "\n".join(out)


if __name__ == "__main__":
    raise SystemExit(main())
