"""Thread counts: an explicit count is never overridden, and results do not depend on it."""

from __future__ import annotations

import json
import math

import numba
import numpy as np
import pytest
from click.testing import CliRunner

import thermoswarm.sim.engine as engine
from thermoswarm.cli import cli
from thermoswarm.maxent import kT_for_mean_speed
from thermoswarm.policy import BoltzmannUniform
from thermoswarm.sim import EngineParams, Simulator, box_world, place_lattice, set_threads

R = 16.5
TWO = numba.config.NUMBA_NUM_THREADS >= 2
needs_two = pytest.mark.skipif(not TWO, reason="needs 2 Numba threads (2 cores)")


@pytest.fixture
def seen_threads(monkeypatch):
    """Numba's thread count at each call of the step kernel, as the kernel would see it."""
    seen: list[int] = []
    kernel = engine.K.overdamped_step

    def spy(*args):
        seen.append(numba.get_num_threads())
        return kernel(*args)

    monkeypatch.setattr(engine.K, "overdamped_step", spy)
    before = numba.get_num_threads()
    yield seen
    set_threads(None)
    numba.set_num_threads(before)


def _run(n, steps, seed=1):
    side = math.sqrt(n * math.pi * R * R / 0.5)
    world = box_world(side, side)
    sim = Simulator(world, EngineParams(tau=0.1), BoltzmannUniform(kT_for_mean_speed(10.0)))
    rng = np.random.default_rng(seed)
    state = sim.init(place_lattice(world.bounds, n, R, rng), rng)
    for _ in range(steps):
        sim.step(state)
    return state


@needs_two
def test_bench_cli_threads_1_runs_on_one_thread_at_10000_robots(seen_threads):
    res = CliRunner().invoke(
        cli, ["bench", "--n", "10000", "--seconds", "0.5", "--threads", "1", "--json"]
    )
    assert res.exit_code == 0, res.output
    assert json.loads(res.output)["threads"] == 1
    assert len(seen_threads) >= 5 and set(seen_threads) == {1}


@needs_two
def test_explicit_counts_are_kept_and_the_automatic_choice_applies_only_without_one(
    seen_threads,
):
    big = engine.SERIAL_BELOW + 500
    set_threads(1)
    _run(big, 2)  # large swarm, explicit 1: stays 1
    set_threads(2)
    _run(200, 2)  # small swarm, explicit 2: stays 2
    assert seen_threads == [1, 1, 2, 2]
    seen_threads.clear()
    set_threads(None)
    numba.set_num_threads(1)  # a count set directly with Numba is respected too
    _run(big, 2)
    assert seen_threads == [1, 1]
    seen_threads.clear()
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)  # the default: automatic
    _run(200, 2)
    _run(big, 2)
    top = numba.config.NUMBA_NUM_THREADS
    assert seen_threads == [1, 1, top, top]
    assert numba.get_num_threads() == top  # the automatic choice is undone after a step


def test_set_threads_rejects_bad_counts():
    with pytest.raises(Exception, match="threads must be an integer in"):
        set_threads(0)
    with pytest.raises(Exception, match="threads must be an integer in"):
        set_threads(numba.config.NUMBA_NUM_THREADS + 1)


@needs_two
def test_bit_identical_on_1_and_2_threads_above_the_serial_threshold(seen_threads):
    n = engine.SERIAL_BELOW + 1000
    out = []
    for t in (1, 2):
        set_threads(t)
        s = _run(n, 12, seed=7)
        out.append((s.by_id(s.pos), s.by_id(s.heading), s.counters.copy()))
    assert set(seen_threads[:12]) == {1} and set(seen_threads[12:]) == {2}
    assert np.array_equal(out[0][0], out[1][0])
    assert np.array_equal(out[0][1], out[1][1])
    assert np.array_equal(out[0][2], out[1][2])
    assert out[0][2][0] > 12  # contacts were projected: sweeps beyond one per step
