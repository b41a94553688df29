"""The classical detector's options (:class:`ClassicalConfig`), checked on construction."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Literal

from thermoswarm.config import check
from thermoswarm.tracking import anatomy

__all__ = ["ClassicalConfig"]


@dataclass(frozen=True)
class ClassicalConfig:
    """Options of the classical detector.

    Contrast is *relative*: ``(background - frame) / background`` for dark ants (so a
    shadow or a dimmer frame does not change it), ``(frame - background) / (255 -
    background)`` for light ones (flies on a dark floor), in [0, 1].

    ``ant_length_mm``/``ant_width_mm``: expected ant size (the paper's 7.14 x 2.5 mm),
    a prior that the measured ants refine.  ``polarity``: ``"dark"`` ants on a lighter
    background (the paper's road) or ``"light"``.  ``channel``: the image channel used
    (``"green"`` by default: red-brown and black ants on yellow wood differ most in
    green; ``"gray"`` is the luma).  ``downsample``: integer factor of the working
    resolution of the foreground mask (blobs are measured at full resolution; when the
    option is not given, :func:`make_detector` lowers it so that the animals stay at
    least 2 px wide).
    ``threshold``: relative contrast of foreground pixels (``None``: automatic, the
    largest of ``min_threshold``, ``threshold_sigmas`` robust standard deviations of
    the background noise and ``peak_fraction`` times the typical ant's peak contrast).
    ``peak_fraction`` also sets, per blob, which pixels are measured (thin legs and
    antennae fall below it).  ``min_area``/``split_area``: blob areas in
    single-ant areas below which blobs are dropped and above which they are split
    (``hint_split_area`` when the tracker predicts two or more ants in the blob);
    ``max_split``: most ants in one blob.  ``bg_quantile``: per-pixel quantile of the
    prepared frames taken as the background (0.9 for dark ants: a pixel is background
    unless an ant covers it in over 90 % of those frames; ``1 - bg_quantile`` for light
    ants); ``bg_frames``: most frames used for it; ``bg_rate``: running-average rate per
    frame of the background where no ant is.  ``gain_grid``: cell size (px, working
    resolution) of the lighting correction, 0 for one global gain.  ``shift_px``: how
    far (px, working resolution) the background may have moved under the camera; a
    pixel is compared with the background's extreme within that distance, so that
    jitter between photos or video frames does not turn its edges into blobs.
    ``join_split``: join two blobs that are the two ends of one body split at its
    waist into one detection (:mod:`~.join`).
    ``background``: what each frame is compared with: ``"time"``, the background
    learned over the prepared frames (what moves); ``"picture"``, the frame's own
    spatial background, a grey closing (dark animals) or opening (light ones) over a
    disc of 3 body lengths, which holds no animal whether it moves or not, nor
    anything else narrower than that disc that stands out of its surroundings
    (specks, thin lines, small objects are found with the animals; wide areas and
    the steps between them are background).  The pipeline chooses ``"picture"`` itself where
    the animals stood nearly still while the background was learned
    (:attr:`~.size.SizeEstimate.stood_still`).
    """

    ant_length_mm: float = anatomy.ANT_LENGTH_MM
    ant_width_mm: float = anatomy.ANT_WIDTH_MM
    polarity: Literal["dark", "light"] = "dark"
    channel: Literal["gray", "red", "green", "blue"] = "green"
    downsample: int = 2
    threshold: float | None = None
    min_threshold: float = 0.1
    threshold_sigmas: float = 6.0
    peak_fraction: float = 0.3
    min_area: float = 0.3
    split_area: float = 1.6
    hint_split_area: float = 1.2
    max_split: int = 6
    bg_quantile: float = 0.9
    bg_frames: int = 32
    bg_rate: float = 0.02
    gain_grid: int = 24
    shift_px: int = 0
    join_split: bool = True
    background: Literal["time", "picture"] = "time"

    def __post_init__(self) -> None:
        for name in ("ant_length_mm", "ant_width_mm", "threshold_sigmas", "split_area"):
            v = getattr(self, name)
            check(math.isfinite(v) and v > 0, name, "a positive number", v)
        check(1 <= self.downsample <= 8, "downsample", "an integer in [1, 8]", self.downsample)
        check(
            self.threshold is None or 0 < self.threshold < 1,
            "threshold",
            "a relative contrast in (0, 1)",
            self.threshold,
        )
        check(0 <= self.min_threshold < 1, "min_threshold", "in [0, 1)", self.min_threshold)
        check(0 <= self.peak_fraction < 1, "peak_fraction", "in [0, 1)", self.peak_fraction)
        check(0 < self.min_area < self.split_area, "min_area", "in (0, split_area)", self.min_area)
        check(self.max_split >= 1, "max_split", "a positive integer", self.max_split)
        check(
            0 < self.hint_split_area <= self.split_area,
            "hint_split_area",
            "in (0, split_area]",
            self.hint_split_area,
        )
        check(0.5 <= self.bg_quantile <= 1, "bg_quantile", "in [0.5, 1]", self.bg_quantile)
        check(self.bg_frames >= 1, "bg_frames", "a positive integer", self.bg_frames)
        check(0 <= self.bg_rate <= 1, "bg_rate", "in [0, 1]", self.bg_rate)
        check(self.gain_grid >= 0, "gain_grid", "a non-negative integer", self.gain_grid)
        check(0 <= self.shift_px <= 4, "shift_px", "an integer in [0, 4]", self.shift_px)

    def for_animals(self, px_per_mm: float) -> ClassicalConfig:
        """This configuration with ``downsample`` lowered until animals of
        ``ant_width_mm`` at ``px_per_mm`` are at least 2 px wide at the working
        resolution: tiny animals (small ants in a phone or field video, 2-3 px wide)
        at 1 px have blob areas that jump by half from frame to frame, and single ants
        are split."""
        f = self.downsample
        while f > 1 and self.ant_width_mm * px_per_mm / f < 2.0:
            f -= 1
        return dataclasses.replace(self, downsample=f)
