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

This module holds the parameters and the registered scenario; the layout (walls,
channel, pillar, start, target) is in :mod:`._transport_free_geometry`, the measures
(phases by light region, displacement metrics) and :func:`plot_frame` in
:mod:`._transport_free_results`; every public name is importable from here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import xarray as xr

from thermoswarm.config import check
from thermoswarm.maxent import kT_for_mean_speed
from thermoswarm.policy import PHASE_HOT, LightSwitchedTransport, TurnTimeCharged
from thermoswarm.scenarios._transport import (
    TransportSensing,
    TransportSensor,
    batch_mean_se,
    light_info,
    make_light,
)
from thermoswarm.scenarios._transport_free_geometry import (
    Geometry,
    arena_grid,
    geometry,
    robot_region,
    zigzag_centreline,
)
from thermoswarm.scenarios._transport_free_results import (
    REGIONS,
    capped_temperature,
    phase_by_region,
    plot_frame,
    summarize_phase_by_region,
    transport_metrics,
)
from thermoswarm.scenarios.base import Numerics, Recording, Scenario, Setup, wrap
from thermoswarm.scenarios.registry import register
from thermoswarm.sim import kernels as K
from thermoswarm.sim.engine import Simulator, SwarmState, place_lattice
from thermoswarm.sim.geometry import Shapes
from thermoswarm.sim.light import light_level
from thermoswarm.sim.world import Body, World

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
    "REGIONS",
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
        pos = place_lattice(g.bounds, p.n, r, rng, inside=robot_region(p, g))
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
        grid, cell = arena_grid(p, g)
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
