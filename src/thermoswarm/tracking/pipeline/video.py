"""A video through a detector and the tracker: :func:`track_video`, what ``thermoswarm
track VIDEO`` runs (see the package's docstring for the stages)."""

from __future__ import annotations

import collections
import dataclasses
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.errors import InputError
from thermoswarm.fsutil import atomic_write_json, atomic_write_text, prepare_output_dir
from thermoswarm.tracking.detect.classical import NOTHING_FOUND_HINT, FrameDetections
from thermoswarm.tracking.detect.register import (
    RegisteredSource,
    camera_summary,
    register_source,
)
from thermoswarm.tracking.pipeline.common import (
    _detector_info,
    _prep_frames,
    _summary,
    build_detector,
    pixel_dataset,
)
from thermoswarm.tracking.pipeline.flood import (
    add_warning,
    flood_reasons,
    photo_series_note,
    refuse_flood,
    warn_no_track,
)
from thermoswarm.tracking.track.tracker import Tracker, TrackerConfig, TrackResult


def _write_outputs(
    result: TrackResult,
    out: Path,
    *,
    px_per_mm: float | None,
    fps: float,
    source: str,
    det_rows: np.ndarray | None,
    attrs: dict[str, Any],
) -> list[str]:
    from thermoswarm.io.mot import write_mot_table
    from thermoswarm.io.netcdf import write as write_nc

    if px_per_mm is None:
        ds = pixel_dataset(result, fps=fps, source=source, attrs=attrs)
    else:
        ds = result.dataset(px_per_mm=px_per_mm, fps=fps, source_file=source, attrs=attrs)
    write_nc(ds, out / "tracks.nc")
    write_mot_table(out / "tracks_mot.txt", result.mot_table())
    names = ["tracks.nc", "tracks_mot.txt"]
    if det_rows is not None:
        write_mot_table(out / "detections.txt", det_rows)
        names.append("detections.txt")
    return names


def _det_rows(frame: int, d: FrameDetections, pad: float) -> np.ndarray:
    rows = np.full((len(d), 10), -1.0)
    rows[:, 0] = frame + 1
    rows[:, 2:6] = d.box_array(pad)
    rows[:, 6] = d.scores
    return rows


def _check_video_args(
    video: Any, src: Any, fps: float | None, max_frames: int | None, overlay: bool, scale: float
) -> float:
    """The frame rate to use; :class:`InputError` for a bad rate, frame count or scale."""
    rate = fps if fps is not None else src.fps
    if rate is None:
        raise InputError(f"{video}: the frame rate is unknown (a folder of frames?); pass --fps")
    if not (rate > 0 and np.isfinite(rate)):
        raise InputError(f"fps must be a positive number, got {rate!r}")
    if max_frames is not None and max_frames < 1:
        raise InputError(f"max_frames must be a positive integer, got {max_frames!r}")
    if overlay and not (0 < scale <= 1):
        raise InputError(f"overlay scale must be in (0, 1], got {scale!r}")
    return rate


def _draw_final(writer: Any, ring: collections.deque, final: Any) -> None:
    """Draw the frames whose tracks are final into the overlay; drop older ring frames."""
    for f, rows in final:
        while ring and ring[0][0] < f:
            ring.popleft()
        if ring and ring[0][0] == f:
            writer.write(ring.popleft()[1], rows, shrunk=True)


def _frame_stream(src: Any, max_frames: int | None, progress: bool) -> Any:
    """Read frames: decoded in a background thread, with a progress bar if asked."""
    total = max_frames if max_frames is not None else src.n_frames
    frames = src.frames(max_frames, prefetch=4)
    if progress:
        from tqdm import tqdm

        frames = tqdm(frames, total=total, unit="frame", desc="track", disable=None)
    return frames


def _with_cuts(frames: Any, cuts: set[int], look: int) -> Any:
    """``(k, frame, ahead)``: ``ahead`` is the frame and up to ``look`` frames after
    it where frame ``k`` starts a new scene, else ``None``."""
    it = iter(frames)
    buf: collections.deque[np.ndarray] = collections.deque()
    k = 0
    while True:
        frame = buf.popleft() if buf else next(it, None)
        if frame is None:
            return
        ahead = None
        if k in cuts:
            while len(buf) < look and (f := next(it, None)) is not None:
                buf.append(f)
            ahead = [frame, *buf]
        yield k, frame, ahead
        k += 1


def _detect_and_associate(
    video: Any,
    frames: Any,
    det: Any,
    tracker: Tracker,
    writer: Any,
    takes_hints: bool,
    cuts: tuple[set[int], int] = (set(), 0),
) -> tuple[int, np.ndarray]:
    """Detect each frame, associate its detections with the tracks, draw final frames.

    At a scene cut (``cuts``: the 0-based frames that start a new scene, and how many
    frames the detector's new background is learned from) every track ends and the
    detector learns the new scene's background (its ``rebase``, where it has one).
    Returns the number of detections and their MOT rows; :class:`InputError` when no
    frame is decoded or nothing is detected.  The overlay is closed here (aborted on
    any error), as the tracker's lag means the last frames are drawn after the loop.
    """
    ring: collections.deque[tuple[int, np.ndarray]] = collections.deque()
    det_rows = []
    n_det = 0
    k = -1
    rebase = getattr(det, "rebase", None)
    try:
        for k, frame, ahead in _with_cuts(frames, *cuts):
            if ahead is not None:
                tracker.cut()
                if rebase is not None:
                    rebase(ahead)
            hints = tracker.predict()
            d = det.detect(frame, hints=hints) if takes_hints else det.detect(frame)
            tracker.update(d)
            n_det += len(d)
            det_rows.append(_det_rows(k, d, tracker.pad))
            if writer is not None:
                ring.append((k, writer.shrink(frame)))  # small frames wait for the lag
                _draw_final(writer, ring, tracker.pop_final())
        if k < 0:
            raise InputError(f"{video}: no frame could be decoded")
        if n_det == 0:
            raise InputError(
                f"{video}: no animals detected in {k + 1} frames "
                f"({getattr(det, 'name', 'the')} detector); nothing written; {NOTHING_FOUND_HINT}"
            )
        if writer is not None:
            _draw_final(writer, ring, tracker.flush())
            writer.close()
    except BaseException:
        if writer is not None:
            writer.abort()
        raise
    dets = np.concatenate(det_rows) if det_rows else np.zeros((0, 10))
    return n_det, dets


def _register(
    src: Any, camera: str, max_frames: int | None, prepare_s: float, rate: float
) -> tuple[Any, Any, int, tuple[set[int], int], str | None]:
    """The source (registered when the camera moves), its path, the frames the detector
    is prepared on (the first scene's only), the scene cuts with that count, and
    :func:`photo_series_note`'s warning (a photo series: the camera taken as still)."""
    note, camera = photo_series_note(src.files, src.path, camera)
    src, path = register_source(src, camera, max_frames=max_frames)
    n_prep = _prep_frames(prepare_s, rate, max_frames)
    cuts = set(path.cuts) if path is not None else set()
    if cuts:
        n_prep = min(n_prep, min(cuts))
    return src, path, n_prep, (cuts, n_prep), note


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
) -> dict[str, Any]:
    """Track the ants of a video; write the outputs; return the summary.  The stages:
    read frames (:func:`_frame_stream`), detect and associate (:func:`_detect_and_associate`),
    smooth and gap-fill (the tracker's ``finish``), write (:func:`_write_video_outputs`).

    Parameters
    ----------
    video
        Video file or folder of frames.
    out_dir
        Output folder (created with its parents).
    px_per_mm
        Image scale (px per mm); ``None``: the animals' body length is measured from
        the video (:func:`~thermoswarm.tracking.detect.classical.estimate_length_px`) and
        ``tracks.nc`` is written in px (``space_unit = "px"``).
    fps
        Frame rate (frames/s); default the video's own (required for folders of frames).
    detector, model, detector_options
        See :func:`thermoswarm.tracking.detect.classical.make_detector` (default: classical).
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

    Raises
    ------
    InputError
        Bad input, nothing detected (nothing written), a camera that cannot be
        followed, or detections that are not animals (:mod:`~.flood`).
    """
    from thermoswarm.tracking.video import OverlayWriter, open_video

    src = open_video(video)
    rate = _check_video_args(video, src, fps, max_frames, overlay, overlay_scale)
    t0 = time.perf_counter()
    src, path, n_prep, cuts, note = _register(src, camera, max_frames, prepare_s, rate)
    det, scale = build_detector(
        src, n_prep, px_per_mm=px_per_mm, detector=detector, model=model,
        options=detector_options, max_frames=max_frames)  # fmt: skip
    out = prepare_output_dir(out_dir)  # only once the detector is built
    tcfg = tracker_config or TrackerConfig()
    tracker = Tracker(tcfg, px_per_mm=scale["px_per_mm"], fps=rate, frame_size=src.size)
    t_prep = time.perf_counter() - t0
    takes_hints = hints and bool(getattr(det, "accepts_hints", False))
    writer = OverlayWriter(out / "overlay.mp4", rate, scale=overlay_scale) if overlay else None
    frames = _frame_stream(src, max_frames, progress)
    n_det, dets = _detect_and_associate(video, frames, det, tracker, writer, takes_hints, cuts)
    result = _to_first_frame(src, tracker.finish(), dets, out)
    elapsed = time.perf_counter() - t0
    run = dict(video=video, src=src, det=det, scale=scale, dets=dets, n_det=n_det, rate=rate)
    run["camera"] = camera_summary(path, isinstance(src, RegisteredSource))
    return _write_video_outputs(
        result, out, run, px_per_mm=px_per_mm, fps_source="user" if fps is not None else "video",
        tracker=tcfg, detector=detector, model=model, detector_options=detector_options,
        timing=(elapsed, t_prep), overlay=writer is not None, series_note=note,
    )  # fmt: skip


def _write_video_outputs(
    result: TrackResult,
    out: Path,
    run: dict[str, Any],
    *,
    px_per_mm: float | None,
    fps_source: str,
    tracker: TrackerConfig,
    detector: str | None,
    model: Any,
    detector_options: dict[str, Any] | None,
    timing: tuple[float, float],
    overlay: bool,
    series_note: str | None = None,
) -> dict[str, Any]:
    """Write tracks.nc, tracks_mot.txt, detections.txt and summary.json; return the summary.

    ``run`` holds the run's ``video``, ``src`` (its source), ``det`` (the detector),
    ``scale`` (:func:`build_detector`'s), ``dets`` (MOT detection rows), ``n_det`` and
    ``rate`` (frames/s); ``timing`` is ``(elapsed, prepare)`` in s; ``overlay`` says
    overlay.mp4 was written.
    """
    video, src, det, scale, rate = (run[k] for k in ("video", "src", "det", "scale", "rate"))
    det_name = getattr(det, "name", detector or "classical")
    attrs = {
        "detector": str(det_name),
        "frame_width": src.size[0],
        "frame_height": src.size[1],
        "body_length_px": scale["length_px"],
        "scale_source": scale["scale_source"],
    }
    names = _write_outputs(
        result,
        out,
        px_per_mm=px_per_mm,
        fps=rate,
        source=str(video),
        det_rows=run["dets"],
        attrs=attrs,
    )
    if overlay:
        names.append("overlay.mp4")
    summary = _summary(
        result,
        source=str(video),
        fps=rate,
        fps_source=fps_source,
        px_per_mm=px_per_mm,
        tracker=tracker,
        detector=str(det_name),
        model=model,
        n_det=run["n_det"],
        elapsed=timing[0],
        prepare=timing[1],
        size=src.size,
        outputs=names + ["summary.json"],
        detector_options=_detector_info(det, detector_options),
    )
    summary.update(
        length_px=scale["length_px"],
        scale_source=scale["scale_source"],
        prepare_frames=scale.get("prepare_frames"),
        space_unit="mm" if px_per_mm is not None else "px",
        camera=run["camera"],
    )
    summary["outputs"][-1:-1] = run["camera"]["outputs"]
    dets = run["dets"]
    per_frame = np.bincount(dets[:, 0].astype(np.int64) - 1, minlength=result.n_frames)
    still_bg = det_name == "classical"  # finds what moves: specks flickering in place are not
    reasons = flood_reasons(
        per_frame, src.size, scale["length_px"], dets if still_bg else None, fps=rate
    )
    summary["warnings"] = reasons or warn_no_track(result.n_tracks, per_frame, rate, tracker, out)
    summary["warnings"] += add_warning(out, series_note)
    atomic_write_json(out / "summary.json", summary)
    if reasons:
        refuse_flood(str(video), out, reasons)
    return summary
