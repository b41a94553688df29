"""``transport-connected``: robots attached to the object carry it to a target room
(Algorithm 4).

The paper (PAPER_NOTES sections 4-5): robots physically connected to the 100 mm object
run Algorithm 4 -- TurnToAngle(0), Boltzmann speed at a constant temperature, heading
``theta ~ U(-90, 90)`` deg relative to the light -- and move it to "the bottom smaller
space".  Here the light and the target are both on the +y side (the paper's "bottom";
Algorithm 4 can only move toward the light): a main room, a wall with a door, and a
smaller target room behind it.

Model (a simplification, stated): the object and its ``n_attached`` robots form one
rigid, overdamped, non-rotating composite -- a disc of radius ``object_radius +
diameter`` (the robots sit around the rim, touching it, evenly spaced).  Each robot
pivots freely at its attachment (so it can turn to any heading) and drives with the
force ``drag_r v_i`` (robot drag ``drag_r`` = 1) along its heading; the composite moves at

    V = sum_i v_i u_i / (k + g_o)

(``k`` robots, object ground drag ``g_o`` = ``object_drag``), and slides along walls
(the engine's body-wall projection).  Robots are recorded at their fixed offsets around
the object.  Not modelled: rotation of the composite, robots pulling each other's
attachments, wheel slip.

Sensing: the object's disc casts a shadow (``object_shadow``, default on): robots on the
far side of the object from the light see no light, so TurnToAngle leaves their
heading unchanged and their sampled heading is relative to wherever they point -- they
random-walk and add no mean drive.  With a directional light from +y, 3 of 8 robots
are shadowed, and the mean velocity in open space is ``k_lit <v> (2 / pi) / (k +
g_o)`` (``metrics["velocity_theory_open_space"]``).

Units: mm, s; forces in robot drags (mm/s); temperatures mm^2/s^2; angles rad.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import xarray as xr

from thermoswarm.config import check
from thermoswarm.errors import ConfigError
from thermoswarm.maxent import kT_for_mean_speed, speed_law
from thermoswarm.policy import ConnectedTransport, TurnTimeCharged
from thermoswarm.scenarios._transport import (
    TransportSensing,
    TransportSensor,
    batch_mean_se,
    draw_world,
    light_info,
    make_light,
    nearest_frame,
)
from thermoswarm.scenarios.base import Numerics, Recording, Scenario, Setup
from thermoswarm.scenarios.registry import register
from thermoswarm.sim import kernels as K
from thermoswarm.sim.engine import Simulator, SwarmState
from thermoswarm.sim.geometry import Shapes
from thermoswarm.sim.light import light_level
from thermoswarm.sim.world import Body, World, polygon_segments

__all__ = [
    "TransportConnectedParams",
    "TransportConnected",
    "ConnectedSimulator",
    "attachment_offsets",
    "max_attached",
    "plot_frame",
]

FORCE_BATCHES = 20


def max_attached(object_radius: float, robot_radius: float) -> int:
    """Most robots of radius ``robot_radius`` that fit around a disc without overlap."""
    return int(math.floor(math.pi / math.asin(robot_radius / (object_radius + robot_radius))))


def attachment_offsets(k: int, object_radius: float, robot_radius: float) -> np.ndarray:
    """Offsets (k, 2) mm of ``k`` robots evenly spaced around the object, touching it.

    Robot ``j`` sits at world angle ``pi / 2 + pi / k + 2 pi j / k``: the pattern is
    symmetric about the axis through the object's centre along +y (the light).
    """
    ang = 2 * np.pi * np.arange(k) / k + np.pi / k + np.pi / 2
    d = object_radius + robot_radius
    return np.column_stack([d * np.cos(ang), d * np.sin(ang)])


@dataclass(frozen=True)
class TransportConnectedParams:
    """Parameters of ``transport-connected`` (lengths mm, times s).

    Attributes
    ----------
    n_attached : int
        Robots attached around the object (at most 12 for 33 mm robots on a 100 mm
        object).
    duration : float
        Simulated seconds.
    diameter : float
        Robot diameter (mm).
    tau : float
        Control period (s).
    kT : float
        Temperature (mm^2/s^2); default: mean speed 10 mm/s.
    half_width_deg : float
        Half width of the heading law (deg): Algorithm 4's 90.
    speed_law : {"boltzmann", "half-normal"}
    object_radius : float
        The paper's object: 100 mm across.
    object_drag : float
        Ground friction of the object in robot drags (> 0); the composite's drag is
        ``n_attached + object_drag``.
    object_shadow : bool
        Whether the object shadows the robots attached behind it.
    width, height : float
        The main room (mm).
    target_width, target_height : float
        The smaller target room beyond the top wall (mm), centred on the door.
    door_width : float
        Width of the door between the rooms (mm); must pass the composite.
    door_x : float or None
        Door centre (mm); ``None``: the middle of the top wall.
    object_x, object_y : float or None
        Start of the object's centre; ``None``: ``(width / 2, 2.5 composite radii)``.
    light : {"directional", "point"}
    light_distance : float
        Point light: distance of the lamp beyond the target room's far wall (mm).
    sensor : TransportSensor
        ``[sensor]``: ideal or photoresistor sensing.
    """

    n_attached: int = 8
    duration: float = 600.0
    diameter: float = 33.0
    tau: float = 1.0
    kT: float = field(default_factory=lambda: round(kT_for_mean_speed(10.0), 6))
    half_width_deg: float = 90.0
    speed_law: Literal["boltzmann", "half-normal"] = "boltzmann"
    object_radius: float = 50.0
    object_drag: float = 8.0
    object_shadow: bool = True
    width: float = 1500.0
    height: float = 1200.0
    target_width: float = 700.0
    target_height: float = 500.0
    door_width: float = 300.0
    door_x: float | None = None
    object_x: float | None = None
    object_y: float | None = None
    light: Literal["directional", "point"] = "directional"
    light_distance: float = 1000.0
    sensor: TransportSensor = TransportSensor()
    engine: Numerics = Numerics()
    record: Recording = Recording()

    def __post_init__(self) -> None:
        def positive(name: str, unit: str) -> None:
            v = getattr(self, name)
            check(math.isfinite(v) and v > 0, name, f"a positive number ({unit})", v)

        for name, unit in (
            ("duration", "s"),
            ("diameter", "mm"),
            ("tau", "s"),
            ("kT", "mm^2/s^2"),
            ("object_radius", "mm"),
            ("object_drag", "robot drags"),
            ("width", "mm"),
            ("height", "mm"),
            ("target_width", "mm"),
            ("target_height", "mm"),
            ("door_width", "mm"),
            ("light_distance", "mm"),
        ):
            positive(name, unit)
        kmax = max_attached(self.object_radius, self.diameter / 2)
        check(
            1 <= self.n_attached <= kmax,
            "n_attached",
            f"an integer in [1, {kmax}] (robots of {self.diameter:g} mm around an object "
            f"of radius {self.object_radius:g} mm)",
            self.n_attached,
        )
        check(
            math.isfinite(self.half_width_deg) and 0 < self.half_width_deg <= 180,
            "half_width_deg",
            "in (0, 180] degrees",
            self.half_width_deg,
        )
        Rc = self.composite_radius
        check(
            self.door_width > 2 * Rc,
            "door_width",
            f"wider than the object with its robots ({2 * Rc:g} mm)",
            self.door_width,
        )
        dx = self.door_center
        check(
            self.door_width / 2 < dx < self.width - self.door_width / 2,
            "door_x",
            f"such that the door lies within the top wall (0..{self.width:g} mm)",
            dx,
        )
        check(
            self.door_width <= self.target_width <= self.width,
            "target_width",
            f"between door_width = {self.door_width:g} and width = {self.width:g} mm",
            self.target_width,
        )
        check(
            self.target_height > 2 * Rc,
            "target_height",
            f"deeper than the object with its robots ({2 * Rc:g} mm)",
            self.target_height,
        )
        x, y = self.start
        if not (Rc <= x <= self.width - Rc and Rc <= y <= self.height - Rc):
            raise ConfigError(
                f"object_x/object_y: the object with its robots (radius {Rc:g} mm) at "
                f"({x:g}, {y:g}) mm must lie inside the {self.width:g} x {self.height:g} mm "
                "main room"
            )
        self.sensor.sensing_params()

    @property
    def composite_radius(self) -> float:
        return self.object_radius + self.diameter

    @property
    def door_center(self) -> float:
        return self.width / 2 if self.door_x is None else self.door_x

    @property
    def start(self) -> tuple[float, float]:
        Rc = self.composite_radius
        x = self.width / 2 if self.object_x is None else self.object_x
        y = 2.5 * Rc if self.object_y is None else self.object_y
        return (float(x), float(y))

    @property
    def target_y(self) -> float:
        """The object's centre y at which the composite is wholly in the target room."""
        return self.height + self.composite_radius


def _target_room(p: TransportConnectedParams) -> tuple[float, float, float, float]:
    """(x0, y0, x1, y1) of the target room: centred on the door, kept within the
    main room's width."""
    x0 = min(max(p.door_center - p.target_width / 2, 0.0), p.width - p.target_width)
    return (x0, p.height, x0 + p.target_width, p.height + p.target_height)


def _walls(p: TransportConnectedParams) -> np.ndarray:
    W, H = p.width, p.height
    dx, dw = p.door_center, p.door_width
    tx0, _, tx1, top = _target_room(p)
    segs = [
        [0, 0, W, 0],
        [0, 0, 0, H],
        [W, 0, W, H],
        [0, H, dx - dw / 2, H],
        [dx + dw / 2, H, W, H],
    ]
    segs += polygon_segments([(tx0, H), (tx0, top), (tx1, top), (tx1, H)], closed=False).tolist()
    seg = np.array(segs, dtype=np.float64)
    return seg[np.hypot(seg[:, 2] - seg[:, 0], seg[:, 3] - seg[:, 1]) > 0]


class ConnectedSimulator(Simulator):
    """The rigid composite of the object and its attached robots (see the module doc).

    The engine's robots are the attached robots; their positions are set each step to
    the object's centre plus fixed offsets, so they never overlap anything (the
    composite disc, which covers them, is kept out of walls).  Decisions (sensing and
    policy) go through the engine's own machinery; the object is the world's body 0,
    whose drag is ``k + g_o`` and whose external force is the sum of the robots'
    drive forces.  ``state.body_force[0]`` reports that drive force (robot drag units).
    """

    def __init__(self, world, params, policy, sensing, offsets: np.ndarray) -> None:
        super().__init__(world, params, policy, sensing)
        self.offsets = np.ascontiguousarray(offsets, dtype=np.float64)

    def step(self, state: SwarmState) -> SwarmState:
        p = self.params
        due = np.flatnonzero(state.timer <= 0)
        if due.size:
            self._decide(state, due)
            state.timer[due] = p.tau_steps
        drive = p.drag * np.array(
            [
                np.sum(state.speed * np.cos(state.heading)),
                np.sum(state.speed * np.sin(state.heading)),
            ]
        )
        b = state.bodies
        b[0, K.BFX], b[0, K.BFY] = drive
        b[0, K.BX] += drive[0] * p.dt / b[0, K.BDRAG]
        b[0, K.BY] += drive[1] * p.dt / b[0, K.BDRAG]
        # walls do not yield: the engine's own body-wall projection (sliding contact)
        K._bodies_vs_static(b, self.world.segments, self.world.static_discs)
        b[0, K.BCX], b[0, K.BCY] = drive
        # robots stay in id order (never re-sorted here)
        state.pos[state.ids] = b[0, K.BX : K.BY + 1] + self.offsets
        state.icols[2] -= 1  # timers
        state.step += 1
        state.time = state.step * p.dt
        return state

    def max_overlap(self, state: SwarmState) -> float:
        """Largest overlap (mm) of an attached robot with another robot or a wall.

        The object (body 0) is the composite disc that covers its attached robots, so
        robots against it are not contacts and are left out; everything else is the
        engine's independent check (:meth:`Simulator.max_overlap`).
        """
        bodies = state.bodies
        state.bodies = bodies[:0]
        try:
            return super().max_overlap(state)
        finally:
            state.bodies = bodies


@dataclass
class _ConnectedSetup(Setup):
    offsets: np.ndarray | None = None

    def simulator(self) -> Simulator:
        return ConnectedSimulator(self.world, self.engine, self.policy, self.sensing, self.offsets)


@register
class TransportConnected(Scenario):
    name = "transport-connected"
    description = (
        "Algorithm 4: robots attached around a 100 mm object carry it through a door into "
        "a target room on the light side"
    )
    Params = TransportConnectedParams

    def build(self, rng: np.random.Generator) -> Setup:
        p: TransportConnectedParams = self.params
        r = p.diameter / 2
        k = p.n_attached
        x, y = p.start
        Rc = p.composite_radius
        walls = _walls(p)
        body = Body(x, y, radius=Rc, drag=k + p.object_drag)
        world = World((0.0, 0.0, p.width, p.height + p.target_height), walls, bodies=(body,))
        light = make_light(
            p.light, x=p.door_center, top=p.height + p.target_height, distance=p.light_distance
        )
        offsets = attachment_offsets(k, p.object_radius, r)
        inner = ConnectedTransport(
            kT=p.kT, half_width=math.radians(p.half_width_deg), speed_law=p.speed_law
        )
        policy: Any = inner
        if p.sensor.charges_turns:
            policy = TurnTimeCharged(
                inner,
                turn_rate=math.radians(p.sensor.turn_rate_deg),
                dark_threshold=p.sensor.dark_threshold,
                turns_to_light=True,
            )
        sensing = TransportSensing(
            light, Shapes(), p.object_radius, p.sensor, casts_shadow=p.object_shadow
        )
        engine = p.engine.engine(tau=p.tau, radius=r)
        info = {
            "bounds": [0.0, 0.0, p.width, p.height + p.target_height],
            "walls": walls.tolist(),
            "obstacles": [],
            "object_radius": p.object_radius,
            "composite_radius": Rc,
            "object_start": [x, y],
            "target_y": p.target_y,
            "target_room": list(_target_room(p)),
            "light": light_info(light),
            "offsets": offsets.tolist(),
        }
        return _ConnectedSetup(
            world=world,
            engine=engine,
            policy=policy,
            positions=np.array([x, y]) + offsets,
            sensing=sensing,
            headings=np.full(k, math.pi / 2),
            info=info,
            offsets=offsets,
        )

    def extras(self, setup: Setup) -> dict[str, tuple[tuple[str, ...], tuple[int, ...], str]]:
        out = super().extras(setup)
        out["object_position"] = (("time", "space"), (2,), "f8")
        return out

    def frame(
        self, sim: Simulator, state: SwarmState, acc: dict[str, np.ndarray]
    ) -> dict[str, np.ndarray]:
        out = super().frame(sim, state, acc)
        out["object_position"] = state.body_pos[0].copy()
        return out

    def init_acc(self, setup: Setup, sim: Simulator, state: SwarmState) -> dict[str, np.ndarray]:
        total = int(math.floor(self.duration / sim.params.dt + 1e-9))
        return {
            "start": state.body_pos[0].copy(),
            "max_progress": np.array(0.0),
            "t_target": np.array(np.nan),
            "force_sum": np.zeros((FORCE_BATCHES, 2)),
            "force_count": np.zeros(FORCE_BATCHES),
            "steps_per_batch": np.array(max(1, math.ceil(total / FORCE_BATCHES))),
        }

    def observe(self, sim: Simulator, state: SwarmState, acc: dict[str, np.ndarray]) -> None:
        y = state.body_pos[0, 1]
        prog = y - acc["start"][1]
        if prog > acc["max_progress"]:
            acc["max_progress"][...] = prog
        if np.isnan(acc["t_target"]) and y >= self.params.target_y:
            acc["t_target"][...] = state.time
        b = min((state.step - 1) // int(acc["steps_per_batch"]), FORCE_BATCHES - 1)
        acc["force_sum"][b] += state.body_force[0]
        acc["force_count"][b] += 1

    def metrics(
        self,
        setup: Setup,
        acc: dict[str, np.ndarray],
        tracks: xr.Dataset,
        sim: Simulator,
        state: SwarmState,
    ) -> dict[str, Any]:
        p: TransportConnectedParams = self.params
        start = acc["start"]
        final = state.body_pos[0]
        obj = tracks["object_position"].values
        t = tracks["time"].values
        fy = batch_mean_se(acc["force_sum"][:, 1], acc["force_count"])
        fx = batch_mean_se(acc["force_sum"][:, 0], acc["force_count"])
        k = p.n_attached
        # robots that see the light at the start (the pattern moves with the object)
        sensing: TransportSensing = setup.sensing  # type: ignore[assignment]
        at_start = np.asarray(setup.info["offsets"]) + start
        lit = light_level(at_start, sensing.light, sensing.occluders_at(start[None, :]))
        lit = lit > p.sensor.dark_threshold
        w = math.radians(p.half_width_deg)
        drive = speed_law(p.speed_law, p.kT).mean() * math.sin(w) / w
        theory = int(lit.sum()) * drive / (k + p.object_drag)
        t_target = float(acc["t_target"])
        return {
            "n_attached": k,
            "sensor_mode": p.sensor.mode,
            "duration": p.duration,
            "object_start": start.tolist(),
            "object_final": final.tolist(),
            "target_y": p.target_y,
            "target_distance": p.target_y - float(start[1]),
            "displacement_toward_target": float(final[1] - start[1]),
            "max_displacement_toward_target": float(acc["max_progress"]),
            "time_to_target": None if math.isnan(t_target) else t_target,
            "reached_target": not math.isnan(t_target),
            "mean_velocity_toward_target": float(final[1] - start[1]) / float(state.time),
            "lateral_displacement": float(final[0] - start[0]),
            "attached_lit_at_start": int(lit.sum()),
            "velocity_theory_open_space": theory,
            "drive_force_toward_target": {"mean": fy[0], "se": fy[1], "batches": fy[2]},
            "drive_force_lateral": {"mean": fx[0], "se": fx[1], "batches": fx[2]},
            "composite_drag": k + p.object_drag,
            "object_path": {"time": t.tolist(), "x": obj[:, 0].tolist(), "y": obj[:, 1].tolist()},
        }


def plot_frame(ax: Any, tracks: xr.Dataset, t: float, setup_info: dict[str, Any]) -> Any:
    """Draw the frame of ``tracks`` nearest to time ``t`` (s) on matplotlib axes ``ax``:
    walls, the target room (green), the object (white) with its attached robots
    (orange) and each robot's drive direction (arrow, length proportional to speed).
    ``setup_info`` is ``Setup.info`` of the run.  Returns the arrows' artist."""
    from matplotlib.patches import Circle, Rectangle

    k = nearest_frame(tracks, t)
    info = setup_info
    draw_world(ax, info)
    x0, y0, x1, y1 = info["target_room"]
    ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, color="tab:green", alpha=0.12, zorder=0))
    obj = np.asarray(tracks["object_position"].values[k], dtype=np.float64)
    ax.add_patch(Circle(tuple(obj), info["object_radius"], facecolor="white", edgecolor="k"))
    pos = tracks["position"].values[k, :, 0, :]
    r = float(tracks.attrs.get("radius", 16.5))
    for x, y in pos.T:
        ax.add_patch(Circle((x, y), r, facecolor="tab:orange", edgecolor="k", lw=0.5))
    h = tracks["heading"].values[k].astype(np.float64)
    v = tracks["speed"].values[k].astype(np.float64)
    q = ax.quiver(pos[0], pos[1], v * np.cos(h), v * np.sin(h), angles="xy", scale_units="xy",
                  scale=0.5, width=0.004, zorder=6)  # fmt: skip
    ax.plot(tracks["object_position"].values[: k + 1, 0],
            tracks["object_position"].values[: k + 1, 1], color="0.4", lw=0.8)  # fmt: skip
    ax.set_title(f"t = {float(tracks['time'].values[k]):.0f} s")
    return q
