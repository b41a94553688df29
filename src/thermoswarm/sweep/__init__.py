"""Parameter sweeps over any :class:`concurrent.futures.Executor`.

A sweep is a scenario, a base configuration, a grid of values for some keys (their
Cartesian product) and a list of seeds.  Every combination is one run, written to
``OUT/<run_id>/`` by :func:`thermoswarm.scenarios.runner.run`; ``run_id`` is a hash of
the run's fully resolved configuration (seed included) and of the simulation code, so a
finished run is skipped when the sweep starts again, a killed run resumes from its last
committed block, and two sweeps that share a run share its directory.

Results: ``OUT/results.parquet`` (one row per run, written as runs finish) and
``OUT/sweep.json``.  Executors: the default :class:`~thermoswarm.sweep.pool.LocalPool`
(a dead worker costs only its own run an attempt), or Dask
(``client.get_executor()``; :func:`~thermoswarm.sweep.cluster.dask_client`).
``docs/cluster.md`` tells how to run one on a cluster.

Modules: :mod:`.spec` (what runs), :mod:`.worker` (one run, on a worker),
:mod:`.pool` (the local executor), :mod:`.run` (:func:`run_sweep`), :mod:`.table`
(the results table), :mod:`.cluster` (Dask), :mod:`.compression` (the compression
experiment's sweeps).
"""

from __future__ import annotations

from thermoswarm.sweep.run import local_pool, run_sweep
from thermoswarm.sweep.spec import (
    RunRecord,
    SweepSpec,
    _flatten_base,
    code_fingerprint,
    expand,
    run_id,
)
from thermoswarm.sweep.worker import compile_here as _compile_here

__all__ = [
    "SweepSpec",
    "RunRecord",
    "expand",
    "run_sweep",
    "run_id",
    "code_fingerprint",
    "local_pool",
    "_flatten_base",
    "_compile_here",
]
