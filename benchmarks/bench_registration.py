"""The camera path with animals walking in the picture: how far the registration is off
(the largest error at any corner of any frame), and what ``track`` then scores.

``walkers``: drawn clips filmed by the moving camera of ``tests/tracking/
test_moving_camera.py`` (a drift of 0.6, 0.3 px a frame, a turn of 0.05 deg a frame, a
hand's shake), 60 frames each: a dark textured floor or a dark floor with a grid of light
holes, two or four light walkers 60 or 80 px long at about 3 px a frame; seeds 1-4.

``whole CLIP GT``: a real clip (SLEAP's fly clip, ``tests/tracks/clip.mp4`` of
talmolab/sleap at 7785f660) seen through a ``--view`` px camera that drifts 0.15 and
0.1 px a frame, turns 0.004 deg a frame and shakes (3 px, 0.4 deg) over all its frames;
the path error, then ``track`` at ``--px-per-mm`` scored against the labelled boxes
``GT`` (``bench_real_footage.py --gt-mot``), mapped into the first frame's px; with
``--max-frames N`` the clip's first N frames only, with ``--detector self-trained``
the U-Net trained on the moved clip's classical tracks (``track --detector
self-trained``).

    python benchmarks/bench_registration.py walkers
    python benchmarks/bench_registration.py whole clip.mp4 clip_gt.txt --px-per-mm 14.94 \\
        --set detector.polarity=light
    python benchmarks/bench_registration.py whole clip.mp4 clip_gt.txt --px-per-mm 14.94 \\
        --set detector.polarity=light --max-frames 1100 --detector self-trained
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "tracking"))


def _corner_error(matrices: np.ndarray, truth: np.ndarray, w: int, h: int) -> float:
    corners = np.array([[0, 0, 1], [w, 0, 1], [0, h, 1], [w, h, 1.0]])
    return float(np.abs(np.einsum("nij,kj->nki", matrices - truth, corners)).max())


def walkers(seed: int, size: float, n_walk: int, grid: bool, n: int = 60) -> float:
    """Path error (px) on one drawn clip."""
    import cv2
    from test_moving_camera import VIEW, _truth, filmed

    from thermoswarm.tracking.detect.register import camera_path

    rng = np.random.default_rng(seed)
    floor = np.full((300, 600), 35.0, np.float32)
    if grid:
        img = np.full((300, 600), 35, np.uint8)
        for y in range(10, 300, 22):
            for x in range(10, 600, 22):
                cv2.circle(img, (x, y), 4, 190, -1, cv2.LINE_AA)
        floor = img.astype(np.float32)
    else:
        floor += cv2.GaussianBlur(rng.normal(0, 25, (300, 600)).astype(np.float32), (0, 0), 3)
    starts = rng.uniform([100, 60], [450, 200], (n_walk, 2))
    vel = rng.normal(0, 3, (n_walk, 2))
    frames = []
    for k in range(n):
        f = floor.copy()
        for c0, v in zip(starts, vel, strict=True):
            c = c0 + k * v
            ang = float(np.degrees(np.arctan2(v[1], v[0])))
            cv2.ellipse(f, ((float(c[0]), float(c[1])), (size, size * 0.37), ang), 210.0, -1,
                        cv2.LINE_AA)  # fmt: skip
        f = np.clip(f + rng.normal(0, 2, f.shape), 0, 255).astype(np.uint8)
        frames.append(np.repeat(f[..., None], 3, axis=2))
    p = camera_path(filmed(frames))
    return _corner_error(p.matrices, _truth(n), *VIEW)


def _hand(k: int) -> np.ndarray:
    """Camera px -> clip px at frame ``k`` (the slow hand of ``whole``)."""
    ang = np.radians(0.004 * k + 0.4 * np.sin(k / 6))
    tx, ty = 60 + 0.15 * k + 3 * np.sin(k / 3), 60 + 0.1 * k + 2 * np.cos(k / 4)
    c, s = np.cos(ang), np.sin(ang)
    return np.array([[c, -s, tx], [s, c, ty], [0, 0, 1.0]])


def whole(
    clip: str,
    gt: str,
    view: int,
    px_per_mm: float | None,
    opts: dict,
    max_frames: int | None = None,
    detector: str | None = None,
) -> dict:
    import cv2

    from thermoswarm.io.mot import read_mot_table
    from thermoswarm.tracking.detect.register import camera_path
    from thermoswarm.tracking.evaluate import evaluate_tables
    from thermoswarm.tracking.pipeline import track_video
    from thermoswarm.tracking.synth.clip import write_video
    from thermoswarm.tracking.video import open_video

    src = open_video(clip)
    with tempfile.TemporaryDirectory() as tmp:
        moved = Path(tmp) / "moved.mp4"
        frames = (
            cv2.warpAffine(
                f, _hand(k)[:2], (view, view), flags=cv2.WARP_INVERSE_MAP | cv2.INTER_LINEAR
            )  # fmt: skip
            for k, f in enumerate(src.frames(max_frames))
        )
        write_video(frames, moved, src.fps or 30.0)
        p = camera_path(open_video(moved).frames())
        c0 = np.linalg.inv(_hand(0))
        truth = np.stack([(c0 @ _hand(k))[:2] for k in range(len(p.matrices))])
        out = {
            "frames": len(p.matrices),
            "path_error_px": _corner_error(p.matrices, truth, view, view),
        }
        s = track_video(moved, Path(tmp) / "t", px_per_mm=px_per_mm, overlay=False,
                        detector=detector, detector_options=opts)  # fmt: skip
        boxes = np.loadtxt(gt, delimiter=",", ndmin=2)
        boxes = boxes[boxes[:, 0] <= len(p.matrices)].copy()
        boxes[:, 2:4] -= _hand(0)[:2, 2]  # the first frame's px (not turned at frame 0)
        m = evaluate_tables(boxes, read_mot_table(Path(tmp) / "t" / "tracks_mot.txt"))
    out.update(
        registered=s["camera"]["registered"], prepare_frames=s["prepare_frames"],
        prepare_step=s.get("prepare_step"), tracks=s["n_tracks"],
        **{k: m[k] for k in ("mota", "idf1", "hota", "idsw", "fp", "fn")},
    )  # fmt: skip
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="what", required=True)
    sub.add_parser("walkers")
    w = sub.add_parser("whole")
    w.add_argument("clip")
    w.add_argument("gt")
    w.add_argument("--view", type=int, default=600)
    w.add_argument("--px-per-mm", type=float, default=None)
    w.add_argument("--set", dest="sets", action="append", default=[])
    w.add_argument("--max-frames", type=int, default=None)
    w.add_argument("--detector", choices=["classical", "self-trained"], default=None)
    a = ap.parse_args()
    if a.what == "walkers":
        rows = {}
        for seed in (1, 2, 3, 4):
            for size, n_walk, grid in (
                (60, 2, True),
                (80, 2, True),
                (60, 4, True),
                (60, 2, False),
            ):
                key = f"seed {seed}, {n_walk} x {size} px, {'hole grid' if grid else 'textured'}"
                rows[key] = round(walkers(seed, size, n_walk, grid), 2)
        print(json.dumps(rows, indent=1))
        return
    opts = {}
    for item in a.sets:
        key, val = item.removeprefix("detector.").split("=", 1)
        opts[key] = val
    got = whole(a.clip, a.gt, a.view, a.px_per_mm, opts, a.max_frames, a.detector)
    print(json.dumps(got, indent=1))


if __name__ == "__main__":
    main()
