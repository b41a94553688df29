"""Video (or detections) in, trajectories out: what ``thermoswarm track`` runs.

:func:`track_video` streams a video through a detector and the tracker:

1. the detector's ``prepare`` (if any) sees the first ``prepare_s`` seconds (the
   classical detector learns the empty road there; decoded once more, a small cost
   on long videos);
2. each frame is decoded in a background thread, detected (with the tracker's
   predictions as hints where the detector takes them) and tracked;
3. frames whose tracks are final (after the tracker's fixed lag) are drawn into the
   overlay video, so nothing but a short ring of small frames is kept in memory.

:func:`track_detection_file` runs the tracker on another detector's boxes without
video (MOTChallenge, YOLO txt or COCO JSON; :mod:`~thermoswarm.tracking.detfiles`):
head and tail are then unknown (NaN), the body point is the box centre, the boxes
written are the detections' own, the tracker's unit of length is the objects' size
measured from the boxes, and the frames keep the input's numbering.

Without a scale ``px_per_mm`` the animals' body length is measured from the video
(:func:`~thermoswarm.tracking.detect.estimate_length_px`); the tracker works in body
lengths either way.  :func:`detect_inputs` runs the same detectors without the tracker
and writes COCO keypoints and MOTChallenge detections (``thermoswarm detect``).

Both tracking functions write into ``out_dir``: ``tracks.nc`` (trajectory format, s,
keypoints head/body/tail; mm with a scale, else px with ``space_unit = "px"``),
``tracks_mot.txt`` (MOTChallenge boxes in px), ``detections.txt`` (video only: MOT
detection rows, to re-track without the video), ``overlay.mp4`` (unless disabled) and
``summary.json``; every file is written atomically.
"""

from __future__ import annotations

import collections
import dataclasses
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.config import to_dict
from thermoswarm.errors import InputError
from thermoswarm.fsutil import atomic_write_json, prepare_output_dir
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.detect import (
    NOTHING_FOUND_HINT,
    FrameDetections,
    estimate_length_px,
    make_detector,
)
from thermoswarm.tracking.tracker import Tracker, TrackerConfig, TrackResult

__all__ = [
    "track_video",
    "track_detection_file",
    "detections_from_table",
    "detect_inputs",
    "build_detector",
    "pixel_dataset",
]


def pixel_dataset(result: TrackResult, *, fps: float, source: str, attrs: dict[str, Any]) -> Any:
    """The trajectory Dataset of ``result`` with positions in px (no scale known).

    ``attrs["space_unit"]`` is ``"px"``; readers (:func:`thermoswarm.io.read_tracks`)
    then need ``--px-per-mm`` to convert to mm, or the ``units`` option to keep px.
    """
    ds = result.dataset(px_per_mm=1.0, fps=fps, source_file=source, attrs=attrs)
    del ds.attrs["px_per_mm"]
    ds.attrs["space_unit"] = "px"
    return ds


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


def _prep_frames(prepare_s: float, rate: float, max_frames: int | None) -> int:
    """How many first frames the detector's ``prepare`` step sees (at least one)."""
    n_prep = max(1, int(round(prepare_s * rate)))
    if max_frames is not None:
        n_prep = min(n_prep, max_frames)
    return n_prep


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


def _detect_and_associate(
    video: Any, frames: Any, det: Any, tracker: Tracker, writer: Any, takes_hints: bool
) -> tuple[int, np.ndarray]:
    """Detect each frame, associate its detections with the tracks, draw final frames.

    Returns the number of detections and their MOT rows; :class:`InputError` when no
    frame is decoded or nothing is detected.  The overlay is closed here (aborted on
    any error), as the tracker's lag means the last frames are drawn after the loop.
    """
    ring: collections.deque[tuple[int, np.ndarray]] = collections.deque()
    det_rows = []
    n_det = 0
    k = -1
    try:
        for k, frame in enumerate(frames):
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
) -> dict[str, Any]:
    """Track the ants of a video; write the outputs; return the summary.

    The stages: read frames (:func:`_frame_stream`), detect and associate
    (:func:`_detect_and_associate`), smooth and gap-fill (the tracker's ``finish``),
    write (:func:`_write_video_outputs`).

    Parameters
    ----------
    video
        Video file or folder of frames.
    out_dir
        Output folder (created with its parents).
    px_per_mm
        Image scale (px per mm); ``None``: the animals' body length is measured from
        the video (:func:`~thermoswarm.tracking.detect.estimate_length_px`) and
        ``tracks.nc`` is written in px (``space_unit = "px"``).
    fps
        Frame rate (frames/s); default the video's own (required for folders of frames).
    detector, model, detector_options
        See :func:`thermoswarm.tracking.detect.make_detector` (default: classical).
    tracker_config
        :class:`~thermoswarm.tracking.tracker.TrackerConfig`.
    overlay, overlay_scale
        Write ``overlay.mp4`` at this fraction of the video's size (1: full size).
    max_frames
        Stop after this many frames.
    prepare_s
        Seconds of video shown to the detector's ``prepare`` step.
    progress
        Show a progress bar (tqdm; silent when not on a terminal).
    hints
        Give the tracker's predicted poses to detectors that take them (splitting of
        touching ants); ``False`` tracks exactly what ``thermoswarm detect`` writes.

    Raises
    ------
    InputError
        Bad input, or a video in which nothing is detected (nothing is written then).
    """
    from thermoswarm.tracking.video import OverlayWriter, open_video

    src = open_video(video)
    rate = _check_video_args(video, src, fps, max_frames, overlay, overlay_scale)
    t0 = time.perf_counter()
    det, scale = build_detector(
        src,
        _prep_frames(prepare_s, rate, max_frames),
        px_per_mm=px_per_mm,
        detector=detector,
        model=model,
        options=detector_options,
    )
    out = prepare_output_dir(out_dir)  # only once the detector is built
    tcfg = tracker_config or TrackerConfig()
    tracker = Tracker(tcfg, px_per_mm=scale["px_per_mm"], fps=rate, frame_size=src.size)
    t_prep = time.perf_counter() - t0
    takes_hints = hints and bool(getattr(det, "accepts_hints", False))
    writer = OverlayWriter(out / "overlay.mp4", rate, scale=overlay_scale) if overlay else None
    frames = _frame_stream(src, max_frames, progress)
    n_det, dets = _detect_and_associate(video, frames, det, tracker, writer, takes_hints)
    result = tracker.finish()
    elapsed = time.perf_counter() - t0
    run = dict(video=video, src=src, det=det, scale=scale, dets=dets, n_det=n_det, rate=rate)
    return _write_video_outputs(
        result, out, run, px_per_mm=px_per_mm, fps_source="user" if fps is not None else "video",
        tracker=tcfg, detector=detector, model=model, detector_options=detector_options,
        timing=(elapsed, t_prep), overlay=writer is not None,
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
        space_unit="mm" if px_per_mm is not None else "px",
    )
    atomic_write_json(out / "summary.json", summary)
    return summary


def build_detector(
    src: Any,
    n_prep: int,
    *,
    px_per_mm: float | None,
    detector: str | None,
    model: str | os.PathLike | None,
    options: dict[str, Any] | None,
) -> tuple[Any, dict[str, Any]]:
    """The detector for video ``src``, prepared on its first ``n_prep`` frames.

    Without a scale the animals' body length is measured first from the same frames
    (:func:`~thermoswarm.tracking.detect.estimate_length_px`, with the classical
    detector's options when the detector is the classical one) and the detector is
    built at the scale that makes the paper's ant that long.  Returns the detector
    and ``{"px_per_mm", "length_px", "scale_source", "n_blobs"}`` (``px_per_mm`` the
    scale used, ``length_px`` the body length in px).
    """
    step = 2 if n_prep >= 32 else 1
    info: dict[str, Any] = {"scale_source": "user", "n_blobs": None}
    if px_per_mm is None:
        classical = (detector or ("classical" if model is None else "")) == "classical"
        est = estimate_length_px(
            src.frames(n_prep, step=step, prefetch=4),
            options if classical else None,
            source=str(src.path),
        )
        px_per_mm = est.length_px / anatomy.ANT_LENGTH_MM
        info.update(scale_source="measured", n_blobs=est.n_blobs)
    elif not (px_per_mm > 0 and np.isfinite(px_per_mm)):
        raise InputError(f"px_per_mm must be a positive number, got {px_per_mm!r}")
    det = make_detector(detector, px_per_mm=px_per_mm, model=model, options=options)
    prepare = getattr(det, "prepare", None)
    if prepare is not None:
        prepare(src.frames(n_prep, step=step, prefetch=4))
    info.update(px_per_mm=float(px_per_mm), length_px=float(anatomy.ANT_LENGTH_MM * px_per_mm))
    return det, info


def _detector_info(det: Any, options: dict[str, Any] | None) -> dict[str, Any]:
    info: dict[str, Any] = {"options": dict(options or {})}
    for attr in ("threshold", "single_area", "length_px", "widening_px"):
        if hasattr(det, attr):
            info[attr] = getattr(det, attr)
    if dataclasses.is_dataclass(getattr(det, "config", None)):
        info["config"] = to_dict(det.config)
    return info


def _summary(
    result: TrackResult,
    *,
    source: str,
    fps: float,
    fps_source: str,
    px_per_mm: float | None,
    tracker: TrackerConfig,
    detector: str | None,
    model: Any,
    n_det: int,
    elapsed: float,
    prepare: float,
    size: tuple[int, int] | None,
    outputs: list[str],
    detector_options: dict[str, Any] | None,
) -> dict[str, Any]:
    n = max(result.n_frames, 1)
    return {
        "source": source,
        "n_frames": result.n_frames,
        "fps": fps,
        "fps_source": fps_source,
        "px_per_mm": px_per_mm,
        "frame_size": list(size) if size else None,
        "detector": detector,
        "model": None if model is None else str(model),
        "n_detections": n_det,
        "detections_per_frame": n_det / n,
        "n_tracks": result.n_tracks,
        "n_rows": int(result.frames.size),
        "n_interpolated": int(result.interpolated.sum()),
        "seconds": elapsed,
        "prepare_seconds": prepare,
        "frames_per_second": result.n_frames / elapsed if elapsed > 0 else None,
        "tracker": to_dict(tracker),
        "detector_info": detector_options,
        "outputs": outputs,
    }


def detections_from_table(table: np.ndarray) -> list[FrameDetections]:
    """Per-frame detections from MOT detection rows, frames 1, 2, ... (box centres as
    body points, head and tail unknown; a negative score counts as 1)."""
    from thermoswarm.tracking.detfiles import DetectionTable

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
        (:func:`~thermoswarm.tracking.detfiles.read_detections`).
    fps
        Frame rate (frame numbers only in the files).
    px_per_mm
        Image scale: ``tracks.nc`` in mm; without it in px (``space_unit = "px"``).
    fmt, image_size
        Format (default from the path) and ``(width, height)`` px (needed by YOLO).
    first_frame
        Number of the first frame (0 or 1; default 0 if the file has a frame 0, else 1);
        the tracks keep the input's numbering.
    length_px
        The objects' length in px, the tracker's unit; default the length the file
        records (``thermoswarm detect``'s COCO), else the median longer box side.
    """
    from thermoswarm.tracking.detfiles import read_detections

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
) -> dict[str, Any]:
    """Write tracks_mot.txt, tracks.nc and summary.json of :func:`track_detection_file`.

    ``table`` is the detections read from ``path``, ``length_px`` the tracker's unit
    (px) and ``elapsed`` the tracking time (s); returns the summary.
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
    )
    atomic_write_json(out / "summary.json", summary)
    return summary


def _detect_sources(inputs: list[Path]) -> list[tuple[str, Any, bool]]:
    """``(name, source, is_video)`` per input: each video file or folder of frames is one
    source; the image files given are one sequence together (sorted by name)."""
    from thermoswarm.tracking.video import IMAGE_EXTS, VideoSource, open_video

    images = sorted(p for p in inputs if p.is_file() and p.suffix.lower() in IMAGE_EXTS)
    out: list[tuple[str, Any, bool]] = []
    names: set[str] = set()
    for p in inputs:
        if p in images:
            continue
        name = p.stem if p.is_file() else p.name
        if name in names:
            raise InputError(f"{p}: two inputs are named {name!r}; rename one")
        names.add(name)
        out.append((name, open_video(p), True))
    if images:
        if "images" in names:
            raise InputError("an input named 'images' clashes with the image files given")
        out.append(("images", VideoSource.from_images(images, "images"), False))
    return out


def detect_inputs(
    inputs: list[str | os.PathLike],
    out_dir: str | os.PathLike,
    *,
    px_per_mm: float | None = None,
    detector: str | None = None,
    model: str | os.PathLike | None = None,
    detector_options: dict[str, Any] | None = None,
    fps: float | None = None,
    max_frames: int | None = None,
    prepare_s: float = 3.0,
    width_bl: float | None = None,
) -> dict[str, Any]:
    """Detect the animals of videos, folders of frames or images; write COCO and MOT.

    The detector is built and prepared exactly as :func:`track_video` does (the same
    registry, the same size measurement without a scale), but without the tracker's
    predictions, so ``thermoswarm track --detections NAME.json`` on the output gives
    the tracks of ``track_video(..., hints=False)``.

    Writes, per input ``NAME`` (a video's or folder's name; ``images`` for the image
    files given, taken as one sequence): ``NAME.json`` (COCO keypoints: images,
    annotations with ``bbox``, ``score``, head/body/tail ``keypoints``, categories
    with the keypoint names and skeleton) and, for videos and folders,
    ``NAME_det.txt`` (MOTChallenge detections, frames from 1); and ``summary.json``.

    Parameters
    ----------
    inputs
        Video files, folders of frames and image files.
    out_dir
        Output folder (created with its parents).
    px_per_mm, detector, model, detector_options, prepare_s
        As for :func:`track_video`.
    fps
        Frame rate of folders and images (only sets how many frames ``prepare_s``
        spans; default the video's own, else 30: up to 90 images).
    max_frames
        Detect at most this many frames of each input.
    width_bl
        Object width in body lengths, half of which pads the boxes of poses (default
        the tracker's ``width_bl``, so the boxes are those the tracker draws).
    """
    if not inputs:
        raise InputError("give at least one video, folder of frames or image")
    if max_frames is not None and max_frames < 1:
        raise InputError(f"max_frames must be a positive integer, got {max_frames!r}")
    if fps is not None and not (fps > 0 and np.isfinite(fps)):
        raise InputError(f"fps must be a positive number, got {fps!r}")
    wbl = TrackerConfig().width_bl if width_bl is None else float(width_bl)
    sources = _detect_sources([Path(p) for p in inputs])
    out = prepare_output_dir(out_dir)
    results = [
        _detect_source(
            name,
            src,
            is_video,
            out,
            px_per_mm=px_per_mm,
            detector=detector,
            model=model,
            detector_options=detector_options,
            fps=fps,
            max_frames=max_frames,
            prepare_s=prepare_s,
            width_bl=wbl,
        )
        for name, src, is_video in sources
    ]
    summary = {"inputs": results, "outputs": [f for r in results for f in r["outputs"]]}
    summary["outputs"].append("summary.json")
    atomic_write_json(out / "summary.json", summary)
    return summary


def _detect_source(
    name: str,
    src: Any,
    is_video: bool,
    out: Path,
    *,
    px_per_mm: float | None,
    detector: str | None,
    model: str | os.PathLike | None,
    detector_options: dict[str, Any] | None,
    fps: float | None,
    max_frames: int | None,
    prepare_s: float,
    width_bl: float,
) -> dict[str, Any]:
    """Detect one source of :func:`detect_inputs`; write its COCO (and MOT) file.

    Returns the source's summary record (counts, scale, seconds, files written).
    """
    from thermoswarm.io.mot import write_mot_table
    from thermoswarm.tracking.detfiles import coco_dataset, mot_rows

    t0 = time.perf_counter()
    rate = fps or src.fps or 30.0  # images: the background from up to 90 of them
    det, scale = build_detector(
        src,
        _prep_frames(prepare_s, rate, max_frames),
        px_per_mm=px_per_mm,
        detector=detector,
        model=model,
        options=detector_options,
    )
    dets = [det.detect(frame) for frame in src.frames(max_frames, prefetch=4)]
    files = src.files
    images = []
    for k in range(len(dets)):
        img = {"id": k + 1, "width": src.size[0], "height": src.size[1], "frame_id": k + 1}
        img["file_name"] = files[k].name if files else f"{src.path.name}#{k + 1:06d}"
        images.append(img)
    pad = 0.5 * width_bl * scale["length_px"]
    coco = coco_dataset(
        images,
        dets,
        pad=pad,
        length_px=scale["length_px"],
        description=f"thermoswarm detect {src.path} ({getattr(det, 'name', detector)})",
    )
    written = [f"{name}.json"]
    atomic_write_json(out / f"{name}.json", coco)
    if is_video:
        write_mot_table(out / f"{name}_det.txt", mot_rows(dets, pad=pad))
        written.append(f"{name}_det.txt")
    n_det = sum(len(d) for d in dets)
    return {
        "input": str(src.path),
        "n_frames": len(dets),
        "n_detections": n_det,
        "detections_per_frame": n_det / max(len(dets), 1),
        "detector": str(getattr(det, "name", detector)),
        "px_per_mm": px_per_mm,
        "length_px": scale["length_px"],
        "scale_source": scale["scale_source"],
        "seconds": time.perf_counter() - t0,
        "outputs": written,
    }
