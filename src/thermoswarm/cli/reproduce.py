"""``thermoswarm reproduce``: every experiment of the paper into one report."""

from __future__ import annotations

from pathlib import Path

import click


@click.command()
@click.option(
    "--out",
    type=click.Path(path_type=Path),
    required=True,
    help="Output directory (created with its parents); reruns reuse finished runs.",
)
@click.option(
    "--quick/--full",
    default=False,
    help="Shorter runs and smaller studies (minutes on 2 cores) or the full setting.",
)
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True)
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    default=None,
    help="Processes for the studies (default: all cores).",
)
@click.option("--quiet", is_flag=True, help="No progress lines.")
def reproduce(out, quick, seed, workers, quiet):
    """Run the paper's robot experiments and write OUT/report.html, OUT/results.json and
    an animation per scenario in OUT/animations/."""
    from thermoswarm.reproduce import reproduce as run

    run(out, quick=quick, seed=seed, workers=workers, verbose=not quiet)
