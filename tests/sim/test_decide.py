"""The decision fast path (``BoltzmannUniform.act_into``, the engine's ``_decide_fast``)
gives bit for bit what the general path (``act`` through an observation) gives."""

from __future__ import annotations

import math

import numpy as np
import pytest

from thermoswarm.maxent import kT_for_mean_speed
from thermoswarm.policy import BoltzmannUniform, Observation
from thermoswarm.sim import EngineParams, Simulator, box_world, place_lattice
from thermoswarm.sim.engine import LIGHT_DIRECTION


@pytest.mark.parametrize("law", ["boltzmann", "half-normal"])
@pytest.mark.parametrize("half_width", [math.pi, math.pi / 2, 0.3])
def test_act_into_draws_what_act_draws(law, half_width):
    pol = BoltzmannUniform(kT=57.0, half_width=half_width, speed_law=law)
    n = 1001
    a, b = np.random.default_rng(7), np.random.default_rng(7)
    obs = Observation(time=0.0, index=np.arange(n), tau=1.0,
                      zero_heading=np.full(n, LIGHT_DIRECTION))  # fmt: skip
    want = pol.act(obs, a)
    fcols = np.zeros((2, n))  # rows of a state: contiguous views
    pol.act_into(b, LIGHT_DIRECTION, fcols[0], fcols[1])
    assert np.array_equal(fcols[0], want.heading)
    assert np.array_equal(fcols[1], want.speed)
    assert a.random() == b.random()  # the generators advanced alike


class _General(BoltzmannUniform):
    """The same policy, through the general path (it overrides ``act`` alone)."""

    def act(self, obs, rng):
        return super().act(obs, rng)


def _run(policy, tau: float, steps: int = 40, n: int = 400):
    r = 16.5
    side = math.sqrt(n * math.pi * r * r / 0.5)
    world = box_world(side, side)
    sim = Simulator(world, EngineParams(dt=0.1, tau=tau), policy)
    rng = np.random.default_rng(3)
    state = sim.init(place_lattice(world.bounds, n, r, rng), rng)
    for _ in range(steps):
        sim.step(state)
    return sim, state


@pytest.mark.parametrize("tau", [0.1, 0.5])  # every robot every step; staggered subsets
def test_engine_fast_path_is_bit_identical_to_the_general_path(tau):
    kT = kT_for_mean_speed(20.0)
    fast_sim, fast = _run(BoltzmannUniform(kT), tau)
    slow_sim, slow = _run(_General(kT), tau)
    assert fast_sim._fast_policy is not None and slow_sim._fast_policy is None
    for name in ("pos", "fcols", "icols", "udir", "ref"):
        assert np.array_equal(getattr(fast, name), getattr(slow, name)), name
    assert fast.rng.random() == slow.rng.random()


def _sim_and_state(policy, n: int, sensing=None, tau: float = 0.1):
    r = 16.5
    side = math.sqrt(n * math.pi * r * r / 0.3)
    world = box_world(side, side)
    sim = Simulator(world, EngineParams(dt=0.1, tau=tau), policy, sensing)
    rng = np.random.default_rng(5)
    return sim, sim.init(place_lattice(world.bounds, n, r, rng), rng)


_VARIANTS = [
    dict(speed_law="half-normal"),
    dict(half_width=math.pi / 2),
    dict(half_width=0.3, speed_law="half-normal"),
]


@pytest.mark.parametrize("variant", _VARIANTS)
@pytest.mark.parametrize("tau", [0.1, 0.5])
def test_engine_fast_path_other_laws(variant, tau):
    kT = kT_for_mean_speed(20.0)
    fast = _run(BoltzmannUniform(kT, **variant), tau, steps=25)[1]
    slow = _run(_General(kT, **variant), tau, steps=25)[1]
    for name in ("pos", "fcols", "icols", "udir"):
        assert np.array_equal(getattr(fast, name), getattr(slow, name)), name


def test_one_decision_of_a_large_swarm_is_bit_identical():
    # 20,011 robots: NumPy casts float64 headings to float32 in 8,192-element buffers
    # inside np.cos(..., dtype=float32); the directions must still equal _unit_directions'.
    # Decisions of everyone, then of an irregular subset.
    kT = kT_for_mean_speed(15.0)
    fsim, fst = _sim_and_state(BoltzmannUniform(kT), 20011)
    gsim, gst = _sim_and_state(_General(kT), 20011)
    sub = np.flatnonzero(np.random.default_rng(9).random(20011) < 0.37)
    for index in (None, sub):
        fsim._decide(fst, index)
        gsim._decide(gst, index)
        for name in ("fcols", "udir"):
            assert np.array_equal(getattr(fst, name), getattr(gst, name)), name
    from thermoswarm.sim.engine import _unit_directions

    assert np.array_equal(fst.udir, _unit_directions(fst.heading))


def test_other_sensing_takes_the_general_path():
    # a sensing model whose zero heading is not the light direction: the fast path (which
    # assumes the light direction) must not be taken, or every heading would be off by 1.2
    def sensing(state, index):
        return np.full(index.size, LIGHT_DIRECTION - 1.2), np.ones(index.size)

    kT = kT_for_mean_speed(20.0)
    fsim, fst = _sim_and_state(BoltzmannUniform(kT, 0.5), 300, sensing=sensing, tau=0.3)
    gsim, gst = _sim_and_state(_General(kT, 0.5), 300, sensing=sensing, tau=0.3)
    for _ in range(10):
        fsim.step(fst)
        gsim.step(gst)
    assert np.array_equal(fst.fcols, gst.fcols) and np.array_equal(fst.pos, gst.pos)
    assert np.abs(fst.heading - (LIGHT_DIRECTION - 1.2)).max() <= 0.5  # the sensed zero


class _Both(BoltzmannUniform):
    """Overrides both methods: its own act_into is the fast path (it must stand for its act)."""

    def act(self, obs, rng):
        return super().act(obs, rng)

    def act_into(self, rng, zero_heading, heading, speed):
        super().act_into(rng, zero_heading, heading, speed)


def test_subclass_choice_of_path():
    kT = 100.0
    assert Simulator(box_world(500, 500), EngineParams(), _Both(kT))._fast_policy is not None
    assert Simulator(box_world(500, 500), EngineParams(), _General(kT))._fast_policy is None
    # a policy replaced after construction is never run through the old one's fast path
    sim, state = _sim_and_state(BoltzmannUniform(kT), 50)
    sim.policy = _General(kT, half_width=0.1)
    sim._decide(state, None)
    rel = state.heading - LIGHT_DIRECTION
    assert np.abs(rel).max() <= 0.1


@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")  # the general path
@pytest.mark.parametrize("kT", [1e308, 8e307])  # 2 kT overflows; 2 kT E overflows for E > 1.13
@pytest.mark.parametrize("cls", [BoltzmannUniform, _General])
def test_an_overflowing_temperature_is_refused_on_both_paths(cls, kT):
    # act's speeds are infinite and the engine's check refuses them; the fast path skips
    # that check, so it must refuse them itself (400 robots: P(no E > 1.13) = e^-452)
    with pytest.raises(ValueError, match="too large|non-finite"):
        _run(cls(kT), 0.1, steps=1, n=400)
