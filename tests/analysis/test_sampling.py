"""Autocorrelation time and the thinned test sample."""

from __future__ import annotations

import numpy as np
import pytest

from thermoswarm.analysis.sampling import (
    DECORRELATION_THRESHOLD,
    autocorrelation,
    decorrelation_lag,
    draw_test_sample,
    integrated_autocorr_time,
)


def ar1(a: float, n_t: int, n_i: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    e = rng.standard_normal((n_t, n_i))
    x = np.empty_like(e)
    x[0] = e[0] / np.sqrt(1 - a * a)
    for t in range(1, n_t):
        x[t] = a * x[t - 1] + e[t]
    return x


def test_independent_samples_have_tau_one():
    x = np.random.default_rng(0).standard_normal((2000, 50))
    tau = integrated_autocorr_time(x, np.ones_like(x, dtype=bool))
    # Sokal's estimator: var ~ 2 (2M + 1) / N tau^2 with M ~ 5, N = 1e5
    assert abs(tau - 1.0) < 3 * np.sqrt(2 * 11 / x.size)


@pytest.mark.parametrize("masked", [False, True])
def test_ar1_tau_is_recovered(masked):
    a = 0.8
    truth = (1 + a) / (1 - a)  # 9
    x = ar1(a, 2000, 100, seed=1)
    valid = np.ones_like(x, dtype=bool)
    if masked:
        valid = np.random.default_rng(2).random(x.shape) > 0.2
        x = np.where(valid, x, np.nan)
    tau = integrated_autocorr_time(x, valid)
    se = truth * np.sqrt(2 * (2 * 5 * truth + 1) / valid.sum())
    assert abs(tau - truth) < 3 * se


def test_decorrelation_lag_of_ar1_and_held_values():
    a = 0.8
    x = ar1(a, 2000, 100, seed=5)
    valid = np.ones_like(x, dtype=bool)
    k = decorrelation_lag(x, valid)
    se = 1 / np.sqrt(x.size)  # of one lag's rho, roughly
    assert a**k <= DECORRELATION_THRESHOLD + 3 * se
    assert a ** (k - 1) >= DECORRELATION_THRESHOLD - 3 * se
    rho = autocorrelation(x, valid)
    assert rho[0] == 1.0 and abs(rho[1] - a) < 3 * se * 3
    held = np.repeat(np.random.default_rng(6).standard_normal((40, 30)), 5, axis=0)
    assert decorrelation_lag(held, np.ones_like(held, dtype=bool)) == 5  # rho(4) = 0.2
    iid = np.random.default_rng(7).standard_normal((300, 10))
    assert decorrelation_lag(iid, np.ones_like(iid, dtype=bool)) == 1


def test_persistent_track_offsets_do_not_count_as_correlation():
    rng = np.random.default_rng(3)
    x = rng.standard_normal((500, 40)) + rng.normal(0, 5, 40)[None, :]
    assert integrated_autocorr_time(x, np.ones_like(x, dtype=bool)) < 1.2


def test_draw_test_sample_thins_and_caps():
    held = np.repeat(np.random.default_rng(4).standard_normal((200, 20)), 5, axis=0)
    valid = np.ones_like(held, dtype=bool)
    s, info = draw_test_sample(held, valid, max_n=None, thin="auto", rng=np.random.default_rng(0))
    assert info["thinning_step"] == 5 and s.size == held.size // 5
    assert np.unique(s).size == s.size  # one sample per held value: independent draws
    s2, info2 = draw_test_sample(held, valid, max_n=500, thin=3, rng=np.random.default_rng(0))
    assert s2.size == 500 and info2["thinning_step"] == 3 and info2["n_available"] == held.size
    assert np.isin(s2, held).all()
    s3, _ = draw_test_sample(held, valid, max_n=None, thin=1, rng=np.random.default_rng(0))
    np.testing.assert_array_equal(s3, held[valid])
    s4, info4 = draw_test_sample(held, valid, max_n=None, step=2, rng=np.random.default_rng(0))
    assert info4["thinning_step"] == 2 and s4.size == held.size // 2
    a, _ = draw_test_sample(held, valid, max_n=300, rng=np.random.default_rng(9))
    b, _ = draw_test_sample(held, valid, max_n=300, rng=np.random.default_rng(9))
    np.testing.assert_array_equal(a, b)
    with pytest.raises(ValueError, match="thin"):
        draw_test_sample(held, valid, thin=0, rng=np.random.default_rng(0))


def test_autocorrelation_of_short_tracks_beside_a_long_one_equals_the_dense_sum():
    # the batches sorted by track length give the sums over all pairs of each track
    rng = np.random.default_rng(3)
    v = np.full((400, 30), np.nan)
    v[:, 0] = rng.exponential(1.0, 400)
    v[:7, 1:] = rng.exponential(1.0, (7, 29))
    ok = np.isfinite(v)
    rho = autocorrelation(v, ok, chunk=4)
    num = np.zeros(400)
    cnt = np.zeros(400)
    for i in range(30):
        x = v[ok[:, i], i] - v[ok[:, i], i].mean()
        for k in range(x.size):
            num[k] += (x[: x.size - k] * x[k:]).sum()
            cnt[k] += x.size - k
    expect = np.where(cnt > 0, num / np.where(cnt > 0, cnt, 1), np.nan)
    np.testing.assert_allclose(rho, expect / expect[0], rtol=1e-9, atol=1e-12)
