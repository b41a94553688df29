"""False-rejection rates of the bootstrap tests on null datasets, one test per run.

Not collected by pytest (minutes of CPU); the numbers in docs/analysis.md ("One
procedure, before and after") come from it::

    PYTHONPATH=src python tests/analysis/calibration_runs.py lr 1000          # seed 2024
    PYTHONPATH=src python tests/analysis/calibration_runs.py gof 1000         # seed 2025
    PYTHONPATH=src python tests/analysis/calibration_runs.py gof 1000 7777

``lr``: the bootstrap likelihood-ratio test under one exponential (n = 200); ``gof``:
the two-phase KS test under the mixture (0.6, 20, 80) (n = 300); B = 99 replicates,
rejection at p <= 0.05.  Prints the test, the count, the rate and the CPU time.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from thermoswarm.analysis.phase_tests import goodness_of_fit, likelihood_ratio_test
from thermoswarm.maxent import EnergyMixture

B = 99


def main(which: str, n: int, seed: int | None = None) -> float:
    t0 = time.process_time()
    rej = 0
    if which == "lr":
        rng = np.random.default_rng(seed or 2024)
        for _ in range(n):
            x = rng.exponential(10.0, 200)
            rej += (
                likelihood_ratio_test(x, n_bootstrap=B, random_state=rng, n_jobs=1).p_value <= 0.05
            )
    elif which == "gof":
        rng = np.random.default_rng(seed or 2025)
        law = EnergyMixture(0.6, 20.0, 80.0)
        for _ in range(n):
            x = law.sample(rng, 300)
            p = goodness_of_fit("two_phase", x, n_bootstrap=B, random_state=rng, n_jobs=1).p_value
            rej += p <= 0.05
    else:
        raise SystemExit(f"usage: {sys.argv[0]} lr|gof N [SEED]")
    print(f"{which} {n} {rej} {rej / n:.3f} cpu {time.process_time() - t0:.1f}s")
    return rej / n


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]) if len(sys.argv) > 3 else None)
