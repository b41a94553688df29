"""The classical detector and the U-Net + pose model on labelled frames of real ant
video: detection precision and recall, keypoint errors, the U-Net zero-shot (trained on
synthetic data only) and fine-tuned from 1, 2, 4, ... labelled frames, and MOTA where
the held-out frames are consecutive and carry track identities.

    python benchmarks/bench_real_footage.py LABELS.slp --px-per-mm S --model synth.pt \\
        [--nodes HEAD,BODY,TAIL] [--image-root DIR] [--frames 1,2,4,8,16,31] \\
        [--steps 300] [--held-out 0.3] [--threads 2] [--json OUT.json]
        [--keep 0:1050:10,1350:1500] [--test-from 1350] [--polarity light]
        [--peer PREDICTIONS.slp] [--gt-mot GT.txt]

On real fly footage (SLEAP's tests/data/tracks, the commands and numbers in
docs/real_footage.md): ``--keep`` reads only those labelled frames of a long file,
``--test-from`` holds out the frames from that number on (instead of the last share),
``--polarity light`` for light animals on a dark floor, ``--peer`` scores a peer's
SLEAP predictions on the same held-out frames (its tracks for MOTA, IDF1, HOTA; a
skeleton without tail node is scored on head and body, its boxes and the labels'
from those two), and ``--gt-mot`` only writes the tracked labels as MOTChallenge
ground truth for ``thermoswarm evaluate``.  ``--model`` may be left out (no U-Net rows).

``LABELS``: a SLEAP ``.slp`` (images embedded, or its videos beside it or in
``--image-root``) or COCO keypoints ``.json``, read as ``thermoswarm track train
--labels`` reads it (user labels; unlabelled ants in a frame are ignore regions).
``--model``: the synthetic model (``thermoswarm track train --synthetic --out
synth.pt``), evaluated as is (zero-shot) and fine-tuned.

Split (stated in the output): per video, the labelled frames in time order; the last
``--held-out`` share of each video's frames are held out (a block of time, so that no
held-out frame has a near-copy among the training frames), the others form the
training pool.  Fine-tuning on n frames uses the first n of one seeded permutation of
the pool (nested sets: 1 of 2 of 4 ...).  Nothing is tuned on the held-out frames.

Matching (stated): per held-out frame, detected and labelled body points are paired by
the Hungarian algorithm within half a body length L = 7.14 mm x ``--px-per-mm`` (the
ant length the models assume at that scale, as ``track train`` validates); unpaired
detections within that radius of an unlabelled ant (ignore region) are not false
positives.  Keypoint errors are those of the paired ants, in px and in L.  The table's
header gives the labelled head-to-tail distance over L (0.66 when head and tail are the
centres of head and gaster, as in thermoswarm; about 1 for the tips of the ant): far
from these, the scale is wrong for the models.  MOTA: runs of consecutive
held-out frames in which every labelled ant has a track; boxes from head, body and
tail as everywhere in thermoswarm (``anatomy.pose_boxes``), IoU 0.5.

The classical detector runs with its defaults, its background learned from all
labelled frames of the video (images only, no labels), no running update between the
sparse frames (``bg_rate`` 0).  Training: ``--steps`` steps at the defaults of
``TrainConfig`` otherwise (``--set`` changes them), ``nice -n 10`` advised on shared
machines.  Times are wall seconds in this process.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

from thermoswarm.tracking import anatomy  # noqa: E402
from thermoswarm.tracking.train.fit import (  # noqa: E402
    LabeledFrames,
    TrainConfig,
    detection_metrics,
    read_labels,
    train,
)


def keep_frames(path: Path, keep: str, tmp: Path) -> Path:
    """A copy of the SLEAP file ``path`` holding only the labelled frames whose numbers
    lie in ``keep`` (Python slices ``START:STOP[:STEP]`` joined by commas), so that
    long labelled videos are read in part (1,500 frames of 1024x1024 are 4.7 GB)."""
    import sleap_io as sio

    want: set[int] = set()
    for part in keep.split(","):
        a = [int(x) if x else None for x in part.split(":")]
        want |= set(range(100_000)[slice(*a)])
    labels = sio.load_slp(str(path))
    labels.labeled_frames = [lf for lf in labels.labeled_frames if lf.frame_idx in want]
    out = tmp / path.name
    sio.save_slp(labels, str(out), embed=False)
    return out


def labelled_length(data: LabeledFrames) -> float:
    """Median head-to-tail distance (px) of the labelled ants that have both."""
    d = [np.linalg.norm(p[:, 0] - p[:, 2], axis=-1) for p in data.points if p.shape[0]]
    d = np.concatenate(d) if d else np.zeros(0)
    d = d[np.isfinite(d)]
    return float(np.median(d)) if d.size else float("nan")


def split_frames(
    data: LabeledFrames, held_out: float, seed: int, test_from: int | None = None
) -> tuple[list[int], list[int]]:
    """Training pool (a seeded permutation) and held-out frames (time order): the last
    ``held_out`` share of each video's labelled frames (at least one) are held out, or,
    with ``test_from``, the frames numbered ``test_from`` or later in every video."""
    keys = data.keys or [(0, i) for i in range(len(data))]
    by_video: dict[int, list[int]] = {}
    for i in sorted(range(len(data)), key=lambda i: keys[i]):
        by_video.setdefault(keys[i][0], []).append(i)
    pool, test = [], []
    for idx in by_video.values():
        if test_from is not None:
            pool += [i for i in idx if keys[i][1] < test_from]
            test += [i for i in idx if keys[i][1] >= test_from]
            continue
        n_test = max(1, int(round(held_out * len(idx)))) if len(idx) > 1 else 0
        pool += idx[: len(idx) - n_test]
        test += idx[len(idx) - n_test :]
    if not pool or not test:
        raise SystemExit("error: too few labelled frames to hold some out")
    rng = np.random.default_rng(seed)
    return [pool[i] for i in rng.permutation(len(pool))], test


def consecutive_runs(data: LabeledFrames, idx: list[int]) -> list[list[int]]:
    """Runs (length >= 2) of frames of ``idx`` that follow each other in one video and
    whose labelled ants all have a track."""
    if data.keys is None or data.tracks is None:
        return []
    runs: list[list[int]] = []
    cur: list[int] = []
    for i in sorted(idx, key=lambda i: data.keys[i]):
        ok = bool((data.tracks[i] >= 0).all())
        if cur and ok:
            (v0, f0), (v1, f1) = data.keys[cur[-1]], data.keys[i]
            if v0 == v1 and f1 == f0 + 1:
                cur.append(i)
                continue
        if len(cur) >= 2:
            runs.append(cur)
        cur = [i] if ok else []
    if len(cur) >= 2:
        runs.append(cur)
    return runs


def score(dets: list[Any], data: LabeledFrames, idx: list[int], length: float) -> dict[str, Any]:
    """Detection metrics at radius length / 2, errors also in body lengths."""
    m = detection_metrics(
        dets, [data.points[i] for i in idx], 0.5 * length, [data.ignore_at(i) for i in idx]
    )
    for k in anatomy.KEYPOINTS:
        m[f"{k}_error_median_L"] = m[f"{k}_error_median_px"] / length
    return m


def gt_boxes(
    data: LabeledFrames, run: list[int], length: float, drop_tail: bool = False
) -> np.ndarray:
    """MOT rows of the labelled ants of a run (frames numbered from 1); ``drop_tail``:
    boxes from head and body only, as for a peer whose skeleton has no tail."""
    pad = 0.5 * anatomy.ANT_WIDTH_MM / anatomy.ANT_LENGTH_MM * length  # half a width
    rows = []
    for k, i in enumerate(run):
        pts = data.points[i].copy()
        if drop_tail:
            pts[:, 2] = np.nan
        b = anatomy.pose_boxes(pts, pad)
        for t, box in zip(data.tracks[i], b, strict=True):
            rows.append([k + 1, t + 1, *box, 1, 1, 1])
    return np.asarray(rows, dtype=np.float64).reshape(-1, 9)


def mota(
    dets: dict[int, Any] | None,
    data: LabeledFrames,
    runs: list[list[int]],
    length: float,
    fps: float,
    tables: list[np.ndarray] | None = None,
) -> dict[str, Any] | None:
    """CLEAR-MOT counts summed over the consecutive runs; IDF1 and HOTA their mean
    weighted by the run's labelled boxes.  ``dets`` are tracked by thermoswarm's
    tracker; ``tables`` (one MOT table per run, frames from 1) are a peer's tracks."""
    from thermoswarm.tracking.evaluate import evaluate_tables
    from thermoswarm.tracking.track.tracker import track_detections

    if not runs:
        return None
    tot = {"n_gt": 0, "fp": 0, "fn": 0, "idsw": 0}
    wsum = {"idf1": 0.0, "hota": 0.0}
    for r, run in enumerate(runs):
        gt = gt_boxes(data, run, length, drop_tail=tables is not None)
        if tables is not None:
            pred = tables[r]
        else:
            H, W = data.frames[run[0]].shape[:2]
            res = track_detections(
                [dets[i] for i in run], fps=fps, length_px=length, frame_size=(W, H)
            )
            pred = res.mot_table()
        m = evaluate_tables(gt, pred)
        for key in tot:
            tot[key] += int(m[key])
        for key in wsum:
            wsum[key] += float(m[key]) * int(m["n_gt"])
    tot["mota"] = 1 - (tot["fp"] + tot["fn"] + tot["idsw"]) / max(tot["n_gt"], 1)
    for key in wsum:
        tot[key] = wsum[key] / max(tot["n_gt"], 1)
    tot["n_runs"] = len(runs)
    return tot


class _Points:
    """Detections of a peer: only ``points`` ``(n, 3, 2)``, as the metrics read them."""

    def __init__(self, points: np.ndarray) -> None:
        self.points = points


def read_peer(
    path: Path,
    data: LabeledFrames,
    test: list[int],
    runs: list[list[int]],
    length: float,
    nodes: list[str] | None,
) -> tuple[dict[int, Any], list[np.ndarray]]:
    """A peer's SLEAP predictions on the held-out frames: per frame its head, body and
    tail (NaN where its skeleton lacks the node, e.g. SLEAP's 2-node head-thorax model),
    and per MOTA run its own tracks as MOT rows (boxes from its points as for the
    labels)."""
    import sleap_io as sio

    labels = sio.load_slp(str(path))
    want = nodes or ["head", "thorax", "abdomen"]
    by_key: dict[tuple[int, int], list[tuple[np.ndarray, int]]] = {}
    track_no = {id(t): k for k, t in enumerate(labels.tracks)}
    for lf in labels.labeled_frames:
        names = lf.instances[0].skeleton.node_names if lf.instances else []
        have = [n for n in want if n in names]
        for inst in lf.predicted_instances or lf.instances:
            xy = np.asarray(inst.numpy(), dtype=np.float64)[:, :2]
            p = np.full((3, 2), np.nan)
            for role, n in enumerate(want):
                if n in have:
                    p[role] = xy[list(names).index(n)]
            tid = track_no.get(id(inst.track), -1) if inst.track is not None else -1
            by_key.setdefault((0, int(lf.frame_idx)), []).append((p, tid))
    keys = data.keys or [(0, i) for i in range(len(data))]
    dets = {}
    for i in test:
        got = by_key.get((0, keys[i][1]), [])
        pts = np.asarray([p for p, _ in got], dtype=np.float64).reshape(-1, 3, 2)
        dets[i] = _Points(pts[np.all(np.isfinite(pts[:, 1]), axis=-1)])
    pad = 0.5 * anatomy.ANT_WIDTH_MM / anatomy.ANT_LENGTH_MM * length
    tables = []
    for run in runs:
        rows = []
        for k, i in enumerate(run):
            for p, tid in by_key.get((0, keys[i][1]), []):
                if np.all(np.isfinite(p[1])):
                    box = anatomy.pose_boxes(p[None], pad)[0]
                    rows.append([k + 1, tid + 1, *box, 1, -1, -1, -1])
        tables.append(np.asarray(rows, dtype=np.float64).reshape(-1, 10))
    return dets, tables


def run_classical(
    data: LabeledFrames, test: list[int], length: float, polarity: str = "dark"
) -> tuple[dict, dict]:
    from thermoswarm.tracking.detect.classical import ClassicalConfig, ClassicalDetector

    keys = data.keys or [(0, i) for i in range(len(data))]
    dets: dict[int, Any] = {}
    t0 = time.perf_counter()
    for v in sorted({k[0] for k in keys}):
        frames = [i for i in range(len(data)) if keys[i][0] == v]
        det = ClassicalDetector(data.px_per_mm, ClassicalConfig(bg_rate=0.0, polarity=polarity))
        det.prepare(data.frames[i] for i in frames)
        for i in test:
            if keys[i][0] == v:
                dets[i] = det.detect(data.frames[i])
    m = score([dets[i] for i in test], data, test, length)
    m["seconds"] = time.perf_counter() - t0
    return m, dets


def run_unet(
    model_path: Path, data: LabeledFrames, test: list[int], length: float, threads: int | None
) -> tuple[dict, dict]:
    from thermoswarm.tracking.detect.unet import UNetDetector, UNetOptions, load_model

    det = UNetDetector(
        load_model(model_path), px_per_mm=data.px_per_mm, options=UNetOptions(threads=threads)
    )
    t0 = time.perf_counter()
    dets = {i: det.detect(data.frames[i]) for i in test}
    m = score([dets[i] for i in test], data, test, length)
    m["seconds"] = time.perf_counter() - t0
    return m, dets


def write_gt_mot(path: Path, nodes: list[str] | None, length: float, out: Path) -> int:
    """The tracked labelled animals of a SLEAP file as MOTChallenge ground truth
    (frame = video frame + 1, id = track + 1, boxes as :func:`gt_boxes`; images are not
    read), for ``thermoswarm evaluate`` against ``thermoswarm track`` on the video."""
    import sleap_io as sio

    from thermoswarm.fsutil import atomic_write_text
    from thermoswarm.tracking.train.data import node_map

    labels = sio.load_slp(str(path))
    track_no = {id(t): k for k, t in enumerate(labels.tracks)}
    pad = 0.5 * anatomy.ANT_WIDTH_MM / anatomy.ANT_LENGTH_MM * length
    rows = []
    for lf in labels.labeled_frames:
        for inst in lf.user_instances:
            if inst.track is None:
                continue
            nm = node_map(inst.skeleton.node_names, nodes, str(path))
            p = nm.apply(np.asarray(inst.numpy(), dtype=np.float64)[:, :2])
            if np.all(np.isfinite(p[1])):
                box = anatomy.pose_boxes(p[None], pad)[0]
                rows.append([lf.frame_idx + 1, track_no[id(inst.track)] + 1, *box, 1, 1, 1])
    rows.sort()
    text = "".join(",".join(f"{v:g}" for v in r) + "\n" for r in rows)
    atomic_write_text(out, text)
    print(f"{out}: {len(rows)} boxes")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("labels", type=Path, help="SLEAP .slp or COCO keypoint .json")
    ap.add_argument("--px-per-mm", type=float, required=True, help="scale of the images")
    ap.add_argument("--model", type=Path, help="model trained on synthetic data (none: no U-Net)")
    ap.add_argument("--nodes", help="HEAD,BODY,TAIL node names ('+' averages nodes)")
    ap.add_argument("--image-root", type=Path, help="folder of the images or videos")
    ap.add_argument("--predicted", action="store_true", help="also prediction-only frames")
    ap.add_argument("--frames", default="1,2,4,8,16,31", help="fine-tuning set sizes")
    ap.add_argument("--steps", type=int, default=300, help="fine-tuning steps per size")
    ap.add_argument("--held-out", type=float, default=0.3, help="share of each video held out")
    ap.add_argument("--test-from", type=int, help="hold out the frames numbered from here on")
    ap.add_argument("--keep", help="read only these frame numbers, e.g. 0:1050:10,1350:1500")
    ap.add_argument("--polarity", choices=["dark", "light"], default="dark",
                    help="classical detector: dark animals or light ones")  # fmt: skip
    ap.add_argument("--peer", type=Path, help="a peer's SLEAP predictions on the same video")
    ap.add_argument("--peer-nodes", default="head,thorax,abdomen",
                    help="the peer's node names for head,body,tail")  # fmt: skip
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=None, help="PyTorch threads")
    ap.add_argument("--fps", type=float, default=30.0, help="frame rate (MOTA runs only)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="TrainConfig override for fine-tuning, e.g. patch_size=128")  # fmt: skip
    ap.add_argument("--json", type=Path, help="write the results here too")
    ap.add_argument("--gt-mot", type=Path,
                    help="only write the labels as MOT ground truth here")  # fmt: skip
    args = ap.parse_args(argv)

    from thermoswarm.config import apply_overrides, from_mapping, parse_overrides
    from thermoswarm.errors import InputError

    tmpdir = tempfile.TemporaryDirectory(prefix="bench-real-keep-")
    try:
        nodes = None if args.nodes is None else [n.strip() for n in args.nodes.split(",")]
        if args.gt_mot is not None:
            L = anatomy.ANT_LENGTH_MM * args.px_per_mm
            return write_gt_mot(args.labels, nodes, L, args.gt_mot)
        labels_path = args.labels
        if args.keep:
            labels_path = keep_frames(args.labels, args.keep, Path(tmpdir.name))
        data = read_labels(
            labels_path,
            px_per_mm=args.px_per_mm,
            nodes=nodes,
            image_root=args.image_root,
            include_predicted=args.predicted,
        )
        sizes = sorted({int(x) for x in args.frames.split(",") if x.strip()})
        base = dict(max_steps=args.steps, eval_every=args.steps, val_fraction=0.0)
        base.update(seed=args.seed, threads=args.threads)
        cfg = from_mapping(
            TrainConfig, apply_overrides(base, parse_overrides(args.set)), source="--set"
        )
    except (InputError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    labelled = labelled_length(data)
    length = anatomy.ANT_LENGTH_MM * args.px_per_mm
    pool, test = split_frames(data, args.held_out, args.seed, args.test_from)
    runs = consecutive_runs(data, test)
    n_test_ants = sum(data.points[i].shape[0] for i in test)
    split = {
        "n_frames": len(data),
        "pool": len(pool),
        "held_out": len(test),
        "held_out_ants": n_test_ants,
        "held_out_ignored": int(sum(data.ignore_at(i).shape[0] for i in test)),
        "body_length_px": length,
        "labelled_head_tail_px": labelled,
        "match_radius_px": 0.5 * length,
        "mota_runs": len(runs),
        "source": data.source,
    }
    rows: list[dict[str, Any]] = []

    def add(name: str, n: int | None, m: dict, dets: dict, extra: dict | None = None) -> None:
        row = {"detector": name, "frames": n, **m, **(extra or {})}
        t = mota(dets, data, runs, length, args.fps)
        row["mota"] = None if t is None else t["mota"]
        row["mota_detail"] = t
        rows.append(row)

    if args.peer is not None:
        d, tables = read_peer(args.peer, data, test, runs, length, args.peer_nodes.split(","))
        m = score([d[i] for i in test], data, test, length)
        row = {"detector": f"peer {args.peer.name}", "frames": None, **m}
        t = mota(None, data, runs, length, args.fps, tables=tables)
        row["mota"] = None if t is None else t["mota"]
        row["mota_detail"] = t
        rows.append(row)
    m, d = run_classical(data, test, length, args.polarity)
    add("classical", None, m, d)
    if args.model is not None:
        m, d = run_unet(args.model, data, test, length, args.threads)
        add("unet zero-shot", 0, m, d)
    with tempfile.TemporaryDirectory(prefix="bench-real-") as tmp:
        for n in sizes if args.model is not None else []:
            if n > len(pool):
                continue
            out = Path(tmp) / f"ft{n}.pt"
            t0 = time.perf_counter()
            rep = train(data.subset(pool[:n]), out, cfg, init=args.model)
            t_train = time.perf_counter() - t0
            m, d = run_unet(out, data, test, length, args.threads)
            add("unet fine-tuned", n, m, d, {"train_seconds": t_train, "steps": rep["steps"]})

    held = (
        f"frames {args.test_from} on"
        if args.test_from is not None
        else f"last {args.held_out:.0%} of each video"
    )
    print(
        f"{args.labels.name}: {split['n_frames']} labelled frames; training pool "
        f"{split['pool']}, held out {split['held_out']} ({held}, "
        f"{n_test_ants} ants, {split['held_out_ignored']} unlabelled ants ignored); "
        f"body length L {length:.1f} px (labelled head-tail {labelled / length:.2f} L), "
        f"match radius {0.5 * length:.1f} px; "
        f"fine-tuning {args.steps} steps from "
        f"{args.model.name if args.model else '(no model)'}"
    )
    hdr = (
        f"{'detector':<16} {'frames':>6} {'P':>6} {'R':>6} {'F1':>6} {'body px':>8} "
        f"{'body L':>8} {'head px':>8} {'tail px':>8} {'swap':>6} {'MOTA':>6} "
        f"{'IDF1':>6} {'HOTA':>6} {'IDSW':>5} "
        f"{'train s':>8} {'detect s':>8}"
    )
    print(hdr)
    print("-" * len(hdr))
    for r in rows:
        md = r.get("mota_detail") or {}

        def f(x: Any, w: int, p: int = 3) -> str:
            return (
                f"{'-':>{w}}"
                if x is None or (isinstance(x, float) and np.isnan(x))
                else (f"{x:>{w}.{p}f}")
            )

        print(
            f"{r['detector']:<16} {'-' if r['frames'] is None else r['frames']:>6} "
            f"{f(r['precision'], 6)} {f(r['recall'], 6)} {f(r['f1'], 6)} "
            f"{f(r['body_error_median_px'], 8, 2)} {f(r['body_error_median_L'], 8)} "
            f"{f(r['head_error_median_px'], 8, 2)} {f(r['tail_error_median_px'], 8, 2)} "
            f"{f(r['head_tail_swapped'], 6)} {f(r['mota'], 6)} "
            f"{f(md.get('idf1'), 6)} {f(md.get('hota'), 6)} {md.get('idsw', '-'):>5} "
            f"{f(r.get('train_seconds'), 8, 1)} {f(r.get('seconds'), 8, 1)}"
        )
    result = {
        "benchmark": "real_footage",
        "labels": str(args.labels),
        "split": split,
        "config": {k: v for k, v in vars(args).items() if k not in ("labels",)},
        "train_config": dataclasses.asdict(cfg),
        "rows": rows,
    }
    if args.json is not None:
        from thermoswarm.fsutil import atomic_write_json

        atomic_write_json(args.json, json.loads(json.dumps(result, default=str)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
