"""``make bench``: every benchmark, one after the other, each against its own baseline.

Prints the engine tables (thermoswarm on 1 and 2 threads beside NumPy + cKDTree, JAX-MD,
VMAS and pymunk's batch API; its fraction of a STREAM-style bandwidth; the jammed
mechanism run with and without the warm start) and a summary line per other benchmark;
the full JSON of each goes to ``bench-out/<name>.json``.  Every figure is a ratio
against a baseline measured in the same process (these machines are noisy); the load
average is printed with each result.

Options: ``--quick`` runs smaller sizes (a few minutes in all); ``--only NAME`` runs one.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import subprocess
import sys
import time
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
    data = json.loads(res.stdout.strip().splitlines()[-1])
    OUT.mkdir(exist_ok=True)
    (OUT / f"{name}.json").write_text(json.dumps(data, indent=2))
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(
        f"{name}: {time.perf_counter() - t0:.0f} s (load average {load}); "
        f"full results in {OUT / (name + '.json')}"
    )
    return data


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller sizes")
    ap.add_argument("--only", choices=["engine", "analysis", "tracking", "unet", "light", "io"])
    a = ap.parse_args(argv)

    def want(name: str) -> bool:
        return a.only in (None, name)

    if want("engine"):
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
        jam = [[], ["--set", "engine.warm_start=true"]]
        for script, args in [("bench_engine", lim)] + [("engine_jam", j) for j in jam]:
            print(f"\ncommand: python benchmarks/{script}.py {' '.join(args)}")
            subprocess.run([sys.executable, str(HERE / f"{script}.py"), *args], check=False)
        print()
    if want("analysis"):
        args = ["--n-tracks", "200", "--n-frames", "5000"] if a.quick else []
        d = _run("bench_analysis", args)
        if d:
            print("   " + json.dumps({k: d[k] for k in d if not isinstance(d[k], dict)})[:300])
    if want("tracking"):
        d = _run("bench_tracking", ["--seeds", "1"] if a.quick else [])
        if d:
            print("   " + json.dumps(d.get("summary", {k: d[k] for k in list(d)[:8]}))[:400])
    if want("unet") and (HERE / "bench_unet.py").exists():
        if importlib.util.find_spec("torch") is None:
            print("bench_unet: skipped (torch is not installed)")
        else:
            d = _run("bench_unet", ["--quick"] if a.quick else [])
            if d:
                print("   " + json.dumps(d.get("summary", {k: d[k] for k in list(d)[:8]}))[:400])
    if want("light"):
        d = _run("bench_light", ["--sizes", "100000"] if a.quick else [])
        if d:
            print("   " + json.dumps(d)[:300])
    if want("io"):
        d = _run("bench_io", ["--quick"] if a.quick else [])
        if d:
            print("   " + json.dumps(d)[:300])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
