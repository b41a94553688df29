"""The robot: the paper's algorithms as a controller a microcontroller can run.

- :mod:`thermoswarm.robot.controller`: the controller itself, plain Python that runs on
  MicroPython (it imports only ``math``); copy it to the board with its ``main.py``.
- :mod:`thermoswarm.robot.sim`: runs the same controller inside the simulator
  (:class:`~thermoswarm.robot.sim.ControllerPolicy`) and against a simulated robot with
  photoresistors (:class:`~thermoswarm.robot.sim.SimulatedHAL`).
"""

from thermoswarm.robot.controller import ALGORITHMS, DEFAULTS, Config, Controller, Rng

__all__ = ["ALGORITHMS", "DEFAULTS", "Config", "Controller", "Rng"]
