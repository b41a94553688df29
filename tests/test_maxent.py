"""The law: distributions, sampling, the Jaynes solution."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import integrate, stats

from thermoswarm import maxent as M

N = 200_000


def _ks_ok(x, cdf):
    return stats.kstest(x, cdf).pvalue > 1e-3


def test_energy_law_is_exponential_with_mean_kT(rng):
    law = M.EnergyLaw(kT=37.0)
    x = law.sample(rng, N)
    assert abs(x.mean() - 37.0) < 4 * 37.0 / math.sqrt(N)
    assert _ks_ok(x, law.cdf)
    assert integrate.quad(law.pdf, 0, np.inf)[0] == pytest.approx(1.0, abs=1e-9)


def test_speed_is_rayleigh_and_its_energy_is_the_maxent_law(rng):
    law = M.SpeedLaw(kT=50.0)
    v = law.sample(rng, N)
    assert _ks_ok(v, law.cdf)
    assert abs(v.mean() - law.mean()) < 4 * v.std() / math.sqrt(N)
    # the energy v^2/2 of the sampled speeds is Exponential(kT): the point of 6.1
    assert _ks_ok(v**2 / 2, M.EnergyLaw(50.0).cdf)
    assert abs(np.mean(v**2) - law.mean_square()) < 4 * np.std(v**2) / math.sqrt(N)
    # and the half-normal reading is a different law (the tests have power)
    assert stats.kstest(v**2 / 2, M.EnergyLaw(50.0).cdf).pvalue > 1e-3
    hn = M.HalfNormalSpeed(kT=50.0).sample(rng, N)
    assert stats.kstest(hn**2 / 2, M.EnergyLaw(50.0).cdf).pvalue < 1e-10


def test_kT_for_mean_speed_inverts_the_mean():
    for kind in ("boltzmann", "half-normal"):
        kT = M.kT_for_mean_speed(10.0, kind)
        assert M.speed_law(kind, kT).mean() == pytest.approx(10.0, rel=1e-12)


def test_mixture_pdf_cdf_sampling_and_responsibility(rng):
    mix = M.EnergyMixture(phi=0.3, kT1=5.0, kT2=40.0)
    assert integrate.quad(mix.pdf, 0, np.inf)[0] == pytest.approx(1.0, abs=1e-9)
    xs = np.array([0.0, 1.0, 10.0, 100.0])
    num = [integrate.quad(mix.pdf, 0, x)[0] for x in xs]
    assert np.allclose(mix.cdf(xs), num, atol=1e-9)
    assert np.allclose(np.exp(mix.logpdf(xs)), mix.pdf(xs))
    x = mix.sample(rng, N)
    assert _ks_ok(x, mix.cdf)
    assert abs(x.mean() - mix.mean()) < 4 * x.std() / math.sqrt(N)
    r = mix.responsibility(xs)
    assert np.all(np.diff(r) > 0) and 0 < r[0] < 1  # hotter energies: gas phase
    with pytest.raises(ValueError):
        M.EnergyMixture(phi=1.5, kT1=1, kT2=2)


def test_steering_law_is_signed_exponential_with_speed_dependent_temperature(rng):
    T = M.DecayingTemperature(T_max=2.0, T_min=0.5, v_scale=10.0)
    law = M.SteeringLaw(T)
    v = rng.uniform(0, 40, N)
    w = law.sample(rng, speed=v)
    # |w| / T(v) is Exponential(1) and the sign is symmetric
    assert _ks_ok(np.abs(w) / T(v), stats.expon.cdf)
    assert abs(np.mean(w > 0) - 0.5) < 4 * 0.5 / math.sqrt(N)
    # faster robots steer less
    assert np.mean(np.abs(w[v > 30])) < np.mean(np.abs(w[v < 5]))
    assert integrate.quad(lambda x: law.pdf(x, 3.0), -np.inf, np.inf)[0] == pytest.approx(1.0)


def test_headings(rng):
    u = M.UniformHeading().sample(rng, N)
    assert u.min() >= -np.pi and u.max() < np.pi and _ks_ok(u, M.UniformHeading().cdf)
    nh = M.NormalHeading(mean_angle=np.pi, sigma=0.5)
    a = nh.sample(rng, N)
    assert np.all((a >= -np.pi) & (a < np.pi))
    # circular mean at pi, spread 0.5
    assert abs(np.angle(np.mean(np.exp(1j * a))) % (2 * np.pi) - np.pi) < 0.01
    assert integrate.quad(nh.pdf, -np.pi, np.pi)[0] == pytest.approx(1.0, abs=1e-6)
    assert _ks_ok(a, nh.cdf)


def test_jaynes_solution_meets_the_constraint_and_maximises_entropy(rng):
    e = np.array([0.0, 1.0, 2.0, 3.0, 7.0])
    p, beta = M.jaynes(e, 1.5)
    assert p.sum() == pytest.approx(1.0) and (p * e).sum() == pytest.approx(1.5, abs=1e-10)
    assert np.allclose(p, np.exp(-beta * e) / np.exp(-beta * e).sum())
    H = -(p * np.log(p)).sum()
    # every other distribution with the same normalisation and mean has lower entropy:
    # perturb p along directions d with sum(d) = 0 and sum(d * e) = 0
    A = np.vstack([np.ones_like(e), e])
    null = np.linalg.svd(A)[2][2:]  # basis of the null space of the two constraints
    checked = 0
    for _ in range(200):
        d = null.T @ rng.standard_normal(null.shape[0])
        q = p + 0.5 * p.min() * d / np.abs(d).max()
        assert q.sum() == pytest.approx(1.0) and (q * e).sum() == pytest.approx(1.5)
        assert -(q * np.log(q)).sum() < H
        checked += 1
    assert checked == 200
    # above the states' mean the temperature is negative
    _, b2 = M.jaynes(e, 5.0)
    assert b2 < 0
    with pytest.raises(ValueError):
        M.jaynes(e, 9.0)


def test_fit_temperature_recovers_kT_within_its_standard_error(rng):
    x = M.EnergyLaw(12.0).sample(rng, 5000)
    kT, se = M.fit_temperature(x)
    assert abs(kT - 12.0) < 4 * se
    assert se == pytest.approx(kT / math.sqrt(5000))
    with pytest.raises(ValueError):
        M.fit_temperature(np.array([-1.0, 2.0]))
