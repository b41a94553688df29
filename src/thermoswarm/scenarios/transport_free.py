"""``transport-free``: a swarm moves an object it is not attached to (Algorithm 5).

The paper's setup (PAPER_NOTES section 5): 1,200 robots, a 100 mm object in the centre
of a walled arena, the light on the target side (+y, "the top"); the object's shadow
darkens the area behind it, and each robot switches the temperature of its speed law
by the light level it senses (Algorithm 5).  Variants:

- ``free``: an open square arena;
- ``obstacle``: a round pillar between the object and the target, offset to one side so
  that the object must slide past it (the pillar casts a shadow unless
  ``obstacle_shadow = false``);
- ``zigzag``: the robots start in an open room; above the object a zig-zag channel
  leads to the top (the object starts in the channel's straight mouth).  Channel walls
  are low: they stop robots and the object but cast no shadow.

Modelling choices (see ``docs/scenarios_transport.md`` for the measurements):

- **Mapping** (PAPER_NOTES 6.3): ``"lit_hot"`` (captions and text: lit robots gas-like)
  or ``"lit_cold"`` (the equation: T_liquid where l > threshold).
- **Heading law**: ``"uniform"`` (fresh every period, Algorithm 5 as written) or
  ``"persistent"`` (heading kept, steered by the exponential steering-rate law, with a
  steering temperature per phase).  The default is ``lit_cold`` with ``persistent``
  headings, hot robots steering little and cold robots much, at mean speeds 22 and 18
  mm/s cut at the robot's 33 mm/s: the fastest regime of the drift-speed search
  (``thermoswarm.studies.regime``).  Fresh uniform headings do not move the object
  toward the light with either mapping, and the captions' ``lit_hot`` pushes it away
  (``thermoswarm.studies.mechanism``).
- **Light**: directional from +y by default (a lamp far beyond the target: rays across a
  100 mm object are parallel to a few percent when the lamp is 2 m away), or a point
  lamp ``light_distance`` mm beyond the top wall.  Arena walls cast no shadow (the lamp
  is above them); the object's disc does, and so does the obstacle.
- **Object**: a movable disc (``Body``) of radius 50 mm with viscous ground-friction
  drag ``object_drag`` in units of one robot's drag (the paper gives no mass or
  friction).  The default 2 means that one robot alone pushes it at one third of its
  own speed; the object's speed under a given net force scales as ``1 / object_drag``.
- **Phase**: each robot's phase (1 hot, 0 cold) is decided from its light reading at
  the start of each control period and held for the period; it is kept in the engine's
  ``group`` column and recorded per frame as ``phase``.

Units: mm, s; forces in robot drag units (mm/s); temperatures mm^2/s^2; angles rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import xarray as xr

from thermoswarm.config import check
from thermoswarm.errors import ConfigError
from thermoswarm.maxent import kT_for_mean_speed
from thermoswarm.policy import PHASE_HOT, LightSwitchedTransport, TurnTimeCharged
from thermoswarm.scenarios._transport import (
    TransportSensing,
    TransportSensor,
    batch_mean_se,
    draw_world,
    light_info,
    make_light,
    nearest_frame,
    segment_distance,
    shadow_polygon,
)
from thermoswarm.scenarios.base import Numerics, Recording, Scenario, Setup, wrap
from thermoswarm.scenarios.registry import register
from thermoswarm.sim import kernels as K
from thermoswarm.sim.engine import Simulator, SwarmState, place_lattice
from thermoswarm.sim.geometry import Shapes
from thermoswarm.sim.light import light_level
from thermoswarm.sim.world import Body, World, polygon_segments

__all__ = [
    "TransportFreeParams",
    "TransportFree",
    "Geometry",
    "geometry",
    "zigzag_centreline",
    "plot_frame",
    "transport_metrics",
    "phase_by_region",
    "summarize_phase_by_region",
    "capped_temperature",
]

#: Arena (width, height) in mm when not given: about packing fraction 0.32 for 1,200
#: robots of 33 mm in the free arena; the zig-zag arena is larger because its upper part
#: is mostly solid.
DEFAULT_ARENA = {
    "free": (1800.0, 1800.0),
    "obstacle": (1800.0, 1800.0),
    "zigzag": (2400.0, 2400.0),
}
#: Simulated seconds when ``duration`` is not given: every run of seeds 0-9 of the
#: defaults reaches the target within it (free: at most 998 s, obstacle 1578 s, zigzag
#: 1153 s; ``docs/scenarios_transport.md``).
DEFAULT_DURATION = {"free": 1200.0, "obstacle": 1800.0, "zigzag": 1800.0}
#: Batches of the time-averaged force (batch-means standard error).
FORCE_BATCHES = 20


@dataclass(frozen=True)
class TransportFreeParams:
    """Parameters of ``transport-free`` (lengths mm, times s, temperatures mm^2/s^2).

    Attributes
    ----------
    variant : {"free", "obstacle", "zigzag"}
    n : int
        Number of robots (the paper: 1,200).
    width, height : float or None
        Arena size (mm); ``None``: 1800 x 1800 (free, obstacle), 2400 x 2400 (zigzag).
    duration : float or None
        Simulated seconds, warm-up included; ``None``: :data:`DEFAULT_DURATION` of the
        variant (free 1200 s; obstacle and zigzag 1800 s), within which every run of
        seeds 0-9 of the defaults reached the target.
    warmup : float
        Seconds during which the object is held in place (its contact force measured:
        ``metrics["force_held"]``) before it is released; displacement, time to target
        and the free force count from the release.  0 (default): released at once, the
        paper's protocol, so the first seconds carry the transient of the initial
        placement (robots spread evenly, whatever their phase).
    diameter : float
        Robot diameter (the paper's robots: 33 mm).
    tau : float
        Control period (s).
    mapping : {"lit_cold", "lit_hot"}
        Which robots are hot: ``lit_cold`` (the paper's equation; default) or
        ``lit_hot`` (the paper's captions).
    heading_law : {"persistent", "uniform"}
    kT_hot, kT_cold : float
        Temperatures of the gas-like and liquid-like phases; defaults give mean speeds
        22 and 18 mm/s (Rayleigh laws, cut at ``v_max``).  Chosen by the drift-speed
        search (``thermoswarm study regime``): the push grows with the rate at which
        cold robots enter the shadow, so a mobile cold phase moves the object fastest.
    kT_theta : float
        Steering temperature (rad/s) of the persistent law (mean |turn rate|) of hot
        robots (and of cold ones unless ``kT_theta_cold``).  The default 0.1 turns a
        heading by 0.1 rad per 1 s period on average: heading correlation time ``tau /
        ln(1 + (kT_theta tau)^2)`` = 100 s, so a hot robot runs straight for metres.
    kT_theta_cold : float or None
        Steering temperature (rad/s) of cold robots (``None``: ``kT_theta``).  Default 2:
        a cold robot's heading is nearly random after one period (correlation time 0.6
        s), so it presses on the object only briefly, while a hot one keeps pushing.  The
        paper's steering law has a temperature that falls with speed (its Discussion
        table), which this follows.
    v_max : float or None
        Top speed (mm/s): sampled speeds above it are cut to it (the paper's robot:
        about 33 mm/s, the default; ``None``: no cut).
    threshold : float
        Light level above which a robot is lit, in [0, 1).
    speed_law : {"boltzmann", "half-normal"}
    object_radius : float
        The paper's object: 100 mm across.
    object_drag : float
        Ground friction of the object in robot drags (> 0), viscous (the engine's
        bodies have no Coulomb friction); ``inf`` holds the object in place (its contact
        force is still measured: a force gauge).  Default 2: at the measured transport
        speed (about 1.5 mm/s) the friction is 3 force units, 9 % of a robot's push at top
        speed (33 units); for a robot whose push is traction-limited near 0.25 N that is
        about 0.02 N, the Coulomb friction (mu = 0.3) of a light 100 mm object of about 8 g
        (foam or card) -- ``docs/scenarios_transport.md``.
    object_x, object_y : float or None
        Start of the object's centre; ``None``: arena centre (zigzag: the channel mouth).
    target_y : float or None
        The object has reached the target when its centre's y is at least this;
        ``None``: 3 object radii below the top wall.
    light : {"directional", "point"}
    light_distance : float
        Point light: distance of the lamp beyond the top wall (mm).
    light_spread_deg : float
        Angular radius of the lamp (deg, in [0, 45)); > 0 gives shadows a penumbra in
        which the light level ramps from 0 to 1 (``threshold`` then sets where the
        phase switches).  Default 0: hard shadows.
    obstacle_radius, obstacle_dx, obstacle_dy : float
        ``obstacle``: pillar radius and centre relative to the object's start (default
        100 mm at (-130, +200): it overlaps the object's straight path by 20 mm, 50 mm
        ahead of it).
    obstacle_shadow : bool
        Whether the pillar casts a shadow.
    channel_width : float
        ``zigzag``: horizontal width of the channel (mm).
    zigzag_amplitude, zigzag_leg : float
        ``zigzag``: sideways excursion and rise of each leg (mm).
    sensor : TransportSensor
        ``[sensor]``: ideal or photoresistor sensing.
    """

    variant: Literal["free", "obstacle", "zigzag"] = "free"
    n: int = 1200
    width: float | None = None
    height: float | None = None
    duration: float | None = None
    warmup: float = 0.0
    diameter: float = 33.0
    tau: float = 1.0
    mapping: Literal["lit_cold", "lit_hot"] = "lit_cold"
    heading_law: Literal["persistent", "uniform"] = "persistent"
    kT_hot: float = field(default_factory=lambda: round(kT_for_mean_speed(22.0), 3))
    kT_cold: float = field(default_factory=lambda: round(kT_for_mean_speed(18.0), 3))
    kT_theta: float = 0.1
    kT_theta_cold: float | None = 2.0
    v_max: float | None = 33.0
    threshold: float = 0.5
    speed_law: Literal["boltzmann", "half-normal"] = "boltzmann"
    object_radius: float = 50.0
    object_drag: float = 2.0
    object_x: float | None = None
    object_y: float | None = None
    target_y: float | None = None
    light: Literal["directional", "point"] = "directional"
    light_distance: float = 1000.0
    light_spread_deg: float = 0.0
    obstacle_radius: float = 100.0
    obstacle_dx: float = -130.0
    obstacle_dy: float = 200.0
    obstacle_shadow: bool = True
    channel_width: float = 400.0
    zigzag_amplitude: float = 150.0
    zigzag_leg: float = 300.0
    sensor: TransportSensor = TransportSensor()
    engine: Numerics = Numerics()
    record: Recording = Recording()

    def __post_init__(self) -> None:
        def positive(name: str, unit: str) -> None:
            v = getattr(self, name)
            check(math.isfinite(v) and v > 0, name, f"a positive number ({unit})", v)

        check(
            self.variant in DEFAULT_ARENA,
            "variant",
            "one of 'free', 'obstacle', 'zigzag'",
            self.variant,
        )
        check(self.n >= 1, "n", "a positive integer (number of robots)", self.n)
        for name in ("width", "height"):
            if getattr(self, name) is not None:
                positive(name, "mm")
        if self.duration is None:
            object.__setattr__(self, "duration", DEFAULT_DURATION.get(self.variant, 1200.0))
        positive("duration", "s")
        check(
            math.isfinite(self.warmup) and 0 <= self.warmup < self.duration,
            "warmup",
            f"in [0, duration = {self.duration:g}) s",
            self.warmup,
        )
        positive("diameter", "mm")
        positive("tau", "s")
        positive("kT_hot", "mm^2/s^2")
        positive("kT_cold", "mm^2/s^2")
        positive("kT_theta", "rad/s")
        if self.kT_theta_cold is not None:
            positive("kT_theta_cold", "rad/s")
        if self.v_max is not None:
            positive("v_max", "mm/s")
        check(
            math.isfinite(self.threshold) and 0 <= self.threshold < 1,
            "threshold",
            "in [0, 1)",
            self.threshold,
        )
        positive("object_radius", "mm")
        check(
            self.object_drag > 0,
            "object_drag",
            "a positive number of robot drags (inf holds the object: a force gauge)",
            self.object_drag,
        )
        positive("light_distance", "mm")
        check(
            math.isfinite(self.light_spread_deg) and 0 <= self.light_spread_deg < 45,
            "light_spread_deg",
            "in [0, 45) degrees (0: a point-like lamp, hard shadows)",
            self.light_spread_deg,
        )
        positive("obstacle_radius", "mm")
        positive("channel_width", "mm")
        check(
            math.isfinite(self.zigzag_amplitude) and self.zigzag_amplitude >= 0,
            "zigzag_amplitude",
            "a non-negative number (mm)",
            self.zigzag_amplitude,
        )
        positive("zigzag_leg", "mm")
        for name in ("obstacle_dx", "obstacle_dy"):
            v = getattr(self, name)
            check(math.isfinite(v), name, "a finite number (mm)", v)
        geometry(self)  # object inside the arena, clear of walls; target reachable

    @property
    def arena(self) -> tuple[float, float]:
        w, h = DEFAULT_ARENA[self.variant]
        return (self.width or w, self.height or h)


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


def _mouth_y(p: TransportFreeParams) -> float:
    _, h = p.arena
    return h / 2 - 2 * p.object_radius


def geometry(p: TransportFreeParams) -> Geometry:
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
        mouth = _mouth_y(p)
        oy = mouth + 2 * R if p.object_y is None else p.object_y
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
        walls = np.vstack(
            [
                walls,
                polygon_segments(left, closed=False),
                polygon_segments(right, closed=False),
                [[0.0, mouth, left[0, 0], mouth], [right[0, 0], mouth, W, mouth]],
            ]
        )
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


def _robot_region(p: TransportFreeParams, g: Geometry, obj: tuple[float, float] | None = None):
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


#: Regions of :func:`phase_by_region`, and the keys of its per-frame series.
REGIONS = ("lit", "shadow")


def phase_by_region(
    times: np.ndarray,
    positions: np.ndarray,
    phases: np.ndarray,
    lit: Any,
    grid_points: np.ndarray,
    grid_cell_area: float,
    grid_lit: Any,
) -> dict[str, Any]:
    """Phase separation over time: the robots of each phase in each light region.

    Parameters
    ----------
    times : (k,) s
    positions : (k, n, 2) mm
        Robot centres per frame.
    phases : (k, n)
        1 hot (gas-like), 0 cold (liquid-like).
    lit : callable ``(frame, points (m, 2)) -> bool (m,)``
        Whether points are lit (light level above the threshold, no sensor noise) in
        that frame (the object's shadow moves with it).
    grid_points : (g, 2) mm
        A regular grid over the region robots' centres can reach (at the start), of cell
        area ``grid_cell_area`` (mm^2): the areas of the regions are counted on it.
    grid_lit : callable ``(frame, grid_points) -> (lit bool (g,), reachable bool (g,))``
        The grid's light and whether each cell is still reachable in that frame (the
        object covers some).

    Returns
    -------
    dict of lists (one value per frame): ``time``; for ``region`` in ``lit``/``shadow``:
    ``n_<region>`` (robots), ``area_<region>`` (m^2), ``hot_fraction_<region>`` (the
    share of that region's robots that are hot; None when it holds none) and
    ``density_<phase>_<region>`` (robots of that phase per m^2 of the region).
    """
    k = len(times)
    out: dict[str, Any] = {"time": [float(t) for t in times]}
    for reg in REGIONS:
        for key in ("n", "area", "hot_fraction", "density_hot", "density_cold"):
            out[f"{key}_{reg}"] = []
    for f in range(k):
        pos = np.asarray(positions[f], dtype=np.float64)
        hot = np.asarray(phases[f]) == PHASE_HOT
        is_lit = np.asarray(lit(f, pos), dtype=bool)
        g_lit, g_ok = grid_lit(f, grid_points)
        for reg, sel, gsel in (
            ("lit", is_lit, g_lit & g_ok),
            ("shadow", ~is_lit, ~g_lit & g_ok),
        ):
            n_reg = int(np.count_nonzero(sel))
            n_hot = int(np.count_nonzero(sel & hot))
            area = float(np.count_nonzero(gsel)) * grid_cell_area / 1e6  # m^2
            out[f"n_{reg}"].append(n_reg)
            out[f"area_{reg}"].append(area)
            out[f"hot_fraction_{reg}"].append(n_hot / n_reg if n_reg else None)
            out[f"density_hot_{reg}"].append(n_hot / area if area > 0 else None)
            out[f"density_cold_{reg}"].append((n_reg - n_hot) / area if area > 0 else None)
    return out


def summarize_phase_by_region(series: dict[str, Any], since: float) -> dict[str, Any]:
    """Time means of :func:`phase_by_region`'s series over frames at ``time >= since``
    (None entries skipped; None when there are none)."""
    t = np.asarray(series["time"], dtype=np.float64)
    keep = t >= since
    out: dict[str, Any] = {"since": float(since), "frames": int(np.count_nonzero(keep))}
    for key, vals in series.items():
        if key == "time":
            continue
        v = [x for x, ok in zip(vals, keep, strict=True) if ok and x is not None]
        out[key] = float(np.mean(v)) if v else None
    return out


def capped_temperature(kT: float, v_max: float | None) -> float:
    """``<v^2> / 2`` (mm^2/s^2) of Rayleigh speeds at temperature ``kT`` cut at ``v_max``:
    ``kT (1 - exp(-v_max^2 / (2 kT)))`` (``kT`` without a cut), what ``speed_by_phase``
    should measure."""
    if v_max is None:
        return float(kT)
    return float(kT * -math.expm1(-(v_max**2) / (2 * kT)))


def transport_metrics(
    times: np.ndarray, progress: np.ndarray, target_distance: float
) -> dict[str, Any]:
    """Displacement metrics of one run from the object's progress toward the target.

    Parameters
    ----------
    times : (k,) s
    progress : (k,) mm
        Displacement of the object's centre along the target direction since the start
        (``progress[0]`` is normally 0).
    target_distance : float
        Progress (mm) at which the object is at the target.

    Returns
    -------
    dict with ``displacement_toward_target`` (the last progress, mm),
    ``max_displacement_toward_target`` (mm), ``time_to_target`` (s, the first sample at
    or beyond the target, None if never) and ``mean_velocity_toward_target`` (mm/s, last
    progress over elapsed time).
    """
    t = np.asarray(times, dtype=np.float64)
    d = np.asarray(progress, dtype=np.float64)
    hit = np.flatnonzero(d >= target_distance)
    elapsed = float(t[-1] - t[0])
    return {
        "displacement_toward_target": float(d[-1]),
        "max_displacement_toward_target": float(d.max()),
        "time_to_target": None if hit.size == 0 else float(t[hit[0]]),
        "mean_velocity_toward_target": float(d[-1] / elapsed) if elapsed > 0 else None,
    }


@register
class TransportFree(Scenario):
    name = "transport-free"
    description = (
        "Algorithm 5: a swarm pushes a 100 mm object toward the light without attachment "
        "(variants free, obstacle, zigzag)"
    )
    Params = TransportFreeParams

    def policy(self) -> LightSwitchedTransport:
        p: TransportFreeParams = self.params
        return LightSwitchedTransport(
            kT_hot=p.kT_hot,
            kT_cold=p.kT_cold,
            mapping=p.mapping,
            threshold=p.threshold,
            heading_law=p.heading_law,
            kT_theta=p.kT_theta,
            speed_law=p.speed_law,
            kT_theta_cold=p.kT_theta_cold,
            v_max=p.v_max,
        )

    def build(self, rng: np.random.Generator) -> Setup:
        p: TransportFreeParams = self.params
        g = geometry(p)
        r = p.diameter / 2
        W, H = p.arena
        held = p.warmup > 0
        body = Body(g.start[0], g.start[1], radius=p.object_radius,
                    drag=math.inf if held else p.object_drag)  # fmt: skip
        obstacles = g.obstacles
        world = World(g.bounds, g.walls, obstacles, bodies=(body,))
        light = make_light(
            p.light, x=W / 2, top=H, distance=p.light_distance, spread_deg=p.light_spread_deg
        )
        shadowing = obstacles if p.obstacle_shadow else np.zeros((0, 3))
        inner = self.policy()
        sensing = TransportSensing(
            light, Shapes(discs=shadowing), p.object_radius, p.sensor, phase_of=inner.phase
        )
        policy: Any = inner
        if p.sensor.charges_turns:
            policy = TurnTimeCharged(
                inner,
                turn_rate=math.radians(p.sensor.turn_rate_deg),
                dark_threshold=p.sensor.dark_threshold,
                turns_to_light=p.heading_law == "uniform",
            )
        pos = place_lattice(g.bounds, p.n, r, rng, inside=_robot_region(p, g))
        engine = p.engine.engine(tau=p.tau, radius=r)
        info = {
            "variant": p.variant,
            "bounds": list(g.bounds),
            "walls": g.walls.tolist(),
            "obstacles": g.obstacles.tolist(),
            "shadow_obstacles": shadowing.tolist(),
            "object_radius": p.object_radius,
            "object_start": list(g.start),
            "target_y": g.target_y,
            "light": light_info(light),
            "channel": None if g.channel is None else g.channel.tolist(),
            "channel_width": p.channel_width if g.channel is not None else None,
            "mapping": p.mapping,
        }
        return Setup(world=world, engine=engine, policy=policy, positions=pos,
                     sensing=sensing, info=info)  # fmt: skip

    # -- recording
    def extras(self, setup: Setup) -> dict[str, tuple[tuple[str, ...], tuple[int, ...], str]]:
        out = super().extras(setup)
        n = setup.positions.shape[0]
        out["phase"] = (("time", "individuals"), (n,), "i1")
        out["object_position"] = (("time", "space"), (2,), "f8")
        return out

    def frame(
        self, sim: Simulator, state: SwarmState, acc: dict[str, np.ndarray]
    ) -> dict[str, np.ndarray]:
        return {
            "heading": wrap(state.by_id(state.heading)),
            "speed": state.by_id(state.speed),
            "phase": state.by_id(state.group).astype(np.int8),
            "object_position": state.body_pos[0].copy(),
        }

    # -- online accumulation
    def init_acc(self, setup: Setup, sim: Simulator, state: SwarmState) -> dict[str, np.ndarray]:
        return {
            "start": state.body_pos[0].copy(),
            "released": np.array(0 if self.params.warmup > 0 else 1),
            "max_progress": np.array(0.0),
            "t_target": np.array(np.nan),
            "force_sum": np.zeros((FORCE_BATCHES, 2)),
            "force_count": np.zeros(FORCE_BATCHES),
            "held_sum": np.zeros((FORCE_BATCHES, 2)),
            "held_count": np.zeros(FORCE_BATCHES),
            "hot_sum": np.array(0.0),
            "hot_count": np.array(0.0),
        }

    def observe(self, sim: Simulator, state: SwarmState, acc: dict[str, np.ndarray]) -> None:
        p: TransportFreeParams = self.params
        t = state.time
        acc["hot_sum"][...] += np.count_nonzero(state.group == PHASE_HOT) / state.n
        acc["hot_count"][...] += 1
        if not acc["released"]:
            # held: average the contact force over the second half of the warm-up
            half = p.warmup / 2
            if t > half:
                b = min(int((t - half) / half * FORCE_BATCHES), FORCE_BATCHES - 1)
                acc["held_sum"][b] += state.body_force[0]
                acc["held_count"][b] += 1
            if t >= p.warmup - 1e-9:
                state.bodies[0, K.BDRAG] = p.object_drag
                acc["released"][...] = 1
            return
        y = state.body_pos[0, 1]
        prog = y - acc["start"][1]
        if prog > acc["max_progress"]:
            acc["max_progress"][...] = prog
        if np.isnan(acc["t_target"]) and y >= self._target_y:
            acc["t_target"][...] = t - p.warmup
        span = p.duration - p.warmup
        b = min(int((t - p.warmup) / span * FORCE_BATCHES - 1e-9), FORCE_BATCHES - 1)
        acc["force_sum"][max(b, 0)] += state.body_force[0]
        acc["force_count"][max(b, 0)] += 1

    def _phase_regions(self, setup: Setup, tracks: xr.Dataset) -> dict[str, Any]:
        """:func:`phase_by_region` of the recorded frames (light without sensor noise)."""
        p: TransportFreeParams = self.params
        g = geometry(p)
        sensing: TransportSensing = setup.sensing  # type: ignore[assignment]
        obj = np.asarray(tracks["object_position"].values, dtype=np.float64)
        pos = np.moveaxis(tracks["position"].values[:, :, 0, :], 1, 2)  # (k, n, 2)
        grid, cell = _grid(p, g)
        reach = p.object_radius + p.diameter / 2 + 0.5

        def lit(f: int, pts: np.ndarray) -> np.ndarray:
            occ = sensing.occluders_at(obj[f][None, :])
            return light_level(pts, sensing.light, occ) > p.threshold

        def grid_lit(f: int, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            ok = np.hypot(pts[:, 0] - obj[f, 0], pts[:, 1] - obj[f, 1]) >= reach
            return lit(f, pts), ok

        return phase_by_region(
            tracks["time"].values, pos, tracks["phase"].values, lit, grid, cell, grid_lit
        )

    @property
    def _target_y(self) -> float:
        tg = getattr(self, "_ty", None)
        if tg is None:
            tg = self._ty = geometry(self.params).target_y
        return tg

    # -- the end
    def metrics(
        self,
        setup: Setup,
        acc: dict[str, np.ndarray],
        tracks: xr.Dataset,
        sim: Simulator,
        state: SwarmState,
    ) -> dict[str, Any]:
        p: TransportFreeParams = self.params
        start = acc["start"]
        ty = setup.info["target_y"]
        obj = tracks["object_position"].values  # (frames, 2)
        t = tracks["time"].values
        progress = obj[:, 1] - start[1]
        # displacement and max from every step (acc), path from frames
        final = state.body_pos[0]
        fy = batch_mean_se(acc["force_sum"][:, 1], acc["force_count"])
        fx = batch_mean_se(acc["force_sum"][:, 0], acc["force_count"])
        phase = tracks["phase"].values.astype(np.int16)
        speed = tracks["speed"].values.astype(np.float64)
        by_phase: dict[str, Any] = {}
        for name, code in (("hot", 1), ("cold", 0)):
            sel = phase == code
            v = speed[sel]
            kT_set = p.kT_hot if code == 1 else p.kT_cold
            by_phase[name] = {
                "kT_set": kT_set,
                "kT_expected": capped_temperature(kT_set, p.v_max)
                if p.speed_law == "boltzmann"
                else None,
                "kT_measured": float(np.mean(v**2) / 2) if v.size else None,
                "mean_speed": float(v.mean()) if v.size else None,
                "samples": int(v.size),
            }
        t_target = float(acc["t_target"])
        held = batch_mean_se(acc["held_sum"][:, 1], acc["held_count"])
        regions = self._phase_regions(setup, tracks)
        out: dict[str, Any] = {
            "variant": p.variant,
            "n": p.n,
            "mapping": p.mapping,
            "heading_law": p.heading_law,
            "sensor_mode": p.sensor.mode,
            "duration": p.duration,
            "warmup": p.warmup,
            "object_start": start.tolist(),
            "object_final": final.tolist(),
            "target_y": ty,
            "target_distance": ty - float(start[1]),
            "displacement_toward_target": float(final[1] - start[1]),
            "max_displacement_toward_target": float(acc["max_progress"]),
            "time_to_target": None if math.isnan(t_target) else t_target,
            "mean_velocity_toward_target": float(final[1] - start[1])
            / max(float(state.time) - p.warmup, 1e-300),
            "lateral_displacement": float(final[0] - start[0]),
            "force_toward_target": {"mean": fy[0], "se": fy[1], "batches": fy[2]},
            "force_lateral": {"mean": fx[0], "se": fx[1], "batches": fx[2]},
            "force_held": (
                {"mean": held[0], "se": held[1], "batches": held[2]} if p.warmup > 0 else None
            ),
            "hot_fraction_mean": float(acc["hot_sum"]) / max(float(acc["hot_count"]), 1.0),
            "hot_fraction_final": float(np.mean(state.group == PHASE_HOT)),
            "speed_by_phase": by_phase,
            "phase_by_region": regions,
            "phase_by_region_mean": summarize_phase_by_region(regions, since=p.duration / 2),
            "object_path": {
                "time": t.tolist(),
                "x": obj[:, 0].tolist(),
                "y": obj[:, 1].tolist(),
                "progress": progress.tolist(),
            },
        }
        return out


def _grid(p: TransportFreeParams, g: Geometry) -> tuple[np.ndarray, float]:
    """Cell centres of a regular grid over the arena where robots' centres can be (the
    object at its start), and the cell area (mm^2); about 40,000 cells at most."""
    x0, y0, x1, y1 = g.bounds
    step = max(10.0, math.sqrt((x1 - x0) * (y1 - y0) / 40000.0))
    xs = np.arange(x0 + step / 2, x1, step)
    ys = np.arange(y0 + step / 2, y1, step)
    pts = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    far = _robot_region(p, g, obj=(math.inf, math.inf))  # the object excluded per frame
    return np.ascontiguousarray(pts[far(pts)]), step * step


def plot_frame(ax: Any, tracks: xr.Dataset, t: float, setup_info: dict[str, Any]) -> Any:
    """Draw the frame of ``tracks`` nearest to time ``t`` (s) on matplotlib axes ``ax``.

    Walls, obstacles, the target line (dashed green), the object's shadow (grey), the
    object (white disc) and the robots coloured by phase (red hot/gas-like, blue
    cold/liquid-like).  ``setup_info`` is ``Setup.info`` of the run (``runner.build``).
    Returns the robots' scatter artist.
    """
    from matplotlib.patches import Circle, Polygon

    k = nearest_frame(tracks, t)
    info = setup_info
    draw_world(ax, info)
    obj = np.asarray(tracks["object_position"].values[k], dtype=np.float64)
    R = float(info["object_radius"])
    shade = shadow_polygon(obj, R, info["light"], info["bounds"])
    if shade.size:
        ax.add_patch(Polygon(shade, closed=True, facecolor="0.85", edgecolor="none", zorder=0))
    for x, y, ro in np.asarray(info.get("shadow_obstacles", []), dtype=float).reshape(-1, 3):
        s = shadow_polygon((x, y), ro, info["light"], info["bounds"])
        ax.add_patch(Polygon(s, closed=True, facecolor="0.85", edgecolor="none", zorder=0))
    ax.add_patch(Circle(tuple(obj), R, facecolor="white", edgecolor="k", lw=1.2, zorder=5))
    pos = tracks["position"].values[k, :, 0, :]  # (space, individuals)
    phase = tracks["phase"].values[k]
    colors = np.where(phase == PHASE_HOT, "tab:red", "tab:blue")
    r = float(tracks.attrs.get("radius", 16.5))
    # marker size in points^2 so that discs have their true size in data units
    fig = ax.figure
    x0, y0, x1, y1 = info["bounds"]
    bbox = ax.get_window_extent().transformed(fig.dpi_scale_trans.inverted())
    pts_per_mm = bbox.width * 72.0 / max(x1 - x0 + 40.0, 1e-9)
    sc = ax.scatter(pos[0], pos[1], s=(2 * r * pts_per_mm) ** 2, c=colors, lw=0, zorder=3)
    ax.set_title(f"t = {float(tracks['time'].values[k]):.0f} s")
    return sc
