"""Regions of the arena: named polygons in mm, read from TOML, and point lookup.

File format (``--regions FILE``)::

    # regions.toml -- coordinates in mm, in the frame of the trajectories
    [[region]]
    name = "wide"
    polygon = [[0, 0], [60, 0], [60, 40], [0, 40]]

    [[region]]
    name = "narrow"
    polygon = [[60, 10], [100, 10], [100, 30], [60, 30]]

    [[region]]
    name = "box"
    rect = [100, 0, 140, 40]        # x_min, y_min, x_max, y_max: a shorthand

Each ``[[region]]`` has a unique ``name`` and either ``polygon`` (at least three
``[x, y]`` vertices; closed automatically; it must not cross itself) or ``rect``.  No
other key is accepted.  A point belongs to the *first* region in file order that
contains it (so regions may overlap: put the specific one first), or to none.

Points on a polygon's edge may fall on either side (floating point).  The lookup is
:meth:`matplotlib.path.Path.contains_points` (compiled, vectorised), applied to the
points inside each polygon's bounding box only.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.config import load_toml
from thermoswarm.errors import ConfigError

__all__ = ["Region", "load_regions", "regions_from_mapping", "assign_regions"]

#: Label of points in no region.
OUTSIDE = -1


@dataclass(frozen=True)
class Region:
    """A named polygon (vertices ``(n, 2)`` in mm, not repeated at the end)."""

    name: str
    vertices: np.ndarray

    @property
    def area(self) -> float:
        """Area in mm^2 (shoelace formula)."""
        x, y = self.vertices[:, 0], self.vertices[:, 1]
        return float(0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))

    def contains(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Boolean mask of the points ``(x, y)`` (mm) inside the polygon."""
        from matplotlib.path import Path as MplPath

        x = np.asarray(x, dtype=float)
        y = np.asarray(y, dtype=float)
        out = np.zeros(x.shape, dtype=bool)
        lo = self.vertices.min(axis=0)
        hi = self.vertices.max(axis=0)
        box = (x >= lo[0]) & (x <= hi[0]) & (y >= lo[1]) & (y <= hi[1])
        if box.any():
            pts = np.column_stack([x[box], y[box]])
            out[box] = MplPath(self.vertices).contains_points(pts)
        return out

    def to_dict(self) -> dict[str, Any]:
        return {"vertices": self.vertices.tolist(), "area_mm2": self.area}


def _segments_cross(p1, p2, p3, p4) -> bool:
    def orient(a, b, c):
        return np.sign((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))

    return (
        orient(p1, p2, p3) * orient(p1, p2, p4) < 0 and orient(p3, p4, p1) * orient(p3, p4, p2) < 0
    )


def _self_intersecting(v: np.ndarray) -> bool:
    n = len(v)
    for i in range(n):
        for j in range(i + 2, n):
            if i == 0 and j == n - 1:
                continue
            if _segments_cross(v[i], v[(i + 1) % n], v[j], v[(j + 1) % n]):
                return True
    return False


def _vertices(value: Any, where: str) -> np.ndarray:
    if isinstance(value, str) or not isinstance(value, Sequence):
        raise ConfigError(f"{where}.polygon must be a list of [x, y] pairs, got {value!r}")
    pts = []
    for k, p in enumerate(value):
        if (
            isinstance(p, str)
            or not isinstance(p, Sequence)
            or len(p) != 2
            or not all(isinstance(c, int | float) and not isinstance(c, bool) for c in p)
        ):
            raise ConfigError(f"{where}.polygon[{k}] must be [x, y] (numbers, mm), got {p!r}")
        pts.append((float(p[0]), float(p[1])))
    v = np.asarray(pts, dtype=float)
    if len(v) >= 2 and np.allclose(v[0], v[-1]):
        v = v[:-1]
    if len(v) < 3:
        raise ConfigError(f"{where}.polygon needs at least 3 distinct vertices, got {len(v)}")
    if not np.all(np.isfinite(v)):
        raise ConfigError(f"{where}.polygon has a non-finite coordinate")
    return v


def regions_from_mapping(data: Mapping[str, Any], *, source: str = "regions") -> list[Region]:
    """Regions from a parsed TOML document ``{"region": [{...}, ...]}``."""
    unknown = [k for k in data if k != "region"]
    if unknown:
        raise ConfigError(f"{source}: unknown key {unknown[0]!r}; expected [[region]] tables")
    items = data.get("region")
    if not isinstance(items, list) or not items:
        raise ConfigError(f"{source}: no [[region]] tables (each needs a name and a polygon)")
    regions: list[Region] = []
    for i, item in enumerate(items):
        where = f"{source}: region[{i}]"
        if not isinstance(item, Mapping):
            raise ConfigError(f"{where} must be a table")
        extra = [k for k in item if k not in ("name", "polygon", "rect")]
        if extra:
            raise ConfigError(
                f"{where}: unknown key {extra[0]!r}; expected one of: name, polygon, rect"
            )
        name = item.get("name")
        if not isinstance(name, str) or not name.strip():
            raise ConfigError(f"{where}.name must be a non-empty string, got {name!r}")
        if name == "outside":
            raise ConfigError(f"{where}.name 'outside' is reserved for points in no region")
        if any(r.name == name for r in regions):
            raise ConfigError(f"{where}.name {name!r} is used twice")
        where = f"{source}: region {name!r}"
        if ("polygon" in item) == ("rect" in item):
            raise ConfigError(f"{where} needs exactly one of polygon or rect")
        if "rect" in item:
            r = item["rect"]
            if (
                isinstance(r, str)
                or not isinstance(r, Sequence)
                or len(r) != 4
                or not all(isinstance(c, int | float) and not isinstance(c, bool) for c in r)
            ):
                raise ConfigError(f"{where}.rect must be [x_min, y_min, x_max, y_max], got {r!r}")
            x0, y0, x1, y1 = (float(c) for c in r)
            if not (x1 > x0 and y1 > y0):
                raise ConfigError(f"{where}.rect needs x_max > x_min and y_max > y_min, got {r!r}")
            v = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
        else:
            v = _vertices(item["polygon"], where)
        reg = Region(name, v)
        if _self_intersecting(v):
            raise ConfigError(f"{where}.polygon crosses itself")
        if not reg.area > 0:
            raise ConfigError(f"{where}.polygon has zero area")
        regions.append(reg)
    return regions


def load_regions(path: str | os.PathLike) -> list[Region]:
    """Read regions from a TOML file (format in the module docstring)."""
    path = Path(path)
    return regions_from_mapping(load_toml(path), source=str(path))


def assign_regions(regions: Sequence[Region], x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Index (int16) of the first region containing each point, :data:`OUTSIDE` if none.

    NaN coordinates are outside.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    out = np.full(x.shape, OUTSIDE, dtype=np.int16)
    free = np.isfinite(x) & np.isfinite(y)
    for k, reg in enumerate(regions):
        if not free.any():
            break
        inside = np.zeros(x.shape, dtype=bool)
        inside[free] = reg.contains(x[free], y[free])
        out[inside] = k
        free &= ~inside
    return out
