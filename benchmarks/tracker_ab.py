"""Tracker A/B: two git revisions of the tracker on the same detections, in one process.

The tracker's modules of revision ``--base`` (``tracker``, ``kalman`` and, where the
revision has them, ``association``, ``track_bank``, ``track_result``) are exported with
``git show`` into a temporary package whose imports of each other are redirected to the
copies; the other is the working tree (or ``--new REV``).  Both track the same
box-only detections, alternately, ``--repeat`` times; the best times are compared
(``new/base`` > 1: the new one is faster) and the MOT tables must be equal bit for bit
(the run stops otherwise).  Detections: the noisy ground truth of real sequences as in
``bench_tracking_real.py`` (``--data``, ``--limit``), synthetic box sequences of
``--synthetic N`` objects (:func:`bench_tracking_real.synthetic_boxes`, same noise), and
posed detections (head, body, tail) of ``--poses N`` ants of the synthetic video
generator (:func:`pose_detections`), for which the whole
:class:`~thermoswarm.tracking.track.result.TrackResult` (points and head-tail order,
boxes, scores, interpolation flags) must be equal, not only the MOT table.

    python benchmarks/tracker_ab.py --base d3abd6a --data DATA --limit \\
        Seq0001Object10Image94=53 Seq0006Object21Image64=57 Seq0007Object26Image64=18
"""

from __future__ import annotations

import argparse
import importlib
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))
MODULES = ("tracker", "kalman", "association", "track_bank", "track_result")


def export(rev: str, where: Path) -> str:
    """Write revision ``rev``'s tracker modules into package ``where/trk_<rev>``: the
    ``tracking/track/`` room where the revision has it, else the flat modules of the
    revisions before the rooms (``tracking/tracker.py`` and its neighbours)."""
    pkg = "trk_" + re.sub(r"\W", "_", rev)
    d = where / pkg
    d.mkdir(parents=True)
    (d / "__init__.py").write_text("")
    room = subprocess.run(
        ["git", "ls-tree", "--name-only", f"{rev}:src/thermoswarm/tracking/track/"],
        cwd=ROOT, capture_output=True, text=True,
    )  # fmt: skip
    if room.returncode == 0:
        for name in room.stdout.split():
            if name.endswith(".py") and name != "__init__.py":
                src = _show(rev, f"src/thermoswarm/tracking/track/{name}")
                (d / name).write_text(re.sub(r"thermoswarm\.tracking\.track\b", pkg, src))
        if not (d / "tracker.py").exists():
            raise SystemExit(f"{rev}: no src/thermoswarm/tracking/track/tracker.py")
        return pkg
    have = []
    for m in MODULES:
        try:
            (d / f"{m}.py").write_text(_show(rev, f"src/thermoswarm/tracking/{m}.py"))
            have.append(m)
        except FileNotFoundError:
            pass
    if "tracker" not in have:
        raise SystemExit(f"{rev}: no src/thermoswarm/tracking/tracker.py")
    names = "|".join(have)
    for m in have:
        p = d / f"{m}.py"
        s = p.read_text()
        s = re.sub(rf"from thermoswarm\.tracking\.({names}) import", rf"from {pkg}.\1 import", s)

        def imports(match: re.Match) -> str:
            parts = [x.strip() for x in match.group(1).split(",")]
            ours = [x for x in parts if x in have]
            rest = [x for x in parts if x not in have]
            out = [f"from {pkg} import {', '.join(ours)}"] if ours else []
            if rest:
                out.append(f"from thermoswarm.tracking import {', '.join(rest)}")
            return "\n".join(out)

        s = re.sub(r"from thermoswarm\.tracking import ([\w, ]+)", imports, s)
        p.write_text(s)
    return pkg


def _show(rev: str, path: str) -> str:
    """``git show REV:PATH``; FileNotFoundError when the revision has no such file."""
    r = subprocess.run(["git", "show", f"{rev}:{path}"], cwd=ROOT, capture_output=True, text=True)
    if r.returncode != 0:
        raise FileNotFoundError(f"{rev}:{path}")
    return r.stdout


def pose_detections(n_ants: int, n_frames: int, seed: int) -> tuple[list[Any], float]:
    """Posed detections of a synthetic video (:func:`thermoswarm.tracking.synth.clip.generate`,
    1920x1080): the true keypoints plus 1 px noise, 5 % of the ants missed in each frame,
    head and tail swapped in 20 % of the detections with a head confidence of 0.3 (0.8
    otherwise), scores uniform in [0.5, 1]; and the frame rate."""
    from thermoswarm.tracking.detection import FrameDetections
    from thermoswarm.tracking.synth.clip import SynthConfig, generate

    rng = np.random.default_rng(seed)
    video = generate(SynthConfig(n_ants=n_ants, n_frames=n_frames), rng)
    out = []
    for k in range(video.n_frames):
        kp = video.keypoints[k]
        alive = np.flatnonzero(np.isfinite(kp[:, 1, 0]) & (rng.random(kp.shape[0]) >= 0.05))
        pts = kp[alive] + rng.standard_normal((alive.size, 3, 2))
        flip = rng.random(alive.size) < 0.2
        pts[flip] = pts[flip][:, [2, 1, 0]]
        hc = np.where(flip, 0.3, 0.8)
        out.append(FrameDetections(pts, rng.uniform(0.5, 1.0, alive.size), head_confidence=hc))
    return out, float(video.config.fps)


def _run_poses(mod: Any, dets: list[Any], fps: float) -> Any:
    tr = mod.Tracker(mod.TrackerConfig(), fps=fps, frame_size=(1920, 1080))
    for d in dets:
        tr.predict()
        tr.update(d)
    return tr.finish()


def _same_result(a: Any, b: Any) -> bool:
    return a.n_frames == b.n_frames and all(
        np.array_equal(getattr(a, f), getattr(b, f), equal_nan=f in ("points", "boxes"))
        for f in ("frames", "ids", "points", "boxes", "scores", "interpolated")
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", required=True, help="git revision to compare against")
    ap.add_argument("--new", default=None, help="git revision (default: the working tree)")
    ap.add_argument("--data", type=Path, help="folder of sequences <seq>/gt/gt.txt")
    ap.add_argument("--limit", nargs="*", default=[], metavar="SEQ=N")
    ap.add_argument("--levels", nargs="+", default=["moderate", "hard"])
    ap.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    ap.add_argument("--synthetic", nargs="*", type=int, default=[50, 100, 200])
    ap.add_argument("--synthetic-frames", type=int, default=100)
    ap.add_argument("--poses", nargs="*", type=int, default=[40], metavar="N")
    ap.add_argument("--pose-frames", type=int, default=300)
    ap.add_argument("--fps", type=float, default=25.0)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    from bench_tracking_real import _per_frame, noisy_detections, run_ours, synthetic_boxes
    from thermoswarm.io.mot import read_mot_table

    groups: dict[str, list[Any]] = {}
    if args.data is not None:
        limit = dict(x.split("=") for x in args.limit)
        for seq in sorted(p.name for p in args.data.iterdir() if (p / "gt" / "gt.txt").exists()):
            gt = read_mot_table(args.data / seq / "gt" / "gt.txt")
            if seq in limit:
                gt = gt[gt[:, 0] <= int(limit[seq])]
            for level in args.levels:
                groups[f"{seq} {level}"] = [
                    _per_frame(noisy_detections(gt, level, s), int(gt[:, 0].max()))
                    for s in args.seeds
                ]
    for n in args.synthetic:
        gt = synthetic_boxes(n, args.synthetic_frames, seed=n)
        for level in args.levels:
            groups[f"synthetic {n} objects {level}"] = [
                _per_frame(noisy_detections(gt, level, s), args.synthetic_frames)
                for s in args.seeds
            ]
    posed = set()
    for n in args.poses:
        posed.add(name := f"synthetic video {n} ants, poses")
        groups[name] = [pose_detections(n, args.pose_frames, s) for s in args.seeds]
    with tempfile.TemporaryDirectory() as tmp:
        sys.path.insert(0, tmp)
        base = importlib.import_module(export(args.base, Path(tmp)) + ".tracker")
        if args.new is None:
            import thermoswarm.tracking.track.tracker as new
        else:
            new = importlib.import_module(export(args.new, Path(tmp)) + ".tracker")
        print(f"{'detections':36s} {'base f/s':>9s} {'new f/s':>9s} {'new/base':>9s}")
        for name, runs in groups.items():
            ratios, fb, fn = [], [], []
            for frames in runs:
                if name in posed:
                    dets, fps = frames

                    def job(mod: Any, dets: list[Any] = dets, fps: float = fps) -> Any:
                        return _run_poses(mod, dets, fps)

                    same, what = _same_result, "tracks"
                else:

                    def job(mod: Any, frames: list[np.ndarray] = frames) -> Any:
                        return run_ours(frames, args.fps, mod.TrackerConfig(), mod.Tracker)

                    same, what = np.array_equal, "MOT tables"
                best = {"base": np.inf, "new": np.inf}
                out = {}
                for _ in range(args.repeat):
                    for tag, mod in (("base", base), ("new", new)):
                        t0 = time.perf_counter()
                        out[tag] = job(mod)
                        best[tag] = min(best[tag], time.perf_counter() - t0)
                if not same(out["base"], out["new"]):
                    print(f"{name}: the {what} differ", file=sys.stderr)
                    return 1
                n = len(frames[0]) if name in posed else len(frames)
                ratios.append(best["base"] / best["new"])
                fb.append(n / best["base"])
                fn.append(n / best["new"])
            g = float(np.exp(np.mean(np.log(ratios))))
            print(f"{name:36s} {np.mean(fb):9.0f} {np.mean(fn):9.0f} {g:9.2f}")
    print(
        f"(best of {args.repeat}, interleaved, one process; MOT tables, and for posed "
        "detections the whole track result, identical on every run)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
