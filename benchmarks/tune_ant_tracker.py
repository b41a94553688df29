"""Coordinate search of our tracker's options on the tuning part of real_ant_boxes
(frames 3558-9860, never the held-out part), at 15, 7.5 and 5 fps.

Objective: the sum of MOTA + IDF1 + HOTA on ``post09`` boxes and of HOTA on
``320_raw`` boxes (whose boxes are half the ground truth's size, so no tracker gets a
match at IoU 0.5 there and only HOTA's low thresholds say anything) over the three
frame rates; ``post12`` is left out (its boxes do not line up with the ground truth:
median distance to the nearest true box 1,210 px).  Prints each trial and the best.

    python benchmarks/tune_ant_tracker.py --data ../shared/data/real_ant_boxes
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_ant_boxes as bab  # noqa: E402
from thermoswarm.tracking.track.presets import preset  # noqa: E402

#: Candidate values per option, searched one option at a time (two passes).
SPACE = {
    "confirm_s": [0.1, 0.3],
    "tentative_gap_s": [0.0, 0.4],
    "max_gap_s": [0.5, 2.0],
    "min_score": [0.5],
    "distance_weight": [0.5],
    "smooth_given": [True],
    "size_band": [0.0, 2.0],
    "max_cost": [2.0],
}


def objective(data: dict, cfg, steps: list[int]) -> tuple[float, list]:
    total, parts = 0.0, []
    for name in ("post09", "320_raw"):
        L = bab.length_of(data[name])
        for step in steps:
            gt = bab.cut(data["gt"], "tune", step)
            frames = bab.per_frame(bab.cut(data[name], "tune", step), bab.n_frames("tune", step))
            m = bab.score(gt, bab.run_ours(frames, bab.BASE_FPS / step, cfg, L))
            s = m["mota"] + m["idf1"] + m["hota"] if name == "post09" else m["hota"]
            total += s
            parts.append(round(s, 3))
    return total, parts


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", type=Path, default=Path("../shared/data/real_ant_boxes"))
    ap.add_argument("--steps", nargs="+", type=int, default=[1, 2, 3])
    ap.add_argument("--passes", type=int, default=2)
    ap.add_argument("--only", nargs="*", default=list(SPACE))
    a = ap.parse_args()
    names = ["post09", "320_raw"]
    data = bab.load_data(a.data, names)
    best: dict = {}
    top, parts = objective(data, preset("ants"), a.steps)
    print(f"start {top:.3f} {parts}", flush=True)
    for _ in range(a.passes):
        for key in a.only:
            for v in SPACE[key]:
                trial = {**best, key: v}
                s, parts = objective(data, preset("ants", **trial), a.steps)
                print(f"{json.dumps(trial)} {s:.3f} {parts}", flush=True)
                if s > top + 1e-6:
                    top, best = s, trial
    print("best", json.dumps(best), f"{top:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
