"""Photo series: still photos taken a while apart (a tray photographed every 30 min).

Between such photos the light, the reflections and the wet stains drift, and ants
that sit still for hours would become background if one background served the whole
series.  :func:`is_photo_series` recognises a series by the photos' own clocks (EXIF
``DateTimeOriginal``, else ``DateTime``): a median gap of at least ``min_gap_s``
(60 s) between consecutive photos; :func:`detect_series` then detects the photos in
windows of :data:`SERIES_WINDOW` consecutive photos, each with its own background, the
body length measured once from the first 90 photos, with the classical detector's
options :data:`SERIES_OPTIONS`.  Both values are what ``benchmarks/bench_niche_counts.py``
tuned on the Niche-Lab train photos (trials 1-5; docs/real_footage.md): windows of 12
against 6, 24 and one per trial, ``shift_px=1`` and ``split_area=2.5`` against the
defaults.
"""

from __future__ import annotations

import datetime as dt
import os
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.tracking import anatomy
from thermoswarm.tracking.detect.classical import estimate_length_px
from thermoswarm.tracking.pipeline.common import build_detector

__all__ = ["SERIES_OPTIONS", "SERIES_WINDOW", "photo_times", "is_photo_series", "detect_series"]

#: Photos per background window (tuned on the Niche-Lab train photos).
SERIES_WINDOW = 12
#: Classical detector options for photo series (tuned on the same photos; the user's
#: options win).
SERIES_OPTIONS: dict[str, Any] = {"shift_px": 1, "split_area": 2.5}


def photo_times(files: list[Path]) -> np.ndarray | None:
    """Seconds since the first photo from each file's EXIF clock; ``None`` when a photo
    has none (or it cannot be read)."""
    from PIL import Image

    out = []
    for f in files:
        try:
            with Image.open(f) as im:
                exif = im.getexif()
                stamp = exif.get_ifd(0x8769).get(36867) or exif.get(306)
        except OSError:
            return None
        if not stamp:
            return None
        try:
            t = dt.datetime.strptime(str(stamp).strip("\x00 "), "%Y:%m:%d %H:%M:%S")
        except ValueError:
            return None
        out.append(t.timestamp())
    return np.asarray(out) - out[0] if out else None


def is_photo_series(files: list[Path] | None, min_gap_s: float = 60.0) -> bool:
    """Whether ``files`` are still photos taken a while apart (see the module docstring)."""
    if not files or len(files) < 2:
        return False
    t = photo_times(files)
    return t is not None and float(np.median(np.diff(np.sort(t)))) >= min_gap_s


def detect_series(
    files: list[Path],
    *,
    px_per_mm: float | None,
    detector: str | None,
    model: str | os.PathLike | None,
    options: dict[str, Any] | None,
) -> tuple[list[Any], dict[str, Any], Any]:
    """Detect the photos ``files`` (in order) window by window.

    Returns the detections per photo, the scale record (as
    :func:`~thermoswarm.tracking.pipeline.common.build_detector`'s) and the last
    window's detector.  A short last window (under half a window) is detected together
    with the window before it.
    """
    from thermoswarm.tracking.video import VideoSource

    classical = (detector or ("classical" if model is None else "")) == "classical"
    opts = {**SERIES_OPTIONS, **(options or {})} if classical else options
    source = "user"
    if px_per_mm is None:
        first = VideoSource.from_images(files[:90], "series")
        est = estimate_length_px(first.frames(90, step=2), opts if classical else None)
        px_per_mm = est.length_px / anatomy.ANT_LENGTH_MM
        source = "measured"
    dets: list[Any] = []
    w = SERIES_WINDOW
    det = scale = None
    for k in range(0, len(files), w):
        lo = k if len(files) - k >= w // 2 or not k else max(k - w, 0)
        chunk = files[lo : k + w]
        src = VideoSource.from_images(chunk, "window")
        det, scale = build_detector(
            src, len(chunk), px_per_mm=px_per_mm, detector=detector, model=model, options=opts
        )
        dets.extend(det.detect(f) for f in list(src.frames())[k - lo :])
    assert scale is not None
    scale = {**scale, "scale_source": source, "series_window": w, "series_options": opts}
    return dets, scale, det
