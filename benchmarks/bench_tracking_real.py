"""Our tracker beside ByteTrack, OC-SORT and SORT on the same detections of real ant
sequences; MOTA, IDF1, HOTA, ID switches and frames per second for each.

Data: folders ``DATA/<sequence>/gt/gt.txt`` (MOTChallenge ground truth of real ant
video).  The benchmark was run on an excerpt of the public ANTS dataset (Cao et al.
2021, "ANTS -- ant detection and tracking", Mendeley Data, doi:10.17632/9ws98g4npw;
manual point annotations with identities, boxes of fixed size around each point): see
docs/tracking.md for how to obtain it.  That dataset ships no detector output (its
``det.txt`` is the ground truth without identities), so the detections are the
ground truth passed through a seeded detection-noise model (:func:`noisy_detections`:
misses, runs of misses, jitter, merged neighbours, duplicates and false boxes, with
scores); a folder ``DATA/<sequence>/det/det.txt`` of real detector output is used
instead with ``--use-det``.

Every tracker sees the same boxes and scores; scores are computed with
``thermoswarm.tracking.evaluate`` (equal to TrackEval's CLEAR, Identity and HOTA,
tested; ``--check-trackeval`` re-checks every row here).  Speed: tracking only (no I/O,
no scoring): only each tracker's own work is timed -- ours ``predict`` + ``update``
per frame and ``finish``, each peer's ``update`` per frame; every tracker's input
(our ``FrameDetections``, the peers' ``supervision.Detections``) is built before the
timer and its output turned into a MOT table after it.  The best of ``--repeat`` runs
interleaved with the other trackers', frames per second in this process; ``ours/it`` is
our speed over the tracker's (geometric mean over seeds; > 1: ours is faster).

    python benchmarks/bench_tracking_real.py DATA --tune Seq0006Object21Image64
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.io.mot import read_mot_table
from thermoswarm.tracking.detect.classical import FrameDetections
from thermoswarm.tracking.evaluate import evaluate_tables
from thermoswarm.tracking.track.tracker import Tracker, TrackerConfig

#: Noise levels of the detection model (per ground-truth box unless said otherwise).
NOISE = {
    "moderate": dict(
        p_miss=0.08, p_run=0.01, run_mean=5, jitter=0.06, size_jitter=0.06,
        p_merge=0.5, p_dup=0.02, fp_rate=0.03,
    ),
    "hard": dict(
        p_miss=0.15, p_run=0.03, run_mean=8, jitter=0.12, size_jitter=0.12,
        p_merge=0.8, p_dup=0.05, fp_rate=0.08,
    ),
}  # fmt: skip


def noisy_detections(gt: np.ndarray, level: str, seed: int) -> np.ndarray:
    """MOT detection rows made from ground truth ``gt`` by a seeded noise model.

    Per object and frame: missed with ``p_miss``, or within a run of misses (a run
    starts with ``p_run`` and lasts a geometric number of frames of mean
    ``run_mean``: occlusions); centre moved by a normal of sd ``jitter`` x box size,
    sides scaled by ``exp(N(0, size_jitter))``.  Two objects whose centres are closer
    than 0.6 box sizes are merged into one box covering both with ``p_merge``
    (touching ants).  A second box offset by 0.3 sizes is added with ``p_dup``, and
    ``fp_rate`` false boxes per object and frame appear anywhere in the objects'
    range.  Scores: Beta(6, 2) for true boxes, Beta(3, 3) for merged and duplicated
    ones, Beta(2, 5) for false ones.
    """
    p = NOISE[level]
    rng = np.random.default_rng(seed)
    gt = gt[np.lexsort((gt[:, 1], gt[:, 0]))]
    frames = np.unique(gt[:, 0]).astype(int)
    run_left: dict[int, int] = {}
    lo, hi = gt[:, 2:4].min(0), (gt[:, 2:4] + gt[:, 4:6]).max(0)
    out = []
    for f in frames:
        rows = gt[gt[:, 0] == f]
        n = len(rows)
        size = rows[:, 4:6].mean(1)
        keep = np.ones(n, bool)
        for i, ident in enumerate(rows[:, 1].astype(int)):
            left = run_left.get(ident, 0)
            if left == 0 and rng.random() < p["p_run"]:
                left = int(rng.geometric(1 / p["run_mean"]))
            if left > 0:
                keep[i] = False
                run_left[ident] = left - 1
            elif rng.random() < p["p_miss"]:
                keep[i] = False
        c = rows[:, 2:4] + rows[:, 4:6] / 2
        boxes, scores = [], []
        used = np.zeros(n, bool)
        for i in range(n):
            if not keep[i] or used[i]:
                continue
            d = np.linalg.norm(c - c[i], axis=1)
            near = np.flatnonzero(keep & ~used & (d < 0.6 * size[i]) & (np.arange(n) != i))
            if near.size and rng.random() < p["p_merge"]:
                j = near[0]
                x0 = np.minimum(rows[i, 2:4], rows[j, 2:4])
                x1 = np.maximum(rows[i, 2:4] + rows[i, 4:6], rows[j, 2:4] + rows[j, 4:6])
                boxes.append([*x0, *(x1 - x0)])
                scores.append(rng.beta(3, 3))
                used[[i, j]] = True
                continue
            used[i] = True
            wh = rows[i, 4:6] * np.exp(p["size_jitter"] * rng.standard_normal(2))
            cc = c[i] + p["jitter"] * size[i] * rng.standard_normal(2)
            boxes.append([*(cc - wh / 2), *wh])
            scores.append(rng.beta(6, 2))
            if rng.random() < p["p_dup"]:
                off = 0.3 * size[i] * rng.standard_normal(2)
                boxes.append([*(cc + off - wh / 2), *wh])
                scores.append(rng.beta(3, 3))
        for _ in range(rng.poisson(p["fp_rate"] * n)):
            s = float(np.median(size))
            xy = rng.uniform(lo, np.maximum(hi - s, lo + 1))
            boxes.append([*xy, s, s])
            scores.append(rng.beta(2, 5))
        for b, s in zip(boxes, scores, strict=True):
            out.append([f, -1, *b, s, -1, -1, -1])
    return np.asarray(out, dtype=np.float64).reshape(-1, 10)


def _per_frame(dets: np.ndarray, n_frames: int) -> list[np.ndarray]:
    return [dets[dets[:, 0] == f] for f in range(1, n_frames + 1)]


def synthetic_boxes(n: int, n_frames: int, seed: int, size: float = 30.0) -> np.ndarray:
    """MOT ground truth of ``n`` box objects walking for ``n_frames`` frames (seeded).

    Each object keeps a heading that turns by a normal of sd 0.2 rad per frame at a
    speed redrawn (exponential, mean 0.07 box sizes per frame) with probability 0.05
    per frame, and reflects off the walls of a square arena of ``3 size sqrt(n)`` px a
    side (about three box sizes between neighbours); box sides ``size`` x
    ``exp(N(0, 0.1))``, fixed per object.  Detections come from it through
    :func:`noisy_detections`, as for the real sequences.
    """
    rng = np.random.default_rng(seed)
    side = 3 * size * np.sqrt(n)
    pos = rng.uniform(size, side - size, (n, 2))
    head = rng.uniform(-np.pi, np.pi, n)
    speed = rng.exponential(0.07 * size, n)
    wh = size * np.exp(0.1 * rng.standard_normal((n, 2)))
    rows = []
    for f in range(1, n_frames + 1):
        head += 0.2 * rng.standard_normal(n)
        redraw = rng.random(n) < 0.05
        speed[redraw] = rng.exponential(0.07 * size, redraw.sum())
        pos += speed[:, None] * np.c_[np.cos(head), np.sin(head)]
        for a in (0, 1):
            lo, hi = pos[:, a] < size, pos[:, a] > side - size
            pos[lo | hi, a] = np.clip(pos[lo | hi, a], size, side - size)
            head[lo | hi] = np.pi - head[lo | hi] if a == 0 else -head[lo | hi]
        t = np.full((n, 10), -1.0)
        t[:, 0], t[:, 1] = f, np.arange(1, n + 1)
        t[:, 2:4], t[:, 4:6], t[:, 6] = pos - wh / 2, wh, 1.0
        rows.append(t)
    return np.concatenate(rows)


def our_detections(frames: list[np.ndarray]) -> list[FrameDetections]:
    """Our tracker's input for each frame (boxes, their centres as the body point)."""
    out = []
    for r in frames:
        b = r[:, 2:6]
        pts = np.full((len(r), 3, 2), np.nan)
        pts[:, 1] = b[:, :2] + b[:, 2:] / 2
        out.append(FrameDetections(pts, r[:, 6], boxes=b))
    return out


def time_ours(
    dets: list[FrameDetections], fps: float, config: TrackerConfig, tracker: type = Tracker
) -> tuple[Any, float]:
    """Our tracker on prepared detections: ``(finished tracks, seconds)``.

    Timed: ``predict`` and ``update`` for every frame and ``finish`` (which closes the
    open tracks: part of producing them); not timed: building the detections (before)
    and the MOT table (after).
    """
    tr = tracker(config, fps=fps)
    t0 = time.perf_counter()
    for d in dets:
        tr.predict()
        tr.update(d)
    result = tr.finish()
    return result, time.perf_counter() - t0


def run_ours(
    frames: list[np.ndarray], fps: float, config: TrackerConfig, tracker: type = Tracker
) -> np.ndarray:
    """Our tracker's MOT table for MOT detection rows per frame (untimed)."""
    return time_ours(our_detections(frames), fps, config, tracker)[0].mot_table()


#: Our tracker's defaults before the real-box work (issue 26, item 6): the fields
#: that changed, at their old values (``--previous`` runs them beside the defaults).
#: Then in frames (3 detections, one miss), here in seconds at 25 fps.
PREVIOUS_DEFAULTS: dict[str, Any] = dict(
    confirm_s=0.08, tentative_gap_s=0.04, max_gap_s=1.0, accel_bl_s2=28.0, adapt_range=5.0,
    min_iou=0.0, relink_gate=False, duplicate_radius=0.5, duplicate_overlap=1.0,
    distance_weight=1.0, mahalanobis_weight=0.0, max_cost=2.0, min_score=0.0,
)  # fmt: skip

#: The peers' options searched on the tuning sequences (their own search spaces,
#: ``trackers``' ``search_space``, on a coarse grid); the defaults are in every grid.
PEER_GRID = {
    "ByteTrack": dict(
        track_activation_threshold=[0.3, 0.5, 0.7], high_conf_det_threshold=[0.4, 0.6],
        minimum_iou_threshold=[0.1, 0.3], minimum_consecutive_frames=[1, 2, 3],
    ),
    "OC-SORT": dict(
        high_conf_det_threshold=[0.3, 0.45, 0.6], minimum_iou_threshold=[0.1, 0.2, 0.3],
        minimum_consecutive_frames=[1, 2, 3],
    ),
    "SORT": dict(
        track_activation_threshold=[0.25, 0.5], minimum_iou_threshold=[0.1, 0.2, 0.3],
        minimum_consecutive_frames=[1, 2, 3],
    ),
}  # fmt: skip


def peer_detections(frames: list[np.ndarray]) -> list[Any]:
    """The peers' input for each frame: ``supervision.Detections`` (xyxy, scores)."""
    import supervision as sv

    out = []
    for r in frames:
        xyxy = np.c_[r[:, 2:4], r[:, 2:4] + r[:, 4:6]] if len(r) else np.zeros((0, 4))
        out.append(
            sv.Detections(
                xyxy=xyxy.astype(np.float32),
                confidence=r[:, 6].astype(np.float32),
                class_id=np.zeros(len(r), int),
            )
        )
    return out


def time_peer(
    name: str, dets: list[Any], fps: float, options: dict | None = None
) -> tuple[list[Any], float]:
    """A peer tracker on prepared detections: ``(its output per frame, seconds)``.

    Timed: its ``update`` for every frame, nothing else (the detections are built
    before, its output turned into a MOT table after).
    """
    from trackers import ByteTrackTracker, OCSORTTracker, SORTTracker

    make = {"ByteTrack": ByteTrackTracker, "OC-SORT": OCSORTTracker, "SORT": SORTTracker}
    tracker = make[name](frame_rate=fps, **(options or {}))
    t0 = time.perf_counter()
    res = [tracker.update(d) for d in dets]
    return res, time.perf_counter() - t0


def peer_table(res: list[Any]) -> np.ndarray:
    """MOT rows of a peer's output per frame (frames numbered from 1)."""
    out = []
    for k, r in enumerate(res, 1):
        ok = r.tracker_id >= 0
        for b, i, s in zip(r.xyxy[ok], r.tracker_id[ok], r.confidence[ok], strict=True):
            out.append([k, i + 1, b[0], b[1], b[2] - b[0], b[3] - b[1], s, -1, -1, -1])
    return np.asarray(out, dtype=np.float64).reshape(-1, 10)


def run_peer(
    name: str, frames: list[np.ndarray], fps: float, options: dict | None = None
) -> np.ndarray:
    """A peer's MOT table for MOT detection rows per frame (untimed)."""
    return peer_table(time_peer(name, peer_detections(frames), fps, options)[0])


def seq_fps(folder: Path, default: float) -> float:
    """Frame rate of a sequence folder: ``frameRate`` of its ``seqinfo.ini`` (the
    MOTChallenge layout) if there is one, else ``default`` (``--fps``)."""
    ini = folder / "seqinfo.ini"
    if ini.exists():
        for line in ini.read_text().splitlines():
            key, _, value = line.partition("=")
            if key.strip() == "frameRate" and value.strip():
                return float(value)
    return default


def considered_gt(gt: np.ndarray, mot15: bool = False) -> np.ndarray:
    """Ground-truth rows that count: those not marked 0 in column 7 (MOTChallenge's
    "ignore"), with an absent class (-1) written as 1 (pedestrian), so that
    TrackEval's MOT17 preprocessing and ours read the same rows.  ``mot15``: the
    MOT15 layout, whose columns 8-10 are world coordinates, not class and
    visibility (every row is then of class 1)."""
    gt = gt[gt[:, 6] != 0].copy()
    if mot15:
        gt[:, 7:10] = -1
    gt[gt[:, 7] == -1, 7] = 1
    return gt


def _gmean(x: list[float]) -> float:
    return float(np.exp(np.mean(np.log(x))))


#: Our keys and TrackEval's (metric, field): counts compared exactly, floats to
#: :data:`TRACKEVAL_TOL` (HOTA's fields are TrackEval's means over its 19 thresholds).
TRACKEVAL_COUNTS = {
    "idsw": ("CLEAR", "IDSW"), "fp": ("CLEAR", "CLR_FP"), "fn": ("CLEAR", "CLR_FN"),
    "tp": ("CLEAR", "CLR_TP"), "mt": ("CLEAR", "MT"), "pt": ("CLEAR", "PT"),
    "ml": ("CLEAR", "ML"), "frag": ("CLEAR", "Frag"),
}  # fmt: skip
TRACKEVAL_FLOATS = {
    "mota": ("CLEAR", "MOTA"), "motp": ("CLEAR", "MOTP"), "idf1": ("Identity", "IDF1"),
    "idp": ("Identity", "IDP"), "idr": ("Identity", "IDR"), "hota": ("HOTA", "HOTA"),
    "deta": ("HOTA", "DetA"), "assa": ("HOTA", "AssA"), "loca": ("HOTA", "LocA"),
}  # fmt: skip
TRACKEVAL_TOL = 1e-9


def _write_exact(path: Path, table: np.ndarray) -> None:
    """A MOT file of ``table``'s rows in their own order, every number written so that
    it reads back as the same float64 (``%.17g``): TrackEval then reads exactly the
    tables we scored (``write_mot_table`` sorts rows and rounds boxes to 1e-3 px)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    t = np.asarray(table, dtype=np.float64)
    if t.shape[1] < 10:
        pad = np.full((t.shape[0], 10 - t.shape[1]), -1.0)
        if t.shape[1] == 6:
            pad[:, 0] = 1.0
        t = np.hstack([t, pad])
    lines = [f"{int(r[0])},{int(r[1])}," + ",".join(f"{v:.17g}" for v in r[2:10]) for r in t]
    path.write_text("".join(line + "\n" for line in lines))


def _trackeval_check(gt: np.ndarray, pred: np.ndarray, ours: dict, tmp: Path) -> None:
    """TrackEval (CLEAR, Identity, HOTA) on exactly the tables ``ours`` scored (same
    rows, same order, same float64 values); raise AssertionError naming every field
    that differs: counts must be equal, floats within :data:`TRACKEVAL_TOL`."""
    import trackeval

    n = int(max(gt[:, 0].max(), pred[:, 0].max(initial=1)))
    _write_exact(tmp / "gt" / "s" / "gt" / "gt.txt", gt)
    _write_exact(tmp / "tr" / "t" / "data" / "s.txt", pred)
    cfg = dict(GT_FOLDER=str(tmp / "gt"), TRACKERS_FOLDER=str(tmp / "tr"), SKIP_SPLIT_FOL=True,
               SEQ_INFO={"s": n}, TRACKERS_TO_EVAL=["t"], PRINT_CONFIG=False,
               OUTPUT_FOLDER=str(tmp / "o"))  # fmt: skip
    ev = dict(USE_PARALLEL=False, PRINT_RESULTS=False, PRINT_CONFIG=False, TIME_PROGRESS=False,
              OUTPUT_SUMMARY=False, OUTPUT_DETAILED=False, PLOT_CURVES=False,
              DISPLAY_LESS_PROGRESS=True)  # fmt: skip
    with contextlib.redirect_stdout(io.StringIO()):
        res, msg = trackeval.Evaluator(ev).evaluate(
            [trackeval.datasets.MotChallenge2DBox(cfg)],
            [trackeval.metrics.CLEAR({"PRINT_CONFIG": False}),
             trackeval.metrics.Identity({"PRINT_CONFIG": False}),
             trackeval.metrics.HOTA({"PRINT_CONFIG": False})],
        )  # fmt: skip
    if msg["MotChallenge2DBox"]["t"] != "Success":  # TrackEval reports its errors here
        raise AssertionError(f"TrackEval failed: {msg['MotChallenge2DBox']['t']}")
    r = res["MotChallenge2DBox"]["t"]["s"]["pedestrian"]
    bad = [
        f"{k}: ours {ours[k]} != TrackEval {r[m][f]}"
        for k, (m, f) in TRACKEVAL_COUNTS.items()
        if ours[k] != int(r[m][f])
    ]
    for k, (m, f) in TRACKEVAL_FLOATS.items():
        v = float(np.mean(r[m][f]))
        if not abs(ours[k] - v) <= TRACKEVAL_TOL:
            bad.append(f"{k}: ours {ours[k]!r} != TrackEval {v!r}")
    if bad:
        raise AssertionError("scores differ from TrackEval's: " + "; ".join(bad))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("data", type=Path, help="folder of sequences <seq>/gt/gt.txt")
    ap.add_argument("--tune", nargs="*", default=[], help="sequences our defaults were tuned on")
    ap.add_argument("--fps", type=float, default=25.0, help="frame rate of the sequences")
    ap.add_argument("--levels", nargs="+", default=["moderate", "hard"], choices=list(NOISE))
    ap.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    ap.add_argument("--repeat", type=int, default=3, help="timing: best of this many runs")
    ap.add_argument("--use-det", action="store_true", help="use <seq>/det/det.txt")
    ap.add_argument("--check-trackeval", action="store_true")
    ap.add_argument(
        "--mot15",
        action="store_true",
        help="ground truth in the MOT15 layout (columns 8-10: world coordinates)",
    )
    ap.add_argument("--no-peer-tuning", action="store_true", help="peers at their defaults")
    ap.add_argument(
        "--peer-defaults",
        action="store_true",
        help="with tuning: also the peers at their defaults (rows without '(tuned)')",
    )
    ap.add_argument(
        "--peer-options",
        type=Path,
        metavar="JSON",
        help="take the peers' tuned options from an earlier --json output",
    )
    ap.add_argument(
        "--previous",
        action="store_true",
        help="also our tracker at its previous defaults (PREVIOUS_DEFAULTS)",
    )
    ap.add_argument("--set", dest="overrides", nargs="*", default=[], metavar="KEY=VALUE",
                    help="our tracker's options (e.g. max_gap_s=0.5), for tuning")  # fmt: skip
    ap.add_argument(
        "--limit",
        nargs="*",
        default=[],
        metavar="SEQ=N",
        help="use only frames 1..N of sequence SEQ (the published table: "
        "Seq0001Object10Image94=53 Seq0006Object21Image64=57 Seq0007Object26Image64=18)",
    )
    ap.add_argument(
        "--synthetic",
        nargs="*",
        type=int,
        default=[],
        metavar="N",
        help="also synthetic box sequences of N objects (synthetic_boxes; e.g. 50 100 200)",
    )
    ap.add_argument("--synthetic-frames", type=int, default=100)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    from thermoswarm.config import from_mapping, parse_overrides

    cfg = from_mapping(TrackerConfig, parse_overrides(args.overrides), source="--set")
    limit = {}
    for item in args.limit:
        name, _, n = item.partition("=")
        if not n.isdigit():
            print(f"--limit: expected SEQ=N, got {item!r}", file=sys.stderr)
            return 2
        limit[name] = int(n)

    synth = {f"synthetic-{n:03d}": n for n in args.synthetic}

    def load_gt(seq: str) -> np.ndarray:
        if seq in synth:
            return synthetic_boxes(synth[seq], args.synthetic_frames, seed=synth[seq])
        gt = considered_gt(read_mot_table(args.data / seq / "gt" / "gt.txt"), args.mot15)
        return gt[gt[:, 0] <= limit[seq]] if seq in limit else gt

    def fps_of(seq: str) -> float:
        return args.fps if seq in synth else seq_fps(args.data / seq, args.fps)

    seqs = sorted(p.name for p in args.data.iterdir() if (p / "gt" / "gt.txt").exists())
    seqs += sorted(synth)
    if not seqs:
        print(f"{args.data}: no <sequence>/gt/gt.txt found", file=sys.stderr)
        return 2
    rows = []
    import itertools
    import tempfile

    def detections(seq: str, gt: np.ndarray, level: str | None, seed: int | None):
        if args.use_det:
            return read_mot_table(args.data / seq / "det" / "det.txt")
        return noisy_detections(gt, level, seed)

    runs = [("det.txt", None)] if args.use_det else [
        (lvl, s) for lvl in args.levels for s in args.seeds]  # fmt: skip
    # The peers' options: the best of PEER_GRID on the tuning sequences (mean MOTA +
    # IDF1 over their detection runs); their defaults if no sequence is for tuning.
    peer_options: dict[str, dict] = {n: {} for n in PEER_GRID}
    tune = [s for s in seqs if s in args.tune]
    if args.peer_options is not None:
        # Options tuned by an earlier run on the same tuning sequences (its --json
        # output's "peer_options"): the grid search is the slow part.
        loaded = json.loads(args.peer_options.read_text())["peer_options"]
        peer_options.update(loaded)
    elif tune and not args.no_peer_tuning:
        cache = {}
        for seq in tune:
            gt = load_gt(seq)
            for level, seed in runs:
                cache[seq, level, seed] = (
                    gt,
                    fps_of(seq),
                    _per_frame(detections(seq, gt, level, seed), int(gt[:, 0].max())),
                )
        for name, grid in PEER_GRID.items():
            best = -np.inf
            for values in itertools.product(*grid.values()):
                opt = dict(zip(grid, values, strict=True))
                score = np.mean([
                    sum(evaluate_tables(gt, run_peer(name, fr, fps, opt))[k]
                        for k in ("mota", "idf1"))
                    for gt, fps, fr in cache.values()])  # fmt: skip
                if score > best:
                    best, peer_options[name] = score, opt
        print("peer options tuned on", ", ".join(tune), file=sys.stderr)
        for name, opt in peer_options.items():
            print(f"  {name}: {opt}", file=sys.stderr)
    # Every tracker run: label -> (ours or the peer's name, its options).
    trackers: dict[str, tuple[str, Any]] = {"ours": ("ours", cfg)}
    if args.previous:
        trackers["ours (previous)"] = ("ours", TrackerConfig(**PREVIOUS_DEFAULTS))
    tuned = bool(tune) and not args.no_peer_tuning
    for name in PEER_GRID:
        # With --peer-options, only the peers it holds count as tuned.
        if tuned and (args.peer_options is None or name in loaded):
            trackers[f"{name} (tuned)"] = (name, peer_options[name])
            if not args.peer_defaults:
                continue
        trackers[name] = (name, {})
    names = list(trackers)

    for seq in seqs:
        gt = load_gt(seq)
        n_frames = int(gt[:, 0].max())
        fps = fps_of(seq)
        for level, seed in runs:
            frames = _per_frame(detections(seq, gt, level, seed), n_frames)
            # Inputs built and outputs converted outside the timer; timed is each
            # tracker's own per-frame work (time_ours, time_peer), interleaved (ours,
            # peer, peer, ..., repeated) so that load changes hit all alike.
            inputs = {
                name: our_detections(frames) if kind == "ours" else peer_detections(frames)
                for name, (kind, _) in trackers.items()
            }
            best = dict.fromkeys(names, np.inf)
            outs: dict[str, Any] = {}
            for _ in range(args.repeat):
                for name, (kind, opts) in trackers.items():
                    if kind == "ours":
                        outs[name], secs = time_ours(inputs[name], fps, opts)
                    else:
                        outs[name], secs = time_peer(kind, inputs[name], fps, opts)
                    best[name] = min(best[name], secs)
            preds = {
                name: outs[name].mot_table() if kind == "ours" else peer_table(outs[name])
                for name, (kind, _) in trackers.items()
            }
            for name in names:
                pred, secs = preds[name], best[name]
                m = evaluate_tables(gt, pred)
                if args.check_trackeval:
                    with tempfile.TemporaryDirectory() as tmp:
                        _trackeval_check(gt, pred, m, Path(tmp))
                split = "tune" if seq in args.tune else "held-out"
                rows.append(dict(
                    sequence=seq, split="synth" if seq in synth else split,
                    detections=level, seed=seed, tracker=name, mota=m["mota"], idf1=m["idf1"],
                    hota=m["hota"], idsw=m["idsw"], fp=m["fp"], fn=m["fn"], fps=n_frames / secs,
                    speed_vs_ours=best["ours"] / secs, n_gt=m["n_gt"],
                    n_frames=n_frames, n_gt_ids=m["n_gt_ids"]))  # fmt: skip
    if args.json:
        print(json.dumps({"peer_options": peer_options, "rows": rows}, indent=1))
        return 0
    # Mean over seeds per sequence, level and tracker.
    print(f"{'sequence':24s} {'split':8s} {'dets':9s} {'tracker':17s} "
          f"{'MOTA':>6s} {'IDF1':>6s} {'HOTA':>6s} {'IDSW':>5s} {'FP':>6s} {'FN':>6s} "
          f"{'frames/s':>9s} "
          f"{'ours/it':>8s}")  # fmt: skip
    key = lambda r: (r["sequence"], r["detections"])  # noqa: E731
    for k in sorted({key(r) for r in rows}):
        group = [r for r in rows if key(r) == k]
        for name in names:
            g = [r for r in group if r["tracker"] == name]
            print(f"{k[0]:24s} {g[0]['split']:8s} {k[1]:9s} {name:17s} "
                  f"{np.mean([r['mota'] for r in g]):6.3f} {np.mean([r['idf1'] for r in g]):6.3f} "
                  f"{np.mean([r['hota'] for r in g]):6.3f} {np.mean([r['idsw'] for r in g]):5.1f} "
                  f"{np.mean([r['fp'] for r in g]):6.0f} {np.mean([r['fn'] for r in g]):6.0f} "
                  f"{np.mean([r['fps'] for r in g]):9.0f} "
                  f"{_gmean([1 / r['speed_vs_ours'] for r in g]):8.2f}")  # fmt: skip
    peers = (
        "at their defaults" if args.no_peer_tuning or not tune else "tuned on " + ", ".join(tune)
    )
    print(
        f"(means over detection seeds {args.seeds}; fps assumed {args.fps:g}; timed: each "
        f"tracker's own update per frame (ours also finish), inputs built before and "
        f"outputs converted after the timer; best of {args.repeat}, this process; ours at "
        f"{'its defaults' if not args.overrides else ' '.join(args.overrides)}; peers {peers})"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
