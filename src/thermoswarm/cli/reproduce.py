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
@click.option(
    "--smoke",
    is_flag=True,
    help="Every step at a toy scale (a minute or two): checks that an install runs end to "
    "end; the numbers mean nothing.",
)
@click.option("--seed", type=click.IntRange(min=0), default=0, show_default=True)
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    default=None,
    help="Processes for the studies (default: all cores).",
)
@click.option("--quiet", is_flag=True, help="No progress lines.")
def reproduce(out, quick, smoke, seed, workers, quiet):
    """Run the paper's robot experiments and write OUT/report.html (each experiment
    beside the paper's figure or number, with a verdict), OUT/results.json and an
    animation per scenario in OUT/animations/."""
    from thermoswarm.fsutil import check_output_dir

    check_output_dir(out)  # before the heavy imports
    from thermoswarm.reproduce import reproduce as run

    plan = "smoke" if smoke else "quick" if quick else "full"
    run(out, plan=plan, seed=seed, workers=workers, verbose=not quiet)
