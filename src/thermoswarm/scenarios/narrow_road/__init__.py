"""``narrow-road``: two groups of robots cross a road with a narrow section (Algorithm 2).

Robots that know only the direction of a light cross a straight road (381 mm, a wide
152.4 mm and a narrow 76.2 mm section) in both directions without communicating; robots
that reach the far end are put back at their start.  The claim: the two streams pass
each other without deadlock.  Units: mm, s, energies mm^2/s^2 per unit mass.

:mod:`.params` (parameters), :mod:`.geometry` (the road), :mod:`.metrics` (pure metric
functions), :mod:`.scenario` (the registered scenario), :mod:`.plots` (drawing).
Geometry, defaults, recorded variables, metrics keys and measurements:
``docs/scenarios_road_compression.md``.
"""

from thermoswarm.scenarios.narrow_road.geometry import (
    RoadGeometry,
    regions_toml,
    road_geometry,
    road_n,
    section_index,
)
from thermoswarm.scenarios.narrow_road.metrics import (
    SE_BLOCKS,
    flow_series,
    longest_gap,
    section_samples,
    section_stats,
)
from thermoswarm.scenarios.narrow_road.params import (
    DIRECTIONS,
    PAPER_OCCUPATION,
    ROAD_SCALE,
    NarrowRoadParams,
)
from thermoswarm.scenarios.narrow_road.plots import plot_flow, plot_frame
from thermoswarm.scenarios.narrow_road.scenario import NarrowRoadScenario

__all__ = [
    "NarrowRoadParams",
    "NarrowRoadScenario",
    "road_geometry",
    "RoadGeometry",
    "longest_gap",
    "flow_series",
    "section_index",
    "section_samples",
    "section_stats",
    "plot_frame",
    "plot_flow",
    "regions_toml",
    "road_n",
    "DIRECTIONS",
    "PAPER_OCCUPATION",
    "ROAD_SCALE",
    "SE_BLOCKS",
]
