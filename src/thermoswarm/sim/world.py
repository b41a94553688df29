"""World geometry: static walls, static obstacles, movable discs and force-driven walls.

All lengths in mm, forces in drag units (see :mod:`thermoswarm.sim.engine`).  The
world is plain data: frozen dataclasses holding NumPy arrays, built by small helper
functions (:func:`box_world`, :func:`polygon_segments`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from thermoswarm.errors import ConfigError

__all__ = ["World", "Body", "Piston", "polygon_segments", "box_world"]


def polygon_segments(points, closed: bool = True) -> np.ndarray:
    """Segments ``(M, 4)`` (x0, y0, x1, y1) of a polyline or closed polygon (mm)."""
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2 or p.shape[0] < 2:
        raise ConfigError(f"polygon must be a list of at least 2 [x, y] points, got {p.shape}")
    q = np.roll(p, -1, axis=0) if closed else p[1:]
    a = p if closed else p[:-1]
    seg = np.hstack([a, q])
    keep = np.hypot(seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1]) > 0
    return seg[keep]


@dataclass(frozen=True)
class Body:
    """A movable disc (the transported object).

    Parameters
    ----------
    x, y : float
        Initial centre (mm).
    radius : float
        Radius (mm); the paper's object is 100 mm across.
    drag : float
        Friction with the ground as a drag coefficient (force per mm/s, in units of a
        robot's drag).  ``inf`` makes the body immovable (its contact force is still
        measured).
    force : (float, float)
        A constant external force (e.g. robots attached to it); a scenario may change it
        every step through ``SwarmState.body_ext_force``.

    Notes
    -----
    Bodies collide with robots (sharing each overlap by mobility) and with static walls
    and obstacles (which do not yield); they do not rotate.
    """

    x: float
    y: float
    radius: float = 50.0
    drag: float = 50.0
    force: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        if not self.radius > 0:
            raise ConfigError(f"body radius must be positive, got {self.radius!r}")
        if not self.drag > 0:
            raise ConfigError(f"body drag must be positive (inf = fixed), got {self.drag!r}")


@dataclass(frozen=True)
class Piston:
    """A straight wall that slides along one axis under a constant external force.

    The wall is the line ``coordinate[axis] = position`` between ``lo`` and ``hi`` along the
    other axis.  Robots are on the side ``side`` (+1: robots have larger coordinate).  The
    external ``force`` (>= 0) pushes the wall toward the robots.  ``drag = inf`` holds the
    wall in place (a force gauge).  ``limits`` bound its travel.
    """

    axis: int
    position: float
    side: int
    lo: float
    hi: float
    force: float = 0.0
    drag: float = 100.0
    limits: tuple[float, float] = (-math.inf, math.inf)

    def __post_init__(self) -> None:
        if self.axis not in (0, 1):
            raise ConfigError(f"piston axis must be 0 (x) or 1 (y), got {self.axis!r}")
        if self.side not in (-1, 1):
            raise ConfigError(f"piston side must be -1 or +1, got {self.side!r}")
        if not self.hi > self.lo:
            raise ConfigError(f"piston span must have hi > lo, got {self.lo}..{self.hi}")
        if not self.force >= 0:
            raise ConfigError(f"piston force must be non-negative, got {self.force!r}")
        if not self.drag > 0:
            raise ConfigError(f"piston drag must be positive (inf = held), got {self.drag!r}")


@dataclass(frozen=True)
class World:
    """Static geometry plus the movable things' initial state.

    Attributes
    ----------
    bounds : (xmin, ymin, xmax, ymax)
        The region robots can occupy (mm); the cell grid covers it.  Walls must keep
        the robots inside it.
    segments : ndarray (M, 4)
        Static wall segments.
    static_discs : ndarray (S, 3)
        Static round obstacles (x, y, radius).
    bodies : tuple of Body
        Movable discs.
    pistons : tuple of Piston
        Force-driven walls.
    """

    bounds: tuple[float, float, float, float]
    segments: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    static_discs: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    bodies: tuple[Body, ...] = ()
    pistons: tuple[Piston, ...] = ()

    def __post_init__(self) -> None:
        x0, y0, x1, y1 = (float(v) for v in self.bounds)
        if not (x1 > x0 and y1 > y0 and all(map(math.isfinite, (x0, y0, x1, y1)))):
            raise ConfigError(f"world bounds must be finite with max > min, got {self.bounds}")
        object.__setattr__(self, "bounds", (x0, y0, x1, y1))
        seg = np.asarray(self.segments, dtype=np.float64).reshape(-1, 4)
        disc = np.asarray(self.static_discs, dtype=np.float64).reshape(-1, 3)
        object.__setattr__(self, "segments", np.ascontiguousarray(seg))
        object.__setattr__(self, "static_discs", np.ascontiguousarray(disc))

    @property
    def width(self) -> float:
        return self.bounds[2] - self.bounds[0]

    @property
    def height(self) -> float:
        return self.bounds[3] - self.bounds[1]

    def with_segments(self, extra: np.ndarray) -> World:
        """A copy with more static segments."""
        seg = np.vstack([self.segments, np.asarray(extra, dtype=np.float64).reshape(-1, 4)])
        return World(self.bounds, seg, self.static_discs, self.bodies, self.pistons)


def box_world(
    width: float,
    height: float,
    *,
    origin: tuple[float, float] = (0.0, 0.0),
    bodies: tuple[Body, ...] = (),
    pistons: tuple[Piston, ...] = (),
    walls: bool = True,
) -> World:
    """A rectangle ``[ox, ox + width] x [oy, oy + height]`` closed by four static walls."""
    if not (width > 0 and height > 0):
        raise ConfigError(f"box width and height must be positive, got {width} x {height}")
    ox, oy = origin
    corners = [(ox, oy), (ox + width, oy), (ox + width, oy + height), (ox, oy + height)]
    seg = polygon_segments(corners) if walls else np.zeros((0, 4))
    return World((ox, oy, ox + width, oy + height), seg, bodies=bodies, pistons=pistons)
