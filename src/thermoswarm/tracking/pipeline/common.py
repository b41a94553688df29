"""What the pipeline's verbs share: the detector built and prepared on a source's first
frames (measuring the animals' size when no scale is given), the run's summary, and the
trajectory Dataset in px."""

from __future__ import annotations

import dataclasses
import os
from typing import Any

import numpy as np

from thermoswarm.config import to_dict
from thermoswarm.errors import InputError
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.detect.classical import estimate_length_px, make_detector
from thermoswarm.tracking.track.tracker import TrackerConfig, TrackResult

#: Smallest share of its length squared that a single animal's blob fills (lines below).
MIN_FILL = 0.1


def pixel_dataset(result: TrackResult, *, fps: float, source: str, attrs: dict[str, Any]) -> Any:
    """The trajectory Dataset of ``result`` with positions in px (no scale known).

    ``attrs["space_unit"]`` is ``"px"``; readers (:func:`thermoswarm.io.read_tracks`)
    then need ``--px-per-mm`` to convert to mm, or the ``units`` option to keep px.
    """
    ds = result.dataset(px_per_mm=1.0, fps=fps, source_file=source, attrs=attrs)
    del ds.attrs["px_per_mm"]
    ds.attrs["space_unit"] = "px"
    return ds


def _prep_frames(prepare_s: float, rate: float, max_frames: int | None) -> int:
    """How many first frames the detector's ``prepare`` step sees (at least one)."""
    n_prep = max(1, int(round(prepare_s * rate)))
    if max_frames is not None:
        n_prep = min(n_prep, max_frames)
    return n_prep


def build_detector(
    src: Any,
    n_prep: int,
    *,
    px_per_mm: float | None,
    detector: str | None,
    model: str | os.PathLike | None,
    options: dict[str, Any] | None,
    step: int | None = None,
) -> tuple[Any, dict[str, Any]]:
    """The detector for video ``src``, prepared on its first ``n_prep`` frames (every
    ``step``-th; default every other from 32 frames, else all).

    Without a scale the animals' body length is measured first from the same frames
    (:func:`~thermoswarm.tracking.detect.classical.estimate_length_px`, with the classical
    detector's options when the detector is the classical one) and the detector is
    built at the scale that makes the paper's ant that long.  Returns the detector
    and ``{"px_per_mm", "length_px", "scale_source", "n_blobs"}`` (``px_per_mm`` the
    scale used, ``length_px`` the body length in px).
    """
    step = step or (2 if n_prep >= 32 else 1)
    info: dict[str, Any] = {"scale_source": "user", "n_blobs": None}
    if px_per_mm is None:
        classical = (detector or ("classical" if model is None else "")) == "classical"
        est = estimate_length_px(
            src.frames(n_prep, step=step, prefetch=4),
            options if classical else None,
            source=str(src.path),
        )
        if est.fill < MIN_FILL:
            raise InputError(
                f"{src.path}: the moving things are thin lines, not animals: their blobs "
                f"fill {est.fill:.2f} of their length squared (an animal's 0.25-0.5); a "
                "plot or a drawing has nothing to track; give --px-per-mm to track anyway"
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
