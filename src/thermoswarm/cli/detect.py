"""``thermoswarm detect``: videos, folders of frames or images -> COCO and MOT detections."""

from __future__ import annotations

from pathlib import Path

import click

from thermoswarm.errors import InputError


@click.command()
@click.argument("inputs", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option(
    "--out",
    "out_dir",
    required=True,
    type=click.Path(path_type=Path),
    help="Output folder (created with its parents).",
)
@click.option(
    "--model",
    type=click.Path(path_type=Path),
    help="Trained detector weights (selects the 'unet' detector).",
)
@click.option("--detector", help="Detector name (default: classical, or unet with --model).")
@click.option(
    "--px-per-mm",
    "px_per_mm",
    help="Image scale in px per mm, or 'paper' (3.04); default: the animals' size is "
    "measured from each input.",
)
@click.option(
    "--fps",
    type=float,
    help="Frame rate of folders and images (sets how many frames the detector learns "
    "the background from: 3 s; default the video's own, else 30, i.e. 90 images).",
)
@click.option(
    "--config",
    type=click.Path(dir_okay=False),
    help="TOML file with a [detector] table (and [tracker] for the box width).",
)
@click.option(
    "--set",
    "overrides",
    multiple=True,
    metavar="KEY=VALUE",
    help="Override an option, e.g. --set detector.polarity=light.",
)
@click.option(
    "--max-frames", type=click.IntRange(min=1), help="Detect at most this many frames per input."
)
@click.option(
    "--camera",
    type=click.Choice(["auto", "still", "moving"]),
    default="auto",
    show_default=True,
    help="auto: register video frames to the first when the camera moves (folders and "
    "images: still unless 'moving'); detections then in the first frame's px.",
)
@click.option(
    "--regions",
    help="Regions TOML (as `analyze --regions`; px, or mm with --px-per-mm), or "
    "color:HUE_LO-HUE_HI (coloured patches found in each photo, left and right; OpenCV "
    "hue 0-180; ,split=lr|tb|quad|none ,name=NAME, several colours joined by +): writes "
    "NAME_regions.csv (detections per frame and region) and, for photos, a picture each.",
)
@click.option(
    "--series",
    type=click.Choice(["auto", "yes", "no"]),
    default="auto",
    show_default=True,
    help="Photo series (photos a minute or more apart by their EXIF clocks or the times in "
    "their names, else consecutive photos as different as photos 8 apart; or 'yes'): "
    "detect in windows of 12 photos, in the order taken, each with its own background, "
    "with the options tuned on such photos.",
)
def detect(
    inputs: tuple[Path, ...],
    out_dir: Path,
    model: Path | None,
    detector: str | None,
    px_per_mm: str | None,
    fps: float | None,
    config: str | None,
    overrides: tuple[str, ...],
    max_frames: int | None,
    camera: str,
    regions: str | None,
    series: str,
) -> None:
    """Detect the animals in INPUTS (videos, folders of frames, images) into OUT.

    Writes OUT/NAME.json per input (COCO keypoints: boxes, scores, head/body/tail
    keypoints; the image files given form one sequence, NAME 'images'), OUT/NAME_det.txt
    for videos and folders (MOTChallenge detections) and OUT/summary.json.  The
    detectors are those of `thermoswarm track`; `thermoswarm track --detections
    OUT/NAME.json --fps F` tracks them.  The classical detector learns the background
    from the frames, so it needs several frames of one scene.
    """
    from thermoswarm.fsutil import require_input

    colour = regions is not None and regions.startswith(("color:", "colour:"))
    require_input(*inputs, None if colour else regions)  # before the heavy imports
    try:
        import cv2  # noqa: F401
    except ImportError:
        raise InputError("detection needs OpenCV: pip install 'thermoswarm[track]'") from None
    from thermoswarm.cli.track import _load_settings, check_body_px, check_rate
    from thermoswarm.io import resolve_px_per_mm
    from thermoswarm.tracking.detect.classical import NOTHING_FOUND_HINT
    from thermoswarm.tracking.pipeline import detect_inputs

    check_rate(fps, "--fps")
    scale = resolve_px_per_mm(px_per_mm) if px_per_mm is not None else None
    if scale is not None:
        check_body_px(scale)
    settings = _load_settings(config, overrides)
    width_bl = settings.get("tracker", {}).get("width_bl")
    unknown = set(settings.get("tracker", {})) - {"width_bl"}
    if unknown:
        raise InputError(f"detect takes only tracker.width_bl, got tracker.{sorted(unknown)[0]}")
    summary = detect_inputs(
        list(inputs),
        out_dir,
        px_per_mm=scale,
        detector=detector,
        model=model,
        detector_options=settings.get("detector"),
        fps=fps,
        max_frames=max_frames,
        width_bl=width_bl,
        camera=camera,
        regions=regions,
        series=series,
    )
    for r in summary["inputs"]:
        click.echo(
            f"{r['input']}: {r['n_frames']} frames, {r['n_detections']} detections "
            f"({r['detections_per_frame']:.1f}/frame, body length {r['length_px']:.1f} px, "
            f"{r['scale_source']}) -> {out_dir}/{r['outputs'][0]}"
        )
        if r["n_detections"] == 0:
            click.echo(
                f"warning: nothing detected in {r['input']}; {NOTHING_FOUND_HINT}", err=True
            )
