"""Where a robot-step's time goes, by phase, at several swarm sizes (1 thread, CPU time).

The bench workload (``thermoswarm.sim.bench.workload``, packing ``--phi``) runs
``--settle`` steps, then ``--steps`` steps whose phases are called one by one from Python
in the order ``kernels.overdamped_step`` calls them on its default (cold Jacobi) path:
the decision, the commanded move, the re-sort, the list builds, the first sweep (every
robot), the later sweeps (the robots whose surroundings changed) and the choice of the
robots the next sweep visits (collecting the rows the sweep marked).  Each phase's CPU
time (``time.thread_time``) is printed in ns per robot-step, with the later sweeps'
visits per robot-step and their ns per visit.
A twin state stepped by the engine itself checks the replica: the line ends with
"replica = engine" when the two end bit-identical (a replica that drifted from the
engine's step says so instead of timing something else).  Phases called from Python
carry a few microseconds of call overhead each (noticeable below ~10,000 robots).

Usage::

    python benchmarks/engine_phases.py --n 100000 --n 1000000 --settle 200 --steps 40
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from thermoswarm.sim import kernels as K
from thermoswarm.sim import set_threads
from thermoswarm.sim.bench import workload

PHASES = ("decide", "move", "re-sort", "build", "sweep 1", "sweeps 2+", "next visits")


def _step(sim, state, t: dict, c: dict) -> None:
    """One step of the cold path, phase by phase (as ``overdamped_step``)."""
    clock = time.thread_time
    ws, p, w = sim._ensure_ws(state), sim.params, sim.world
    num, n = ws.numerics, state.n
    t0 = clock()
    due, everyone = K.due_robots(state.timer, p.tau_steps)
    sim._decide(state, None if everyone else due)
    t1 = clock()
    t["decide"] += t1 - t0
    pos, ref = state.pos, state.ref
    far = K._move_serial(pos, state.udir, state.speed, state.timer, ref, num.dt)
    t["move"] += clock() - t1
    no_f, no_i = np.zeros((0, 0), np.float32), np.zeros((0, 0), np.int32)
    new_row = ws.visits[1]
    if not (far <= num.half_skin**2):
        t2 = clock()
        K.sort_rows(pos, state.fcols, state.icols, state.udir, no_f, no_i, ws.scratch, ws.grid,
                    ws.cell, ws.cell_start, ws.perm)  # fmt: skip
        K._inverse(ws.perm, new_row)
        t3 = clock()
        ws.overflows[0] = K._rebuild(pos, ref, ws.grid, num, ws.cell, ws.cell_start,
                                     ws.perm, ws.neighbours, ws.n_neighbours, no_f, new_row,
                                     True, False)  # fmt: skip
        t["re-sort"] += t3 - t2
        t["build"] += clock() - t3
    visit, visit_next = ws.visits[0], ws.visits[1]
    src, dst, in_scratch = pos, ws.scratch, False
    everyone, count, sweeps = True, n, 0
    while True:
        ta = clock()
        overlap, far = K._sweep_serial(
            src, dst, ref, ws.neighbours, ws.n_neighbours, ws.cell, ws.cell_start, ws.perm,
            ws.cell_near_static, ws.grid, num, w.segments, w.static_discs, state.bodies,
            state.pistons, visit, count, everyone, ws.mark,
        )  # fmt: skip
        t["sweep 1" if sweeps == 0 else "sweeps 2+"] += clock() - ta
        c["visits"] += 0 if sweeps == 0 else count
        sweeps += 1
        if (sweeps >= num.min_sweeps and overlap < num.tol) or sweeps >= num.max_sweeps:
            ws.mark[:] = 0
            break
        src, dst, in_scratch = dst, src, not in_scratch
        tb = clock()
        if not (far <= num.half_skin**2) or ws.overflows[0]:
            if not (far <= num.half_skin**2):
                ws.overflows[0] = K._rebuild(src, ref, ws.grid, num, ws.cell, ws.cell_start,
                                             ws.perm, ws.neighbours, ws.n_neighbours, no_f,
                                             new_row, False, False)  # fmt: skip
            everyone, count = True, n
            ws.mark[:] = 0
            t["build"] += clock() - tb
            continue
        count = K._collect_marked(ws.mark, ws.near_moved, False, visit_next)
        visit, visit_next, everyone = visit_next, visit, False
        t["next visits"] += clock() - tb
    if in_scratch:
        state.pos, ws.scratch = ws.scratch, state.pos
    c["sweeps"] += sweeps
    state.step += 1
    state.time = state.step * p.dt


def _compile(sim, state) -> None:
    """Compile every phase's signature on copies (the profiled steps time no compiling,
    and the state is untouched)."""
    ws, num = sim._ensure_ws(state), sim._ensure_ws(state).numerics
    no_f, no_i = np.zeros((0, 0), np.float32), np.zeros((0, 0), np.int32)
    pos, ref, row = state.pos.copy(), state.ref.copy(), ws.visits[1].copy()
    cell, start, perm = ws.cell.copy(), ws.cell_start.copy(), ws.perm.copy()
    nbr, nnb = ws.neighbours.copy(), ws.n_neighbours.copy()
    K.sort_rows(pos, state.fcols.copy(), state.icols.copy(), state.udir.copy(), no_f, no_i,
                np.empty_like(pos), ws.grid, cell, start, perm)  # fmt: skip
    K._inverse(perm, row)
    for renumber in (True, False):
        K._rebuild(pos, ref, ws.grid, num, cell, start, perm, nbr, nnb, no_f, row, renumber,
                   False)  # fmt: skip


def profile(n: int, phi: float, settle: int, steps: int) -> str:
    """One size: settle, then ``steps`` profiled steps; one line of ns per robot-step."""
    _, sim, state = workload(n, phi, seed=0)
    for _ in range(settle):
        sim.step(state)
    _, twin_sim, twin = workload(n, phi, seed=0)
    for _ in range(settle):
        twin_sim.step(twin)
    t = dict.fromkeys(PHASES, 0.0)
    c = {"visits": 0, "sweeps": 0}
    _compile(sim, state)
    for _ in range(3):  # the other phases' signatures; not timed
        _step(sim, state, dict(t), dict(c))
        twin_sim.step(twin)
    for _ in range(steps):
        _step(sim, state, t, c)
        twin_sim.step(twin)
    same = np.array_equal(state.by_id(state.pos), twin.by_id(twin.pos))
    per = {k: 1e9 * v / (n * steps) for k, v in t.items()}
    visits = c["visits"] / (n * steps)
    return (
        f"| {n:,} | " + " | ".join(f"{per[k]:.1f}" for k in PHASES)
        + f" | {sum(per.values()):.1f} | {c['sweeps'] / steps:.2f} | {visits:.3f} | "
        f"{per['sweeps 2+'] / max(visits, 1e-12):.0f} | "
        f"{'replica = engine' if same else 'REPLICA DIFFERS from the engine'} |"
    )  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, action="append", help="robots (repeatable)")
    ap.add_argument("--phi", type=float, default=0.5)
    ap.add_argument("--settle", type=int, default=200, help="steps before the profile")
    ap.add_argument("--steps", type=int, default=40, help="profiled steps")
    a = ap.parse_args(argv)
    set_threads(1)
    print(f"ns per robot-step by phase, 1 thread, CPU time; packing {a.phi}, after "
          f"{a.settle} steps, {a.steps} steps profiled")  # fmt: skip
    print("\n| N | " + " | ".join(PHASES) + " | total | sweeps/step | later visits/robot-step "
          "| ns/later visit | check |")  # fmt: skip
    print("|---:" * (len(PHASES) + 5) + "|---|")
    for n in a.n or [100_000, 1_000_000]:
        print(profile(n, a.phi, a.settle, a.steps), flush=True)
    print(f"(load average at the end: {os.getloadavg()[0]:.1f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
