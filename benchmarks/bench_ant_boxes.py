"""Our tracker beside ByteTrack, OC-SORT and SORT on real ant detector boxes with
ground truth, at 15, 7.5 and 5 frames per second; MOTA, IDF1, HOTA, ID switches,
false positives and misses.

Data: ``real_ant_boxes`` (``--data``; the AntTracking repository's ``output_4``
colony video, github.com/imatge-upc/AntTracking at 5b6317e, GPL-3.0; its README
says what it is): the ground truth of frames 3558-16163 at 15 fps and three YOLO
detection sets (``post09``, ``post12``: 640 px SAHI tiles, post-processed;
``320_raw``: 320 px tiles, raw).  Nothing of it is in git.

Frame numbers: the detection files number the video's frames from 1 (1-16164), the
ground truth from 0 (its last frame is 16163): detection frame ``k + 1`` is
ground-truth frame ``k`` (``DET_FRAME_OFFSET``; ``--det-offset 0`` reads the files as
they are).  ``--alignment`` measures it: on the tuning part the median distance from a
true box's centre to the nearest ``post09`` box is 4.1 px at offset 1 against 16.4 px
at 0 (the ants walk about 15 px a frame).

Split by frame range: **tuning** frames 3558-9860 (the first half), **held out**
frames 9861-16163 (the second half).  Our defaults (the ``ants`` preset) and the
peers' tuned options were chosen on the tuning part only; the table reports both.

Frame rates: every ``k``-th frame kept (``--steps 1 2 3``: 15, 7.5 and 5 fps), the
detections and the ground truth alike (frames renumbered 1, 2, ...), and every
tracker told the true rate ``15 / k``.  The peers run at their defaults and tuned on
the tuning part (``PEER_GRID``, a small grid of their main thresholds that holds
their defaults, best mean of MOTA + IDF1 + HOTA, one option set per detector set and
frame rate); ``--tune-peers FILE`` runs that search and writes it, ``--peer-options
FILE`` reads it back.  Scores: ``thermoswarm.tracking.evaluate`` (TrackEval's
definitions; ``--check-trackeval`` re-checks every row with TrackEval itself).

    python benchmarks/bench_ant_boxes.py --data ../shared/data/real_ant_boxes \\
        --peer-options bench-out/ant_peer_options.json

``--speed``: our tracker's ``predict`` + ``update`` (and ``finish``) against
ByteTrack's own ``update`` on the same boxes (held-out part, 15 fps, ``post09``), in
this process, each timed on its own work only, interleaved, best of ``--repeat``.
"""

from __future__ import annotations

import argparse
import gzip
import itertools
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_tracking_real as btr  # noqa: E402
from thermoswarm.tracking.evaluate import evaluate_tables  # noqa: E402
from thermoswarm.tracking.track.presets import preset  # noqa: E402

#: Frame ranges of the split (inclusive, the ground truth's frame numbers).
PARTS = {"tune": (3558, 9860), "held-out": (9861, 16163)}
#: Detection files, by short name.
DETS = {
    "post09": "output_4_dets_yolo_sahi_640_post09.txt.gz",
    "post12": "output_4_dets_yolo_sahi_640_post12.txt.gz",
    "320_raw": "output_4_dets_yolo_sahi_320_raw.txt.gz",
}
GT = "output_4_gt.txt.gz"
BASE_FPS = 15.0
#: Detection frame ``k + DET_FRAME_OFFSET`` is ground-truth frame ``k`` (the detection
#: files count the video's frames from 1, the ground truth from 0).
DET_FRAME_OFFSET = 1

#: The peers' main thresholds searched on the tuning part; their defaults are in it.
PEER_GRID = {
    "ByteTrack": dict(
        track_activation_threshold=[0.05, 0.1, 0.2, 0.3, 0.5, 0.7],
        minimum_consecutive_frames=[1, 2], high_conf_det_threshold=[0.4, 0.5, 0.6],
    ),
    "OC-SORT": dict(
        minimum_iou_threshold=[0.01, 0.03, 0.05, 0.1, 0.3], minimum_consecutive_frames=[1, 3],
        high_conf_det_threshold=[0.4, 0.5, 0.6],
    ),
    "SORT": dict(
        minimum_iou_threshold=[0.01, 0.03, 0.05, 0.1, 0.3], minimum_consecutive_frames=[1, 3],
        track_activation_threshold=[0.25, 0.5, 0.6],
    ),
}  # fmt: skip


def load(path: Path) -> np.ndarray:
    """MOT rows ``(n, 10)`` of a gzipped MOTChallenge file."""
    with gzip.open(path, "rt") as f:
        t = np.loadtxt(f, delimiter=",", ndmin=2)
    return t.reshape(-1, 10) if t.size else np.zeros((0, 10))


def load_data(folder: Path, names: list[str], offset: int = DET_FRAME_OFFSET) -> dict:
    """The ground truth (``"gt"``) and the detection sets ``names``, the detections'
    frames renumbered as the ground truth's (``offset`` subtracted)."""
    data = {"gt": load(folder / GT)}
    for n in names:
        d = load(folder / DETS[n])
        d[:, 0] -= offset
        data[n] = d
    return data


def alignment(data: dict, name: str, offsets=(-1, 0, 1, 2)) -> list[tuple[int, float, float]]:
    """For each extra frame offset ``o`` of the detections (after the one applied at
    load): the median distance (px) from each true box's centre in the tuning part to
    the nearest box of ``name`` in frame ``f + o``, and the share within 10 px.
    Centres, not the IoU share of :func:`thermoswarm.tracking.evaluate.frame_offsets`
    (what ``thermoswarm evaluate`` checks): ``320_raw``'s half-size boxes match no
    true box at IoU 0.5 in any frame, but their centres still say which frame."""
    lo, hi = PARTS["tune"]
    gt, det = data["gt"], data[name]
    gt = gt[(gt[:, 0] >= lo) & (gt[:, 0] <= hi)]
    centre = lambda t: t[:, 2:4] + t[:, 4:6] / 2  # noqa: E731
    order = np.argsort(det[:, 0], kind="stable")
    det, dc = det[order], centre(det[order])
    out = []
    for o in offsets:
        lo_i = np.searchsorted(det[:, 0], gt[:, 0] + o, "left")
        hi_i = np.searchsorted(det[:, 0], gt[:, 0] + o, "right")
        dist = np.array([
            np.min(np.linalg.norm(dc[a:b] - c, axis=1)) if b > a else np.inf
            for a, b, c in zip(lo_i, hi_i, centre(gt), strict=True)
        ])  # fmt: skip
        out.append((o, float(np.median(dist)), float(np.mean(dist < 10))))
    return out


def cut(table: np.ndarray, part: str, step: int) -> np.ndarray:
    """Rows of ``table`` in ``part``'s frames, every ``step``-th frame from its first,
    renumbered 1, 2, ... (the same for detections and ground truth)."""
    lo, hi = PARTS[part]
    f = table[:, 0].astype(np.int64)
    keep = (f >= lo) & (f <= hi) & ((f - lo) % step == 0)
    out = table[keep].copy()
    out[:, 0] = (f[keep] - lo) // step + 1
    return out


def n_frames(part: str, step: int) -> int:
    lo, hi = PARTS[part]
    return (hi - lo) // step + 1


def per_frame(dets: np.ndarray, n: int) -> list[np.ndarray]:
    """Detection rows of frames 1..n (empty arrays for frames without any)."""
    order = np.argsort(dets[:, 0], kind="stable")
    dets = dets[order]
    idx = np.searchsorted(dets[:, 0], np.arange(1, n + 2))
    return [dets[idx[k] : idx[k + 1]] for k in range(n)]


def length_of(dets: np.ndarray) -> float:
    """The objects' size as ``thermoswarm track --detections`` measures it: the median
    longer side of all the file's boxes."""
    return float(np.median(np.max(dets[:, 4:6], axis=1)))


def run_ours(frames: list[np.ndarray], fps: float, cfg: Any, length_px: float) -> np.ndarray:
    from thermoswarm.tracking.track.tracker import Tracker

    tr = Tracker(cfg, fps=fps, length_px=length_px)
    for d in btr.our_detections(frames):
        tr.predict()
        tr.update(d)
    return tr.finish().mot_table()


def score(gt: np.ndarray, pred: np.ndarray) -> dict:
    return evaluate_tables(gt, pred)


def tune_peers(data: dict, dets_names: list[str], steps: list[int]) -> dict:
    """The best ``PEER_GRID`` options of each peer per detector set and frame step on
    the tuning part: ``{f"{dets}/{step}": {peer: options}}``."""
    out: dict[str, dict] = {}
    for name, step in itertools.product(dets_names, steps):
        gt = cut(data["gt"], "tune", step)
        frames = per_frame(cut(data[name], "tune", step), n_frames("tune", step))
        best: dict[str, dict] = {}
        for peer, grid in PEER_GRID.items():
            top = -np.inf
            for values in itertools.product(*grid.values()):
                opt = dict(zip(grid, values, strict=True))
                m = score(gt, btr.run_peer(peer, frames, BASE_FPS / step, opt))
                s = m["mota"] + m["idf1"] + m["hota"]
                if s > top:
                    top, best[peer] = s, opt
            print(f"  {name} 1/{step}: {peer} {best[peer]} ({top:.3f})", file=sys.stderr)
        out[f"{name}/{step}"] = best
    return out


def speed(data: dict, cfg: Any, repeat: int) -> dict:
    """Our tracker's time over ByteTrack's ``update`` on held-out ``post09`` boxes at
    15 fps (each timed on its own work, interleaved, best of ``repeat``)."""
    frames = per_frame(cut(data["post09"], "held-out", 1), n_frames("held-out", 1))
    L = length_of(data["post09"])
    ours_in = btr.our_detections(frames)
    peer_in = btr.peer_detections(frames)
    from thermoswarm.tracking.track.tracker import Tracker

    t_ours, t_bt = [], []
    for _ in range(repeat):
        tr = Tracker(cfg, fps=BASE_FPS, length_px=L)
        t0 = time.perf_counter()
        for d in ours_in:
            tr.predict()
            tr.update(d)
        tr.finish()
        t_ours.append(time.perf_counter() - t0)
        t_bt.append(btr.time_peer("ByteTrack", peer_in, BASE_FPS)[1])
    return dict(
        frames=len(frames),
        ours_s=min(t_ours),
        bytetrack_s=min(t_bt),
        ratio=min(t_bt) / min(t_ours),
    )


def _table(rows: list[dict]) -> str:
    lines = [
        "| part | boxes | fps | tracker | MOTA | IDF1 | HOTA | IDSW | FP | FN |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['part']} | {r['dets']} | {r['fps']:g} | {r['tracker']} | {r['mota']:.3f} "
            f"| {r['idf1']:.3f} | {r['hota']:.3f} | {r['idsw']} | {r['fp']} | {r['fn']} |"
        )
    return "\n".join(lines)


def _summary(rows: list[dict], ours: str) -> str:
    """Per part, detector set and frame rate: ``ours`` against the best peer (tuned
    or not) on each of MOTA, IDF1, HOTA and the fewest identity switches."""
    out = [
        "| part | boxes | fps | ours MOTA / IDF1 / HOTA / IDSW | best peer on each |",
        "|---|---|---|---|---|",
    ]
    for key in dict.fromkeys((r["part"], r["dets"], r["fps"]) for r in rows):
        group = [r for r in rows if (r["part"], r["dets"], r["fps"]) == key]
        me = [r for r in group if r["tracker"] == ours]
        peers = [r for r in group if not r["tracker"].startswith("ours")]
        if not me or not peers:
            continue
        m = me[0]
        best = []
        for k in ("mota", "idf1", "hota"):
            p = max(peers, key=lambda r: r[k])  # noqa: B023
            best.append(f"{p[k]:.3f} ({p['tracker']})")
        p = min(peers, key=lambda r: r["idsw"])
        best.append(f"{p['idsw']} ({p['tracker']})")
        out.append(
            f"| {key[0]} | {key[1]} | {key[2]:g} | {m['mota']:.3f} / {m['idf1']:.3f} / "
            f"{m['hota']:.3f} / {m['idsw']} | {' / '.join(best)} |"
        )
    return "\n".join(out)


def _merge(paths: list[Path], ours: str) -> int:
    """Print the tables of earlier ``--json`` outputs (later rows replace earlier ones
    of the same part, detector set, frame rate and tracker)."""
    merged: dict = {}
    for path in paths:
        for r in json.loads(path.read_text())["rows"]:
            merged[r["part"], r["dets"], r["fps"], r["tracker"]] = r
    rows = list(merged.values())
    print(_table(rows) + "\n\n" + _summary(rows, ours))
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=Path("../shared/data/real_ant_boxes"))
    ap.add_argument("--parts", nargs="+", default=["held-out"], choices=list(PARTS))
    ap.add_argument("--dets", nargs="+", default=list(DETS), choices=list(DETS))
    ap.add_argument("--steps", nargs="+", type=int, default=[1, 2, 3])
    ap.add_argument("--preset", default="ants", help="our tracker's preset")
    ap.add_argument("--set", dest="overrides", nargs="*", default=[], metavar="KEY=VALUE")
    ap.add_argument("--also", nargs="*", default=[], metavar="PRESET",
                    help="also our tracker at these presets (e.g. pedestrians)")  # fmt: skip
    ap.add_argument("--no-peers", action="store_true")
    ap.add_argument("--peer-options", type=Path, help="peers' tuned options (JSON)")
    ap.add_argument("--tune-peers", type=Path, help="search PEER_GRID, write JSON here")
    ap.add_argument("--check-trackeval", action="store_true")
    ap.add_argument("--speed", action="store_true", help="only the speed ratio")
    ap.add_argument(
        "--det-offset",
        type=int,
        default=DET_FRAME_OFFSET,
        help="detection frame k + OFFSET is ground-truth frame k (0: as read)",
    )
    ap.add_argument("--alignment", action="store_true",
                    help="only how well each detection set lines up with the ground truth "
                    "at frame offsets -1..2 around --det-offset (tuning part)")  # fmt: skip
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--merge", nargs="+", type=Path, metavar="JSON",
                    help="only print the tables of earlier --json outputs (rows of later "
                    "files replace those of earlier ones for the same tracker)")  # fmt: skip
    args = ap.parse_args(argv)
    if args.merge:
        return _merge(args.merge, f"ours ({args.preset})")
    if not (args.data / GT).exists():
        print(f"{args.data}: no {GT} (see docs/tracking.md)", file=sys.stderr)
        return 2
    from thermoswarm.config import parse_overrides

    cfg = preset(args.preset, **parse_overrides(args.overrides))
    names = sorted(set(args.dets) | ({"post09"} if args.speed else set()))
    data = load_data(args.data, names, args.det_offset)
    if args.alignment:
        for n in names:
            for o, med, near in alignment(data, n):
                print(f"{n}: detection frame k{args.det_offset + o:+d} for true frame k: "
                      f"median distance {med:.1f} px, {near:.2f} within 10 px")  # fmt: skip
        return 0
    if args.speed:
        s = speed(data, cfg, args.repeat)
        print(json.dumps(s) if args.json else (
            f"{s['frames']} frames (held-out, post09, 15 fps): ours {s['ours_s']:.3f} s, "
            f"ByteTrack update {s['bytetrack_s']:.3f} s, ours {s['ratio']:.2f}x as fast "
            f"(best of {args.repeat}, this process)"))  # fmt: skip
        return 0
    peer_opts: dict[str, dict] = {}
    if args.tune_peers is not None:
        peer_opts = tune_peers(data, args.dets, args.steps)
        args.tune_peers.parent.mkdir(parents=True, exist_ok=True)
        args.tune_peers.write_text(json.dumps(peer_opts, indent=1))
    elif args.peer_options is not None:
        peer_opts = json.loads(args.peer_options.read_text())
    ours = {f"ours ({args.preset})": cfg}
    for p in args.also:
        ours[f"ours ({p})"] = preset(p)
    rows = []
    for part, name, step in itertools.product(args.parts, args.dets, args.steps):
        # Class -1 read as 1 (pedestrian), as TrackEval's MOT17 reader requires; the
        # scores are the same either way.
        gt = btr.considered_gt(cut(data["gt"], part, step))
        frames = per_frame(cut(data[name], part, step), n_frames(part, step))
        fps = BASE_FPS / step
        preds = {k: run_ours(frames, fps, c, length_of(data[name])) for k, c in ours.items()}
        if not args.no_peers:
            for peer in PEER_GRID:
                preds[peer] = btr.run_peer(peer, frames, fps)
                opt = peer_opts.get(f"{name}/{step}", {}).get(peer)
                if opt is not None:
                    preds[f"{peer} (tuned)"] = btr.run_peer(peer, frames, fps, opt)
        for tracker, pred in preds.items():
            m = score(gt, pred)
            if args.check_trackeval:
                with tempfile.TemporaryDirectory() as tmp:
                    btr._trackeval_check(gt, pred, m, Path(tmp))
            keys = ("mota", "idf1", "hota", "idsw", "fp", "fn")
            rows.append(
                dict(part=part, dets=name, fps=fps, tracker=tracker, **{k: m[k] for k in keys})
            )
            if not args.json:
                print(_table(rows[-1:]).splitlines()[-1], flush=True)
    if args.json:
        print(json.dumps({"peer_options": peer_opts, "rows": rows}, indent=1))
    else:
        print("\n" + _table(rows) + "\n\n" + _summary(rows, f"ours ({args.preset})"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
