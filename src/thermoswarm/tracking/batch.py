"""A lab's batch: many videos tracked by one command, on the executors of ``sweep``.

:func:`track_batch` tracks every video of a list into ``OUT/<name>/`` (one folder per
video, the files of :func:`~thermoswarm.tracking.pipeline.track_video`) through the
same executors as a parameter sweep: the default
:class:`~thermoswarm.sweep.pool.LocalPool` (:func:`thermoswarm.sweep.local_pool`,
a crashed worker fails only its own video) or a Dask executor
(:func:`thermoswarm.sweep.cluster.dask_client`).

Restarts.  Each video's folder gets ``done.json`` last, written atomically, holding a
*key*: a hash of the video's absolute path, size and modification time, of every
tracking option and of the package version.  A re-run skips a video whose marker
holds the same key, so a changed video or changed options track it again.  A video
that fails with a one-line input error (a corrupt file, nothing detected) gets
``failed.json`` with its key and message: a re-run reports it again without redoing
the work (``retry_failed`` or a changed key tries again).  Other failures (a crash, a
worker that died twice) are not remembered: the next run tries again.

Results: ``OUT/batch.json`` (one record per video: status ``done``, ``skipped`` or
``failed``, the error line, frames and tracks; counts), rewritten atomically as
videos finish.  ``thermoswarm analyze OUT`` reads the finished videos of such a
folder as one study (:func:`expand_batch_dirs`), each video on its own clock.

This module imports only the standard library at import time (it is read by the CLI
before any heavy import).
"""

from __future__ import annotations

import hashlib
import json
import os
import queue
import traceback
from collections.abc import Callable, Sequence
from concurrent.futures import Executor, Future
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from thermoswarm.errors import InputError, ThermoswarmError
from thermoswarm.fsutil import atomic_write_json, check_output_dir

__all__ = [
    "VIDEO_EXTS",
    "LIST_EXTS",
    "VideoRecord",
    "find_videos",
    "is_batch_input",
    "track_batch",
    "track_one",
    "expand_batch_dirs",
]

#: File name endings taken as videos when a folder is listed.
VIDEO_EXTS = (".mp4", ".avi", ".mov", ".mkv", ".m4v", ".mpg", ".mpeg", ".webm", ".wmv")
#: File name endings of list files: one video (file or frame folder) per line.
LIST_EXTS = (".txt", ".list", ".lst")
DONE, FAILED, SUMMARY = "done.json", "failed.json", "batch.json"


@dataclass
class VideoRecord:
    """One video of a batch and what became of it in this run."""

    video: str
    out: str
    key: str
    status: str = "pending"  # done | skipped | failed
    error: str | None = None
    n_frames: int | None = None
    n_tracks: int | None = None
    attempts: int = 0


def _videos_in(folder: Path) -> list[Path]:
    return sorted(p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in VIDEO_EXTS)


def is_batch_input(paths: Sequence[Path]) -> bool:
    """Several paths, a list file or a folder that holds video files (not frames)."""
    if len(paths) != 1:
        return len(paths) > 1
    p = Path(paths[0])
    if p.is_file():
        return p.suffix.lower() in LIST_EXTS
    return p.is_dir() and bool(_videos_in(p))


def _read_list(path: Path) -> list[Path]:
    """Lines of a list file: paths relative to the list's folder; ``#`` comments."""
    try:
        lines = path.read_text().splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read the list of videos ({exc})") from None
    items = [s.strip() for s in lines]
    out = [path.parent / s for s in items if s and not s.startswith("#")]
    for n, p in enumerate(out, 1):
        if not p.exists():
            raise InputError(f"{path}: entry {n} {str(p)!r}: no such file or directory")
    return out


def find_videos(paths: Sequence[str | os.PathLike]) -> list[Path]:
    """The videos that ``paths`` name: video files, frame folders, list files
    (:data:`LIST_EXTS`) and folders of video files (:data:`VIDEO_EXTS`), in order,
    each once."""
    found: list[Path] = []
    for p in map(Path, paths):
        if not p.exists():
            raise InputError(f"{p}: no such file or directory")
        if p.is_file() and p.suffix.lower() in LIST_EXTS:
            found += _read_list(p)
        elif p.is_dir() and _videos_in(p):
            found += _videos_in(p)
        else:
            found.append(p)
    unique = list(dict.fromkeys(Path(os.path.abspath(p)) for p in found))  # "a/../b" once
    if not unique:
        raise InputError(f"{', '.join(map(str, paths))}: no videos found")
    return unique


def _out_names(videos: list[Path]) -> list[str]:
    """One folder name per video: its stem, with a hash of its path where stems clash."""
    stems = [v.stem if v.suffix else v.name for v in videos]
    return [
        s if stems.count(s) == 1 else f"{s}-{hashlib.sha1(str(v).encode()).hexdigest()[:8]}"
        for s, v in zip(stems, videos, strict=True)
    ]


def _stat_id(path: Path) -> list:
    st = path.stat()
    return [str(path.absolute()), st.st_size, st.st_mtime_ns]


def video_key(video: Path, options: dict[str, Any]) -> str:
    """Hash of the video (path, size, mtime), the options and the package version."""
    from thermoswarm import __version__

    ident: dict[str, Any] = {"options": options, "version": __version__}
    if video.is_dir():  # a folder of frames: its frames' names, sizes and times
        ident["video"] = [_stat_id(p) for p in sorted(video.iterdir()) if p.is_file()]
    else:
        ident["video"] = _stat_id(video)
    if options.get("model"):
        ident["model"] = _stat_id(Path(options["model"]))
    text = json.dumps(ident, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _marker_key(path: Path) -> str | None:
    try:
        return json.loads(path.read_text()).get("key")
    except (OSError, ValueError, AttributeError):
        return None


def track_one(video: str, out: str, options: dict[str, Any], key: str, attempt: int = 1) -> dict:
    """Track one video into ``out`` (on a worker); write ``done.json`` last.

    ``options`` are :func:`~thermoswarm.tracking.pipeline.track_video`'s keywords with
    ``tracker`` a mapping of :class:`~thermoswarm.tracking.track.tracker.TrackerConfig`
    fields.  ``attempt`` only makes repeated calls distinct (Dask merges equal calls).
    Returns the frame and track counts.
    """
    from thermoswarm.config import from_mapping
    from thermoswarm.tracking.pipeline import track_video
    from thermoswarm.tracking.track.tracker import TrackerConfig

    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)  # holds failed.json if the video is bad
    for name in (DONE, FAILED):  # stale markers go first: a crash leaves none
        (folder / name).unlink(missing_ok=True)
    kw = dict(options)
    tcfg = from_mapping(TrackerConfig, kw.pop("tracker", {}), source="tracker options")
    try:
        summary = track_video(video, folder, tracker_config=tcfg, progress=False, **kw)
    except ThermoswarmError as exc:
        atomic_write_json(folder / FAILED, {"key": key, "video": video, "error": str(exc)})
        raise
    result = {"n_frames": summary["n_frames"], "n_tracks": summary["n_tracks"]}
    atomic_write_json(folder / DONE, {"key": key, "video": video, **result})
    return result


def _plan(
    videos: list[Path], out: Path, options: dict[str, Any], retry_failed: bool
) -> list[VideoRecord]:
    records = []
    for v, name in zip(videos, _out_names(videos), strict=True):
        folder = out.absolute() / name
        rec = VideoRecord(str(v), str(folder), video_key(v, options))
        if _marker_key(folder / DONE) == rec.key:
            rec.status = "skipped"
        elif not retry_failed and _marker_key(folder / FAILED) == rec.key:
            rec.status = "failed"
            rec.error = json.loads((folder / FAILED).read_text()).get("error")
        records.append(rec)
    return records


def _error_line(exc: BaseException) -> str:
    from thermoswarm.sweep.run import _worker_lost

    if isinstance(exc, ThermoswarmError):
        return str(exc).splitlines()[0]
    if _worker_lost(exc):
        return f"worker lost: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}"
    return "".join(traceback.format_exception_only(exc)).strip().splitlines()[-1]


def _write_summary(out: Path, records: list[VideoRecord], counts: dict[str, int]) -> None:
    atomic_write_json(out / SUMMARY, {"counts": counts, "videos": [asdict(r) for r in records]})


def _counts(records: list[VideoRecord], tracked: int) -> dict[str, int]:
    c = {s: sum(r.status == s for r in records) for s in ("done", "skipped", "failed")}
    return {"videos": len(records), **c, "tracked": tracked}


def _executor(executor: Executor | Any | None, n_todo: int, max_workers: int | None
              ) -> tuple[Any, bool]:  # fmt: skip
    """The executor that tracks the videos and whether it is the batch's own (a local
    pool, made when none is given and there is work; shut down at the end)."""
    from thermoswarm.sweep import local_pool

    if hasattr(executor, "get_executor"):  # a dask.distributed.Client
        executor = executor.get_executor()
    own = executor is None and bool(n_todo)
    n = max_workers or min(os.cpu_count() or 1, max(1, n_todo))
    return (local_pool(n) if own else executor), own


def _settle(
    fut: Future,
    rec: VideoRecord,
    retries: int,
    on_failure: Callable[[VideoRecord], None] | None,
) -> bool:
    """Record a finished video's result in ``rec``; true when it is to be tried again
    (its worker died and it has attempts left)."""
    try:
        res = fut.result()
    except Exception as exc:
        from thermoswarm.sweep.run import _worker_lost

        rec.error = _error_line(exc)
        if _worker_lost(exc) and rec.attempts <= retries:
            return True
        rec.status = "failed"
        if on_failure is not None:
            on_failure(rec)
    else:
        rec.status, rec.error = "done", None
        rec.n_frames, rec.n_tracks = res["n_frames"], res["n_tracks"]
    return False


def track_batch(
    videos: Sequence[str | os.PathLike],
    out: str | os.PathLike,
    options: dict[str, Any] | None = None,
    executor: Executor | Any | None = None,
    *,
    max_workers: int | None = None,
    retries: int = 1,
    retry_failed: bool = False,
    on_failure: Callable[[VideoRecord], None] | None = None,
) -> list[VideoRecord]:
    """Track every video of ``videos`` into ``out/<name>/``; return one record each.

    Parameters
    ----------
    videos : sequence of paths
        Video files, frame folders, list files or folders of videos (:func:`find_videos`).
    out : path
        Batch folder: one sub-folder per video (named after it) and ``batch.json``.
    options : dict, optional
        Keywords of :func:`~thermoswarm.tracking.pipeline.track_video` (JSON values;
        ``tracker``: a mapping of tracker options); they are part of each video's key.
    executor : Executor or dask.distributed.Client, optional
        Default: a :func:`~thermoswarm.sweep.local_pool` of ``max_workers`` processes
        (default: the number of cores, at most one per video).
    retries : int
        Further attempts of a video whose worker died (input errors are not retried).
    retry_failed : bool
        Track again the videos whose input error is recorded under the same key.
    on_failure : callable, optional
        Called with each failed record as it fails (the CLI prints it).
    """
    out = check_output_dir(out)
    options = dict(options or {})
    records = _plan(find_videos(videos), out, options, retry_failed)
    out.mkdir(parents=True, exist_ok=True)
    todo = [r for r in records if r.status == "pending"]
    for r in records:
        if r.status == "failed" and on_failure is not None:
            on_failure(r)
    ex, own = _executor(executor, len(todo), max_workers)
    finished: queue.SimpleQueue[Future] = queue.SimpleQueue()
    futures: dict[Future, VideoRecord] = {}

    def submit(rec: VideoRecord) -> None:
        rec.attempts += 1
        try:
            fut = ex.submit(track_one, rec.video, rec.out, options, rec.key, rec.attempts)
        except Exception as exc:  # e.g. an executor that refuses work
            fut = Future()
            fut.set_exception(exc)
        futures[fut] = rec
        fut.add_done_callback(finished.put)

    tracked, clean = 0, False
    try:
        for rec in todo:
            submit(rec)
        while futures:
            try:
                fut = finished.get(timeout=1.0)  # a timeout lets Ctrl-C through
            except queue.Empty:
                continue
            rec = futures.pop(fut)
            if _settle(fut, rec, retries, on_failure):
                submit(rec)
                continue
            tracked += rec.status == "done"
            _write_summary(out, records, _counts(records, tracked))
        clean = True
    finally:
        if own:  # interrupted: do not wait for the videos in flight
            ex.shutdown(wait=clean, cancel_futures=True)
    _write_summary(out, records, _counts(records, tracked))
    return records


def batch_tracks(folder: Path) -> list[Path] | None:
    """The ``tracks.nc`` of the finished videos of batch folder ``folder``, or None if
    ``folder`` is not a batch folder (it has no ``batch.json``)."""
    if not (folder.is_dir() and (folder / SUMMARY).is_file()):
        return None
    found = sorted(
        d / "tracks.nc"
        for d in folder.iterdir()
        if (d / DONE).is_file() and (d / "tracks.nc").is_file()
    )
    if not found:
        raise InputError(f"{folder}: batch folder holds no finished video (no {DONE})")
    return found


def expand_batch_dirs(paths: Sequence[Path]) -> list[Path]:
    """``paths`` with every batch folder replaced by its finished videos' tracks."""
    out: list[Path] = []
    for p in map(Path, paths):
        out += batch_tracks(p) or [p]
    return out
