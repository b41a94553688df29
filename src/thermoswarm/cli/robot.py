"""``thermoswarm robot``: build the board's files, deploy them, calibrate the robot."""

from __future__ import annotations

import click

from thermoswarm.robot.host.build import BOARDS


@click.group()
def robot() -> None:
    """The paper's robot: build, deploy and calibrate (docs/robot.md)."""


@robot.command()
@click.option("--board", required=True, type=click.Choice(sorted(BOARDS)), help="Target board.")
@click.option("--scenario", required=True, help="Scenario whose algorithm the robot runs.")
@click.option("--out", required=True, type=click.Path(file_okay=False), help="Output folder.")
@click.option("--config", "config_file", type=click.Path(exists=True, dir_okay=False),
              help="The scenario's TOML file.")  # fmt: skip
@click.option("--set", "overrides", multiple=True, metavar="KEY=VALUE",
              help="Override a scenario parameter.")  # fmt: skip
@click.option("--seed", type=click.IntRange(min=0), default=None,
              help="Controller seed (default: from the chip's unique id).")  # fmt: skip
@click.option("--group", type=click.IntRange(0, 1), default=0, help="narrow-road group.")
def build(board, scenario, out, config_file, overrides, seed, group) -> None:  # type: ignore[no-untyped-def]
    """Write the files to copy to the board into OUT."""
    from thermoswarm.robot.host.build import build as _build

    for p in _build(board, scenario, out, config_file=config_file, overrides=overrides,
                    seed=seed, group=group):  # fmt: skip
        click.echo(str(p))


@robot.command()
@click.argument("folder", type=click.Path(file_okay=False))
@click.option("--port", required=True, help="Serial port of the board (e.g. /dev/ttyACM0).")
def deploy(folder, port) -> None:  # type: ignore[no-untyped-def]
    """Copy a built FOLDER to the board with mpremote."""
    from thermoswarm.robot.host.deploy import deploy as _deploy

    for name in _deploy(folder, port):
        click.echo(f"copied {name}")


@robot.command()
@click.option("--port", required=True, help="Serial port of the board.")
def calibrate(port) -> None:  # type: ignore[no-untyped-def]
    """Measure the light sensors and motors; store calib.json on the board."""
    from thermoswarm.robot.host.deploy import calibrate as _calibrate

    def ask(prompt: str) -> float:
        if prompt.endswith("Enter"):
            click.prompt(prompt, default="", show_default=False)
            return 0.0
        return float(click.prompt(prompt, type=float))

    _calibrate(port, ask, click.echo)
