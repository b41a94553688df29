"""The GPU engine at scale, beside JAX-MD and the CPU engine: one command, one table.

    python benchmarks/bench_gpu.py                 # on a CUDA GPU: 1e5, 1e6, 1e7 (1e8 if it fits)
    python benchmarks/bench_gpu.py --sizes 10000 30000 --device cpu   # Warp's CPU device

Workload (the engine benchmark's, :mod:`thermoswarm.sim.bench`): discs of 33 mm at
packing fraction 0.18 and 0.5 in a walled square box, mean speed 10 mm/s, heading and
speed re-drawn every 0.1 s, ``dt = 0.1 s``; compilation and the first step excluded.

Columns: robot-steps per second of the Warp engine (``gpu``), its exact largest overlap as
a fraction of the diameter (SciPy k-d tree on the host up to ``--kdtree-max`` robots, the
device's exhaustive pair search above), device bytes per robot, the CPU engine (Numba;
one thread below 60,000 robots, all cores above: the engine's own choice) on the same
workload and its overlap, JAX-MD (Brownian dynamics of soft
discs with a cell-list neighbour list on the same device: a throughput peer, not the same
contact model) and its largest overlap, and the speed-up of the Warp engine over each.
A baseline that cannot run says why in its column.  The goal on one H100 is at least
1e9 robot-steps/s at 1e7 robots, overlap below 1 % of the diameter and at most 100
bytes per robot.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time

import numpy as np

DIAMETER = 33.0


def _gpu(n: int, phi: float, device: str | None, kdtree_max: int) -> dict:
    from thermoswarm.sim.gpu.bench import run_bench_gpu

    return run_bench_gpu(n, phi, device=device, exact_check=n <= kdtree_max)


def _cpu(n: int, phi: float) -> dict:
    from thermoswarm.sim.bench import run_bench

    return run_bench(n, phi)


def _jax_md(n: int, phi: float, steps: int = 20) -> dict:
    """Brownian dynamics of soft discs (JAX-MD's soft sphere, cell-list neighbour list)
    in a periodic square of the same size (JAX-MD has no walls)."""
    try:
        import jax
        import jax.numpy as jnp
        from jax_md import energy, partition, simulate, space
    except ImportError as exc:
        return {"skipped": f"jax / jax-md not installed ({exc.name})"}
    import warnings

    warnings.filterwarnings("ignore", message="Explicitly requested dtype")
    jax.config.update("jax_enable_x64", False)
    side = math.sqrt(n * math.pi * (DIAMETER / 2) ** 2 / phi)
    rng = np.random.default_rng(0)
    from thermoswarm.sim.engine import place_lattice

    pos = jnp.asarray(place_lattice((0, 0, side, side), n, DIAMETER / 2, rng), jnp.float32)
    displacement, shift = space.periodic(side)
    neighbor_fn, energy_fn = energy.soft_sphere_neighbor_list(
        displacement, side, sigma=DIAMETER, epsilon=1.0, dr_threshold=DIAMETER * 0.2,
        capacity_multiplier=1.5, format=partition.Sparse,
    )  # fmt: skip
    # the robots' diffusion coefficient D = kT tau / 2 (mean speed 10 mm/s, tau 0.1 s)
    # as Brownian D = kT' / gamma with gamma = 1; the robots' time step
    d_robot = (10.0 / math.sqrt(math.pi / 2)) ** 2 * 0.1 / 2
    init_fn, apply_fn = simulate.brownian(energy_fn, shift, dt=0.1, kT=d_robot, gamma=1.0)
    nbrs = neighbor_fn.allocate(pos)
    state = init_fn(jax.random.PRNGKey(0), pos)

    @jax.jit
    def step(carry, _):
        state, nbrs = carry
        state = apply_fn(state, neighbor=nbrs)
        nbrs = nbrs.update(state.position)
        return (state, nbrs), None

    def run(k, carry):
        carry, _ = jax.lax.scan(step, carry, None, length=k)
        return carry

    for _ in range(3):  # a neighbour list that overflowed is re-allocated and re-run
        carry = run(steps, (state, nbrs))  # compile (the scan length is static)
        jax.block_until_ready(carry[0].position)
        t0 = time.perf_counter()
        carry = run(steps, carry)
        jax.block_until_ready(carry[0].position)
        wall = time.perf_counter() - t0
        overflow = bool(carry[1].did_buffer_overflow)
        if not overflow:
            break
        nbrs = neighbor_fn.allocate(carry[0].position)
    state = carry[0]
    from scipy.spatial import cKDTree  # the overlap: the same k-d tree check as ours

    p = np.asarray(state.position, dtype=np.float64)
    dist, _ = cKDTree(p, boxsize=side).query(p, k=2)
    return {
        "robot_steps_per_second": n * steps / wall,
        "max_overlap_fraction": max(0.0, DIAMETER - float(dist[:, 1].min())) / DIAMETER,
        "device": str(jax.devices()[0]),
        "neighbour_overflow": overflow,
    }


def _fits(n: int, device: str | None) -> tuple[bool, str]:
    """Whether a swarm of n robots fits on the device (about 72 bytes per robot plus
    the host's copy of the initial positions)."""
    import warp as wp

    from thermoswarm.sim.gpu import default_device

    dev = wp.get_device(device or default_device())
    need = 80 * n
    if dev.is_cuda:
        free = getattr(dev, "free_memory", None) or dev.total_memory
        if need > 0.9 * free:
            return False, f"needs ~{need / 2**30:.1f} GiB, {free / 2**30:.1f} GiB free"
    return True, ""


def _fmt(x, spec):
    return "-" if x is None else format(x, spec)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--sizes",
        type=float,
        nargs="+",
        default=None,
        help="swarm sizes (default: 1e5 1e6 1e7 1e8 on a GPU, 1e4 3e4 on a CPU)",
    )
    ap.add_argument("--phis", type=float, nargs="+", default=[0.18, 0.5])
    ap.add_argument("--device", default=None, help="Warp device (default: cuda:0 if present)")
    ap.add_argument(
        "--cpu-max",
        type=float,
        default=1e7,
        help="largest size the CPU engine runs (it needs ~190 bytes per robot)",
    )
    ap.add_argument(
        "--kdtree-max",
        type=float,
        default=1e7,
        help="largest size checked with the host k-d tree (device check above)",
    )
    ap.add_argument("--no-cpu", action="store_true")
    ap.add_argument("--no-jax", action="store_true")
    ap.add_argument("--json", action="store_true", help="also print the rows as JSON lines")
    args = ap.parse_args(argv)  # fmt: skip

    from thermoswarm.sim.gpu import default_device

    device = args.device or default_device()
    on_gpu = device.startswith("cuda")
    sizes = [int(s) for s in (args.sizes or ([1e5, 1e6, 1e7, 1e8] if on_gpu else [1e4, 3e4]))]
    rows = []
    for n in sizes:
        for phi in args.phis:
            row: dict = {"n": n, "phi": phi}
            ok, why = _fits(n, device)
            if not ok:
                row["gpu"] = {"skipped": why}
                rows.append(row)
                continue
            row["gpu"] = _gpu(n, phi, device, int(args.kdtree_max))
            if args.no_cpu:
                row["cpu"] = {"skipped": "--no-cpu"}
            elif n > args.cpu_max:
                row["cpu"] = {"skipped": f"n > --cpu-max {args.cpu_max:.0e}"}
            else:
                row["cpu"] = _cpu(n, phi)
            if args.no_jax:
                row["jax_md"] = {"skipped": "--no-jax"}
            else:
                try:
                    row["jax_md"] = _jax_md(n, phi)
                except Exception as exc:  # a baseline's failure must not lose our rows
                    row["jax_md"] = {"skipped": f"{type(exc).__name__}: {exc}"[:120]}
            rows.append(row)
            if args.json:
                print(json.dumps(row), flush=True)
    g0 = next((r["gpu"] for r in rows if "device" in r["gpu"]), {})
    print()
    note = "" if on_gpu else "  -- Warp's CPU device: CPU numbers, not GPU figures"
    print(f"Warp device: {g0.get('device', device)} ({device}){note}")
    print(f"host: {platform.processor() or platform.machine()}, {os.cpu_count()} cpus; "
          f"python {sys.version.split()[0]}")  # fmt: skip
    print()
    head = ("| N | phi | Warp robot-steps/s | exact max overlap | bytes/robot (device) | "
            "CPU engine robot-steps/s | CPU overlap | JAX-MD robot-steps/s | JAX-MD overlap | "
            "vs CPU | vs JAX-MD |")  # fmt: skip
    print(head)
    print("|" + "---:|" * 11)

    def pct(d: dict, key: str, spec: str) -> str:
        v = d.get(key)
        return "-" if v is None else format(100 * v, spec) + " %"

    def rate(d: dict) -> str:
        v = d.get("robot_steps_per_second")
        return f"{v / 1e6:.2f} M" if v else f"skipped: {d.get('skipped')}"

    for r in rows:
        g, c, j = r["gpu"], r.get("cpu", {}), r.get("jax_md", {})
        gs = g.get("robot_steps_per_second")
        cs_ = c.get("robot_steps_per_second")
        js = j.get("robot_steps_per_second")
        cells = [
            f"{r['n']:,}",
            str(r["phi"]),
            rate(g),
            pct(g, "exact_max_overlap_fraction", ".2f") + f" ({g.get('exact_check', '-')})",
            _fmt(g.get("device_bytes_per_robot"), ".0f"),
            rate(c),
            pct(c, "max_overlap_fraction", ".2f"),
            rate(j),
            pct(j, "max_overlap_fraction", ".1f"),
            _fmt(gs / cs_ if gs and cs_ else None, ".1f") + "x",
            _fmt(gs / js if gs and js else None, ".1f") + "x",
        ]
        print("| " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
