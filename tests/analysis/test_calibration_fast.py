"""Fast calibration of the bootstrap p-values, run by ``make test``.

200 null datasets, 19 bootstrap replicates each.  With B = 19 an exact Monte Carlo
test gives P(p <= k/20) = k/20 exactly, so the number of datasets with p <= 0.2 is
Binomial(200, 0.2): mean 40, standard deviation 5.66.  The test accepts 40 +/- 3.3
standard deviations, [22, 58] (two-sided binomial probability of failing a
calibrated test: about 0.1 %).  The level 0.2 rather than 0.05 keeps the test able
to fail: a p-value that is too conservative (the paper's naive KS) puts only a few
datasets below 0.2, one that is too liberal many more than 58 (the long test,
tests/analysis/test_calibration.py, uses 1,000 datasets at 0.05).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

from thermoswarm.analysis.fit import naive_ks
from thermoswarm.analysis.phase_tests import goodness_of_fit, likelihood_ratio_test
from thermoswarm.maxent import EnergyLaw, EnergyMixture

N, B, LEVEL = 200, 19, 0.2
SD = math.sqrt(N * LEVEL * (1 - LEVEL))
LOW, HIGH = math.ceil(N * LEVEL - 3.3 * SD), math.floor(N * LEVEL + 3.3 * SD)
# the acceptance region holds a calibrated count with probability about 0.999
assert stats.binom.cdf(HIGH, N, LEVEL) - stats.binom.cdf(LOW - 1, N, LEVEL) > 0.998


def test_lr_test_and_one_phase_gof_are_calibrated_under_one_phase():
    rng = np.random.default_rng(7)
    lr = gof = naive = 0
    for _ in range(N):
        x = rng.exponential(10.0, 100)
        lr += likelihood_ratio_test(x, n_bootstrap=B, random_state=rng).p_value <= LEVEL
        gof += goodness_of_fit("one_phase", x, n_bootstrap=B, random_state=rng).p_value <= LEVEL
        naive += naive_ks(x, EnergyLaw(x.mean()))[1] <= LEVEL
    assert LOW <= lr <= HIGH, lr
    assert LOW <= gof <= HIGH, gof
    assert naive < LOW, naive  # the paper's p-value: far too conservative


def test_two_phase_gof_is_calibrated_under_two_phases():
    rng = np.random.default_rng(8)
    law = EnergyMixture(0.6, 20.0, 80.0)
    rej = 0
    for _ in range(N):
        x = law.sample(rng, 150)
        rej += goodness_of_fit("two_phase", x, n_bootstrap=B, random_state=rng).p_value <= LEVEL
    assert LOW <= rej <= HIGH, rej
