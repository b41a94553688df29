"""``thermoswarm simulate`` and ``thermoswarm scenarios``."""

from __future__ import annotations

import json
from pathlib import Path

import click

from thermoswarm.errors import ConfigError


@click.command()
@click.argument("scenario", required=False)
@click.option("--out", "out", type=click.Path(path_type=Path), help="Output directory.")
@click.option(
    "--config", "config_file", type=click.Path(path_type=Path), help="TOML file of parameters."
)
@click.option(
    "--set",
    "overrides",
    multiple=True,
    metavar="KEY=VALUE",
    help="Override a parameter (repeatable; dotted keys for sections, "
    "e.g. --set n=500 --set engine.dt=0.05).",
)
@click.option("--seed", type=int, default=None, help="Random seed (default 0).")
@click.option(
    "--resume",
    "resume_dir",
    type=click.Path(path_type=Path),
    default=None,
    help="Continue the killed run in this directory.",
)
@click.option(
    "--progress/--no-progress", default=None, help="Progress bar (default: only on a terminal)."
)
def simulate(scenario, out, config_file, overrides, seed, resume_dir, progress):
    """Run SCENARIO (see `thermoswarm scenarios`) and write DIR/tracks.zarr, tracks.nc,
    metrics.json and config.toml."""
    from thermoswarm.scenarios import runner

    if resume_dir is not None:
        if scenario or out or config_file or overrides or seed is not None:
            raise click.UsageError("--resume DIR takes no other arguments")
        metrics = runner.resume(resume_dir, progress=progress)
        target = resume_dir
    else:
        if out is None:
            raise click.UsageError("missing option --out DIR")
        if config_file is not None and not Path(config_file).is_file():
            raise ConfigError(f"config file {str(config_file)!r} does not exist")
        cfg = runner.resolve(scenario, config_file=config_file, overrides=overrides, seed=seed)
        metrics = runner.run(cfg, out, progress=progress)
        target = out
    perf = metrics.get("performance", {})
    line = {
        "out": str(target),
        "metrics": str(Path(target) / "metrics.json"),
        # stepping only; compiling or loading the Numba kernels is reported apart
        "robot_steps_per_second": perf.get("robot_steps_per_second"),
        "compile_seconds": round(perf.get("compile_seconds") or 0.0, 2),
    }
    click.echo(json.dumps(line))


@click.command()
def scenarios():
    """List the scenarios and their default parameters."""
    from thermoswarm.config import to_dict
    from thermoswarm.scenarios import get, names

    for name in names():
        cls = get(name)
        click.echo(f"{name}: {cls.description}")
        for k, v in to_dict(cls.Params()).items():
            if not isinstance(v, dict):
                click.echo(f"    {k} = {v!r}")
