"""``thermoswarm bench``: the engine's speed on the standard workload."""

from __future__ import annotations

import json

import click


@click.command()
@click.option(
    "--scenario",
    type=click.Choice(["box"]),
    default="box",
    show_default=True,
    help="Benchmark workload.",
)
@click.option(
    "--n",
    "n",
    type=click.IntRange(min=1),
    default=10_000,
    show_default=True,
    help="Number of robots.",
)
@click.option(
    "--phi",
    type=click.FloatRange(0.0, 0.85, min_open=True),
    default=0.5,
    show_default=True,
    help="Packing fraction.",
)
@click.option(
    "--seconds",
    type=click.FloatRange(0.0, min_open=True),
    default=None,
    help="Simulated seconds to time (default: as many as take about 2 s of wall time).",
)
@click.option(
    "--threads",
    type=click.IntRange(min=1),
    default=None,
    help="Numba threads, kept for the whole run (default: the engine's automatic choice: "
    "one thread below 60,000 robots, all cores above).",
)
@click.option(
    "--backend",
    type=click.Choice(["cpu", "gpu"]),
    default="cpu",
    show_default=True,
    help="cpu: the Numba engine; gpu: the numba-cuda engine (a CUDA GPU, else its simulator).",
)
@click.option("--device", default=None, help="Device for --backend gpu (cuda:0, simulator).")
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def bench(scenario, n, phi, seconds, threads, backend, device, seed, as_json):
    """Time the engine: discs of 33 mm at packing fraction PHI, mean speed 10 mm/s,
    headings re-sampled every 0.1 s.

    The timed part takes about 2 s of wall time by default.  Not timed, and reported
    apart: building the swarm, compiling the kernels (about a minute the first time
    after an install, a second or two once Numba's cache holds them), the exact overlap
    checks and the memory trace (a few steps).  Expect the whole command to take 5-10 s
    at the default size with a warm cache.
    """
    import numba

    from thermoswarm.sim import set_threads

    top = numba.config.NUMBA_NUM_THREADS
    if threads is not None and threads > top:
        raise click.BadParameter(
            f"{threads} is more than the {top} threads Numba has (NUMBA_NUM_THREADS)",
            param_hint="--threads",
        )
    set_threads(threads)
    if backend == "gpu":
        from thermoswarm.sim.gpu.bench import run_bench_gpu

        out = run_bench_gpu(n, phi, seconds, seed=seed, device=device)
    else:
        from thermoswarm.sim.bench import run_bench

        out = run_bench(n, phi, seconds, seed=seed)
    if as_json:
        click.echo(json.dumps(out))
    else:
        for k, v in out.items():
            click.echo(f"{k:36s} {v:.6g}" if isinstance(v, float) else f"{k:36s} {v}")
