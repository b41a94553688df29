"""Algorithms 4 and 5 and the turn-time wrapper, on constructed observations."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from thermoswarm.maxent import SpeedLaw, kT_for_mean_speed
from thermoswarm.policy import (
    PHASE_COLD,
    PHASE_HOT,
    Action,
    ConnectedTransport,
    LightSwitchedTransport,
    Observation,
    TurnTimeCharged,
)

KT_HOT = kT_for_mean_speed(15.0)
KT_COLD = kT_for_mean_speed(3.0)


def _obs(n, *, zero=math.pi / 2, light=1.0, heading=None, tau=1.0):
    heading = np.zeros(n) if heading is None else np.asarray(heading, dtype=float)
    return Observation(
        time=0.0,
        index=np.arange(n),
        tau=tau,
        zero_heading=np.broadcast_to(np.asarray(zero, dtype=float), (n,)).copy(),
        light=np.broadcast_to(np.asarray(light, dtype=float), (n,)).copy(),
        heading=heading,
    )


def _rel(h, zero):
    return (np.asarray(h) - zero + np.pi) % (2 * np.pi) - np.pi


def test_connected_transport_heading_and_speed_laws():
    n = 20_000
    rng = np.random.default_rng(1)
    zero = 0.7
    act = ConnectedTransport(kT=KT_HOT).act(_obs(n, zero=zero), rng)
    rel = _rel(act.heading, zero)
    assert rel.min() >= -math.pi / 2 and rel.max() <= math.pi / 2
    assert stats.kstest(rel, stats.uniform(-math.pi / 2, math.pi).cdf).pvalue > 1e-3
    assert stats.kstest(act.speed, SpeedLaw(KT_HOT).cdf).pvalue > 1e-3
    # mean drive along the light: <v> sin(w)/w = <v> 2/pi, within 4 standard errors
    drive = act.speed * np.cos(rel)
    se = drive.std(ddof=1) / math.sqrt(n)
    assert abs(drive.mean() - ConnectedTransport(kT=KT_HOT).mean_drive()) < 4 * se
    assert ConnectedTransport(kT=KT_HOT).mean_drive() == pytest.approx(
        SpeedLaw(KT_HOT).mean() * 2 / math.pi
    )


@pytest.mark.parametrize("mapping", ["lit_hot", "lit_cold"])
def test_light_switched_phase_and_speed_by_mapping(mapping):
    n = 20_000
    rng = np.random.default_rng(2)
    light = np.where(np.arange(n) % 3 == 0, 0.0, 1.0)  # a third dark
    pol = LightSwitchedTransport(KT_HOT, KT_COLD, mapping=mapping, threshold=0.5)
    phase = pol.phase(light)
    lit = light > 0.5
    expect_hot = lit if mapping == "lit_hot" else ~lit
    assert np.array_equal(phase == PHASE_HOT, expect_hot)
    assert np.array_equal(phase == PHASE_COLD, ~expect_hot)
    act = pol.act(_obs(n, light=light), rng)
    hot = phase == PHASE_HOT
    assert stats.kstest(act.speed[hot], SpeedLaw(KT_HOT).cdf).pvalue > 1e-3
    assert stats.kstest(act.speed[~hot], SpeedLaw(KT_COLD).cdf).pvalue > 1e-3
    # swapping the mapping is swapping the two temperatures
    other = "lit_cold" if mapping == "lit_hot" else "lit_hot"
    swapped = LightSwitchedTransport(KT_COLD, KT_HOT, mapping=other)
    assert np.array_equal(pol.temperature(light), swapped.temperature(light))


def test_light_switched_uniform_heading_is_fresh_and_uniform():
    n = 20_000
    rng = np.random.default_rng(3)
    zero = -1.1
    pol = LightSwitchedTransport(KT_HOT, KT_COLD, heading_law="uniform")
    act = pol.act(_obs(n, zero=zero, heading=np.full(n, 2.0)), rng)
    rel = _rel(act.heading, zero)
    assert stats.kstest(rel, stats.uniform(-math.pi, 2 * math.pi).cdf).pvalue > 1e-3


def test_light_switched_persistent_heading_turns_by_the_steering_law():
    """Heading increments are Laplace with scale kT_theta * tau (the exponential law of
    the steering rate with a random sign), independent of the light direction."""
    n = 20_000
    rng = np.random.default_rng(4)
    prev = rng.uniform(-np.pi, np.pi, n)
    tau = 0.5
    pol = LightSwitchedTransport(KT_HOT, KT_COLD, heading_law="persistent", kT_theta=0.8)
    act = pol.act(_obs(n, zero=rng.uniform(-3, 3, n), heading=prev, tau=tau), rng)
    turn = np.asarray(act.heading) - prev
    assert stats.kstest(turn, stats.laplace(scale=0.8 * tau).cdf).pvalue > 1e-3
    assert abs(np.mean(np.abs(turn)) - 0.8 * tau) < 4 * 0.8 * tau / math.sqrt(n)


def test_light_switched_steering_temperature_per_phase():
    """With kT_theta_cold, hot robots turn by Laplace(kT_theta tau) and cold robots by
    Laplace(kT_theta_cold tau); which robots are hot follows the mapping (lit_cold:
    the dark ones).  KS per phase, 10,000 robots each."""
    n = 20_000
    rng = np.random.default_rng(11)
    prev = rng.uniform(-np.pi, np.pi, n)
    light = np.where(np.arange(n) < n // 2, 0.0, 1.0)  # first half dark: hot
    tau = 1.0
    pol = LightSwitchedTransport(KT_HOT, KT_COLD, mapping="lit_cold", heading_law="persistent",
                                 kT_theta=0.1, kT_theta_cold=2.0)  # fmt: skip
    act = pol.act(_obs(n, light=light, heading=prev, tau=tau), rng)
    turn = np.asarray(act.heading) - prev
    hot = pol.phase(light) == PHASE_HOT
    assert hot.sum() == n // 2 and hot[: n // 2].all()
    assert stats.kstest(turn[hot], stats.laplace(scale=0.1 * tau).cdf).pvalue > 1e-3
    assert stats.kstest(turn[~hot], stats.laplace(scale=2.0 * tau).cdf).pvalue > 1e-3
    # the two laws differ: one sample against the other's law is rejected outright
    assert stats.kstest(turn[hot], stats.laplace(scale=2.0 * tau).cdf).pvalue < 1e-10


def test_light_switched_v_max_cuts_speeds_at_the_top_speed():
    """Speeds are Rayleigh at the phase's temperature cut at v_max: none above it, the
    share at the cap is P(V > c) = exp(-c^2 / (2 kT)) within 4 binomial standard errors,
    and below the cap the law is untouched (KS of the uncut part against the Rayleigh
    law conditioned on V < c)."""
    n = 40_000
    kT = kT_for_mean_speed(22.0)
    c = 33.0
    pol = LightSwitchedTransport(kT, KT_COLD, mapping="lit_hot", v_max=c)
    v = np.asarray(pol.act(_obs(n, light=1.0), np.random.default_rng(5)).speed)
    assert v.max() == c
    p = math.exp(-(c**2) / (2 * kT))
    share = np.mean(v == c)
    assert abs(share - p) < 4 * math.sqrt(p * (1 - p) / n)
    below = v[v < c]
    law = stats.rayleigh(scale=math.sqrt(kT))
    assert stats.kstest(below, lambda x: law.cdf(x) / law.cdf(c)).pvalue > 1e-3


def test_light_switched_rejects_bad_values():
    with pytest.raises(ValueError, match="mapping"):
        LightSwitchedTransport(KT_HOT, KT_COLD, mapping="bright_hot")
    with pytest.raises(ValueError, match="heading_law"):
        LightSwitchedTransport(KT_HOT, KT_COLD, heading_law="ballistic")
    with pytest.raises(ValueError, match="threshold"):
        LightSwitchedTransport(KT_HOT, KT_COLD, threshold=1.5)
    with pytest.raises(ValueError, match="kT_theta"):
        LightSwitchedTransport(KT_HOT, KT_COLD, kT_theta=0.0)
    with pytest.raises(ValueError, match="kT_theta_cold"):
        LightSwitchedTransport(KT_HOT, KT_COLD, kT_theta_cold=-1.0)
    with pytest.raises(ValueError, match="v_max"):
        LightSwitchedTransport(KT_HOT, KT_COLD, v_max=0.0)


class _Fixed:
    """A policy that returns given headings and speeds."""

    def __init__(self, heading, speed):
        self.heading = np.asarray(heading, dtype=float)
        self.speed = np.asarray(speed, dtype=float)

    def act(self, obs, rng):
        return Action(heading=self.heading.copy(), speed=self.speed.copy())


def test_turn_time_charged_on_constructed_turns():
    # turn rate pi rad/s, tau 1 s: a robot that turns pi/4 keeps 3/4 of its speed
    h_prev = np.array([0.0, 0.0, 0.0, 3.0])
    zero = np.array([np.pi / 2, np.pi / 2, np.pi / 2, np.pi / 2])
    light = np.array([1.0, 0.0, 1.0, 1.0])
    new = np.array([np.pi / 2 + np.pi / 4, np.pi / 4, -np.pi, np.pi / 2])
    inner = _Fixed(new, [10.0, 10.0, 10.0, 10.0])
    obs = _obs(4, zero=zero, light=light, heading=h_prev)
    out = TurnTimeCharged(inner, turn_rate=math.pi, dark_threshold=0.05).act(obs, None)
    # robot 0: lit, turns pi/2 to the light then pi/4: 3/4 s of turning
    # robot 1: dark, turns only from its heading to the new one: pi/4
    # robot 2: lit, pi/2 to the light then pi/2 on to -pi: a whole period -> speed 0
    # robot 3: lit, from 3 rad to pi/2 (1.429 rad) and no further turn
    expect = 10.0 * np.array([0.25, 0.75, 0.0, 1 - (3.0 - np.pi / 2) / np.pi])
    np.testing.assert_allclose(out.speed, expect, rtol=1e-12)
    np.testing.assert_array_equal(out.heading, new)
    # a policy that does not turn to the light is charged its own turn only
    out2 = TurnTimeCharged(inner, turn_rate=math.pi, turns_to_light=False).act(obs, None)
    turned = np.abs((new - h_prev + np.pi) % (2 * np.pi) - np.pi)
    np.testing.assert_allclose(out2.speed, 10.0 * np.clip(1 - turned / np.pi, 0, 1))
