"""Reader throughput against the route a user would otherwise take, in one process.

Each case writes one file with the format's own library, then times
``thermoswarm.io.read_tracks`` (to the finished trajectory dataset, in mm and s) and
a baseline that gets the same numbers into a NumPy array the usual way:

* ``sleap_analysis_h5``: ``sleap_io.load_analysis_h5(...).numpy()``
* ``sleap_analysis_h5_h5py``: ``h5py`` reads ``tracks`` and ``point_scores`` directly
  and transposes them to (time, space, keypoints, individuals) -- the arrays
  ``movement``'s SLEAP loader starts from, the fastest route there is (bare arrays)
* ``sleap_analysis_h5_movement``: ``movement``'s own loader,
  ``movement.io.load_poses.from_sleap_file`` (its validated dataset, in pixels)
* ``sleap_slp``: ``sleap_io.load_slp(...).numpy()`` (what ``movement`` does)
* ``dlc_h5``: ``pandas.read_hdf`` + reshape to (time, space, keypoints, individuals)
  (what ``movement`` does; ``read_hdf`` unpickles the file's attributes)
* ``dlc_h5_movement``: ``movement.io.load_poses.from_dlc_file``
* ``tidy_csv``: ``pandas.read_csv`` + ``pivot`` to a (frame, individual) table

Timings are the best of ``--repeat`` runs; the ratio is baseline / ours (> 1: ours
faster).  Usage::

    PYTHONPATH=src python benchmarks/bench_io.py [--quick] [--json]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from thermoswarm.io import read_tracks


def best(fn: Callable[[], object], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def movement_loader(name: str) -> Callable | None:
    """A loader of ``movement.io.load_poses`` (the dev extra), quiet; None without it."""
    try:
        from loguru import logger
        from movement.io import load_poses
    except ImportError:
        return None
    logger.disable("movement")  # its INFO lines on stderr would fill the table
    return getattr(load_poses, name)


def make_positions(rng, n_frames: int, n_ind: int, n_kp: int) -> np.ndarray:
    steps = rng.normal(scale=2.0, size=(n_frames, 2, n_kp, n_ind))
    return 500.0 + np.cumsum(steps, axis=0)


def case_sleap(tmp: Path, rng, n_frames: int, n_ind: int, repeat: int) -> list[dict]:
    import sleap_io as sio

    px = make_positions(rng, n_frames, n_ind, 3)
    skel = sio.Skeleton(nodes=["head", "thorax", "tail"])
    video = sio.Video(filename="v.mp4", open_backend=False)
    tracks = [sio.Track(name=f"ant{i}") for i in range(n_ind)]
    frames = [
        sio.LabeledFrame(
            video=video,
            frame_idx=t,
            instances=[
                sio.PredictedInstance.from_numpy(
                    points_data=px[t, :, :, i].T,
                    skeleton=skel,
                    point_scores=np.ones(3),
                    score=1.0,
                    track=tracks[i],
                )
                for i in range(n_ind)
            ],
        )
        for t in range(n_frames)
    ]
    labels = sio.Labels(labeled_frames=frames, videos=[video], skeletons=[skel], tracks=tracks)
    slp, h5 = tmp / "p.slp", tmp / "p.analysis.h5"
    sio.save_slp(labels, str(slp))
    sio.save_analysis_h5(labels, str(h5))
    size = f"{n_frames} frames x {n_ind} tracks x 3 nodes"
    out = []

    def direct() -> np.ndarray:
        import h5py

        with h5py.File(h5, "r") as f:  # movement: tracks (n_tracks, 2, n_nodes, n_frames)
            pos = f["tracks"][:].transpose(3, 1, 2, 0) / 3.04
            scores = f["point_scores"][:].transpose(2, 1, 0)
        return pos, scores

    cases = [
        ("sleap_analysis_h5", h5, lambda: sio.load_analysis_h5(str(h5)).numpy()),
        ("sleap_analysis_h5_h5py", h5, direct),
        ("sleap_slp", slp, lambda: sio.load_slp(str(slp), open_videos=False).numpy()),
    ]
    loader = movement_loader("from_sleap_file")
    if loader is not None:
        cases.insert(2, ("sleap_analysis_h5_movement", h5, lambda: loader(h5, fps=30.0)))
    for name, path, baseline in cases:
        ours = best(lambda p=path: read_tracks(p, fps=30.0, px_per_mm=3.04), repeat)
        base = best(baseline, repeat)
        out.append({"case": name, "size": size, "ours_s": ours, "baseline_s": base})
    return out


def case_dlc(tmp: Path, rng, n_frames: int, n_ind: int, repeat: int) -> list[dict]:
    try:
        import tables  # noqa: F401
    except ImportError:
        return []
    px = make_positions(rng, n_frames, n_ind, 3)
    cols, data = [], []
    for i in range(n_ind):
        for k, kp in enumerate(("head", "thorax", "tail")):
            for c, v in (("x", px[:, 0, k, i]), ("y", px[:, 1, k, i]), ("likelihood", None)):
                cols.append(("DLC_resnet50", f"ant{i}", kp, c))
                data.append(np.ones(n_frames) if v is None else v)
    names = ["scorer", "individuals", "bodyparts", "coords"]
    df = pd.DataFrame(np.column_stack(data), columns=pd.MultiIndex.from_tuples(cols, names=names))
    path = tmp / "dlc.h5"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        df.to_hdf(path, key="df_with_missing", format="table", mode="w")

    def baseline() -> np.ndarray:
        # movement's route: read_hdf, then reshape to (time, coords, keypoints, individuals)
        arr = pd.read_hdf(path, key="df_with_missing").to_numpy()
        return arr.reshape(n_frames, n_ind, 3, 3).transpose(0, 3, 2, 1)[:, :2] / 3.04

    ours = best(lambda: read_tracks(path, fps=30.0, px_per_mm=3.04), repeat)
    size = f"{n_frames} frames x {n_ind} individuals x 3 bodyparts"
    rows = [{"case": "dlc_h5", "size": size, "ours_s": ours, "baseline_s": best(baseline, repeat)}]
    loader = movement_loader("from_dlc_file")
    if loader is not None:
        base = best(lambda: loader(path, fps=30.0), repeat)
        rows.append({"case": "dlc_h5_movement", "size": size, "ours_s": ours, "baseline_s": base})
    return rows


def case_tidy(tmp: Path, rng, n_frames: int, n_ind: int, repeat: int) -> list[dict]:
    px = make_positions(rng, n_frames, n_ind, 1)[:, :, 0, :]
    frame = np.repeat(np.arange(n_frames), n_ind)
    ind = np.tile([f"ant{i}" for i in range(n_ind)], n_frames)
    df = pd.DataFrame({"id": ind, "frame": frame, "x": px[:, 0].ravel(), "y": px[:, 1].ravel()})
    path = tmp / "tidy.csv"
    df.to_csv(path, index=False)

    def baseline() -> np.ndarray:
        d = pd.read_csv(path)
        return d.pivot(index="frame", columns="id", values=["x", "y"]).to_numpy()

    ours = best(lambda: read_tracks(path, fps=30.0, px_per_mm=3.04), repeat)
    base = best(baseline, repeat)
    size = f"{n_frames * n_ind} rows ({n_frames} frames x {n_ind} individuals)"
    return [{"case": "tidy_csv", "size": size, "ours_s": ours, "baseline_s": base}]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (a few seconds)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", action="store_true", help="print JSON instead of a table")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    rng = np.random.default_rng(args.seed)
    n_frames, n_ind = (500, 10) if args.quick else (3000, 20)
    rows: list[dict] = []
    with tempfile.TemporaryDirectory() as d, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tmp = Path(d)
        rows += case_sleap(tmp, rng, n_frames, n_ind, args.repeat)
        rows += case_dlc(tmp, rng, n_frames * 5, n_ind, args.repeat)
        rows += case_tidy(tmp, rng, n_frames * 20, n_ind, args.repeat)
    for r in rows:
        r["ratio"] = r["baseline_s"] / r["ours_s"]
    if args.json:
        print(json.dumps(rows, indent=2))
    else:
        for r in rows:
            print(
                f"{r['case']:<18} {r['size']:<46} ours {r['ours_s'] * 1e3:8.1f} ms  "
                f"baseline {r['baseline_s'] * 1e3:8.1f} ms  ratio {r['ratio']:6.2f}"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
