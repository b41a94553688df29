"""Dask for sweeps: a ``LocalCluster`` started for the run, or an existing scheduler.

Needs the ``dask`` extra (``pip install 'thermoswarm[dask]'``).  Dask does the
scheduling: a worker that dies while running a run has its task re-run on another
worker by the scheduler (up to ``distributed.scheduler.allowed-failures`` times), and
the re-run resumes the run from its last committed block because it finds the run's
store in the shared sweep directory.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from thermoswarm.errors import ConfigError, InputError

__all__ = ["parse_cluster", "dask_client"]

_NEEDS_DASK = "needs Dask: pip install 'thermoswarm[dask]'"

#: Dask settings of the LocalCluster that :func:`dask_client` starts.
LOCAL_CLUSTER_CONFIG = {"distributed.worker.profile.enabled": False}


def parse_cluster(text: str) -> int:
    """The worker count of a ``--cluster`` value ``local:N`` (N >= 1)."""
    m = re.fullmatch(r"local:(\d+)", text.strip())
    if not m or int(m.group(1)) < 1:
        raise ConfigError(f"--cluster {text!r}: expected local:N with N >= 1 workers")
    return int(m.group(1))


@contextmanager
def dask_client(
    scheduler: str | None = None,
    *,
    local_workers: int | None = None,
    threads_per_run: int | None = 1,
    timeout: float = 30.0,
) -> Iterator[Any]:
    """A ``distributed.Client`` for the duration of a ``with`` block.

    Parameters
    ----------
    scheduler : str, optional
        Address of a running scheduler (``tcp://host:8786``).
    local_workers : int, optional
        Instead, start a ``LocalCluster`` of this many worker processes, one task each,
        each started with ``NUMBA_NUM_THREADS = threads_per_run`` and without Dask's
        profiler (:data:`LOCAL_CLUSTER_CONFIG`); closed at the end.
    timeout : float
        Seconds to wait for the scheduler.
    """
    if (scheduler is None) == (local_workers is None):
        raise ConfigError("give either a scheduler address or a local worker count")
    try:
        import dask
        from distributed import Client, LocalCluster
    except ImportError:
        raise ConfigError(f"--scheduler/--cluster {_NEEDS_DASK}") from None
    cluster = None
    if local_workers is not None:
        env = {} if threads_per_run is None else {"NUMBA_NUM_THREADS": str(threads_per_run)}
        # Dask's statistical profiler samples the task's stack every 10 ms; it cost a
        # short run a fifth of its time (benchmarks/bench_sweep.py), so it is off here
        with dask.config.set(LOCAL_CLUSTER_CONFIG):
            cluster = LocalCluster(
                n_workers=local_workers,
                threads_per_worker=1,
                processes=True,
                dashboard_address=":0",  # any free port: never clash with a running one
                env=env,
            )
        client = Client(cluster)
    else:
        try:
            client = Client(scheduler, timeout=timeout)
        except (OSError, TimeoutError, ValueError) as exc:
            msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise InputError(f"--scheduler {scheduler!r}: cannot reach it ({msg})") from None
    try:
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
