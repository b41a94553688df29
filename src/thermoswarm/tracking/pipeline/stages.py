"""The stages that ``track`` runs on every source, whatever made its detections: the
frames read (:func:`frame_stream`), detected and associated with the tracks
(:func:`detect_and_associate`, the overlay drawn as frames become final), and the
outputs written (:func:`write_video_outputs`: tracks.nc, tracks_mot.txt,
detections.txt, summary.json, with the flood guard and the warnings).

:func:`~thermoswarm.tracking.pipeline.video.track_video` runs them on a video or a
folder of frames, :func:`~thermoswarm.tracking.pipeline.series_track.track_series` on
a photo series (the photos detected window by window first, as ``detect`` does).
"""

from __future__ import annotations

import collections
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.errors import InputError
from thermoswarm.fsutil import atomic_write_json
from thermoswarm.tracking.detect.classical import NOTHING_FOUND_HINT, FrameDetections
from thermoswarm.tracking.pipeline.common import _detector_info, _summary, pixel_dataset
from thermoswarm.tracking.pipeline.flood import (
    add_warning,
    few_found_warning,
    flood_reasons,
    inner_ends,
    refuse_flood,
    still_look_warning,
    warn_no_track,
)
from thermoswarm.tracking.track.tracker import Tracker, TrackerConfig, TrackResult

__all__ = ["detect_and_associate", "frame_stream", "write_video_outputs"]


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


def _draw_final(writer: Any, ring: collections.deque, final: Any) -> None:
    """Draw the frames whose tracks are final into the overlay; drop older ring frames."""
    for f, rows in final:
        while ring and ring[0][0] < f:
            ring.popleft()
        if ring and ring[0][0] == f:
            writer.write(ring.popleft()[1], rows, shrunk=True)


def frame_stream(src: Any, max_frames: int | None, progress: bool) -> Any:
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


class DetectionCuts:
    """Scene cuts seen in the detections: an edited clip of the same floor (a white
    arena), where registration sees no jump, but every animal is somewhere else.

    A frame starts a new scene when under ``low`` of its detections lie within a
    track's reach of one frame (``Tracker.step_px``) of a detection in the frame
    before, where that share has been at least ``usual`` (median of the last
    ``history`` frames), both frames holding at least ``min_dets`` detections.
    Walking animals keep nearly all their detections within that reach (a drawn clip
    of 66 ants at 30 frames/s: 0.97-1.0 a frame); a cut leaves only chance neighbours.
    """

    def __init__(
        self, low: float = 0.3, usual: float = 0.8, min_dets: int = 8, history: int = 15
    ) -> None:
        self.low, self.usual, self.min_dets, self.history = low, usual, min_dets, history
        self._prev: np.ndarray | None = None
        self._shares: collections.deque[float] = collections.deque(maxlen=history)

    def check(self, points: np.ndarray, reach_px: float | None) -> bool:
        """Whether the frame of body points ``points`` ``(n, 2)`` px starts a new scene."""
        from scipy.spatial import cKDTree

        prev, self._prev = self._prev, points
        if prev is None or not reach_px or min(len(prev), len(points)) < self.min_dets:
            return False
        d, _ = cKDTree(prev).query(points, distance_upper_bound=reach_px)
        share = float(np.mean(np.isfinite(d)))
        cut = share < self.low and len(self._shares) >= 5
        cut = cut and float(np.median(self._shares)) >= self.usual
        if cut:
            self._shares.clear()
        self._shares.append(share)
        return cut


def detect_and_associate(
    video: Any,
    frames: Any,
    det: Any,
    tracker: Tracker,
    writer: Any,
    takes_hints: bool,
    cuts: tuple[set[int], int] = (set(), 0),
    found_cuts: list[int] | None = None,
) -> tuple[int, np.ndarray]:
    """Detect each frame, associate its detections with the tracks, draw final frames.

    At a scene cut (``cuts``: the 0-based frames that start a new scene, and how many
    frames the detector's new background is learned from) every track ends and the
    detector learns the new scene's background (its ``rebase``, where it has one).
    Cuts seen in the detections alone (:class:`DetectionCuts`) end every track too;
    their 0-based frames are appended to ``found_cuts``.
    Returns the number of detections and their MOT rows; :class:`InputError` when no
    frame is decoded or nothing is detected.  The overlay is closed here (aborted on
    any error), as the tracker's lag means the last frames are drawn after the loop.
    """
    ring: collections.deque[tuple[int, np.ndarray]] = collections.deque()
    det_rows = []
    n_det = 0
    k = -1
    rebase = getattr(det, "rebase", None)
    watch = DetectionCuts()
    try:
        for k, frame, ahead in _with_cuts(frames, *cuts):
            if ahead is not None:
                tracker.cut()
                if rebase is not None:
                    rebase(ahead)
            hints = tracker.predict()
            d = det.detect(frame, hints=hints) if takes_hints else det.detect(frame)
            if watch.check(d.points[:, 1, :], getattr(tracker, "step_px", None)):
                tracker.cut()
                if found_cuts is not None:
                    found_cuts.append(k)
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


def write_video_outputs(
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
    ``scale`` (:func:`build_detector`'s), ``dets`` (MOT detection rows), ``n_det``,
    ``rate`` (frames/s), ``camera`` (the camera's record) and, for a photo series,
    ``series`` (its record: ``summary.json``'s ``photo_series``); ``timing`` is
    ``(elapsed, prepare)`` in s; ``overlay`` says overlay.mp4 was written.
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
        prepare_step=scale.get("prepare_step"),
        background=scale.get("background"),
        moved_length_px=scale.get("moved_length_px"),
        picture_length_px=scale.get("picture_length_px"),
        space_unit="mm" if px_per_mm is not None else "px",
        camera=run["camera"],
        photo_series=run.get("series"),
    )
    summary["outputs"][-1:-1] = run["camera"]["outputs"]
    reasons, summary["warnings"] = _warnings(result, out, run, tracker, str(det_name))
    atomic_write_json(out / "summary.json", summary)
    if reasons:
        refuse_flood(str(video), out, reasons)
    return summary


def _warnings(
    result: TrackResult, out: Path, run: dict[str, Any], tracker: TrackerConfig, det_name: str
) -> tuple[list[str], list[str]]:
    """``(flood reasons, warnings)`` of a run (``run`` as for :func:`write_video_outputs`),
    the warnings also written to ``out/WARNING.txt``: a flood's reasons, else no track
    confirmed, or for a photo series whose photos are not linked, its note (a stale
    ``WARNING.txt`` removed when there is none).

    A photo series is checked as ``detect`` checks it, for crowding only: the stillness
    check compares detections one second apart, which photos far apart are not."""
    dets, rate, series = run["dets"], run["rate"], run.get("series")
    per_frame = np.bincount(dets[:, 0].astype(np.int64) - 1, minlength=result.n_frames)
    classical = det_name == "classical" and series is None
    # Finds what moves (against a background learned over time, not the picture's own).
    still_bg = classical and run["scale"].get("background", "time") == "time"
    look = still_look_warning(run["scale"]) if classical else None
    length = run["scale"]["length_px"]
    reasons = flood_reasons(
        per_frame, run["src"].size, length, dets if still_bg else None, fps=rate
    )
    if reasons:
        return reasons, reasons
    if series is not None and not series["linked"]:
        (out / "WARNING.txt").unlink(missing_ok=True)  # an earlier run's
        return [], add_warning(out, series["note"])
    warned = warn_no_track(result.n_tracks, per_frame, rate, tracker, out)
    if still_bg and result.n_tracks:
        det = result.scores > 0  # tracked and detected there
        per = np.bincount(result.frames[det], minlength=result.n_frames)
        ins = inner_ends(result.ids[det], result.frames[det], result.points[det, 1],
                         run["src"].size, length)  # fmt: skip
        warned += add_warning(out, few_found_warning(per, ins))
    return [], warned + add_warning(out, look)
