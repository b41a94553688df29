"""Another detector's boxes through the tracker, without video: :func:`track_detection_file`,
what ``thermoswarm track --detections FILE`` runs."""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.errors import InputError
from thermoswarm.fsutil import atomic_write_json, prepare_output_dir
from thermoswarm.tracking.detection import FrameDetections
from thermoswarm.tracking.pipeline.common import _summary, pixel_dataset
from thermoswarm.tracking.pipeline.flood import warn_no_track
from thermoswarm.tracking.track.tracker import Tracker, TrackerConfig, TrackResult


def detections_from_table(table: np.ndarray) -> list[FrameDetections]:
    """Per-frame detections from MOT detection rows, frames 1, 2, ... (box centres as
    body points, head and tail unknown; a negative score counts as 1)."""
    from thermoswarm.tracking.detect.files import DetectionTable

    t = DetectionTable(
        table[:, 0].astype(np.int64),
        table[:, 2:6].astype(np.float64),
        np.clip(np.where(table[:, 6] < 0, 1.0, table[:, 6]), 0, 1),
        "table",
        "mot",
    )
    return t.per_frame(first_frame=1)[1]


def track_detection_file(
    detections: str | os.PathLike,
    out_dir: str | os.PathLike,
    *,
    fps: float,
    px_per_mm: float | None = None,
    tracker_config: TrackerConfig | None = None,
    fmt: str | None = None,
    image_size: tuple[int, int] | None = None,
    first_frame: int | None = None,
    length_px: float | None = None,
) -> dict[str, Any]:
    """Track another detector's boxes (no video); write the outputs; return the summary.

    Parameters
    ----------
    detections
        MOTChallenge file, folder of YOLO per-frame files or COCO JSON
        (:func:`~thermoswarm.tracking.detect.files.read_detections`).
    fps
        Frame rate (frame numbers only in the files).
    px_per_mm
        Image scale: ``tracks.nc`` in mm; without it in px (``space_unit = "px"``).
    fmt, image_size
        Format (default from the path) and ``(width, height)`` px (needed by YOLO).
    first_frame
        Number of the first frame (0 or 1; default: the file's first frame number, so
        that a file numbered from 10,000,000 is not tracked from frame 0); the tracks
        keep the input's numbering.
    length_px
        The objects' length in px, the tracker's unit; default the length the file
        records (``thermoswarm detect``'s COCO), else the median longer box side.
    """
    from thermoswarm.tracking.detect.files import read_detections

    path = Path(detections)
    if fps is None or not (fps > 0 and np.isfinite(fps)):
        raise InputError(f"{path}: detections have frame numbers only; pass --fps")
    if px_per_mm is not None and not (px_per_mm > 0 and np.isfinite(px_per_mm)):
        raise InputError(f"px_per_mm must be a positive number, got {px_per_mm!r}")
    table = read_detections(path, fmt=fmt, image_size=image_size)
    if len(table) == 0:
        raise InputError(f"{path}: no detections")
    first, dets = table.per_frame(first_frame)
    size = length_px if length_px is not None else table.length_px()
    out = prepare_output_dir(out_dir)
    tcfg = tracker_config or TrackerConfig()
    t0 = time.perf_counter()
    tracker = Tracker(tcfg, fps=fps, length_px=size, frame_size=table.image_size)
    for d in dets:
        tracker.predict()
        tracker.update(d)
    result = tracker.finish()
    result.first_frame = first
    elapsed = time.perf_counter() - t0
    return _write_detection_outputs(
        result,
        out,
        path,
        table,
        px_per_mm=px_per_mm,
        fps=fps,
        tracker=tcfg,
        length_px=float(tracker.length_px or 0),
        elapsed=elapsed,
        per_frame=np.array([len(d) for d in dets]),
    )


def _write_detection_outputs(
    result: TrackResult,
    out: Path,
    path: Path,
    table: Any,
    *,
    px_per_mm: float | None,
    fps: float,
    tracker: TrackerConfig,
    length_px: float,
    elapsed: float,
    per_frame: np.ndarray,
) -> dict[str, Any]:
    """Write tracks_mot.txt, tracks.nc and summary.json of :func:`track_detection_file`.

    ``table`` is the detections read from ``path``, ``length_px`` the tracker's unit
    (px), ``elapsed`` the tracking time (s) and ``per_frame`` the detections per frame;
    returns the summary (its ``warnings``: :func:`~.flood.no_track_warning`'s, if any).
    """
    from thermoswarm.io.mot import write_mot_table
    from thermoswarm.io.netcdf import write as write_nc

    first = result.first_frame
    write_mot_table(out / "tracks_mot.txt", result.mot_table())
    attrs = {"detector": f"{table.fmt} detections file", "first_frame": first}
    attrs["body_length_px"] = length_px
    if px_per_mm is None:
        ds = pixel_dataset(result, fps=fps, source=str(path), attrs=attrs)
    else:
        ds = result.dataset(px_per_mm=px_per_mm, fps=fps, source_file=str(path), attrs=attrs)
    write_nc(ds, out / "tracks.nc")
    names = ["tracks.nc", "tracks_mot.txt"]
    summary = _summary(
        result,
        source=str(path),
        fps=fps,
        fps_source="user",
        px_per_mm=px_per_mm,
        tracker=tracker,
        detector=None,
        model=None,
        n_det=len(table),
        elapsed=elapsed,
        prepare=0.0,
        size=table.image_size,
        outputs=names + ["summary.json"],
        detector_options=None,
    )
    summary.update(
        detections_format=table.fmt,
        first_frame=first,
        length_px=length_px,
        space_unit="mm" if px_per_mm is not None else "px",
        warnings=warn_no_track(result.n_tracks, per_frame, fps, tracker, out, video=False),
    )
    atomic_write_json(out / "summary.json", summary)
    return summary
