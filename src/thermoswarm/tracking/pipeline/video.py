"""A video through a detector and the tracker: :func:`track_video`, what ``thermoswarm
track VIDEO`` runs (see the package's docstring for the stages)."""

from __future__ import annotations

import dataclasses
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.errors import InputError
from thermoswarm.fsutil import atomic_write_text, prepare_output_dir
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.detect.register import (
    RegisteredSource,
    camera_summary,
    register_source,
)
from thermoswarm.tracking.pipeline.common import _prep_frames, build_detector, first_cut
from thermoswarm.tracking.pipeline.self_train import SELF_TRAINED, track_self_trained
from thermoswarm.tracking.pipeline.series import (
    SERIES_WINDOW,
    check_series_options,
    is_photo_series,
    series_source,
)
from thermoswarm.tracking.pipeline.series_track import track_series
from thermoswarm.tracking.pipeline.stages import (
    detect_and_associate,
    frame_stream,
    write_video_outputs,
)
from thermoswarm.tracking.track.tracker import Tracker, TrackerConfig, TrackResult
from thermoswarm.tracking.video import open_video


def _check_video_args(
    src: Any, fps: float | None, max_frames: int | None, overlay: bool, scale: float
) -> float | None:
    """The frame rate to use (``None``: unknown); :class:`InputError` for a bad rate,
    frame count or scale."""
    rate = fps if fps is not None else src.fps
    if rate is not None and not (rate > 0 and np.isfinite(rate)):
        raise InputError(f"fps must be a positive number, got {rate!r}")
    if max_frames is not None and max_frames < 1:
        raise InputError(f"max_frames must be a positive integer, got {max_frames!r}")
    if overlay and not (0 < scale <= 1):
        raise InputError(f"overlay scale must be in (0, 1], got {scale!r}")
    return rate


def _register(
    src: Any, camera: str, max_frames: int | None, prepare_s: float, rate: float
) -> tuple[Any, Any, int, tuple[set[int], int]]:
    """The source (registered when the camera moves), its path, the frames the detector
    is prepared on (the first scene's only), and the scene cuts with that count."""
    src, path = register_source(src, camera, max_frames=max_frames)
    n_prep = _prep_frames(prepare_s, rate, max_frames)
    cuts = set(path.cuts) if path is not None else set()
    if cuts:
        n_prep = min(n_prep, min(cuts))
    return src, path, n_prep, (cuts, n_prep)


def _to_first_frame(src: Any, result: TrackResult, dets: np.ndarray, out: Path) -> TrackResult:
    """For a registered source: tracks and detection rows (in place) moved from the
    canvas's px to the first frame's, and ``camera_path.csv`` written."""
    if not isinstance(src, RegisteredSource):
        return result
    off = np.asarray(src.camera.offset)
    pts = result.points - off
    boxes = result.boxes - np.array([*off, 0.0, 0.0])
    dets[:, 2:4] -= off
    atomic_write_text(out / "camera_path.csv", src.camera.table())
    return dataclasses.replace(result, points=pts, boxes=boxes)


def track_video(
    video: str | os.PathLike,
    out_dir: str | os.PathLike,
    *,
    px_per_mm: float | None = None,
    fps: float | None = None,
    detector: str | None = None,
    model: str | os.PathLike | None = None,
    detector_options: dict[str, Any] | None = None,
    tracker_config: TrackerConfig | None = None,
    overlay: bool = True,
    overlay_scale: float = 1.0,
    max_frames: int | None = None,
    prepare_s: float = 3.0,
    progress: bool = False,
    hints: bool = True,
    camera: str = "auto",
    series: str = "auto",
    series_window: int = SERIES_WINDOW,
    length_px: float | None = None,
) -> dict[str, Any]:
    """Track the ants of a video; write the outputs; return the summary.  The stages:
    read frames (:func:`frame_stream`), detect and associate (:func:`detect_and_associate`),
    smooth and gap-fill (the tracker's ``finish``), write (:func:`write_video_outputs`).

    Parameters
    ----------
    video
        Video file or folder of frames.
    out_dir
        Output folder (created with its parents).
    px_per_mm, length_px
        Image scale (px per mm); ``None``: the animals' body length is ``length_px``, or
        measured from the video (:func:`~.detect.size.estimate_length_px`), and
        ``tracks.nc`` is written in px (``space_unit = "px"``).
    fps
        Frame rate (frames/s); default the video's own (required for folders of frames).
    detector, model, detector_options
        See :func:`.detect.classical.make_detector` (default: classical; ``"self-trained"``:
        :func:`.self_train.track_self_trained`, a U-Net trained on the video first).
    tracker_config, overlay, overlay_scale
        :class:`~thermoswarm.tracking.track.tracker.TrackerConfig`; write
        ``overlay.mp4`` at this fraction of the video's size (1: full size).
    max_frames, prepare_s
        Stop after this many frames; seconds of video shown to the detector's ``prepare``.
    progress, hints
        Show a progress bar (tqdm); give the tracker's predicted poses to detectors
        that take them (``False``: track exactly what ``thermoswarm detect`` writes).
    camera
        ``"auto"``, ``"moving"`` or ``"still"`` (:mod:`~.detect.register`): registered
        tracks are in the first frame's px (``camera_path.csv``); cuts end every track.
    series, series_window
        As for :func:`.detect_inputs`; a photo series is tracked by
        :func:`.series_track.track_series` (unless ``camera="moving"``).

    Raises
    ------
    InputError
        Bad input, nothing detected (nothing written), a camera that cannot be
        followed, or detections that are not animals (:mod:`~.flood`).
    """
    if detector == SELF_TRAINED:  # two passes, each with this call's arguments (locals())
        args = {k: v for k, v in locals().items() if k not in ("video", "out_dir", "length_px")}
        return track_self_trained(video, out_dir, track_video, **args)
    src = open_video(video)
    rate = _check_video_args(src, fps, max_frames, overlay, overlay_scale)
    photos, evidence, camera = _series_of(src, series, series_window, max_frames, camera)
    opts = dict(
        px_per_mm=px_per_mm, detector=detector, model=model, detector_options=detector_options,
        tracker_config=tracker_config, overlay=overlay, overlay_scale=overlay_scale,
        progress=progress,
    )  # fmt: skip
    if evidence is not None:
        return track_series(video, photos, evidence, out_dir, forced=series == "yes", fps=fps,
                            series_window=series_window, **opts)  # fmt: skip
    if rate is None:
        raise InputError(f"{video}: the frame rate is unknown (a folder of frames?); pass --fps")
    return _track_frames(video, src, out_dir, rate, "user" if fps is not None else "video",
                         max_frames=max_frames, prepare_s=prepare_s, hints=hints, camera=camera,
                         length_px=length_px, **opts)  # fmt: skip


def _series_of(
    src: Any, series: str, window: int, max_frames: int | None, camera: str
) -> tuple[Any, dict | None, str]:
    """``(photos, evidence, camera)``: a photo series' photos in the order taken and
    :func:`~.series.series_evidence`'s record (``None``: not a series, or a camera
    to register), and the camera, ``"still"`` in place of ``"auto"`` for a series taken
    as frames (``series="no"``): photos a while apart never register to each other."""
    check_series_options(series, window)
    if camera == "moving":
        return src, None, camera
    photos, evidence = series_source(src, series, max_frames)
    if series == "no" and camera == "auto" and is_photo_series(src.files):
        camera = "still"
    return photos, evidence, camera


def _track_frames(
    video: str | os.PathLike,
    src: Any,
    out_dir: str | os.PathLike,
    rate: float,
    fps_source: str,
    *,
    px_per_mm: float | None,
    detector: str | None,
    model: str | os.PathLike | None,
    detector_options: dict[str, Any] | None,
    tracker_config: TrackerConfig | None,
    overlay: bool,
    overlay_scale: float,
    max_frames: int | None,
    prepare_s: float,
    progress: bool,
    hints: bool,
    camera: str,
    length_px: float | None,
) -> dict[str, Any]:
    """:func:`track_video` on a video or frames (not a photo series) at ``rate``
    frames/s (``fps_source``: ``"user"`` or ``"video"``)."""
    from thermoswarm.tracking.video import OverlayWriter

    t0 = time.perf_counter()
    src, path, n_prep, cuts = _register(src, camera, max_frames, prepare_s, rate)
    # A body length known without a scale (a classical pass's) sets the detector's scale;
    # the outputs stay in px.
    known = None if length_px is None else length_px / anatomy.ANT_LENGTH_MM
    det, scale = build_detector(
        src, n_prep, px_per_mm=px_per_mm or known, detector=detector, model=model,
        options=detector_options, max_frames=max_frames, scene_end=first_cut(path))  # fmt: skip
    if px_per_mm is None and known is not None:
        scale["scale_source"] = "measured"
    out = prepare_output_dir(out_dir)  # only once the detector is built
    tcfg = tracker_config or TrackerConfig()
    tracker = Tracker(tcfg, px_per_mm=scale["px_per_mm"], fps=rate, frame_size=src.size)
    t_prep = time.perf_counter() - t0
    takes_hints = hints and bool(getattr(det, "accepts_hints", False))
    writer = OverlayWriter(out / "overlay.mp4", rate, scale=overlay_scale) if overlay else None
    frames = frame_stream(src, max_frames, progress)
    seen: list[int] = []
    n_det, dets = detect_and_associate(
        video, frames, det, tracker, writer, takes_hints, cuts, seen)  # fmt: skip
    result = _to_first_frame(src, tracker.finish(), dets, out)
    elapsed = time.perf_counter() - t0
    run = dict(video=video, src=src, det=det, scale=scale, dets=dets, n_det=n_det, rate=rate)
    # the path's cuts and those seen in the detections alone (stages.DetectionCuts)
    run["camera"] = camera_summary(path, isinstance(src, RegisteredSource), seen)
    return write_video_outputs(
        result, out, run, px_per_mm=px_per_mm, fps_source=fps_source,
        tracker=tcfg, detector=detector, model=model, detector_options=detector_options,
        timing=(elapsed, t_prep), overlay=writer is not None,
    )  # fmt: skip
