"""``thermoswarm sweep``: a scenario over a grid of parameters and seeds."""

from __future__ import annotations

import json
from pathlib import Path

import click

from thermoswarm.errors import ConfigError

#: Most runs in one sweep (grid points times seeds).
MAX_RUNS = 100_000


def _parse_grid(items: tuple[str, ...]) -> dict[str, list]:
    from thermoswarm.config import parse_value

    grid: dict[str, list] = {}
    for item in items:
        key, sep, text = item.partition("=")
        key = key.strip()
        if not sep or not key or not text.strip():
            raise ConfigError(f"--grid {item[:60]!r}: expected key=v1,v2,...")
        if key in grid:
            raise ConfigError(
                f"--grid {key!r} is given twice; give its values once: --grid {key}=v1,v2,..."
            )
        grid[key] = [parse_value(v.strip()) for v in text.split(",")]
    return grid


def _parse_seeds(text: str) -> list[int]:
    """``0-9``, ``1,4,7`` or both: at most :data:`MAX_RUNS` seeds, each 0 to 2**63 - 1."""
    bad = ConfigError(f"--seeds {text[:60]!r}: expected e.g. 0-9 or 1,2,5 (integers from 0 "
                      "to 2**63 - 1)")  # fmt: skip
    seeds: list[int] = []
    for part in text.split(","):
        a, sep, b = part.strip().partition("-")
        if not a.strip().isascii() or not a.strip().isdigit() or len(a.strip()) > 19:
            raise bad
        if sep and (not b.strip().isascii() or not b.strip().isdigit() or len(b.strip()) > 19):
            raise bad
        lo = int(a)
        hi = int(b) if sep else lo
        if hi >= 2**63 or hi < lo:
            raise bad
        if len(seeds) + hi - lo + 1 > MAX_RUNS:
            raise ConfigError(f"--seeds {text[:60]!r}: more than {MAX_RUNS:,} seeds in one sweep")
        seeds += range(lo, hi + 1)
    if len(set(seeds)) != len(seeds):
        raise ConfigError(f"--seeds {text[:60]!r}: a seed is given twice")
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
    "--workers",
    type=click.IntRange(min=1),
    default=None,
    help="Local worker processes (default: all cores).",
)
@click.option(
    "--scheduler",
    metavar="ADDRESS",
    default=None,
    help="Run on the Dask scheduler at ADDRESS (e.g. tcp://host:8786).",
)
@click.option(
    "--cluster",
    metavar="local:N",
    default=None,
    help="Run on a Dask LocalCluster of N worker processes started for this sweep.",
)
@click.option(
    "--retries",
    type=click.IntRange(min=0),
    default=2,
    show_default=True,
    help="Further attempts of a run whose worker died or that crashed.",
)
@click.option("--progress/--no-progress", default=None)
def sweep(scenario, out, grid, seeds, overrides, workers, scheduler, cluster, retries, progress):
    """Run SCENARIO for every combination of --grid values and --seeds; finished runs
    are skipped when started again.  Writes OUT/<run_id>/, OUT/results.parquet (one row
    per run) and OUT/sweep.json.  Runs execute in local processes, or through Dask
    (--scheduler, --cluster; docs/cluster.md)."""
    from thermoswarm.scenarios.schema import precheck

    grid_values, seed_list = _parse_grid(grid), _parse_seeds(seeds)
    n_runs = len(seed_list)
    for values in grid_values.values():
        n_runs *= len(values)
    if n_runs > MAX_RUNS:
        raise ConfigError(f"--grid and --seeds make {n_runs:,} runs; at most {MAX_RUNS:,}")
    precheck(scenario, overrides=overrides, grid=grid_values)  # before the heavy imports
    from thermoswarm.sweep import SweepSpec, run_sweep

    if scheduler is not None and cluster is not None:
        raise ConfigError("give --scheduler or --cluster, not both")
    if workers is not None and (scheduler is not None or cluster is not None):
        raise ConfigError("--workers is for local processes; Dask brings its own workers")
    n_local = None
    if cluster is not None:
        from thermoswarm.sweep.cluster import parse_cluster

        n_local = parse_cluster(cluster)
    spec = SweepSpec(scenario, out, {}, grid_values, seed_list)
    kw = {"progress": progress, "overrides": overrides, "retries": retries}
    if scheduler is None and cluster is None:
        records = run_sweep(spec, max_workers=workers, **kw)
    else:
        from thermoswarm.sweep.cluster import dask_client

        with dask_client(scheduler, local_workers=n_local) as client:
            records = run_sweep(spec, client.get_executor(), **kw)
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
