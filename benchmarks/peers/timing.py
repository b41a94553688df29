"""What every tool of ``bench_engine.py`` shares: the workload's constants, the timed
loop (:func:`timed`), the exact overlap (:func:`kd_overlap`), the memory measure and
the common initial positions (:func:`start_positions`).

``bench_engine.py`` sets :data:`BUDGET`, :data:`SETTLE_STEPS`, :data:`CLOCK`,
:data:`FULL_SETTLE` and :data:`RSS0` from its command line before a tool runs.
"""

from __future__ import annotations

import functools
import math
import os
import time

import numpy as np
from scipy.spatial import cKDTree

from thermoswarm.sim.bench import DIAMETER
from thermoswarm.sim.engine import place_lattice

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
#: The clock of the timed blocks: wall time, except with ``--ours-only`` (one thread),
#: which times the thread's CPU time (``time.thread_time``), far less disturbed than
#: wall time on a busy shared machine, runs every settle step (no budget cap: the
#: budget is the timed blocks'), and times at least SETTLED_MIN_STEPS steps a block.
CLOCK = time.perf_counter
FULL_SETTLE = False
#: Steps a timed block makes at least with ``--ours-only``: the lists are rebuilt every
#: 4-6 steps (a rebuild costs ~3 steps' sweeps at a million robots), so a block of 2
#: steps, the fastest of three, could miss the rebuilds and understate the cost.
SETTLED_MIN_STEPS = 30


def kd_overlap(pos: np.ndarray, side: float) -> float:
    """Exact largest overlap (mm) between discs and with the box walls."""
    pairs = cKDTree(pos).query_pairs(DIAMETER, output_type="ndarray")
    worst = 0.0
    if len(pairs):
        d = np.linalg.norm(pos[pairs[:, 0]] - pos[pairs[:, 1]], axis=1)
        worst = float((DIAMETER - d).max())
    walls = max(float((R - pos).max()), float((pos - (side - R)).max()))
    return max(worst, walls, 0.0)


def side_of(n: int, phi: float) -> float:
    return math.sqrt(n * math.pi * R * R / phi)


#: Resident set (bytes) before the tool being timed was built (set by :func:`run_cell`).
RSS0: int | None = None


def rss_now() -> int:
    """Resident set of this process now, bytes (``/proc/self/statm``)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def rss_peak_reset() -> None:
    """Reset this process's peak resident set (``VmHWM``) to its current one (Linux)."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        pass


def rss_peak() -> int:
    """Peak resident set since the last :func:`rss_peak_reset`, bytes (``VmHWM``)."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
    return 0


def timed(step, n: int, positions, side: float, overlap=None, rss0: int | None = None) -> dict:
    """Time a tool within :data:`BUDGET` wall seconds (the first step apart).

    The first step (compilation, warm-up) is timed apart, outside the budget; then up
    to SETTLE_STEPS untimed steps, stopped once they have taken half the budget (the
    number done is reported); then BLOCKS blocks of at least MIN_STEPS steps filling the
    rest of the budget, or one block of MIN_STEPS steps where a step is too long for
    more (with ``--ours-only``: every settle step, then three blocks of at least
    SETTLED_MIN_STEPS steps, the budget counted from the end of settling); the fastest
    block is reported.  The exact overlap (KD-tree, not timed) is measured on the final
    state (``overlap(positions())``, default :func:`kd_overlap`).  Memory: peak
    resident set growth over ``rss0`` (bytes, before the final overlap check) per robot.
    """
    if overlap is None:
        overlap = functools.partial(kd_overlap, side=side)
    if rss0 is None:
        rss0 = RSS0
    t0 = time.perf_counter()
    step()  # compiles / warms up: outside the budget
    first = time.perf_counter() - t0
    t_all = time.perf_counter()
    settled = 0
    t0 = time.perf_counter()
    while settled < SETTLE_STEPS and (FULL_SETTLE or time.perf_counter() - t0 < BUDGET / 2):
        step()
        settled += 1
    if FULL_SETTLE:  # the budget is the timed blocks'
        t_all = time.perf_counter()
    t0 = CLOCK()
    step()
    one = CLOCK() - t0
    left = max(0.0, BUDGET - (time.perf_counter() - t_all))
    least = SETTLED_MIN_STEPS if FULL_SETTLE else MIN_STEPS
    blocks = BLOCKS if left >= BLOCKS * MIN_STEPS * one or FULL_SETTLE else 1
    per_block = max(least, int(left / blocks / max(one, 1e-6)))
    walls, cpu = [], 0.0
    for _ in range(blocks):
        c0, t0 = time.process_time(), CLOCK()
        for _ in range(per_block):
            step()
        walls.append(CLOCK() - t0)
        cpu += time.process_time() - c0
    peak = rss_peak()
    worst = overlap(positions())
    best = min(walls)
    out = {
        "steps": per_block * blocks,
        "settle_steps": settled,
        "block_wall_seconds": walls,
        "first_step_seconds": first,
        "compile_seconds": max(0.0, first - one),
        "cpu_per_wall": cpu / sum(walls),
        "robot_steps_per_second": n * per_block / best,
        "median_robot_steps_per_second": n * per_block / float(np.median(walls)),
        "simulated_robot_seconds_per_second": n * per_block * DT / best,
        "max_overlap_fraction": worst / DIAMETER,
        "cell_wall_seconds": time.perf_counter() - t_all + first,
    }
    if rss0 is not None:
        out["rss_bytes_per_robot"] = (peak - rss0) / n
    return out


@functools.lru_cache(maxsize=2)
def start_positions(n: int, phi: float, seed: int = 0) -> np.ndarray:
    """The initial positions every peer starts from (the engine's own placement)."""
    side = side_of(n, phi)
    return place_lattice((0.0, 0.0, side, side), n, R, np.random.default_rng(seed))
