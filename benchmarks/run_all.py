"""``make bench``: every benchmark, one after the other, each against its own baseline.

Prints the engine tables (thermoswarm on 1 and 2 threads beside NumPy + cKDTree, JAX-MD,
VMAS and pymunk's batch API; its fraction of a STREAM-style bandwidth; the jammed
mechanism run with and without the warm start) and a summary line per other benchmark;
the full JSON of each goes to ``bench-out/<name>.json``.  Every figure is a ratio
against a baseline measured in the same process (these machines are noisy); the load
average is printed with each result.

The real-tracking step needs the ANTS ground truth (``--tracking-data DIR``, see
docs/tracking.md); without it, it runs its synthetic box sequences only.

Options: ``--quick`` runs smaller sizes (a few minutes in all); ``--only NAME`` runs one.
A new benchmark is one entry of :data:`STEPS`.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).parent
OUT = Path("bench-out")


def _run(name: str, args: list[str]) -> dict | None:
    cmd = [sys.executable, str(HERE / f"{name}.py"), *args, "--json"]
    t0 = time.perf_counter()
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode != 0:
        print(f"{name}: failed ({res.stderr.strip().splitlines()[-1:]})")
        return None
    out = res.stdout.strip()
    try:  # one JSON object: on its last line, or the whole output (indented)
        data = json.loads(out.splitlines()[-1])
    except (json.JSONDecodeError, IndexError):
        data = json.loads(out[out.index("{") :])
    OUT.mkdir(exist_ok=True)
    (OUT / f"{name}.json").write_text(json.dumps(data, indent=2))
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(
        f"{name}: {time.perf_counter() - t0:.0f} s (load average {load}); "
        f"full results in {OUT / (name + '.json')}"
    )
    return data


def _short(d: dict) -> str:
    return "   " + json.dumps(d.get("summary", {k: d[k] for k in list(d)[:8]}))[:400]


def _analysis(d: dict) -> str:
    w = d["same_work"]
    rows = [f"   {k}: ours {r['ours_s']} s, SciPy {r.get('scipy_s', r.get('scipy_lbfgsb_s'))} s, "
            f"ratio {r['ratio']}" for k, r in w.items()]  # fmt: skip
    return "\n".join(
        [
            f"   whole study {d['wall_s']} s; one thread each side",
            *rows,
            f"   same optimum: {d['same_optimum']}",
        ]  # fmt: skip
    )


def _tracking_real(d: dict) -> str:
    by: dict[tuple[str, str], list[float]] = {}
    for r in d["rows"]:
        if r["tracker"] != "ours":
            by.setdefault((r["sequence"], r["tracker"]), []).append(1 / r["speed_vs_ours"])
    lines = ["   our speed over each peer's (timed: each tracker's own update per frame):"]
    for (seq, peer), v in sorted(by.items()):
        lines.append(f"   {seq:28s} {peer:9s} {min(v):.2f}-{max(v):.2f}x")
    return "\n".join(lines)


@dataclass(frozen=True)
class Step:
    """One benchmark: its script, its arguments (full and ``--quick``), its summary."""

    name: str
    script: str
    full: list[str]
    quick: list[str]
    summary: Callable[[dict], str]
    needs: str | None = None  # a module that must be importable, or the step is skipped


STEPS = [
    Step(
        "analysis",
        "bench_analysis",
        [],
        ["--n-tracks", "200", "--n-frames", "5000", "--bootstrap", "50"],
        _analysis,
    ),
    Step("tracking", "bench_tracking", [], ["--seeds", "1"], _short),
    Step("unet", "bench_unet", [], ["--quick"], _short, needs="torch"),
    Step("light", "bench_light", [], ["--sizes", "100000"], lambda d: "   " + json.dumps(d)[:300]),
    Step("io", "bench_io", [], ["--quick"], lambda d: "   " + json.dumps(d)[:300]),
    Step(
        "sweep",
        "bench_sweep",
        [],
        ["--runs", "100", "--tasks", "200", "--rounds", "2"],
        _short,
        needs="distributed",
    ),
    Step(
        "tracking_real",
        "bench_tracking_real",
        ["--synthetic", "50", "100", "200"],
        ["--synthetic", "50", "--seeds", "0", "--levels", "moderate"],
        _tracking_real,
        needs="trackers",
    ),
    Step(
        "viewer",
        "bench_viewer",
        [],
        ["--sizes", "10000,100000", "--seconds", "3"],
        lambda d: "   " + json.dumps(d)[:300],
    ),
    # GPU step: bench_gpu.py's CPU part (Warp's CPU device) goes here as one more Step.
]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller sizes")
    ap.add_argument("--only", choices=["engine", *(s.name for s in STEPS)])
    ap.add_argument("--tracking-data", type=Path, default=None,
                    help="folder of <sequence>/gt/gt.txt for the real-tracking step")  # fmt: skip
    a = ap.parse_args(argv)

    if a.only in (None, "engine"):
        sys.path.insert(0, str(HERE))
        from bench_engine import table

        ns = ["--n", "1200", "--n", "10000", "--n", "100000"] if a.quick else []
        print("## engine (thermoswarm, NumPy + cKDTree, JAX-MD, VMAS, pymunk: same workload)")
        print(f"command: python benchmarks/bench_engine.py {' '.join(ns)}\n")
        d = _run("bench_engine", ns)
        if d:
            print(table(d["engine"]))
        lim = ["--limit", "--settle", "2", "--phi", "0.5", "--n", "10000", "--n", "100000"]
        lim += [] if a.quick else ["--n", "1000000"]
        # engine_jam runs Jacobi sweeps alone and the default solve, one after the other
        for script, args in [("bench_engine", lim), ("engine_jam", [])]:
            print(f"\ncommand: python benchmarks/{script}.py {' '.join(args)}")
            subprocess.run([sys.executable, str(HERE / f"{script}.py"), *args], check=False)
        print()
    with tempfile.TemporaryDirectory() as empty:
        for step in STEPS:
            if a.only not in (None, step.name):
                continue
            if step.needs and importlib.util.find_spec(step.needs) is None:
                print(f"{step.script}: skipped ({step.needs} is not installed)")
                continue
            args = list(step.quick if a.quick else step.full)
            if step.name == "tracking_real":
                data = a.tracking_data or Path(empty)
                tune = ["--tune", "Seq0006Object21Image64"] if a.tracking_data else []
                args = [str(data), *tune, *args]
            d = _run(step.script, args)
            if d:
                print(step.summary(d))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
