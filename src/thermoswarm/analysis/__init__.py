"""Analysis of trajectories from any source: kinematics, maximum-entropy fits, the study.

Dependencies run one way: kinematics and fits (on :mod:`thermoswarm.maxent`) ->
the study -> :mod:`thermoswarm.report.analysis_figures` (figures, the HTML report) and
:mod:`thermoswarm.report.analysis_run` (:func:`analyze_file`: files in, files out)
-> the CLI.  Nothing here imports the report or the CLI.

- :mod:`~thermoswarm.analysis.kinematics`: speed, energy, heading, steering rate per step,
  each individual on its own clock, every step in one counted bucket; built on
  :mod:`~thermoswarm.analysis.samples` (sorting, duplicates, gaps, smoothing) and
  :mod:`~thermoswarm.analysis.exclusions` (implausible motion, resting, the buckets);
- :mod:`~thermoswarm.analysis.fit`: one and two exponentials (ML), BIC;
- :mod:`~thermoswarm.analysis.phase_tests`: bootstrap goodness of fit, bootstrap
  likelihood-ratio test, one phase against two;
- :mod:`~thermoswarm.analysis.sampling`: the thinned test sample the tests run on;
- :mod:`~thermoswarm.analysis.recording`: what a recording says of itself (sampling
  interval, control period, recorded speeds and headings), shared-position masking;
- :mod:`~thermoswarm.analysis.regions`: named polygons from TOML;
- :mod:`~thermoswarm.analysis.study`: the paper's study (:func:`analyze_tracks`), built
  from :mod:`~thermoswarm.analysis.phases` (one phase or two, plausibility),
  :mod:`~thermoswarm.analysis.groups`, :mod:`~thermoswarm.analysis.steering` and
  :mod:`~thermoswarm.analysis.region_stats`;
- :mod:`~thermoswarm.analysis.explain`: p-values and statements that explain themselves;
- :mod:`~thermoswarm.analysis.synthetic`: tracks drawn from known laws.
"""

from thermoswarm.analysis.fit import ExponentialFit, ExponentialMixtureFit
from thermoswarm.analysis.kinematics import compute_kinematics
from thermoswarm.analysis.phase_tests import (
    compare_phases,
    goodness_of_fit,
    likelihood_ratio_test,
)
from thermoswarm.analysis.study import analyze_tracks, run_study

__all__ = [
    "ExponentialFit",
    "ExponentialMixtureFit",
    "compare_phases",
    "goodness_of_fit",
    "likelihood_ratio_test",
    "compute_kinematics",
    "analyze_tracks",
    "run_study",
]
