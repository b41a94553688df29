"""Copy-paste augmentation: real ant crops pasted on a real background frame.

The U-Net's synthetic training data show drawn ants; this module composes training
frames from *real* pixels instead: random tiles of a real background frame (the empty
arena of an experiment, e.g. anTraX's ``background.png``) with real cropped ants
pasted on them (anTraX's classifier examples: one folder of background-removed crops
per individual).  Each paste has a random position, rotation, mirror and a scale near
the crop's own (the crops and the background come from the same camera, so an ant
keeps its real size in that background's px); its alpha is the crop's
background-removed mask.  Ants sometimes touch or overlap (a paste next to the
previous one).

Labels come from each pasted crop's mask: the body point is the centroid of the
darkness-weighted mask (dark body and tags count, the pale legs and antennae that
background removal leaves little); the body length is measured from its second
moments.  Head and tail are left **unlabelled** (NaN): anTraX's crops are aligned
on the body axis but their head-tail direction is not documented, and at 10 px/mm
the two colour tags (thorax and gaster) hide the gaster's width, so neither the crop
orientation nor a width profile is a label we can trust.  The pose loss ignores NaN
points, so these samples teach the centroid network and the pose network's body
point only; a wrong head-tail label would teach the tracker's head-tail decision
the wrong way.  An ant more than half covered by later pastes is an ignore region
(no loss near it), not a label.

Crops are split **by individual** (folder) into training and held-out identities, so
that an evaluation on held-out composites never sees an ant it was trained on.
Every random draw of a call flows from the one ``numpy.random.Generator`` passed in.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from thermoswarm.config import check
from thermoswarm.errors import InputError
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.train.data import LabeledFrames

__all__ = [
    "RealCropConfig",
    "AntCrop",
    "load_crops",
    "load_background",
    "split_identities",
    "composite_frames",
    "crop_length_px",
    "measure_crop",
]

#: anTraX ``labels.csv`` category of the labels that are one individual each (the
#: others are ``noant_labels``, ``other_labels`` such as ``Unknown``, ``tagcolors``).
ANT_CATEGORY = "ant_labels"


@dataclass(frozen=True)
class RealCropConfig:
    """Copy-paste composites (TOML table ``[real]``).

    ``n_frames``: composite frames made for training.  ``tile``: their side (px of
    the background; a multiple of 16).  ``ants_min``, ``ants_max``: ants pasted per
    frame (uniform).  ``touch_probability``: chance that an ant is pasted touching
    the previous one (centre 0.4-0.9 body lengths away).  ``scale_jitter``: relative
    scale change of a paste (uniform +-).  ``holdout_fraction``: individuals held out
    of training (at least one when there are two or more).  ``min_visible``: an ant
    with less of its mask visible after later pastes is an ignore region.
    """

    n_frames: int = 240
    tile: int = 256
    ants_min: int = 2
    ants_max: int = 12
    touch_probability: float = 0.3
    scale_jitter: float = 0.1
    holdout_fraction: float = 0.25
    min_visible: float = 0.5

    def __post_init__(self) -> None:
        check(self.n_frames >= 1, "n_frames", "a positive integer", self.n_frames)
        check(
            self.tile >= 64 and self.tile % 16 == 0, "tile", "a multiple of 16, >= 64", self.tile
        )
        check(self.ants_min >= 0, "ants_min", ">= 0", self.ants_min)
        check(self.ants_max >= max(1, self.ants_min), "ants_max", ">= ants_min", self.ants_max)
        check(
            0 <= self.touch_probability <= 1,
            "touch_probability",
            "in [0, 1]",
            self.touch_probability,
        )
        check(0 <= self.scale_jitter < 0.5, "scale_jitter", "in [0, 0.5)", self.scale_jitter)
        check(
            0 <= self.holdout_fraction < 1, "holdout_fraction", "in [0, 1)", self.holdout_fraction
        )
        check(0 <= self.min_visible <= 1, "min_visible", "in [0, 1]", self.min_visible)


@dataclass(frozen=True)
class AntCrop:
    """One background-removed ant: ``rgb`` ``(h, w, 3)`` uint8, ``alpha`` ``(h, w)``
    float32 in [0, 1], ``centre`` (x, y) px of its body point, ``angle`` of its body
    axis (rad, image axes), ``length`` px (body length from the second moments)."""

    rgb: np.ndarray
    alpha: np.ndarray
    centre: np.ndarray
    angle: float
    length: float


def _read_png(path: Path) -> np.ndarray:
    import cv2

    img = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if img is None:
        raise InputError(f"{path}: cannot read the image (expected a PNG file)")
    return cv2.cvtColor(img, cv2.COLOR_BGR2RGB)


def measure_crop(rgb: np.ndarray) -> AntCrop | None:
    """Mask, body point, axis and length of a background-removed crop (white, 255,
    where removed); ``None`` when nothing is left."""
    import cv2

    mask = (rgb < 250).any(-1).astype(np.uint8)
    mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, np.ones((3, 3), np.uint8))
    if mask.sum() < 10:
        return None
    grey = rgb.astype(np.float32).mean(-1)
    w = mask * np.clip((255.0 - grey) / 255.0, 0, 1) ** 2
    total = float(w.sum())
    if total <= 0:
        return None
    ys, xs = np.mgrid[0 : rgb.shape[0], 0 : rgb.shape[1]]
    cx, cy = float((w * xs).sum() / total), float((w * ys).sum() / total)
    dx, dy = xs - cx, ys - cy
    cov = (
        np.array(
            [
                [(w * dx * dx).sum(), (w * dx * dy).sum()],
                [(w * dx * dy).sum(), (w * dy * dy).sum()],
            ]
        )
        / total
    )
    evals, evecs = np.linalg.eigh(cov)
    major = evecs[:, 1]
    # A uniform rod of length L has variance L^2 / 12 along it.
    length = math.sqrt(12.0 * max(evals[1], 0.0))
    alpha = cv2.GaussianBlur(mask.astype(np.float32), (0, 0), 0.6) * mask
    return AntCrop(rgb, alpha, np.array([cx, cy]), math.atan2(major[1], major[0]), length)


def _individuals(root: Path) -> list[Path]:
    """The individuals' folders of ``root`` (those of ``ant_labels`` in its anTraX
    ``labels.csv`` when there is one; every sub-folder otherwise)."""
    if not root.is_dir():
        raise InputError(f"{root}: not a folder (expected one folder of ant crops per individual)")
    dirs = sorted(p for p in root.iterdir() if p.is_dir())
    table = root / "labels.csv"
    if table.is_file():
        keep = set()
        for line in table.read_text().splitlines():
            parts = [p.strip() for p in line.replace("\t", ",").split(",")]
            if len(parts) >= 2 and parts[1] == ANT_CATEGORY:
                keep.add(parts[0])
        dirs = [d for d in dirs if d.name in keep]
    return [d for d in dirs if any(d.glob("*.png"))]


def load_crops(root: str | Path, *, max_per_individual: int | None = None
               ) -> dict[str, list[AntCrop]]:  # fmt: skip
    """Crops by individual from ``root``: one sub-folder of PNG crops per individual
    (white background = removed), e.g. anTraX's ``classifier/examples``.

    Parameters
    ----------
    root
        The folder.  An anTraX ``labels.csv`` in it restricts the individuals to its
        ``ant_labels`` (multi-ant and noise labels are left out).
    max_per_individual
        Read at most this many crops per individual (evenly spaced in name order).

    Returns
    -------
    dict
        Individual name -> its crops (crops with no ant pixel are left out).
    """
    root = Path(root)
    out: dict[str, list[AntCrop]] = {}
    for d in _individuals(root):
        files = sorted(d.glob("*.png"))
        if max_per_individual is not None and len(files) > max_per_individual:
            idx = np.linspace(0, len(files) - 1, max_per_individual).round().astype(int)
            files = [files[i] for i in idx]
        crops = [c for c in (measure_crop(_read_png(f)) for f in files) if c is not None]
        if crops:
            out[d.name] = crops
    if not out:
        raise InputError(
            f"{root}: no ant crops (expected sub-folders of PNG crops, one per individual)"
        )
    return out


def load_background(path: str | Path, roi: str | Path | None, tile: int
                    ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The background frame (RGB) and its region of interest (bool; all true without
    ``roi``); both at least ``tile`` px on each side."""
    import cv2

    img = _read_png(Path(path))
    if min(img.shape[:2]) < tile:
        raise InputError(
            f"{path}: background is {img.shape[1]}x{img.shape[0]} px, smaller than the "
            f"{tile} px tile (real.tile)"
        )
    mask = np.ones(img.shape[:2], bool)
    if roi is not None:
        m = cv2.imread(str(roi), cv2.IMREAD_GRAYSCALE)
        if m is None:
            raise InputError(f"{roi}: cannot read the ROI mask (expected a PNG file)")
        if m.shape != img.shape[:2]:
            raise InputError(
                f"{roi}: ROI mask is {m.shape[1]}x{m.shape[0]} px, the background "
                f"{img.shape[1]}x{img.shape[0]}"
            )
        mask = m > 127
    return img, mask


def split_identities(names: Sequence[str], holdout_fraction: float, rng: np.random.Generator
                     ) -> tuple[list[str], list[str]]:  # fmt: skip
    """Training and held-out individuals (disjoint, sorted): ``holdout_fraction`` of
    them, rounded, at least one when there are two or more and the fraction is > 0."""
    names = sorted(names)
    n_out = int(round(holdout_fraction * len(names)))
    if holdout_fraction > 0 and len(names) >= 2:
        n_out = min(max(n_out, 1), len(names) - 1)
    perm = rng.permutation(len(names))
    held = sorted(names[i] for i in perm[:n_out])
    return sorted(set(names) - set(held)), held


def crop_length_px(crops: dict[str, list[AntCrop]]) -> float:
    """Median body length (px) of the crops: the ants' size in the background's px."""
    return float(np.median([c.length for cs in crops.values() for c in cs]))


def _tile(bg: np.ndarray, roi: np.ndarray, T: int, rng: np.random.Generator
          ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """A random ``T`` x ``T`` tile of the background, mostly inside the ROI, randomly
    mirrored and turned by a multiple of 90 degrees."""
    H, W = bg.shape[:2]
    for _ in range(20):
        y, x = int(rng.integers(H - T + 1)), int(rng.integers(W - T + 1))
        r = roi[y : y + T, x : x + T]
        if r.mean() >= 0.5:
            break
    img, r = bg[y : y + T, x : x + T], roi[y : y + T, x : x + T]
    k = int(rng.integers(4))
    img, r = np.rot90(img, k), np.rot90(r, k)
    if rng.random() < 0.5:
        img, r = img[:, ::-1], r[:, ::-1]
    return np.ascontiguousarray(img), np.ascontiguousarray(r)


def _paste(canvas: np.ndarray, owner: np.ndarray, crop: AntCrop, at: np.ndarray, theta: float,
           scale: float, mirror: bool, k: int) -> np.ndarray:  # fmt: skip
    """Paste ``crop`` with its body point at ``at`` (px), rotated by ``theta``, scaled
    and mirrored; mark its pixels in ``owner`` with ``k``; return the body point."""
    import cv2

    c, s = math.cos(theta) * scale, math.sin(theta) * scale
    A = np.array([[c, -s], [s, c]])
    if mirror:
        A = A @ np.diag([-1.0, 1.0])
    M = np.column_stack([A, at - A @ crop.centre])
    T = canvas.shape[0]
    rgb = cv2.warpAffine(crop.rgb, M, (T, T), flags=cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_CONSTANT, borderValue=(255, 255, 255))  # fmt: skip
    a = cv2.warpAffine(crop.alpha, M, (T, T), flags=cv2.INTER_LINEAR)[..., None]
    canvas[:] = canvas * (1 - a) + rgb.astype(np.float32) * a
    owner[a[..., 0] > 0.5] = k
    return M[:, :2] @ crop.centre + M[:, 2]


def _position(T: int, roi: np.ndarray, prev: np.ndarray | None, length: float, p_touch: float,
              rng: np.random.Generator) -> np.ndarray:  # fmt: skip
    """Where the next ant goes: touching ``prev`` with probability ``p_touch``,
    anywhere in the tile's ROI otherwise (at least 3 px inside the tile)."""
    for _ in range(20):
        if prev is not None and rng.random() < p_touch:
            a = rng.uniform(0, 2 * np.pi)
            at = prev + rng.uniform(0.4, 0.9) * length * np.array([math.cos(a), math.sin(a)])
        else:
            at = rng.uniform(3, T - 4, 2)
        xi, yi = int(round(at[0])), int(round(at[1]))
        if 3 <= xi < T - 3 and 3 <= yi < T - 3 and roi[yi, xi]:
            return at
    return rng.uniform(3, T - 4, 2)


def _one_frame(crops: list[AntCrop], bg: np.ndarray, roi: np.ndarray, cfg: RealCropConfig,
               length: float, rng: np.random.Generator
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """One composite: the frame, its labelled ants ``(n, 3, 2)`` (head and tail NaN)
    and the centres ``(m, 2)`` of ants mostly hidden by later pastes."""
    tile, troi = _tile(bg, roi, cfg.tile, rng)
    canvas = tile.astype(np.float32)
    owner = np.full(tile.shape[:2], -1, np.int32)
    n = int(rng.integers(cfg.ants_min, cfg.ants_max + 1))
    body, area = [], []
    prev = None
    for k in range(n):
        crop = crops[int(rng.integers(len(crops)))]
        at = _position(cfg.tile, troi, prev, length, cfg.touch_probability, rng)
        theta = float(rng.uniform(0, 2 * np.pi))
        scale = float(1 + cfg.scale_jitter * rng.uniform(-1, 1))
        mirror = bool(rng.random() < 0.5)
        body.append(_paste(canvas, owner, crop, at, theta, scale, mirror, k))
        area.append(max(int((owner == k).sum()), 1))  # its pixels when pasted
        prev = at
    visible = np.array([(owner == k).sum() / area[k] for k in range(n)])
    body_xy = np.array(body).reshape(-1, 2)
    inside = (body_xy >= 0).all(1) & (body_xy <= cfg.tile - 1).all(1)
    keep = inside & (visible >= cfg.min_visible)
    pts = np.full((int(keep.sum()), 3, 2), np.nan)
    pts[:, 1] = body_xy[keep]
    ignore = body_xy[inside & ~keep]
    return np.rint(canvas).clip(0, 255).astype(np.uint8), pts, ignore


def composite_frames(
    crops: dict[str, list[AntCrop]],
    background: np.ndarray,
    roi: np.ndarray,
    config: RealCropConfig,
    rng: np.random.Generator,
    *,
    n_frames: int | None = None,
    source: str = "anTraX copy-paste",
) -> LabeledFrames:
    """Composite frames of ``crops`` pasted on tiles of ``background``.

    Parameters
    ----------
    crops
        Crops by individual (:func:`load_crops`); every individual given is used.
    background, roi
        The background frame (RGB uint8) and its region of interest (bool), from
        :func:`load_background`.
    config
        :class:`RealCropConfig`.
    rng
        The generator of every draw.
    n_frames
        Frames to make (default ``config.n_frames``).

    Returns
    -------
    LabeledFrames
        Frames of ``config.tile`` px; body points labelled, head and tail NaN; ants
        mostly hidden are ``ignore``.  Its ``px_per_mm`` is the scale at which the
        crops' median body length is the model's 7.14 mm ant (the convention of
        ``--px-per-mm`` for ants of another size).
    """
    if min(background.shape[:2]) < config.tile:
        raise InputError(
            f"background is {background.shape[1]}x{background.shape[0]} px, smaller than "
            f"the {config.tile} px tile (real.tile)"
        )
    pool = [c for name in sorted(crops) for c in crops[name]]
    if not pool:
        raise InputError("no ant crops to paste")
    length = crop_length_px(crops)
    frames, points, ignore = [], [], []
    for _ in range(config.n_frames if n_frames is None else n_frames):
        f, p, g = _one_frame(pool, background, roi, config, length, rng)
        frames.append(f)
        points.append(p)
        ignore.append(g)
    px_per_mm = length / anatomy.ANT_LENGTH_MM
    names = ", ".join(sorted(crops))
    return LabeledFrames(
        frames, points, px_per_mm, f"{source} ({len(frames)} frames; individuals {names})",
        ignore=ignore,
    )  # fmt: skip
