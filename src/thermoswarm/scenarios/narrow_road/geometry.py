"""The road as numbers (mm): outline, walls, sections, re-entry spots, the depot.

The road runs along +x from ``x = 0`` to ``length``, symmetric about ``y = 0``, its
sections from ``x = 0``; robots waiting to re-enter stand in a depot below it.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from thermoswarm.errors import ConfigError
from thermoswarm.scenarios.narrow_road.params import NarrowRoadParams
from thermoswarm.sim.world import polygon_segments

__all__ = ["RoadGeometry", "road_geometry", "road_n", "section_index", "regions_toml"]


@dataclass(frozen=True)
class RoadGeometry:
    """The road as numbers (mm): built by :func:`road_geometry`, JSON-able by :meth:`info`.

    Attributes
    ----------
    length : float
    edges : ndarray (k + 1,)
        x of the section boundaries, from 0 to ``length``.
    widths : ndarray (k,)
    names : tuple of str
    outline : ndarray (m, 2)
        The road's closed outline (counter-clockwise), walls along it.
    segments : ndarray (m, 4)
        Wall segments.
    area : float
        Road area (mm^2).
    depot_line : float
        Robots with ``y`` below this wait off the road.
    depot_slots : ndarray (n, 2)
        Where each robot (by id) waits.
    bounds : (xmin, ymin, xmax, ymax)
    radius : float
    open_ends : bool
    arrive_depth : float
    entry_clearance : float
    entry_spots : (ndarray (m0, 2), ndarray (m1, 2))
        Candidate re-entry spots of group 0 (at ``x = 0``) and group 1 (at ``x = length``):
        a 1 mm grid of centres within ``entry_depth`` of the start wall, clear of every wall.
    """

    length: float
    edges: np.ndarray
    widths: np.ndarray
    names: tuple[str, ...]
    outline: np.ndarray
    segments: np.ndarray
    area: float
    depot_line: float
    depot_slots: np.ndarray
    bounds: tuple[float, float, float, float]
    radius: float
    open_ends: bool
    arrive_depth: float
    entry_clearance: float
    entry_spots: tuple[np.ndarray, np.ndarray]

    def section_areas(self) -> np.ndarray:
        """Area of each section (mm^2), splitting tapers at their middle."""
        return np.diff(self.edges) * self.widths

    def info(self) -> dict[str, Any]:
        """JSON-able description (what :func:`plot_frame` needs)."""
        return {
            "length": self.length,
            "edges": self.edges.tolist(),
            "widths": self.widths.tolist(),
            "names": list(self.names),
            "outline": self.outline.tolist(),
            "segments": self.segments.tolist(),
            "area_mm2": self.area,
            "depot_line": self.depot_line,
            "bounds": list(self.bounds),
            "radius": self.radius,
            "open_ends": self.open_ends,
            "arrive_depth": self.arrive_depth,
            "entry_clearance": self.entry_clearance,
        }


def _shoelace(p: np.ndarray) -> float:
    x, y = p[:, 0], p[:, 1]
    return float(0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def road_n(p: NarrowRoadParams) -> int:
    """Number of robots: ``n``, or ``round(occupation x road area / robot area)``."""
    if p.n is not None:
        return int(p.n)
    area = road_geometry(p, n=0).area
    return max(2, int(round(p.occupation * area / (math.pi * p.radius**2))))


def road_geometry(p: NarrowRoadParams, n: int | None = None) -> RoadGeometry:
    """The road of ``p`` with depot slots for ``n`` robots (mm)."""
    L = p.length
    edges = np.concatenate([[0.0], np.cumsum(p.section_fractions) * L])
    edges[-1] = L
    widths = np.asarray(p.section_widths, dtype=float)
    top: list[tuple[float, float]] = [(0.0, widths[0] / 2)]
    for i in range(1, len(widths)):
        xb = edges[i]
        if widths[i] != widths[i - 1]:
            h = p.taper / 2
            top.append((xb - h, widths[i - 1] / 2))
            top.append((xb + h, widths[i] / 2))
    top.append((L, widths[-1] / 2))
    # counter-clockwise: bottom edge left to right, then the top edge right to left
    bottom = [(x, -y) for x, y in top]
    outline = np.array(bottom + top[::-1])
    outline = outline[np.r_[True, np.any(np.diff(outline, axis=0) != 0, axis=1)]]
    segments = polygon_segments(outline, closed=True)
    if p.ends == "open":  # no walls across the ends
        vertical_end = (segments[:, 0] == segments[:, 2]) & np.isin(segments[:, 0], (0.0, L))
        segments = segments[~vertical_end]
    area = _shoelace(outline)
    r = p.radius
    if n is None:
        n = road_n(p)
    pitch = p.diameter + 4.0
    per_row = max(1, int((L - 4.0) // pitch))
    rows = max(1, math.ceil(n / per_row))
    depot_top = -widths.max() / 2 - 2 * p.diameter
    ids = np.arange(n)
    slots = np.column_stack(
        [2.0 + r + (ids % per_row) * pitch, depot_top - (ids // per_row) * pitch]
    )
    ymin = depot_top - (rows - 1) * pitch - r - 4.0
    margin = p.diameter if p.ends == "open" else 0.0  # room for robots leaving the road
    spots = []
    for xs0, w in ((0.0, widths[0]), (L, widths[-1])):
        xs = np.arange(r + 0.5, p.entry_depth + 1e-9, 1.0)
        xs = xs if xs0 == 0.0 else L - xs
        ys = np.arange(-w / 2 + r + 0.5, w / 2 - r - 0.5 + 1e-9, 1.0)
        ys = ys if ys.size else np.array([0.0])
        spots.append(np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2))
    geo = RoadGeometry(
        length=L,
        edges=edges,
        widths=widths,
        names=tuple(p.section_names),
        outline=outline,
        segments=segments,
        area=area,
        depot_line=-widths.max() / 2 - p.diameter / 2,
        depot_slots=slots,
        bounds=(-margin, ymin, L + margin, float(widths.max() / 2)),
        radius=r,
        open_ends=p.ends == "open",
        arrive_depth=p.arrival,
        entry_clearance=p.entry_clearance,
        entry_spots=(spots[0], spots[1]),
    )
    clear = tuple(sp[_inside(geo, sp, r * 1.001)] for sp in spots)
    for g, sp in enumerate(clear):
        if sp.shape[0] == 0:
            end = "x = 0" if g == 0 else f"x = {L:g}"
            raise ConfigError(
                f"entry_depth = {p.entry_depth:g} mm leaves no room to re-enter a robot at {end}"
            )
    return dataclasses.replace(geo, entry_spots=clear)


def _seg_distance(points: np.ndarray, seg: np.ndarray) -> np.ndarray:
    """Distance (mm) from each point (m, 2) to the nearest segment (k, 4)."""
    p = points[:, None, :]
    a = seg[None, :, 0:2]
    b = seg[None, :, 2:4]
    ab = b - a
    t = np.clip(((p - a) * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-300), 0.0, 1.0)
    q = a + t[..., None] * ab
    return np.sqrt(((p - q) ** 2).sum(-1)).min(axis=1)


def _inside(geo: RoadGeometry, points: np.ndarray, clearance: float) -> np.ndarray:
    """Points inside the road and at least ``clearance`` from every wall."""
    from matplotlib.path import Path as MplPath

    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    if pts.shape[0] == 0:
        return np.zeros(0, bool)
    ok = MplPath(geo.outline).contains_points(pts)
    ok &= _seg_distance(pts, geo.segments) >= clearance
    return ok


def section_index(x: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Section of each x (mm): ``i`` with ``edges[i] <= x < edges[i + 1]``, clipped to the
    road (x below 0 is section 0, x at or beyond the end the last section)."""
    k = len(edges) - 1
    idx = np.searchsorted(np.asarray(edges), np.asarray(x, dtype=float), side="right") - 1
    return np.clip(idx, 0, k - 1)


def regions_toml(geometry: dict[str, Any] | RoadGeometry) -> str:
    """The road's sections as a regions file for ``thermoswarm analyze --regions``.

    One ``rect`` per section, ``[x0, -width/2, x1, width/2]`` (mm); exact for square
    steps, and with a taper the boundary lies at the taper's middle.
    """
    import tomli_w

    info = geometry.info() if isinstance(geometry, RoadGeometry) else geometry
    edges, widths, names = info["edges"], info["widths"], info["names"]
    regions = [
        {"name": str(nm), "rect": [float(edges[k]), -widths[k] / 2, float(edges[k + 1]),
                                   widths[k] / 2]}
        for k, nm in enumerate(names)
    ]  # fmt: skip
    return "# narrow-road sections, mm\n" + tomli_w.dumps({"region": regions})
