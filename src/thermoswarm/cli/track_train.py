"""``thermoswarm track train`` (also ``thermoswarm track-train``): train the U-Net detector.

``track`` is a plain command whose argument is a video, so ``train`` cannot be its
sub-command in click's sense; the top-level group routes ``track train ...`` here (a
video file literally named ``train`` is tracked as ``thermoswarm track ./train``).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from thermoswarm.errors import InputError

if TYPE_CHECKING:
    from thermoswarm.tracking.train.fit import TrainConfig


@click.command("track-train")
@click.option(
    "--out",
    "out",
    required=True,
    type=click.Path(dir_okay=False, path_type=Path),
    help="Weights file to write (e.g. model.pt); the report goes to model.json.",
)
@click.option(
    "--synthetic",
    is_flag=True,
    help="Train on videos of the synthetic generator (validated by tracking a held-out one).",
)
@click.option(
    "--labels",
    multiple=True,
    type=click.Path(dir_okay=False, path_type=Path),
    help="Labelled frames: SLEAP .slp (images embedded or videos readable) or COCO "
    "keypoint .json; repeatable.",
)
@click.option(
    "--px-per-mm",
    "px_per_mm",
    help="Scale of the labelled images (px per mm, or 'paper' = 3.04); for --synthetic "
    "alone the generator's scale (default 3.04).",
)
@click.option(
    "--nodes",
    help="Skeleton nodes used as head,body,tail (default: by name, e.g. head,thorax,gaster); "
    "'+' averages nodes, e.g. Head,UpperThorax+LowerThorax,Abdomen.",
)
@click.option(
    "--image-root",
    type=click.Path(file_okay=False, path_type=Path),
    help="Folder of the COCO images (default: the JSON file's folder), or where the videos "
    "of a SLEAP file are looked for by name when missing at their stored path (also "
    "beside the .slp).",
)
@click.option(
    "--predicted",
    is_flag=True,
    help="Also train on SLEAP frames that hold predicted instances only (default: user "
    "labels only).",
)
@click.option(
    "--real-crops",
    "real_crops",
    type=click.Path(path_type=Path),
    help="Folder of real background-removed ant crops, one sub-folder per individual "
    "(e.g. anTraX's classifier/examples; its labels.csv keeps the ant labels): pasted on "
    "tiles of --background (copy-paste augmentation, [real] table).",
)
@click.option(
    "--background",
    type=click.Path(path_type=Path),
    help="Real background frame (PNG) for --real-crops, e.g. anTraX's background.png.",
)
@click.option(
    "--roi",
    type=click.Path(path_type=Path),
    help="Region-of-interest mask (PNG, white = arena) of --background: ants are pasted "
    "inside it.",
)
@click.option(
    "--init",
    type=click.Path(dir_okay=False, path_type=Path),
    help="Start from this model (fine-tuning, e.g. a synthetic model on your labels).",
)
@click.option("--seed", type=int, help="Seed of every random draw (default: the config's, 0).")
@click.option("--threads", type=int, help="PyTorch CPU threads (default: as set).")
@click.option(
    "--config",
    type=click.Path(dir_okay=False),
    help="TOML file of training options (keys of TrainConfig; [model], [augment], "
    "[synth], [validation] tables).",
)
@click.option(
    "--set",
    "overrides",
    multiple=True,
    metavar="KEY=VALUE",
    help="Override an option, e.g. --set max_steps=2000 --set model.crop_size=40.",
)
@click.option("--quiet", is_flag=True, help="No progress bar or log lines.")
def track_train(
    out: Path,
    synthetic: bool,
    labels: tuple[Path, ...],
    px_per_mm: str | None,
    nodes: str | None,
    image_root: Path | None,
    predicted: bool,
    real_crops: Path | None,
    background: Path | None,
    roi: Path | None,
    init: Path | None,
    seed: int | None,
    threads: int | None,
    config: str | None,
    overrides: tuple[str, ...],
    quiet: bool,
) -> None:
    """Train the top-down U-Net detector and write its weights to OUT.

    Data: --synthetic (the generator; stops when the held-out video reaches the MOTA
    and ID-switch targets), --labels FILE (SLEAP .slp or COCO .json, repeatable),
    --real-crops DIR --background PNG (real ant crops pasted on a real background),
    or several of them.  Use the model with: thermoswarm track VIDEO --model OUT --px-per-mm S.
    """
    if not synthetic and not labels and real_crops is None:
        raise InputError("give training data: --synthetic, --labels FILE and/or --real-crops DIR")
    if (real_crops is None) != (background is None):
        raise InputError("--real-crops DIR and --background PNG go together")
    if roi is not None and background is None:
        raise InputError("--roi is the mask of --background: give --background too")
    from thermoswarm.io import resolve_px_per_mm
    from thermoswarm.tracking.train.fit import train_from_sources

    cfg = _train_config(config, overrides, seed, threads)
    if labels and px_per_mm is None:
        raise InputError(
            "pass --px-per-mm for --labels (the scale of the labelled images; the paper's "
            "is --px-per-mm paper = 3.04)"
        )
    scale = resolve_px_per_mm(px_per_mm) if px_per_mm is not None else None
    node_names = _node_names(nodes)

    def log(line: str) -> None:
        if not quiet:
            click.echo(line, err=True)

    report = train_from_sources(
        out,
        synthetic=synthetic,
        labels=list(labels),
        px_per_mm=scale,
        nodes=node_names,
        image_root=image_root,
        include_predicted=predicted,
        real_crops=real_crops,
        background=background,
        roi=roi,
        init=init,
        config=cfg,
        progress=not quiet,
        log=log,
    )
    click.echo(_summary(report, out))


def _train_config(
    config: str | None, overrides: tuple[str, ...], seed: int | None, threads: int | None
) -> TrainConfig:
    """The training options: the TOML file, the ``--set`` overrides, then ``--seed`` and
    ``--threads``."""
    from thermoswarm.config import apply_overrides, from_mapping, load_toml, parse_overrides
    from thermoswarm.tracking.train.fit import TrainConfig

    data = load_toml(config) if config else {}
    data = apply_overrides(data, parse_overrides(overrides))
    if seed is not None:
        data["seed"] = seed
    if threads is not None:
        data["threads"] = threads
    return from_mapping(TrainConfig, data, source=config or "--set")


def _node_names(nodes: str | None) -> list[str] | None:
    """``--nodes HEAD,BODY,TAIL`` as three names (``None`` without it)."""
    if nodes is None:
        return None
    node_names = [n.strip() for n in nodes.split(",")]
    if len(node_names) != 3 or not all(node_names):
        raise InputError(
            f"--nodes must be three names HEAD,BODY,TAIL (a name may be A+B), got {nodes!r}"
        )
    return node_names


def _summary(report: dict[str, Any], out: Path) -> str:
    """The line printed after training: steps, time, why it stopped, the best score."""
    best = report["best"] or {}
    score = (
        f"validation MOTA {best['mota']:.4f}, ID switches {100 * best['idsw_rate']:.2f} %"
        if "mota" in best
        else (f"validation F1 {best['f1']:.3f}" if "f1" in best else "no validation")
    )
    return (
        f"{report['steps']} steps in {report['seconds']:.0f} s (stopped: {report['stopped']}), "
        f"{score} -> {out}"
    )
