"""``thermoswarm track`` (video or detections -> trajectories) and ``thermoswarm evaluate``."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import click

from thermoswarm.errors import ConfigError, InputError

_SECTIONS = ("tracker", "detector")


def _load_settings(config: str | None, overrides: tuple[str, ...]) -> dict[str, Any]:
    """``[tracker]`` and ``[detector]`` tables from a TOML file and ``--set`` items."""
    from thermoswarm.config import apply_overrides, load_toml, parse_overrides

    data: dict[str, Any] = load_toml(config) if config else {}
    source = config or "--set"
    data = apply_overrides(data, parse_overrides(overrides))
    for key, value in data.items():
        if key not in _SECTIONS:
            raise ConfigError(
                f"{source}: unknown section {key!r}; expected one of: "
                + ", ".join(_SECTIONS)
                + " (e.g. --set tracker.max_gap_s=0.5)"
            )
        if not isinstance(value, dict):
            raise ConfigError(f"{source}: {key!r} must be a table of options")
    return data


@click.command()
@click.argument("videos", nargs=-1, type=click.Path(path_type=Path))
@click.option(
    "--out",
    "out_dir",
    required=True,
    type=click.Path(path_type=Path),
    help="Output folder (created with its parents); with many videos, one folder per video.",
)
@click.option(
    "--detections",
    type=click.Path(path_type=Path),
    help="Track another detector's boxes instead of a video: a MOTChallenge file, a "
    "folder of YOLO per-frame .txt files or a COCO JSON file.",
)
@click.option(
    "--det-format",
    type=click.Choice(["mot", "yolo", "coco"]),
    help="Format of --detections (default: a folder is yolo, .json is coco, else mot).",
)
@click.option(
    "--image-size",
    metavar="WxH|FILE",
    help="Image size for --detections, as 1920x1080 or a frame/video to read it from "
    "(needed by YOLO's normalised boxes).",
)
@click.option(
    "--first-frame",
    type=click.IntRange(0, 1),
    help="Number of the first frame of --detections, 0 or 1 (default: the file's first "
    "frame number); the tracks keep the file's numbering.",
)
@click.option(
    "--object-size-px",
    type=float,
    help="Length of the tracked objects in px, the tracker's unit (default: measured "
    "from the detections' boxes).",
)
@click.option(
    "--model",
    type=click.Path(path_type=Path),
    help="Trained detector weights (selects the 'unet' detector).",
)
@click.option(
    "--detector",
    help="Detector name (default: classical, or unet with --model); self-trained: a "
    "U-Net trained first on this video's animals as the classical detector tracks them, "
    "which finds them also where they stand still (a minute or two of training).",
)
@click.option(
    "--px-per-mm",
    "px_per_mm",
    help="Image scale in px per mm, or 'paper' (3.04).  Without it a video's animals "
    "are measured from the video and tracks.nc is in px (its space_unit says so).",
)
@click.option("--fps", type=float, help="Frame rate (default: the video's own).")
@click.option(
    "--config",
    type=click.Path(dir_okay=False),
    help="TOML file with [tracker] and [detector] tables.",
)
@click.option(
    "--preset",
    default="ants",
    show_default=True,
    help="Tracker settings to start from: ants (tuned on real ant boxes at 5-15 fps) or "
    "pedestrians (tuned on MOT15); --config and --set override single options.",
)
@click.option(
    "--set",
    "overrides",
    multiple=True,
    metavar="KEY=VALUE",
    help="Override an option, e.g. --set tracker.max_gap_s=0.5.",
)
@click.option(
    "--overlay/--no-overlay",
    default=True,
    show_default=True,
    help="Write overlay.mp4 with the tracks drawn on the video.",
)
@click.option(
    "--overlay-scale",
    type=float,
    default=1.0,
    show_default=True,
    help="Size of the overlay relative to the video (1: the video's resolution).",
)
@click.option("--max-frames", type=click.IntRange(min=1), help="Stop after this many frames.")
@click.option(
    "--series",
    type=click.Choice(["auto", "yes", "no"]),
    default="auto",
    show_default=True,
    help="A folder that is a photo series (as `detect --series`: photos a minute or more "
    "apart by their clocks or names, or as different from one photo to the next as 8 "
    "apart; or 'yes') is detected as `detect` does, and its photos are linked into tracks "
    "only when close enough in time (else per-photo detections and a warning); 'no': "
    "video frames at --fps.",
)
@click.option("--quiet", is_flag=True, help="No progress bar.")
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    help="Many videos: local worker processes (default: all cores).",
)
@click.option("--scheduler", metavar="ADDRESS", help="Many videos: the Dask scheduler to use.")
@click.option(
    "--cluster", metavar="local:N", help="Many videos: a Dask LocalCluster of N workers."
)
@click.option(
    "--retry-failed",
    is_flag=True,
    help="Many videos: track again those whose input error is recorded (failed.json).",
)
def track(**opts: Any) -> None:
    """Track the ants of VIDEO (a file or a folder of frames) into OUT.

    Many videos (several paths, a folder of video files or a list file .txt with one
    path per line) are tracked into OUT/<video name>/ on local worker processes or
    Dask (--workers, --cluster, --scheduler, as `sweep`); finished videos are skipped
    when run again; OUT/batch.json records each video; exit status 1 if one failed.

    Writes OUT/tracks.nc (trajectory format: mm with --px-per-mm, else px (attribute
    space_unit), s, keypoints head/body/tail),
    OUT/tracks_mot.txt (MOTChallenge), OUT/detections.txt, OUT/overlay.mp4 and
    OUT/summary.json.  With --detections, tracks another detector's boxes without a
    video (MOTChallenge, YOLO or COCO, e.g. what `thermoswarm detect` writes): the
    boxes written are the detections' own, frames keep their numbering, and tracks.nc
    is in px unless --px-per-mm is given.  The tracker's settings start from --preset
    (ants: tuned on real ant boxes; pedestrians: tuned on MOT15), then --config and
    --set tracker.KEY=VALUE.  A folder of photos taken a while apart (--series) is
    detected as `thermoswarm detect` detects it and tracked only where its photos are
    close enough in time for an ant to be followed; summary.json's photo_series says
    which.
    """
    o = opts
    videos, out_dir, detections = o["videos"], o["out_dir"], o["detections"]
    batch_only = (o["workers"], o["scheduler"], o["cluster"], o["retry_failed"])
    many = _check_inputs(videos, detections, batch_only=batch_only)
    if videos:
        _check_video_options(
            o["det_format"], o["image_size"], o["first_frame"], o["object_size_px"]
        )
    check_rate(o["fps"], "--fps")
    scale, settings, tcfg = _options(o["px_per_mm"], o["config"], o["overrides"], o["preset"])
    if videos and scale is not None:
        check_body_px(scale)
    video_opts = dict(
        px_per_mm=scale, fps=o["fps"], detector=o["detector"],
        detector_options=settings.get("detector"), overlay=o["overlay"],
        overlay_scale=o["overlay_scale"], max_frames=o["max_frames"], series=o["series"],
    )  # fmt: skip
    model = o["model"]
    if many:
        options = dict(video_opts, model=str(model) if model else None, tracker=tcfg)
        _run_batch(videos, out_dir, options, *batch_only)
        return
    if detections is not None:
        summary = _track_detections(
            detections,
            out_dir,
            px_per_mm=scale,
            fps=o["fps"],
            tracker_config=tcfg,
            settings=settings,
            uses_detector=model is not None or o["detector"] is not None or o["series"] != "auto",
            fmt=o["det_format"],
            image_size=o["image_size"],
            first_frame=o["first_frame"],
            object_size_px=o["object_size_px"],
        )
    else:
        from thermoswarm.tracking.pipeline import track_video

        summary = track_video(
            videos[0], out_dir, model=model, tracker_config=tcfg, progress=not o["quiet"],
            **video_opts,
        )  # fmt: skip
    _echo_summary(summary, out_dir)


#: The tracked objects' length in px: shorter, nothing can be detected or told apart.
MIN_BODY_PX, MAX_BODY_PX = 2.0, 1e5


def check_rate(fps: float | None, flag: str) -> float | None:
    """``None`` or a frame rate within the readers' range (``--fps 0``, ``1e308``,
    ``nan``: one-line errors naming ``flag``)."""
    from thermoswarm.io import check_fps

    try:
        return check_fps(Path(flag), fps, flag)
    except InputError as exc:  # "PATH: MESSAGE" without the path, which is the flag
        raise InputError(str(exc).split(": ", 1)[-1]) from None


def check_body_px(px_per_mm: float) -> None:
    """Refuse a scale at which an ant (:data:`~thermoswarm.tracking.anatomy.ANT_LENGTH_MM`)
    would be shorter than :data:`MIN_BODY_PX` or longer than :data:`MAX_BODY_PX`."""
    from thermoswarm.tracking.anatomy import ANT_LENGTH_MM

    length = ANT_LENGTH_MM * px_per_mm
    if not MIN_BODY_PX <= length <= MAX_BODY_PX:
        raise InputError(
            f"--px-per-mm {px_per_mm:g}: an ant ({ANT_LENGTH_MM:g} mm) would be {length:.3g} px "
            f"long; expected {MIN_BODY_PX:g} to {MAX_BODY_PX:g} px"
        )


def _check_inputs(
    videos: tuple[Path, ...], detections: Path | None, *, batch_only: tuple[Any, ...]
) -> bool:
    """Whether ``videos`` are many; :class:`InputError` for a missing input, both or
    neither of VIDEO and --detections, batch options on one video, or no OpenCV."""
    from thermoswarm.fsutil import require_input
    from thermoswarm.tracking.batch import is_batch_input

    if (not videos) == (detections is None):
        raise InputError("give either VIDEO or --detections DETS.txt (exactly one)")
    require_input(*videos, detections)  # before the heavy imports
    many = is_batch_input(videos)
    if not many and any(batch_only):
        raise InputError(
            "--workers, --scheduler, --cluster and --retry-failed apply to many videos "
            "(several paths, a folder of videos or a list file)"
        )
    if videos:
        try:
            import cv2  # noqa: F401
        except ImportError:
            raise InputError(
                "tracking videos needs OpenCV: pip install 'thermoswarm[track]'"
            ) from None
    return many


def _check_video_options(
    det_format: str | None,
    image_size: str | None,
    first_frame: int | None,
    object_size_px: float | None,
) -> None:
    """Refuse the options that apply to --detections only."""
    for name, value in (
        ("--det-format", det_format),
        ("--image-size", image_size),
        ("--first-frame", first_frame),
        ("--object-size-px", object_size_px),
    ):
        if value is not None:
            raise InputError(f"{name} applies to --detections, not to videos")


def _options(
    px_per_mm: str | None, config: str | None, overrides: tuple[str, ...], preset: str = "ants"
) -> tuple[float | None, dict[str, Any], Any]:
    """The scale (px/mm or ``None``), the settings tables and the tracker's config
    (preset ``preset``, then the ``[tracker]`` table and ``--set tracker.*``)."""
    from thermoswarm.config import from_mapping
    from thermoswarm.io import resolve_px_per_mm
    from thermoswarm.tracking.track.presets import PRESETS
    from thermoswarm.tracking.track.tracker import TrackerConfig

    if preset not in PRESETS:
        raise ConfigError(
            f"--preset: unknown preset {preset!r}; expected one of: {', '.join(PRESETS)}"
        )
    scale = resolve_px_per_mm(px_per_mm) if px_per_mm is not None else None
    settings = _load_settings(config, overrides)
    tcfg = from_mapping(
        TrackerConfig,
        {**PRESETS[preset], **settings.get("tracker", {})},
        source=config or "--set tracker",
    )
    return scale, settings, tcfg


def _track_detections(
    detections: Path,
    out_dir: Path,
    *,
    px_per_mm: float | None,
    fps: float | None,
    tracker_config: Any,
    settings: dict[str, Any],
    uses_detector: bool,
    fmt: str | None,
    image_size: str | None,
    first_frame: int | None,
    object_size_px: float | None,
) -> dict[str, Any]:
    """Check the --detections options and run
    :func:`~thermoswarm.tracking.pipeline.track_detection_file`; return its summary."""
    from thermoswarm.tracking.detect.files import parse_image_size
    from thermoswarm.tracking.pipeline import track_detection_file

    if uses_detector:
        raise InputError(
            "--model, --detector and --series apply to videos and folders, not to --detections"
        )
    if settings.get("detector"):
        raise InputError("[detector] options apply to videos, not to --detections")
    if fps is None:
        raise InputError(f"{detections}: detections have frame numbers only; pass --fps")
    lo, hi = MIN_BODY_PX, MAX_BODY_PX
    if object_size_px is not None and not lo <= object_size_px <= hi:
        raise InputError(f"--object-size-px must be a number from {lo:g} to {hi:g} (px), "
                         f"got {object_size_px!r}")  # fmt: skip
    return track_detection_file(
        detections,
        out_dir,
        px_per_mm=px_per_mm,
        fps=fps,
        tracker_config=tracker_config,
        fmt=fmt,
        image_size=parse_image_size(image_size) if image_size else None,
        first_frame=first_frame,
        length_px=object_size_px,
    )


def _echo_summary(summary: dict[str, Any], out_dir: Path) -> None:
    """Print one line: frames, tracks, detections per frame, speed and the main output;
    then each of the summary's warnings (e.g. no track confirmed) on stderr."""
    main = "tracks.nc" if "tracks.nc" in summary["outputs"] else "tracks_mot.txt"
    click.echo(
        f"{summary['n_frames']} frames, {summary['n_tracks']} tracks, "
        f"{summary['detections_per_frame']:.1f} detections/frame, "
        f"{summary['frames_per_second']:.1f} frames/s -> {out_dir}/{main}"
    )
    st = summary.get("self_training")
    if st:
        click.echo(
            f"self-trained on {len(st['label_frames'])} frames ({st['n_labels']} animals) in "
            f"{st['train_seconds']:.0f} s: {out_dir}/self_trained.pt; the classical pass: "
            f"{out_dir}/classical"
        )
    for text in summary.get("warnings") or []:
        click.echo(f"\nWARNING: {text}\n(also in {out_dir}/WARNING.txt)", err=True)


def _run_batch(
    videos: tuple[Path, ...],
    out: Path,
    options: dict[str, Any],
    workers: int | None,
    scheduler: str | None,
    cluster: str | None,
    retry_failed: bool,
) -> None:
    """Track many videos (:func:`thermoswarm.tracking.batch.track_batch`); print one
    JSON line of counts, one ``error:`` line per failed video; exit 1 if any failed.

    ``options`` are the per-video options, ``tracker`` a ``TrackerConfig``."""
    import json

    from thermoswarm.config import to_dict
    from thermoswarm.tracking.batch import track_batch

    options = {**options, "tracker": to_dict(options["tracker"])}  # plain data for workers
    if scheduler is not None and cluster is not None:
        raise ConfigError("give --scheduler or --cluster, not both")
    if workers is not None and (scheduler is not None or cluster is not None):
        raise ConfigError("--workers is for local processes; Dask brings its own workers")

    def report(rec: Any) -> None:  # one line that names the video once
        line = rec.error if rec.video in rec.error else f"{rec.video}: {rec.error}"
        click.echo(f"error: {line}", err=True)

    kw = {"retry_failed": retry_failed, "on_failure": report}
    if scheduler is None and cluster is None:
        records = track_batch(videos, out, options, max_workers=workers, **kw)
    else:
        from thermoswarm.sweep.cluster import dask_client, parse_cluster

        n_local = parse_cluster(cluster) if cluster is not None else None
        with dask_client(scheduler, local_workers=n_local) as client:
            records = track_batch(videos, out, options, client.get_executor(), **kw)
    counts = {s: sum(r.status == s for r in records) for s in ("done", "skipped", "failed")}
    click.echo(json.dumps({"out": str(out), "videos": len(records), **counts}))
    if counts["failed"]:
        raise SystemExit(1)


@click.command()
@click.argument("gt", type=click.Path(path_type=Path))
@click.argument("pred", type=click.Path(path_type=Path))
@click.option(
    "--iou", type=float, default=0.5, show_default=True, help="IoU threshold of a match."
)
@click.option(
    "--frame-offset",
    type=int,
    default=0,
    show_default=True,
    help="Score PRED's frame k + N as GT's frame k (files that count frames from "
    "different origins).",
)
def evaluate(gt: Path, pred: Path, iou: float, frame_offset: int) -> None:
    """Compare tracks PRED with ground truth GT (MOTChallenge files); print JSON.

    Keys: mota, motp, idf1, idp, idr, idsw, idsw_rate, fp, fn, tp, n_gt, n_pred,
    n_gt_ids, n_pred_ids, n_frames, precision, recall, mt, pt, ml, frag, iou_threshold,
    and hota, deta, assa, loca (means over IoU thresholds 0.05..0.95, as TrackEval).
    Frames may count from 0 or 1.  When PRED matches GT clearly better one or two
    frames off, a warning on stderr says so and names the --frame-offset to pass.
    """
    from thermoswarm.fsutil import require_input

    require_input(gt, pred)  # before the heavy imports
    from thermoswarm.fsutil import dumps_json
    from thermoswarm.tracking.evaluate import evaluate_files

    warnings: list[str] = []
    result = evaluate_files(gt, pred, iou=iou, frame_offset=frame_offset, warnings=warnings)
    for line in warnings:
        click.echo(f"warning: {line}", err=True)
    click.echo(dumps_json(result))
