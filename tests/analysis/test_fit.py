"""Fits and tests of the energy laws against known truths and independent computations."""

from __future__ import annotations

import math

import numpy as np
import pytest
from matplotlib.figure import Figure
from scipy import optimize, stats

from thermoswarm.analysis import _kernels as K
from thermoswarm.analysis.fit import ExponentialFit, ExponentialMixtureFit, ks_statistic, naive_ks
from thermoswarm.analysis.phase_tests import compare_phases, goodness_of_fit, likelihood_ratio_test
from thermoswarm.errors import InputError
from thermoswarm.maxent import EnergyLaw, EnergyMixture


def test_exponential_fit_is_the_mean_with_its_likelihood():
    x = np.random.default_rng(0).exponential(3.0, 500)
    f = ExponentialFit()
    assert f.fit(x) is f
    assert f.kT_ == pytest.approx(x.mean())
    assert f.kT_se_ == pytest.approx(x.mean() / math.sqrt(500))
    assert f.loglik_ == pytest.approx(stats.expon(scale=x.mean()).logpdf(x).sum())
    assert f.nllf() == pytest.approx(-f.loglik_)
    assert f.nllf(x[:10]) == pytest.approx(-stats.expon(scale=x.mean()).logpdf(x[:10]).sum())
    assert f.aic() == pytest.approx(2 * f.nllf() + 2)
    assert f.bic() == pytest.approx(2 * f.nllf() + math.log(500))
    assert f.params == {"kT": f.kT_}


@pytest.mark.parametrize("truth", [(0.6, 20.0, 80.0), (0.3, 5.0, 12.0), (0.85, 1.0, 30.0)])
def test_mixture_parameters_recovered_within_three_standard_errors(truth):
    phi, k1, k2 = truth
    x = EnergyMixture(phi, k1, k2).sample(np.random.default_rng(7), 20_000)
    f = ExponentialMixtureFit(random_state=1).fit(x)
    assert f.converged_ and not f.degenerate_
    for est, se, true in (
        (f.phi_, f.phi_se_, phi),
        (f.kT1_, f.kT1_se_, k1),
        (f.kT2_, f.kT2_se_, k2),
    ):
        assert np.isfinite(se) and se > 0
        assert abs(est - true) < 3 * se, (est, se, true)


def test_mixture_standard_errors_are_calibrated():
    """Over 40 datasets the z-scores of kT2 have unit spread (SE of a SD: 1/sqrt(2n))."""
    rng = np.random.default_rng(8)
    law = EnergyMixture(0.5, 10.0, 40.0)
    z = []
    for _ in range(40):
        f = ExponentialMixtureFit(random_state=rng).fit(law.sample(rng, 3000))
        z.append((f.kT2_ - 40.0) / f.kT2_se_)
    z = np.asarray(z)
    assert abs(z.std(ddof=1) - 1) < 3 / math.sqrt(2 * z.size)
    # the mean of 40 unit-spread z-scores has SE 1/sqrt(40); the ML bias of kT2 is O(1/n),
    # i.e. O(1/sqrt(n)) = O(0.02) standard errors at n = 3000: nothing to add to 3 SE
    assert abs(z.mean()) < 3 / math.sqrt(z.size)


def test_mixture_fit_is_the_likelihood_maximum():
    """A generic optimiser from many starts finds no higher likelihood."""
    x = EnergyMixture(0.4, 2.0, 9.0).sample(np.random.default_rng(9), 2000)
    f = ExponentialMixtureFit(random_state=0).fit(x)

    def nll(th):
        phi = 1 / (1 + math.exp(-th[0]))
        return -EnergyMixture(phi, math.exp(th[1]), math.exp(th[2])).logpdf(x).sum()

    best = min(
        optimize.minimize(nll, [a, math.log(b), math.log(c)], method="Nelder-Mead",
                          options={"xatol": 1e-8, "fatol": 1e-10, "maxiter": 4000}).fun
        for a in (-1.0, 0.0, 1.0) for b in (0.5, 2.0) for c in (6.0, 20.0)
    )  # fmt: skip
    assert f.nllf() <= best + 1e-6
    assert f.nllf() == pytest.approx(-f.law_.logpdf(x).sum())


def test_gradient_and_hessian_kernels_match_finite_differences():
    z = np.random.default_rng(1).exponential(1.0, 400)
    th = np.array([0.3, math.log(0.5), math.log(1.8)])

    def ll(t):
        phi = 1 / (1 + math.exp(-t[0]))
        return K.loglik(z, K.ONCE, phi, math.exp(t[1]), math.exp(t[2]))

    phi = 1 / (1 + math.exp(-th[0]))
    val, g, H = K.grad_hess(z, K.ONCE, phi, math.exp(th[1]), math.exp(th[2]))
    assert val == pytest.approx(ll(th))
    h = 1e-5
    eye = np.eye(3)
    g_num = np.array([(ll(th + h * e) - ll(th - h * e)) / (2 * h) for e in eye])
    np.testing.assert_allclose(g, g_num, rtol=1e-6, atol=1e-6)
    H_num = np.array(
        [[(ll(th + h * a + h * b) - ll(th + h * a - h * b) - ll(th - h * a + h * b)
           + ll(th - h * a - h * b)) / (4 * h * h) for b in eye] for a in eye]
    )  # fmt: skip
    np.testing.assert_allclose(H, H_num, rtol=1e-4, atol=1e-3)


def test_counted_samples_equal_the_samples_repeated():
    rng = np.random.default_rng(4)
    z = rng.exponential(1.0, 50)
    c = rng.integers(1, 5, 50).astype(np.float64)
    rep = np.repeat(z, c.astype(np.int64))
    p = (0.4, 0.5, 2.0)
    assert K.loglik(z, c, *p) == pytest.approx(K.loglik(rep, K.ONCE, *p), rel=1e-12)
    _, g, H = K.grad_hess(z, c, *p)
    _, g_rep, H_rep = K.grad_hess(rep, K.ONCE, *p)
    np.testing.assert_allclose(g, g_rep, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(H, H_rep, rtol=1e-10, atol=1e-12)
    em = K.em_steps(z, c, *p, 5, 0.0)[:3]
    np.testing.assert_allclose(em, K.em_steps(rep, K.ONCE, *p, 5, 0.0)[:3], rtol=1e-10)


def test_em_never_decreases_the_likelihood():
    z = np.random.default_rng(2).exponential(1.0, 1000)
    p = (0.5, 0.3, 2.0)
    last = K.loglik(z, K.ONCE, *p)
    for _ in range(30):
        phi, k1, k2, _, _ = K.em_steps(z, K.ONCE, *p, 1, 0.0)
        p = (phi, k1, k2)
        now = K.loglik(z, K.ONCE, *p)
        assert now >= last - 1e-9
        last = now


def test_components_are_sorted_cold_first():
    x = EnergyMixture(0.3, 50.0, 5.0).sample(np.random.default_rng(3), 5000)  # phi on hot
    f = ExponentialMixtureFit(random_state=0).fit(x, init=(0.3, 50.0, 5.0))
    assert f.kT1_ < f.kT2_
    assert abs(f.phi_ - 0.7) < 3 * f.phi_se_
    assert f.predict_proba(np.array([0.0]))[0] < 0.5 < f.predict_proba(np.array([500.0]))[0]


def test_units_do_not_matter():
    x = EnergyMixture(0.6, 2.0, 8.0).sample(np.random.default_rng(4), 3000)
    a = ExponentialMixtureFit(random_state=0).fit(x)
    b = ExponentialMixtureFit(random_state=0).fit(x * 1e-12)  # joules-sized numbers
    assert b.phi_ == pytest.approx(a.phi_, rel=1e-6)
    assert b.kT2_ == pytest.approx(a.kT2_ * 1e-12, rel=1e-6)
    assert b.loglik_ == pytest.approx(a.loglik_ - x.size * math.log(1e-12), rel=1e-9)


@pytest.mark.parametrize(
    ("x", "match"),
    [([1.0], "at least"), ([1.0, -1.0, 2.0, 3.0], "non-negative"), ([0.0] * 5, "all samples"),
     ([1.0, np.nan, 2.0, 3.0], "NaN")],
)  # fmt: skip
def test_bad_samples_are_input_errors(x, match):
    with pytest.raises(InputError, match=match):
        ExponentialMixtureFit().fit(x)


def test_ks_matches_scipy_and_naive_p_is_kstest():
    x = np.random.default_rng(5).exponential(2.0, 300)
    law = EnergyLaw(2.1)
    ref = stats.kstest(x, law.cdf, method="exact")
    assert ks_statistic(x, law) == pytest.approx(ref.statistic, abs=1e-12)
    d, p, n = naive_ks(x, law)
    assert p == pytest.approx(ref.pvalue, rel=1e-6) and n == 300
    mix = EnergyMixture(0.5, 1.0, 4.0)
    assert ks_statistic(x, mix) == pytest.approx(stats.kstest(x, mix.cdf).statistic, abs=1e-12)
    big = np.random.default_rng(6).exponential(2.0, 30_000)
    ref = stats.kstest(big, EnergyLaw(2.01).cdf)
    d, p, _ = naive_ks(big, EnergyLaw(2.01))
    assert d == pytest.approx(ref.statistic, abs=1e-12) and p == pytest.approx(
        ref.pvalue, rel=1e-6
    )


def test_one_phase_goodness_of_fit_accepts_and_rejects():
    rng = np.random.default_rng(6)
    x = rng.exponential(5.0, 800)
    good = goodness_of_fit("one_phase", x, n_bootstrap=199, random_state=1)
    assert good.n == 800 and good.p_value > 0.05
    assert good.statistic == pytest.approx(ks_statistic(x, EnergyLaw(x.mean())), abs=1e-12)
    bad = goodness_of_fit("one_phase", EnergyMixture(0.6, 2.0, 20.0).sample(rng, 800),
                          n_bootstrap=199, random_state=1)  # fmt: skip
    assert bad.p_value < 0.05
    # the p-value counts the replicates at least as large as the statistic
    k = int((bad.null_distribution >= bad.statistic).sum())
    assert bad.p_value == pytest.approx((k + 1) / 200)


def test_two_phase_goodness_of_fit_accepts_mixtures_rejects_other_laws():
    rng = np.random.default_rng(7)
    ok = goodness_of_fit("two_phase", EnergyMixture(0.6, 2.0, 20.0).sample(rng, 1000),
                         n_bootstrap=99, random_state=2)  # fmt: skip
    assert ok.p_value > 0.05
    # a gamma law with shape 3 has a mode away from zero: no exponential mixture fits it
    bad = goodness_of_fit("two_phase", rng.gamma(3.0, 2.0, 1000), n_bootstrap=99,
                          random_state=2)  # fmt: skip
    assert bad.p_value < 0.05


def test_likelihood_ratio_prefers_two_phases_only_when_there_are_two():
    rng = np.random.default_rng(8)
    two = likelihood_ratio_test(EnergyMixture(0.6, 20.0, 80.0).sample(rng, 2000),
                                n_bootstrap=99, random_state=3)  # fmt: skip
    assert two.p_value < 0.05 and two.statistic > 0
    one = likelihood_ratio_test(rng.exponential(40.0, 2000), n_bootstrap=99, random_state=3)
    assert one.p_value > 0.05


def test_compare_phases_result_and_reproducibility():
    x = EnergyMixture(0.6, 20.0, 80.0).sample(np.random.default_rng(9), 3000)
    x = np.append(x, [0.0, 0.0])
    a = compare_phases(x, n_bootstrap=49, random_state=5)
    b = compare_phases(x, n_bootstrap=49, random_state=5)
    da, db = a.to_dict(), b.to_dict()
    assert da == db
    assert da["n_zero"] == 2 and da["n"] == 3000
    assert da["preferred"] == "two_phase" and da["bic_preferred"] == "two_phase"
    assert da["two_phase"]["naive"]["n"] == 3000
    assert da["one_phase"]["naive"]["p_value"] < 1e-6
    assert da["delta_bic"] < 0
    # a separate test sample: the tests' n is its size, the estimates use all samples
    c = compare_phases(x, test_x=x[:500], n_bootstrap=19, random_state=5).to_dict()
    assert c["one_phase"]["n"] == 500 and c["lr_n"] == 500 and c["n"] == 3000
    assert c["two_phase"]["kT2"] == pytest.approx(da["two_phase"]["kT2"])


def test_without_bootstrap_bic_decides():
    x = np.random.default_rng(10).exponential(3.0, 2000)
    d = compare_phases(x, n_bootstrap=0, random_state=0).to_dict()
    assert d["lr_p_value"] is None and d["one_phase"]["p_value"] is None
    assert d["preferred"] == "one_phase" == d["bic_preferred"]
    assert "BIC" in d["preferred_by"] or "collapsed" in d["preferred_by"]


def test_plot_draws_data_and_fits_on_log_axes():
    x = EnergyMixture(0.6, 2.0, 20.0).sample(np.random.default_rng(11), 2000)
    f = ExponentialMixtureFit(random_state=0).fit(x)
    ax = Figure().subplots()
    assert f.plot(ax, x) is ax
    assert ax.get_yscale() == "log"
    labels = [ln.get_label() for ln in ax.get_lines()]
    assert "data" in labels and any(lab.startswith("2 phases") for lab in labels)
    assert len(ax.get_lines()) == 4  # data, mixture, two components
