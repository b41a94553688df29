"""Ants on the two food patches of the Niche-Lab foraging photos, counted by a
thermoswarm detector without a scale, against the labelled counts.

    python benchmarks/bench_niche_counts.py DATA_DIR [--model M.pt] [--detector NAME]
        [--set detector.KEY=VALUE] [--series auto|yes|no] [--window 12]
        [--detections-dir DIR] [--margin 0.5] [--plot OUT.png] [--overlay-dir DIR]
        [--json OUT.json]

``DATA_DIR``: the photos of Niche-Lab/ant-detective at commit be518ac,
``data/peptone_sucrose/train/`` (trials 1-5) and ``val/`` (trial 6) as ``DATA_DIR/train``
and ``DATA_DIR/val``, and the labels, ``DATA_DIR/trials.xlsx`` (``data/OHA Foraging
Trials.xlsx``, sheets ``P v S 1`` to ``P v S 6`` only; read with the standard library)
or ``DATA_DIR/{train,val}/annotation.txt`` (the authors' CSV: ``filename, time,
sucrose, peptone, ...``).  docs/real_footage.md says how to bring them in.  Nothing of
the ``test`` split (trials 7-9) is read.

The benchmark detects nothing itself; it scores what ``thermoswarm detect`` finds.

- Detection: each trial's photos are given to
  :func:`thermoswarm.tracking.pipeline.detect_inputs`, as ``thermoswarm detect PHOTOS...
  --out DIR`` does: the tool recognises the photos as a series (no clocks, no times in
  the names: by how much changes between them), takes them in the order taken (the
  camera's counter wraps in trial 6) and detects them in windows of photos, each with
  its own background, the body length measured once per trial from its first 90
  photos, with its options for photo series (``thermoswarm.tracking.pipeline.series``).
  ``--series``/``--window`` are ``detect_inputs``' ``series``/``series_window``;
  ``--model``/``--detector``/``--set`` choose and tune the detector as for ``detect``.
  ``--detections-dir DIR`` scores a finished run instead: ``DIR/t<N>.json`` (or
  ``DIR/t<N>/t<N>.json``: ``thermoswarm detect t<N> --out DIR/t<N>`` on a folder
  ``t<N>`` of one trial's photos), COCO from ``detect`` or any detector.
- Patches and counts: the tool's ``--regions color:8-45,margin=M``
  (:mod:`thermoswarm.tracking.pipeline.patches`, ``NAME_regions.csv``).  Each dish
  holds pieces of saturated yellow-orange paper soaked with one food (two dishes, left
  and right).  A patch is the paper of one dish: pixels of hue 8-45 (OpenCV's 0-180
  scale), saturation >= 150 and value >= 100; components smaller than 3 L^2 or
  touching the photo's border (the loose paper outside the dishes) are dropped; each
  component is closed with a disc of diameter L (the ants sitting on it) and its holes
  filled; components left of the photo's centre form the left patch.  On a patch: the
  detection's body point lies within the patch plus a margin of ``--margin`` body
  lengths (default 0.5, half a body length).  A ``--detections-dir`` without such a
  CSV is counted here with the same functions.
- Which dish holds sucrose: ``SUCROSE_SIDE`` per trial.  For trials 1-5 it is the side
  whose counts fit the train labels better (the only thing tuned, on train); trial 6's
  is read from the dishes' "S" and "P" marks (sucrose on the right), not from its labels.

Figures per split and patch (and both patches together): mean absolute error (MAE),
bias (mean of predicted minus labelled), Pearson and Spearman correlation, and the
labelled mean; frames (photos) per second of
the detection (wall time in this process, background learning included) and of the
patch finding.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import re
import sys
import tempfile
import time
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree import ElementTree

import numpy as np

from thermoswarm.tracking.pipeline.patches import (
    ColorPatch,
    ColorRegions,
    count_patches,
    on_patch,
)
from thermoswarm.tracking.pipeline.series import SERIES_WINDOW

#: The food papers (yellow and orange): ``detect --regions color:8-45``
#: (:mod:`thermoswarm.tracking.pipeline.patches`, saturation >= 150, value >= 100).
PAPER_HUE = (8, 45)

#: Side of the sucrose dish per trial: trials 1-5 tuned on the train labels (see
#: ``tune_sides``), trial 6 read from the "S" written on the right dish.
SUCROSE_SIDE = {1: "left", 2: "right", 3: "right", 4: "right", 5: "left", 6: "right"}

TRAIN_TRIALS = (1, 2, 3, 4, 5)
VAL_TRIALS = (6,)
_NS = {"m": "http://schemas.openxmlformats.org/spreadsheetml/2006/main"}
_REL = "{http://schemas.openxmlformats.org/officeDocument/2006/relationships}id"


@dataclass
class Photo:
    """One labelled photo and, once counted, the predicted counts."""

    name: str
    trial: int
    sucrose: int
    peptone: int
    path: Path
    counts: dict[str, int] = field(default_factory=dict)  # side -> ants on its patch


def _photo_name(number: str, trial: int) -> str:
    """The authors' file name of photo ``number`` of ``trial`` (their make_splits.py:
    the last three digits, zero-padded)."""
    return f"t{trial}_{int(float(number)) % 1000:03d}.JPG"


def _cell_values(z: zipfile.ZipFile, path: str, strings: list[str]) -> list[list[str]]:
    root = ElementTree.fromstring(z.read(path))
    rows = []
    for row in root.iter(f"{{{_NS['m']}}}row"):
        vals: dict[int, str] = {}
        for c in row.findall("m:c", _NS):
            v = c.find("m:v", _NS)
            if v is None or v.text is None:
                continue
            col = re.match(r"[A-Z]+", c.get("r", "A"))
            k = sum((ord(ch) - 64) * 26**i for i, ch in enumerate(reversed(col.group())))
            vals[k - 1] = strings[int(v.text)] if c.get("t") == "s" else v.text
        rows.append([vals.get(i, "") for i in range(max(vals, default=-1) + 1)])
    return rows


def labels_from_xlsx(path: Path, trials: tuple[int, ...]) -> dict[str, tuple[int, int, int]]:
    """``{file name: (trial, sucrose, peptone)}`` from the sheets ``P v S <trial>`` of
    the authors' workbook (rows with all of photo, sucrose and peptone filled)."""
    with zipfile.ZipFile(path) as z:
        book = ElementTree.fromstring(z.read("xl/workbook.xml"))
        rels = ElementTree.fromstring(z.read("xl/_rels/workbook.xml.rels"))
        targets = {r.get("Id"): r.get("Target", "").lstrip("/") for r in rels}
        sst = ElementTree.fromstring(z.read("xl/sharedStrings.xml"))
        strings = ["".join(t.text or "" for t in si.iter(f"{{{_NS['m']}}}t")) for si in sst]
        out: dict[str, tuple[int, int, int]] = {}
        for sheet in book.find("m:sheets", _NS) or []:
            m = re.fullmatch(r"P v S (\d+)", sheet.get("name", ""))
            if not m or int(m.group(1)) not in trials:
                continue
            target = targets[sheet.get(_REL)]
            rows = _cell_values(z, target if target.startswith("xl/") else "xl/" + target, strings)
            head = [h.strip().lower() for h in rows[0]]
            i_s, i_p = head.index("sucrose"), head.index("peptone")
            for r in rows[1:]:
                if len(r) > max(i_s, i_p) and r[0] and r[i_s] and r[i_p]:
                    t = int(m.group(1))
                    out[_photo_name(r[0], t)] = (t, int(float(r[i_s])), int(float(r[i_p])))
    return out


def labels_from_csv(path: Path) -> dict[str, tuple[int, int, int]]:
    """``{file name: (trial, sucrose, peptone)}`` from an ``annotation.txt``."""
    with open(path, newline="") as fh:
        return {
            r["filename"]: (int(r["trial"].split("_")[-1]), int(r["sucrose"]), int(r["peptone"]))
            for r in csv.DictReader(fh)
        }


def load_photos(data_dir: Path) -> list[Photo]:
    """The labelled photos of ``data_dir/train`` and ``data_dir/val`` (trials 1-6)."""
    trials = TRAIN_TRIALS + VAL_TRIALS
    if (data_dir / "trials.xlsx").is_file():
        labels = labels_from_xlsx(data_dir / "trials.xlsx", trials)
    else:
        labels = {}
        for split in ("train", "val"):
            if not (data_dir / split / "annotation.txt").is_file():
                sys.exit(f"error: {data_dir}: expected trials.xlsx or {split}/annotation.txt")
            labels.update(labels_from_csv(data_dir / split / "annotation.txt"))
    photos = []
    for split in ("train", "val"):
        for p in sorted((data_dir / split).glob("t*_*.JPG")):
            if p.name in labels and labels[p.name][0] in trials:
                t, s, pep = labels[p.name]
                photos.append(Photo(p.name, t, s, pep, p))
    if not photos:
        sys.exit(f"error: {data_dir}: no labelled photos t<N>_<NNN>.JPG in train/ or val/")
    return photos


def coco_bodies(path: Path) -> tuple[dict[str, np.ndarray], float]:
    """Body points per image file name from a COCO file of ``thermoswarm detect`` (the
    middle keypoint; the box centre when there are no keypoints) and the body length
    L it states (``info.thermoswarm.length_px``; else the median box diagonal)."""
    data = json.loads(path.read_text())
    names = {im["id"]: im["file_name"] for im in data["images"]}
    pts: dict[str, list] = {n: [] for n in names.values()}
    diag = []
    for a in data["annotations"]:
        kp = a.get("keypoints")
        if kp and len(kp) >= 6:
            xy = (kp[3], kp[4])
        else:
            x, y, w, h = a["bbox"]
            xy = (x + w / 2, y + h / 2)
        pts[names[a["image_id"]]].append(xy)
        diag.append(math.hypot(a["bbox"][2], a["bbox"][3]))
    length = data.get("info", {}).get("thermoswarm", {}).get("length_px")
    if not length:
        length = float(np.median(diag)) if diag else 30.0
    return {n: np.asarray(p, float).reshape(-1, 2) for n, p in pts.items()}, float(length)


def _detections_file(root: Path, trial: int) -> Path:
    """``root/t<N>.json``, else ``root/t<N>/t<N>.json`` (``detect t<N> --out root/t<N>``)."""
    for f in (root / f"t{trial}.json", root / f"t{trial}" / f"t{trial}.json"):
        if f.is_file():
            return f
    sys.exit(f"error: {root}: no t{trial}.json or t{trial}/t{trial}.json (trial {trial})")


def _regions_csv(path: Path) -> dict[str, dict[str, int]]:
    """``{file: {"left": n, "right": n}}`` from a ``NAME_regions.csv`` of ``detect
    --regions color:...``."""
    with open(path, newline="") as fh:
        return {r["file"]: {k: int(r[k]) for k in ("left", "right")} for r in csv.DictReader(fh)}


def detect_trials(
    photos: list[Photo], out_dir: Path, args: argparse.Namespace
) -> dict[int, tuple[dict[str, np.ndarray], float, float, dict | None]]:
    """Detect every trial's photos with ``detect_inputs`` (as ``thermoswarm detect
    PHOTOS... --regions color:8-45,margin=M``); ``{trial: (bodies per file, L px,
    seconds, counts per file)}``.  With ``args.detections_dir`` the COCO files there
    are read instead (seconds NaN), and their ``t<N>_regions.csv`` when it holds
    ``left`` and ``right`` (else counts ``None``: counted here with the tool's
    patches)."""
    from thermoswarm.tracking.pipeline import detect_inputs

    out: dict[int, tuple[dict[str, np.ndarray], float, float, dict | None]] = {}
    for t in sorted({p.trial for p in photos}):
        if args.detections_dir is not None:
            coco = _detections_file(args.detections_dir, t)
            bodies, length = coco_bodies(coco)
            regions = coco.with_name(f"t{t}_regions.csv")
            with_sides = regions.is_file() and "left" in regions.read_text().split("\n", 1)[0]
            out[t] = (bodies, length, math.nan, _regions_csv(regions) if with_sides else None)
            continue
        t0 = time.perf_counter()
        summary = detect_inputs(
            [p.path for p in photos if p.trial == t],
            out_dir / f"t{t}",
            detector=args.detector,
            model=args.model,
            detector_options=args.options or None,
            series=args.series,
            series_window=args.window,
            regions=f"color:{PAPER_HUE[0]}-{PAPER_HUE[1]},margin={args.margin}",
        )
        args.series_used[t] = summary["inputs"][0]["photo_series"]
        bodies, length = coco_bodies(out_dir / f"t{t}" / "images.json")
        counts = _regions_csv(out_dir / f"t{t}" / "images_regions.csv")
        out[t] = (bodies, length, time.perf_counter() - t0, counts)
    return out


def count_photo(photo: Photo, bodies: np.ndarray, length: float, margin: float) -> dict:
    """Count the ants on each patch of one photo with the tool's patches
    (``detect --regions color:8-45``); returns the masks (with margin)."""
    import cv2

    rgb = cv2.cvtColor(cv2.imread(str(photo.path)), cv2.COLOR_BGR2RGB)
    spec = ColorRegions((ColorPatch(hue=PAPER_HUE, margin_bl=margin),))
    counts, masks, _ = count_patches(spec, rgb, bodies, length)
    photo.counts = {k: int(c) for k, c in zip(spec.names, counts, strict=False)}
    return masks


def count_all(photos: list[Photo], dets: dict, args: argparse.Namespace) -> tuple[dict, int]:
    """Set every photo's counts: from the tool's ``NAME_regions.csv`` where there is
    one, else counted here (and for the photos to draw, whose masks are returned with
    the number of photos counted here)."""
    masks = {}
    n_counted = 0
    for p in photos:
        bodies, length, _, counts = dets[p.trial]
        draw = p.name in args.overlay.split(",") and args.overlay_dir is not None
        if counts is not None:
            p.counts = counts[p.name]
        if counts is None or draw:
            m = count_photo(p, bodies[p.name], length, args.margin)
            n_counted += 1
            if draw:
                masks[p.name] = m
    return masks, n_counted


def predicted(photo: Photo, sides: dict[int, str]) -> tuple[int, int]:
    """(sucrose, peptone) counted, with the sucrose dish on ``sides[trial]``."""
    s = sides[photo.trial]
    return photo.counts[s], photo.counts["left" if s == "right" else "right"]


def tune_sides(photos: list[Photo]) -> dict[int, str]:
    """Per trial, the sucrose side whose counts fit the labels better (smaller summed
    absolute error over both patches)."""
    sides = {}
    for t in sorted({p.trial for p in photos}):
        err = {}
        for side in ("left", "right"):
            err[side] = sum(
                abs(a - p.sucrose) + abs(b - p.peptone)
                for p in photos
                if p.trial == t
                for a, b in [predicted(p, {t: side})]
            )
        sides[t] = min(err, key=err.get)
    return sides


def metrics(pred: np.ndarray, true: np.ndarray) -> dict[str, float]:
    """MAE, bias (mean of pred - true), Pearson r, Spearman rho, labelled mean, n."""
    from scipy.stats import spearmanr

    d = pred - true
    varied = pred.std() > 0 and true.std() > 0
    r = float(np.corrcoef(pred, true)[0, 1]) if varied else math.nan
    rho = float(spearmanr(pred, true).statistic) if varied else math.nan
    return {
        "mae": float(np.abs(d).mean()),
        "bias": float(d.mean()),
        "r": r,
        "rho": rho,
        "mean_label": float(true.mean()),
        "n": int(len(d)),
    }


def table(photos: list[Photo], sides: dict[int, str]) -> dict[str, dict[str, dict]]:
    """``{split: {patch: metrics}}`` for train (trials 1-5) and val (trial 6)."""
    out: dict[str, dict[str, dict]] = {}
    for split, trials in (("train", TRAIN_TRIALS), ("val", VAL_TRIALS)):
        sel = [p for p in photos if p.trial in trials]
        if not sel:
            continue
        pred = np.array([predicted(p, sides) for p in sel], float)
        true = np.array([(p.sucrose, p.peptone) for p in sel], float)
        out[split] = {
            "sucrose": metrics(pred[:, 0], true[:, 0]),
            "peptone": metrics(pred[:, 1], true[:, 1]),
            "total": metrics(pred.sum(1), true.sum(1)),
        }
    return out


def draw_overlay(
    photo: Photo, bodies: np.ndarray, length: float, masks: dict, sides: dict, path: Path
) -> None:
    """Write ``path`` (PNG): the photo with each patch's outline (margin included),
    every detection (a circle of diameter L/2 at its body point: green on a patch,
    magenta off) and the predicted and labelled counts."""
    import cv2

    from thermoswarm.fsutil import atomic_write_bytes

    img = cv2.imread(str(photo.path))
    s_side = sides[photo.trial]
    for side, m in masks.items():
        mode = (cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        contours, _ = cv2.findContours(m.astype(np.uint8), *mode)
        colour = (255, 128, 0) if side == s_side else (0, 128, 255)
        cv2.drawContours(img, contours, -1, colour, 2)
    on = np.zeros(len(bodies), bool)
    for m in masks.values():
        on |= on_patch(bodies, m)
    r = max(3, int(round(length / 4)))
    for (x, y), o in zip(bodies, on, strict=True):
        cv2.circle(img, (int(round(x)), int(round(y))), r, (0, 200, 0) if o else (255, 0, 255), 2)
    pred = predicted(photo, sides)
    text = [
        f"{photo.name}  sucrose ({s_side}, blue): {pred[0]} counted / {photo.sucrose} labelled",
        f"peptone (orange): {pred[1]} counted / {photo.peptone} labelled",
    ]
    for k, line in enumerate(text):
        for colour, thick in (((255, 255, 255), 5), ((0, 0, 0), 2)):
            font = cv2.FONT_HERSHEY_SIMPLEX
            cv2.putText(img, line, (10, 28 + 30 * k), font, 0.75, colour, thick)
    ok, buf = cv2.imencode(".png", img)
    atomic_write_bytes(path, buf.tobytes())


def plot(photos: list[Photo], sides: dict, res: dict, path: Path) -> None:
    """Predicted against labelled counts, one panel per patch, train and val marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(9, 4.4))
    rng = np.random.default_rng(0)  # jitter only, so that equal counts do not hide
    for ax, (j, patch) in zip(axes, enumerate(("sucrose", "peptone")), strict=True):
        top = 1
        for split, trials, style in (("train", TRAIN_TRIALS, "o"), ("val", VAL_TRIALS, "s")):
            sel = [p for p in photos if p.trial in trials]
            if not sel:
                continue
            pred = np.array([predicted(p, sides)[j] for p in sel], float)
            true = np.array([(p.sucrose, p.peptone)[j] for p in sel], float)
            m = res[split][patch]
            ax.scatter(
                true + rng.uniform(-0.2, 0.2, len(true)),
                pred + rng.uniform(-0.2, 0.2, len(pred)),
                s=10,
                marker=style,
                alpha=0.5,
                label=f"{split} (n={m['n']}): MAE {m['mae']:.2f}, bias {m['bias']:+.2f}, "
                f"r {m['r']:.2f}",
            )
            top = max(top, true.max(), pred.max())
        ax.plot([0, top], [0, top], "k--", lw=0.8)
        ax.set_xlabel(f"labelled ants on the {patch} patch")
        ax.set_ylabel("counted by the detector")
        ax.set_title(patch)
        ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=90)
    plt.close(fig)
    tmp.replace(path)


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("data_dir", type=Path, help="train/, val/ and trials.xlsx (see above)")
    ap.add_argument("--model", type=Path, help="trained detector weights (the unet detector)")
    ap.add_argument("--detector", help="detector name (default: classical, unet with --model)")
    ap.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument(
        "--detections-dir",
        "--coco-dir",
        dest="detections_dir",
        type=Path,
        help="score DIR/t<N>.json or DIR/t<N>/t<N>.json (a detect run) instead of detecting",
    )
    ap.add_argument("--margin", type=float, default=0.5, help="body lengths (default 0.5)")
    ap.add_argument(
        "--series",
        choices=("auto", "yes", "no"),
        default="auto",
        help="detect's --series: auto (default) lets the tool recognise the photo series",
    )
    ap.add_argument(
        "--window",
        type=int,
        default=SERIES_WINDOW,
        help=f"photos per background in a series (default {SERIES_WINDOW}, the tool's; "
        "0: one per trial)",
    )
    ap.add_argument("--tune-sides", action="store_true", help="re-tune SUCROSE_SIDE on train")
    ap.add_argument("--plot", type=Path, help="PNG of predicted against labelled counts")
    ap.add_argument("--overlay-dir", type=Path, help="PNG overlays of --overlay photos")
    ap.add_argument("--overlay", default="t1_412.JPG,t6_830.JPG", help="photos to draw")
    ap.add_argument("--json", type=Path, help="write the figures as JSON")
    args = ap.parse_args(argv)
    from thermoswarm.config import parse_overrides

    try:
        sets = parse_overrides(tuple(args.sets))
    except Exception as exc:  # a malformed --set: one line, exit 2
        ap.exit(2, f"error: --set: {exc}\n")
    unknown = set(sets) - {"detector"}
    if unknown:
        ap.exit(2, f"error: --set takes detector.KEY=VALUE, got {sorted(unknown)[0]}.*\n")
    args.options = sets.get("detector", {})  # the tool adds its options for photo series
    args.series_used = {}
    if not args.data_dir.is_dir():
        ap.exit(2, f"error: {args.data_dir}: no such folder (expected train/, val/)\n")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    photos = load_photos(args.data_dir)
    with tempfile.TemporaryDirectory() as tmp:
        dets = detect_trials(photos, Path(tmp), args)
    t0 = time.perf_counter()
    masks, n_counted = count_all(photos, dets, args)
    patch_s = time.perf_counter() - t0
    sides = dict(SUCROSE_SIDE)
    tuned = tune_sides([p for p in photos if p.trial in TRAIN_TRIALS])
    if args.tune_sides:
        sides.update(tuned)
    res = table(photos, sides)
    det_s = sum(v[2] for v in dets.values())
    n = len(photos)
    print(
        f"Niche-Lab photos: {n} labelled (trials {sorted({p.trial for p in photos})}), "
        f"margin {args.margin} L, body length L per trial (px): "
        + ", ".join(f"t{t} {v[1]:.1f}" for t, v in sorted(dets.items()))
    )
    print(f"sucrose side: {sides} (tuned on train: {tuned})")
    if args.series_used:
        print(f"photo series (per trial, as detect recognised them): {args.series_used}")
    print("| split | patch | n | labelled mean | MAE | bias | r | Spearman |")
    print("|---|---|---|---|---|---|---|---|")
    for split, per in res.items():
        for patch, m in per.items():
            print(
                f"| {split} | {patch} | {m['n']} | {m['mean_label']:.2f} | {m['mae']:.2f} | "
                f"{m['bias']:+.2f} | {m['r']:.3f} | {m['rho']:.3f} |"
            )
    counted = (
        f"patches and counting here: {n_counted / patch_s:.1f} photos/s ({patch_s:.1f} s)"
        if n_counted
        else "patches and counts: by detect (NAME_regions.csv)"
    )
    print(f"detection: {n / det_s:.1f} photos/s ({det_s:.1f} s; NaN: read from files); {counted}")
    if args.plot:
        plot(photos, sides, res, args.plot)
    if args.overlay_dir:
        args.overlay_dir.mkdir(parents=True, exist_ok=True)
        for p in photos:
            if p.name in masks:
                bodies, length = dets[p.trial][:2]
                out = args.overlay_dir / f"niche_{p.name.split('.')[0]}.png"
                draw_overlay(p, bodies[p.name], length, masks[p.name], sides, out)
    if args.json:
        from thermoswarm.fsutil import atomic_write_json

        atomic_write_json(
            args.json,
            {
                "table": res,
                "sides": sides,
                "tuned_sides": tuned,
                "margin": args.margin,
                "photo_series": args.series_used,
                "length_px": {t: v[1] for t, v in dets.items()},
                "detect_seconds": det_s,
                "photos": [
                    {
                        "name": p.name,
                        "trial": p.trial,
                        "sucrose": p.sucrose,
                        "peptone": p.peptone,
                        "counts": p.counts,
                    }
                    for p in photos
                ],
            },
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
