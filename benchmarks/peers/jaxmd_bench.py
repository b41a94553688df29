"""JAX-MD: overdamped Euler of soft discs on its cell-list neighbour list, jit-compiled."""

from __future__ import annotations

import os

import numpy as np

from thermoswarm.maxent import SpeedLaw, kT_for_mean_speed
from thermoswarm.sim.bench import DIAMETER, MEAN_SPEED

from .timing import DT, R, side_of, start_positions, timed

#: JAX-MD's soft discs: ``U = eps / 2 (1 - r / D)^2`` (``energy.soft_sphere``, alpha 2),
#: overdamped Euler with the commanded velocity, ``SUBSTEPS`` sub-steps per 0.1 s step
#: and ``eps = STIFFNESS D^2 / dt_sub`` (each sub-step removes ``2 STIFFNESS`` of a lone
#: pair's overlap: the most explicit Euler takes stably in a crowd of six neighbours).
JAXMD_STIFFNESS = 0.25
JAXMD_SUBSTEPS = 50
#: XLA_FLAGS for JAX-MD on 1 thread and on 2 (XLA's default CPU thread pool, the
#: process limited to 2 cores where the machine has more).
XLA_FLAGS = {1: "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1", 2: ""}


def jaxmd_bench(n: int, phi: float, substeps: int, threads: int = 1, seed: int = 0) -> dict:
    # XLA reads its flags when jax is first imported: :func:`run_cell` sets them for
    # ``threads`` (one thread: no Eigen thread pool, one intra-op thread)
    os.environ.setdefault("XLA_FLAGS", XLA_FLAGS[threads])
    import jax
    import jax.numpy as jnp
    from jax_md import energy, partition, space

    side = side_of(n, phi)
    pad = DIAMETER  # the cell list needs every disc inside [0, box): walls are soft
    box = side + 2 * pad
    dts = DT / substeps
    eps = JAXMD_STIFFNESS * DIAMETER**2 / dts
    disp, _ = space.free()
    neighbor_fn, energy_fn = energy.soft_sphere_neighbor_list(
        disp, box, sigma=DIAMETER, epsilon=eps, alpha=2.0, dr_threshold=0.25 * DIAMETER,
        format=partition.Sparse,
    )  # fmt: skip
    force_fn = jax.grad(lambda x, nb: -energy_fn(x, nb))
    k_wall = eps / DIAMETER**2  # the same stiffness against the walls
    lo, hi = pad + R, pad + side - R

    def walls(x):
        return k_wall * (jnp.maximum(lo - x, 0.0) - jnp.maximum(x - hi, 0.0))

    @jax.jit
    def step(x, nbrs, v):
        def sub(_, carry):
            x, nbrs = carry
            nbrs = nbrs.update(x)
            x = x + dts * (v + force_fn(x, nbrs) + walls(x))
            return x, nbrs

        return jax.lax.fori_loop(0, substeps, sub, (x, nbrs))

    rng = np.random.default_rng(seed + 1)
    law = SpeedLaw(kT_for_mean_speed(MEAN_SPEED))
    x = jnp.asarray(start_positions(n, phi) + pad, dtype=jnp.float32)
    holder = {"x": x, "nbrs": neighbor_fn.allocate(x)}

    def one_step() -> None:
        sp = law.sample(rng, n)
        th = rng.uniform(-np.pi, np.pi, n)
        v = jnp.asarray(np.column_stack([sp * np.cos(th), sp * np.sin(th)]), jnp.float32)
        x1, nb1 = step(holder["x"], holder["nbrs"], v)
        if nb1.did_buffer_overflow:  # JAX-MD's fixed capacity: reallocate and redo
            holder["nbrs"] = neighbor_fn.allocate(holder["x"])
            x1, nb1 = step(holder["x"], holder["nbrs"], v)
        x1.block_until_ready()
        holder["x"], holder["nbrs"] = x1, nb1

    def positions() -> np.ndarray:
        return np.asarray(holder["x"], dtype=np.float64) - pad

    out = timed(one_step, n, positions, side)
    out.update(substeps=substeps, epsilon=eps, threads=threads)
    return out
