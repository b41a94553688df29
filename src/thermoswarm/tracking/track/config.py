"""The tracker's options (:class:`TrackerConfig`) and their conversion to frames.

Every length is in body lengths ``L`` (the tracked objects' length in px), every
duration in seconds; :func:`frames` turns a duration into frames at the video's
frame rate, never rounding a positive duration to 0 frames.  The defaults are the
``ants`` preset (:mod:`~thermoswarm.tracking.track.presets` says where each preset
was tuned).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from thermoswarm.config import check
from thermoswarm.errors import ConfigError
from thermoswarm.tracking import anatomy

__all__ = ["TrackerConfig", "frames"]


def frames(seconds: float, fps: float) -> int:
    """Frames in ``seconds`` at ``fps``: ``round(seconds * fps)``, at least 1 for any
    positive duration (0 only for 0 s)."""
    if seconds <= 0:
        return 0
    return max(1, int(round(seconds * fps)))


def _bounded(seconds: float, fps: float, key: str) -> int:
    """:func:`frames`, at most 1000: the frames the track bank holds per tentative track
    (checked before it allocates them; ConfigError naming ``key`` otherwise)."""
    n = frames(seconds, fps)
    if n > 1000:
        raise ConfigError(
            f"tracker.{key} = {seconds:g} s is {n} frames at {fps:g} frames/s; at most 1000"
        )
    return n


@dataclass(frozen=True)
class TrackerConfig:
    """Tracker options, in units of the objects' own size and of time.

    Lengths are in body lengths ``L`` (the tracked objects' length in px, given to the
    :class:`~thermoswarm.tracking.track.tracker.Tracker` or estimated from the
    detections), times in seconds (converted with ``fps`` by :func:`frames`: a
    positive time is at least one frame); nothing depends on the mm scale of the
    image.  See :mod:`~thermoswarm.tracking.track.tracker` for the role of each weight
    and limit.

    Time: ``confirm_s``: a new track is confirmed once it has been detected in the
    frames spanning this time (``1 + frames(confirm_s)`` detections; 0: at once);
    ``tentative_gap_s``: the longest gap in a new track's detections before it is
    confirmed; ``max_gap_s``: how long a confirmed track coasts without detections
    (and the longest gap re-linked and interpolated).

    Motion: ``max_speed_bl_s`` the objects' top speed (gates and jump removal);
    ``accel_bl_s2``: initial sd of the objects' acceleration (sets the Kalman process
    noise, which then adapts within ``[q/adapt_range, q*adapt_range]``);
    ``birth_speed_bl_s``: sd of a new track's unknown velocity (its first match is
    gated by it: ``gate_sigmas`` of it must cover a walking ant's step);
    ``meas_noise_bl``: sd of detected body points, divided by ``score **
    score_noise_power`` for a detection of score below 1.

    Association: pair cost ``iou_weight (1 - IoU) + distance_weight d / L +
    mahalanobis_weight m / gate_sigmas + angle_weight |sin da| [+ hint_weight]``
    (``m`` the Mahalanobis distance of the innovation: the distance in units of the
    track's predicted uncertainty); pairs beyond ``gate_sigmas`` or the reach of
    ``max_speed_bl_s`` are never matched, nor pairs costing more than ``max_cost``,
    nor a detector's own boxes overlapping the predicted box less than ``min_iou``.

    Births: no birth from a detection whose body point is within ``duplicate_radius``
    body lengths of a matched or better-scored one, or (posed detections) within
    ``duplicate_body`` of that one's oriented body: inside the ellipse of semi-axes
    ``duplicate_body`` body lengths along its head-tail axis and ``duplicate_body``
    body widths across it (0: off; 0.7: bodies that overlap by about a third or more,
    as the pieces of one ant cut in two by a detector's split do; two ants side by
    side 0.5 body lengths apart or end to end are outside it), or (when
    ``duplicate_overlap`` is below 1) whose box intersection covers that share of the
    smaller box; none below ``min_score``.  ``width_bl``: object width, half of which
    pads body-centred pose boxes.

    Output: ``smooth`` smooths each finished track's box centres
    (:mod:`~thermoswarm.tracking.track.smooth`: a fixed-interval Kalman smoother whose
    noises are measured on the tracks); false writes the detections' boxes.  A
    detector's own boxes are smoothed only with ``smooth_given`` as well (off: on real
    YOLO ant boxes it lowered HOTA and left MOTA unchanged, docs/tracking.md); boxes
    built from body points are.  The body points are never smoothed.
    ``smooth_weight``: the weight, in second differences, of the colony's acceleration
    in each track's own (a very large one gives every track the colony's).
    ``size_band``: a detector's own boxes are written only where their longer side is
    within this factor of their track's median longer side (0: all written).  A box
    much shorter or longer than its ant's usual one is a partial or merged view (an ant
    at the frame's edge or half in a hole, two ants end to end in one box): the track
    keeps its identity across it, the box is not written.  Pose boxes (built from the
    body points) are always written.
    """

    confirm_s: float = 0.1
    tentative_gap_s: float = 0.0
    max_gap_s: float = 0.5
    max_speed_bl_s: float = 14.0
    accel_bl_s2: float = 28.0
    birth_speed_bl_s: float = 14.0 / 3
    adapt: bool = True
    adapt_range: float = 5.0
    meas_noise_bl: float = 0.04605  # 1 px at the paper's 3.04 px/mm
    score_noise_power: float = 4.0
    gate_sigmas: float = 5.0
    iou_weight: float = 1.0
    distance_weight: float = 0.0
    mahalanobis_weight: float = 1.0
    angle_weight: float = 0.3
    hint_weight: float = 1.0
    max_cost: float = 1.7
    min_iou: float = 0.0
    relink_gate: bool = True
    own_size: bool = False
    coast_last: bool = False
    min_score: float = 0.5
    duplicate_radius: float = 0.3
    duplicate_body: float = 0.7
    duplicate_overlap: float = 1.0
    interpolate: bool = True
    fix_jumps: bool = True
    head_motion_speed_bl_s: float = 0.42
    continuity_weight: float = 1.0
    motion_weight: float = 1.5
    shape_weight: float = 1.0
    width_bl: float = anatomy.ANT_WIDTH_MM / anatomy.ANT_LENGTH_MM
    smooth: bool = True
    smooth_given: bool = False
    smooth_weight: float = 10.0
    size_band: float = 1.5

    def __post_init__(self) -> None:
        for name in (
            "confirm_s",
            "tentative_gap_s",
            "max_gap_s",
            "duplicate_radius",
            "duplicate_body",
        ):
            v = getattr(self, name)
            check(math.isfinite(v) and v >= 0, name, "a non-negative number (s or L)", v)
        # the track bank keeps the confirming detections of each tentative track and a
        # lag of frames: bounded here, and in frames by the Tracker, before allocation
        for name, most in (("confirm_s", 60.0), ("tentative_gap_s", 60.0), ("max_gap_s", 3600.0)):
            v = getattr(self, name)
            check(v <= most, name, f"at most {most:g} (s)", v)
        for name in (
            "max_speed_bl_s",
            "accel_bl_s2",
            "birth_speed_bl_s",
            "meas_noise_bl",
            "gate_sigmas",
            "max_cost",
            "head_motion_speed_bl_s",
            "width_bl",
        ):
            v = getattr(self, name)
            check(math.isfinite(v) and v > 0, name, "a positive number", v)
        check(self.adapt_range >= 1, "adapt_range", "at least 1", self.adapt_range)
        check(
            math.isfinite(self.smooth_weight) and self.smooth_weight >= 0,
            "smooth_weight",
            "a non-negative number (second differences)",
            self.smooth_weight,
        )
        for name in (
            "iou_weight",
            "distance_weight",
            "mahalanobis_weight",
            "angle_weight",
            "hint_weight",
            "continuity_weight",
            "motion_weight",
            "shape_weight",
        ):
            v = getattr(self, name)
            check(math.isfinite(v) and v >= 0, name, "a non-negative number", v)
        v = self.size_band
        ok = v == 0 or (math.isfinite(v) and v > 1)
        check(ok, "size_band", "0 (off) or a factor above 1", v)
        check(0 <= self.min_score <= 1, "min_score", "in [0, 1]", self.min_score)
        check(0 <= self.min_iou < 1, "min_iou", "in [0, 1)", self.min_iou)
        v = self.duplicate_overlap
        check(v > 0 and not math.isnan(v), "duplicate_overlap", "a positive number (>= 1: off)", v)

    def n_init(self, fps: float) -> int:
        """Detections that confirm a new track at ``fps``."""
        return 1 + _bounded(self.confirm_s, fps, "confirm_s")

    def tentative_max_misses(self, fps: float) -> int:
        """Frames a new track may miss before it is confirmed, at ``fps``."""
        return _bounded(self.tentative_gap_s, fps, "tentative_gap_s")

    def max_gap(self, fps: float) -> int:
        """Frames a confirmed track coasts without detections, at ``fps``."""
        return frames(self.max_gap_s, fps)
