"""Benchmark of ant video tracking with the classical detector.

For each seed: a synthetic 1920x1080 video (40 ants, 300 frames at 30 fps, the
paper's 3.04 px/mm; cached under ``--cache``) is tracked end to end with
``thermoswarm.tracking.pipeline.track_video`` (decode in a thread, detection,
tracking, outputs, overlay video), and the result is scored against the ground truth
(MOTA, IDF1, ID-switch rate, keypoint errors in mm, head-tail correctness).

Speed is reported as frames per second and, because the machine may be shared, as a
ratio to a baseline measured in the same process just before: plain decoding of the
same video with ``cv2.VideoCapture`` (read every frame, no processing); and as frames
per CPU-second (user + system time of this process and its ffmpeg children), which
other programs on the machine do not change much: on two idle cores the wall-clock
rate is at least this.

The energy law is fitted (a two-exponential mixture by EM) to ``v^2 / 2`` from body
displacements over 1 and 5 frames, of the true and of the tracked trajectories: what
the analysis will see.

Usage::

    python benchmarks/bench_tracking.py --json            # seeds 1 2 3
    python benchmarks/bench_tracking.py --seeds 1 --json  # quicker

Prints one JSON object with ``--json`` (keys documented in docs/tracking.md).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import platform
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def _generate(seed: int, folder: str, n_frames: int, n_ants: int) -> None:
    from thermoswarm.tracking.synth.clip import SynthConfig, generate, write_sequence

    cfg = SynthConfig(width=1920, height=1080, n_ants=n_ants, n_frames=n_frames, fps=30.0)
    write_sequence(generate(cfg, np.random.default_rng(seed)), folder)


def _sequence(cache: Path, seed: int, n_frames: int, n_ants: int) -> Path:
    folder = cache / f"synth_1080p_{n_ants}ants_{n_frames}f_seed{seed}"
    if not (folder / "video.mp4").exists():
        # A child process, so that generating does not count in our peak memory.
        ctx = mp.get_context("spawn")
        p = ctx.Process(target=_generate, args=(seed, str(folder), n_frames, n_ants))
        p.start()
        p.join()
        if p.exitcode != 0:
            raise SystemExit(f"generating seed {seed} failed")
    return folder


def _decode_fps(video: Path) -> float:
    import cv2

    cap = cv2.VideoCapture(str(video))
    n = 0
    t0 = time.perf_counter()
    while True:
        ok, _ = cap.read()
        if not ok:
            break
        n += 1
    cap.release()
    return n / (time.perf_counter() - t0)


def _keypoint_errors(gt_nc: Path, tr_nc: Path) -> dict:
    from scipy.optimize import linear_sum_assignment

    from thermoswarm.io import read_tracks

    G = (
        read_tracks(gt_nc)["position"]
        .transpose("time", "individuals", "keypoints", "space")
        .values
    )
    P = (
        read_tracks(tr_nc)["position"]
        .transpose("time", "individuals", "keypoints", "space")
        .values
    )
    errs = {0: [], 1: [], 2: []}
    agree = []
    for t in range(G.shape[0]):
        gi = np.flatnonzero(np.isfinite(G[t, :, 1, 0]))
        pi = np.flatnonzero(np.isfinite(P[t, :, 1, 0]))
        if not (gi.size and pi.size):
            continue
        D = np.linalg.norm(G[t][gi][:, None, 1] - P[t][pi][None, :, 1], axis=-1)
        r, c = linear_sum_assignment(D)
        ok = D[r, c] < 2.0  # mm
        g, p = G[t][gi[r[ok]]], P[t][pi[c[ok]]]
        for k in range(3):
            e = np.linalg.norm(g[:, k] - p[:, k], axis=-1)
            errs[k].append(e[np.isfinite(e)])
        agree.append(((g[:, 0] - g[:, 2]) * (p[:, 0] - p[:, 2])).sum(-1) > 0)
    out = {}
    for k, name in enumerate(("head", "body", "tail")):
        e = np.concatenate(errs[k])
        out[f"{name}_error_median_mm"] = float(np.median(e))
        out[f"{name}_error_p90_mm"] = float(np.quantile(e, 0.9))
    out["head_tail_correct"] = float(np.concatenate(agree).mean())
    return out


def _cpu_seconds() -> float:
    """CPU time of this process and its finished children (ffmpeg), user + system."""
    a = resource.getrusage(resource.RUSAGE_SELF)
    b = resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime


def _energies(nc: Path, lag: int) -> np.ndarray:
    """Energies per unit mass ``v^2 / 2`` (mm^2/s^2) from body displacements over
    ``lag`` frames, every frame of every individual."""
    from thermoswarm.io import read_tracks

    ds = read_tracks(nc)
    body = ds["position"].sel(keypoints="body").transpose("time", "individuals", "space").values
    v = np.linalg.norm(body[lag:] - body[:-lag], axis=-1) * ds.attrs["fps"] / lag
    v = v[np.isfinite(v)]
    return 0.5 * v**2


def _fit_mixture(e: np.ndarray, iters: int = 500) -> dict:
    """Two-exponential mixture by EM: a check of what the analysis will see (the
    analysis package has its own fitter; this one only reports numbers here)."""
    phi, k1, k2 = 0.5, np.quantile(e, 0.25), np.quantile(e, 0.9)
    for _ in range(iters):
        a = phi / k1 * np.exp(-e / k1)
        b = (1 - phi) / k2 * np.exp(-e / k2)
        r = a / np.maximum(a + b, 1e-300)
        phi = float(r.mean())
        k1 = float((r * e).sum() / max(r.sum(), 1e-12))
        k2 = float(((1 - r) * e).sum() / max((1 - r).sum(), 1e-12))
    if k1 > k2:
        phi, k1, k2 = 1 - phi, k2, k1
    return {"phi": phi, "kT1": k1, "kT2": k2, "n": int(e.size)}


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--frames", type=int, default=300)
    ap.add_argument("--ants", type=int, default=40)
    ap.add_argument("--cache", type=Path, default=Path("bench-out/tracking"))
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    ap.add_argument("--set", dest="overrides", nargs="*", default=[], metavar="KEY=VALUE",
                    help="tracker options over the ants preset (e.g. confirm_s=0.2)")  # fmt: skip
    args = ap.parse_args(argv)

    from thermoswarm.config import parse_overrides
    from thermoswarm.tracking.evaluate import evaluate_files
    from thermoswarm.tracking.pipeline import track_video
    from thermoswarm.tracking.synth.clip import SynthConfig
    from thermoswarm.tracking.track.presets import preset

    tracker = preset("ants", **parse_overrides(args.overrides))

    args.cache.mkdir(parents=True, exist_ok=True)
    runs = []
    for seed in args.seeds:
        seq = _sequence(args.cache, seed, args.frames, args.ants)
        video = seq / "video.mp4"
        decode = _decode_fps(video)
        with tempfile.TemporaryDirectory() as tmp:
            c0 = _cpu_seconds()
            s_no = track_video(video, Path(tmp) / "a", px_per_mm=3.04, overlay=False,
                               tracker_config=tracker)  # fmt: skip
            c1 = _cpu_seconds()
            s = track_video(video, Path(tmp) / "b", px_per_mm=3.04, overlay=True,
                            tracker_config=tracker)  # fmt: skip
            c2 = _cpu_seconds()
            m = evaluate_files(seq / "gt" / "gt.txt", Path(tmp) / "b" / "tracks_mot.txt")
            kp = _keypoint_errors(seq / "gt_tracks.nc", Path(tmp) / "b" / "tracks.nc")
            fits = {}
            for lag in (1, 5):
                fits[f"gt_lag{lag}"] = _fit_mixture(_energies(seq / "gt_tracks.nc", lag))
                fits[f"tracked_lag{lag}"] = _fit_mixture(
                    _energies(Path(tmp) / "b" / "tracks.nc", lag)
                )
        runs.append(
            {
                "seed": seed,
                "decode_fps": decode,
                "track_fps": s["frames_per_second"],
                "track_fps_no_overlay": s_no["frames_per_second"],
                "ratio_to_decode": s["frames_per_second"] / decode,
                "ratio_to_decode_no_overlay": s_no["frames_per_second"] / decode,
                "cpu_seconds": c2 - c1,
                "cpu_seconds_no_overlay": c1 - c0,
                "frames_per_cpu_second": args.frames / (c2 - c1),
                "frames_per_cpu_second_no_overlay": args.frames / (c1 - c0),
                "prepare_seconds": s["prepare_seconds"],
                "n_tracks": s["n_tracks"],
                **{
                    k: m[k]
                    for k in (
                        "mota",
                        "motp",
                        "idf1",
                        "idsw",
                        "idsw_rate",
                        "fp",
                        "fn",
                        "n_gt",
                        "n_gt_ids",
                        "n_pred_ids",
                    )
                },
                **kp,
                "energy_fits": fits,
            }
        )
        if not args.json:
            print(json.dumps(runs[-1]), file=sys.stderr)
    keys = (
        "mota",
        "idf1",
        "idsw_rate",
        "motp",
        "track_fps",
        "track_fps_no_overlay",
        "decode_fps",
        "ratio_to_decode",
        "body_error_median_mm",
        "head_tail_correct",
    )
    result = {
        "benchmark": "tracking",
        "video": {
            "width": 1920,
            "height": 1080,
            "n_ants": args.ants,
            "n_frames": args.frames,
            "fps": 30.0,
            "px_per_mm": 3.04,
        },
        "detector": "classical",
        "true_law": {k: getattr(SynthConfig(), k) for k in ("phi", "kT1", "kT2")},
        "runs": runs,
        "mean": {k: float(np.mean([r[k] for r in runs])) for k in keys},
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "cpu_count": os.cpu_count(),
        "load_average": list(os.getloadavg()),
        "python": platform.python_version(),
        "machine": platform.machine(),
    }
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print(json.dumps(result["mean"], indent=2))
    return result


if __name__ == "__main__":
    main()
