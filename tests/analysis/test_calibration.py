"""Calibration of the bootstrap p-values: false rejections at 5 % over many null datasets.

With 200 datasets the standard error of a 5 % rate is 1.5 %, so +/- 2 % would fail one
calibrated test in five by chance.  We use 1,000 datasets: standard error 0.69 %, and
+/- 2 % is 2.9 standard errors.  (The fast version run by ``make test`` is
``test_calibration_fast.py``.)
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from thermoswarm.analysis.fit import naive_ks
from thermoswarm.analysis.phase_tests import goodness_of_fit, likelihood_ratio_test
from thermoswarm.analysis.sampling import draw_test_sample
from thermoswarm.maxent import EnergyLaw, EnergyMixture

N_DATASETS = 1000
B = 99  # P(p <= 0.05) is exactly 5/100 for an exact Monte Carlo test
TOL = 0.02
assert TOL >= 2.9 * math.sqrt(0.05 * 0.95 / N_DATASETS)


@pytest.mark.slow
def test_lr_and_one_phase_gof_are_calibrated_under_one_phase():
    rng = np.random.default_rng(2024)
    lr = gof = naive = 0
    for _ in range(N_DATASETS):
        x = rng.exponential(10.0, 200)
        lr += likelihood_ratio_test(x, n_bootstrap=B, random_state=rng).p_value <= 0.05
        gof += goodness_of_fit("one_phase", x, n_bootstrap=B, random_state=rng).p_value <= 0.05
        naive += naive_ks(x, EnergyLaw(x.mean()))[1] <= 0.05
    print(f"\ncalibration, one phase, n=200: LR {lr / N_DATASETS:.3f}, KS {gof / N_DATASETS:.3f}, "
          f"naive KS {naive / N_DATASETS:.3f}")  # fmt: skip
    assert abs(lr / N_DATASETS - 0.05) <= TOL, lr
    assert abs(gof / N_DATASETS - 0.05) <= TOL, gof
    # The paper's p-value (fitted law taken as known) hardly ever rejects: miscalibrated.
    assert naive / N_DATASETS < 0.05 - TOL, naive


@pytest.mark.slow
def test_two_phase_gof_is_calibrated_under_two_phases():
    rng = np.random.default_rng(2025)
    law = EnergyMixture(0.6, 20.0, 80.0)
    rej = 0
    for _ in range(N_DATASETS):
        x = law.sample(rng, 300)
        rej += goodness_of_fit("two_phase", x, n_bootstrap=B, random_state=rng).p_value <= 0.05
    print(f"\ncalibration, two phases, n=300: KS {rej / N_DATASETS:.3f}")
    assert abs(rej / N_DATASETS - 0.05) <= TOL, rej


@pytest.mark.slow
def test_thinning_keeps_the_test_calibrated_on_autocorrelated_tracks():
    """Each energy held for 5 frames (a tracked animal keeps its speed for a while).

    On all frames, the test of a true exponential law rejects far too often; on the
    test sample thinned by the estimated autocorrelation time it is calibrated.
    """
    rng = np.random.default_rng(2026)
    thinned = raw = 0
    steps = []
    for _ in range(N_DATASETS):
        held = np.repeat(rng.exponential(10.0, (40, 20)), 5, axis=0)  # (200 frames, 20 tracks)
        valid = np.ones_like(held, dtype=bool)
        sample, info = draw_test_sample(held, valid, max_n=None, rng=rng)
        steps.append(info["thinning_step"])
        p = goodness_of_fit("one_phase", sample, n_bootstrap=B, random_state=rng).p_value
        thinned += p <= 0.05
        p = goodness_of_fit("one_phase", held.ravel(), n_bootstrap=B, random_state=rng).p_value
        raw += p <= 0.05
    print(f"\ncalibration, held 5 frames: thinned {thinned / N_DATASETS:.3f}, "
          f"all frames {raw / N_DATASETS:.3f}, median step {np.median(steps)}")  # fmt: skip
    assert np.median(steps) == 5
    assert abs(thinned / N_DATASETS - 0.05) <= TOL, thinned
    assert raw / N_DATASETS > 0.2, raw
