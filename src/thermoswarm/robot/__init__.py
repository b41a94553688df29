"""The robot's own code: what a MicroPython board runs, and nothing else.

:mod:`thermoswarm.robot.controller` is the paper's algorithms for one robot in plain
Python that imports only ``math``; copy it to the board.  The simulator runs the same
controller through :mod:`thermoswarm.sim.robot`.
"""

from thermoswarm.robot.controller import ALGORITHMS, DEFAULTS, Config, Controller, Rng

__all__ = ["ALGORITHMS", "DEFAULTS", "Config", "Controller", "Rng"]
