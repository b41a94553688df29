"""Duplicate detections of tiny dark ants on white, with and without joining split
bodies (issue 32, item 3; the drawn stand-in of ``tests/tracking/test_split_join.py``).

Each frame holds 60 ants 6-7 px long, the paper's ant drawn dark on a white 640 x 360
frame with pixel noise, a share of them split by a light band across the waist; the
classical detector learns the background and the ants' area from 12 such frames (told
the body length, 6.5 px, or with ``--no-scale`` measuring it as ``track`` does).
Every drawn ant is matched to a detection (body points within half a body length,
Hungarian); duplicates are further detections within one body length of an ant.

    python benchmarks/bench_split_join.py --frames 20 --split 0.33
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "tracking"))

from test_split_join import frame, prepared, scene, score  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    """Print ants found, duplicates and other detections per ant, joining off and on."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--frames", type=int, default=20, help="frames of 60 ants (default 20)")
    p.add_argument("--split", type=float, default=1 / 3, help="share of split ants")
    p.add_argument("--seed", type=int, default=60)
    p.add_argument(
        "--no-scale", action="store_true", help="measure the body length as `track` does"
    )
    a = p.parse_args(argv)
    print(f"{a.frames} frames of 60 ants 6-7 px, {a.split:.2f} of them split at the waist")
    print("joining | ants | found | duplicates | other detections | detection time")
    for join in (False, True):
        det = prepared(None if a.no_scale else 6.5, (6.0, 7.0), a.split, join=join)
        if join:
            print(f"body length used: {det.length_px:.2f} px")
        rng = np.random.default_rng(a.seed)
        tot = np.zeros(3, np.int64)
        ants = 0
        for _ in range(a.frames):
            drawn = scene(rng, 60, (6.0, 7.0), a.split)
            img = frame(rng, drawn)
            tot += score(det, img, np.array([d[0] for d in drawn]), 6.5)
            ants += len(drawn)
        t0 = time.perf_counter()
        for _ in range(20):  # the last frame again: the detection time
            det.detect(img)
        ms = (time.perf_counter() - t0) / 20 * 1e3
        f, d, o = (int(v) for v in tot)
        print(
            f"{'on' if join else 'off'} | {ants} | {f} ({f / ants:.3f}) | {d} ({d / ants:.3f})"
            f" | {o} ({o / ants:.3f}) | {ms:.1f} ms/frame"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
