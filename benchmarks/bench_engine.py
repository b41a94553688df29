"""Engine benchmark: thermoswarm beside JAX-MD, VMAS, NumPy + cKDTree and pymunk (CPU).

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
- **NumPy + SciPy cKDTree**: move, then Jacobi projection sweeps over the pairs
  ``query_pairs`` finds until the largest overlap is below our tolerance (0.5 % of D);
- **JAX-MD** (``energy.soft_sphere_neighbor_list``, its cell-list neighbour list, ``jit``
  and ``lax.fori_loop``): overdamped Euler of soft discs under the commanded velocity,
  ``--jaxmd-substeps`` sub-steps per 0.1 s step with the stiffness each sub-step allows
  (``JAXMD_STIFFNESS``); its overlap falls with the sub-steps (about our 0.5 % at 50);
  compile time excluded and reported; on 1 and on 2 XLA threads (``XLA_FLAGS``);
- **VMAS** (its own penalty collisions, ``World.step``): as one world of N agents (timed
  at ``VMAS_ONE_WORLD_N`` agents: it checks every pair) and as N / 12 batched worlds of 12
  agents each; on 1 and on 2 torch threads (``torch.set_num_threads``).

Every cell (one tool, one size, one thread count) runs in a process of its own, so that
its threads (XLA's flags are read at import) and its memory are its own.  Measured for
every tool: robot-steps per second of wall time (timed steps only: the first step,
which compiles or warms up, is excluded and reported as ``compile_seconds``; then
``--settle`` untimed steps, stopped at half the budget; then the fastest of 3 blocks
filling ``--budget-s``, or one block of 2 steps where a step is too long for more), the
**exact largest overlap** of the final state from a KD-tree
(``scipy.spatial.cKDTree``), for every tool (ours also reports its own exact per-step
maximum), CPU seconds per wall second while timed, and bytes per robot (the peak
resident set's growth from just before the swarm is built, over N).  A cell whose
estimate from the tool's largest size so far passes ``--max-cell-s`` is not run and
says so, with the estimate ("est. 7 h a run of 20 steps"); VMAS as one world is timed
at 120 agents and estimated as N^2 above.

Each tool is one module of ``benchmarks/peers/`` (``peers/timing.py``: the timed loop
and the measures they share); this script runs the cells, estimates the ones it skips,
and prints the tables.

Usage::

    python benchmarks/bench_engine.py                      # 1,200 .. 1,000,000; phi 0.18, 0.5
    python benchmarks/bench_engine.py --phi 0.5 --budget-s 10   # the table the README quotes
    python benchmarks/bench_engine.py --n 10000 --phi 0.5 --json
    python benchmarks/bench_engine.py --ours-only --settle 20 --phi 0.5   # cost vs N
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import os
import sys
import time

import numpy as np

from peers import timing as T
from peers.jaxmd_bench import JAXMD_SUBSTEPS, XLA_FLAGS, jaxmd_bench
from peers.numpy_bench import numpy_bench
from peers.ours import ours
from peers.pymunk_bench import pymunk_bench
from peers.vmas_bench import vmas_bench
from thermoswarm.sim import set_threads

# ---------------------------------------------------------------------------- cells
#: Agents per world in VMAS's batched column (E worlds of this many, E x n = N).
VMAS_AGENTS_PER_ENV = _W = 12
#: VMAS as one world checks every pair of entities in Python (N^2 / 2 per sub-step): it
#: is timed at this size only, and estimated from it at the table's sizes.
VMAS_ONE_WORLD_N = 120
#: Steps in "a run" for the estimates of cells that are not run.
EST_STEPS = 20

#: Column key -> (tool, threads, header).
COLUMNS = {
    "ours_1_thread": ("ours", 1, "ours, 1 thread"),
    "ours_2_thread": ("ours", 2, "ours, 2 threads"),
    "numpy": ("numpy", 1, "NumPy + cKDTree, 1 thread"),
    "jaxmd_1_thread": ("jaxmd", 1, "JAX-MD soft discs, 1 thread"),
    "jaxmd_2_thread": ("jaxmd", 2, "JAX-MD soft discs, 2 threads"),
    "vmas_one": ("vmas", 1, "VMAS, one world, 1 thread"),
    "vmas_batched_1_thread": (
        "vmas_batched",
        1,
        f"VMAS, worlds of {_W}, 1 thread",
    ),
    "vmas_batched_2_thread": (
        "vmas_batched",
        2,
        f"VMAS, worlds of {_W}, 2 threads",
    ),
    "pymunk_1_thread": ("pymunk", 1, "pymunk batch, 1 thread"),
    "pymunk_2_thread": ("pymunk", 2, "pymunk batch, threaded (2)"),
}
#: ``--tools`` names -> column keys.
TOOL_NAMES = {
    "ours1": "ours_1_thread", "ours2": "ours_2_thread", "numpy": "numpy",
    "jaxmd": "jaxmd_1_thread", "jaxmd2": "jaxmd_2_thread", "vmas": "vmas_one",
    "vmas_batched": "vmas_batched_1_thread", "vmas_batched2": "vmas_batched_2_thread",
    "pymunk1": "pymunk_1_thread", "pymunk2": "pymunk_2_thread",
}  # fmt: skip


def _call(key: str, n: int, phi: float, substeps: int) -> dict:
    tool, threads, _ = COLUMNS[key]
    if tool == "ours":
        return ours(n, phi, threads)
    if tool == "numpy":
        return numpy_bench(n, phi)
    if tool == "jaxmd":
        return jaxmd_bench(n, phi, substeps, threads)
    if tool == "vmas":
        return vmas_bench(n, phi, 1, threads)
    if tool == "vmas_batched":
        return vmas_bench(n, phi, max(1, n // VMAS_AGENTS_PER_ENV), threads)
    return pymunk_bench(n, phi, threads)


def run_cell(key: str, n: int, phi: float, substeps: int) -> dict:
    """One tool at one size, in this process: a warm-up at 240 robots (loads compiled
    code, so that the memory measured is the swarm's), then the timed run; memory is
    the peak resident set's growth from just before the swarm is built."""
    budget = T.BUDGET
    try:
        T.BUDGET = 0.0
        _call(key, 24 if COLUMNS[key][0] == "vmas" else 240, phi, substeps)
    finally:
        T.BUDGET = budget
    if COLUMNS[key][0] != "ours":
        T.start_positions(n, phi)  # the shared initial positions, outside the tool's memory
    T.rss_peak_reset()
    T.RSS0 = T.rss_now()
    out = _call(key, n, phi, substeps)
    if COLUMNS[key][0] == "ours":
        from thermoswarm.sim.bench import run_bench

        mem = run_bench(n, phi, seconds=T.DT, checks=0, memory_steps=2)
        out["bytes_per_robot"] = mem["bytes_per_robot"]
    return out


def _child(key: str, n: int, phi: float, a: argparse.Namespace, timeout: float) -> dict:
    """:func:`run_cell` in a fresh process (threads and memory its own), killed after
    ``timeout`` wall seconds."""
    import subprocess

    tool, threads, _ = COLUMNS[key]
    env = dict(os.environ)
    if tool == "jaxmd":
        env["XLA_FLAGS"] = XLA_FLAGS[threads]
    cmd = [sys.executable, __file__, "--cell", key, "--n", str(n), "--phi", str(phi),
           "--budget-s", str(T.BUDGET), "--settle", str(T.SETTLE_STEPS * T.DT),
           "--jaxmd-substeps", str(a.jaxmd_substeps)]  # fmt: skip
    try:
        res = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        return {"skipped": f"not done in {timeout:.0f} s (the cap, --max-cell-s)"}
    if res.returncode != 0:
        tail = (res.stderr.strip().splitlines() or ["no message"])[-1]
        return {"skipped": f"failed: {tail[:120]}"}
    return json.loads(res.stdout.strip().splitlines()[-1])


def _duration(seconds: float) -> str:
    for unit, s in (("d", 86400), ("h", 3600), ("min", 60)):
        if seconds >= s:
            return f"{seconds / s:.2g} {unit}"
    return f"{seconds:.2g} s"


def _estimate(key: str, n: int, ran: dict) -> tuple[float, str] | None:
    """Wall seconds of a cell at ``n`` (setup, first step, MIN_STEPS + 2 steps) and a
    note, from the largest size this tool ran (``ran``: n -> result); None if none ran.
    VMAS as one world grows as N^2 a step; every other tool as N."""
    done = [m for m, r in ran.items() if "skipped" not in r and m < n]
    if not done:
        return None
    m = max(done)
    r = ran[m]
    p = 2 if COLUMNS[key][0] == "vmas" else 1
    scale = (n / m) ** p
    step_s = m / r["robot_steps_per_second"] * scale
    run_s = EST_STEPS * step_s
    setup = max(0.0, r["cell_wall_seconds"] - sum(r["block_wall_seconds"])) * n / m
    cell_s = setup + (T.MIN_STEPS + 2) * step_s
    note = f"est. {_duration(run_s)} a run of {EST_STEPS} steps (from N={m:,}"
    note += ", N^2)" if p == 2 else ")"
    if p == 2 and "rss_bytes_per_robot" in r:
        pair_bytes = r["rss_bytes_per_robot"] * m / (m * m / 2)
        note += f"; N^2/2 pairs: {pair_bytes * n * n / 2 / 1e9:.2g} GB"
    return cell_s, note


def one(n: int, phi: float, keys: list[str], a: argparse.Namespace, history: dict) -> dict:
    """One row: every column at ``n`` robots, each in its own process; a cell whose
    estimate (from the tool's largest size so far, ``history``) passes the cap is
    not run and says why."""
    row: dict = {"n": n, "phi": phi}
    for key in keys:
        ran = history.setdefault((key, phi), {})
        est = _estimate(key, n, ran)
        if key == "vmas_one" and n > VMAS_ONE_WORLD_N and est is None:
            ran[VMAS_ONE_WORLD_N] = _child(key, VMAS_ONE_WORLD_N, phi, a, a.max_cell_s)
            row["vmas_one_reference"] = {"n": VMAS_ONE_WORLD_N, **ran[VMAS_ONE_WORLD_N]}
            est = _estimate(key, n, ran)
        if key == "vmas_one" and n > VMAS_ONE_WORLD_N:
            row[key] = {"skipped": est[1] if est else "every pair checked: N^2"}
        elif est is not None and est[0] > a.max_cell_s:
            row[key] = {"skipped": est[1]}
        else:
            row[key] = ran[n] = _child(key, n, phi, a, a.max_cell_s)
            if "skipped" in row[key] and est is not None:
                row[key]["skipped"] += "; " + est[1]
        print(f"    {key} n={n:,}: done (load {os.getloadavg()[0]:.1f})", file=sys.stderr)
    return row


# ---------------------------------------------------------------------------- table
def _cell(r: dict | None) -> str:
    if r is None:
        return "not run"
    if "skipped" in r:
        return f"not run: {r['skipped']}"
    return (
        f"{r['simulated_robot_seconds_per_second'] / 1e3:.3g} k, "
        f"{r['robot_steps_per_second'] / 1e6:.3g} M/s, {100 * r['max_overlap_fraction']:.2f} %"
    )


def _ratio(row: dict, a: str, b: str) -> str:
    ra, rb = row.get(a), row.get(b)
    if not ra or not rb or "skipped" in ra or "skipped" in rb:
        return "-"
    x = ra["simulated_robot_seconds_per_second"] / rb["simulated_robot_seconds_per_second"]
    return f"{x:.3g}x" if x >= 1 else f"{x:.3g}x (peer {1 / x:.3g}x)"


def _mem(r: dict | None) -> str:
    if not r or "rss_bytes_per_robot" not in r:
        return "-"
    return f"{r['rss_bytes_per_robot']:.0f}"


def _cpu(r: dict | None, n: int) -> str:
    if not r or "cpu_per_wall" not in r:
        return "-"
    cpu_s = r["cpu_per_wall"] * sum(r["block_wall_seconds"])
    return f"{n * r['steps'] / max(cpu_s, 1e-9) / 1e6:.3g} M, {r['cpu_per_wall']:.2f}"


def table(rows: list[dict]) -> str:
    """The speed table, then the memory table (peak RSS growth per robot, every tool)."""
    cols = [k for k in COLUMNS if any(k in r for r in rows)]
    peers = [k for k in cols if not k.startswith("ours")]
    # a peer is compared with ours on the same number of threads
    mine = {k: ("ours_2_thread" if COLUMNS[k][1] == 2 else "ours_1_thread") for k in peers}
    head = " | ".join(COLUMNS[k][2] for k in cols)
    out = [
        "each cell: simulated robot-seconds per wall second (k), robot-steps per wall "
        "second (M, each step 0.1 s), exact max overlap (KD-tree on the final state, % of "
        "D); ratios: ours / peer in simulated robot-seconds per second on the same "
        "number of threads, the peer's own ratio in brackets where it is faster",
        "",
        f"| N | phi | {head} | "
        + "".join(f"ours / {COLUMNS[k][2]} | " for k in peers)
        + "ours cost vs N=1,200 |",
        "|---:|---:|" + "---:|" * (len(cols) + len(peers) + 1),
    ]
    base = {}
    for r in rows:
        o = r.get("ours_1_thread")
        if o and "skipped" not in o and r["n"] == 1200:
            base[r["phi"]] = o["robot_steps_per_second"]
    for r in rows:
        o1 = r.get("ours_1_thread")
        ok = o1 and "skipped" not in o1 and r["phi"] in base
        rel = f"{base[r['phi']] / o1['robot_steps_per_second']:.2f}x" if ok else "-"
        out.append(
            f"| {r['n']:,} | {r['phi']} | "
            + " | ".join(_cell(r.get(k)) for k in cols)
            + " | "
            + "".join(f"{_ratio(r, mine[k], k)} | " for k in peers)
            + f"{rel} |"
        )
    out += [
        "",
        "bytes per robot: peak resident set growth from just before the swarm is built to "
        "the end of its timed steps, / N, each tool in its own process (ours also: its "
        "arrays and largest per-step allocation, tracemalloc)",
        "",
        "| N | phi | " + " | ".join(COLUMNS[k][2] for k in cols) + " | ours, tracemalloc |",
        "|---:|---:|" + "---:|" * (len(cols) + 1),
    ]
    for r in rows:
        o1 = r.get("ours_1_thread") or {}
        tm = f"{o1['bytes_per_robot']:.0f}" if "bytes_per_robot" in o1 else "-"
        out.append(
            f"| {r['n']:,} | {r['phi']} | " + " | ".join(_mem(r.get(k)) for k in cols)
            + f" | {tm} |"
        )  # fmt: skip
    out += [
        "",
        "CPU time (load-robust on a shared machine): robot-steps per CPU second of the "
        "process while timed (all its threads), and CPU seconds per wall second (1.0: one "
        "core all the time; less: the machine's other work took the rest)",
        "",
        "| N | phi | " + " | ".join(COLUMNS[k][2] for k in cols) + " |",
        "|---:|---:|" + "---:|" * len(cols),
    ]
    for r in rows:
        cpu = " | ".join(_cpu(r.get(k), r["n"]) for k in cols)
        out.append(f"| {r['n']:,} | {r['phi']} | {cpu} |")
    refs = [r["vmas_one_reference"] for r in rows if "vmas_one_reference" in r]
    for ref in refs[:1]:
        out += ["", f"VMAS, one world, timed at N={ref['n']}: {_cell(ref)}"]
    return "\n".join(out)


# ---------------------------------------------------------------------------- limit
#: Bytes a robot-step must move at least (the arrays each phase streams, per robot; cell
#: and neighbour data of the neighbours themselves are assumed cached, as the rows are
#: in cell order): the commanded move (pos, ref, udir, speed, timer read; pos, timer
#: written), the decision (heading, speed, udir written; two NumPy draws of 8 bytes read
#: and written), the first sweep (pos, list, count, cell read; the second position
#: buffer and a flag written), and per list build, the re-sort of every per-robot array
#: and the new lists.  Later sweeps (a few per cent of the robots) are left out.
BYTES_MOVE = 16 + 16 + 8 + 8 + 4 + 16 + 4
BYTES_DECIDE = 8 + 8 + 8 + 2 * 16
BYTES_FIRST_SWEEP = 16 + 40 + 4 + 4 + 16 + 1
BYTES_PER_BUILD = 2 * (16 + 16 + 24 + 8) + 16 + 40 + 4 + 4 + 16


def cost_spread(rows: list[dict]) -> list[str]:
    """For each packing fraction: the largest over the smallest cost per robot-step
    (ours, 1 thread) over the sizes run, and at which sizes."""
    out = []
    for phi in sorted({r["phi"] for r in rows}):
        cost = {
            r["n"]: 1e9 / r["ours_1_thread"]["robot_steps_per_second"]
            for r in rows
            if r["phi"] == phi and "robot_steps_per_second" in r.get("ours_1_thread", {})
        }
        if len(cost) < 2:
            continue
        hi = max(cost, key=cost.__getitem__)
        lo = min(cost, key=cost.__getitem__)
        sizes = ", ".join(f"{n:,}: {c:.1f}" for n, c in sorted(cost.items()))
        out.append(
            f"ours, 1 thread, phi {phi}: ns per robot-step ({T.CLOCK.__name__}) {sizes}; "
            "largest over smallest "
            f"{cost[hi] / cost[lo]:.2f}x (N={hi:,} over N={lo:,})"
        )
    return out


def stream(mib: int = 256, reps: int = 5) -> dict:
    """STREAM-style bandwidth of this process (one thread: NumPy), GB/s: ``copy``
    (``b[:] = a``: 16 bytes an element) and ``triad`` (``a = b + s c``: counted as
    STREAM counts it, 24 bytes an element; NumPy does it in two passes), best of
    ``reps`` on arrays of ``mib`` MiB each (far beyond the caches)."""
    m = mib * 2**20 // 8
    a = np.ones(m)
    b = np.full(m, 2.0)
    c = np.full(m, 3.0)
    best = {"copy": math.inf, "triad": math.inf}
    for _ in range(reps):
        t0 = time.perf_counter()
        np.copyto(b, a)
        best["copy"] = min(best["copy"], time.perf_counter() - t0)
        t0 = time.perf_counter()
        np.multiply(c, 3.0, out=a)
        np.add(a, b, out=a)
        best["triad"] = min(best["triad"], time.perf_counter() - t0)
    return {"copy": 16 * m / best["copy"] / 1e9, "triad": 24 * m / best["triad"] / 1e9}


def limit(ns: list[int], phi: float, settle: float) -> str:
    """The engine's fraction of the measured bandwidth, one thread, one command."""
    from thermoswarm.sim.bench import run_bench

    set_threads(1)
    bw = stream()
    rows = [
        f"STREAM-style, one thread, this command: copy {bw['copy']:.1f} GB/s, triad "
        f"{bw['triad']:.1f} GB/s; instructions per robot-step: not measured (perf has no "
        "hardware counters in this VM)",
        "",
        "| N | robot-steps/s (1 thread) | sweeps/step | builds/step | bytes/robot-step "
        "(at least) | GB/s moved | of copy bandwidth |",
        "|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for n in ns:
        r = run_bench(n, phi, seconds=max(settle, 0.5), checks=0, memory_steps=1)
        b = BYTES_MOVE + BYTES_DECIDE + BYTES_FIRST_SWEEP
        b += r["list_builds_per_step"] * BYTES_PER_BUILD
        gbs = b * r["robot_steps_per_second"] / 1e9
        rows.append(
            f"| {n:,} | {r['robot_steps_per_second'] / 1e6:.2f} M | "
            f"{r['mean_sweeps_per_step']:.1f} | {r['list_builds_per_step']:.2f} | {b:.0f} | "
            f"{gbs:.2f} | {100 * gbs / bw['copy']:.0f} % |"
        )
    set_threads(None)
    return "\n".join(rows)


def _tools(names: str) -> list[str]:
    """Column keys for ``--tools``, less those whose package is missing (said on stderr)."""
    keys = []
    for t in (t.strip() for t in names.split(",")):
        if t and t not in TOOL_NAMES:
            raise SystemExit(f"error: --tools: unknown tool {t!r}; expected some of "
                             f"{','.join(TOOL_NAMES)}")  # fmt: skip
        if t:
            keys.append(TOOL_NAMES[t])
    import numba

    if numba.config.NUMBA_NUM_THREADS < 2 and "ours_2_thread" in keys:
        print("only one Numba thread: the 2-thread column is skipped", file=sys.stderr)
        keys.remove("ours_2_thread")
    for mod, tool in (("pymunk", "pymunk"), ("jax_md", "jaxmd"), ("vmas", "vmas"),
                      ("vmas", "vmas_batched")):  # fmt: skip
        if importlib.util.find_spec(mod) is None:
            gone = [k for k in keys if COLUMNS[k][0] == tool]
            if gone:
                print(f"{mod} is not installed (pip install thermoswarm[bench]): skipped",
                      file=sys.stderr)  # fmt: skip
            keys = [k for k in keys if k not in gone]
    return keys


def _args(argv: list[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, action="append", help="robots (repeatable)")
    ap.add_argument("--phi", type=float, action="append", help="packing fraction (repeatable)")
    ap.add_argument(
        "--tools", default=",".join(TOOL_NAMES),
        help=f"comma-separated subset of {','.join(TOOL_NAMES)}",
    )  # fmt: skip
    ap.add_argument(
        "--jaxmd-substeps", type=int, default=JAXMD_SUBSTEPS,
        help="JAX-MD sub-steps per 0.1 s step (its stiffness follows: see JAXMD_STIFFNESS)",
    )  # fmt: skip
    ap.add_argument(
        "--budget-s", type=float, default=T.BUDGET,
        help="wall seconds of stepping per cell (settle steps stop at half of it; at "
        "least 2 timed steps are run whatever it is)",
    )  # fmt: skip
    ap.add_argument(
        "--max-cell-s", type=float, default=600.0,
        help="a cell (one tool at one size, setup included) is not run when its "
        "estimate from the tool's largest size so far passes this, and is stopped there",
    )  # fmt: skip
    ap.add_argument(
        "--settle", type=float, default=0.0,
        help="simulated seconds every tool runs before it is timed (default 0: timed from "
        "the start, where contacts are still building up)",
    )  # fmt: skip
    ap.add_argument("--json", action="store_true", help="print JSON instead of a table")
    ap.add_argument(
        "--ours-only", action="store_true",
        help="only ours on 1 thread, in this process, timed in the thread's CPU time after "
        "every settle step, and the largest over the smallest cost per robot-step",
    )  # fmt: skip
    ap.add_argument(
        "--limit", action="store_true",
        help="print the bandwidth table instead (ours, 1 thread, against a STREAM-style "
        "bandwidth measured in the same command; --settle = simulated seconds timed)",
    )  # fmt: skip
    ap.add_argument("--cell", choices=list(COLUMNS), help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    for name in ("budget_s", "max_cell_s", "settle"):
        if getattr(a, name) < 0:
            ap.error(f"--{name.replace('_', '-')} must be >= 0, got {getattr(a, name)}")
    return a


def main(argv: list[str] | None = None) -> int:
    a = _args(argv)
    T.SETTLE_STEPS = max(0, round(a.settle / T.DT))
    T.BUDGET = a.budget_s
    ns = a.n or [1_200, 10_000, 100_000, 1_000_000]
    phis = a.phi or [0.18, 0.5]
    if a.cell:  # one cell, in a process of its own (see _child)
        print(json.dumps(run_cell(a.cell, ns[0], phis[0], a.jaxmd_substeps)))
        return 0
    if a.limit:
        print(limit(ns, phis[-1], a.settle))
        print(f"(load average at the end: {os.getloadavg()[0]:.1f})")
        return 0
    keys = ["ours_1_thread"] if a.ours_only else _tools(a.tools)
    if a.ours_only:
        T.CLOCK, T.FULL_SETTLE = time.thread_time, True
    rows, history = [], {}
    for phi in phis:
        for n in ns:
            if a.ours_only:
                cell = run_cell("ours_1_thread", n, phi, a.jaxmd_substeps)
                rows.append({"n": n, "phi": phi, "ours_1_thread": cell})
            else:
                rows.append(one(n, phi, keys, a, history))
            print(f"  done n={n:,} phi={phi} (load {os.getloadavg()[0]:.1f})", file=sys.stderr)
    info = {"cpus": os.cpu_count(), "load_average": os.getloadavg()}
    if a.json:
        print(json.dumps({"engine": rows, "machine": info}))
    else:
        print(table(rows))
        print("\n".join(cost_spread(rows)))
        print(
            f"\n(cpus: {info['cpus']}, load average at the end: "
            f"{', '.join(f'{x:.1f}' for x in info['load_average'])})"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
