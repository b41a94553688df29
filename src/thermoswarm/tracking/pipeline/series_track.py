"""``track`` on a photo series: the photos detected as ``detect`` detects them, linked
into tracks only where they are close enough in time.

A folder that :func:`~thermoswarm.tracking.pipeline.series.series_source` takes for a
photo series (recognised by clocks, names or changes, or ``series="yes"``) is detected
by :func:`~thermoswarm.tracking.pipeline.series.detect_series`, the function ``detect``
runs: the same windows of photos, each with its own background, the same size
measurement and options, so ``detections.txt`` holds ``detect``'s ``NAME_det.txt``.

Then the photos' interval decides whether tracks can follow an animal from one photo
to the next (:func:`series_timing`):

* the interval is the median gap between the photos' clocks or the times in their
  names; where neither gives one it is unknown, and the frames are written one photo
  per frame at ``--fps`` (assumed 1 photo/s without it), which the summary says;
* tracks link the photos only when the interval is known (clocks, names, or ``--fps``
  on photos that were not recognised by their changes) and an animal at the tracker's
  top speed (``tracker.max_speed_bl_s``) moves at most :data:`MAX_REACH_BL` body
  lengths between two photos.  Photos recognised by their changes never link: that
  consecutive photos differ as much as photos 8 apart says that nothing stays in
  place from one photo to the next.

Where they do not link (a tray photographed every 30 min: 25,200 body lengths at 14
body lengths/s), ``tracks.nc`` and ``tracks_mot.txt`` hold no track, the overlay
draws each photo's detections numbered 1..n (numbers, not identities), and a warning
(``WARNING.txt``, stderr, ``summary.json``'s ``warnings``) says that identities cannot
be followed across photos so far apart and points at ``detect --regions`` for counts
per photo and region.  ``summary.json``'s ``photo_series`` holds ``detect``'s record
plus the interval, its source, whether the photos were linked and the photos in the
order taken (frame ``k`` is ``files[k - 1]``).
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.fsutil import prepare_output_dir
from thermoswarm.tracking.detect.register import camera_summary
from thermoswarm.tracking.pipeline.series import detect_series, series_record
from thermoswarm.tracking.pipeline.stages import (
    detect_and_associate,
    frame_stream,
    write_video_outputs,
)
from thermoswarm.tracking.track.result import TrackResult
from thermoswarm.tracking.track.tracker import Tracker, TrackerConfig

__all__ = ["MAX_REACH_BL", "series_timing", "track_series"]

#: Farthest (body lengths) an animal at the tracker's top speed may move between two
#: photos for tracks to link them: the ``ants`` preset's 14 body lengths/s at 5
#: frames/s, the slowest rate that preset was tuned at.
MAX_REACH_BL = 14.0 / 5.0
#: The overlay of a photo series plays at the photos' own rate, within these (photos/s).
OVERLAY_FPS = (2.0, 30.0)
_SOURCE = {
    "clocks": "the median gap of their clocks",
    "names": "the median gap of the times in their names",
    "--fps": "by --fps",
}


def series_timing(
    evidence: dict[str, Any], fps: float | None, tracker: TrackerConfig, label: Any
) -> dict[str, Any]:
    """The interval between the photos of a series and whether tracks link them.

    Parameters
    ----------
    evidence
        :func:`~thermoswarm.tracking.pipeline.series.series_evidence`'s record.
    fps
        The user's frame rate (photos/s), or ``None``.
    tracker
        The tracker's options (its ``max_speed_bl_s``, body lengths/s).
    label
        The folder, named in the note.

    Returns
    -------
    dict
        ``interval_s`` (s between photos; ``None`` when unknown), ``interval_source``
        (``"clocks"``, ``"names"``, ``"--fps"`` or ``None``), ``fps`` (the frame rate
        written, photos/s: ``1 / interval_s``, else ``fps``, else 1 assumed),
        ``fps_source`` (as ``interval_source``, or ``"assumed"``), ``reach_bl`` (body
        lengths an animal at the top speed may move between two photos; ``None`` when
        unknown), ``linked`` and ``note`` (why not linked, or ``None``).
    """
    by, gap = evidence["by"], evidence.get("median_gap_s")
    by_changes = bool(evidence["series"]) and by == "changes"
    interval, source = None, None
    if by in ("clocks", "names") and gap:
        interval, source = float(gap), by
    elif fps is not None and not by_changes:
        interval, source = 1.0 / fps, "--fps"
    rate = 1.0 / interval if interval else (fps or 1.0)
    v = tracker.max_speed_bl_s
    reach = v * interval if interval else None
    linked = reach is not None and reach <= MAX_REACH_BL
    rec = dict(interval_s=interval, interval_source=source, fps=rate, reach_bl=reach)
    rec.update(fps_source=source or ("--fps" if fps is not None else "assumed"), linked=linked)
    n = len(evidence["files"])
    if linked:
        rec["note"] = None
    elif reach is not None:
        rec["note"] = (
            f"{label}: {n} photos {interval:g} s apart ({_SOURCE[source]}): an "
            f"animal at the tracker's top speed ({v:g} body lengths/s) may move "
            f"{reach:,.1f} body lengths between two photos, more than the {MAX_REACH_BL:g} "
            "over which tracks link them"
        )
    else:
        why = (
            "consecutive photos differ as much as photos 8 apart "
            f"(ratio {evidence['change_ratio']:.2f}): the animals are elsewhere in every "
            "photo"
            if by_changes
            else "the photos have no clock and no time in their names"
        )
        assumed = f"{rate:g} photos/s (--fps)" if fps is not None else "1 photo/s (assumed)"
        rec["note"] = (
            f"{label}: {n} photos taken as a photo series, {why}; the interval between "
            f"them is unknown and the frames are written at {assumed}"
        )
    if fps is not None and source in ("clocks", "names"):
        rec["fps_ignored"] = (
            f"--fps {fps:g} not used: the photos' {source} give the interval; --series no "
            "takes the photos as video frames at --fps"
        )
    if rec["note"] is not None:
        rec["note"] += (
            ": identities cannot be followed across photos, so tracks.nc holds no track; "
            "detections.txt and the overlay hold each photo's detections (frame k is the "
            "k-th photo in summary.json's photo_series.files); for counts per photo and "
            f"region use `thermoswarm detect {label} --regions REGIONS --out DIR`"
        )
        if "fps_ignored" in rec:
            rec["note"] += f" ({rec['fps_ignored']})"
    return rec


class _Replay:
    """Hands out the detections already made, one photo per call, as a detector would."""

    accepts_hints = False

    def __init__(self, dets: list[Any], det: Any) -> None:
        self._it = iter(dets)
        self.name = getattr(det, "name", "classical")

    def detect(self, frame: np.ndarray) -> Any:
        return next(self._it)


class _PerPhoto:
    """Stands in for the tracker where the photos are too far apart to link: no track,
    and each photo's detections, numbered 1..n, for the overlay."""

    def __init__(self, pad: float) -> None:
        self.pad = pad
        self.frame = -1
        self._rows: list[tuple[int, list]] = []

    def cut(self) -> None:
        pass

    def predict(self) -> np.ndarray:
        self.frame += 1
        return np.zeros((0, 3, 2))

    def update(self, d: Any) -> None:
        boxes = d.box_array(self.pad) if len(d) else np.zeros((0, 4))
        rows = [(j + 1, d.points[j], boxes[j]) for j in range(len(d))]
        self._rows.append((self.frame, rows))

    def pop_final(self) -> list[tuple[int, list]]:
        out, self._rows = self._rows, []
        return out

    flush = pop_final

    def finish(self) -> TrackResult:
        return TrackResult.empty(self.frame + 1)


def track_series(
    video: str | os.PathLike,
    src: Any,
    evidence: dict[str, Any],
    out_dir: str | os.PathLike,
    *,
    forced: bool,
    fps: float | None,
    px_per_mm: float | None,
    detector: str | None,
    model: str | os.PathLike | None,
    detector_options: dict[str, Any] | None,
    tracker_config: TrackerConfig | None,
    overlay: bool,
    overlay_scale: float,
    series_window: int,
    progress: bool = False,
) -> dict[str, Any]:
    """Track a photo series (see the module docstring); write the outputs of
    :func:`~thermoswarm.tracking.pipeline.track_video`; return the summary.

    ``src`` holds the photos in the order taken and ``evidence`` is
    :func:`~thermoswarm.tracking.pipeline.series.series_evidence`'s record (both from
    :func:`~thermoswarm.tracking.pipeline.series.series_source`); ``forced``: the
    series was asked for (``series="yes"``); ``fps``: the user's rate (photos/s) or
    ``None``; the other options as for ``track_video``.
    """
    from thermoswarm.tracking.video import OverlayWriter

    t0 = time.perf_counter()
    dets, scale, det = detect_series(
        src.files, px_per_mm=px_per_mm, detector=detector, model=model,
        options=detector_options, window=series_window,
    )  # fmt: skip
    tcfg = tracker_config or TrackerConfig()
    timing = series_timing(evidence, fps, tcfg, video)
    record = {**series_record(evidence, scale, forced=forced), **timing}
    record["files"] = [f.name for f in src.files]
    out = prepare_output_dir(out_dir)
    rate = timing["fps"]
    if timing["linked"]:
        tracker: Any = Tracker(tcfg, px_per_mm=scale["px_per_mm"], fps=rate, frame_size=src.size)
    else:
        tracker = _PerPhoto(0.5 * tcfg.width_bl * scale["length_px"])
    t_prep = time.perf_counter() - t0
    writer = None
    if overlay:
        writer = OverlayWriter(
            out / "overlay.mp4", float(np.clip(rate, *OVERLAY_FPS)), scale=overlay_scale
        )
        if not timing["linked"]:
            writer.trail = 1  # the numbers are per photo: no trail joins them
    # Without an overlay the photos need not be read again: a stand-in frame each.
    frames = frame_stream(src, None, progress) if writer else (np.zeros(1) for _ in dets)
    n_det, rows = detect_and_associate(video, frames, _Replay(dets, det), tracker, writer, False)
    run = dict(video=video, src=src, det=det, scale=scale, dets=rows, n_det=n_det, rate=rate)
    run.update(camera=camera_summary(None, False), series=record)
    return write_video_outputs(
        tracker.finish(), Path(out), run, px_per_mm=px_per_mm, fps_source=timing["fps_source"],
        tracker=tcfg, detector=detector, model=model, detector_options=detector_options,
        timing=(time.perf_counter() - t0, t_prep), overlay=writer is not None,
    )  # fmt: skip
