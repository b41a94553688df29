"""Engine A/B: the speed of two git revisions of ``thermoswarm.sim`` on the bench workload.

Each revision's ``sim`` package (engine, kernels, world) is exported with ``git show``
into a temporary package; the two run alternately, each in a fresh process, ``--reps``
times, and the medians are compared.  One thread is timed in CPU time
(``time.thread_time``), which a busy shared machine disturbs far less than wall time;
more threads in wall time.  (Two engine copies in one process disturb each other: the
second one's parallel loops pay a fixed cost per call, so separate processes it is.)
The rest of the package (the policy among it) is the installed one, shared by both.

Each line also says whether the two revisions ended in the same state, bit for bit
(positions, headings and speeds in id order after the same steps from the same seed).
``--objects`` adds a pushed body, a static disc and a piston, with 1 s control periods
staggered over the swarm and headings towards the light: a jammed swarm, ~100 sweeps a
step, which exercises the paths the bench workload does not.

Usage::

    python benchmarks/engine_ab.py --base cd3ff16 --n 10000 --n 100000
    python benchmarks/engine_ab.py --base HEAD~1 --new WORKTREE --threads 2
    python benchmarks/engine_ab.py --base HEAD~1 --objects --phi 0.4 --n 1200 --n 5000
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FILES = (
    "__init__",
    "engine",
    "kernels",
    "kernels_grid",
    "kernels_walls",
    "kernels_sweep",
    "kernels_held",
    "world",
    "state",
    "threads",
    "placement",
)  # fmt: skip (a revision without one of them is exported without it)

CHILD = r"""
import hashlib, importlib, json, math, sys, time
import numba, numpy as np
sys.path.insert(0, {where!r})
S = importlib.import_module({pkg!r})
from thermoswarm.maxent import kT_for_mean_speed
from thermoswarm.policy import BoltzmannUniform
n, phi, th = {n}, {phi}, {threads}
numba.set_num_threads(th)
if hasattr(S, "set_threads"):
    S.set_threads(th)
else:  # engines before set_threads switched to all threads from 8,000 robots
    S.engine._MAX_THREADS = th
clock = time.thread_time if th == 1 else time.perf_counter
r = 16.5
side = math.sqrt(n * math.pi * r * r / phi)
if {objects}:  # a pushed body, a static disc and a piston; staggered 1 s periods
    world = S.box_world(side, side, bodies=(S.Body(side / 3, side / 2, 50.0, 50.0),),
                        pistons=(S.Piston(0, 0.8 * side, -1, 0.0, side, 5.0 * math.sqrt(n)),))
    world = S.World(world.bounds, world.segments, np.array([[side / 2, side / 3, 60.0]]),
                    world.bodies, world.pistons)
    params = S.EngineParams(dt=0.1, tau=1.0)
    policy = BoltzmannUniform(kT_for_mean_speed(20.0), half_width=math.pi / 2)
else:
    world = S.box_world(side, side)
    params = S.EngineParams(dt=0.1, tau=0.1)
    policy = BoltzmannUniform(kT_for_mean_speed(10.0))
sim = S.Simulator(world, params, policy)
rng = np.random.default_rng(0)
inside = None
if {objects}:
    def inside(p):
        d1 = np.hypot(p[:, 0] - side / 3, p[:, 1] - side / 2)
        d2 = np.hypot(p[:, 0] - side / 2, p[:, 1] - side / 3)
        return (d1 > 50.0 + r) & (d2 > 60.0 + r) & (p[:, 0] < 0.8 * side - r)
state = sim.init(S.place_lattice(world.bounds, n, r, rng, inside=inside), rng)
for _ in range(3):
    sim.step(state)
steps = max(5, int((3e5 if {objects} else 3e6) / n))  # objects: ~100 sweeps a step
t0 = clock()
for _ in range(steps):
    sim.step(state)
ns = (clock() - t0) / steps / n * 1e9 * th
# what the run computed: positions, headings and speeds in id order
digest = hashlib.sha256()
for a in (state.by_id(state.pos), state.by_id(state.heading), state.by_id(state.speed)):
    digest.update(np.ascontiguousarray(a).tobytes())
print(json.dumps({{"ns": ns, "digest": digest.hexdigest(), "steps": state.step}}))
"""


def export(rev: str, dest: Path, pkg: str) -> None:
    """The ``sim`` package of revision ``rev`` (or the work tree) as package ``pkg``."""
    d = dest / pkg
    d.mkdir(parents=True)
    for f in FILES:
        rel = f"src/thermoswarm/sim/{f}.py"
        if rev == "WORKTREE":
            if not (ROOT / rel).exists():
                continue
            text = (ROOT / rel).read_text()
        else:
            res = subprocess.run(
                ["git", "show", f"{rev}:{rel}"], cwd=ROOT, capture_output=True, text=True
            )
            if res.returncode:  # not in that revision (the kernels were split later)
                continue
            text = res.stdout
        text = re.sub(r"\bthermoswarm\.sim\b(?!\.light|\.geometry|\.recorder)", pkg, text)
        (d / f"{f}.py").write_text(text)


def measure(where: Path, pkg: str, n: int, phi: float, threads: int, objects: bool) -> dict:
    """One fresh process: ``{"ns": ns per robot-step x threads, "digest": the final
    state's hash, "steps": steps run}``."""
    code = CHILD.format(where=str(where), pkg=pkg, n=n, phi=phi, threads=threads, objects=objects)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    if out.returncode:
        raise SystemExit(f"{pkg}: {out.stderr.strip().splitlines()[-1]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", required=True, help="git revision to compare against")
    ap.add_argument("--new", default="HEAD", help="git revision, or WORKTREE (default HEAD)")
    ap.add_argument("--n", type=int, action="append", help="robots (repeatable)")
    ap.add_argument("--phi", type=float, default=0.5)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument(
        "--objects", action="store_true",
        help="add a movable body, a static disc and a piston; 1 s control periods, staggered "
        "(checks that the final states agree on those paths too)",
    )  # fmt: skip
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        where = Path(tmp)
        export(a.base, where, "engine_a")
        export(a.new, where, "engine_b")
        print(f"ns per robot-step x threads (median of {a.reps}, alternating processes); "
              f"{a.threads} thread(s), packing {a.phi}")  # fmt: skip
        for n in a.n or [1_200, 10_000, 100_000]:
            runs = {"engine_a": [], "engine_b": []}
            for _ in range(a.reps):
                for pkg in runs:
                    runs[pkg].append(measure(where, pkg, n, a.phi, a.threads, a.objects))
            ma, mb = (statistics.median(r["ns"] for r in runs[p]) for p in runs)
            # both revisions run the same steps from the same seed: same digest = the
            # same positions, headings and speeds, bit for bit
            same = {r["digest"] for r in runs["engine_a"]} == {
                r["digest"] for r in runs["engine_b"]
            }
            print(f"n={n:>9,}  {a.base}: {ma:6.1f}  {a.new}: {mb:6.1f}  speed-up {ma / mb:.2f}x"
                  f"  final state {'bit-identical' if same else 'DIFFERENT'}")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
