"""Regions found as coloured patches: the bait papers of a foraging tray, photo by photo.

``thermoswarm detect FOLDER --regions color:HUE_LO-HUE_HI`` counts the ants on the
coloured patches of each photo instead of on fixed polygons: the papers soaked in food
move a little, curl and get wet over two days, so they are found again in every photo.
A spec is one colour or several joined by ``+``, each ``color:LO-HI`` with optional
``,sat=S``, ``,val=V``, ``,margin=M``, ``,split=lr|tb|quad|none`` and ``,name=NAME``
(:func:`parse_color_regions`).

A patch (:func:`find_patches`, what ``benchmarks/bench_niche_counts.py`` tuned on the
Niche-Lab train photos): pixels of hue ``LO``-``HI`` (OpenCV's 0-180 scale),
saturation >= ``S`` (150) and value >= ``V`` (100); components smaller than 3 L^2 (L
the ants' body length, px) or touching the photo's border (loose paper outside the
dishes) are dropped; each component is closed with a disc of diameter L (the ants on it
leave holes) and filled.  A colour's patches are then split into regions by where
their centres lie in the photo (``split``): ``lr`` the left and the right half (two
baits side by side, the usual choice assay; the default for a colour without a name),
``tb`` the top and the bottom half, ``quad`` the four quarters, ``none`` one region
(the default for a named colour: baits told apart by their paper's colour, wherever
they lie).  Regions are named ``NAME_SIDE`` (``sucrose_left``), ``SIDE`` without a
name (``left``, ``top_right``), ``NAME`` with ``split=none`` (``patch`` when neither).
A detection is on a patch when its body point lies within the patch grown by ``M``
body lengths (0.5); a detection on two regions counts in the first one of the spec.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from thermoswarm.errors import InputError

__all__ = [
    "ColorPatch",
    "ColorRegions",
    "count_patches",
    "draw_patches",
    "find_patches",
    "grow",
    "on_patch",
    "parse_color_regions",
]

#: Each split's sides, in the order of the CSV's columns.
SPLITS: dict[str, tuple[str, ...]] = {
    "lr": ("left", "right"),
    "tb": ("top", "bottom"),
    "quad": ("top_left", "top_right", "bottom_left", "bottom_right"),
    "none": ("",),
}
#: Outline colours (RGB) of the regions in pictures: the two sides of the usual assay
#: keep theirs, the others take the Okabe-Ito palette in turn (colour-blind safe).
_SIDE_COLOURS = {"left": (0, 114, 178), "right": (230, 159, 0)}
_PALETTE = ((0, 158, 115), (204, 121, 167), (86, 180, 233), (213, 94, 0), (240, 228, 66))


@dataclass(frozen=True)
class ColorPatch:
    """Patches of one colour, split into regions (see the module docstring).

    ``hue``: OpenCV hue range (0-180, inclusive); ``min_sat``, ``min_val``: 0-255;
    ``margin_bl``: body lengths added around each patch; ``split``: a key of
    :data:`SPLITS`; ``name``: the regions' prefix ('' for none).
    """

    hue: tuple[int, int]
    min_sat: int = 150
    min_val: int = 100
    margin_bl: float = 0.5
    split: str = "lr"
    name: str = ""

    @property
    def names(self) -> tuple[str, ...]:
        """The names of this colour's regions, one per side of its split."""
        return tuple("_".join(filter(None, (self.name, s))) or "patch" for s in SPLITS[self.split])


@dataclass(frozen=True)
class ColorRegions:
    """Regions found in each photo as patches of one or more colours."""

    patches: tuple[ColorPatch, ...]

    @property
    def names(self) -> tuple[str, ...]:
        """Every region's name, in the spec's order (the CSV's columns)."""
        return tuple(n for p in self.patches for n in p.names)


_USAGE = (
    "expected color:HUE_LO-HUE_HI[,sat=S][,val=V][,margin=M][,split=lr|tb|quad|none]"
    "[,name=NAME] (hue 0-180), several joined by +"
)
_KEYS = {"sat": ("min_sat", int), "val": ("min_val", int), "margin": ("margin_bl", float)}


def _parse_one(spec: str, part: str) -> ColorPatch:
    m = re.fullmatch(r"colou?r:(\d+)-(\d+)((?:,\w+=[\w.-]+)*)", part.strip())
    if m is None:
        raise InputError(f"--regions {spec!r}: {_USAGE}")
    lo, hi = int(m.group(1)), int(m.group(2))
    kw: dict[str, Any] = {}
    for item in filter(None, m.group(3).split(",")):
        k, v = item.split("=")
        if k == "split":
            if v not in SPLITS:
                raise InputError(f"--regions {spec!r}: split={v}: expected {'|'.join(SPLITS)}")
            kw["split"] = v
        elif k == "name":
            if not re.fullmatch(r"[A-Za-z][A-Za-z0-9_-]*", v):
                raise InputError(
                    f"--regions {spec!r}: name={v}: a letter, then letters, digits, _ or -"
                )
            kw["name"] = v
        elif k in _KEYS:
            try:
                kw[_KEYS[k][0]] = _KEYS[k][1](v)
            except ValueError:
                raise InputError(f"--regions {spec!r}: {k}={v} is not a number") from None
        else:
            raise InputError(f"--regions {spec!r}: unknown key {k!r}; {_USAGE}")
    if not (0 <= lo <= hi <= 180) or not all(
        0 <= kw.get(k, 0) <= 255 for k in ("min_sat", "min_val")
    ):
        raise InputError(f"--regions {spec!r}: {_USAGE}, LO <= HI; sat and val 0-255")
    if kw.get("margin_bl", 0) < 0:
        raise InputError(f"--regions {spec!r}: margin must be >= 0 (body lengths)")
    kw.setdefault("split", "none" if kw.get("name") else "lr")
    return ColorPatch(hue=(lo, hi), **kw)


def parse_color_regions(spec: str) -> ColorRegions:
    """``color:LO-HI[,key=value...][+color:...]`` -> :class:`ColorRegions`; a one-line
    :class:`~thermoswarm.errors.InputError` naming the spec otherwise (also when two
    regions would have one name)."""
    out = ColorRegions(tuple(_parse_one(spec, part) for part in spec.split("+")))
    names = out.names
    twice = sorted(
        {n for n in names if names.count(n) > 1} | ({"outside", "file", "frame"} & set(names))
    )
    if twice:
        raise InputError(
            f"--regions {spec!r}: region name {twice[0]!r} is taken (twice, or a column of "
            "the CSV); give each colour its own name=NAME"
        )
    return out


def find_patches(
    rgb: np.ndarray,
    length_px: float,
    hue: tuple[int, int] = (8, 45),
    min_sat: int = 150,
    min_val: int = 100,
    split: str = "lr",
) -> dict[str, np.ndarray]:
    """Boolean masks of the coloured patches, one per side of ``split`` (keys: the
    sides of :data:`SPLITS`, ``""`` for ``none``).

    Parameters
    ----------
    rgb
        Photo, ``uint8`` ``(H, W, 3)`` RGB.
    length_px
        The animals' body length L, px (sets the smallest patch, 3 L^2, and the
        closing disc, diameter L, that fills the holes the animals on it leave).
    hue, min_sat, min_val
        The patches' colour: OpenCV hue range (0-180), least saturation and value.
    split
        How the patches are split into regions by their centres (:data:`SPLITS`).
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
    out = {side: np.zeros_like(paper) for side in SPLITS[split]}
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
        side = _side(split, cent[i], width, height)
        cv2.drawContours(out[side][y0:y1, x0:x1], contours, -1, 1, thickness=cv2.FILLED)
    return {k_: m.astype(bool) for k_, m in out.items()}


def _side(split: str, centre: np.ndarray, width: int, height: int) -> str:
    """The side of ``split`` that a patch centred at ``centre`` (x, y px) is on."""
    lr = "left" if centre[0] < width / 2 else "right"
    tb = "top" if centre[1] < height / 2 else "bottom"
    return {"lr": lr, "tb": tb, "quad": f"{tb}_{lr}", "none": ""}[split]


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
    masks: dict[str, np.ndarray] = {}
    for patch in spec.patches:
        found = find_patches(
            frame, length_px, patch.hue, patch.min_sat, patch.min_val, patch.split
        )
        for name, m in zip(patch.names, found.values(), strict=True):
            masks[name] = grow(m, patch.margin_bl * length_px)
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
    drawn = 0
    for i, name in enumerate(spec.names):
        mask = masks[name].astype(np.uint8)
        if not mask.any():
            continue  # no patch of this region in the photo: its 0 is in the CSV
        col = _SIDE_COLOURS.get(name, _PALETTE[drawn % len(_PALETTE)])
        drawn += 1
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        cv2.drawContours(img, contours, -1, col, 2 * th, cv2.LINE_AA)
        # the label above the region (below it at the photo's top), inside the photo
        text = f"{name}: {counts[i]}"
        (tw, t_h), _ = cv2.getTextSize(text, font, fs, 2 * th)
        x, y, _, hh = cv2.boundingRect(mask)
        ty = y - 6 if y - 6 - t_h >= 0 else min(y + hh + t_h + 6, img.shape[0] - 4)
        cv2.putText(img, text, (min(x, img.shape[1] - tw - 4), ty), font, fs, col, 2 * th)
    rad = max(4, h // 120)
    for p, s in zip(bodies, side, strict=True):
        col = (0, 200, 0) if s >= 0 else (220, 0, 220)
        cv2.circle(img, (int(round(p[0])), int(round(p[1]))), rad, col, th, cv2.LINE_AA)
    cv2.putText(img, f"outside: {counts[-1]}", (8, h - 10), font, fs, (220, 0, 220), 2 * th)
    return img
