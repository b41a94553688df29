"""Executors shared by the sweep tests: starting worker processes is the slow part."""

from __future__ import annotations

import pytest

from thermoswarm.sweep import local_pool


@pytest.fixture(scope="session")
def pool():
    """The default executor: two local worker processes, one Numba thread each."""
    with local_pool(2, threads_per_run=1) as ex:
        yield ex


@pytest.fixture(scope="session")
def dask_cluster_client():
    """A client of a Dask LocalCluster of two worker processes (one task each)."""
    from thermoswarm.sweep.cluster import dask_client  # the dask extra: make install has it

    with dask_client(local_workers=2) as client:
        yield client


@pytest.fixture
def dask_executor(dask_cluster_client):
    return dask_cluster_client.get_executor()
