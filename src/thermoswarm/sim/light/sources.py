"""Light sources of the simulated arena: :class:`DirectionalLight` and :class:`PointLight`.

Units: positions mm, angles rad (fields ending in ``_deg`` are degrees).  Sources are
frozen, checked dataclasses; :func:`_pack_lights` turns a list of them into the array
rows the Numba kernels read.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal

import numpy as np

from thermoswarm.config import check
from thermoswarm.errors import InputError
from thermoswarm.sim.geometry import Shapes

#: Radius of the paper's robot (mm): a 33 mm disc (PAPER_NOTES section 4).
ROBOT_RADIUS = 16.5

Falloff = Literal["none", "inverse", "inverse_square"]
_FALLOFF_CODE = {"none": 0, "inverse": 1, "inverse_square": 2}


# --------------------------------------------------------------------------------------
# Light sources


def _finite(x: float) -> bool:
    return isinstance(x, int | float) and math.isfinite(x)


@dataclass(frozen=True)
class DirectionalLight:
    """Parallel rays from a distant source.

    Parameters
    ----------
    direction : (float, float)
        Direction in which the rays travel (any length, normalised here).  The default
        ``(0, -1)`` is light coming from the +y side (the target side of the transport
        experiments); heading 0 then points to +y.
    intensity : float
        Relative intensity (> 0); only ratios between sources matter.
    angular_radius_deg : float
        Angular radius of the source (deg) for soft shadows; 0 (default) gives hard
        shadows.  Below 90.
    """

    direction: tuple[float, float] = (0.0, -1.0)
    intensity: float = 1.0
    angular_radius_deg: float = 0.0

    def __post_init__(self) -> None:
        d = tuple(self.direction)
        check(
            len(d) == 2 and all(_finite(float(v)) for v in d) and math.hypot(*d) > 0,
            "direction",
            "a non-zero pair of finite numbers",
            self.direction,
        )
        norm = math.hypot(*d)
        object.__setattr__(self, "direction", (float(d[0]) / norm, float(d[1]) / norm))
        check(_finite(self.intensity) and self.intensity > 0, "intensity", "> 0", self.intensity)
        check(
            _finite(self.angular_radius_deg) and 0 <= self.angular_radius_deg < 90,
            "angular_radius_deg",
            "in [0, 90) degrees",
            self.angular_radius_deg,
        )

    @property
    def source_angle(self) -> float:
        """World angle (rad) pointing to the source: the opposite of the rays."""
        return math.atan2(-self.direction[1], -self.direction[0])


@dataclass(frozen=True)
class PointLight:
    """A lamp at a point.

    Parameters
    ----------
    position : (float, float)
        Position (mm).
    intensity : float
        Relative intensity (> 0).
    falloff : {"inverse_square", "inverse", "none"}
        Strength with distance ``r``: ``min(1, (r0 / r)^2)`` (a lamp in 3D space, the
        default), ``min(1, r0 / r)`` (a line source seen in 2D) or 1.  Capped at 1 so
        that the level stays in [0, 1]: a sensor closer than ``r0`` saturates.
    reference_distance : float
        ``r0`` (mm): the distance within which the lamp gives its full intensity
        (default 1000 mm: full strength across a 1 m arena, 1/4 at 2 m).
    radius : float
        Radius of the lamp (mm) for soft shadows; 0 (default) gives hard shadows.
    """

    position: tuple[float, float]
    intensity: float = 1.0
    falloff: Falloff = "inverse_square"
    reference_distance: float = 1000.0
    radius: float = 0.0

    def __post_init__(self) -> None:
        p = tuple(self.position)
        check(
            len(p) == 2 and all(_finite(float(v)) for v in p),
            "position",
            "a pair of finite numbers (mm)",
            self.position,
        )
        object.__setattr__(self, "position", (float(p[0]), float(p[1])))
        check(_finite(self.intensity) and self.intensity > 0, "intensity", "> 0", self.intensity)
        check(
            self.falloff in _FALLOFF_CODE,
            "falloff",
            "one of 'inverse_square', 'inverse', 'none'",
            self.falloff,
        )
        check(
            _finite(self.reference_distance) and self.reference_distance > 0,
            "reference_distance",
            "> 0 (mm)",
            self.reference_distance,
        )
        check(_finite(self.radius) and self.radius >= 0, "radius", ">= 0 (mm)", self.radius)


Light = DirectionalLight | PointLight

# Packed light row: kind (0 directional, 1 point), x, y (unit vector toward the source,
# or the position), weight I_i / sum I, falloff code, r0, alpha (rad) or radius (mm).
_NCOL = 7


def _pack_lights(lights: Light | Iterable[Light]) -> np.ndarray:
    if isinstance(lights, DirectionalLight | PointLight):
        lights = [lights]
    if isinstance(lights, Shapes | str | bytes) or not isinstance(lights, Iterable):
        raise InputError(
            "lights must be a DirectionalLight, a PointLight or a list of them, got "
            f"{type(lights).__name__} (argument order is: points, lights, occluders)"
        )
    items = list(lights)
    if not items:
        raise InputError("lights must contain at least one light source")
    out = np.zeros((len(items), _NCOL))
    for i, lt in enumerate(items):
        if isinstance(lt, DirectionalLight):
            out[i] = (
                0,
                -lt.direction[0],
                -lt.direction[1],
                lt.intensity,
                0,
                1.0,
                math.radians(lt.angular_radius_deg),
            )
        elif isinstance(lt, PointLight):
            out[i] = (
                1,
                lt.position[0],
                lt.position[1],
                lt.intensity,
                _FALLOFF_CODE[lt.falloff],
                lt.reference_distance,
                lt.radius,
            )
        else:
            raise InputError(
                f"lights[{i}] must be a DirectionalLight or a PointLight, got "
                f"{type(lt).__name__} (argument order is: points, lights, occluders)"
            )
    out[:, 3] /= out[:, 3].sum()
    return out
