"""The simulation engine: world geometry, state, stepping, recording.

See :mod:`thermoswarm.sim.engine` for the physics and the choices behind it.
"""

from thermoswarm.sim.engine import (
    LIGHT_DIRECTION,
    EngineParams,
    Simulator,
    SwarmState,
    place_lattice,
    set_threads,
    simulator,
)
from thermoswarm.sim.world import Body, Piston, World, box_world, polygon_segments

__all__ = [
    "LIGHT_DIRECTION",
    "EngineParams",
    "Simulator",
    "SwarmState",
    "place_lattice",
    "set_threads",
    "simulator",
    "Body",
    "Piston",
    "World",
    "box_world",
    "polygon_segments",
]
