"""Regions found as coloured patches: the bait papers of a foraging tray, photo by photo.

``thermoswarm detect FOLDER --regions color:HUE_LO-HUE_HI`` counts the ants on the
coloured patches of each photo instead of on fixed polygons: the papers soaked in food
move a little, curl and get wet over two days, so they are found again in every photo.
A spec is ``color:LO-HI`` with optional ``,sat=S``, ``,val=V`` and ``,margin=M``
(:func:`parse_color_regions`).

A patch (:func:`find_patches`, what ``benchmarks/bench_niche_counts.py`` tuned on the
Niche-Lab train photos): pixels of hue ``LO``-``HI`` (OpenCV's 0-180 scale),
saturation >= ``S`` (150) and value >= ``V`` (100); components smaller than 3 L^2 (L
the ants' body length, px) or touching the photo's border (loose paper outside the
dishes) are dropped; each component is closed with a disc of diameter L (the ants on it
leave holes) and filled.  The components left of the photo's centre are the region
``left``, the others ``right`` (two baits side by side, the usual choice assay).  A
detection is on a patch when its body point lies within the patch grown by ``M`` body
lengths (0.5).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from thermoswarm.errors import InputError

__all__ = [
    "ColorRegions",
    "count_patches",
    "draw_patches",
    "find_patches",
    "grow",
    "on_patch",
    "parse_color_regions",
]

#: Colours (RGB) of the two sides' outlines in pictures.
_SIDE_COLOURS = {"left": (0, 114, 178), "right": (230, 159, 0)}


@dataclass(frozen=True)
class ColorRegions:
    """Regions found in each photo as patches of one colour (see the module docstring).

    ``hue``: OpenCV hue range (0-180, inclusive); ``min_sat``, ``min_val``: 0-255;
    ``margin_bl``: body lengths added around each patch.
    """

    hue: tuple[int, int]
    min_sat: int = 150
    min_val: int = 100
    margin_bl: float = 0.5
    names: tuple[str, ...] = ("left", "right")


def parse_color_regions(spec: str) -> ColorRegions:
    """``color:LO-HI[,sat=S][,val=V][,margin=M]`` -> :class:`ColorRegions`; a one-line
    :class:`~thermoswarm.errors.InputError` naming the spec otherwise."""
    m = re.fullmatch(r"colou?r:(\d+)-(\d+)((?:,\w+=[\d.]+)*)", spec.strip())
    usage = "expected color:HUE_LO-HUE_HI[,sat=S][,val=V][,margin=M] (hue 0-180)"
    if m is None:
        raise InputError(f"--regions {spec!r}: {usage}")
    lo, hi = int(m.group(1)), int(m.group(2))
    kw: dict[str, Any] = {}
    keys = {"sat": ("min_sat", int), "val": ("min_val", int), "margin": ("margin_bl", float)}
    for item in filter(None, m.group(3).split(",")):
        k, v = item.split("=")
        if k not in keys:
            raise InputError(f"--regions {spec!r}: unknown key {k!r}; {usage}")
        try:
            kw[keys[k][0]] = keys[k][1](v)
        except ValueError:
            raise InputError(f"--regions {spec!r}: {k}={v} is not a number") from None
    if not (0 <= lo <= hi <= 180) or not all(
        0 <= kw.get(k, 0) <= 255 for k in ("min_sat", "min_val")
    ):
        raise InputError(f"--regions {spec!r}: {usage}, LO <= HI; sat and val 0-255")
    return ColorRegions(hue=(lo, hi), **kw)


def find_patches(
    rgb: np.ndarray,
    length_px: float,
    hue: tuple[int, int] = (8, 45),
    min_sat: int = 150,
    min_val: int = 100,
) -> dict[str, np.ndarray]:
    """Boolean masks ``{"left": ..., "right": ...}`` of the coloured patches.

    Parameters
    ----------
    rgb
        Photo, ``uint8`` ``(H, W, 3)`` RGB.
    length_px
        The animals' body length L, px (sets the smallest patch, 3 L^2, and the
        closing disc, diameter L, that fills the holes the animals on it leave).
    hue, min_sat, min_val
        The patches' colour: OpenCV hue range (0-180), least saturation and value.
    """
    import cv2

    hsv = cv2.cvtColor(np.ascontiguousarray(rgb[..., :3]), cv2.COLOR_RGB2HSV)
    h, s, v = hsv[..., 0], hsv[..., 1], hsv[..., 2]
    paper = ((h >= hue[0]) & (h <= hue[1]) & (s >= min_sat) & (v >= min_val)).astype(np.uint8)
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
    """``mask`` dilated by a disc of ``radius_px`` (px; the margin of "on a patch")."""
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


def count_patches(
    spec: ColorRegions, frame: np.ndarray, bodies: np.ndarray, length_px: float
) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray]:
    """Count one photo: ``(counts, masks, side)``.

    ``counts``: detections on each region of ``spec.names`` then those on none;
    ``masks``: each region's mask with its margin; ``side``: per detection, the index
    of its region (the first that holds it) or -1.  ``bodies``: ``(n, 2)`` px.
    """
    found = find_patches(frame, length_px, spec.hue, spec.min_sat, spec.min_val)
    masks = {k: grow(m, spec.margin_bl * length_px) for k, m in found.items()}
    side = np.full(len(bodies), -1, np.int64)
    for i, name in enumerate(spec.names):
        side[(side < 0) & on_patch(bodies, masks[name])] = i
    counts = np.bincount(np.where(side < 0, len(spec.names), side), minlength=len(spec.names) + 1)
    return counts, masks, side


def draw_patches(
    frame: np.ndarray,
    spec: ColorRegions,
    masks: dict[str, np.ndarray],
    bodies: np.ndarray,
    side: np.ndarray,
    counts: np.ndarray,
) -> np.ndarray:
    """``frame`` (RGB uint8) with each patch's outline (its margin included) and count,
    a circle at every detection (green on a patch, magenta off); a new array."""
    import cv2

    img = np.ascontiguousarray(frame[..., :3]).copy()
    h = img.shape[0]
    font, fs, th = cv2.FONT_HERSHEY_SIMPLEX, max(0.5, h / 900), max(1, h // 450)
    for i, name in enumerate(spec.names):
        col = _SIDE_COLOURS.get(name, (0, 158, 115))
        contours, _ = cv2.findContours(
            masks[name].astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE
        )
        cv2.drawContours(img, contours, -1, col, 2 * th, cv2.LINE_AA)
        x = 8 if name == "left" else img.shape[1] // 2 + 8
        cv2.putText(img, f"{name}: {counts[i]}", (x, int(30 * fs) + 8), font, fs, col, 2 * th)
    rad = max(4, h // 120)
    for p, s in zip(bodies, side, strict=True):
        col = (0, 200, 0) if s >= 0 else (220, 0, 220)
        cv2.circle(img, (int(round(p[0])), int(round(p[1]))), rad, col, th, cv2.LINE_AA)
    cv2.putText(img, f"outside: {counts[-1]}", (8, h - 10), font, fs, (220, 0, 220), 2 * th)
    return img
