"""The animals' size measured from a video, without a scale (its own room: the
classical detector's background and blobs, used once per run before any detector is
built).

- :func:`estimate_length_px` -> :class:`SizeEstimate`: the body length from the
  foreground blobs of a few frames (the typical single animal's contrast-weighted
  second moments), and the evidence a caller needs to trust it: ``fill`` (lines are not
  animals), ``clear`` (blobs that stand out of the noise, not compression specks) and
  ``look_px`` (the same blobs in the picture itself: animals that stood nearly still
  are only partly foreground).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from thermoswarm.config import from_mapping
from thermoswarm.errors import ConfigError, InputError, NoBlobsError
from thermoswarm.tracking.detect.blobs import (
    _MAX_DISC,
    _Blobs,
    _weighted_median,
    blob_pixels,
    median_length,
    parts_at,
    spatial_response,
    typical_area,
)
from thermoswarm.tracking.detect.classical import NOTHING_FOUND_HINT, ClassicalDetector
from thermoswarm.tracking.detect.config import ClassicalConfig

__all__ = ["SizeEstimate", "estimate_length_px", "looks_still"]


#: Smallest blob (working px) that counts when the animals' size is unknown.
_MIN_BLOB = 4.0


@dataclass(frozen=True)
class SizeEstimate:
    """The animals' size measured from a video (:func:`estimate_length_px`).

    ``length_px``: body length (px, full resolution); ``n_blobs``: blobs measured;
    ``n_single``: blobs within a factor 2.5 of the typical area (taken as single
    animals); ``threshold``: the relative contrast used; ``fill``: the median share of
    its span squared that a single blob covers (rendered ants 0.26-0.48 from 36 to 7
    px long; a drawn line about 0.04); ``clear``: the blobs' typical peak contrast
    (area-weighted median) over the noise threshold, NaN with a user's ``threshold``
    (real animals 6.6-8.9: beelab's ants, SLEAP's flies; compression specks of a clip
    whose animals stand still, 1.7-2.2); ``look_px``: the same single blobs' median
    length in the picture itself (:func:`_look_length`), 1.07-1.17 times ``length_px``
    where whole animals moved, twice or more where they stood nearly still and only
    their moving parts differ from the background.
    """

    length_px: float
    n_blobs: int
    n_single: int
    threshold: float
    fill: float = math.nan
    clear: float = math.nan
    look_px: float = math.nan

    @property
    def stood_still(self) -> bool:
        """Whether the blobs look more than :data:`STILL_LOOK` times longer in the
        picture than what moved (:func:`looks_still`): the animals stood nearly still
        where the background was learned, and only their moving parts differ from it."""
        return looks_still(self.look_px, self.length_px)

    def length_for(self, background: str) -> float:
        """The body length (px) for a classical detector whose ``background`` is
        ``"time"`` (what moved: ``length_px``) or ``"picture"`` (the same blobs in the
        picture, ``look_px``, where it was measured)."""
        return self.look_px if background == "picture" and self.look_px > 0 else self.length_px


def looks_still(look_px: float | None, moved_px: float | None) -> bool:
    """Whether blobs that moved ``moved_px`` long look more than :data:`STILL_LOOK`
    times longer in the picture (``look_px``); false where either is unknown."""
    return bool(look_px and moved_px and look_px > STILL_LOOK * moved_px)


#: How many times longer than what moved the animals may look in the picture before
#: they count as standing still where the background was learned (whole animals that
#: moved: 1.07-1.17 on SLEAP's flies, beelab's ants, drawn and rendered ants; SLEAP's
#: flies standing nearly still for 6 s, their wings and legs the moving blobs, 2.0-2.6).
STILL_LOOK = 1.5


def estimate_length_px(
    frames: Iterable[np.ndarray], options: Mapping[str, Any] | None = None, source: str = "video"
) -> SizeEstimate:
    """Measure the animals' body length (px) from a video's first frames, without a scale.

    The classical detector's background (the ``bg_quantile`` of the frames) and
    automatic threshold give the foreground blobs of up to 8 frames; the typical
    single animal is the mode of the blob areas, found by trimming to a factor 2.5
    around the median until it settles, starting from the area-weighted median (so
    that specks of texture or noise do not outvote a few animals, and clumps of
    touching animals or clutter fall outside).  The body length is the median of those
    blobs' lengths from their contrast-weighted second moments (:func:`~.blobs.axis_lengths`).
    Animals small enough for a finer working resolution (unless ``downsample`` is
    given; :meth:`~.config.ClassicalConfig.for_animals`) are measured again at it,
    unless that finds under 3/4 of the length: ants split at the waist there, as
    separate halves (most of the ants split), and the coarser measurement stands.

    Parameters
    ----------
    frames
        Frames (RGB or grey uint8) spanning a few seconds, in time order.
    options
        Classical detector options (:class:`ClassicalConfig`: ``polarity``,
        ``channel``, ``threshold``, ...).
    source
        Name of the video, for error messages.

    Raises
    ------
    InputError
        When fewer than 3 blobs are found (no moving animals, too little contrast).
    """
    # Always against the background learned over time: what moves is the measurement,
    # the picture only its look (a picture background at this unknown scale would
    # take every speck of the floor for an animal).
    opts = {k: v for k, v in (options or {}).items() if k != "background"}
    try:
        cfg = from_mapping(ClassicalConfig, opts, source="detector options")
    except ConfigError as exc:
        raise InputError(str(exc)) from None
    det = ClassicalDetector(1.0, cfg)  # the scale is unused: background and blobs only
    grays = det._background(frames)
    est = _size(det, grays, source)
    fine = cfg.for_animals(est.length_px / cfg.ant_length_mm)
    if fine.downsample < cfg.downsample and "downsample" not in opts:
        det = ClassicalDetector(1.0, fine)
        det._background(grays)
        again = _size(det, grays, source)
        est = again if again.length_px > 0.75 * est.length_px else est
    return est


def _size(det: ClassicalDetector, grays: list[np.ndarray], source: str) -> SizeEstimate:
    """:func:`estimate_length_px` on the full frames ``grays``, background learned."""
    cfg = det.config
    smalls = [det._small(g) for g in grays]
    gm = [(g, det._contrast_map(s)) for g, s in zip(grays, smalls, strict=True)]
    thr = det._noise_threshold(smalls)

    def blobs(t: float) -> list[_Blobs]:
        return [det._measure(g, *m, t, _MIN_BLOB, split=False) for g, m in gm]

    clear = math.nan
    if cfg.threshold is not None:
        thr = cfg.threshold
    else:
        first = blobs(thr)
        peaks = np.concatenate([b.peak for b in first])
        if peaks.size >= 3:
            w = np.concatenate([b.area for b in first])
            peak = _weighted_median(peaks, w)
            clear = peak / thr if thr > 0 else math.inf  # thr: the noise threshold still
            thr = max(thr, cfg.peak_fraction * peak)
    found = blobs(thr)
    area = np.concatenate([b.area for b in found])
    span = np.concatenate([b.span for b in found])
    if area.size < 3:
        raise NoBlobsError(
            f"{source}: cannot measure the animals' size: {area.size} moving blob(s) in "
            f"the first {len(grays)} sampled frames; {NOTHING_FOUND_HINT}"
        )
    ref = typical_area(area)
    sel = (area > ref / 2.5) & (area < ref * 2.5)
    # The same blobs again, weighted by their contrast alone (peak_fraction 0).
    px = (blob_pixels(g, *m, thr, _MIN_BLOB, cfg.downsample, det._offsets, 0.0, det._contrast)
          for g, m in gm)  # fmt: skip
    length = median_length(px, (ref / 2.5, ref * 2.5))
    fill = float(np.median(area[sel] * cfg.downsample**2 / np.maximum(span[sel], 1.0) ** 2))
    singles = [b.points[(b.area > ref / 2.5) & (b.area < ref * 2.5), 1] for b in found]
    look = _look_length(smalls, singles, length, cfg)
    return SizeEstimate(
        length, int(area.size), int(sel.sum()), float(thr), fill, float(clear), look
    )


#: Grey levels by which blobs must stand out of their spatial background (median at
#: their centres) to be measured in the picture (:func:`_look_length`): below it the
#: mask at half their response is the floor's texture.
_LOOK_MIN_GREY = 4.0


def _look_length(
    smalls: list[np.ndarray], centres: list[np.ndarray], length: float, cfg: ClassicalConfig
) -> float:
    """The median length (px, full resolution) in the picture itself of the blobs whose
    body centres (full-resolution px) are ``centres`` in the working-resolution frames
    ``smalls``: against a spatial background (a grey opening for light animals, a
    closing for dark ones, over a disc of 3 ``length``), which holds no animal whether
    it moves or not, the connected pixels above half the centres' median response that
    hold each centre (:func:`~.blobs.spatial_response`, :func:`~.blobs.parts_at`), 4
    standard deviations along their major axis.  Hand-written: no library measures a
    blob's length in a picture from a point inside it.

    NaN when no centre is found, or none stands out of the picture by
    :data:`_LOOK_MIN_GREY`.  Measured (the ratio to the length from the background):
    SLEAP's flies walking, beelab's ants, drawn and rendered ants, 1.07-1.17; SLEAP's
    flies standing nearly still for 6 s (their moving wings and legs were the blobs:
    32.5 px against 70 px), 2.0-2.6."""
    import cv2

    if not (math.isfinite(length) and length > 0):
        return math.nan
    # At most a _MAX_DISC-px disc: the frames shrunk further for large animals (the
    # cost of a grey opening grows with the disc).  ``f``: full-resolution px per px
    # measured.
    f = cfg.downsample * max(1.0, 3 * length / cfg.downsample / _MAX_DISC)
    shrink = cfg.downsample / f
    lengths = []
    for small, c in zip(smalls, centres, strict=True):
        if not len(c):
            continue
        if shrink < 1:
            small = cv2.resize(small, None, fx=shrink, fy=shrink, interpolation=cv2.INTER_AREA)
        resp = spatial_response(small.astype(np.float32), 3 * length / f, cfg.polarity == "light")
        at = np.clip((c / f).astype(int), 0, np.array(resp.shape[::-1]) - 1)
        if np.median(resp[at[:, 1], at[:, 0]]) < _LOOK_MIN_GREY:  # not seen in the picture
            continue
        n, lab = parts_at(resp, at)[:2]
        held = np.zeros(n, bool)
        held[lab[at[:, 1], at[:, 0]]] = True
        held[0] = False
        lengths += list(4.0 * f * np.sqrt(_top_variance(lab, held)))
    return float(np.median(lengths)) if lengths else math.nan


def _top_variance(lab: np.ndarray, held: np.ndarray) -> np.ndarray:
    """The variance along the major axis (px^2; sample covariance) of each part of the
    label image ``lab`` whose ``held[label]`` is true and that has 5 pixels or more,
    all parts at once (one pass over the image, not one per part)."""
    ys, xs = np.nonzero(held[lab])
    lab = lab[ys, xs]
    m = held.size
    cnt = np.bincount(lab, minlength=m).astype(float)
    ok = cnt >= 5
    if not ok.any():
        return np.zeros(0)
    x, y = xs.astype(float), ys.astype(float)
    mx = np.bincount(lab, x, m)[ok] / cnt[ok]
    my = np.bincount(lab, y, m)[ok] / cnt[ok]
    c = cnt[ok]
    sxx = (np.bincount(lab, x * x, m)[ok] - c * mx * mx) / (c - 1)
    syy = (np.bincount(lab, y * y, m)[ok] - c * my * my) / (c - 1)
    sxy = (np.bincount(lab, x * y, m)[ok] - c * mx * my) / (c - 1)
    half = (sxx + syy) / 2
    return half + np.sqrt(np.maximum(((sxx - syy) / 2) ** 2 + sxy * sxy, 0.0))
