"""Benchmark of the trained top-down detector (U-Net centroids + pose network).

1. **Training** (unless ``--model`` is given): ``train_from_sources(synthetic=True)``
   with the default :class:`~thermoswarm.tracking.train.fit.TrainConfig` (seed ``--seed``):
   synthetic training videos, periodic evaluation on a held-out synthetic video
   (tracked, CLEAR-MOT), stop when MOTA >= 0.95 and ID switches <= 1 %.  Reports the
   wall time and the CPU time (this process, all threads) to reach the target.
2. **Accuracy**: for each seed, the benchmark video (1920x1080, 40 ants, 300 frames at
   30 fps, 3.04 px/mm, x264; the same files as ``bench_tracking.py``, cached under
   ``--cache``) is tracked end to end (``track_video``, no overlay) with the trained
   model and with the classical detector, and scored against the ground truth: MOTA,
   IDF1, ID-switch rate, FP, FN, and the keypoint errors of the tracked trajectories
   (``bench_tracking._keypoint_errors``: per frame, tracks matched to true ants within
   2 mm; median and 90th percentile error of head, body and tail in mm; share with
   head and tail the right way round).
3. **Speed**: detector-only frames per second on ``--speed-frames`` decoded frames of
   the first video, for the U-Net and, as the baseline measured in the same process
   just before, the classical detector (ratio reported); end-to-end frames per second
   of ``track_video`` for both (decoding, detection, tracking, outputs).  On a CUDA
   device, if one is present, the U-Net is timed there too.

The machine may be shared: the load average is reported with the timings, and CPU
seconds beside wall seconds.

Usage::

    python benchmarks/bench_unet.py --json                      # train, then evaluate
    python benchmarks/bench_unet.py --model m.pt --seeds 1 --json

Prints one JSON object with ``--json`` (keys documented in docs/tracking_unet.md).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # before torch starts (see unet.py)

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_tracking import _decode_fps, _keypoint_errors, _sequence  # noqa: E402


def _detector_fps(det, frames: list[np.ndarray], prepare: bool) -> float:
    if prepare and hasattr(det, "prepare"):
        det.prepare(frames)
    det.detect(frames[0])  # warm-up
    t0 = time.perf_counter()
    for f in frames:
        det.detect(f)
    return len(frames) / (time.perf_counter() - t0)


def _metrics(gt: Path, pred: Path) -> dict:
    from thermoswarm.tracking.evaluate import evaluate_files

    m = evaluate_files(gt, pred)
    keys = ("mota", "idf1", "idsw", "idsw_rate", "fp", "fn", "n_gt", "n_gt_ids", "n_pred_ids")
    return {k: m[k] for k in keys}


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--model", type=Path, help="use this model instead of training one")
    ap.add_argument("--out", type=Path, default=Path("bench-out/unet"))
    ap.add_argument("--seed", type=int, default=0, help="training seed")
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3], help="video seeds")
    ap.add_argument("--frames", type=int, default=300)
    ap.add_argument("--ants", type=int, default=40)
    ap.add_argument("--speed-frames", type=int, default=30)
    ap.add_argument("--threads", type=int, default=None, help="torch threads")
    ap.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="training option (TrainConfig), e.g. --set max_steps=2000",
    )
    ap.add_argument(
        "--tracker-set",
        dest="tracker_overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="tracker option for both detectors, e.g. --tracker-set interpolate=false",
    )
    ap.add_argument("--cache", type=Path, default=Path("bench-out/tracking"))
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)

    import torch

    from thermoswarm.config import from_mapping, parse_overrides
    from thermoswarm.tracking.detect.classical import make_detector
    from thermoswarm.tracking.pipeline import track_video
    from thermoswarm.tracking.track.tracker import TrackerConfig
    from thermoswarm.tracking.train.fit import TrainConfig, train_from_sources
    from thermoswarm.tracking.video import open_video

    if args.threads is not None:
        torch.set_num_threads(args.threads)
    args.out.mkdir(parents=True, exist_ok=True)
    args.cache.mkdir(parents=True, exist_ok=True)
    result: dict = {"benchmark": "unet", "load_average_start": list(os.getloadavg())}

    training = None
    model = args.model
    if model is None:
        cfg = from_mapping(TrainConfig, parse_overrides(args.overrides), source="--set")
        cfg = from_mapping(TrainConfig, {**_plain(cfg), "seed": args.seed}, source="--seed")
        model = args.out / f"unet_seed{args.seed}.pt"
        l0 = os.getloadavg()
        c0 = time.process_time()
        t0 = time.perf_counter()
        rep = train_from_sources(
            model,
            synthetic=True,
            config=cfg,
            log=None if args.json else lambda s: print(s, file=sys.stderr),
        )
        training = {
            "target_reached": rep["target_reached"],
            "stopped": rep["stopped"],
            "steps": rep["steps"],
            "wall_seconds_total": time.perf_counter() - t0,
            "cpu_seconds_total": time.process_time() - c0,
            "wall_seconds_training": rep["seconds"],
            "cpu_seconds_training": rep["cpu_seconds"],
            "validation": rep["best"],
            "load_average_before": list(l0),
            "load_average_after": list(os.getloadavg()),
            "torch_threads": rep["torch_threads"],
        }
    result["training"] = training
    result["model"] = str(model)

    tcfg = from_mapping(
        TrackerConfig, parse_overrides(args.tracker_overrides), source="--tracker-set"
    )
    result["tracker_overrides"] = parse_overrides(args.tracker_overrides)
    runs = []
    for seed in args.seeds:
        seq = _sequence(args.cache, seed, args.frames, args.ants)
        video = seq / "video.mp4"
        run: dict = {"seed": seed, "decode_fps": _decode_fps(video)}
        with tempfile.TemporaryDirectory() as tmp:
            for name, kw in (("classical", {}), ("unet", {"model": model})):
                c0 = time.process_time()
                s = track_video(
                    video,
                    Path(tmp) / name,
                    px_per_mm=3.04,
                    overlay=False,
                    tracker_config=tcfg,
                    **kw,
                )
                run[name] = {
                    **_metrics(seq / "gt" / "gt.txt", Path(tmp) / name / "tracks_mot.txt"),
                    **_keypoint_errors(seq / "gt_tracks.nc", Path(tmp) / name / "tracks.nc"),
                    "track_fps": s["frames_per_second"],
                    "cpu_seconds": time.process_time() - c0,
                }
        runs.append(run)
        if not args.json:
            print(json.dumps(run), file=sys.stderr)
    result["runs"] = runs
    keys = (
        "mota",
        "idf1",
        "idsw_rate",
        "fp",
        "fn",
        "track_fps",
        "body_error_median_mm",
        "head_error_median_mm",
        "tail_error_median_mm",
        "head_tail_correct",
    )
    result["mean"] = {
        name: {k: float(np.mean([r[name][k] for r in runs])) for k in keys}
        for name in ("classical", "unet")
    }

    # Detector-only speed on decoded frames of the first video.
    seq = _sequence(args.cache, args.seeds[0], args.frames, args.ants)
    frames = list(open_video(seq / "video.mp4").frames(args.speed_frames))
    classical = make_detector("classical", px_per_mm=3.04)
    fps_classical = _detector_fps(classical, frames, prepare=True)
    speed = {"classical_fps": fps_classical, "n_frames": len(frames)}
    c0 = time.process_time()
    t0 = time.perf_counter()
    det = make_detector(model=model, px_per_mm=3.04, options={"device": "cpu"})
    speed["unet_cpu_fps"] = _detector_fps(det, frames, prepare=False)
    speed["unet_cpu_frames_per_cpu_second"] = (len(frames) + 1) / (time.process_time() - c0)
    speed["unet_cpu_ratio_to_classical"] = speed["unet_cpu_fps"] / fps_classical
    speed["unet_cpu_wall_seconds"] = time.perf_counter() - t0
    speed["torch_threads"] = torch.get_num_threads()
    if torch.cuda.is_available():
        det = make_detector(model=model, px_per_mm=3.04, options={"device": "cuda"})
        speed["unet_cuda_fps"] = _detector_fps(det, frames, prepare=False)
        speed["cuda_device"] = torch.cuda.get_device_name(0)
    else:
        speed["unet_cuda_fps"] = None
    result["speed"] = speed
    result["video"] = {
        "width": 1920,
        "height": 1080,
        "n_ants": args.ants,
        "n_frames": args.frames,
        "fps": 30.0,
        "px_per_mm": 3.04,
    }
    result["load_average_end"] = list(os.getloadavg())
    result["cpu_count"] = os.cpu_count()
    result["python"] = platform.python_version()
    result["torch"] = torch.__version__
    out = args.out / "bench_unet.json"
    out.write_text(json.dumps(result, indent=2))
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print(json.dumps({"mean": result["mean"], "speed": speed}, indent=2))
    return result


def _plain(cfg) -> dict:
    from thermoswarm.config import to_dict

    return to_dict(cfg)


if __name__ == "__main__":
    main()
