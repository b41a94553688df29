"""Named tracker settings, and where each was tuned.

- ``ants`` (the defaults of :class:`~thermoswarm.tracking.track.config.TrackerConfig`):
  tuned on real ant boxes, the tuning half (frames 3558-9860) of AntTracking's
  ``output_4`` colony video with its three YOLO detection sets, at 15, 7.5 and 5
  frames per second, the detections' frames aligned to the ground truth's
  (``benchmarks/bench_ant_boxes.py``; the second half is held out),
  and checked on ant motion from anTraX's JS16 trajectories at 10 and 5 fps and on the
  synthetic 1080p video (docs/tracking.md, "Real ant boxes").
- ``pedestrians``: the values tuned on the MOT15 pedestrian sequences with SORT's
  Faster R-CNN boxes (issue 26, docs/tracking.md "Real detector boxes"): 4 detections
  without a miss to confirm, 0.5 s coasting, ``min_iou`` 0.3 on a detector's own boxes,
  duplicates judged by box overlap (0.3 of the smaller box), slow process noise, the
  detections' boxes written as detected (no smoothing, every box written: a
  pedestrian's box grows as they walk toward the camera).  Those
  were tuned in frames (4 detections, no miss); here they are seconds at 15 fps (the
  tuning sequences' rates were 7-30 fps, median 14), so at other frame rates the frame
  counts differ from the ones tuned.
"""

from __future__ import annotations

from dataclasses import fields, replace
from typing import Any

from thermoswarm.errors import ConfigError
from thermoswarm.tracking.track.config import TrackerConfig

__all__ = ["PRESETS", "preset"]

#: Fields that differ from the defaults (the ``ants`` preset), per preset.
PRESETS: dict[str, dict[str, Any]] = {
    "ants": {},
    "pedestrians": dict(
        confirm_s=0.2,
        tentative_gap_s=0.0,
        max_gap_s=0.5,
        accel_bl_s2=8.0,
        birth_speed_bl_s=14.0 / 3,
        adapt_range=25.0,
        iou_weight=1.0,
        distance_weight=1.0,
        mahalanobis_weight=0.0,
        max_cost=2.0,
        min_iou=0.3,
        relink_gate=True,
        min_score=0.0,
        duplicate_radius=0.0,
        duplicate_body=0.0,
        duplicate_overlap=0.3,
        smooth=False,
        size_band=0.0,
    ),
}


def preset(name: str, **overrides: Any) -> TrackerConfig:
    """The :class:`TrackerConfig` of preset ``name``, with ``overrides`` (fields)."""
    if name not in PRESETS:
        raise ConfigError(
            f"unknown tracker preset {name!r}; expected one of: {', '.join(PRESETS)}"
        )
    known = {f.name for f in fields(TrackerConfig)}
    for key in overrides:
        if key not in known:
            raise ConfigError(f"unknown tracker option {key!r}")
    return replace(TrackerConfig(), **{**PRESETS[name], **overrides})
