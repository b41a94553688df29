"""``track --detector self-trained`` beside the classical detector, on real pixels.

Three rows each: the classical detector (its background learned over time), the same
with ``detector.background=picture`` (each frame against its own surroundings) and
the self-trained U-Net.

``frozen``: SLEAP's two-fly clip as shipped in ``tests/data/sleap_fly_clip`` (500
frames, 10 frames/s, 256 x 256), with fly 1 frozen where it stood in frame 1
(``tests/tracking/test_self_trained.py``'s clip): the classical detector, which finds
what differs from a still background, never finds it.  With ``--moved``, the same clip
seen by a hand-held camera (``tests/tracking/test_still_animals.py``'s slow hand: a
200 x 200 px view that drifts, turns and shakes), so both runs register it first;
the truth is mapped into its first frame's px.

``cut CLIP GT``: a real clip's first ``--max-frames`` frames, scored against the
labelled boxes ``GT`` (SLEAP's full fly clip: ``bench_real_footage.py --gt-mot``; its
first 1,100 frames hold the flies standing still until frame 1,000).

Both: MOTA, IDF1, HOTA, misses and false positives (IoU 0.5), and the seconds each
run took (the self-trained one's includes its classical pass and its training).

    python benchmarks/bench_self_trained.py frozen [--figure docs/figures/self_trained_flies.png]
    python benchmarks/bench_self_trained.py frozen --no-ignore   # the ablation
    python benchmarks/bench_self_trained.py frozen --moved       # a hand-held camera
    python benchmarks/bench_self_trained.py cut clip.mp4 clip_gt.txt --max-frames 1100 \\
        --px-per-mm 14.94 --set detector.polarity=light
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "tracking"))

KEYS = ("mota", "idf1", "hota", "fn", "fp", "idsw")


def _run(video: Path, out: Path, truth: np.ndarray, overlay: bool = False, **kw) -> dict:
    from thermoswarm.io.mot import read_mot_table
    from thermoswarm.tracking.evaluate import evaluate_tables
    from thermoswarm.tracking.pipeline import track_video

    t = time.perf_counter()
    s = track_video(video, out, overlay=overlay, **kw)
    m = evaluate_tables(truth, read_mot_table(out / "tracks_mot.txt"))
    row = {k: m[k] for k in KEYS} | {"seconds": round(time.perf_counter() - t, 1)}
    row["n_tracks"] = s["n_tracks"]
    if "self_training" in s:
        row["train_seconds"] = s["self_training"]["train_seconds"]
    return row


def both(video: Path, truth: np.ndarray, tmp: Path, **kw) -> dict:
    """The classical detector's row, the same with the picture background (each frame
    against its own surroundings: ``detector.background=picture``) and the self-trained
    one's."""
    pic = {
        **kw,
        "detector_options": {**(kw.get("detector_options") or {}), "background": "picture"},
    }
    return {
        "classical": _run(video, tmp / "c", truth, **kw),
        "classical, picture background": _run(video, tmp / "p", truth, **pic),
        "self-trained": _run(video, tmp / "s", truth, detector="self-trained", **kw),
    }


def figure(tmp: Path, path: Path, frame: int = 200, scale: int = 2) -> None:
    """Frame ``frame`` of the three runs' overlays side by side, enlarged ``scale`` times."""
    import cv2

    panels = []
    for sub, title in (("c", "classical"), ("p", "picture bg"), ("s", "self-trained")):
        cap = cv2.VideoCapture(str(tmp / sub / "overlay.mp4"))
        cap.set(cv2.CAP_PROP_POS_FRAMES, frame - 1)
        ok, img = cap.read()
        assert ok, f"no frame {frame} in {sub}/overlay.mp4"
        img = cv2.resize(img, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
        cv2.putText(img, f"{title}, frame {frame}", (8, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.7,
                    (255, 255, 255), 2, cv2.LINE_AA)  # fmt: skip
        panels.append(img)
    gap = np.full((panels[0].shape[0], 8, 3), 255, np.uint8)
    cv2.imwrite(str(path), np.hstack([panels[0], gap, panels[1], gap, panels[2]]))


def moved(video: Path, truth: np.ndarray, out: Path) -> tuple[Path, np.ndarray]:
    """``video`` seen by the slow hand of ``test_still_animals.py``, and ``truth`` in
    its first frame's px (the hand is not turned at frame 0)."""
    import cv2
    from test_still_animals import VIEW, _hand

    from thermoswarm.tracking.synth.clip import write_video
    from thermoswarm.tracking.video import open_video

    src = open_video(video)
    frames = (
        cv2.warpAffine(f, _hand(k)[:2], VIEW, flags=cv2.WARP_INVERSE_MAP | cv2.INTER_LINEAR)
        for k, f in enumerate(src.frames())
    )
    path = out / "moved.mp4"
    write_video(frames, path, src.fps or 10.0)
    truth = truth.copy()
    truth[:, 2:4] -= _hand(0)[:2, 2]
    return path, truth


def _options(sets: list[str]) -> dict:
    out = {}
    for s in sets:
        key, _, value = s.partition("=")
        out[key.removeprefix("detector.")] = value
    return out


def main(argv: list[str] | None = None) -> int:
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--json", action="store_true")
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="what", required=True)
    frozen = sub.add_parser("frozen", parents=[common])
    frozen.add_argument("--figure", type=Path, help="write both overlays' frame 200 here")
    frozen.add_argument(
        "--no-ignore",
        action="store_true",
        help="ablation: train without leaving the unlabelled blobs out (every place but "
        "the labels taught as floor)",
    )
    frozen.add_argument("--moved", action="store_true", help="seen by a hand-held camera")
    cut = sub.add_parser("cut", parents=[common])
    cut.add_argument("clip", type=Path)
    cut.add_argument("gt", type=Path)
    cut.add_argument("--max-frames", type=int, required=True)
    cut.add_argument("--px-per-mm", type=float)
    cut.add_argument("--set", nargs="*", default=[], help="detector.KEY=VALUE")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        if args.what == "frozen":
            from test_self_trained import PX_PER_MM, frozen_fly_clip

            if args.no_ignore:
                from thermoswarm.tracking.pipeline import self_train

                self_train._unlabelled_spots = lambda frame, points: np.zeros((0, 2))

            video, truth, _ = frozen_fly_clip(tmp)
            if args.moved:
                video, truth = moved(video, truth, tmp)
            rows = both(video, truth, tmp, px_per_mm=PX_PER_MM, overlay=args.figure is not None,
                        detector_options={"polarity": "light"})  # fmt: skip
            if args.figure is not None:
                figure(tmp, args.figure)
        else:
            from thermoswarm.io.mot import read_mot_table

            truth = read_mot_table(args.gt)
            truth = truth[truth[:, 0] <= args.max_frames]
            rows = both(args.clip, truth, tmp, px_per_mm=args.px_per_mm,
                        max_frames=args.max_frames,
                        detector_options=_options(args.set) or None)  # fmt: skip
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    print("| detector | MOTA | IDF1 | HOTA | misses | false positives | ID switches | s |")
    print("|---|---|---|---|---|---|---|---|")
    for name, r in rows.items():
        print(f"| {name} | {r['mota']:.3f} | {r['idf1']:.3f} | {r['hota']:.3f} | {r['fn']} | "
              f"{r['fp']} | {r['idsw']} | {r['seconds']} |")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
