"""Real ant motion, made into detector boxes: anTraX's JS16 trajectories
(``tests/data/antrax_js16``, 16 *Ooceraea biroi*, 10 fps, 240 s) at 10 and 5 fps,
our tracker beside ByteTrack, OC-SORT and SORT at their defaults.

Boxes: each ant's axis-aligned box of a 1 x 0.35 body-length rectangle at its heading
(the direction of its displacement over the frame; body length ``--length-mm``, px at
anTraX's 0.0923 mm/px); from one seed, a box is missed with ``--p-miss``, its centre
moved by a normal of sd ``--jitter`` body lengths, and ``--fp-rate`` false boxes a
frame appear anywhere in the arena.  Positions anTraX gives to every ant of a
multi-ant blob (shared exactly by those ants) are left out of the ground truth and
the boxes.  Scores: Beta(6, 2) for true boxes, Beta(2, 5) for false ones.

    python benchmarks/bench_js16_boxes.py
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_tracking_real as btr  # noqa: E402
from thermoswarm.tracking.evaluate import evaluate_tables  # noqa: E402
from thermoswarm.tracking.track.presets import preset  # noqa: E402
from thermoswarm.tracking.track.tracker import Tracker  # noqa: E402

CSV = Path(__file__).resolve().parents[1] / "tests/data/antrax_js16/js16_xy_1_1_mm.csv"
MM_PER_PX = 0.0923


def load(path: Path) -> np.ndarray:
    """Positions ``(T, N, 2)`` px (NaN: absent or shared with another ant)."""
    lines = [ln for ln in path.read_text().splitlines() if not ln.startswith("#")]
    head = lines[0].split(",")
    cols = [c[:-2] for c in head if c.endswith("_x")]
    rows = [[float(v) if v else np.nan for v in ln.split(",")] for ln in lines[1:]]
    a = np.asarray(rows)
    xy = np.stack([a[:, [head.index(f"{c}_x") for c in cols]],
                   a[:, [head.index(f"{c}_y") for c in cols]]], -1) / MM_PER_PX  # fmt: skip
    for k in range(xy.shape[0]):  # shared blob positions
        p = xy[k]
        ok = np.isfinite(p[:, 0])
        d = np.linalg.norm(p[:, None] - p[None], axis=-1)
        np.fill_diagonal(d, np.inf)
        shared = ok & (np.nanmin(np.where(np.isfinite(d), d, np.inf), axis=1) < 1e-6)
        p[shared] = np.nan
    return xy


def make(xy: np.ndarray, L: float, a: argparse.Namespace, step: int) -> tuple:
    """Ground truth and detections (MOT rows) of every ``step``-th frame."""
    rng = np.random.default_rng(a.seed)
    xy = xy[::step]
    T, N, _ = xy.shape
    v = np.diff(xy, axis=0, prepend=xy[:1])
    heading = np.arctan2(v[..., 1], v[..., 0])
    still = ~(np.hypot(v[..., 0], v[..., 1]) > 0.02 * L)  # NaN or hardly moved
    for k in range(T):  # keep the last heading while an ant stands or was unseen
        heading[k, still[k]] = heading[k - 1, still[k]] if k else 0.0
    lo, hi = np.nanmin(xy, axis=(0, 1)), np.nanmax(xy, axis=(0, 1))
    gt, det = [], []
    for k in range(T):
        ok = np.flatnonzero(np.isfinite(xy[k, :, 0]))
        c, s = np.abs(np.cos(heading[k, ok])), np.abs(np.sin(heading[k, ok]))
        wh = L * np.c_[c + 0.35 * s, s + 0.35 * c]
        for i, p, w in zip(ok, xy[k, ok], wh, strict=True):
            gt.append([k + 1, i + 1, *(p - w / 2), *w, 1, -1, -1, -1])
            if rng.random() < a.p_miss:
                continue
            q = p + a.jitter * L * rng.standard_normal(2)
            det.append([k + 1, -1, *(q - w / 2), *w, rng.beta(6, 2), -1, -1, -1])
        for _ in range(rng.poisson(a.fp_rate)):
            q = rng.uniform(lo, hi)
            det.append([k + 1, -1, *(q - L / 2), L, L, rng.beta(2, 5), -1, -1, -1])
    return np.asarray(gt), np.asarray(det), T


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--csv", type=Path, default=CSV)
    ap.add_argument("--length-mm", type=float, default=2.5, help="body length (mm)")
    ap.add_argument("--p-miss", type=float, default=0.1)
    ap.add_argument("--jitter", type=float, default=0.05)
    ap.add_argument("--fp-rate", type=float, default=0.2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--steps", nargs="+", type=int, default=[1, 2])
    a = ap.parse_args(argv)
    xy = load(a.csv)
    L = a.length_mm / MM_PER_PX
    print("| fps | tracker | MOTA | IDF1 | HOTA | IDSW | FP | FN |")
    print("|---|---|---|---|---|---|---|---|")
    for step in a.steps:
        gt, det, T = make(xy, L, a, step)
        frames = btr._per_frame(det, T)
        fps = 10.0 / step
        preds = {}
        for name in ("ants", "pedestrians"):
            tr = Tracker(preset(name), fps=fps, length_px=L)
            for d in btr.our_detections(frames):
                tr.predict()
                tr.update(d)
            preds[f"ours ({name})"] = tr.finish().mot_table()
        for peer in ("ByteTrack", "OC-SORT", "SORT"):
            preds[peer] = btr.run_peer(peer, frames, fps)
        for name, pred in preds.items():
            m = evaluate_tables(gt, pred)
            print(f"| {fps:g} | {name} | {m['mota']:.3f} | {m['idf1']:.3f} | {m['hota']:.3f} "
                  f"| {m['idsw']} | {m['fp']} | {m['fn']} |", flush=True)  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
