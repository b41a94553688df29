"""``narrow-road``: two groups of robots cross a road with a narrow section (Algorithm 2).

The paper's first robot experiment (PAPER_NOTES sections 4, 5 and 6.2): robots that
know only the direction of a light cross a straight road in both directions, without
communicating; robots that reach the far end are put back at their start (the real
test ran 5,600 s).  The claim to reproduce: the two streams pass each other without
deadlock.

Geometry (all mm)
-----------------
The ants' road of the Methods is about 100 mm long, with a section 40 mm wide and a
section 20 mm wide.  The simulated road is 381 mm long ("road length in simulation is
381"), so the ant road is scaled by ``381 / 100 = 3.81``: the wide section is
``40 x 3.81 = 152.4`` mm wide and the narrow one ``20 x 3.81 = 76.2`` mm wide, two
robots abreast.  The paper does not give the sections' lengths (its figure is missing);
by default each is half the road (``section_fractions``), wide first.  The road runs
along +x from ``x = 0`` to ``x = length``, symmetric about ``y = 0``; its ends are open
(``ends = "open"``, the default: robots leave the road across them) or closed by walls
(``ends = "walls"``).  Steps between sections are square unless ``taper`` > 0.

Number of robots.  The paper keeps the ants' occupation ratio (robot area / road area)
0.17857 = 80 ants / 448 ant places.  With the default road the area is
``190.5 x 152.4 + 190.5 x 76.2 = 43,548 mm^2`` and a 33 mm robot covers
``pi 16.5^2 = 855.3 mm^2``, so ``N = round(0.17857 x 43,548 / 855.3) = round(9.09) = 9``
robots (occupation 0.1768).  ``n`` overrides the derivation.  Group 0 (``ceil(N/2)``
robots) starts at the wide end (``x = 0``) and heads for ``x = length``; group 1 the
other way.  At ``t = 0`` the robots stand at random non-overlapping places on the road.

Light.  Heading 0 (what TurnToAngle finds) points along the road to ``+x``: the light is
at the narrow end.  ``sensing.mode = "ideal"`` (default) takes the exact direction;
``"photoresistor"`` runs the simulated sensors and the stepwise turn
(:mod:`thermoswarm.sim.light`).

Re-entry.  A robot has arrived when its centre comes within ``arrive_depth`` of its far
end (default: with open ends, when its centre crosses the end line).  A crossing is
counted, the robot leaves the road and is put back at its start end, at a random free
spot whose centre lies within ``entry_depth`` (default 33 mm) of the start end, clear
of every robot and wall.  If there is none it waits off the road -- in a depot below
the road, standing still -- and is put back as soon as a spot frees up (first come,
first served); such waits are counted, and ``entry_clearance`` can further hold a robot
back while robots heading the other way are near its start.  A re-entered robot starts
a new control period at once.  With open ends a robot can also leave across its own
start end (pushed back by oncoming robots, or wandering): that is not a crossing; it
is counted (``left_backward``) and put back at its start the same way.

Why open ends by default: the real test had a person lift robots that "reached the
opposite end", and the ants' road opens onto the nest and the forage area.  With end
walls, robots just put back at an end are pinned against the wall by a stream arriving
there, and the road locks: with the arrival line one diameter from the wall, zero-flow
periods lasted 950-3,900 s of the 5,600 s run; with two diameters (the walls default)
the longest gap in the slower direction was 56-90 s against 42-65 s with open ends
(seeds 0-2; ``docs/scenarios_road_compression.md``).

Defaults the paper does not give (measured in ``docs/scenarios_road_compression.md``):
heading spread ``sigma_deg = 45`` and mean speed 20 mm/s (``kT = 254.65``; the robots
top out near 33 mm/s) with ``tau = 1`` s.  Narrower spreads jam the narrow section
(robots rarely back off), wider ones cross slowly; slower robots give proportionally
longer zero-flow periods.

Recorded per frame (besides position): ``heading``, ``speed`` (commanded), ``section``
(index into ``metrics["road"]["sections"]``, -1 while waiting off the road), ``lap``
(times the robot has been put back: split a robot's track where it changes) and
``group``.

Metrics (``metrics.json``) -- directions are named ``"+x"`` (group 0) and ``"-x"``
(group 1):

- ``flow_per_direction``: crossings per minute over the run;
- ``flow_over_time``: crossings per minute in bins of ``flow_bin`` seconds;
- ``crossings``: counts per direction and in total;
- ``longest_zero_flow_s``: longest time without a crossing per direction and
  ``overall`` (no crossing in either direction), counting from t = 0 and to the end;
- ``transit_times``: seconds from entry to arrival (complete laps only: a robot's first
  lap from its random start is not one), with summary statistics and the values;
- ``waiting``: entries, entries that had to wait, total and longest wait;
- ``sections``: per road section, the occupancy and the speed and energy
  (``v^2 / 2``, mm^2/s^2) both commanded and measured from the recorded positions
  (frame-to-frame displacement / interval, within one lap), overall and per direction.

See ``docs/scenarios_road_compression.md``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import xarray as xr

from thermoswarm.config import check, check_positive
from thermoswarm.errors import ConfigError
from thermoswarm.maxent import kT_for_mean_speed
from thermoswarm.policy import STEERING_LAWS, Action, NarrowRoad, Observation, Policy
from thermoswarm.scenarios import register
from thermoswarm.scenarios.base import Numerics, Recording, Scenario, Setup, wrap
from thermoswarm.sim.engine import Simulator, SwarmState, place_lattice
from thermoswarm.sim.light import DirectionalLight, SensingParams, sense
from thermoswarm.sim.world import World, polygon_segments

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
]

#: The ants' occupation ratio: 80 ants on 448 ant places (PAPER_NOTES section 5).
PAPER_OCCUPATION = 80 / 448
#: Scale from the ants' ~100 mm road to the simulated 381 mm road.
ROAD_SCALE = 381.0 / 100.0
DIRECTIONS = ("+x", "-x")


@dataclass(frozen=True)
class NarrowRoadParams:
    """Parameters of ``narrow-road`` (lengths mm, times s, angles as named).

    Attributes
    ----------
    length : float
        Road length (mm); the paper's simulated road is 381.
    section_fractions : tuple of float
        Lengths of the sections as fractions of ``length`` (sum 1), from ``x = 0``.
    section_widths : tuple of float
        Widths of the sections (mm); default the ants' 40 and 20 mm times 3.81.
    section_names : tuple of str
        Names used in the metrics.
    taper : float
        Length (mm) of a linear transition between sections of different widths
        (0: a square step).
    occupation : float
        Robot area / road area, from which the number of robots is derived.
    n : int or None
        Number of robots; overrides ``occupation``.
    diameter : float
        Robot diameter (mm).
    kT : float
        Speed temperature (mm^2/s^2 per unit mass); default: mean speed 20 mm/s (the
        robots top out near 33 mm/s; see the module docstring for the choice).
    tau : float
        Control period (s).
    steering : {"normal", "exponential"}
        Heading law of Algorithm 2 (:class:`thermoswarm.policy.NarrowRoad`).
    sigma_deg : float
        Spread of the normal heading law (deg).
    T_theta_max, T_theta_min : float
        Steering temperatures (rad/s) of the exponential law at speed 0 and high speed.
    v_scale : float
        Speed scale (mm/s) of the fall of the steering temperature.
    speed_law : {"boltzmann", "half-normal"}
        The speed law (PAPER_NOTES 6.1).
    ends : {"open", "walls"}
        Open road ends (robots leave the road across them) or end walls.
    arrive_depth : float or None
        A robot whose centre comes this close (mm) to its far end has arrived.
        Default 0 with open ends (the centre crosses the end line) and two diameters
        with end walls (see the module docstring).
    entry_depth : float
        Re-entry spots are centres within this distance (mm) of the start wall.
    entry_clearance : float
        A robot is put back only while no robot heading the other way has its centre
        within this distance (mm) of the start wall (0: no such rule).
    flow_bin : float
        Width (s) of the bins of ``flow_over_time``.
    duration : float
        Simulated seconds; default the paper's 5,600 s test.
    sensing : SensingParams
        How robots find heading 0 (``mode = "ideal"`` or ``"photoresistor"``).
    """

    length: float = 381.0
    section_fractions: tuple[float, ...] = (0.5, 0.5)
    section_widths: tuple[float, ...] = (40.0 * ROAD_SCALE, 20.0 * ROAD_SCALE)
    section_names: tuple[str, ...] = ("wide", "narrow")
    taper: float = 0.0
    occupation: float = round(PAPER_OCCUPATION, 5)
    n: int | None = None
    diameter: float = 33.0
    kT: float = field(default_factory=lambda: round(kT_for_mean_speed(20.0), 6))
    tau: float = 1.0
    steering: Literal["normal", "exponential"] = "normal"
    sigma_deg: float = 45.0
    T_theta_max: float = 1.0
    T_theta_min: float = 0.2
    v_scale: float = 10.0
    speed_law: Literal["boltzmann", "half-normal"] = "boltzmann"
    ends: Literal["open", "walls"] = "open"
    arrive_depth: float | None = None
    entry_depth: float = 33.0
    entry_clearance: float = 0.0
    flow_bin: float = 60.0
    duration: float = 5600.0
    sensing: SensingParams = SensingParams(mode="ideal")
    engine: Numerics = Numerics()
    record: Recording = Recording(interval=0.1, block=1000)

    def __post_init__(self) -> None:
        fin = math.isfinite
        check_positive("length", self.length, "a positive length (mm)")
        k = len(self.section_fractions)
        check(k >= 1, "section_fractions", "a non-empty list", self.section_fractions)
        check(
            all(fin(f) and f > 0 for f in self.section_fractions)
            and abs(sum(self.section_fractions) - 1) < 1e-6,
            "section_fractions",
            "positive fractions of the road length that sum to 1",
            self.section_fractions,
        )
        check(
            len(self.section_widths) == k,
            "section_widths",
            f"a list of {k} widths (one per section)",
            self.section_widths,
        )
        check(
            len(self.section_names) == k and len(set(self.section_names)) == k,
            "section_names",
            f"a list of {k} distinct names (one per section)",
            self.section_names,
        )
        check_positive("diameter", self.diameter, "a positive length (mm)")
        check(
            all(fin(w) and w >= self.diameter + 2 for w in self.section_widths),
            "section_widths",
            f"widths of at least the robot diameter + 2 = {self.diameter + 2:g} mm",
            self.section_widths,
        )
        shortest = min(self.section_fractions) * self.length
        check(
            fin(self.taper) and 0 <= self.taper < shortest,
            "taper",
            f"in [0, {shortest:g}) mm (shorter than the shortest section)",
            self.taper,
        )
        check(self.ends in ("open", "walls"), "ends", "'open' or 'walls'", self.ends)
        lo = self.diameter / 2 + 1
        check(
            fin(self.entry_depth) and lo < self.entry_depth <= self.length / 4,
            "entry_depth",
            f"in ({lo:g}, {self.length / 4:g}] mm (more than a robot radius + 1 mm, at most a "
            "quarter of the road)",
            self.entry_depth,
        )
        if self.arrive_depth is not None:
            a = self.arrive_depth
            if self.ends == "walls":
                ok = fin(a) and lo < a <= self.length / 3
                want = f"in ({lo:g}, {self.length / 3:g}] mm with end walls (a centre cannot come "
                want += "closer than a radius to a wall)"
            else:
                ok = fin(a) and 0 <= a <= self.length / 3
                want = f"in [0, {self.length / 3:g}] mm"
            check(ok, "arrive_depth", want, a)
        check(
            fin(self.occupation) and 0 < self.occupation < 0.6,
            "occupation",
            "in (0, 0.6) (robot area / road area)",
            self.occupation,
        )
        if self.n is not None:
            check(self.n >= 2, "n", "an integer >= 2 (two groups)", self.n)
        check(
            fin(self.entry_clearance) and 0 <= self.entry_clearance <= self.length / 2,
            "entry_clearance",
            f"in [0, {self.length / 2:g}] mm",
            self.entry_clearance,
        )
        check_positive("kT", self.kT, "a positive number (mm^2/s^2)")
        check_positive("tau", self.tau, "a positive number of seconds")
        check(
            self.steering in STEERING_LAWS,
            "steering",
            "'normal' or 'exponential'",
            self.steering,
        )
        check(
            fin(self.sigma_deg) and 0 < self.sigma_deg <= 360,
            "sigma_deg",
            "in (0, 360] degrees",
            self.sigma_deg,
        )
        for name in ("T_theta_max", "T_theta_min", "v_scale"):
            v = getattr(self, name)
            check(fin(v) and v > 0, name, "a positive number", v)
        check(
            self.T_theta_min <= self.T_theta_max,
            "T_theta_min",
            f"at most T_theta_max = {self.T_theta_max}",
            self.T_theta_min,
        )
        check_positive("flow_bin", self.flow_bin, "a positive number of seconds")
        check_positive("duration", self.duration, "a positive number of seconds")

    @property
    def radius(self) -> float:
        return self.diameter / 2

    @property
    def arrival(self) -> float:
        """``arrive_depth``, or its default for the kind of ends (mm)."""
        if self.arrive_depth is not None:
            return self.arrive_depth
        return 0.0 if self.ends == "open" else 2 * self.diameter


# --------------------------------------------------------------------------------------
# Geometry


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
    """The road of ``p`` (see the module docstring) with depot slots for ``n`` robots."""
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


# --------------------------------------------------------------------------------------
# Sensing and the depot


class _Sensing:
    """Heading 0 along +x: exact (ideal, no noise) or from the light module."""

    def __init__(self, params: SensingParams) -> None:
        self.params = params
        self.light = DirectionalLight(direction=(-1.0, 0.0))  # rays travel -x: source at +x
        self.exact = params.mode == "ideal" and params.ideal_noise_deg == 0

    def __call__(self, state: SwarmState, index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        m = index.size
        if self.exact:
            return np.zeros(m), np.ones(m)
        res = sense(
            state.pos[index], state.heading[index], self.light, None, self.params, state.rng
        )
        return res.zero_heading, res.light


@dataclass(frozen=True)
class _DepotStop:
    """Wraps a policy: robots waiting off the road (below ``depot_line``) stand still."""

    inner: Policy
    depot_line: float

    def act(self, obs: Observation, rng: np.random.Generator) -> Action:
        a = self.inner.act(obs, rng)
        parked = obs.position[:, 1] < self.depot_line
        if parked.any():
            speed = np.where(parked, 0.0, a.speed)
            return Action(heading=a.heading, speed=speed)
        return a


# --------------------------------------------------------------------------------------
# Metric functions (pure; tested on constructed cases)


def longest_gap(times: np.ndarray, start: float, end: float) -> float:
    """Longest interval (s) in ``[start, end]`` containing none of ``times``."""
    t = np.sort(np.asarray(times, dtype=float).ravel())
    t = t[(t >= start) & (t <= end)]
    return float(np.diff(np.concatenate([[start], t, [end]])).max())


def flow_series(times: np.ndarray, duration: float, bin_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Crossings per minute in consecutive bins of ``bin_s`` seconds over ``[0, duration]``.

    Returns ``(bin_starts, flow)``; the last bin may be shorter and is normalised by its
    own length.
    """
    starts = np.arange(0.0, duration, bin_s)
    if starts.size == 0:
        starts = np.array([0.0])
    ends = np.minimum(starts + bin_s, duration)
    t = np.asarray(times, dtype=float).ravel()
    counts = np.histogram(t, bins=np.append(starts, duration))[0]
    width = np.maximum(ends - starts, 1e-12)
    return starts, counts * 60.0 / width


def _summary(values: np.ndarray) -> dict[str, Any]:
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {"n": 0}
    q = np.quantile(v, [0.1, 0.5, 0.9])
    return {
        "n": int(v.size),
        "mean": float(v.mean()),
        "std": float(v.std(ddof=1)) if v.size > 1 else 0.0,
        "p10": float(q[0]),
        "median": float(q[1]),
        "p90": float(q[2]),
        "max": float(v.max()),
    }


def section_samples(tracks: xr.Dataset) -> dict[str, np.ndarray]:
    """Measured speed samples with their section, direction and time.

    The speed of a robot between consecutive frames is its displacement over the frame
    interval (mm/s), attributed to the section of the first frame; pairs that span a
    re-entry (``lap`` changes) or a wait off the road (``section`` -1) are dropped.

    Returns arrays ``time`` (s, first frame), ``id``, ``group``, ``section``, ``speed``
    (mm/s) and ``energy`` (``v^2 / 2``, mm^2/s^2), one entry per sample.
    """
    pos = tracks["position"].isel(keypoints=0).transpose("time", "space", "individuals").values
    t = tracks["time"].values.astype(float)
    sec = tracks["section"].values
    lap = tracks["lap"].values
    grp = tracks["group"].values
    if t.size < 2:
        empty = np.zeros(0)
        return {k: empty for k in ("time", "id", "group", "section", "speed", "energy")}
    dt = np.diff(t)[:, None]
    disp = np.hypot(pos[1:, 0] - pos[:-1, 0], pos[1:, 1] - pos[:-1, 1])
    v = disp / dt
    ok = (lap[1:] == lap[:-1]) & (sec[:-1] >= 0) & (sec[1:] >= 0) & np.isfinite(v)
    ti, ii = np.nonzero(ok)
    vv = v[ti, ii]
    return {
        "time": t[ti],
        "id": ii,
        "group": grp[ti, ii].astype(int),
        "section": sec[ti, ii].astype(int),
        "speed": vv,
        "energy": 0.5 * vv**2,
    }


def section_stats(
    tracks: xr.Dataset, names: tuple[str, ...] | list[str], areas: np.ndarray
) -> dict[str, Any]:
    """Per-section occupancy and speed/energy statistics (see the module docstring)."""
    s = section_samples(tracks)
    sec_all = tracks["section"].values
    cmd = tracks["speed"].values.astype(float)
    grp_all = tracks["group"].values
    t_all = np.broadcast_to(tracks["time"].values.astype(float)[:, None], sec_all.shape)
    nframes = max(sec_all.shape[0], 1)
    span = (float(t_all[0, 0]), float(t_all[-1, 0])) if sec_all.size else (0.0, 0.0)
    out: dict[str, Any] = {}
    for k, name in enumerate(names):
        here = s["section"] == k
        occ = float((sec_all == k).sum()) / nframes
        entry: dict[str, Any] = {
            "occupancy_mean": occ,
            "density_per_mm2": occ / float(areas[k]),
            "measured": _speed_energy(s["speed"][here], s["time"][here], span),
            "commanded": _speed_energy(cmd[sec_all == k], t_all[sec_all == k], span),
            "by_direction": {},
        }
        for g, d in enumerate(DIRECTIONS):
            sel = here & (s["group"] == g)
            sel_all = (sec_all == k) & (grp_all == g)
            entry["by_direction"][d] = {
                "measured": _speed_energy(s["speed"][sel], s["time"][sel], span),
                "commanded": _speed_energy(cmd[sel_all], t_all[sel_all], span),
            }
        out[name] = entry
    return out


#: Time blocks for the standard error of per-section energies.
SE_BLOCKS = 20


def _speed_energy(v: np.ndarray, t: np.ndarray, span: tuple[float, float]) -> dict[str, Any]:
    """Speed and energy statistics of samples ``v`` (mm/s) taken at times ``t`` (s).

    ``energy_se`` comes from the means of :data:`SE_BLOCKS` equal time blocks over
    ``span`` (samples a fraction of a control period apart are not independent); null
    with fewer than 2 blocks holding samples.
    """
    v = np.asarray(v, dtype=float)
    t = np.asarray(t, dtype=float)
    ok = np.isfinite(v)
    v, t = v[ok], t[ok]
    if v.size == 0:
        return {"n": 0}
    e = 0.5 * v**2
    edges = np.linspace(span[0], span[1], SE_BLOCKS + 1)
    blk = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, SE_BLOCKS - 1)
    cnt = np.bincount(blk, minlength=SE_BLOCKS)
    sums = np.bincount(blk, weights=e, minlength=SE_BLOCKS)
    means = sums[cnt > 0] / cnt[cnt > 0]
    se = float(means.std(ddof=1) / math.sqrt(means.size)) if means.size > 1 else None
    return {
        "n": int(v.size),
        "speed_mean": float(v.mean()),
        "speed_std": float(v.std(ddof=1)) if v.size > 1 else 0.0,
        "energy_mean": float(e.mean()),
        "energy_se": se,
        "stopped_fraction": float(np.mean(v < 0.5)),
    }


# --------------------------------------------------------------------------------------
# The scenario


@register
class NarrowRoadScenario(Scenario):
    name = "narrow-road"
    description = (
        "two groups cross a road with a narrow section (Algorithm 2); re-entry at the start"
    )
    Params = NarrowRoadParams

    def build(self, rng: np.random.Generator) -> Setup:
        p: NarrowRoadParams = self.params
        n = road_n(p)
        geo = road_geometry(p, n)
        r = p.radius
        world = World(geo.bounds, geo.segments)
        engine = p.engine.engine(tau=p.tau, radius=r)
        road_box = (0.0, -geo.widths.max() / 2, geo.length, geo.widths.max() / 2)
        pos = place_lattice(road_box, n, r, rng, inside=lambda q: _inside(geo, q, r * 1.001))
        group = np.zeros(n, np.int32)
        group[(n + 1) // 2 :] = 1
        # initial headings toward the goals (the first decision re-draws them anyway)
        headings = np.where(group == 0, 0.0, math.pi)
        policy = NarrowRoad(
            kT=p.kT,
            steering=p.steering,
            sigma=math.radians(p.sigma_deg),
            T_theta_max=p.T_theta_max,
            T_theta_min=p.T_theta_min,
            v_scale=p.v_scale,
            speed_law=p.speed_law,
        )
        self._geometry = geo
        reach = 1.01 * p.diameter + 1e-6  # as in _free_spot's clearance test
        self._boxes = [(sp.min(axis=0) - reach, sp.max(axis=0) + reach)
                       for sp in geo.entry_spots]  # fmt: skip
        return Setup(
            world=world,
            engine=engine,
            policy=_DepotStop(policy, geo.depot_line),
            positions=pos,
            sensing=_Sensing(p.sensing),
            group=group,
            headings=headings,
            info={"geometry": geo, "n": n},
        )

    def extras(self, setup: Setup) -> dict[str, tuple[tuple[str, ...], tuple[int, ...], str]]:
        n = setup.positions.shape[0]
        out = super().extras(setup)
        out["section"] = (("time", "individuals"), (n,), "i1")
        out["lap"] = (("time", "individuals"), (n,), "i4")
        out["group"] = (("time", "individuals"), (n,), "i1")
        return out

    def _geo(self) -> RoadGeometry:
        return self._geometry  # set by build(), which both run and resume call

    def frame(
        self, sim: Simulator, state: SwarmState, acc: dict[str, np.ndarray]
    ) -> dict[str, np.ndarray]:
        geo = self._geo()
        pos = state.by_id(state.pos)
        sec = section_index(pos[:, 0], geo.edges).astype(np.int8)
        sec[pos[:, 1] < geo.depot_line] = -1
        return {
            "heading": wrap(state.by_id(state.heading)),
            "speed": state.by_id(state.speed),
            "section": sec,
            "lap": acc["lap"].astype(np.int32),
            "group": state.by_id(state.group).astype(np.int8),
        }

    # -- every step: arrivals and re-entries
    def init_acc(self, setup: Setup, sim: Simulator, state: SwarmState) -> dict[str, np.ndarray]:
        n = state.n
        return {
            "entry_time": np.full(n, np.nan),  # NaN: still on the lap it started on
            "lap": np.zeros(n, np.int64),
            "park_since": np.full(n, np.nan),  # NaN: on the road
            "n_parked": np.array(0),
            # time, id, group, transit (NaN: partial lap), kind (1 arrived, 0 pushed back)
            "events": np.zeros((64, 5)),
            "n_events": np.array(0),
            "entries": np.zeros(2, np.int64),
            "waited": np.zeros(2, np.int64),
            "wait_total": np.zeros(2),
            "wait_max": np.zeros(2),
        }

    def observe(self, sim: Simulator, state: SwarmState, acc: dict[str, np.ndarray]) -> None:
        geo = self._geo()
        x = state.pos[:, 0]
        g = state.group
        L = geo.length
        ad = geo.arrive_depth
        # cheap test first (every step, a handful of robots): anyone near an end line?
        if x.min() <= ad or x.max() >= L - ad:
            arrived = ((g == 0) & (x >= L - ad)) | ((g == 1) & (x <= ad))
            backed = ((g == 0) & (x < 0.0)) | ((g == 1) & (x > L))  # open ends only
            leaving = arrived | backed
        else:
            leaving = None
        if leaving is not None and leaving.any():
            leaving &= state.pos[:, 1] > geo.depot_line
            for i in np.flatnonzero(leaving):
                self._leave(state, acc, geo, int(i), arrived=bool(arrived[i]))
        if acc["n_parked"] > 0:
            self._reenter(state, acc, geo)

    def _leave(self, state: SwarmState, acc: dict[str, np.ndarray], geo: RoadGeometry,
               i: int, *, arrived: bool) -> None:  # fmt: skip
        """Robot ``i`` leaves the road: it arrived (a crossing) or was pushed back out of
        its start end (open ends); either way it is put back at its start."""
        a = int(state.ids[i])
        g = int(state.group[i])
        t = state.time
        k = int(acc["n_events"])
        if k == acc["events"].shape[0]:
            acc["events"] = np.vstack([acc["events"], np.zeros_like(acc["events"])])
        transit = t - acc["entry_time"][a] if arrived else np.nan
        acc["events"][k] = (t, a, g, transit, 1.0 if arrived else 0.0)
        acc["n_events"] = np.array(k + 1)
        acc["lap"][a] += 1
        acc["park_since"][a] = t
        acc["n_parked"] = np.array(int(acc["n_parked"]) + 1)
        state.pos[i] = geo.depot_slots[a]
        state.speed[i] = 0.0

    def _reenter(self, state: SwarmState, acc: dict[str, np.ndarray], geo: RoadGeometry) -> None:
        r = geo.radius
        d = 2 * r
        t = state.time
        ids = state.ids
        row_of = np.empty(state.n, np.int64)
        row_of[ids] = np.arange(state.n)
        waiting = np.flatnonzero(np.isfinite(acc["park_since"]))
        order = waiting[np.lexsort((waiting, acc["park_since"][waiting]))]
        for a in order:
            i = int(row_of[a])
            g = int(state.group[i])
            on_road = state.pos[:, 1] > geo.depot_line
            others = state.pos[on_road]
            if geo.entry_clearance > 0:
                x = others[:, 0] if g == 0 else geo.length - others[:, 0]
                oncoming = state.group[on_road] != g
                if np.any(oncoming & (x < geo.entry_clearance)):
                    continue
            spot = self._free_spot(geo.entry_spots[g], self._boxes[g], others, d, state.rng)
            if spot is None:
                continue
            state.pos[i] = spot
            state.speed[i] = 0.0
            state.timer[i] = 0  # a new control period starts at the next step
            wait = t - acc["park_since"][a]
            acc["park_since"][a] = np.nan
            acc["n_parked"] = np.array(int(acc["n_parked"]) - 1)
            acc["entry_time"][a] = t
            acc["entries"][g] += 1
            if wait > 0:
                acc["waited"][g] += 1
                acc["wait_total"][g] += wait
                acc["wait_max"][g] = max(acc["wait_max"][g], wait)

    @staticmethod
    def _free_spot(
        spots: np.ndarray,
        box: tuple[np.ndarray, np.ndarray],
        others: np.ndarray,
        d: float,
        rng: np.random.Generator,
    ) -> np.ndarray | None:
        """A random spot among ``spots`` (mm) clear of every robot in ``others``, or None;
        ``box`` = (lower, upper corner) of the spots widened by ``d``."""
        # only robots within reach of the zone matter
        lo, hi = box
        near = np.all((others >= lo) & (others <= hi), axis=1)
        others = others[near]
        if others.shape[0]:
            dx = spots[:, None, 0] - others[None, :, 0]
            dy = spots[:, None, 1] - others[None, :, 1]
            spots = spots[(dx * dx + dy * dy).min(axis=1) >= (d * 1.01) ** 2]
        if spots.shape[0] == 0:
            return None
        return spots[rng.integers(spots.shape[0])].copy()

    # -- the end
    def metrics(
        self,
        setup: Setup,
        acc: dict[str, np.ndarray],
        tracks: xr.Dataset,
        sim: Simulator,
        state: SwarmState,
    ) -> dict[str, Any]:
        p: NarrowRoadParams = self.params
        geo: RoadGeometry = setup.info["geometry"]
        n = int(setup.info["n"])
        T = float(state.time)
        ev_all = acc["events"][: int(acc["n_events"])]
        ev = ev_all[ev_all[:, 4] == 1.0]  # crossings; the rest left backward
        ev_t, ev_g, ev_transit = ev[:, 0], ev[:, 2].astype(int), ev[:, 3]
        group = state.by_id(state.group)
        robot_area = math.pi * p.radius**2
        out: dict[str, Any] = {
            "n": n,
            "n_per_direction": {d: int(np.sum(group == g)) for g, d in enumerate(DIRECTIONS)},
            "occupation": n * robot_area / geo.area,
            "occupation_target": p.occupation if p.n is None else None,
            "duration": T,
            "kT": p.kT,
            "tau": p.tau,
            "steering": p.steering,
            "crossings": {
                **{d: int(np.sum(ev_g == g)) for g, d in enumerate(DIRECTIONS)},
                "total": int(ev.shape[0]),
            },
            "left_backward": {
                d: int(np.sum((ev_all[:, 4] == 0.0) & (ev_all[:, 2] == g)))
                for g, d in enumerate(DIRECTIONS)
            },
            "flow_per_direction": {
                d: float(np.sum(ev_g == g) * 60.0 / T) for g, d in enumerate(DIRECTIONS)
            },
            "longest_zero_flow_s": {
                **{d: longest_gap(ev_t[ev_g == g], 0.0, T) for g, d in enumerate(DIRECTIONS)},
                "overall": longest_gap(ev_t, 0.0, T),
            },
        }
        flows: dict[str, Any] = {"bin_s": p.flow_bin}
        for g, d in enumerate(DIRECTIONS):
            starts, f = flow_series(ev_t[ev_g == g], T, p.flow_bin)
            flows["t_start"] = starts.tolist()
            flows[d] = f.tolist()
        out["flow_over_time"] = flows
        out["transit_times"] = {}
        for g, d in enumerate(DIRECTIONS):
            vals = ev_transit[(ev_g == g) & np.isfinite(ev_transit)]
            out["transit_times"][d] = {**_summary(vals), "values": vals.tolist()}
        out["waiting"] = {
            d: {
                "entries": int(acc["entries"][g]),
                "waited": int(acc["waited"][g]),
                "total_wait_s": float(acc["wait_total"][g]),
                "max_wait_s": float(acc["wait_max"][g]),
                "waiting_at_end": int(np.sum(np.isfinite(acc["park_since"]) & (group == g))),
            }
            for g, d in enumerate(DIRECTIONS)
        }
        areas = geo.section_areas()
        out["sections"] = section_stats(tracks, geo.names, areas)
        out["road"] = {
            "length": geo.length,
            "area_mm2": geo.area,
            "sections": [
                {
                    "name": geo.names[k],
                    "x0": float(geo.edges[k]),
                    "x1": float(geo.edges[k + 1]),
                    "width": float(geo.widths[k]),
                    "area_mm2": float(areas[k]),
                }
                for k in range(len(geo.names))
            ],
            "geometry": geo.info(),
        }
        out["mean_sweeps_per_step"] = float(state.counters[0]) / max(state.step, 1)
        out["max_overlap_fraction"] = float(state.counters[1]) / 1e6 / p.diameter
        out["final_max_overlap_fraction"] = sim.max_overlap(state) / p.diameter
        return out


# --------------------------------------------------------------------------------------
# Drawing


def plot_frame(
    ax: Any,
    tracks: xr.Dataset,
    t: float,
    setup_info: dict[str, Any] | RoadGeometry,
    *,
    color_by: Literal["group", "speed"] = "group",
    cmap: str = "viridis",
) -> Any:
    """Draw the road and the robots at the recorded frame nearest ``t`` (s) on ``ax``.

    ``setup_info`` is ``metrics["road"]["geometry"]`` (or a :class:`RoadGeometry`).
    Robots are discs coloured by direction (``color_by="group"``: +x blue, -x orange) or
    by commanded speed; robots waiting off the road are not drawn but counted in the
    title.  Returns the collection of robot discs.
    """
    from matplotlib.collections import EllipseCollection, LineCollection

    info = setup_info.info() if isinstance(setup_info, RoadGeometry) else setup_info
    k = int(np.argmin(np.abs(tracks["time"].values - t)))
    fr = tracks.isel(time=k)
    pos = fr["position"].isel(keypoints=0).transpose("individuals", "space").values
    on = fr["section"].values >= 0 if "section" in fr else np.ones(pos.shape[0], bool)
    seg = np.asarray(info["segments"])
    ax.add_collection(LineCollection(seg.reshape(-1, 2, 2), colors="k", linewidths=1.5))
    r = float(info["radius"])
    for x in info["edges"][1:-1]:
        ax.axvline(x, color="0.8", lw=0.8, ls=":", zorder=0)
    d = np.full(int(on.sum()), 2 * r)
    coll = EllipseCollection(
        d, d, np.zeros_like(d), units="xy", offsets=pos[on], offset_transform=ax.transData
    )
    if color_by == "speed":
        coll.set_array(fr["speed"].values[on].astype(float))
        coll.set_cmap(cmap)
    else:
        g = fr["group"].values[on] if "group" in fr else np.zeros(int(on.sum()))
        coll.set_facecolor(np.where(g[:, None] == 0, [[0.12, 0.47, 0.71, 1]], [[1, 0.5, 0.05, 1]]))
    coll.set_edgecolor("k")
    coll.set_linewidth(0.5)
    ax.add_collection(coll)
    L = float(info["length"])
    wmax = max(info["widths"])
    ax.set_xlim(-0.05 * L, 1.05 * L)
    ax.set_ylim(-0.6 * wmax - 5, 0.6 * wmax + 5)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    waiting = int((~on).sum())
    title = f"t = {float(tracks['time'].values[k]):.0f} s"
    if waiting:
        title += f" ({waiting} waiting off the road)"
    ax.set_title(title)
    return coll


def plot_flow(ax: Any, metrics: dict[str, Any]) -> None:
    """Crossings per minute per direction over time (``metrics["flow_over_time"]``)."""
    f = metrics["flow_over_time"]
    t = np.asarray(f["t_start"], dtype=float) + 0.5 * float(f["bin_s"])
    for d in DIRECTIONS:
        ax.step(t, f[d], where="mid", label=f"{d} ({metrics['flow_per_direction'][d]:.2f}/min)")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("crossings per minute")
    ax.legend()


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
