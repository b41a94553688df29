"""SLEAP: labels/predictions (``.slp``, via sleap-io) and analysis HDF5 (``.h5``).

Analysis HDF5 (``sleap-convert --format analysis``, ``sleap_io.save_analysis_h5``)
is read with h5py directly, vectorised:

``tracks``        (n_tracks, 2, n_nodes, n_frames) in pixels -- SLEAP's "matlab" order;
                  sleap-io may store another order and records it in the ``dims``
                  attribute (e.g. ``["frame", "track", "node", "xy"]``), which is honoured
``point_scores``  per-node scores (same order without ``xy``) -> ``confidence``
``node_names``    keypoint names; ``track_names`` individual names (empty: one
                  individual, ``id_0``)

``.slp`` files are read with ``sleap_io.load_slp`` (extra ``io``); user-labelled
instances are preferred to predictions of the same track (``user_instances``), and
frames are numbered from 0 as in the video.  Neither format stores the frame rate,
and positions are pixels: both need ``--fps`` and ``--px-per-mm``.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.errors import InputError
from thermoswarm.io._common import (
    check_frame_span,
    check_integers,
    check_options,
    check_unique_frames,
    decode_names,
    h5_file,
    h5_read,
    option_bool,
    option_int,
    require_fps,
    require_px_per_mm,
    unique_names,
)
from thermoswarm.tracks import make_tracks

OPTIONS = {
    "video": "index of the video to read from a .slp with several videos (default 0)",
    "user_instances": "prefer user-labelled instances over predictions in a .slp (default true)",
    "untracked": "in a .slp without tracks, take instances in each frame in file order "
    "(default false: only tracked instances, or the single instance)",
}
NEEDS = "--fps and --px-per-mm (SLEAP stores neither)"

_CANON = ("frame", "track", "node", "xy")
_LEGACY_NOT_TRANSPOSED = ("frame", "node", "xy", "track")


def sniff(path: Path) -> bool:
    if path.suffix.lower() == ".slp":
        return True
    import h5py

    try:
        with h5py.File(path, "r") as fh:
            return "tracks" in fh and "node_names" in fh
    except Exception:
        return False


def _dims(path: Path, fh: Any, name: str, ndim: int) -> tuple[str, ...]:
    """Dimension names of dataset ``name``: its ``dims`` attribute, else SLEAP's order."""
    raw = fh[name].attrs.get("dims")
    if raw is not None:
        try:
            dims = tuple(json.loads(raw if isinstance(raw, str) else raw.decode()))
        except (ValueError, AttributeError):
            raise InputError(f"{path}: unreadable 'dims' attribute on {name!r}") from None
        if len(dims) != ndim or not set(dims) <= set(_CANON):
            raise InputError(f"{path}: 'dims' of {name!r} is {dims}, expected {ndim} of {_CANON}")
        return dims
    transposed = bool(fh.attrs.get("transpose", True))
    order = ("track", "xy", "node", "frame") if transposed else _LEGACY_NOT_TRANSPOSED
    if name == "tracks":
        return order
    return tuple(d for d in order if d != "xy")


def _to_canon(arr: np.ndarray, dims: tuple[str, ...]) -> np.ndarray:
    want = [d for d in _CANON if d in dims]
    return np.transpose(arr, [dims.index(d) for d in want])


def _read_analysis(path: Path, scale: float, fps: float) -> xr.Dataset:
    with h5_file(path, "SLEAP analysis") as fh:
        tracks = h5_read(path, fh, "tracks")
        if tracks.ndim != 4 or tracks.dtype.kind not in "fiu":
            raise InputError(f"{path}: 'tracks' must be a 4-D numeric array, got {tracks.shape}")
        dims = _dims(path, fh, "tracks", 4)
        tracks = _to_canon(tracks, dims).astype(np.float64)  # (frame, track, node, xy)
        if tracks.shape[3] != 2:
            raise InputError(f"{path}: 'tracks' has {tracks.shape[3]} coordinates, expected 2")
        scores = None
        if "point_scores" in fh:
            raw = h5_read(path, fh, "point_scores")
            sdims = tuple(d for d in dims if d != "xy")
            if "dims" in fh["point_scores"].attrs:
                sdims = _dims(path, fh, "point_scores", 3)
            if raw.ndim != 3:
                raise InputError(f"{path}: 'point_scores' must be 3-D, got {raw.shape}")
            scores = _to_canon(raw, sdims).astype(np.float32)  # (frame, track, node)
            if scores.shape != tracks.shape[:3]:
                raise InputError(
                    f"{path}: point_scores shape {scores.shape} does not match tracks "
                    f"{tracks.shape[:3]}"
                )
        nodes = unique_names(path, decode_names(h5_read(path, fh, "node_names")), "node")
        track_names = decode_names(fh["track_names"][()]) if "track_names" in fh else []
        video = fh["video_path"][()] if "video_path" in fh else b""
    n_frames, n_tracks, n_nodes, _ = tracks.shape
    if len(nodes) != n_nodes:
        raise InputError(f"{path}: {len(nodes)} node names for {n_nodes} nodes")
    if not track_names:
        track_names = [f"id_{i}" for i in range(n_tracks)]
    if len(track_names) != n_tracks:
        raise InputError(f"{path}: {len(track_names)} track names for {n_tracks} tracks")
    names = unique_names(path, track_names, "track")
    pos = np.transpose(tracks, (0, 3, 2, 1)) / scale  # (frame, xy, node, track)
    conf = None if scores is None else np.transpose(scores, (0, 2, 1))
    attrs = {"px_per_mm": scale, "source_space_unit": "px"}
    video = video.decode("utf-8", "replace") if isinstance(video, bytes) else str(video)
    if video:
        attrs["video_path"] = video
    return make_tracks(
        pos,
        fps=fps,
        individuals=names,
        keypoints=nodes,
        confidence=conf,
        source_software="SLEAP",
        source_file=str(path),
        attrs=attrs,
    )


def _read_slp(path: Path, scale: float, fps: float, options: dict[str, Any]) -> xr.Dataset:
    try:
        import sleap_io
    except ImportError:
        raise InputError(
            f"{path}: reading .slp needs sleap-io: pip install 'thermoswarm[io]'"
        ) from None
    video = option_int(path, "video", options.get("video", 0), minimum=0)
    user = option_bool(path, "user_instances", options.get("user_instances", True))
    untracked = option_bool(path, "untracked", options.get("untracked", False))
    try:
        try:
            labels = sleap_io.load_slp(str(path), open_videos=False, lazy=True)
        except TypeError:  # sleap-io before lazy loading
            labels = sleap_io.load_slp(str(path), open_videos=False)
    except Exception as exc:  # h5py/sleap-io raise many types for a damaged file
        raise InputError(
            f"{path}: not a readable SLEAP .slp file ({type(exc).__name__})"
        ) from None
    if not labels.videos:
        raise InputError(f"{path}: no videos (and so no frames) in this .slp")
    if video >= len(labels.videos):
        raise InputError(f"{path}: video {video} requested, the file has {len(labels.videos)}")
    if not labels.skeletons:
        raise InputError(f"{path}: no skeleton in this .slp")
    if len(labels.skeletons) > 1:
        raise InputError(f"{path}: {len(labels.skeletons)} skeletons; one is supported")
    if len(labels) == 0:
        raise InputError(f"{path}: no labelled frames")
    lazy = bool(getattr(labels, "is_lazy", False))
    first = _first_frame(path, video, from_zero=not lazy)
    with warnings.catch_warnings():
        # sleap-io returns float32: a position beyond its range becomes inf, which the
        # final check counts as non-finite (n_nonfinite_positions) instead of a warning
        warnings.filterwarnings("ignore", "overflow encountered in cast", RuntimeWarning)
        arr = labels.numpy(
            video=video, untracked=untracked, return_confidence=True, user_instances=user
        )  # (frame, track, node, 3) from the first labelled frame (lazy) or frame 0
    nodes = unique_names(path, labels.skeletons[0].node_names, "node")
    if labels.tracks and not untracked:
        names = unique_names(
            path, [t.name or f"track_{i}" for i, t in enumerate(labels.tracks)], "track"
        )
    else:
        names = [f"id_{i}" for i in range(arr.shape[1])]
    pos = np.transpose(arr[..., :2].astype(np.float64), (0, 3, 2, 1)) / scale
    conf = np.transpose(arr[..., 2].astype(np.float32), (0, 2, 1))
    attrs: dict[str, Any] = {"px_per_mm": scale, "source_space_unit": "px"}
    filename = getattr(labels.videos[video], "filename", "")
    if isinstance(filename, str) and filename:
        attrs["video_path"] = filename
    return make_tracks(
        pos,
        time=(first + np.arange(pos.shape[0])) / fps,  # frame f at f / fps, as in the video
        fps=fps,
        individuals=names,
        keypoints=nodes,
        confidence=conf,
        source_software="SLEAP",
        source_file=str(path),
        attrs=attrs,
    )


def _first_frame(path: Path, video: int, *, from_zero: bool) -> int:
    """The first row's frame number, after checking the frame numbers of ``video``.

    Lazy-loaded labels give rows from the first labelled frame, eager ones
    (``from_zero``, sleap-io before lazy loading) from frame 0.

    Read from the ``frames`` table with h5py before sleap-io builds its array, whose
    rows span every frame from the first to the last: one ``frame_idx`` of 1e11 would
    ask for terabytes, and two frames with one ``frame_idx`` would be merged silently.
    """
    with h5_file(path, "SLEAP .slp") as fh:
        table = h5_read(path, fh, "frames")
    names = table.dtype.names or ()
    if "frame_idx" not in names or "video" not in names:
        raise InputError(f"{path}: the 'frames' table has no frame_idx or video column")
    idx = check_integers(path, table["frame_idx"][table["video"] == video], "frame_idx")
    if idx.size == 0:
        raise InputError(f"{path}: no labelled frames in video {video}")
    if idx.min() < 0:
        raise InputError(f"{path}: negative frame_idx {int(idx.min())}")
    first = 0 if from_zero else int(idx.min())
    check_frame_span(path, [first, int(idx.max())], "frame_idx")
    check_unique_frames(path, idx, "frame_idx")
    return first


def read(
    path: Path, *, fps: float | None = None, px_per_mm: float | None = None, **options: Any
) -> xr.Dataset:
    """Read a SLEAP ``.slp`` or analysis ``.h5`` file (see the module docstring)."""
    check_options(path, "sleap", options, OPTIONS)
    rate = require_fps(path, fps, "SLEAP")
    scale = require_px_per_mm(path, px_per_mm, "SLEAP")
    if path.suffix.lower() == ".slp":
        return _read_slp(path, scale, rate, options)
    extra = sorted(k for k in options if k in ("video", "user_instances", "untracked"))
    if extra:
        raise InputError(f"{path}: option(s) {', '.join(extra)} apply to .slp files only")
    return _read_analysis(path, scale, rate)
