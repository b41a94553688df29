"""Detection without tracking: :func:`detect_inputs`, what ``thermoswarm detect`` runs
(COCO keypoints and MOTChallenge detections per input)."""

from __future__ import annotations

import os
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from thermoswarm.errors import InputError
from thermoswarm.fsutil import atomic_write_json, atomic_write_text, prepare_output_dir
from thermoswarm.tracking.detect.register import (
    RegisteredSource,
    camera_summary,
    register_source,
    shift_detections,
)
from thermoswarm.tracking.pipeline.common import _prep_frames, build_detector, first_cut
from thermoswarm.tracking.pipeline.flood import flood_reasons, refuse_flood
from thermoswarm.tracking.pipeline.patches import (
    ColorRegions,
    count_patches,
    draw_patches,
    parse_color_regions,
)
from thermoswarm.tracking.pipeline.region_counts import count_regions, counts_csv, draw_counts
from thermoswarm.tracking.pipeline.series import (
    SERIES_WINDOW,
    check_series_options,
    detect_series,
    series_record,
    series_source,
)
from thermoswarm.tracking.track.tracker import TrackerConfig


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
    camera: str = "auto",
    regions: str | os.PathLike | None = None,
    series: str = "auto",
    series_window: int = SERIES_WINDOW,
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
    camera
        As for :func:`track_video`, for video files; folders and images are taken as
        from a still camera unless ``"moving"``.  ``NAME_camera.csv``: the path.
    regions
        A regions TOML (:mod:`~thermoswarm.tracking.pipeline.region_counts`), or
        ``"color:LO-HI"``: the coloured patches found in each frame, ``left`` and
        ``right`` (:mod:`~thermoswarm.tracking.pipeline.patches`):
        ``NAME_regions.csv``, and for photos a picture each in ``NAME_regions/``.
    series
        ``"auto"``: folders and images recognised as a photo series by their clocks,
        the times in their names or how much changes between them
        (:func:`~thermoswarm.tracking.pipeline.series.series_evidence`) are detected
        in windows of photos, in the order taken; ``"yes"``/``"no"`` force it.
    series_window
        Photos per background in a series (0: one background for the whole series).
    """
    _check_args(inputs, max_frames, fps)
    check_series_options(series, series_window)
    wbl = TrackerConfig().width_bl if width_bl is None else float(width_bl)
    regs = _load_regions(regions)
    sources = _detect_sources([Path(p) for p in inputs])
    out = prepare_output_dir(out_dir)
    opts = dict(
        px_per_mm=px_per_mm, detector=detector, model=model, detector_options=detector_options,
        fps=fps, max_frames=max_frames, prepare_s=prepare_s, width_bl=wbl, camera=camera,
        regions=regs, series=series, series_window=series_window,
    )  # fmt: skip
    results = [_detect_source(name, src, is_video, out, **opts) for name, src, is_video in sources]
    summary = {"inputs": results, "outputs": [f for r in results for f in r["outputs"]]}
    summary["outputs"].append("summary.json")
    atomic_write_json(out / "summary.json", summary)
    return summary


def _check_args(inputs: list, max_frames: int | None, fps: float | None) -> None:
    if not inputs:
        raise InputError("give at least one video, folder of frames or image")
    if max_frames is not None and max_frames < 1:
        raise InputError(f"max_frames must be a positive integer, got {max_frames!r}")
    if fps is not None and not (fps > 0 and np.isfinite(fps)):
        raise InputError(f"fps must be a positive number, got {fps!r}")


def _load_regions(regions: str | os.PathLike | None) -> list | ColorRegions | None:
    if regions is None:
        return None
    if isinstance(regions, str) and regions.startswith(("color:", "colour:")):
        return parse_color_regions(regions)
    from thermoswarm.analysis.regions import load_regions
    from thermoswarm.errors import ConfigError

    try:
        return load_regions(regions)
    except ConfigError as exc:
        raise InputError(str(exc)) from None


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
    camera: str = "auto",
    regions: list | ColorRegions | None = None,
    series: str = "auto",
    series_window: int = SERIES_WINDOW,
) -> dict[str, Any]:
    """Detect one source of :func:`detect_inputs`; write its COCO (and MOT) file.

    Returns the source's summary record (counts, scale, seconds, files written).
    """
    from thermoswarm.io.mot import write_mot_table
    from thermoswarm.tracking.detect.files import coco_dataset, mot_rows

    t0 = time.perf_counter()
    rate = fps or src.fps or 30.0  # images: the background from up to 90 of them
    if src.files is not None and camera == "auto":
        camera = "still"
    src, path = register_source(src, camera, max_frames=max_frames)
    offset = src.camera.offset if isinstance(src, RegisteredSource) else (0.0, 0.0)
    src, evidence = series_source(src, series, max_frames)
    files = src.files
    kw = dict(px_per_mm=px_per_mm, detector=detector, model=model, options=detector_options)
    if evidence is not None:
        dets, scale, det = detect_series(files, window=series_window, **kw)
        scale["photo_series"] = series_record(evidence, scale, forced=series == "yes")
    else:
        n_prep = _prep_frames(prepare_s, rate, max_frames)
        det, scale = build_detector(
            src, n_prep, max_frames=max_frames, scene_end=first_cut(path), **kw)  # fmt: skip
        frames = src.frames(max_frames, prefetch=4)
        dets = [shift_detections(det.detect(f), offset) for f in frames]
    images = _coco_images(src, files, len(dets))
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
    written += _camera_and_counts(name, out, src, path, dets, images, regions, px_per_mm)
    if isinstance(regions, ColorRegions):  # needs the animals' length
        written += _patch_counts(name, out, src, dets, images, regions, scale["length_px"])
    n_det = sum(len(d) for d in dets)
    reasons = flood_reasons(np.array([len(d) for d in dets]), src.size, scale["length_px"])
    if reasons:
        refuse_flood(str(src.path), out, reasons)
    return {
        "input": str(src.path),
        "n_frames": len(dets),
        "n_detections": n_det,
        "detections_per_frame": n_det / max(len(dets), 1),
        "detector": str(getattr(det, "name", detector)),
        "px_per_mm": px_per_mm,
        "length_px": scale["length_px"],
        "scale_source": scale["scale_source"],
        **{k: scale.get(k) for k in _SCALE_KEYS},
        "seconds": time.perf_counter() - t0,
        "outputs": written,
        "camera": camera_summary(path, isinstance(src, RegisteredSource)),
        "photo_series": scale.get("photo_series"),
    }


#: What ``build_detector`` says of the frames and the background it chose, as written.
_SCALE_KEYS = ("prepare_frames", "prepare_step", "background", "moved_length_px",
               "picture_length_px")  # fmt: skip


def _coco_images(src: Any, files: list[Path] | None, n: int) -> list[dict[str, Any]]:
    """The COCO ``images`` of ``n`` frames of ``src`` (a photo's file name, or
    ``VIDEO#000001``)."""
    images = []
    for k in range(n):
        img = {"id": k + 1, "width": src.size[0], "height": src.size[1], "frame_id": k + 1}
        img["file_name"] = files[k].name if files else f"{src.path.name}#{k + 1:06d}"
        images.append(img)
    return images


def _write_jpeg(path: Path, rgb: np.ndarray) -> None:
    """An RGB picture as a JPEG, written atomically."""
    import cv2

    from thermoswarm.fsutil import atomic_write_bytes

    ok, buf = cv2.imencode(".jpg", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    if not ok:
        raise InputError(f"{path}: the picture could not be encoded as JPEG")
    atomic_write_bytes(path, buf.tobytes())


def _camera_and_counts(
    name: str,
    out: Path,
    src: Any,
    path: Any,
    dets: list,
    images: list[dict],
    regions: list | ColorRegions | None,
    px_per_mm: float | None,
) -> list[str]:
    """Write ``NAME_camera.csv`` (a registered source), ``NAME_regions.csv`` and, for
    photos, ``NAME_regions/`` (regions given); return the names written."""
    written = []
    if isinstance(src, RegisteredSource):
        atomic_write_text(out / f"{name}_camera.csv", path.table())
        written.append(f"{name}_camera.csv")
    if isinstance(regions, list):
        counts = count_regions(regions, dets, px_per_mm)
        names = [img["file_name"] for img in images]
        atomic_write_text(out / f"{name}_regions.csv", counts_csv(names, regions, counts))
        written.append(f"{name}_regions.csv")
        files = src.files
        if files is not None:
            pics = out / f"{name}_regions"
            pics.mkdir(exist_ok=True)
            for k, frame in enumerate(src.frames(len(dets), prefetch=4)):
                img = draw_counts(frame, regions, dets[k], counts[k], px_per_mm)
                _write_jpeg(pics / f"{files[k].stem}.jpg", img)
            written.append(f"{name}_regions/")
    return written


def _patch_counts(
    name: str,
    out: Path,
    src: Any,
    dets: list,
    images: list[dict],
    spec: ColorRegions,
    length_px: float,
) -> list[str]:
    """Count the detections on each frame's coloured patches (``--regions color:...``):
    ``NAME_regions.csv`` and, for photos, a picture each in ``NAME_regions/``."""
    pics = out / f"{name}_regions" if src.files is not None else None
    if pics is not None:
        pics.mkdir(exist_ok=True)
    counts = []
    for k, frame in enumerate(src.frames(len(dets), prefetch=4)):
        d = dets[k]
        bodies = d.points[:, 1, :] if len(d) else np.zeros((0, 2))
        c, masks, side = count_patches(spec, frame, bodies, length_px)
        counts.append(c)
        if pics is not None:
            img = draw_patches(frame, spec, masks, bodies, side, c)
            _write_jpeg(pics / f"{src.files[k].stem}.jpg", img)
    names = [img["file_name"] for img in images]
    regions = [SimpleNamespace(name=n) for n in spec.names]
    atomic_write_text(out / f"{name}_regions.csv", counts_csv(names, regions, np.array(counts)))
    return [f"{name}_regions.csv"] + ([f"{name}_regions/"] if pics is not None else [])
