"""``thermoswarm study mechanism|scaling|regime``: the transport-free studies of the report."""

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
    """The transport-free studies: the mechanism grid, the scaling with swarm size and the
    drift-speed maps of the regime search."""


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
@click.option(
    "--out",
    type=click.Path(path_type=Path),
    required=True,
    help="Study directory (runs go to OUT/runs/).",
)
@click.option(
    "--setting",
    type=click.Choice(["quick", "fixed", "density", "huge"]),
    default="quick",
    show_default=True,
    help="fixed: robots added to the 1800 mm arena; density: the arena grows "
    "with n; huge: 100,000 robots at that density.",
)
@click.option(
    "--seeds",
    type=click.IntRange(min=1),
    default=None,
    help="Number of seeds (default: the setting's).",
)
@click.option(
    "--ns", default=None, metavar="N1,N2,...", help="Swarm sizes (default: the setting's)."
)
@click.option(
    "--variant",
    type=click.Choice(["free", "obstacle", "zigzag"]),
    default="free",
    show_default=True,
)
@click.option(
    "--workers", type=click.IntRange(min=1), default=None, help="Processes (default: all cores)."
)
@click.option(
    "--set",
    "overrides",
    multiple=True,
    metavar="KEY=VALUE",
    help="Override a base parameter (repeatable).",
)
@click.option(
    "--target-distance",
    type=float,
    default=None,
    help="Target line this far (mm) above the object's start (default: the "
    "setting's: 150 quick, 750 otherwise).",
)
@click.option("--horizon", type=float, default=None,
              help="Window (s) of the maximum displacement (default 300).")  # fmt: skip
def scaling(out, setting, seeds, ns, variant, workers, overrides, target_distance, horizon):
    """Maximum displacement and time to target versus the number of robots; writes
    OUT/scaling.json, OUT/scaling.md and OUT/scaling.png."""
    sizes = None
    if ns is not None:
        try:
            sizes = [int(x) for x in ns.split(",")]
        except ValueError:
            raise click.BadParameter(f"expected integers like 50,200, got {ns!r}",
                                     param_hint="--ns") from None  # fmt: skip
    _precheck(out, overrides)
    from thermoswarm.studies._common import dotted_overrides
    from thermoswarm.studies.scaling import run_scaling

    res = run_scaling(out, setting, ns=sizes, seeds=seeds, variant=variant, max_workers=workers,
                      target_distance=target_distance, horizon=horizon,
                      overrides=dotted_overrides(overrides))  # fmt: skip
    click.echo(res.table(), nl=False)


@study.command()
@click.option(
    "--out",
    type=click.Path(path_type=Path),
    required=True,
    help="Study directory (each map's runs go to OUT/<map>/runs/).",
)
@click.option(
    "--setting", type=click.Choice(["quick", "full"]), default="quick", show_default=True
)
@click.option(
    "--map",
    "maps",
    multiple=True,
    type=click.Choice(["cold", "hot", "friction", "light", "period"]),
    help="Maps to run (repeatable; default all).",
)
@click.option(
    "--seeds",
    type=click.IntRange(min=1),
    default=None,
    help="Number of seeds (default: the setting's).",
)
@click.option(
    "--workers", type=click.IntRange(min=1), default=None, help="Processes (default: all cores)."
)
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE",
              help="Override a base parameter of every map (repeatable).")  # fmt: skip
def regime(out, setting, maps, seeds, workers, overrides):
    """Maps of the object's drift speed over the parameters the paper leaves open;
    writes OUT/regime.json, OUT/regime.md and OUT/regime.png."""
    _precheck(out, overrides)
    from thermoswarm.studies._common import dotted_overrides
    from thermoswarm.studies.regime import run_regime

    res = run_regime(out, setting, maps=list(maps) or None, seeds=seeds, max_workers=workers,
                     overrides=dotted_overrides(overrides))  # fmt: skip
    click.echo(res.table(), nl=False)
