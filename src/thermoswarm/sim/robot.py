"""The robot's own controller (:mod:`thermoswarm.robot.controller`) in the simulator.

:class:`ControllerPolicy` is an engine policy whose decisions are made by
:class:`~thermoswarm.robot.controller.Controller` -- the code that runs on the robot --
one robot at a time (slow: for validation at small swarm sizes; the vectorised policies
of :mod:`thermoswarm.policy` draw from the same laws).  Each decision re-seeds the
robot's generator from the engine's generator, so runs stay reproducible and resumable.

:class:`SimulatedHAL` is one robot with three photoresistors in a light field
(:mod:`thermoswarm.sim.light`), for testing Algorithm 1 as the hardware runs it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from thermoswarm.policy import Action, Observation
from thermoswarm.robot.controller import HAL, Config, Controller
from thermoswarm.sim.light import SensingParams, read_sensors

__all__ = ["ControllerPolicy", "SimulatedHAL"]


class ControllerPolicy:
    """An engine policy made of robot controllers.

    Parameters
    ----------
    **settings
        Controller settings (see :data:`thermoswarm.robot.controller.DEFAULTS`);
        ``group`` is taken per robot from the observation.
    """

    def __init__(self, **settings: Any) -> None:
        self.settings = dict(settings)
        self._configs = {g: Config(**{**self.settings, "group": g}) for g in (0, 1)}

    def act(self, obs: Observation, rng: np.random.Generator) -> Action:
        seeds = rng.integers(0, 2**32, obs.n, dtype=np.uint64)
        light = np.asarray(obs.light, dtype=float)
        group = np.asarray(obs.group)
        # the heading each robot held, relative to the light (the persistent law's memory)
        previous = np.asarray(obs.heading) - np.asarray(obs.zero_heading)
        theta = np.empty(obs.n)
        speed = np.empty(obs.n)
        for k in range(obs.n):
            ctrl = Controller(self._configs[int(group[k]) & 1], seed=int(seeds[k]))
            theta[k], speed[k] = ctrl.decide(float(light[k]), float(previous[k]))
        return Action(heading=np.asarray(obs.zero_heading) + theta, speed=speed)


class SimulatedHAL(HAL):
    """One robot's hardware in a simulated light field.

    Parameters
    ----------
    position : (x, y) mm
    heading : float, rad
    lights, occluders : as for :func:`thermoswarm.sim.light.read_sensors`
    params : SensingParams, optional
        Sensor geometry and noise (photoresistor mode).
    rng : numpy Generator, optional
        For sensor noise.
    """

    def __init__(self, position, heading, lights, occluders=None, params=None, rng=None):
        self.position = np.asarray(position, dtype=float).copy()
        self.heading = float(heading)
        self.lights = lights
        self.occluders = occluders
        self.params = params or SensingParams()
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.turned = 0.0
        self.driven = 0.0

    def light(self):
        r = read_sensors(
            self.position[None, :],
            np.array([self.heading]),
            self.lights,
            self.occluders,
            self.params,
            self.rng,
        )
        return tuple(float(x) for x in r[0])

    def turn(self, angle):
        self.heading += angle
        self.turned += abs(angle)

    def drive(self, speed, seconds):
        d = speed * seconds
        self.position += d * np.array([math.cos(self.heading), math.sin(self.heading)])
        self.driven += d
