"""Every verdict states its test, its sample and the smallest effect it can detect
(issue 33, "verdicts with power"); the minimum detectable effect is computed from the
row's own numbers, so a smaller sample states a larger one."""

from __future__ import annotations

import itertools
import math
import re
from statistics import NormalDist

import numpy as np
import pytest
from scipy import stats

from thermoswarm.report.paper import COMPARISONS, compare
from thermoswarm.report.power import (
    mde,
    mde_failure_rate,
    mde_ks,
    mde_spearman,
    p_floor,
    power_note,
    rank_p_floor,
)

Z = NormalDist()


def test_mde_known_answers():
    # (z_0.975 + z_0.8) SE: 1.95996 + 0.84162 = 2.80158 for SE = 1
    assert mde(1.0) == pytest.approx(2.80158, abs=1e-5)
    assert mde(2.5) == pytest.approx(2.5 * 2.80158, abs=1e-4)
    # at the MDE a two-sided 5 % z-test rejects with probability 0.8 (by definition)
    d = mde(1.0)
    assert 1 - Z.cdf(1.959964 - d) + Z.cdf(-1.959964 - d) == pytest.approx(0.8, abs=1e-4)
    # Student quantiles for few degrees of freedom: t_0.975(4) 2.7764 + t_0.8(4) 0.9410
    assert mde(1.0, df=4) == pytest.approx(2.7764 + 0.9410, abs=1e-3)
    assert mde(1.0, df=10_000) == pytest.approx(mde(1.0), abs=1e-3)
    assert mde(None) is None and mde(float("nan")) is None and mde(1.0, df=0) is None
    assert p_floor(199) == 0.005 and p_floor(0) is None
    # every run succeeds in n runs: the failure rate seen with probability 0.8
    assert mde_failure_rate(1) == pytest.approx(0.8)
    assert (1 - mde_failure_rate(3)) ** 3 == pytest.approx(0.2)
    assert mde_failure_rate(10) < mde_failure_rate(3) and mde_failure_rate(0) is None
    assert mde_spearman(3) is None and mde_ks(0) is None


@pytest.mark.parametrize("groups", [[1, 1, 1, 1], [2, 2], [2, 1, 1], [1, 1, 1, 1, 1], [3, 2]])
def test_rank_p_floor_is_the_exact_permutation_floor(groups):
    """Every ordering of distinct responses over x values with these ties: the share
    whose |Spearman rho| reaches the largest possible is the smallest two-sided p."""
    x = np.repeat(np.arange(len(groups)), groups)
    rhos = np.array([stats.spearmanr(x, perm).statistic
                     for perm in itertools.permutations(range(len(x)))])  # fmt: skip
    share = np.mean(np.abs(rhos) >= np.abs(rhos).max() - 1e-12)
    assert rank_p_floor(groups) == pytest.approx(share, rel=1e-12)


def test_rank_p_floor_known_answers():
    assert rank_p_floor([1, 1, 1, 1]) == pytest.approx(2 / 24)  # 0.083: never below 5 %
    assert rank_p_floor([2, 2]) == pytest.approx(1 / 3)
    assert rank_p_floor([1] * 5) == pytest.approx(2 / 120)  # 0.017: can reject
    assert rank_p_floor([5, 5]) == pytest.approx(2 * 120**2 / math.factorial(10))
    assert rank_p_floor([4]) is None and rank_p_floor(None) is None


def test_a_rank_trend_that_no_ordering_makes_significant_is_not_resolved():
    """Two sizes of two runs: even a perfect ordering gives p = 1/3, so a flat or a
    rising capacity is not resolved; ten runs a size can decide."""
    rows = [{"n": n, "maxdisp_median": m, "seeds": k, "reached": 0}
            for n, m, k in [(50, 8.0, 2), (150, 14.0, 2)]]  # fmt: skip
    for trend in ({"spearman_rho": 0.0, "spearman_p": 1.0},
                  {"spearman_rho": 0.9, "spearman_p": 0.01}):  # fmt: skip
        u = compare("scaling", {"rows": rows, "trend": trend})[0]
        assert u["verdict"] == "not resolved at this scale", u
        assert "smallest p-value of an exact rank test is 0.33" in u["why"]
    more = [dict(r, seeds=10) for r in rows]
    flat = compare("scaling", {"rows": more, "trend": {"spearman_rho": 0.0, "spearman_p": 1.0}})
    assert flat[0]["verdict"] == "differs"


def test_mde_spearman_has_its_power_by_simulation():
    """Bivariate normal pairs whose Spearman correlation is the MDE of n = 30 pairs:
    the rank test rejects at 5 % in about 80 % of 400 draws (binomial sd 0.02)."""
    n, rho_s = 30, mde_spearman(30)
    r = 2 * math.sin(math.pi * rho_s / 6)  # Pearson r of a normal pair with that rho_s
    rng = np.random.default_rng(7)
    cov = [[1.0, r], [r, 1.0]]
    hits = [stats.spearmanr(*rng.multivariate_normal([0, 0], cov, n).T).pvalue < 0.05
            for _ in range(400)]  # fmt: skip
    assert 0.7 < np.mean(hits) < 0.9


def test_mde_ks_has_its_power_by_simulation():
    """Values whose CDF lies the MDE away from the uniform's, broadly (x + D sin(pi x))
    or in a narrow bump: the one-sample KS test rejects in at least about 80 % of 400
    draws (binomial sd 0.02) whatever the shape; at half the MDE, rarely."""
    n = 200
    grid = np.linspace(0, 1, 20001)
    rng = np.random.default_rng(11)

    def power(cdf):
        return np.mean([stats.kstest(np.interp(rng.random(n), cdf, grid), "uniform").pvalue
                        < 0.05 for _ in range(400)])  # fmt: skip

    for d in (mde_ks(n), mde_ks(n) / 2):
        broad = grid + d * np.sin(np.pi * grid)
        bump = grid + d * np.exp(-(((grid - 0.5) / 0.15) ** 2))
        assert np.all(np.diff(bump) > 0)  # a distribution function
        got = [power(broad), power(bump)]
        assert min(got) > 0.74 if d == mde_ks(n) else max(got) < 0.5


def test_power_note_says_test_sample_and_effect():
    text = power_note("bootstrap LR", "3 seeds x 2,000 samples", "kT difference 4.1 mm^2/s^2")
    assert text == (
        "test: bootstrap LR; sample: 3 seeds x 2,000 samples; smallest detectable effect "
        "(two-sided 5 % level, 80 % power): kT difference 4.1 mm^2/s^2"
    )
    assert "none computable" in power_note("t", "1 run", None)


def _ants(n_steps, n_test, se=(0.5, 2.0)):
    return {"preferred": "two_phase", "lr_p_value": 0.005, "ks_p_value_preferred": 0.4,
            "one_phase_kT": 12.0, "one_phase_kT_se": 0.3, "n_steps": n_steps,
            "n_test": n_test, "n_bootstrap": 200,
            "two_phase": {"phi": 0.3, "kT1": 3.0, "kT2": 16.0, "kT1_se": se[0],
                          "kT2_se": se[1]}}  # fmt: skip


def _number(pattern, text):
    m = re.search(pattern, text)
    assert m, text
    return float(m.group(1).replace(",", ""))


KT_MDE = r"kT difference between the phases ([\d.,]+) mm\^2/s\^2"


def test_the_ant_row_states_its_test_sample_and_mde():
    row = compare("unified_law", {"ants": _ants(5000, 200)})[1]
    why = row["why"]
    assert "test: bootstrap likelihood-ratio test of one exponential phase against two" in why
    assert "sample: 5,000 steps fitted, 200 in the decorrelated test sample" in why
    assert "200 bootstrap replicates (smallest p 0.005)" in why
    # the fit's standard errors, scaled from 5,000 steps to the 200 tested
    want = mde(math.hypot(0.5, 2.0) * math.sqrt(5000 / 200))
    assert _number(KT_MDE, why) == pytest.approx(want, rel=0.01)


def test_a_tiny_sample_states_a_larger_mde_than_a_large_one():
    # the same fit, tested on 20 decorrelated steps against 2,000
    tiny = compare("unified_law", {"ants": _ants(5000, 20)})[1]["why"]
    large = compare("unified_law", {"ants": _ants(5000, 2000)})[1]["why"]
    assert _number(KT_MDE, tiny) == pytest.approx(10 * _number(KT_MDE, large), rel=0.02)

    # the drift maps: a cell's standard error over 3 seeds against one over 30
    def regime(se, seeds):
        cell = {"map": "cold", "x": 1.0, "y": 1.0, "drift_mean": 0.1, "drift_se": se,
                "seeds": seeds, "verdict": "no detectable motion"}  # fmt: skip
        return compare("regime", {"rows": [cell], "seeds": seeds})[0]["why"]

    pat = r"80 % power\): mean drift ([\d.]+)-"
    few, many = regime(0.3, 3), regime(0.3 / math.sqrt(10), 30)
    assert _number(pat, few) > 3 * _number(pat, many)
    assert _number(pat, few) == pytest.approx(mde(0.3, df=2), rel=0.01)


def test_the_robots_are_not_resolved_when_the_set_gap_is_below_the_mde():
    rob = {**_ants(3000, 30, se=(5.0, 10.0)), "preferred": "one_phase", "kT_hot": 110.0,
           "kT_cold": 5.0}  # fmt: skip
    weak = compare("unified_law", {"robots": rob})[-1]
    assert weak["verdict"] == "not resolved at this scale"
    assert "the set temperatures differ by 105 mm^2/s^2, less than the" in weak["why"]
    strong = compare("unified_law", {"robots": {**rob, "n_test": 3000}})[-1]
    assert strong["verdict"] == "differs" and "less than the" not in strong["why"]


def test_the_steering_trend_states_the_slope_it_detects():
    st = {"by": "energy", "bins": 6, "k": 6, "bins_exponential": 6, "slope": -0.01,
          "slope_se": 0.004, "p_value": 0.06, "bin_n": [40, 90, 100, 100, 100, 100]}  # fmt: skip
    rows = compare("unified_law", {"ants": {"preferred": "two_phase", "steering": st}})
    law = next(r for r in rows if "speed bin" in r["claim"])["why"]
    trend = next(r for r in rows if "falls with speed" in r["claim"])["why"]
    assert "sample: 40-100 decorrelated rates per bin" in law
    assert _number(r"KS distance ([\d.]+) in the smallest bin", law) == pytest.approx(
        mde_ks(40), abs=0.006)  # fmt: skip
    assert "t-test of the weighted least-squares slope (4 degrees of freedom)" in trend
    assert _number(r"slope ([\d.]+) rad/s per", trend) == pytest.approx(
        mde(0.004, df=4), rel=0.01)  # fmt: skip


def test_a_difference_within_its_noise_is_not_resolved():
    road = {"crossings": {"+x": 5, "-x": 4}, "longest_zero_flow_s": {"overall": 20.0},
            "duration_s": 600, "n": 40}  # fmt: skip
    close = {**road, "section_energy": {"wide": {"mean": 50.0, "se": 2.0},
                                        "narrow": {"mean": 47.0, "se": 2.0}}}  # fmt: skip
    far = {**road, "section_energy": {"wide": {"mean": 50.0, "se": 0.5},
                                      "narrow": {"mean": 47.0, "se": 0.5}}}  # fmt: skip
    assert compare("narrow_road", close)[1]["verdict"] == "not resolved at this scale"
    assert compare("narrow_road", far)[1]["verdict"] == "reproduced"
    why = compare("narrow_road", far)[1]["why"]
    assert _number(r"energy difference ([\d.]+) mm", why) == pytest.approx(
        mde(math.hypot(0.5, 0.5)), rel=0.01)  # fmt: skip


#: one results block per experiment, with the fields each row reads
RESULTS = {
    "unified_law": {"ants": _ants(5000, 200), "gas": {**_ants(9000, 300),
                    "preferred": "one_phase", "mean_energy_per_particle": 12.1},
                    "robots": {**_ants(3000, 300), "kT_hot": 110.0, "kT_cold": 5.0}},
    "narrow_road": {"crossings": {"+x": 5, "-x": 4}, "longest_zero_flow_s": {"overall": 2.0},
                    "duration_s": 600, "n": 40, "section_energy": {
                        "wide": {"mean": 50.0, "se": 0.5}, "narrow": {"mean": 40.0, "se": 0.5}}},
    "compression": {"dilute_Z_mean": 1.02, "isotherm": [{"Z": 1.0, "Z_se": 0.02}] * 5,
                    "pressure_vs_temperature": {"r2": 0.999, "n_points": 5},
                    "temperature_for_density": {"r2": 0.995, "n_points": 4}},
    "transport_connected": {"seeds": 3, "reached": 3, "time_to_target_mean": 300.0},
    "transport_free": {"default": {"seeds": 3, "time_to_target": [None] * 3, "reached": 0,
                                   "displacement_toward_target_mean": 90.0,
                                   "displacement_toward_target_se": 20.0, "mean_over_se": 4.5},
                       "obstacle": {"time_to_target": 800.0},
                       "zigzag": {"time_to_target": None, "duration_s": 60}},
    "regime": {"seeds": 3, "rows": [{"drift_mean": 1.0, "drift_se": 0.2, "seeds": 3,
                                     "verdict": "toward target"}]},
    "mechanism": {"rows": [{"mapping": "lit_cold", "heading_law": "persistent",
                            "sensor.mode": "ideal", "disp_mean": 30.0, "disp_se": 5.0,
                            "seeds": 4, "verdict": "toward target"}]},
    "scaling": {"rows": [{"n": n, "maxdisp_median": m, "maxdisp_ci_low": m - 5, "seeds": 5,
                          "reached": 5, "time_median": t, "time_ci_high": t + 50}
                         for n, m, t in [(50, 10.0, 900.0), (200, 20.0, 500.0)]],
                "trend": {"spearman_rho": 0.7, "spearman_p": 0.001, "n_runs": 10}},
}  # fmt: skip


@pytest.mark.parametrize("name", sorted(COMPARISONS))
def test_every_measured_row_states_its_test_sample_and_smallest_effect(name):
    rows = [r for r in compare(name, RESULTS[name]) if r["verdict"] != "not measured"]
    assert rows, name
    for r in rows:
        assert re.search(r"test: [^;]+; sample: [^;]+; smallest detectable", r["why"]), r
