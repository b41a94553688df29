"""Shared 2D primitives: discs, segments, polygons and polylines, and a packed set of them.

Shapes are small frozen dataclasses whose fields are plain tuples, so a scenario's TOML
file can describe them (``thermoswarm.config.from_mapping(Disc, {...})``).  Kernels do not
see shapes: :class:`Shapes` packs any number of them into two float64 arrays,

- ``discs``    ``(k, 3)``: ``x, y, radius`` (mm),
- ``segments`` ``(m, 4)``: ``x0, y0, x1, y1`` (mm); polygons and polylines become chains
  of segments (a polygon is closed: its last vertex joins its first),

which is what Numba kernels (shadows here, contacts in the engine) loop over.  A moving
body (the transported object) is a disc whose centre changes every step:
:meth:`Shapes.with_disc_centers` returns a copy with new centres without rebuilding the
static walls.

All lengths are millimetres.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from thermoswarm.config import check, check_positive
from thermoswarm.errors import InputError

__all__ = ["Disc", "Segment", "Polygon", "Polyline", "Shape", "Shapes", "as_shapes"]


def _finite_point(value: tuple[float, float], name: str) -> None:
    check(
        len(value) == 2 and all(math.isfinite(float(v)) for v in value),
        name,
        "a pair of finite numbers (mm)",
        value,
    )


@dataclass(frozen=True)
class Disc:
    """A disc: the transported object (100 mm in the paper), a pillar, a robot.

    Parameters
    ----------
    center : (float, float)
        Centre (mm).
    radius : float
        Radius (mm), > 0.
    """

    center: tuple[float, float]
    radius: float

    def __post_init__(self) -> None:
        _finite_point(self.center, "center")
        check_positive("radius", self.radius, "a positive number (mm)")


@dataclass(frozen=True)
class Segment:
    """A line segment from ``a`` to ``b`` (mm): a wall, a thin obstacle."""

    a: tuple[float, float]
    b: tuple[float, float]

    def __post_init__(self) -> None:
        _finite_point(self.a, "a")
        _finite_point(self.b, "b")
        check(tuple(self.a) != tuple(self.b), "b", "a point different from a", self.b)


def _check_vertices(vertices: Sequence[tuple[float, float]], at_least: int) -> None:
    check(
        len(vertices) >= at_least,
        "vertices",
        f"a list of at least {at_least} points",
        vertices,
    )
    for i, v in enumerate(vertices):
        _finite_point(v, f"vertices[{i}]")


def _chain(vertices: Sequence[tuple[float, float]], closed: bool) -> np.ndarray:
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 2)
    w = np.roll(v, -1, axis=0) if closed else v[1:]
    seg = np.concatenate([v[: len(w)], w], axis=1)
    keep = np.any(seg[:, :2] != seg[:, 2:], axis=1)  # repeated vertices add nothing
    return seg[keep]


@dataclass(frozen=True)
class Polygon:
    """A closed polygon (an obstacle): its edges, the last vertex joined to the first.

    For shadows only the boundary matters: a ray from outside that enters a closed
    polygon crosses one of its edges, so the edges are the whole occluder.
    """

    vertices: tuple[tuple[float, float], ...]

    def __post_init__(self) -> None:
        _check_vertices(self.vertices, 3)

    def segments(self) -> np.ndarray:
        """Edges as an ``(m, 4)`` array ``x0, y0, x1, y1`` (mm)."""
        return _chain(self.vertices, closed=True)


@dataclass(frozen=True)
class Polyline:
    """An open chain of segments (a channel wall, a zig-zag)."""

    vertices: tuple[tuple[float, float], ...]

    def __post_init__(self) -> None:
        _check_vertices(self.vertices, 2)

    def segments(self) -> np.ndarray:
        """Pieces as an ``(m, 4)`` array ``x0, y0, x1, y1`` (mm)."""
        return _chain(self.vertices, closed=False)


Shape = Disc | Segment | Polygon | Polyline

_EMPTY_DISCS = np.zeros((0, 3))
_EMPTY_SEGMENTS = np.zeros((0, 4))


def _as_array(value: object, cols: int, name: str) -> np.ndarray:
    try:
        arr = np.array(value, dtype=np.float64, order="C")  # a copy: frozen below
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a numeric array of shape (k, {cols})") from None
    if arr.size == 0:
        return np.zeros((0, cols))
    if arr.ndim != 2 or arr.shape[1] != cols:
        raise InputError(f"{name} must have shape (k, {cols}), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name} must be finite")
    return arr


@dataclass(frozen=True)
class Shapes:
    """Discs and segments packed as float64 arrays (what kernels loop over).

    Parameters
    ----------
    discs : array (k, 3)
        ``x, y, radius`` (mm); radii > 0.
    segments : array (m, 4)
        ``x0, y0, x1, y1`` (mm).
    """

    discs: np.ndarray = field(default_factory=lambda: _EMPTY_DISCS)
    segments: np.ndarray = field(default_factory=lambda: _EMPTY_SEGMENTS)

    def __post_init__(self) -> None:
        discs = _as_array(self.discs, 3, "discs")
        segments = _as_array(self.segments, 4, "segments")
        if discs.size and not np.all(discs[:, 2] > 0):
            raise InputError("discs radii (column 2) must be positive (mm)")
        discs.flags.writeable = False
        segments.flags.writeable = False
        object.__setattr__(self, "discs", discs)
        object.__setattr__(self, "segments", segments)

    @classmethod
    def from_shapes(cls, shapes: Iterable[Shape]) -> Shapes:
        """Pack shapes; discs keep their order (``with_disc_centers`` relies on it)."""
        discs: list[tuple[float, float, float]] = []
        segs: list[np.ndarray] = []
        for i, s in enumerate(shapes):
            if isinstance(s, Disc):
                discs.append((float(s.center[0]), float(s.center[1]), float(s.radius)))
            elif isinstance(s, Segment):
                segs.append(np.array([[*s.a, *s.b]], dtype=np.float64))
            elif isinstance(s, Polygon | Polyline):
                segs.append(s.segments())
            else:
                raise InputError(
                    f"shape {i} must be a Disc, Segment, Polygon or Polyline, "
                    f"got {type(s).__name__}"
                )
        return cls(
            discs=np.array(discs, dtype=np.float64).reshape(-1, 3),
            segments=np.concatenate(segs) if segs else _EMPTY_SEGMENTS,
        )

    @property
    def n_discs(self) -> int:
        return int(self.discs.shape[0])

    @property
    def n_segments(self) -> int:
        return int(self.segments.shape[0])

    def with_disc_centers(self, centers: object) -> Shapes:
        """A copy whose discs are centred at ``centers`` ``(k, 2)`` (mm); radii kept."""
        c = np.asarray(centers, dtype=np.float64).reshape(-1, 2)
        if c.shape[0] != self.n_discs:
            raise InputError(
                f"centers must have {self.n_discs} rows (one per disc), got {c.shape[0]}"
            )
        discs = self.discs.copy()
        discs[:, :2] = c
        return Shapes(discs=discs, segments=self.segments)

    def __add__(self, other: Shapes) -> Shapes:
        return Shapes(
            discs=np.concatenate([self.discs, other.discs]),
            segments=np.concatenate([self.segments, other.segments]),
        )


def as_shapes(value: Shapes | Shape | Iterable[Shape] | None) -> Shapes:
    """Accept a :class:`Shapes`, one shape, a sequence of shapes or ``None`` (nothing)."""
    if value is None:
        return Shapes()
    if isinstance(value, Shapes):
        return value
    if isinstance(value, Disc | Segment | Polygon | Polyline):
        return Shapes.from_shapes([value])
    if isinstance(value, str | bytes) or not isinstance(value, Iterable):
        raise InputError(
            "occluders must be a Shapes, a shape or a list of Disc/Segment/Polygon/Polyline, "
            f"got {type(value).__name__}"
        )
    return Shapes.from_shapes(value)
