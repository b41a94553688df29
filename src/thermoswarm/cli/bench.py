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
    help="Simulated seconds to run (default: about 2 s of wall time).",
)
@click.option(
    "--threads",
    type=click.IntRange(min=1),
    default=None,
    help="Numba threads (default: all cores).",
)
@click.option(
    "--backend",
    type=click.Choice(["cpu", "gpu"]),
    default="cpu",
    show_default=True,
    help="cpu: the Numba engine; gpu: the Warp engine (a CUDA GPU, else Warp's CPU device).",
)
@click.option("--device", default=None, help="Warp device for --backend gpu (cuda:0, cpu).")
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--json", "as_json", is_flag=True, help="Print one JSON object.")
def bench(scenario, n, phi, seconds, threads, backend, device, seed, as_json):
    """Run the engine benchmark: discs of 33 mm at packing fraction PHI, mean speed
    10 mm/s, headings re-sampled every 0.1 s; compile time excluded."""
    if threads is not None:
        import numba

        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
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
