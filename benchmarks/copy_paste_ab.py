"""What copy-paste training (real anTraX ant crops on a real background) changes on
real frames: U-Net models compared zero-shot, without a user's label.

    python benchmarks/copy_paste_ab.py --model NAME=MODEL.pt [--model ...] \\
        --crops DIR --background PNG [--roi PNG] [--seed 0] [--n-frames 60] \\
        [--photos DIR --foragers XLSX [--photo-step N]] \\
        [--video CLIP.mp4 ...] [--max-frames 200] [--json OUT.json]

- Held-out composites (always): the crops of ``--crops`` are split by individual as
  ``thermoswarm track train --real-crops`` splits them with the same ``--seed``
  (``holdout_fraction`` 0.25), and ``--n-frames`` composites of the *held-out*
  individuals only are made on the real background; a model trained with that seed
  never saw those ants.  Our own composites (real ants, real background, pasted by
  us): detection precision, recall, F1 (a match within half a body length) and the
  body point's median error.
- ``--photos``: a folder of real photos (the Niche-Lab ant-detective ``val`` split,
  trial 6) detected by ``thermoswarm detect``'s path without a scale (the ants'
  length measured from the photos, the same for every model); per photo the number
  of detections against the labelled ``Total Foragers`` (ants on the two food
  patches; ants elsewhere are not counted by the labels, so detections exceed it),
  read from ``--foragers`` (the authors' workbook; ``benchmarks/bench_niche_counts.py``
  reads it).
- ``--video``: real unlabelled clips (beelab): detections per frame.

Timings are wall time in this process.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import numpy as np


def held_out_scores(models: dict[str, Path], args: argparse.Namespace) -> dict:
    """Detection scores of each model on composites of the held-out individuals."""
    import dataclasses

    from thermoswarm.tracking.detect.unet import UNetDetector, load_model
    from thermoswarm.tracking.train.fit import TrainConfig, _real_composites
    from thermoswarm.tracking.train.validate import evaluate_detector

    cfg = TrainConfig(seed=args.seed)
    # n_frames sets the held-out set's size (a tenth of it); the split comes first
    # from the generator and does not depend on it.
    cfg = dataclasses.replace(cfg, real=dataclasses.replace(cfg.real, n_frames=10 * args.n_frames))
    _, val = _real_composites(args.crops, args.background, args.roi, cfg, None)
    if val is None:
        sys.exit("error: no individual held out (need two or more in --crops)")
    out = {"set": val.description, "n_ants": int(sum(p.shape[0] for p in val.points))}
    for name, path in models.items():
        det = UNetDetector(load_model(path), px_per_mm=val.px_per_mm)
        m = evaluate_detector(det, val)
        keys = ("precision", "recall", "f1", "body_error_median_px", "tp", "fp", "fn")
        out[name] = {k: m[k] for k in keys if k in m}
    return out


def _counts_per_image(coco: Path) -> dict[str, int]:
    doc = json.loads(coco.read_text())
    names = {im["id"]: f"{Path(im['file_name']).name}#{im['id']}" for im in doc["images"]}
    n = Counter(a["image_id"] for a in doc["annotations"])
    return {names[i]: n.get(i, 0) for i in names}


def _detect(inputs: list[Path], model: Path, tmp: Path, fps: float, max_frames: int | None
            ) -> tuple[dict, float]:  # fmt: skip
    from thermoswarm.tracking.pipeline import detect_inputs

    t0 = time.perf_counter()
    summary = detect_inputs(inputs, tmp, model=model, fps=fps, max_frames=max_frames)
    return summary, time.perf_counter() - t0


def photo_counts(models: dict[str, Path], args: argparse.Namespace) -> dict:
    """Detections per photo against the labelled foragers, per model."""
    sys.path.insert(0, str(Path(__file__).parent))
    from bench_niche_counts import labels_from_xlsx

    labels = labels_from_xlsx(args.foragers, (6,))
    photos = sorted(p for p in args.photos.glob("*.JPG") if p.name in labels)
    photos = photos[:: args.photo_step]
    if not photos:
        sys.exit(f"error: {args.photos}: no photo with a label in {args.foragers}")
    total = np.array([labels[p.name][1] + labels[p.name][2] for p in photos], float)
    out: dict = {"n_photos": len(photos), "labelled_mean": float(total.mean())}
    for name, path in models.items():
        with tempfile.TemporaryDirectory() as tmp:
            summary, secs = _detect(photos, path, Path(tmp), 1.0, None)
            counts = _counts_per_image(Path(tmp) / "images.json")
        by_name = {k.split("#")[0]: v for k, v in counts.items()}
        d = np.array([by_name.get(p.name, 0) for p in photos], float)
        r = float(np.corrcoef(d, total)[0, 1]) if d.std() > 0 else float("nan")
        out[name] = {
            "detections_mean": float(d.mean()),
            "mae": float(np.abs(d - total).mean()),
            "pearson_r": r,
            "zero_detection_photos": int((d == 0).sum()),
            "length_px": summary["inputs"][0].get("length_px"),
            "photos_per_s": len(photos) / secs,
        }
    return out


def video_counts(models: dict[str, Path], args: argparse.Namespace) -> dict:
    """Detections per frame of each clip, per model."""
    out: dict = {}
    for clip in args.video:
        row: dict = {}
        for name, path in models.items():
            with tempfile.TemporaryDirectory() as tmp:
                _, secs = _detect([clip], path, Path(tmp), 30.0, args.max_frames)
                counts = _counts_per_image(Path(tmp) / f"{clip.stem}.json")
            n = np.array(list(counts.values()), float)
            row[name] = {
                "frames": int(n.size),
                "per_frame_median": float(np.median(n)),
                "per_frame_min": int(n.min()),
                "per_frame_max": int(n.max()),
                "frames_by_count": {int(k): int((n == k).sum()) for k in np.unique(n)},
                "frames_per_s": n.size / secs,
            }
        out[clip.name] = row
    return out


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", action="append", required=True, metavar="NAME=MODEL.pt")
    ap.add_argument("--crops", type=Path, required=True)
    ap.add_argument("--background", type=Path, required=True)
    ap.add_argument("--roi", type=Path)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--n-frames", type=int, default=60)
    ap.add_argument("--photos", type=Path)
    ap.add_argument("--foragers", type=Path)
    ap.add_argument("--photo-step", type=int, default=1, help="every N-th labelled photo")
    ap.add_argument("--video", type=Path, action="append", default=[])
    ap.add_argument("--max-frames", type=int, default=200)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args(argv)
    models = {}
    for m in args.model:
        name, sep, path = m.partition("=")
        if not sep or not Path(path).is_file():
            ap.error(f"--model {m!r}: expected NAME=MODEL.pt of an existing file")
        models[name] = Path(path)
    if (args.photos is None) != (args.foragers is None):
        ap.error("--photos and --foragers go together")
    res = {"held_out_composites": held_out_scores(models, args)}
    print(json.dumps(res, indent=1), flush=True)
    if args.photos is not None:
        res["photos"] = photo_counts(models, args)
        print(json.dumps(res["photos"], indent=1), flush=True)
    if args.video:
        res["videos"] = video_counts(models, args)
        print(json.dumps(res["videos"], indent=1), flush=True)
    if args.json is not None:
        from thermoswarm.fsutil import atomic_write_json

        atomic_write_json(args.json, res)


if __name__ == "__main__":
    main()
