"""Light, shadows and the robot's photoresistors (Algorithm 1, TurnToAngle), vectorised.

What it computes, for up to millions of robots per call:

- :func:`light_level`: the light level at points, in [0, 1] (1: every source fully
  visible at full strength; ``ambient``: full shadow), with hard or soft shadows of discs,
  segments, polygons and polylines (:mod:`thermoswarm.sim.geometry`) and optionally of the
  robots themselves (``casters``); :func:`direct_light` gives it per source;
- :func:`read_sensors`: the three photoresistors l1, l2 (front, at ``+-a``) and l3
  (back), with multiplicative and additive noise;
- :func:`turn_to_angle`: Algorithm 1, the stepwise turn until ``l1 == l2`` and
  ``l3 == 0``, whose end is "heading 0" of every algorithm (or the exact direction of the
  brightest visible source in ``mode="ideal"``); :func:`sense` does both in one pass, as
  the engine calls it at the start of a control period.

Units: positions mm; angles rad counter-clockwise from world +x (fields ending in
``_deg`` are degrees); time s; returned headings wrapped to ``[-pi, pi)``.  Argument
order everywhere: points, lights, occluders.  Randomness only from the caller's
:class:`numpy.random.Generator`; results are reproducible and, from 65,536 robots up
(parallel kernels), equal to the serial ones.

Layout: :mod:`.sources` (light sources), :mod:`._shadow` (shadow and visibility
kernels), :mod:`._photo` (photoresistor and turning kernels), :mod:`.api` (the public
functions and :class:`SensingParams`).  The model, its formulas and measured accuracy
are in ``docs/light.md``.
"""

from thermoswarm.sim.light._shadow import _PARALLEL_MIN  # noqa: F401  (read by tests)
from thermoswarm.sim.light.api import (
    SenseResult,
    SensingParams,
    TurnResult,
    direct_light,
    ideal_zero_heading,
    light_level,
    read_sensors,
    sense,
    turn_to_angle,
)
from thermoswarm.sim.light.sources import ROBOT_RADIUS, DirectionalLight, Light, PointLight

__all__ = [
    "ROBOT_RADIUS",
    "DirectionalLight",
    "PointLight",
    "Light",
    "SensingParams",
    "TurnResult",
    "SenseResult",
    "direct_light",
    "light_level",
    "read_sensors",
    "turn_to_angle",
    "ideal_zero_heading",
    "sense",
]
