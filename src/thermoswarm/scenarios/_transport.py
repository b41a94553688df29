"""What the two transport scenarios share: light, sensing, metric helpers, drawing.

Private to ``transport-connected`` and ``transport-free``; the metric helpers are pure
functions of arrays so that the tests can check them on constructed cases.

Conventions: the target lies in the +y direction and the light comes from the target
side, so "toward the target" and "toward the light" are both +y; heading 0 of the
paper is then +y (world angle pi/2).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from thermoswarm.config import check, check_positive
from thermoswarm.sim.engine import SwarmState
from thermoswarm.sim.geometry import Shapes
from thermoswarm.sim.light import DirectionalLight, PointLight, SensingParams, sense

__all__ = [
    "TransportSensor",
    "make_light",
    "light_info",
    "TransportSensing",
    "first_crossing_time",
    "batch_mean_se",
    "segment_distance",
    "shadow_polygon",
    "draw_world",
    "nearest_frame",
]


@dataclass(frozen=True)
class TransportSensor:
    """The ``[sensor]`` section of the transport scenarios: how robots sense the light.

    Attributes
    ----------
    mode : {"ideal", "photoresistor"}
        ``"ideal"``: the exact light level at the robot and the exact light direction.
        ``"photoresistor"``: TurnToAngle (Algorithm 1) on three simulated photoresistors
        (:mod:`thermoswarm.sim.light`) and the light level read through the sensor noise
        model.  Turns take no time in either mode unless ``charge_turn_time``.
    noise_mult, noise_add : float
        Relative and absolute standard deviation of a reading (photoresistor mode).
    step_deg : float
        TurnToAngle step (deg).
    turn_rate_deg : float
        Turning speed (deg/s) used to charge turning time (the light module's 130 deg/s:
        wheels at 33 mm/s in opposite directions on an assumed 29 mm track).
    sensor_angle_deg, fov_deg, dark_threshold : float
        As in :class:`thermoswarm.sim.light.SensingParams`.
    charge_turn_time : bool
        Photoresistor mode: a robot's control period includes its turning (see
        :class:`thermoswarm.policy.TurnTimeCharged`).  Off by default: with a fixed
        period, headings near the light cost less turning after TurnToAngle and so carry
        the robot farther, which biases every robot toward the light (a drift of the
        whole swarm measured in ``docs/scenarios_transport.md``); a robot whose move
        lasts a fixed time after turning has no such bias.
    """

    mode: Literal["ideal", "photoresistor"] = "ideal"
    noise_mult: float = 0.02
    noise_add: float = 0.02
    step_deg: float = 2.0
    turn_rate_deg: float = 130.0
    sensor_angle_deg: float = 30.0
    fov_deg: float = 160.0
    dark_threshold: float = 0.05
    charge_turn_time: bool = False

    def __post_init__(self) -> None:
        check(
            self.mode in ("ideal", "photoresistor"),
            "sensor.mode",
            "'ideal' or 'photoresistor'",
            self.mode,
        )
        for name in ("noise_mult", "noise_add"):
            v = getattr(self, name)
            check(math.isfinite(v) and v >= 0, f"sensor.{name}", ">= 0", v)
        check_positive("sensor.turn_rate_deg", self.turn_rate_deg, "a positive number (deg/s)")
        self.sensing_params()  # the light module checks the rest (names the field)

    def sensing_params(self) -> SensingParams:
        return SensingParams(
            mode=self.mode,
            sensor_angle_deg=self.sensor_angle_deg,
            fov_deg=self.fov_deg,
            noise_mult=self.noise_mult,
            noise_add=self.noise_add,
            step_deg=self.step_deg,
            dark_threshold=self.dark_threshold,
            turn_rate_deg=self.turn_rate_deg,
        )

    @property
    def charges_turns(self) -> bool:
        return self.mode == "photoresistor" and self.charge_turn_time


def make_light(
    kind: str, *, x: float, top: float, distance: float, spread_deg: float = 0.0
) -> DirectionalLight | PointLight:
    """The light on the target side (+y).

    ``"directional"``: parallel rays travelling toward -y (a distant lamp).
    ``"point"``: a lamp at ``(x, top + distance)`` with no distance falloff (only its
    direction and the shadows it casts matter to the robots: the temperature switches on
    a threshold, and an inverse-square falloff would make every far robot "dark").
    ``spread_deg`` > 0: the lamp is extended, with this angular radius (deg) seen from
    the top wall's middle (a point lamp gets the radius ``distance * tan(spread)``), so
    shadows have a penumbra whose light level ramps from 0 to 1.
    """
    if kind == "directional":
        return DirectionalLight(direction=(0.0, -1.0), angular_radius_deg=float(spread_deg))
    radius = float(distance) * math.tan(math.radians(spread_deg))
    return PointLight(position=(float(x), float(top + distance)), falloff="none", radius=radius)


def light_info(light: DirectionalLight | PointLight) -> dict[str, Any]:
    """JSON-able description of a light (for ``Setup.info`` and :func:`shadow_polygon`)."""
    if isinstance(light, DirectionalLight):
        return {"kind": "directional", "direction": list(light.direction)}
    return {"kind": "point", "position": list(light.position)}


class TransportSensing:
    """The engine's sensing model for transport: light level and heading 0.

    Occluders are the transported object's disc (at ``state.body_pos``, moving; left out
    when ``casts_shadow`` is false) plus the static ``occluders``.  ``sensor.mode ==
    "ideal"`` gives the exact light direction and level; ``"photoresistor"`` runs
    TurnToAngle on the simulated sensors and reads the
    light level through the sensors' noise model, ``l (1 + noise_mult z1) + noise_add
    z2`` clipped at 0, drawn from the run's generator.

    When ``phase_of`` is given, the robots' ``group`` column receives ``phase_of(light)``
    at each decision: the phase each robot holds during its period (so the engine state
    carries it through re-sorting and checkpoints, and frames record it).
    """

    def __init__(
        self,
        light: DirectionalLight | PointLight,
        occluders: Shapes,
        object_radius: float,
        sensor: TransportSensor,
        phase_of: Callable[[np.ndarray], np.ndarray] | None = None,
        *,
        casts_shadow: bool = True,
    ) -> None:
        self.light = light
        disc = np.array([[0.0, 0.0, float(object_radius)]]).reshape(-1, 3)
        if not casts_shadow:
            disc = disc[:0]
        self.n_object = disc.shape[0]
        self.occ = Shapes(discs=disc) + occluders
        self.sensor = sensor
        self.params = sensor.sensing_params()
        self.phase_of = phase_of
        self.noisy = sensor.mode == "photoresistor" and (
            sensor.noise_mult > 0 or sensor.noise_add > 0
        )

    def occluders_at(self, body_pos: np.ndarray) -> Shapes:
        """The occluders with the object's disc at ``body_pos[0]``."""
        if self.n_object == 0:
            return self.occ
        centers = self.occ.discs[:, :2].copy()
        centers[0] = body_pos[0]
        return self.occ.with_disc_centers(centers)

    def __call__(self, state: SwarmState, index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        pos = state.pos[index]
        occ = self.occluders_at(state.body_pos)
        res = sense(pos, state.heading[index], self.light, occ, self.params, state.rng)
        light = res.light
        if self.noisy:
            z = state.rng.standard_normal((2, index.size))
            light = light * (1.0 + self.sensor.noise_mult * z[0]) + self.sensor.noise_add * z[1]
            np.maximum(light, 0.0, out=light)
        if self.phase_of is not None:
            state.group[index] = self.phase_of(light)
        return res.zero_heading, light


# ------------------------------------------------------------------ metric helpers
def first_crossing_time(times: np.ndarray, progress: np.ndarray, target: float) -> float | None:
    """First time (s) at which ``progress`` reaches ``target`` (None if never).

    Samples are taken as they are (no interpolation): with progress sampled every step
    the answer is exact to one step.
    """
    t = np.asarray(times, dtype=np.float64)
    p = np.asarray(progress, dtype=np.float64)
    hit = np.flatnonzero(p >= target)
    return None if hit.size == 0 else float(t[hit[0]])


def batch_mean_se(sums: np.ndarray, counts: np.ndarray) -> tuple[float, float, int]:
    """Mean and standard error by batch means.

    ``sums[k]`` and ``counts[k]`` are the sum and number of samples in batch ``k`` (a
    contiguous stretch of time).  The mean is the overall mean; the standard error is
    that of the batch means (weighted by counts), valid when batches are longer than
    the correlation time.  Returns ``(mean, se, batches used)``; the se is NaN with
    fewer than two non-empty batches.
    """
    s = np.asarray(sums, dtype=np.float64)
    c = np.asarray(counts, dtype=np.float64)
    keep = c > 0
    s, c = s[keep], c[keep]
    if c.sum() == 0:
        return math.nan, math.nan, 0
    mean = float(s.sum() / c.sum())
    k = c.size
    if k < 2:
        return mean, math.nan, k
    m = s / c
    w = c / c.sum()
    # variance of a weighted mean of k batch means with weights w
    var_b = float(np.sum(w * (m - mean) ** 2) * k / (k - 1))
    se = math.sqrt(var_b * float(np.sum(w**2)))
    return mean, se, k


def segment_distance(points: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """Distance (mm) from each point ``(n, 2)`` to the nearest of ``segments (m, 4)``
    (``inf`` when there are none)."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    s = np.asarray(segments, dtype=np.float64).reshape(-1, 4)
    if s.shape[0] == 0:
        return np.full(p.shape[0], np.inf)
    a = s[None, :, :2]
    d = s[None, :, 2:] - a
    L2 = np.maximum((d**2).sum(-1), 1e-300)
    t = np.clip(((p[:, None, :] - a) * d).sum(-1) / L2, 0.0, 1.0)
    q = a + t[..., None] * d
    return np.sqrt(((p[:, None, :] - q) ** 2).sum(-1)).min(axis=1)


# ------------------------------------------------------------------ drawing
def shadow_polygon(
    center: Sequence[float],
    radius: float,
    light: dict[str, Any],
    bounds: Sequence[float],
) -> np.ndarray:
    """Vertices (4, 2) of a disc's shadow, reaching well past ``bounds`` (clip by axes).

    ``light`` is a :func:`light_info` dict.  The shadow of a disc is the region between
    its two tangent lines on the far side from the source.  Empty (0, 2) when a point
    light is inside the disc.
    """
    cx, cy = float(center[0]), float(center[1])
    x0, y0, x1, y1 = bounds
    reach = 2.0 * math.hypot(x1 - x0, y1 - y0) + 2.0 * math.hypot(cx - x0, cy - y0)
    if light["kind"] == "directional":
        u = np.asarray(light["direction"], dtype=np.float64)
        u = u / np.hypot(*u)
        perp = np.array([-u[1], u[0]])
        c = np.array([cx, cy])
        a, b = c + radius * perp, c - radius * perp
        return np.array([a, a + reach * u, b + reach * u, b])
    lx, ly = light["position"]
    d = math.hypot(cx - lx, cy - ly)
    if d <= radius:
        return np.zeros((0, 2))
    base = math.atan2(cy - ly, cx - lx)
    half = math.asin(radius / d)
    tangent_len = math.sqrt(d * d - radius * radius)
    corners = []
    for s in (+1, -1):
        ang = base + s * half
        u = np.array([math.cos(ang), math.sin(ang)])
        t = np.array([lx, ly]) + tangent_len * u
        corners.append((t, u))
    (ta, ua), (tb, ub) = corners
    return np.array([ta, ta + reach * ua, tb + reach * ub, tb])


def draw_world(ax: Any, info: dict[str, Any]) -> None:
    """Walls, static obstacles and the target line of a transport setup (matplotlib)."""
    from matplotlib.collections import LineCollection
    from matplotlib.patches import Circle

    seg = np.asarray(info.get("walls", []), dtype=np.float64).reshape(-1, 4)
    if seg.size:
        ax.add_collection(
            LineCollection(seg.reshape(-1, 2, 2), colors="0.15", linewidths=1.5, zorder=4)
        )
    for x, y, r in np.asarray(info.get("obstacles", []), dtype=np.float64).reshape(-1, 3):
        ax.add_patch(Circle((x, y), r, facecolor="0.55", edgecolor="0.15", zorder=4))
    x0, y0, x1, y1 = info["bounds"]
    ty = info.get("target_y")
    if ty is not None:
        ax.plot([x0, x1], [ty, ty], color="tab:green", lw=1.0, ls="--", zorder=1)
    ax.set_xlim(x0 - 20, x1 + 20)
    ax.set_ylim(y0 - 20, y1 + 20)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")


def nearest_frame(tracks: Any, t: float) -> int:
    """Index of the recorded frame nearest to time ``t`` (s)."""
    times = np.asarray(tracks["time"].values, dtype=np.float64)
    return int(np.nanargmin(np.abs(times - float(t))))
