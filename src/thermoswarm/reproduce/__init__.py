"""``thermoswarm reproduce``: every robot experiment of the paper, into one report.

Runs, into ``OUT/``:

1. ``narrow-road`` for the paper's 5,600 s: flows per direction, zero-flow gaps,
   speed and energy per road section;
2. ``compression``: an isotherm (pressure against area with the ideal-gas curve), the
   pressure against temperature at fixed density, and the temperature that holds the
   density fixed as the force varies (the paper's panel w);
3. ``transport-connected``: the object carried into the target room, over seeds;
4. ``transport-free``: the default (the regime of the drift-speed search in which the
   object reaches the target fastest) and the ``obstacle`` and ``zigzag`` variants,
   with the phase separation over time;
5. the drift-speed maps of that search (the object's drift over the parameters
   Algorithm 5 leaves open);
6. the transport mechanism study (both light-to-phase mappings x fresh or persistent
   headings x ideal or photoresistor sensing, 10 seeds each);
7. scaling with swarm size (the paper's panels u and v): robots added to a fixed arena,
   and an arena that grows with the swarm;
8. one law for three systems: synthetic ants, an elastic gas and light-switched
   robots, each analysed by the same :func:`~thermoswarm.analysis.study.run_study`.

and writes ``OUT/report.html`` (self-contained), ``OUT/results.json`` (the headline
numbers; keys documented in the README) and an animation per scenario
(``OUT/animations/<scenario>.mp4``, or ``.gif`` without the video extra).

``quick`` keeps every experiment but shortens runs and studies (stated in the report) so
that the whole finishes in minutes on 2 cores; ``make run`` uses it.

The package, by responsibility: :mod:`~thermoswarm.reproduce.plans` (how big each
experiment is), :mod:`~thermoswarm.reproduce.runs` (the worker pool, the progress log,
a scenario run that reuses a finished one), :mod:`~thermoswarm.reproduce.progress` (the
estimate of what is left: CPU seconds per step, this machine's speed and share), one
module per group of experiments (:mod:`~thermoswarm.reproduce.physical`,
:mod:`~thermoswarm.reproduce.transport`,
:mod:`~thermoswarm.reproduce.studies`, :mod:`~thermoswarm.reproduce.unified`: each runs,
computes its numbers and writes its report section), :mod:`~thermoswarm.reproduce.text`
(numbers and figures for the report) and :mod:`~thermoswarm.reproduce.driver` (the steps
in order, each judged against the paper by :mod:`thermoswarm.report.paper`).  Names with
a leading underscore are the package's own, shared between its modules.
"""

from __future__ import annotations

from thermoswarm.reproduce.driver import TITLES, reproduce
from thermoswarm.reproduce.plans import FULL, PLANS, QUICK, SMOKE, Plan
from thermoswarm.reproduce.runs import _Pool

__all__ = ["Plan", "PLANS", "QUICK", "FULL", "SMOKE", "TITLES", "reproduce", "_Pool"]
