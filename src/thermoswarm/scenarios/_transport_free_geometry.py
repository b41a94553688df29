"""The layout of ``transport-free``: arena walls, the pillar, the zig-zag channel, the
object's start and the target line, and where robots may stand.

Private to :mod:`thermoswarm.scenarios.transport_free` (which re-exports
:class:`Geometry`, :func:`geometry` and :func:`zigzag_centreline`).  The functions read
the layout fields of a ``TransportFreeParams`` through :class:`Layout`, so that this
module does not import the parameters back (the parameters check their layout with
:func:`geometry`).  Units: mm.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from thermoswarm.config import check
from thermoswarm.errors import ConfigError
from thermoswarm.scenarios._transport import segment_distance
from thermoswarm.sim.world import polygon_segments

__all__ = ["Layout", "Geometry", "zigzag_centreline", "geometry", "robot_region", "arena_grid"]


class Layout(Protocol):
    """The fields of ``TransportFreeParams`` that the layout depends on (read only)."""

    variant: str
    diameter: float
    object_radius: float
    object_x: float | None
    object_y: float | None
    target_y: float | None
    obstacle_radius: float
    obstacle_dx: float
    obstacle_dy: float
    channel_width: float
    zigzag_amplitude: float
    zigzag_leg: float

    @property
    def arena(self) -> tuple[float, float]: ...


@dataclass(frozen=True)
class Geometry:
    """The resolved layout of a ``transport-free`` run (mm)."""

    bounds: tuple[float, float, float, float]
    walls: np.ndarray  # (M, 4)
    obstacles: np.ndarray  # (S, 3)
    start: tuple[float, float]
    target_y: float
    channel: np.ndarray | None  # zigzag: centreline vertices (k, 2)
    mouth_y: float | None


def zigzag_centreline(
    x: float, mouth_y: float, top: float, amplitude: float, leg: float, straight: float
) -> np.ndarray:
    """Vertices (k, 2) of a zig-zag channel's centreline from ``(x, mouth_y)`` to ``top``.

    A straight rise of ``straight`` mm, then legs that each rise ``leg`` mm while moving
    ``amplitude`` mm sideways, alternately right and left, ending with a straight stub
    at ``top`` (the last leg is cut where it meets the top).
    """
    pts = [(x, mouth_y), (x, min(mouth_y + straight, top))]
    y = pts[-1][1]
    side = 1.0
    cx = x
    while y < top:
        ny = min(y + leg, top)
        frac = (ny - y) / leg
        cx = cx + side * amplitude * frac
        pts.append((cx, ny))
        y = ny
        side = -side
    return np.array(pts)


def _mouth_y(p: Layout) -> float:
    _, h = p.arena
    return h / 2 - 2 * p.object_radius


def _zigzag(p: Layout) -> tuple[np.ndarray, float, list[np.ndarray]]:
    """The zig-zag channel of ``p``: its centreline, the y of its mouth and its walls
    (left side, right side, the wall across the room's top on both sides of the mouth);
    a ConfigError when it does not fit the arena or the object."""
    W, H = p.arena
    R = p.object_radius
    mouth = _mouth_y(p)
    channel = zigzag_centreline(W / 2, mouth, H, p.zigzag_amplitude, p.zigzag_leg, 4 * R)
    half = p.channel_width / 2
    left = channel - [half, 0.0]
    right = channel + [half, 0.0]
    if left[:, 0].min() <= 0 or right[:, 0].max() >= W:
        raise ConfigError(
            f"channel_width/zigzag_amplitude: the zig-zag channel (x from "
            f"{left[:, 0].min():.0f} to {right[:, 0].max():.0f} mm) does not fit in the "
            f"arena width {W:g} mm"
        )
    # perpendicular width of the slanted legs must pass the object
    slope = p.zigzag_amplitude / p.zigzag_leg
    perp = p.channel_width / math.sqrt(1 + slope * slope)
    check(
        perp > 2 * R,
        "channel_width",
        f"wide enough for the object: the legs' perpendicular width {perp:.0f} mm must "
        f"exceed the object's diameter {2 * R:g} mm",
        p.channel_width,
    )
    walls = [
        polygon_segments(left, closed=False),
        polygon_segments(right, closed=False),
        [[0.0, mouth, left[0, 0], mouth], [right[0, 0], mouth, W, mouth]],
    ]
    return channel, mouth, walls


def geometry(p: Layout) -> Geometry:
    """Arena, walls, obstacles, object start and target of ``p``; a ConfigError names
    the field when the object or the target does not fit."""
    W, H = p.arena
    R = p.object_radius
    walls = polygon_segments([(0, 0), (W, 0), (W, H), (0, H)])
    obstacles = np.zeros((0, 3))
    channel = None
    mouth = None
    ox = W / 2 if p.object_x is None else p.object_x
    if p.variant == "zigzag":
        channel, mouth, channel_walls = _zigzag(p)
        oy = mouth + 2 * R if p.object_y is None else p.object_y
        walls = np.vstack([walls, *channel_walls])
    else:
        oy = H / 2 if p.object_y is None else p.object_y
    if p.variant == "obstacle":
        obstacles = np.array([[ox + p.obstacle_dx, oy + p.obstacle_dy, p.obstacle_radius]])
        x, y, ro = obstacles[0]
        if not (ro < x < W - ro and ro < y < H - ro):
            raise ConfigError(
                f"obstacle_dx/obstacle_dy: the obstacle centred at ({x:g}, {y:g}) mm with "
                f"radius {ro:g} mm lies outside the {W:g} x {H:g} mm arena"
            )
    # the object must lie inside the arena, clear of walls and obstacles
    inside = R < ox < W - R and R < oy < H - R
    if inside and p.variant == "zigzag" and oy > mouth:
        xc = np.interp(oy, channel[:, 1], channel[:, 0])
        inside = abs(ox - xc) < p.channel_width / 2
    clear = bool(segment_distance(np.array([[ox, oy]]), walls)[0] >= R)
    if obstacles.size:
        clear &= bool(np.hypot(ox - obstacles[0, 0], oy - obstacles[0, 1]) >= R + obstacles[0, 2])
    if not (inside and clear):
        raise ConfigError(
            f"object_x/object_y: the object (radius {R:g} mm) at ({ox:g}, {oy:g}) mm must lie "
            f"inside the {W:g} x {H:g} mm arena of variant {p.variant!r}, clear of its walls "
            "and obstacles"
        )
    ty = H - 3 * R if p.target_y is None else p.target_y
    check(
        oy < ty <= H - R,
        "target_y",
        f"above the object's start y = {oy:g} and at most {H - R:g} mm (the object's "
        "centre cannot come closer to the top wall than its radius)",
        ty,
    )
    return Geometry(
        bounds=(0.0, 0.0, float(W), float(H)),
        walls=walls,
        obstacles=obstacles,
        start=(float(ox), float(oy)),
        target_y=float(ty),
        channel=channel,
        mouth_y=mouth,
    )


def robot_region(
    p: Layout, g: Geometry, obj: tuple[float, float] | None = None
) -> Callable[[np.ndarray], np.ndarray]:
    """``inside(points)``: where a robot's centre may be, clear of walls, obstacles and
    the object (at ``obj``, default its start)."""
    r = p.diameter / 2
    margin = 0.5
    ox, oy = g.start if obj is None else obj

    def inside(pts: np.ndarray) -> np.ndarray:
        ok = segment_distance(pts, g.walls) >= r + margin
        ok &= np.hypot(pts[:, 0] - ox, pts[:, 1] - oy) >= (p.object_radius + r + margin)
        for x, y, ro in g.obstacles:
            ok &= np.hypot(pts[:, 0] - x, pts[:, 1] - y) >= ro + r + margin
        if g.channel is not None:
            above = pts[:, 1] > g.mouth_y
            xc = np.interp(pts[:, 1], g.channel[:, 1], g.channel[:, 0])
            ok &= ~above | (np.abs(pts[:, 0] - xc) < p.channel_width / 2)
        return ok

    return inside


def arena_grid(p: Layout, g: Geometry) -> tuple[np.ndarray, float]:
    """Cell centres of a regular grid over the arena where robots' centres can be (the
    object at its start), and the cell area (mm^2); about 40,000 cells at most."""
    x0, y0, x1, y1 = g.bounds
    step = max(10.0, math.sqrt((x1 - x0) * (y1 - y0) / 40000.0))
    xs = np.arange(x0 + step / 2, x1, step)
    ys = np.arange(y0 + step / 2, y1, step)
    pts = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    far = robot_region(p, g, obj=(math.inf, math.inf))  # the object excluded per frame
    return np.ascontiguousarray(pts[far(pts)]), step * step
