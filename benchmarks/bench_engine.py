"""Engine benchmark: thermoswarm beside pymunk and NVIDIA Warp (CPU), one command.

Workload: discs of 33 mm at packing fraction PHI in a square walled box, speeds from the
Boltzmann (Rayleigh) law with mean 10 mm/s and uniform headings, both re-drawn every
0.1 s, dt = 0.1 s.  Every tool gets the same initial positions and the same kind of
commands, drawn with NumPy each step inside its timed loop (ours through its policy).

Tools, each at its best as a user would run it:

- **ours**, on 1 thread and on 2 threads (``thermoswarm.sim.set_threads``), each column
  stated as such;
- **pymunk** 7 (Chipmunk2D): dynamic discs with infinite moment, no friction or
  restitution, a spatial hash sized for the discs; the commanded velocities are written
  with its batch API (``pymunk.batch.set_space_bodies``), positions read with
  ``get_space_bodies``; 1 thread, and its threaded solver (``Space(threaded=True)``,
  ``threads = 2``);
- **Warp** (NVIDIA Warp on its CPU device, what a user picks for large particle swarms
  on a GPU): the same overdamped projection as ours written as Warp kernels -- a hash
  grid rebuilt every step, ``--warp-sweeps`` Jacobi sweeps (fixed; Warp offers no
  cheap early exit) -- one CPU thread (Warp runs CPU kernels serially).

Measured for every tool: robot-steps per second of wall time (timed steps only, the
fastest of 3 blocks; the first steps, which compile or warm up, are excluded and their
time is reported as ``compile_seconds``) and the **exact largest overlap**, from a
KD-tree (``scipy.spatial.cKDTree``) after the first step and after each block, for every
tool (ours also reports its own exact per-step maximum).  Sizes a tool cannot run in
reasonable time are skipped and marked so in the table.

Usage::

    python benchmarks/bench_engine.py                      # 1,200 .. 1,000,000; phi 0.18, 0.5
    python benchmarks/bench_engine.py --n 10000 --phi 0.5 --json
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import os
import sys
import time

import numpy as np
from scipy.spatial import cKDTree

from thermoswarm.maxent import SpeedLaw, kT_for_mean_speed
from thermoswarm.sim import set_threads
from thermoswarm.sim.bench import DIAMETER, MEAN_SPEED, workload
from thermoswarm.sim.engine import place_lattice, threads_for

R = DIAMETER / 2
DT = 0.1
#: Wall seconds of timed stepping per tool and configuration, in BLOCKS blocks of at
#: least MIN_STEPS steps each; the fastest block is reported (the machine is shared: a
#: block that another process slowed down says nothing about the tool).
BUDGET = 2.0
BLOCKS = 3
MIN_STEPS = 2
#: Steps every tool runs after its warm-up and before its timed blocks (``--settle``):
#: from the lattice start the contacts take ~150 steps to build up, and a step costs
#: ~1.4x more once they have (1 thread, 100,000 robots at packing 0.5).
SETTLE_STEPS = 0
#: pymunk builds its bodies one by one in Python (about 100 s for 1,000,000): its
#: threaded variant, no faster than one thread from 100,000 robots on, is skipped above.
PYMUNK_THREADED_MAX_N = 100_000


def kd_overlap(pos: np.ndarray, side: float) -> float:
    """Exact largest overlap (mm) between discs and with the box walls."""
    pairs = cKDTree(pos).query_pairs(DIAMETER, output_type="ndarray")
    worst = 0.0
    if len(pairs):
        d = np.linalg.norm(pos[pairs[:, 0]] - pos[pairs[:, 1]], axis=1)
        worst = float((DIAMETER - d).max())
    walls = max(float((R - pos).max()), float((pos - (side - R)).max()))
    return max(worst, walls, 0.0)


def _side(n: int, phi: float) -> float:
    return math.sqrt(n * math.pi * R * R / phi)


def _timed(step, n: int, positions, side: float) -> dict:
    """Warm up, run SETTLE_STEPS steps untimed, then BLOCKS blocks of steps (about BUDGET
    seconds in all); the exact overlap (KD-tree, not timed) before the first block and
    after each block."""
    t0 = time.perf_counter()
    step()  # compiles / warms up
    first = time.perf_counter() - t0
    for _ in range(SETTLE_STEPS):
        step()
    t0 = time.perf_counter()
    step()
    one = time.perf_counter() - t0
    per_block = max(MIN_STEPS, int(BUDGET / BLOCKS / max(one, 1e-6)))
    worst = kd_overlap(positions(), side)
    walls = []
    for _ in range(BLOCKS):
        t0 = time.perf_counter()
        for _ in range(per_block):
            step()
        walls.append(time.perf_counter() - t0)
        worst = max(worst, kd_overlap(positions(), side))
    best = min(walls)
    return {
        "steps": per_block * BLOCKS,
        "block_wall_seconds": walls,
        "compile_seconds": max(0.0, first - one),
        "robot_steps_per_second": n * per_block / best,
        "median_robot_steps_per_second": n * per_block / float(np.median(walls)),
        "simulated_robot_seconds_per_second": n * per_block * DT / best,
        "max_overlap_fraction": worst / DIAMETER,
    }


@functools.lru_cache(maxsize=2)
def _start(n: int, phi: float, seed: int = 0) -> np.ndarray:
    """The initial positions every peer starts from (the engine's own placement)."""
    side = _side(n, phi)
    return place_lattice((0.0, 0.0, side, side), n, R, np.random.default_rng(seed))


# ----------------------------------------------------------------------------- ours
def ours(n: int, phi: float, threads: int) -> dict:
    set_threads(threads)
    try:
        world, sim, state = workload(n, phi, seed=0, dt=DT)
        side = world.bounds[2]
        out = _timed(lambda: sim.step(state), n, lambda: state.pos, side)
        out["engine_max_overlap_fraction"] = state.counters[1] / 1e6 / DIAMETER
        out["threads"] = threads_for(n)
        out["mean_sweeps_per_step"] = state.counters[0] / max(state.step, 1)
        return out
    finally:
        set_threads(None)


# --------------------------------------------------------------------------- pymunk
def pymunk_bench(n: int, phi: float, threads: int, seed: int = 0) -> dict:
    import pymunk
    import pymunk.batch as batch

    side = _side(n, phi)
    rng = np.random.default_rng(seed + 1)
    pos = _start(n, phi)
    space = pymunk.Space(threaded=threads > 1)
    if threads > 1:
        space.threads = threads
    space.gravity = (0.0, 0.0)
    space.use_spatial_hash(2 * R * 1.25, 2 * n)
    corners = [(0, 0), (side, 0), (side, side), (0, side)]
    for a, b in zip(corners, corners[1:] + corners[:1], strict=True):
        seg = pymunk.Segment(space.static_body, a, b, 0.0)
        seg.elasticity, seg.friction = 0.0, 0.0
        space.add(seg)
    for x, y in pos:
        body = pymunk.Body(1.0, math.inf)
        body.position = (float(x), float(y))
        shape = pymunk.Circle(body, R)
        shape.elasticity, shape.friction = 0.0, 0.0
        space.add(body, shape)
    law = SpeedLaw(kT_for_mean_speed(MEAN_SPEED))
    # pymunk's batch calls visit every body of the space, the static body (which holds
    # the walls) last: one spare row for it, and its rows filtered out of the positions
    vel = np.zeros((n + 1, 2))
    vbuf = batch.Buffer()
    vbuf.set_float_buf(vel.reshape(-1))  # pymunk reads the commands from this array
    pbuf = batch.Buffer()
    static_id = space.static_body.id
    fields = batch.BodyFields.POSITION | batch.BodyFields.BODY_ID

    def step() -> None:
        v = law.sample(rng, n)
        th = rng.uniform(-np.pi, np.pi, n)
        np.multiply(v, np.cos(th), out=vel[:n, 0])
        np.multiply(v, np.sin(th), out=vel[:n, 1])
        batch.set_space_bodies(space, batch.BodyFields.VELOCITY, vbuf)
        space.step(DT)

    def positions() -> np.ndarray:
        pbuf.clear()
        batch.get_space_bodies(space, fields, pbuf)
        ids = np.frombuffer(pbuf.int_buf(), dtype=np.uintp)
        xy = np.frombuffer(pbuf.float_buf(), dtype=np.float64).reshape(-1, 2)
        return xy[ids != static_id].copy()

    out = _timed(step, n, positions, side)
    out["threads"] = threads
    return out


# ----------------------------------------------------------------------------- Warp
def warp_bench(n: int, phi: float, sweeps: int, seed: int = 0) -> dict:
    import warp as wp

    wp.config.quiet = True
    wp.init()

    @wp.kernel
    def move(pos: wp.array(dtype=wp.vec3), vel: wp.array(dtype=wp.vec3), dt: float):
        i = wp.tid()
        pos[i] = pos[i] + vel[i] * dt

    @wp.kernel
    def project(
        grid: wp.uint64,
        src: wp.array(dtype=wp.vec3),
        dst: wp.array(dtype=wp.vec3),
        r: float,
        reach: float,
        side: float,
    ):
        tid = wp.tid()
        i = wp.hash_grid_point_id(grid, tid)
        p = src[i]
        corr = wp.vec3(0.0, 0.0, 0.0)
        query = wp.hash_grid_query(grid, p, reach)
        j = int(0)  # noqa: UP018 (Warp: a mutable int, assigned by the query)
        while wp.hash_grid_query_next(query, j):
            if j != i:
                d = p - src[j]
                dist = wp.length(d)
                if dist < 2.0 * r and dist > 1.0e-6:
                    corr = corr + d * (0.5 * (2.0 * r - dist) / dist)
        x = p + corr
        dst[i] = wp.vec3(wp.clamp(x[0], r, side - r), wp.clamp(x[1], r, side - r), 0.0)

    side = _side(n, phi)
    rng = np.random.default_rng(seed + 1)
    p0 = _start(n, phi)
    law = SpeedLaw(kT_for_mean_speed(MEAN_SPEED))
    dev = "cpu"
    host = np.zeros((n, 3), np.float32)
    host[:, :2] = p0
    bufs = [wp.array(host, dtype=wp.vec3, device=dev), wp.zeros(n, dtype=wp.vec3, device=dev)]
    vel_host = np.zeros((n, 3), np.float32)
    vel = wp.array(vel_host, dtype=wp.vec3, device=dev)
    vel_view = vel.numpy()  # CPU arrays share memory with NumPy
    dims = max(1, min(1024, int(side / (2.5 * R))))
    grid = wp.HashGrid(dims, dims, 1, device=dev)
    reach = 2 * R * 1.5  # candidates within 1.5 D of a disc (robots move < D/4 a step)

    def step() -> None:
        v = law.sample(rng, n)
        th = rng.uniform(-np.pi, np.pi, n)
        vel_view[:, 0] = v * np.cos(th)
        vel_view[:, 1] = v * np.sin(th)
        wp.launch(move, dim=n, inputs=[bufs[0], vel, DT], device=dev)
        grid.build(bufs[0], reach)
        for _ in range(sweeps):
            wp.launch(project, dim=n, inputs=[grid.id, bufs[0], bufs[1], R, reach, side])
            bufs.reverse()
        wp.synchronize_device(dev)

    def positions() -> np.ndarray:
        return bufs[0].numpy()[:, :2].astype(np.float64)

    out = _timed(step, n, positions, side)
    out["threads"] = 1
    out["sweeps_per_step"] = sweeps
    return out


# ---------------------------------------------------------------------------- table
def one(n: int, phi: float, tools: list[str], warp_sweeps: int, threaded_max: int) -> dict:
    row: dict = {"n": n, "phi": phi}
    for t in (1, 2):
        if f"ours{t}" in tools:
            row[f"ours_{t}_thread"] = ours(n, phi, t)
    for t in (1, 2):
        if f"pymunk{t}" in tools:
            row[f"pymunk_{t}_thread"] = (
                pymunk_bench(n, phi, t)
                if t == 1 or n <= threaded_max
                else {"skipped": "setup takes minutes"}
            )
    if "warp" in tools:
        row["warp_1_thread"] = warp_bench(n, phi, warp_sweeps)
    return row


COLUMNS = [
    ("ours_1_thread", "ours, 1 thread"),
    ("ours_2_thread", "ours, 2 threads"),
    ("pymunk_1_thread", "pymunk batch, 1 thread"),
    ("pymunk_2_thread", "pymunk batch, threaded (2)"),
    ("warp_1_thread", "Warp CPU (1 thread)"),
]


def _cell(r: dict | None) -> str:
    if r is None:
        return "not run"
    if "skipped" in r:
        return f"skipped ({r['skipped']})"
    return f"{r['robot_steps_per_second'] / 1e6:.2f} M/s, {100 * r['max_overlap_fraction']:.2f} %"


def _ratio(row: dict, a: str, b: str) -> str:
    ra, rb = row.get(a), row.get(b)
    if not ra or not rb or "skipped" in ra or "skipped" in rb:
        return "-"
    return f"{ra['robot_steps_per_second'] / rb['robot_steps_per_second']:.1f}x"


def table(rows: list[dict]) -> str:
    cols = [c for c in COLUMNS if any(c[0] in r for r in rows)]
    head = " | ".join(name for _, name in cols)
    out = [
        "robot-steps per wall second (fastest of 3 blocks), exact max overlap (KD-tree "
        "after the first step and each block, % of D); ratio = ours / peer at the same "
        "thread count",
        "",
        f"| N | phi | {head} | ours/pymunk (1 thr) | ours/pymunk (2 thr) | ours/Warp (1 thr) "
        "| ours sim. robot-s/s (2 thr) | ours bytes/robot | ours cost vs N=1,200 |",
        "|---:|---:|" + "---:|" * (len(cols) + 6),
    ]
    base = {}
    for r in rows:
        o = r.get("ours_1_thread")
        if o and r["n"] == 1200:
            base[r["phi"]] = o["robot_steps_per_second"]
    for r in rows:
        o1, o2 = r.get("ours_1_thread"), r.get("ours_2_thread")
        rel = (
            f"{base[r['phi']] / o1['robot_steps_per_second']:.2f}x"
            if o1 and r["phi"] in base
            else "-"
        )
        sim_rs = f"{o2['simulated_robot_seconds_per_second'] / 1e3:.0f} k" if o2 else "-"
        mem = f"{r['bytes_per_robot']:.0f}" if "bytes_per_robot" in r else "-"
        out.append(
            f"| {r['n']:,} | {r['phi']} | "
            + " | ".join(_cell(r.get(k)) for k, _ in cols)
            + f" | {_ratio(r, 'ours_1_thread', 'pymunk_1_thread')}"
            f" | {_ratio(r, 'ours_2_thread', 'pymunk_2_thread')}"
            f" | {_ratio(r, 'ours_1_thread', 'warp_1_thread')} | {sim_rs} | {mem} | {rel} |"
        )
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, action="append", help="robots (repeatable)")
    ap.add_argument("--phi", type=float, action="append", help="packing fraction (repeatable)")
    ap.add_argument(
        "--tools",
        default="ours1,ours2,pymunk1,pymunk2,warp",
        help="comma-separated subset of ours1,ours2,pymunk1,pymunk2,warp",
    )
    ap.add_argument("--warp-sweeps", type=int, default=8, help="Jacobi sweeps per step in Warp")
    ap.add_argument(
        "--pymunk-threaded-max-n",
        type=int,
        default=PYMUNK_THREADED_MAX_N,
        help="largest swarm for pymunk's threaded variant",
    )
    ap.add_argument(
        "--settle", type=float, default=0.0,
        help="simulated seconds every tool runs before it is timed (default 0: timed from "
        "the start, where contacts are still building up)",
    )  # fmt: skip
    ap.add_argument("--json", action="store_true", help="print JSON instead of a table")
    a = ap.parse_args(argv)
    global SETTLE_STEPS
    SETTLE_STEPS = max(0, round(a.settle / DT))
    ns = a.n or [1_200, 10_000, 100_000, 1_000_000]
    phis = a.phi or [0.18, 0.5]
    tools = [t.strip() for t in a.tools.split(",") if t.strip()]
    import numba

    if numba.config.NUMBA_NUM_THREADS < 2 and "ours2" in tools:
        print("only one Numba thread: the 2-thread column is skipped", file=sys.stderr)
        tools.remove("ours2")
    for mod, names in (("pymunk", ("pymunk1", "pymunk2")), ("warp", ("warp",))):
        try:
            __import__(mod)
        except ImportError:
            if any(t in tools for t in names):
                print(f"{mod} is not installed (pip install thermoswarm[bench]): skipped",
                      file=sys.stderr)  # fmt: skip
            tools = [t for t in tools if t not in names]
    rows = []
    for phi in phis:
        for n in ns:
            row = one(n, phi, tools, a.warp_sweeps, a.pymunk_threaded_max_n)
            from thermoswarm.sim.bench import run_bench

            mem = run_bench(n, phi, seconds=DT, checks=0, memory_steps=2)
            row["bytes_per_robot"] = mem["bytes_per_robot"]
            rows.append(row)
            print(f"  done n={n:,} phi={phi} (load {os.getloadavg()[0]:.1f})", file=sys.stderr)
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
