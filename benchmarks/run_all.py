"""``make bench``: every benchmark, one after the other, each table with its command.

Each step prints a header, the command that prints its table on its own (the same
command, so a figure quoted in README.md or docs/ can be traced to one line here), and
its table: the engine beside its peers (NumPy + cKDTree, JAX-MD, VMAS, pymunk) from
1,200 to 1,000,000 robots, the engine's fraction of a STREAM-style bandwidth, its cost
per robot-step from 1,200 to 1,000,000 robots, the jammed mechanism run with Jacobi
sweeps alone, the first Gauss-Seidel solve and the default, the GPU script's rehearsal on
the CPU (numba-cuda's simulator), the compression claims, then analysis, tracking, the
U-Net, light, I/O, sweeps, real-tracking and the viewer.  The full JSON of each JSON step
goes to ``bench-out/<name>.json`` and the text of each other step to
``bench-out/<name>.txt``.  The load average is printed with each result (these machines
are shared: compare ratios measured in one command).

The real-tracking step needs the ANTS ground truth (``--tracking-data DIR``, see
docs/tracking.md); without it, it runs its synthetic box sequences only.

Options: ``--quick`` runs smaller sizes (for a check that everything runs, not for the
figures the pages quote); ``--only NAME`` runs one step.  A new benchmark is one entry
of :data:`STEPS`.
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


def command(step: Step, quick: bool = False) -> str:
    """The command line a step runs, as printed beside its table."""
    env = "".join(f"{k}={v} " for k, v in step.env)
    args = [*(step.quick if quick else step.full), *(["--json"] if step.json else [])]
    return f"{env}python benchmarks/{step.script}.py {' '.join(args)}".rstrip()


def _run(step: Step, args: list[str]) -> dict | str | None:
    """Run one step's script; its JSON (a JSON step) or its standard output (a table
    step), saved under :data:`OUT`; None (and why, printed) if it failed."""
    cmd = [sys.executable, str(HERE / f"{step.script}.py"), *args]
    cmd += ["--json"] if step.json else []
    t0 = time.perf_counter()
    res = subprocess.run(cmd, capture_output=True, text=True, env={**os.environ, **dict(step.env)})
    if res.returncode != 0:
        print(f"   failed ({res.stderr.strip().splitlines()[-1:]})")
        return None
    out = res.stdout.strip()
    OUT.mkdir(exist_ok=True)
    if step.json:
        try:  # one JSON object: on its last line, or the whole output (indented)
            data = json.loads(out.splitlines()[-1])
        except (json.JSONDecodeError, IndexError):
            data = json.loads(out[out.index("{") :])
        _write(OUT / f"{step.name}.json", json.dumps(data, indent=2))
    else:
        data = out
        _write(OUT / f"{step.name}.txt", out + "\n")
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(f"   ({time.perf_counter() - t0:.0f} s, load average {load} at the end)")
    return data


def _write(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically (a temporary file, then a rename)."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(path)


def _ranges(runs: list[dict], key: str, fmt: str = ".3f") -> str:
    vals = [r[key] for r in runs]
    return f"{min(vals):{fmt}}-{max(vals):{fmt}}" if len(vals) > 1 else f"{vals[0]:{fmt}}"


def _tracking(d: dict) -> str:
    runs = d["runs"]
    return (
        f"   classical detector, {len(runs)} seeds (1080p, {d['video']['n_ants']} ants): "
        f"MOTA {_ranges(runs, 'mota')}, IDF1 {_ranges(runs, 'idf1')}, "
        f"{_ranges(runs, 'track_fps', '.1f')} frames/s"
    )


def _unet(d: dict) -> str:
    lines = []
    for name in ("classical", "unet"):
        runs = [r[name] for r in d["runs"]]
        lines.append(
            f"   {name:9s} {len(runs)} seeds: MOTA {_ranges(runs, 'mota')}, "
            f"IDF1 {_ranges(runs, 'idf1')}, {_ranges(runs, 'track_fps', '.1f')} frames/s"
        )
    return "\n".join(lines)


@dataclass(frozen=True)
class Step:
    """One benchmark: its script, its arguments (full and ``--quick``), and how its table
    is printed: a table step prints the script's own output; a JSON step (``json``)
    runs the script with ``--json`` and prints ``summary`` of the result."""

    name: str
    script: str
    full: list[str]
    quick: list[str]
    summary: Callable[[dict], str] | None = None
    needs: str | None = None  # a module that must be importable, or the step is skipped
    json: bool = False
    env: tuple[tuple[str, str], ...] = ()
    title: str = ""


#: The peer table's sizes: the README quotes the full command's figures.
ENGINE_FULL = ["--n", "1200", "--n", "10000", "--n", "100000", "--n", "1000000",
               "--phi", "0.5", "--budget-s", "10"]  # fmt: skip
ENGINE_QUICK = ["--n", "1200", "--n", "10000", "--phi", "0.5", "--budget-s", "2"]
LIMIT = ["--limit", "--settle", "2", "--phi", "0.5", "--n", "10000", "--n", "100000"]
#: The cost per robot-step from 1,200 to 1,000,000 robots (one thread, CPU time, after
#: 20 simulated seconds), and the largest over the smallest.
FLAT = ["--ours-only", "--settle", "20", "--phi", "0.5", "--n", "1200", "--n", "10000",
        "--n", "100000"]  # fmt: skip

#: Our tracker and its peers on MOT15's public Faster R-CNN boxes (real detector output
#: with ground truth); DATA is ``--boxes-data`` (not shipped: docs/tracking.md says how
#: to make it), tuned on five sequences, the other six held out.
BOXES = ["DATA", "--mot15", "--use-det", "--tune", "ADL-Rundle-6", "ETH-Bahnhof",
         "KITTI-13", "PETS09-S2L1", "TUD-Stadtmitte", "--check-trackeval"]  # fmt: skip

STEPS = [
    Step("engine", "bench_engine", ENGINE_FULL, ENGINE_QUICK,
         title="engine beside NumPy + cKDTree, JAX-MD, VMAS, pymunk (same workload)"),
    Step("limit", "bench_engine", [*LIMIT, "--n", "1000000"], LIMIT,
         title="engine against the machine's bandwidth"),
    Step("flat", "bench_engine", [*FLAT, "--n", "1000000"], FLAT,
         title="engine: cost per robot-step from 1,200 to 1,000,000 robots"),
    Step("jam", "engine_jam", [], ["--duration", "150"],
         title="jammed swarm: Jacobi sweeps alone, the first Gauss-Seidel solve, the default"),
    Step("gpu_rehearse", "bench_gpu",
         ["--rehearse", "--out", "bench-out/gpu_rehearse.json", "--skip", "unet", "tests"],
         ["--rehearse", "--out", "bench-out/gpu_rehearse.json", "--skip", "unet", "tests",
          "--phis", "0.5"],
         needs="numba_cuda", env=(("NUMBA_ENABLE_CUDASIM", "1"),),
         title="the GPU script on the CPU (numba-cuda's simulator, tiny sizes)"),
    Step("compression", "road_compression_study", ["claims"], [],
         title="compression: the ideal-gas claims"),
    Step("analysis", "bench_analysis", [],
         ["--n-tracks", "200", "--n-frames", "5000", "--bootstrap", "50"]),
    Step("tracking", "bench_tracking", [], ["--seeds", "1"], _tracking, json=True),
    Step("unet", "bench_unet", [],
         ["--seeds", "1", "--frames", "60", "--speed-frames", "5", "--set", "max_steps=200"],
         _unet, needs="torch", json=True),
    Step("light", "bench_light", [], ["--sizes", "100000"]),
    Step("io", "bench_io", [], ["--quick"]),
    Step("sweep", "bench_sweep", [], ["--runs", "100", "--tasks", "200", "--rounds", "2"],
         needs="distributed"),
    Step("tracking_real", "bench_tracking_real", ["--synthetic", "50", "100", "200"],
         ["--synthetic", "50", "--seeds", "0", "--levels", "moderate"], needs="trackers"),
    Step("tracking_boxes", "bench_tracking_real", BOXES, BOXES, needs="trackers",
         title="ours, ByteTrack, OC-SORT, SORT on real detector boxes (MOT15; DATA: "
         "--boxes-data, see docs/tracking.md)"),
    Step("tracking_ants", "bench_ant_boxes",
         ["--tune-peers", "bench-out/ant_peer_options.json", "--also", "pedestrians"],
         ["--dets", "post09", "--steps", "3"], needs="trackers",
         title="ours, ByteTrack, OC-SORT, SORT on real ant boxes at 15, 7.5, 5 fps "
         "(held-out half; DATA: --ant-boxes-data, see docs/tracking.md)"),
    Step("tracking_js16", "bench_js16_boxes", [], ["--steps", "2"], needs="trackers",
         title="ours, ByteTrack, OC-SORT, SORT on boxes made from real ant motion "
         "(anTraX JS16, 10 and 5 fps)"),
    Step("viewer", "bench_viewer", [], ["--sizes", "10000,100000", "--seconds", "3"]),
    Step("split_join", "bench_split_join", [], ["--frames", "4"], needs="cv2",
         title="duplicate detections of tiny split ants, joining off and on (drawn)"),
    Step("body_length", "bench_body_length", [], [], needs="cv2",
         title="body length measured without a scale, rendered and drawn ants of 4-40 px"),
    Step("tiny_clip", "bench_tiny_clip", [], ["--seconds", "3"], needs="cv2",
         title="track on a drawn clip of 66 small dark ants on white: share tracked, "
         "duplicates"),
    Step("registration", "bench_registration", ["walkers"], ["walkers"], needs="cv2",
         title="camera path error with large walkers in the picture (drawn floors)"),
    Step("self_trained", "bench_self_trained", ["frozen"], ["frozen"], needs="torch",
         title="track --detector self-trained beside the classical detector: a real fly "
         "clip with one fly frozen in place"),
    Step("self_trained_moved", "bench_self_trained", ["frozen", "--moved"],
         ["frozen", "--moved"], needs="torch",
         title="the same clip seen by a hand-held camera (registered first)"),
]  # fmt: skip
#: Steps that ``--quick`` leaves out (no quick size says anything).
FULL_ONLY = {"compression"}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller sizes")
    ap.add_argument("--only", choices=[s.name for s in STEPS])
    ap.add_argument("--tracking-data", type=Path, default=None,
                    help="folder of <sequence>/gt/gt.txt for the real-tracking step")  # fmt: skip
    ap.add_argument("--boxes-data", type=Path, default=None,
                    help="MOT15 folder (<sequence>/det/det.txt, gt/gt.txt) for the "
                    "real-detector-boxes step")  # fmt: skip
    ap.add_argument("--ant-boxes-data", type=Path,
                    default=Path(__file__).resolve().parents[2] / "shared/data/real_ant_boxes",
                    help="real_ant_boxes folder (AntTracking's output_4: ground truth and "
                    "YOLO boxes) for the real-ant-boxes step")  # fmt: skip
    a = ap.parse_args(argv)
    t_all = time.perf_counter()
    with tempfile.TemporaryDirectory() as empty:
        for step in STEPS:
            if a.only not in (None, step.name) or (a.quick and step.name in FULL_ONLY):
                continue
            print(f"\n## {step.name}" + (f": {step.title}" if step.title else ""))
            if step.needs and importlib.util.find_spec(step.needs) is None:
                print(f"   skipped ({step.needs} is not installed)")
                continue
            args = list(step.quick if a.quick else step.full)
            shown = command(step, a.quick)
            if step.name == "tracking_real":
                data = a.tracking_data or Path(empty)
                tune = ["--tune", "Seq0006Object21Image64"] if a.tracking_data else []
                args = [str(data), *tune, *args]
                shown = shown.replace(".py", f".py {data if a.tracking_data else 'EMPTY_DIR'}", 1)
            if step.name == "tracking_boxes":
                data = a.boxes_data or Path(empty)
                args = [str(data) if x == "DATA" else x for x in args]
                shown += f"   (DATA = {data if a.boxes_data else 'EMPTY_DIR: pass --boxes-data'})"
            if step.name == "tracking_ants":
                args = ["--data", str(a.ant_boxes_data), *args]
                shown += f" --data {a.ant_boxes_data}"
            print(f"command: {shown}\n", flush=True)
            d = _run(step, args)
            if d is not None:
                print(step.summary(d) if step.summary else d, flush=True)
    print(f"\nmake bench: {time.perf_counter() - t_all:.0f} s in all")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
