"""Counts per region: the bait-choice assay (how many ants on each food, photo by photo).

Regions are the named polygons that ``thermoswarm analyze --regions`` reads
(:mod:`thermoswarm.analysis.regions`: ``[[region]]`` tables with ``name`` and
``polygon`` or ``rect``), in the image's px when no scale is given, in mm (the image's
px over ``px_per_mm``) when one is.  A detection counts in the first region that holds
its body point.  :func:`count_regions` gives the counts; :func:`counts_csv` the table
(one row per frame or photo: ``frame, file, REGION..., outside``);
:func:`draw_counts` a picture of a frame with its regions, their counts and the
detections (green in a region, magenta outside).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from thermoswarm.tracking.detection import FrameDetections

__all__ = ["count_regions", "counts_csv", "draw_counts"]

#: Colours (RGB) of the regions in pictures, in file order (then repeated).
_COLOURS = [(0, 114, 178), (230, 159, 0), (0, 158, 115), (204, 121, 167), (86, 180, 233)]


def _labels(regions: Sequence[Any], d: FrameDetections, px_per_mm: float | None) -> np.ndarray:
    from thermoswarm.analysis.regions import assign_regions

    if not len(d):
        return np.zeros(0, np.int64)
    body = d.points[:, 1, :] / (px_per_mm or 1.0)
    return assign_regions(regions, body[:, 0], body[:, 1])


def count_regions(
    regions: Sequence[Any], dets: Sequence[FrameDetections], px_per_mm: float | None = None
) -> np.ndarray:
    """``(n_frames, n_regions + 1)`` detections per frame in each region (file order),
    the last column those in none.

    Parameters
    ----------
    regions
        :class:`~thermoswarm.analysis.regions.Region` list (px, or mm with a scale).
    dets
        The detections of each frame (px).
    px_per_mm
        The image scale when the regions are in mm; ``None``: regions in px.
    """
    out = np.zeros((len(dets), len(regions) + 1), np.int64)
    for k, d in enumerate(dets):
        lab = _labels(regions, d, px_per_mm)
        out[k] = np.bincount(np.where(lab < 0, len(regions), lab), minlength=len(regions) + 1)
    return out


def counts_csv(names: Sequence[str], regions: Sequence[Any], counts: np.ndarray) -> str:
    """The CSV text: ``frame`` (from 1), ``file`` (the photo's name), one column per
    region, ``outside``."""
    head = ["frame", "file", *(r.name for r in regions), "outside"]
    rows = [",".join(head)]
    for k, (name, c) in enumerate(zip(names, counts, strict=True)):
        rows.append(",".join([str(k + 1), name, *(str(int(v)) for v in c)]))
    return "\n".join(rows) + "\n"


def draw_counts(
    frame: np.ndarray,
    regions: Sequence[Any],
    d: FrameDetections,
    counts: np.ndarray,
    px_per_mm: float | None = None,
) -> np.ndarray:
    """``frame`` (RGB uint8) with each region's outline and count and a circle at every
    detection (green in a region, magenta outside); a new array."""
    import cv2

    img = np.ascontiguousarray(frame[..., :3] if frame.ndim == 3 else np.dstack([frame] * 3))
    img = img.copy()
    s = px_per_mm or 1.0
    h = img.shape[0]
    font, fs, th = cv2.FONT_HERSHEY_SIMPLEX, max(0.5, h / 900), max(1, h // 450)
    for i, r in enumerate(regions):
        col = _COLOURS[i % len(_COLOURS)]
        pts = np.round(r.vertices * s).astype(np.int32)
        cv2.polylines(img, [pts], True, col, 2 * th, cv2.LINE_AA)
        x, y = pts[:, 0].min(), max(pts[:, 1].min() - 6, 20)
        cv2.putText(img, f"{r.name}: {counts[i]}", (int(x), int(y)), font, fs, col, 2 * th)
    lab = _labels(regions, d, px_per_mm)
    rad = max(4, h // 120)
    for p, L in zip(d.points[:, 1, :] if len(d) else [], lab, strict=True):
        col = (0, 200, 0) if L >= 0 else (220, 0, 220)
        cv2.circle(img, (int(round(p[0])), int(round(p[1]))), rad, col, th, cv2.LINE_AA)
    cv2.putText(img, f"outside: {counts[-1]}", (8, h - 10), font, fs, (220, 0, 220), 2 * th)
    return img
