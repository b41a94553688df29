"""Ants on the two food patches of the Niche-Lab foraging photos, counted by a
thermoswarm detector without a scale, against the labelled counts.

    python benchmarks/bench_niche_counts.py DATA_DIR [--model M.pt] [--detector NAME]
        [--set detector.KEY=VALUE] [--coco-dir DIR] [--margin 0.5] [--plot OUT.png]
        [--overlay-dir DIR] [--json OUT.json]

``DATA_DIR``: the photos of Niche-Lab/ant-detective at commit be518ac,
``data/peptone_sucrose/train/`` (trials 1-5) and ``val/`` (trial 6) as ``DATA_DIR/train``
and ``DATA_DIR/val``, and the labels, ``DATA_DIR/trials.xlsx`` (``data/OHA Foraging
Trials.xlsx``, sheets ``P v S 1`` to ``P v S 6`` only; read with the standard library)
or ``DATA_DIR/{train,val}/annotation.txt`` (the authors' CSV: ``filename, time,
sucrose, peptone, ...``).  docs/real_footage.md says how to bring them in.  Nothing of
the ``test`` split (trials 7-9) is read.

Method (stated in the output):

- Detection: the photos of each trial (a fixed camera, one photo per 30 min), in the
  order taken, in windows of ``--window`` consecutive photos (12, tuned on train: the
  light, the rims' reflections and the wet wick drift over two days), each window
  given to :func:`thermoswarm.tracking.pipeline.detect_inputs` as ``thermoswarm
  detect PHOTOS... --out DIR`` does (its background learned from those photos);
  without a scale: the ants' body length L (px) is measured once per trial from its
  first 90 photos (``estimate_length_px``) and used for all its windows.
  ``--model``/``--detector``/``--set`` choose and tune the detector as for ``detect``;
  ``--coco-dir DIR`` reads ``DIR/t<N>.json`` (COCO from any detector, one file per
  trial) instead.
- Patches: each dish holds pieces of saturated yellow-orange paper soaked with one
  food (two dishes, left and right).  A patch is the paper of one dish: pixels of hue
  8-45 (OpenCV's 0-180 scale), saturation >= 150 and value >= 100; components smaller
  than 3 L^2 or touching the photo's border (the loose paper outside the dishes) are
  dropped; each component is closed with a disc of diameter L (the ants sitting on it)
  and its holes filled; components left of the photo's centre form the left patch.
- On a patch: the detection's body point lies within the patch plus a margin of
  ``--margin`` body lengths (default 0.5, half a body length).
- Which dish holds sucrose: ``SUCROSE_SIDE`` per trial.  For trials 1-5 it is the side
  whose counts fit the train labels better (the only thing tuned, on train); trial 6's
  is read from the dishes' "S" and "P" marks (sucrose on the right), not from its labels.

Figures per split and patch: mean absolute error (MAE), bias (mean of predicted minus
labelled), Pearson correlation, and the labelled mean; frames (photos) per second of
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

#: Side of the sucrose dish per trial: trials 1-5 tuned on the train labels (see
#: ``tune_sides``), trial 6 read from the "S" written on the right dish.
SUCROSE_SIDE = {1: "left", 2: "right", 3: "right", 4: "right", 5: "left", 6: "right"}

#: Classical detector options for these photos (``--set detector.KEY=VALUE`` adds to
#: or overrides them): a background edge moved by 1 px (working resolution) between
#: photos is not an ant; blobs are split from 2.5 single-ant areas (tuned on train
#: among 1.6, the default, and 2.5: MAE 2.69/3.12 against 3.24/3.43 on the two patches).
PHOTO_OPTIONS: dict[str, object] = {"shift_px": 1, "split_area": 2.5}

#: Photos per background (6 h at one photo per 30 min), tuned on train among 6, 12, 24
#: and one per trial (its first 90 photos): MAE sucrose / peptone 0.97 / 0.64, 0.59 /
#: 0.51, 0.72 / 0.93 and 2.69 / 3.12.
WINDOW = 12

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


def find_patches(rgb: np.ndarray, length_px: float) -> dict[str, np.ndarray]:
    """Boolean masks ``{"left": ..., "right": ...}`` of the food paper in each dish.

    Parameters
    ----------
    rgb
        Photo, ``uint8`` ``(H, W, 3)`` RGB.
    length_px
        The ants' body length L, px (sets the smallest patch, 3 L^2, and the closing
        disc, diameter L, that fills the holes the ants on the paper leave).
    """
    import cv2

    hsv = cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV)
    h, s, v = hsv[..., 0], hsv[..., 1], hsv[..., 2]
    paper = ((h >= 8) & (h <= 45) & (s >= 150) & (v >= 100)).astype(np.uint8)
    paper = cv2.morphologyEx(paper, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
    n, lab, stats, cent = cv2.connectedComponentsWithStats(paper, connectivity=8)
    height, width = paper.shape
    k = max(3, int(round(length_px)) | 1)
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))
    out = {"left": np.zeros_like(paper), "right": np.zeros_like(paper)}
    for i in range(1, n):
        x, y, w, hh, area = stats[i]
        if area < 3 * length_px**2:
            continue
        if x <= 1 or y <= 1 or x + w >= width - 1 or y + hh >= height - 1:
            continue  # loose paper outside the dishes
        # Closed within its bounding box padded by the disc (the same result, faster).
        y0, x0 = max(y - k, 0), max(x - k, 0)
        y1, x1 = min(y + hh + k, height), min(x + w + k, width)
        comp = (lab[y0:y1, x0:x1] == i).astype(np.uint8)
        comp = cv2.morphologyEx(comp, cv2.MORPH_CLOSE, disc, borderValue=0)
        contours, _ = cv2.findContours(comp, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        side = "left" if cent[i][0] < width / 2 else "right"
        cv2.drawContours(out[side][y0:y1, x0:x1], contours, -1, 1, thickness=cv2.FILLED)
    return {k_: m.astype(bool) for k_, m in out.items()}


def grow(mask: np.ndarray, radius_px: float) -> np.ndarray:
    """``mask`` dilated by a disc of ``radius_px`` (the margin of "on a patch")."""
    import cv2

    r = int(round(radius_px))
    if r <= 0:
        return mask
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    return cv2.dilate(mask.astype(np.uint8), disc).astype(bool)


def on_patch(bodies: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Which body points ``(n, 2)`` px (x, y) lie in ``mask``."""
    if len(bodies) == 0:
        return np.zeros(0, bool)
    xy = np.rint(bodies).astype(int)
    xy[:, 0] = np.clip(xy[:, 0], 0, mask.shape[1] - 1)
    xy[:, 1] = np.clip(xy[:, 1], 0, mask.shape[0] - 1)
    return mask[xy[:, 1], xy[:, 0]]


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


def detect_trials(
    photos: list[Photo], out_dir: Path, args: argparse.Namespace
) -> dict[int, tuple[dict[str, np.ndarray], float, float]]:
    """Detect every trial's photos as one sequence; ``{trial: (bodies per file, L px,
    seconds)}``.  With ``args.coco_dir`` the COCO files ``t<N>.json`` there are read
    instead (seconds NaN)."""
    from thermoswarm.tracking.pipeline import detect_inputs

    out: dict[int, tuple[dict[str, np.ndarray], float, float]] = {}
    for t in sorted({p.trial for p in photos}):
        if args.coco_dir is not None:
            bodies, length = coco_bodies(args.coco_dir / f"t{t}.json")
            out[t] = (bodies, length, math.nan)
            continue
        files = time_order([p.path for p in photos if p.trial == t])
        t0 = time.perf_counter()
        if args.window:
            out[t] = (*_detect_windows(files, out_dir / f"t{t}", args), 0.0)
        else:
            detect_inputs(
                files,
                out_dir / f"t{t}",
                detector=args.detector,
                model=args.model,
                detector_options=args.options or None,
            )
            out[t] = (*coco_bodies(out_dir / f"t{t}" / "images.json"), 0.0)
        out[t] = (out[t][0], out[t][1], time.perf_counter() - t0)
    return out


def time_order(files: list[Path]) -> list[Path]:
    """The photos in the order they were taken: their numbers (``t6_826``) count up and
    wrap at 1000 (``t6_999`` is followed by ``t6_000``), so the sequence starts after
    the largest gap between sorted numbers, counted around the wrap."""
    files = sorted(files, key=lambda f: int(f.stem.split("_")[-1]))
    if len(files) < 2:
        return files
    n = np.array([int(f.stem.split("_")[-1]) for f in files])
    gaps = np.diff(np.r_[n, n[0] + 1000])
    start = (int(np.argmax(gaps)) + 1) % len(files)
    return files[start:] + files[:start]


def _detect_windows(
    files: list[Path], out_dir: Path, args: argparse.Namespace
) -> tuple[dict[str, np.ndarray], float]:
    """Detect ``files`` in windows of ``args.window`` consecutive photos, each window
    with its own background (lighting, rims and stains drift over two days); the body
    length is measured once from the trial's first 90 photos (no scale given)."""
    from thermoswarm.tracking import anatomy
    from thermoswarm.tracking.detect.classical import estimate_length_px
    from thermoswarm.tracking.pipeline import detect_inputs
    from thermoswarm.tracking.video import VideoSource

    src = VideoSource.from_images(files[:90], "trial")
    classical = (args.detector or ("classical" if args.model is None else "")) == "classical"
    est = estimate_length_px(src.frames(90, step=2), args.options if classical else None)
    bodies: dict[str, np.ndarray] = {}
    for k in range(0, len(files), args.window):
        chunk = files[k : k + args.window]
        if len(chunk) < args.window // 2 and k:  # a short tail joins the previous window
            chunk = files[max(k - args.window, 0) : k + args.window]
        detect_inputs(
            chunk,
            out_dir / f"w{k}",
            px_per_mm=est.length_px / anatomy.ANT_LENGTH_MM,
            detector=args.detector,
            model=args.model,
            detector_options=args.options or None,
        )
        found, _ = coco_bodies(out_dir / f"w{k}" / "images.json")
        bodies.update({f.name: found[f.name] for f in files[k : k + args.window]})
    return bodies, est.length_px


def count_photo(photo: Photo, bodies: np.ndarray, length: float, margin: float) -> dict:
    """Count the ants on each patch of one photo; returns the masks (with margin)."""
    import cv2

    rgb = cv2.cvtColor(cv2.imread(str(photo.path)), cv2.COLOR_BGR2RGB)
    masks = {k: grow(m, margin * length) for k, m in find_patches(rgb, length).items()}
    photo.counts = {k: int(on_patch(bodies, m).sum()) for k, m in masks.items()}
    return masks


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
    """MAE, bias (mean of pred - true), Pearson r, labelled mean, n."""
    d = pred - true
    r = float(np.corrcoef(pred, true)[0, 1]) if pred.std() > 0 and true.std() > 0 else math.nan
    return {
        "mae": float(np.abs(d).mean()),
        "bias": float(d.mean()),
        "r": r,
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
    ap.add_argument("--coco-dir", type=Path, help="read DIR/t<N>.json instead of detecting")
    ap.add_argument("--margin", type=float, default=0.5, help="body lengths (default 0.5)")
    ap.add_argument(
        "--window",
        type=int,
        default=WINDOW,
        help=f"photos per background (default {WINDOW}, tuned on train; 0: one per trial)",
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
    # Photos 30 min apart: the camera may be nudged between them (see the docstring).
    args.options = {**PHOTO_OPTIONS, **sets.get("detector", {})}
    if not args.data_dir.is_dir():
        ap.exit(2, f"error: {args.data_dir}: no such folder (expected train/, val/)\n")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    photos = load_photos(args.data_dir)
    with tempfile.TemporaryDirectory() as tmp:
        dets = detect_trials(photos, Path(tmp), args)
    t0 = time.perf_counter()
    masks = {}
    for p in photos:
        bodies, length, _ = dets[p.trial]
        m = count_photo(p, bodies[p.name], length, args.margin)
        if p.name in args.overlay.split(","):
            masks[p.name] = m
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
    print("| split | patch | n | labelled mean | MAE | bias | r |")
    print("|---|---|---|---|---|---|---|")
    for split, per in res.items():
        for patch, m in per.items():
            print(
                f"| {split} | {patch} | {m['n']} | {m['mean_label']:.2f} | {m['mae']:.2f} | "
                f"{m['bias']:+.2f} | {m['r']:.3f} |"
            )
    print(
        f"detection: {n / det_s:.1f} photos/s ({det_s:.1f} s); "
        f"patches and counting: {n / patch_s:.1f} photos/s ({patch_s:.1f} s)"
    )
    if args.plot:
        plot(photos, sides, res, args.plot)
    if args.overlay_dir:
        args.overlay_dir.mkdir(parents=True, exist_ok=True)
        for p in photos:
            if p.name in masks:
                bodies, length, _ = dets[p.trial]
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
