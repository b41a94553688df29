"""Engine A/B: the speed of two git revisions of ``thermoswarm.sim`` on the bench workload.

Each revision's ``sim`` package (engine, kernels, world) is exported with ``git show``
into a temporary package; the two run alternately, each in a fresh process, ``--reps``
times, and the medians are compared.  One thread is timed in CPU time
(``time.thread_time``), which a busy shared machine disturbs far less than wall time;
more threads in wall time.  (Two engine copies in one process disturb each other: the
second one's parallel loops pay a fixed cost per call, so separate processes it is.)

Usage::

    python benchmarks/engine_ab.py --base cd3ff16 --n 10000 --n 100000
    python benchmarks/engine_ab.py --base HEAD~1 --new WORKTREE --threads 2
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
FILES = ("__init__", "engine", "kernels", "world")

CHILD = r"""
import importlib, json, math, sys, time
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
world = S.box_world(side, side)
sim = S.Simulator(world, S.EngineParams(dt=0.1, tau=0.1),
                  BoltzmannUniform(kT_for_mean_speed(10.0)))
rng = np.random.default_rng(0)
state = sim.init(S.place_lattice(world.bounds, n, r, rng), rng)
for _ in range(3):
    sim.step(state)
steps = max(5, int(3e6 / n))
t0 = clock()
for _ in range(steps):
    sim.step(state)
print(json.dumps({{"ns": (clock() - t0) / steps / n * 1e9 * th}}))
"""


def export(rev: str, dest: Path, pkg: str) -> None:
    """The ``sim`` package of revision ``rev`` (or the work tree) as package ``pkg``."""
    d = dest / pkg
    d.mkdir(parents=True)
    for f in FILES:
        rel = f"src/thermoswarm/sim/{f}.py"
        if rev == "WORKTREE":
            text = (ROOT / rel).read_text()
        else:
            text = subprocess.run(
                ["git", "show", f"{rev}:{rel}"], cwd=ROOT, capture_output=True, text=True,
                check=True,
            ).stdout  # fmt: skip
        text = re.sub(r"\bthermoswarm\.sim\b(?!\.light|\.geometry|\.recorder)", pkg, text)
        (d / f"{f}.py").write_text(text)


def measure(where: Path, pkg: str, n: int, phi: float, threads: int) -> float:
    code = CHILD.format(where=str(where), pkg=pkg, n=n, phi=phi, threads=threads)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    if out.returncode:
        raise SystemExit(f"{pkg}: {out.stderr.strip().splitlines()[-1]}")
    return json.loads(out.stdout.strip().splitlines()[-1])["ns"]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", required=True, help="git revision to compare against")
    ap.add_argument("--new", default="HEAD", help="git revision, or WORKTREE (default HEAD)")
    ap.add_argument("--n", type=int, action="append", help="robots (repeatable)")
    ap.add_argument("--phi", type=float, default=0.5)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--reps", type=int, default=3)
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
                    runs[pkg].append(measure(where, pkg, n, a.phi, a.threads))
            ma, mb = (statistics.median(runs[p]) for p in runs)
            print(f"n={n:>9,}  {a.base}: {ma:6.1f}  {a.new}: {mb:6.1f}  speed-up {ma / mb:.2f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
