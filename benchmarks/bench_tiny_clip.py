"""`thermoswarm track` on a drawn stand-in of issue 32's clip of small dark ants on white:
the share of ants tracked and of duplicate boxes, end to end, without a scale.

The real clip (640 x 360, 30 frames/s, 59-78 ants 6-7 px long, some split at the waist
by a lighter petiole) is not reachable here; this one is drawn like it with the ants of
``tests/tracking/test_split_join.py`` (the paper's ant: head, mesosoma and gaster
ellipses, dark on white with pixel noise; a third split by a light band 0.8-1.0 px
wide), walking: each ant keeps a speed of 2-14 body lengths/s (some stop and go), turns
by a random angle each frame and turns back at the walls.  ``track`` runs as a user
would (no scale, no option); the score is TrackEval's (``thermoswarm.tracking
.evaluate``) against the drawn ants' boxes, and, per drawn ant and frame, whether a
track box holds its body point (within half a body length; Hungarian) and how many
further boxes lie within one body length of an ant (duplicates).

    python benchmarks/bench_tiny_clip.py [--ants 66] [--seconds 10] [--seed 1] [--cut]

``--cut``: halfway through, every ant is drawn somewhere else (an edited clip's scene
cut on the same white floor); a track that goes on across it carries an id over onto
another ant, counted as ``across_cut``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "tracking"))

from test_split_join import H, W, draw_ant  # noqa: E402

FPS = 30.0


def walk(rng: np.random.Generator, n: int, frames: int, cut: bool) -> np.ndarray:
    """``(frames, n, 4)``: each ant's body point (x, y px), heading (rad) and length
    (px) per frame."""
    length = rng.uniform(6.0, 7.0, n)
    out = np.empty((frames, n, 4))
    pos = rng.uniform([20, 20], [W - 20, H - 20], (n, 2))
    head = rng.uniform(-np.pi, np.pi, n)
    speed = rng.uniform(2.0, 14.0, n) * length / FPS  # px a frame
    moving = np.ones(n, bool)
    for k in range(frames):
        if cut and k == frames // 2:  # the scene cut: every ant somewhere else
            pos = rng.uniform([20, 20], [W - 20, H - 20], (n, 2))
            head = rng.uniform(-np.pi, np.pi, n)
        flip = rng.random(n) < 1 / (2 * FPS)  # stop or go again every 2 s on average
        moving ^= flip
        head += rng.normal(0, 0.15, n)
        step = np.where(moving, speed, 0.0)
        pos += step[:, None] * np.c_[np.cos(head), np.sin(head)]
        for ax, hi in ((0, W - 12), (1, H - 12)):  # turn back at the walls
            out_lo, out_hi = pos[:, ax] < 12, pos[:, ax] > hi
            pos[:, ax] = np.clip(pos[:, ax], 12, hi)
            bounce = out_lo | out_hi
            if ax == 0:
                head[bounce] = np.pi - head[bounce]
            else:
                head[bounce] = -head[bounce]
        out[k, :, :2], out[k, :, 2], out[k, :, 3] = pos, head, length
    return out


def render(rng: np.random.Generator, ants: np.ndarray, split: np.ndarray) -> list[np.ndarray]:
    frames = []
    for state in ants:
        img = np.full((H, W), 235, np.uint8)
        for (x, y, h, L), gap in zip(state, split, strict=True):
            draw_ant(img, (x, y), float(h), float(L), float(gap))
        noisy = np.clip(img + rng.normal(0, 2.0, img.shape), 0, 255).astype(np.uint8)
        frames.append(np.repeat(noisy[..., None], 3, axis=2))
    return frames


def gt_table(ants: np.ndarray, cut: bool) -> np.ndarray:
    """MOT rows of the drawn ants: the box of head to tail, padded by half a width
    (as ``track`` pads its boxes); a new id after the cut."""
    from thermoswarm.tracking import anatomy

    rows = []
    half = len(ants) // 2
    for k, state in enumerate(ants):
        for i, (x, y, h, L) in enumerate(state):
            u = np.array([math.cos(h), math.sin(h)])
            ends = np.array([(x, y) + anatomy.FRONT * L * u, (x, y) + anatomy.BACK * L * u])
            pad = 0.5 * L * anatomy.ANT_WIDTH_MM / anatomy.ANT_LENGTH_MM
            lo, hi = ends.min(0) - pad, ends.max(0) + pad
            gid = i + 1 + (len(state) if cut and k >= half else 0)
            rows.append([k + 1, gid, lo[0], lo[1], *(hi - lo), 1, -1, -1, -1])
    return np.array(rows)


def per_ant(ants: np.ndarray, pred: np.ndarray, cut: bool) -> dict:
    """Share of ant-frames with a track box on the ant, duplicates per ant-frame, and
    tracks that go on across the cut."""
    from scipy.optimize import linear_sum_assignment

    hit = dup = total = 0
    for k, state in enumerate(ants):
        rows = pred[pred[:, 0] == k + 1]
        centre = rows[:, 2:4] + rows[:, 4:6] / 2
        truth, L = state[:, :2], state[:, 3]
        total += len(truth)
        if not len(centre):
            continue
        d = np.linalg.norm(centre[:, None] - truth[None], axis=2)
        r, c = linear_sum_assignment(np.where(d <= 0.5 * L[None], d, 1e6))
        ok = d[r, c] <= 0.5 * L[c]
        hit += int(ok.sum())
        rest = np.setdiff1d(np.arange(len(centre)), r[ok])
        dup += int(np.sum((d[rest] <= L[None]).any(axis=1)))
    across = 0
    if cut:
        half = len(ants) // 2
        before = set(pred[pred[:, 0] == half, 1].astype(int))
        after = set(pred[pred[:, 0] == half + 1, 1].astype(int))
        across = len(before & after)
    return {"tracked": hit / total, "duplicates": dup / total, "ant_frames": total,
            "across_cut": across}  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--ants", type=int, default=66)
    p.add_argument("--seconds", type=float, default=10.0)
    p.add_argument("--split", type=float, default=1 / 3, help="share split at the waist")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--cut", action="store_true")
    p.add_argument("--json", action="store_true")
    a = p.parse_args(argv)
    from thermoswarm.io.mot import read_mot_table
    from thermoswarm.tracking.evaluate import evaluate_tables
    from thermoswarm.tracking.pipeline import track_video
    from thermoswarm.tracking.synth.clip import write_video

    rng = np.random.default_rng(a.seed)
    n_frames = int(round(a.seconds * FPS))
    ants = walk(rng, a.ants, n_frames, a.cut)
    split = np.where(rng.random(a.ants) < a.split, rng.uniform(0.8, 1.0, a.ants), 0.0)
    with tempfile.TemporaryDirectory() as tmp:
        clip = Path(tmp) / "tiny.mp4"
        write_video(render(rng, ants, split), clip, FPS)
        s = track_video(clip, Path(tmp) / "run", overlay=False)
        pred = read_mot_table(Path(tmp) / "run" / "tracks_mot.txt")
    m = evaluate_tables(gt_table(ants, a.cut), pred)
    res = {
        "length_px": s["length_px"], "true_length_px": "6-7", "n_tracks": s["n_tracks"],
        "scene_cuts": s["camera"].get("scene_cuts"),
        **per_ant(ants, pred, a.cut),
        **{k: m[k] for k in ("mota", "idf1", "hota", "idsw", "fp", "fn")},
    }  # fmt: skip
    if a.json:
        print(json.dumps(res, indent=1))
    else:
        print(" | ".join(f"{k} {v:.3f}" if isinstance(v, float) else f"{k} {v}"
                         for k, v in res.items()))  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
