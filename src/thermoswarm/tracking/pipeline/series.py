"""Photo series: still photos taken a while apart (a tray photographed every 30 min).

Between such photos the light, the reflections and the wet stains drift, and ants
that sit still for hours would become background if one background served the whole
series.  :func:`series_evidence` tells a series from the frames of a video, in this
order (the first that speaks decides):

1. **Clocks** -- the photos' EXIF clocks (``DateTimeOriginal``, else ``DateTime``):
   a series when the median gap between consecutive photos is at least ``min_gap_s``
   (60 s), frames when it is shorter.
2. **Names** -- times written in every file name (``IMG_20240501_083000``,
   ``2024-05-01_08-30-00``, ``08-30-00``, ``t_2h30m``, ``030min``): the same rule,
   when at least half of the names give different times.
3. **Changes** -- photos minutes apart share no motion: an ant is somewhere else in
   the next photo, the light has moved, so consecutive photos differ about as much as
   photos eight apart; consecutive frames of a video differ far less than frames eight
   apart (an animal moves a little from one frame to the next).  Measured on the first
   24 images (grey, 256 px wide, blurred by 1 px, each scaled to zero mean and unit
   spread): the share of pixels that change by more than 6 times the noise between
   neighbours, ``f1``, and between images eight apart, ``f8``.  A series when
   ``f1 >= 0.6 f8`` and something changes at all (``f8 >= 2e-4``).  Measured ``f1 /
   f8``: the six Niche-Lab trials (a photo per 30 min), 0.69-0.98; the first 24 frames
   of SLEAP's fly clip (25 frames/s; 0.04, and 0.11 moved by a synthetic hand-held
   camera), of a rendered ant clip (30 frames/s; 0.23) and of a tracking overlay video
   (0.11); drawn ants walking 2.6 body lengths/s at 30 frames/s
   (``tests/tracking/test_series.py``), 0.48-0.49.  Frames so far apart that the
   animals move more than a body length between them (a time-lapse) count as a series
   too (``series="no"`` keeps them a video).

Images without clocks or times are taken in the order of the sequence number their
names end with (``t6_999`` then ``t6_000``: a camera counter of fixed width that
wrapped starts after the largest gap), else by name.

:func:`detect_series` then detects the photos in windows of :data:`SERIES_WINDOW`
consecutive photos, each with its own background (learned from every other photo of
the window), the body length measured once from the first 90 photos, with the
classical detector's options :data:`SERIES_OPTIONS`.  These are what
``benchmarks/bench_niche_counts.py`` tuned on the Niche-Lab train photos (trials 1-5;
docs/real_footage.md): windows of 12 against 6, 24 and one per trial, ``shift_px=1``
and ``split_area=2.5`` against the defaults.
"""

from __future__ import annotations

import datetime as dt
import os
import re
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.errors import InputError
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.detect.size import estimate_length_px
from thermoswarm.tracking.pipeline.common import build_detector

__all__ = [
    "SERIES_OPTIONS",
    "SERIES_WINDOW",
    "change_shares",
    "check_series_options",
    "detect_series",
    "is_photo_series",
    "name_times",
    "photo_times",
    "sequence_order",
    "series_evidence",
    "series_record",
    "series_source",
]

#: Photos per background window (tuned on the Niche-Lab train photos).
SERIES_WINDOW = 12
#: Classical detector options for photo series (tuned on the same photos; the user's
#: options win).
SERIES_OPTIONS: dict[str, Any] = {"shift_px": 1, "split_area": 2.5}
#: The background of each window is learned from every ``SERIES_BG_STEP``-th photo of
#: it (6 of 12), what ``detect`` on a folder of 12 photos does and the benchmark tuned:
#: train MAE sucrose / peptone 0.59 / 0.51 against 0.69 / 0.60 from all 12.
SERIES_BG_STEP = 2
#: Smallest ``f1 / f8`` (see the module docstring) of a series, and the smallest ``f8``.
MIN_CHANGE_RATIO = 0.6
MIN_CHANGED = 2e-4

_DATE_TIME = re.compile(
    r"(?<!\d)(\d{4})[-_.]?(\d{2})[-_.]?(\d{2})[-_T ]?"  # date
    r"(\d{2})[-_.:h]?(\d{2})(?:[-_.:m]?(\d{2}))?(?!\d)"  # time
)
_TIME_OF_DAY = re.compile(r"(?<!\d)(\d{2})[-.:h](\d{2})[-.:m](\d{2})(?!\d)")
_SPAN = re.compile(r"(?<![A-Za-z0-9.])((?:\d+(?:\.\d+)?(?:d|h|min|m|s)){1,4})(?![A-Za-z0-9])")
_SPAN_PART = re.compile(r"(\d+(?:\.\d+)?)(d|h|min|m|s)")
_UNIT_S = {"d": 86400.0, "h": 3600.0, "min": 60.0, "m": 60.0, "s": 1.0}


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


def _name_time(stem: str, kind: str) -> float | None:
    """Seconds from the time of ``kind`` ("date", "day", "span") in a file's stem."""
    if kind == "date":
        m = _DATE_TIME.search(stem)
        if m is None:
            return None
        y, mo, d, h, mi, s = (int(g) if g else 0 for g in m.groups())
        if not 1970 <= y <= 2200:
            return None
        try:
            return dt.datetime(y, mo, d, h, mi, s, tzinfo=dt.UTC).timestamp()
        except ValueError:
            return None
    if kind == "day":
        m = _TIME_OF_DAY.search(stem)
        if m is None:
            return None
        h, mi, s = (int(g) for g in m.groups())
        return 3600.0 * h + 60.0 * mi + s if h < 24 and mi < 60 and s < 60 else None
    m = _SPAN.search(stem.lower())
    if m is None:
        return None
    return sum(float(v) * _UNIT_S[u] for v, u in _SPAN_PART.findall(m.group(1)))


def name_times(files: list[Path]) -> np.ndarray | None:
    """Seconds from the times written in the file names, or ``None``.

    Every name must hold a time of one kind: a date and time (``20240501_083000``,
    ``2024-05-01_08-30``, ``2024-05-01T08.30.00``), a time of day with seconds
    (``08-30-00``, ``08h30m00``; a day is added where it falls below the one before,
    in name order) or a span (``30min``, ``2h30m``, ``1d02h``, ``45s``).  Values are
    seconds, in the order of ``files``; their origin is arbitrary.
    """
    if not files:
        return None
    for kind in ("date", "day", "span"):
        t = [_name_time(Path(f).stem, kind) for f in files]
        if all(v is not None for v in t):
            out = np.asarray(t, float)
            if kind == "day":
                order = np.argsort([Path(f).name for f in files], kind="stable")
                wraps = np.r_[0, np.cumsum(np.diff(out[order]) < 0)]
                out[order] += 86400.0 * wraps
            return out
    return None


def sequence_order(files: list[Path]) -> list[Path]:
    """``files`` in the order of the number their names end with.

    When every name has the same prefix and a number of one fixed width (a camera's
    counter), the counter may have wrapped (``t6_826`` ... ``t6_999``, ``t6_000``
    ...): the sequence starts after the largest gap between the sorted numbers,
    counted around the wrap.  Names without such a number: by name.
    """
    parts = [re.fullmatch(r"(.*?)(\d+)", Path(f).stem) for f in files]
    if not files or any(p is None for p in parts):
        return sorted(files, key=lambda f: Path(f).name)
    nums = np.array([int(p.group(2)) for p in parts])  # type: ignore[union-attr]
    order = np.lexsort((nums, [p.group(1) for p in parts]))  # type: ignore[union-attr]
    out = [files[i] for i in order]
    widths = {len(p.group(2)) for p in parts}  # type: ignore[union-attr]
    prefixes = {p.group(1) for p in parts}  # type: ignore[union-attr]
    if len(out) < 2 or len(widths) != 1 or len(prefixes) != 1:
        return out
    n = nums[order]
    gaps = np.diff(np.r_[n, n[0] + 10 ** widths.pop()])
    start = (int(np.argmax(gaps)) + 1) % len(out)
    return out[start:] + out[:start]


def _prep(path: Path) -> np.ndarray | None:
    import cv2

    g = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if g is None:
        return None
    h, w = g.shape
    g = cv2.resize(g, (256, max(8, round(h * 256 / w))), interpolation=cv2.INTER_AREA)
    g = cv2.GaussianBlur(g.astype(np.float32), (0, 0), 1.0)
    return (g - g.mean()) / (g.std() + 1e-6)


def change_shares(files: list[Path], lag: int = 8, n: int = 24) -> tuple[float, float] | None:
    """``(f1, f_lag)``: the median share of pixels that change between consecutive
    images and between images ``lag`` apart, among the first ``n`` of ``files`` (see
    the module docstring); ``lag`` shrinks to ``len(files) - 2`` for short folders;
    ``None`` with fewer than 6 readable images."""
    imgs = [_prep(f) for f in files[:n]]
    lag = min(lag, len(imgs) - 2)
    if lag < 4 or any(g is None or g.shape != imgs[0].shape for g in imgs):
        return None
    d1 = [np.abs(a - b) for a, b in zip(imgs[:-1], imgs[1:], strict=True)]
    noise = 1.4826 * float(np.median(np.concatenate([d.ravel() for d in d1])))
    thr = max(6.0 * noise, 0.05)
    f1 = float(np.median([np.mean(d > thr) for d in d1]))
    dk = [np.abs(a - b) for a, b in zip(imgs[:-lag], imgs[lag:], strict=True)]
    fk = float(np.median([np.mean(d > thr) for d in dk]))
    return f1, fk


def series_evidence(files: list[Path] | None, min_gap_s: float = 60.0) -> dict[str, Any]:
    """Whether ``files`` are a photo series, why, and their order.

    Returns a dict: ``series`` (bool), ``by`` (``"clocks"``, ``"names"``,
    ``"changes"`` or ``None`` for fewer than two files), ``median_gap_s`` (clocks and
    names), ``change_ratio`` and ``changed_share`` (changes: ``f1 / f8`` and ``f8``),
    and ``files`` (in the order taken: by clock or name time, else by sequence
    number).
    """
    files = list(files or [])
    if len(files) < 2:
        return {"series": False, "by": None, "files": files}
    for by, times in (("clocks", photo_times), ("names", name_times)):
        t = times(files)
        if by == "names" and t is not None and len(np.unique(t)) < max(2, len(t) // 2):
            t = None  # the same "time" in most names (``ant_3d_0001``): not a clock
        if t is not None:
            order = np.argsort(t, kind="stable")
            gap = float(np.median(np.diff(t[order])))
            ordered = [files[i] for i in order]
            return {"series": gap >= min_gap_s, "by": by, "median_gap_s": gap, "files": ordered}
    ordered = sequence_order(files)
    shares = change_shares(ordered)
    rec: dict[str, Any] = {"series": False, "by": "changes", "files": ordered}
    if shares is not None:
        f1, f8 = shares
        ratio = f1 / f8 if f8 > 0 else 0.0
        rec.update(change_ratio=ratio, changed_share=f8)
        rec["series"] = bool(f8 >= MIN_CHANGED and ratio >= MIN_CHANGE_RATIO)
    return rec


def is_photo_series(files: list[Path] | None, min_gap_s: float = 60.0) -> bool:
    """Whether ``files`` are still photos taken a while apart (see the module docstring)."""
    return bool(series_evidence(files, min_gap_s)["series"])


def detect_series(
    files: list[Path],
    *,
    px_per_mm: float | None,
    detector: str | None,
    model: str | os.PathLike | None,
    options: dict[str, Any] | None,
    window: int = SERIES_WINDOW,
) -> tuple[list[Any], dict[str, Any], Any]:
    """Detect the photos ``files`` (in order) window by window.

    Returns the detections per photo, the scale record (as
    :func:`~thermoswarm.tracking.pipeline.common.build_detector`'s) and the last
    window's detector.  A short last window (under half a window) is detected together
    with the window before it.  ``window``: photos per background (0: one background
    from the first 90 photos for all).
    """
    from thermoswarm.tracking.video import VideoSource

    classical = (detector or ("classical" if model is None else "")) == "classical"
    opts = {**SERIES_OPTIONS, **(options or {})} if classical else options
    source = "user"
    if px_per_mm is None:
        first = VideoSource.from_images(files[:90], "series")
        est = estimate_length_px(first.frames(90, step=2), opts if classical else None)
        # With a picture background: what moved, measured in the picture.
        bg = (opts or {}).get("background", "time") if classical else "time"
        px_per_mm = est.length_for(bg) / anatomy.ANT_LENGTH_MM
        source = "measured"
    dets: list[Any] = []
    w = window if window > 0 else len(files)
    det = scale = None
    for k in range(0, len(files), w):
        lo = k if len(files) - k >= w // 2 or not k else max(k - w, 0)
        chunk = files[lo : k + w]
        src = VideoSource.from_images(chunk, "window")
        n_bg = len(chunk) if window > 0 else min(len(chunk), 90)
        det, scale = build_detector(
            src,
            n_bg,
            px_per_mm=px_per_mm,
            detector=detector,
            model=model,
            options=opts,
            step=SERIES_BG_STEP,
            spread=False,  # one background per window of photos, from that window
        )
        dets.extend(det.detect(f) for i, f in enumerate(src.frames()) if i >= k - lo)
    assert scale is not None
    scale = {**scale, "scale_source": source, "series_window": window, "series_options": opts}
    return dets, scale, det


def check_series_options(series: str, window: int) -> None:
    """:class:`~thermoswarm.errors.InputError` unless ``series`` is ``"auto"``,
    ``"yes"`` or ``"no"`` and ``window`` (photos per background) a whole number >= 0."""
    if series not in ("auto", "yes", "no"):
        raise InputError(f"series must be auto, yes or no; got {series!r}")
    if isinstance(window, bool) or not isinstance(window, int) or window < 0:
        raise InputError(f"series_window must be a whole number >= 0, got {window!r}")


def series_source(src: Any, series: str, max_frames: int | None) -> tuple[Any, dict | None]:
    """``(source, evidence)``: for a photo series (recognised, or ``series="yes"``) its
    photos in the order taken (the first ``max_frames``) and :func:`series_evidence`'s
    record; else ``(src, None)`` (a video file, ``series="no"``, or not a series)."""
    from thermoswarm.tracking.video import VideoSource

    if src.files is None or series == "no":
        return src, None
    evidence = series_evidence(src.files)
    if not (series == "yes" or evidence["series"]):
        return src, None
    files = evidence["files"][:max_frames]
    return VideoSource.from_images(files, str(src.path)), evidence


def series_record(evidence: dict, scale: dict, *, forced: bool) -> dict[str, Any]:
    """``photo_series`` of a summary: the window and options (``scale``, as
    :func:`detect_series` returns it) and why (``evidence``; ``forced``: ``series="yes"``)."""
    rec = {"series_window": scale["series_window"], "series_options": scale["series_options"]}
    rec["recognised_by"] = "--series yes" if forced and not evidence["series"] else evidence["by"]
    for k in ("median_gap_s", "change_ratio", "changed_share"):
        if k in evidence:
            rec[k] = evidence[k]
    return rec
