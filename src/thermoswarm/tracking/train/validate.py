"""Validation of a detector during training: synthetic validation video, detection
metrics and tracking scores.  Part of :mod:`thermoswarm.tracking.train.fit`."""

from __future__ import annotations

import tempfile
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.config import check
from thermoswarm.errors import InputError
from thermoswarm.tracking import anatomy


@dataclass(frozen=True)
class ValidationConfig:
    """The held-out synthetic video of synthetic training: ``width`` x ``height`` px,
    ``n_ants`` ants, ``n_frames`` frames (default: the benchmark's geometry and
    density, 5 s), its own ``seed``."""

    width: int = 1920
    height: int = 1080
    n_ants: int = 40
    n_frames: int = 150
    seed: int = 1_000_003

    def __post_init__(self) -> None:
        check(self.width >= 64, "width", "at least 64 px", self.width)
        check(self.height >= 64, "height", "at least 64 px", self.height)
        check(self.n_ants >= 1, "n_ants", "a positive integer", self.n_ants)
        check(self.n_frames >= 10, "n_frames", "at least 10", self.n_frames)


@dataclass
class ValidationSet:
    """Frames and truth for evaluation: a synthetic video (``mot_gt``: MOT ground
    truth, ``fps``) or labelled frames (``mot_gt`` None).

    ``frames`` is a list of RGB frames or the path of a video file, decoded at each
    evaluation (a long 1080p validation video would not fit in memory).
    """

    frames: list[np.ndarray] | Path
    points: list[np.ndarray]
    px_per_mm: float
    fps: float | None = None
    mot_gt: np.ndarray | None = None
    description: str = ""
    _keep: Any = field(default=None, repr=False)  # the temporary folder of the video
    ignore: list[np.ndarray] | None = None  # per frame: centres of unlabelled ants

    def iter_frames(self) -> Iterator[np.ndarray]:
        if isinstance(self.frames, Path):
            from thermoswarm.tracking.video import open_video

            yield from open_video(self.frames).frames(len(self.points), prefetch=4)
        else:
            yield from self.frames


def synthetic_validation(
    config: ValidationConfig, *, px_per_mm: float = 3.04, codec: bool = True
) -> ValidationSet:
    """A held-out synthetic video with its ground truth.

    With ``codec`` the video is encoded like the benchmark videos (x264, CRF 20) into a
    temporary file, which lives as long as the returned object; otherwise the frames
    are kept in memory.
    """
    from thermoswarm.tracking.synth.clip import SynthConfig, generate, write_video

    cfg = SynthConfig(
        width=config.width,
        height=config.height,
        n_ants=config.n_ants,
        n_frames=config.n_frames,
        px_per_mm=px_per_mm,
    )
    video = generate(cfg, np.random.default_rng(config.seed))
    keep = None
    if codec:
        keep = tempfile.TemporaryDirectory(prefix="thermoswarm-val-")
        frames: list[np.ndarray] | Path = Path(keep.name) / "validation.mp4"
        write_video(video.frames(), frames, cfg.fps)
    else:
        frames = list(video.frames())
    kp = video.keypoints
    points = [kp[k][np.isfinite(kp[k, :, 1, 0])] for k in range(cfg.n_frames)]
    return ValidationSet(
        frames,
        points,
        px_per_mm,
        cfg.fps,
        video.mot_gt,
        f"synthetic {config.width}x{config.height}, {config.n_ants} ants, "
        f"{config.n_frames} frames, seed {config.seed}",
        keep,
    )


def _ignored(P: np.ndarray, ign: np.ndarray | None, radius_px: float) -> np.ndarray:
    """Which detections (body points ``P[:, 1]``) lie within ``radius_px`` of an
    unlabelled ant's centre."""
    if ign is None or ign.shape[0] == 0 or P.shape[0] == 0:
        return np.zeros(P.shape[0], bool)
    d = np.linalg.norm(P[:, None, 1] - ign[None], axis=-1)
    return np.asarray((d <= radius_px).any(axis=1))


def detection_metrics(
    detections: Sequence[Any],
    truth: Sequence[np.ndarray],
    radius_px: float,
    ignore: Sequence[np.ndarray] | None = None,
) -> dict[str, float]:
    """Per-frame matching of detected and true body points (Hungarian, within
    ``radius_px``): precision, recall, F1 and keypoint errors (px) of the matches.

    ``ignore``: per frame, centres ``(m, 2)`` of ants present but not labelled; an
    unmatched detection within ``radius_px`` of one is no false positive (counted in
    ``ignored``).
    """
    from scipy.optimize import linear_sum_assignment

    tp = fp = fn = n_ign = 0
    errs: list[np.ndarray] = []
    flips = []
    for k, (det, gt) in enumerate(zip(detections, truth, strict=True)):
        P = det.points
        ign = None if ignore is None else ignore[k]
        if gt.shape[0] == 0 or P.shape[0] == 0:
            skip = int(_ignored(P, ign, radius_px).sum())
            n_ign += skip
            fp += P.shape[0] - skip
            fn += gt.shape[0]
            continue
        D = np.linalg.norm(gt[:, None, 1] - P[None, :, 1], axis=-1)
        D = np.where(np.isfinite(D), D, np.inf)
        # Pairs beyond the radius cost more than any possible set of matches within it.
        r, c = linear_sum_assignment(np.where(D <= radius_px, D, 1e6))
        ok = D[r, c] <= radius_px
        r, c = r[ok], c[ok]
        unmatched = np.ones(P.shape[0], bool)
        unmatched[c] = False
        skip = int((unmatched & _ignored(P, ign, radius_px)).sum())
        n_ign += skip
        tp += r.size
        fp += P.shape[0] - r.size - skip
        fn += gt.shape[0] - r.size
        e = np.linalg.norm(gt[r] - P[c], axis=-1)  # (m, 3)
        errs.append(e)
        ax_g = gt[r, 0] - gt[r, 2]
        ax_p = P[c, 0] - P[c, 2]
        good = np.all(np.isfinite(ax_g), 1) & np.all(np.isfinite(ax_p), 1)
        flips.append(((ax_g * ax_p).sum(-1) < 0)[good])
    e = np.concatenate(errs) if errs else np.zeros((0, 3))
    out = {
        "tp": int(tp),
        "fp": int(fp),
        "fn": int(fn),
        "ignored": int(n_ign),
        "precision": tp / max(tp + fp, 1),
        "recall": tp / max(tp + fn, 1),
    }
    out["f1"] = 2 * tp / max(2 * tp + fp + fn, 1)
    for k, name in enumerate(anatomy.KEYPOINTS):
        ek = e[:, k][np.isfinite(e[:, k])]
        out[f"{name}_error_median_px"] = float(np.median(ek)) if ek.size else float("nan")
        out[f"{name}_error_p90_px"] = float(np.quantile(ek, 0.9)) if ek.size else float("nan")
    fl = np.concatenate(flips) if flips else np.zeros(0, bool)
    out["head_tail_swapped"] = float(fl.mean()) if fl.size else float("nan")
    return out


def evaluate_detector(detector: Any, val: ValidationSet) -> dict[str, Any]:
    """Detect every validation frame; detection metrics, and for a video also the
    tracker's CLEAR-MOT scores (``mota``, ``idf1``, ``idsw_rate``, ...) against the
    ground truth."""
    t0 = time.perf_counter()
    dets = []
    t_det = 0.0
    size = (0, 0)
    for f in val.iter_frames():
        t1 = time.perf_counter()
        dets.append(detector.detect(f))
        t_det += time.perf_counter() - t1
        size = f.shape[:2]
    if len(dets) != len(val.points):
        raise InputError(f"validation: {len(dets)} frames for {len(val.points)} labelled ones")
    radius = 0.5 * anatomy.ANT_LENGTH_MM * val.px_per_mm
    out: dict[str, Any] = detection_metrics(dets, val.points, radius, val.ignore)
    out["detect_seconds_per_frame"] = t_det / max(len(dets), 1)
    out["eval_seconds"] = time.perf_counter() - t0
    if val.mot_gt is not None:
        from thermoswarm.tracking.evaluate import evaluate_tables
        from thermoswarm.tracking.track.tracker import track_detections

        H, W = size
        res = track_detections(dets, px_per_mm=val.px_per_mm, fps=val.fps, frame_size=(W, H))
        m = evaluate_tables(val.mot_gt, res.mot_table())
        for k in ("mota", "idf1", "idsw", "idsw_rate", "fp", "fn", "n_gt", "motp"):
            out[f"track_{k}" if k in ("fp", "fn") else k] = m[k]
    return out


# ------------------------------------------------------------------- training
