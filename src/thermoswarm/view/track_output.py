"""A ``thermoswarm track --out`` folder, for drawing over its source video.

The folder holds ``summary.json`` (the source video's path, ``px_per_mm``, ``fps``,
frame size), ``tracks.nc`` (head/body/tail in mm, one individual ``track_<id>`` per
track) and ``tracks_mot.txt`` (the boxes in px, frames numbered from ``first_frame``,
1 for videos).  Positions are shown in video pixels (mm times ``px_per_mm``).

Events to jump to: a track that ends before the last frame was *lost*; a track that
starts after the first frame is *new*; a new track that starts near where another was
lost shortly before (within two body lengths and the tracker's gap) is flagged as a
*possible id switch*, the frames a user checks first.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.errors import InputError
from thermoswarm.view.data import ViewData, check_dataset

__all__ = ["open_track_output", "track_events"]


def _summary(path: Path) -> dict[str, Any]:
    try:
        summary = json.loads((path / "summary.json").read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputError(f"{path / 'summary.json'}: unreadable ({type(exc).__name__})") from None
    if not isinstance(summary, dict):
        raise InputError(f"{path / 'summary.json'}: expected a JSON object")
    return summary


def _find_video(path: Path, summary: dict[str, Any], video: str | Path | None) -> Path | None:
    """The source video: ``--video``, else summary's ``source`` as given, or beside OUT."""
    if video is not None:
        v = Path(video)
        if not v.exists():
            raise InputError(f"--video {v}: no such file or directory")
        return v
    src = summary.get("source")
    if not isinstance(src, str) or not src:
        return None
    s = Path(src)
    for cand in (s, path / s, path.parent / s, path / s.name, path.parent / s.name):
        if cand.exists():
            return cand
    return None


def _mot_boxes(path: Path, first_frame: int, ids: dict[int, int]) -> dict[int, list[list[float]]]:
    """Boxes by 0-based frame: ``[individual index, x, y, w, h]`` px."""
    mot = path / "tracks_mot.txt"
    if not mot.is_file() or mot.stat().st_size == 0:
        return {}
    try:
        rows = np.loadtxt(mot, delimiter=",", ndmin=2)
    except ValueError as exc:
        raise InputError(f"{mot}: not a MOTChallenge table ({exc})") from None
    out: dict[int, list[list[float]]] = {}
    for r in rows:
        k = int(r[0]) - first_frame
        col = ids.get(int(r[1]))
        if col is not None:
            out.setdefault(k, []).append([float(col), *(round(float(x), 2) for x in r[2:6])])
    return out


def track_events(
    centre: np.ndarray, *, max_gap: int, near: float, ids: list[str]
) -> list[dict[str, Any]]:
    """Frames where ids are lost, new, or possibly switched.

    Parameters
    ----------
    centre
        ``(T, 2, N)`` reference positions (px), NaN where a track is absent.
    max_gap
        Frames between a loss and a new id that may still be the same animal.
    near
        Distance (px) under which a new id near a lost one is a possible switch.
    ids
        Names of the N individuals.
    """
    present = np.isfinite(centre).all(axis=1)  # (T, N)
    T = present.shape[0]
    events: list[dict[str, Any]] = []
    lost = []
    for i in range(present.shape[1]):
        idx = np.flatnonzero(present[:, i])
        if idx.size == 0:
            continue
        first, last = int(idx[0]), int(idx[-1])
        if last < T - 1:
            events.append({"frame": last, "kind": "lost", "id": ids[i], "index": i})
            lost.append((last, centre[last, :, i]))
        if first > 0:
            kind = "new"
            for k, p in lost:
                if 0 <= first - k <= max_gap and np.hypot(*(centre[first, :, i] - p)) < near:
                    kind = "switch?"
            events.append({"frame": first, "kind": kind, "id": ids[i], "index": i})
    events.sort(key=lambda e: (e["frame"], e["kind"], e["id"]))
    return events


def open_track_output(path: Path, *, video: str | Path | None = None) -> ViewData:
    """A :class:`~thermoswarm.view.data.ViewData` of a ``track`` output folder."""
    from thermoswarm.io import read_tracks

    summary = _summary(path)
    nc = path / "tracks.nc"
    if not nc.is_file():
        raise InputError(f"{path}: a track output folder without tracks.nc")
    ds = check_dataset(read_tracks(nc), nc)
    scale = summary.get("px_per_mm") or ds.attrs.get("px_per_mm")
    if not isinstance(scale, (int, float)) or not scale > 0:
        raise InputError(f"{path / 'summary.json'}: px_per_mm missing; cannot place the tracks")
    data = ViewData(ds=ds, kind="track", title=str(path), scale=float(scale))
    names = [str(x) for x in ds["individuals"].values]
    ids = {}
    for col, name in enumerate(names):
        tail = name.rsplit("_", 1)[-1]
        if tail.isdigit():
            ids[int(tail)] = col
    first = int(ds.attrs.get("first_frame", 1))
    data.boxes = _mot_boxes(path, first, ids)
    vpath = _find_video(path, summary, video)
    if vpath is None:
        data.notes.append(
            f"source video {summary.get('source')!r} not found: tracks drawn without it "
            "(pass --video PATH)"
        )
    else:
        from thermoswarm.view.video import VideoFrames

        data.video = VideoFrames(vpath)
    fps = float(summary.get("fps") or ds.attrs.get("fps") or 1.0)
    gap = (summary.get("tracker") or {}).get("max_gap_s", 1.0)
    pos = ds["position"].transpose("time", "keypoints", "space", "individuals").values
    kps = data.keypoints
    centre = pos[:, kps.index("body")] if "body" in kps else np.nanmean(pos, axis=1)
    lengths = np.hypot(*(pos[:, 0] - pos[:, -1]).transpose(1, 0, 2)) if len(kps) > 1 else []
    body = float(np.nanmedian(lengths)) if np.isfinite(lengths).any() else 3.0
    data.events = track_events(
        centre * scale, max_gap=max(1, int(round(float(gap) * fps))), near=2 * body * scale,
        ids=names,
    )  # fmt: skip
    return data
