"""Multi-run studies of the paper's experiments: grids of scenarios over seeds.

- :mod:`thermoswarm.studies.mechanism`: which light-to-phase mapping, heading law and
  sensing model move the object of ``transport-free`` toward the target (PAPER_NOTES
  6.3), with effect sizes and confidence intervals;
- :mod:`thermoswarm.studies.scaling`: maximum displacement and time to target versus
  the number of robots (the paper's panels u and v).

Runs go through :func:`thermoswarm.sweep.run_sweep` when it is available (one
directory per run, finished runs skipped on restart) and through a serial loop over
:func:`thermoswarm.scenarios.runner.run` with the same layout otherwise.
"""

from __future__ import annotations

from thermoswarm.studies._common import Record, effect, run_grid, verdict

__all__ = ["Record", "effect", "run_grid", "verdict"]
