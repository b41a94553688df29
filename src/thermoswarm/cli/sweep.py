"""``thermoswarm sweep``: a scenario over a grid of parameters and seeds."""

from __future__ import annotations

import json
from pathlib import Path

import click

from thermoswarm.errors import ConfigError


def _parse_grid(items: tuple[str, ...]) -> dict[str, list]:
    from thermoswarm.config import parse_value

    grid: dict[str, list] = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep or not key.strip() or not text.strip():
            raise ConfigError(f"--grid {item!r}: expected key=v1,v2,...")
        grid[key.strip()] = [parse_value(v.strip()) for v in text.split(",")]
    return grid


def _parse_seeds(text: str) -> list[int]:
    seeds: list[int] = []
    for part in text.split(","):
        a, sep, b = part.partition("-")
        try:
            seeds += list(range(int(a), int(b) + 1)) if sep else [int(a)]
        except ValueError:
            raise ConfigError(f"--seeds {text!r}: expected e.g. 0-9 or 1,2,5") from None
    return seeds


@click.command()
@click.argument("scenario")
@click.option(
    "--out",
    type=click.Path(path_type=Path),
    required=True,
    help="Sweep directory (one sub-directory per run).",
)
@click.option(
    "--grid",
    "grid",
    multiple=True,
    metavar="KEY=V1,V2,...",
    help="Values of one parameter (repeatable: the runs are the product).",
)
@click.option("--seeds", default="0", show_default=True, help="Seeds, e.g. 0-9 or 1,4,7.")
@click.option(
    "--set",
    "overrides",
    multiple=True,
    metavar="KEY=VALUE",
    help="A parameter shared by all runs (repeatable).",
)
@click.option(
    "--workers", type=click.IntRange(min=1), default=None, help="Processes (default: all cores)."
)
@click.option("--progress/--no-progress", default=None)
def sweep(scenario, out, grid, seeds, overrides, workers, progress):
    """Run SCENARIO for every combination of --grid values and --seeds; finished runs
    are skipped when started again.  Writes OUT/<run_id>/ and OUT/sweep.json."""
    from thermoswarm.scenarios.schema import precheck

    grid_values, seed_list = _parse_grid(grid), _parse_seeds(seeds)
    precheck(scenario, overrides=overrides, grid=grid_values)  # before the heavy imports
    from thermoswarm.sweep import SweepSpec, run_sweep

    spec = SweepSpec(scenario, out, {}, grid_values, seed_list)
    records = run_sweep(spec, max_workers=workers, progress=progress, overrides=overrides)
    failed = [r for r in records if r.status == "failed"]
    click.echo(
        json.dumps(
            {
                "out": str(out),
                "runs": len(records),
                "done": sum(r.status == "done" for r in records),
                "skipped": sum(r.status == "skipped" for r in records),
                "failed": len(failed),
            }
        )
    )
    if failed:
        for r in failed:
            click.echo(f"error: run {r.run_id} ({r.params}, seed {r.seed}): {r.error}", err=True)
        raise SystemExit(1)
