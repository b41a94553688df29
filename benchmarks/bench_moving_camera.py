"""A real still clip made hand-held: every frame moved by a known camera path (a drift,
a turn and a hand's shake), then tracked; the recovered path and the tracks are
compared with the truth (the still clip's own tracks, mapped into the first frame's px).

    python benchmarks/bench_moving_camera.py CLIP.mp4 OUT_DIR [--frames 150] [--start 0]
        [--view 800] [--px-per-mm S] [--set detector.polarity=light] [--gt GT.txt]

Writes OUT_DIR/moved.mp4, OUT_DIR/still/ and OUT_DIR/moved/ (``track_video``
outputs) and prints the path error (px at the frame corners), and for the still
clip's tracked body points in the view: the share within half a body length of a
moved-clip track point, and the median distance; each run's body length, the same
blobs' length in the picture, its number of warnings and its detector's background;
with ``--gt`` (the clip's labelled boxes, e.g. ``bench_real_footage.py --gt-mot``), the
still run scored against the labels of the frames taken.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def camera_matrix(k: int, margin: float) -> np.ndarray:
    """Camera px -> scene px at frame ``k``."""
    ang = np.radians(0.03 * k + 0.4 * np.sin(k / 6))
    tx = margin * 0.2 + 0.8 * k + 3 * np.sin(k / 3)
    ty = margin * 0.5 + 0.4 * k + 2 * np.cos(k / 4)
    c, s = np.cos(ang), np.sin(ang)
    return np.array([[c, -s, tx], [s, c, ty], [0, 0, 1.0]])


def main() -> None:
    import cv2

    from thermoswarm.errors import InputError
    from thermoswarm.io.mot import read_mot_table
    from thermoswarm.tracking.detect.register import camera_path
    from thermoswarm.tracking.pipeline import track_video
    from thermoswarm.tracking.synth.clip import write_video
    from thermoswarm.tracking.video import open_video

    ap = argparse.ArgumentParser()
    ap.add_argument("clip")
    ap.add_argument("out")
    ap.add_argument("--frames", type=int, default=150)
    ap.add_argument("--start", type=int, default=0, help="first frame taken (0-based)")
    ap.add_argument("--view", type=int, default=800)
    ap.add_argument("--set", dest="sets", action="append", default=[])
    ap.add_argument("--px-per-mm", type=float, default=None)
    ap.add_argument("--gt", type=Path, help="the clip's labelled boxes (MOTChallenge)")
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    opts = {}
    for item in a.sets:
        key, val = item.removeprefix("detector.").split("=", 1)
        for cast in (int, float, str):
            try:
                opts[key] = cast(val)
                break
            except ValueError:
                continue
    src = open_video(a.clip)
    frames = list(src.frames(a.start + a.frames))[a.start :]
    w = h = a.view
    margin = min(src.size) - a.view
    mats = [camera_matrix(k, margin) for k in range(len(frames))]
    moved = [
        cv2.warpAffine(f, m[:2], (w, h), flags=cv2.WARP_INVERSE_MAP | cv2.INTER_LINEAR)
        for f, m in zip(frames, mats, strict=True)
    ]
    write_video(moved, out / "moved.mp4", src.fps or 30.0)
    write_video(frames, out / "still.mp4", src.fps or 30.0)
    # The camera's path, measured as track measures it (whether or not track then finds
    # animals), against the truth at the frame's corners.
    got = camera_path(open_video(out / "moved.mp4").frames()).matrices
    c0 = np.linalg.inv(mats[0])
    truth = np.stack([(c0 @ m)[:2] for m in mats])
    corners = np.array([[0, 0, 1], [w, 0, 1], [0, h, 1], [w, h, 1.0]])
    path_err = np.abs(np.einsum("nij,kj->nki", got - truth, corners)).max()
    runs = {}
    for name, cam in (("still", "still"), ("moved", "auto")):
        try:
            runs[name] = track_video(
                out / f"{name}.mp4", out / name, px_per_mm=a.px_per_mm,
                detector_options=opts, camera=cam,
            )  # fmt: skip
        except InputError as exc:  # refused: say why
            runs[name] = {"refused": str(exc).split(": ", 1)[1][:200]}
    if any("refused" in r for r in runs.values()):
        brief = {
            k: r if "refused" in r else {"tracks": r["n_tracks"], "length_px": r["length_px"]}
            for k, r in runs.items()
        }
        print(json.dumps({"path_error_px": float(path_err), **brief}, indent=1))
        return
    s_still, s_moved = runs["still"], runs["moved"]
    # The still clip's body points (scene px) in the first frame's px, inside the view.
    A = read_mot_table(out / "still" / "tracks_mot.txt")
    B = read_mot_table(out / "moved" / "tracks_mot.txt")
    L = s_still["length_px"]
    fmt = {"still": s_still["length_px"], "moved": s_moved["length_px"]}
    near, dist = [], []
    for k in range(len(frames)):
        pa = A[A[:, 0] == k + 1][:, 2:4] + A[A[:, 0] == k + 1][:, 4:6] / 2
        pb = B[B[:, 0] == k + 1][:, 2:4] + B[B[:, 0] == k + 1][:, 4:6] / 2
        cam = np.linalg.inv(mats[k])
        pc = pa @ cam[:2, :2].T + cam[:2, 2]
        pa = pa[
            (pc[:, 0] > 0.1 * w)
            & (pc[:, 0] < 0.9 * w)
            & (pc[:, 1] > 0.1 * h)
            & (pc[:, 1] < 0.9 * h)
        ]
        pa = pa @ c0[:2, :2].T + c0[:2, 2]
        for p in pa:
            d = np.min(np.linalg.norm(pb - p, axis=1)) if len(pb) else np.inf
            near.append(d < 0.5 * L)
            dist.append(d)
    res = {
        "path_error_px": float(path_err),
        "camera": s_moved["camera"]["motion"],
        "still_tracks": s_still["n_tracks"],
        "moved_tracks": s_moved["n_tracks"],
        "points": len(near),
        "within_half_body": float(np.mean(near)),
        "median_px": float(np.median(dist)),
        "length_px": fmt,
        # The same blobs measured in the picture itself, and the runs' warnings.
        "picture_length_px": {k: r.get("picture_length_px") for k, r in runs.items()},
        "warnings": {k: len(r["warnings"]) for k, r in runs.items()},
        "background": {k: r.get("background") for k, r in runs.items()},
    }
    if a.gt is not None:
        res["still_vs_labels"] = against_labels(a.gt, A, a.start, len(frames), L)
    print(json.dumps(res, indent=1))


def against_labels(gt: Path, tracks: np.ndarray, start: int, n: int, length: float) -> dict:
    """The still run's ``tracks`` against the clip's labelled boxes of the frames taken
    (``start`` + 1 .. ``start`` + ``n``, renumbered from 1): TrackEval's MOTA, IDF1,
    HOTA at IoU 0.5 (``evaluate_tables``), and the share of labelled boxes whose centre
    lies within half a body ``length`` of a track box's centre (boxes of another size
    than the labels' still count: a run without a scale)."""
    from thermoswarm.tracking.evaluate import evaluate_tables

    truth = np.loadtxt(gt, delimiter=",", ndmin=2)
    truth = truth[(truth[:, 0] > start) & (truth[:, 0] <= start + n)].copy()
    truth[:, 0] -= start
    m = evaluate_tables(truth, tracks)
    found = 0
    for t in truth:
        at = tracks[tracks[:, 0] == t[0]]
        d = np.hypot(*(at[:, 2:4] + at[:, 4:6] / 2 - t[2:4] - t[4:6] / 2).T)
        found += bool(at.size) and d.min() <= 0.5 * length
    out = {k: float(m[k]) for k in ("mota", "idf1", "hota", "idsw", "fp", "fn")}
    return out | {"labels": len(truth), "within_half_body": found / max(len(truth), 1)}


if __name__ == "__main__":
    main()
