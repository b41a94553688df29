"""The robot's own code: what a MicroPython board runs.

:mod:`thermoswarm.robot.controller` is the paper's algorithms for one robot in plain
Python that imports only ``math``; ``boards/`` holds the reference HAL, ``main.py`` and
one pin map per board.  Both import only what MicroPython has.  The simulator runs the
same controller through :mod:`thermoswarm.sim.robot`.  ``host/`` (CPython) builds the
board's files from a scenario, deploys and calibrates them with mpremote, and runs them
on MicroPython's unix port in closed loop with the simulator.
"""

from thermoswarm.robot.controller import ALGORITHMS, DEFAULTS, Config, Controller, Rng

__all__ = ["ALGORITHMS", "DEFAULTS", "Config", "Controller", "Rng"]
