"""``thermoswarm study mechanism|scaling``: the transport-free studies of the report."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import click


def _common(f: Callable) -> Callable:
    """The options both studies take."""
    options = [
        click.option("--out", type=click.Path(path_type=Path), required=True,
                     help="Study directory (runs go to OUT/runs/)."),
        click.option("--setting", type=click.Choice(["quick", "full"]), default="quick",
                     show_default=True),
        click.option("--seeds", type=click.IntRange(min=1), default=None,
                     help="Number of seeds (default: the setting's)."),
        click.option("--variant", type=click.Choice(["free", "obstacle", "zigzag"]),
                     default="free", show_default=True),
        click.option("--workers", type=click.IntRange(min=1), default=None,
                     help="Processes (default: all cores)."),
        click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE",
                     help="Override a base parameter (repeatable)."),
    ]  # fmt: skip
    for option in reversed(options):
        f = option(f)
    return f


def _precheck(out: Path, overrides: tuple[str, ...]) -> None:
    """Keys and types of --set, and the output path, before the heavy imports."""
    from thermoswarm.fsutil import check_output_dir
    from thermoswarm.scenarios.schema import precheck

    precheck("transport-free", overrides=overrides)
    check_output_dir(out)


@click.group()
def study() -> None:
    """The transport-free studies: the mechanism grid and the scaling with swarm size."""


@study.command()
@_common
def mechanism(out, setting, seeds, variant, workers, overrides):
    """Which light-to-phase mapping, heading law and sensing move the object (the
    mechanism table); writes OUT/mechanism.json and OUT/mechanism.md."""
    _precheck(out, overrides)
    from thermoswarm.studies._common import dotted_overrides
    from thermoswarm.studies.mechanism import run_mechanism

    res = run_mechanism(out, setting, seeds=seeds, variant=variant, max_workers=workers,
                        overrides=dotted_overrides(overrides))  # fmt: skip
    click.echo(res.table(), nl=False)


@study.command()
@_common
@click.option("--target-distance", type=float, default=150.0, show_default=True,
              help="Target line this far (mm) above the object's start.")  # fmt: skip
def scaling(out, setting, seeds, variant, workers, overrides, target_distance):
    """Maximum displacement and time to target versus the number of robots; writes
    OUT/scaling.json, OUT/scaling.md and OUT/scaling.png."""
    _precheck(out, overrides)
    from thermoswarm.studies._common import dotted_overrides
    from thermoswarm.studies.scaling import run_scaling

    res = run_scaling(out, setting, seeds=seeds, variant=variant, max_workers=workers,
                      target_distance=target_distance,
                      overrides=dotted_overrides(overrides))  # fmt: skip
    click.echo(res.table(), nl=False)
