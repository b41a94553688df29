"""Light, shadows and the robot's photoresistors (Algorithm 1, TurnToAngle), vectorised.

The paper's robots know one direction only: the light's.  Three photoresistors -- l1 and
l2 at the front, symmetric about the heading, l3 at the back -- are read while the robot
turns in steps until ``l1 == l2`` and ``l3 == 0`` (Algorithm 1); the heading where it
stops is "heading 0" of every algorithm.  In transport without connection the light
level itself switches the robot's temperature, and the transported object's shadow
darkens the area behind it (PAPER_NOTES sections 4 and 6.3).  This module models all of
it for up to millions of robots at once.

Units and conventions
---------------------
Positions mm; angles radians, counter-clockwise from the world +x axis (config fields
ending in ``_deg`` are degrees); time s.  Headings returned are wrapped to ``[-pi, pi)``.

Light level
-----------
With sources ``i`` of intensity ``I_i``, ``light_level`` is

    level(p) = ambient + (1 - ambient) * sum_i (I_i / sum_j I_j) * s_i(p) * g_i(p)

where ``s_i`` in [0, 1] is the unshadowed fraction of source ``i`` seen from ``p`` (0 or 1
for hard shadows) and ``g_i`` in [0, 1] its distance falloff (1 for directional light).
So the level is 1 where every source is visible at full strength and equals ``ambient``
in full shadow; intensities are relative weights of the sources.

Shadows
-------
A point is shadowed from a source when the ray (directional light) or the segment (point
light) from the point to the source crosses an occluder: a disc (tested analytically:
distance from the disc centre to the ray) or a segment (cross products); polygons and
polylines are chains of segments (:mod:`thermoswarm.sim.geometry`).  One ray test per
point per occluder, in a Numba kernel.  A ray that only grazes a disc (tangent) or runs
along a segment (parallel) is not blocked.  A point inside a disc is dark.

Soft shadows (off by default) come from an extended source: a directional light with an
``angular_radius_deg`` > 0 (the sun's is 0.27 deg) or a point light with a ``radius`` >
0 (mm).  The visible fraction ``s`` is then the share of the source's angular extent
``[-alpha, alpha]`` (as seen from the point, uniform radiance across it) not covered by
the union of the occluders' angular intervals; occluder parts farther than a point
light's centre do not block.  This is exact in 2D.

Robots do not cast shadows by default: the paper models the object's shadow only, and
robot-on-robot shadows cost a sort of all robots per call.  Pass ``casters`` (the robot
positions) to turn them on: robots are then discs of ``caster_radius`` (hard shadows,
multiplied into the soft visibility of the other occluders).  A caster shadows a point
when the ray (or segment) from the point to the source passes within ``caster_radius``
of the caster's centre and that centre lies ahead of the point, toward the source, so a
robot never shadows its own centre, where its sensors are taken to be.  For a directional light
this is exact in O(n log n) (sort across the light, sliding-window maximum along it);
for a point light it scans robots in the angular window each robot can shadow, which is
fast unless robots come within a few radii of the light.

Photoresistors
--------------
Sensor ``k`` sits at angle ``theta_k`` from the heading (l1 at ``+a``, l2 at ``-a``, l3
at ``pi`` by default); its clean reading is

    l_k = ambient + (1 - ambient) * sum_i (I_i / sum_j I_j) s_i g_i R(gamma_ik)

where ``gamma_ik`` is the angle between the sensor's axis and the direction to source
``i`` and ``R(gamma) = max(0, cos gamma)`` within ``|gamma| <= fov/2``, 0 outside.  Light
visibility is evaluated at the robot's centre (the sensors sit 16.5 mm from it, small
against any shadow).  Noise: ``l = max(0, l_clean (1 + noise_mult z1) + noise_add z2)``
with ``z1, z2`` standard normal, fresh at every reading.

TurnToAngle
-----------
Each iteration reads the three sensors, stops if ``|l1 - l2| <= tol * max(l1, l2)``,
``l3 <= dark_threshold`` and ``max(l1, l2) > dark_threshold``, and otherwise turns by
``step``.  The last condition is ours: without it a robot whose front sensors both read
dark (light in a blind spot, or behind) would stop, as ``0 == 0``.  Direction
(``turn``): ``"toward"`` (default) turns counter-clockwise when ``l1 >= l2`` (the light
is on l1's side) and clockwise otherwise, reducing the imbalance, and counter-clockwise
when both front sensors read dark (the light is behind: no side to prefer, and following
the sign of two noisy dark readings would be a random walk that can take thousands of
steps); ``"fixed"`` always turns counter-clockwise, as a robot with a one-way search
does (up to a whole turn).
A robot that sees no light -- every source shadowed, or so dim that its front sensors
would read dark even facing it -- ends at once: heading unchanged, 0 steps,
``converged`` False.  A robot that reaches ``max_steps`` ends unconverged where it is.

Without noise, a single source and no ambient light, the balance test holds exactly for
heading errors ``|phi| <= phi_tol`` with ``tan(phi_tol) = tol / ((2 - tol) tan a)``
(``(l1 - l2) / max = 2 sin a sin|phi| / cos(|phi| - a)``, increasing in ``|phi|``).  A
window narrower than one step would let the robot step over it forever, so the default
tolerance is derived from the step: ``phi_tol = 0.75 step`` (``balance_window``).
Ambient light adds to both readings and widens the window.

The ideal mode skips the sensors: heading 0 is the exact direction of the brightest
visible source (for a directional light, the opposite of its rays), optionally with a
Gaussian error ``ideal_noise_deg``; ``steps`` is the number of steps a robot turning the
short way would need, so time charged for turning stays comparable.

Kernels are Numba loops over robots (``cache=True``).  From 65,536 robots up, shadows
and noise-free turning run in parallel over chunks of robots (``NUMBA_NUM_THREADS``
threads; the results equal the serial kernels'); below that waking threads costs more
than it saves.  With sensor noise the turn runs serially so that noise is drawn from the
caller's :class:`numpy.random.Generator` in robot order (reproducible).
In the loop l3 is read only when the front pair balances, the one time it matters.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np
from numba import njit, prange

from thermoswarm.config import check
from thermoswarm.errors import ConfigError, InputError
from thermoswarm.maxent import wrap_angle
from thermoswarm.sim.geometry import Shape, Shapes, as_shapes

__all__ = [
    "ROBOT_RADIUS",
    "DirectionalLight",
    "PointLight",
    "Light",
    "SensingParams",
    "TurnResult",
    "SenseResult",
    "direct_light",
    "light_level",
    "read_sensors",
    "turn_to_angle",
    "ideal_zero_heading",
    "sense",
]

#: Radius of the paper's robot (mm): a 33 mm disc (PAPER_NOTES section 4).
ROBOT_RADIUS = 16.5

Falloff = Literal["none", "inverse", "inverse_square"]
_FALLOFF_CODE = {"none": 0, "inverse": 1, "inverse_square": 2}


# --------------------------------------------------------------------------------------
# Light sources


def _finite(x: float) -> bool:
    return isinstance(x, int | float) and math.isfinite(x)


@dataclass(frozen=True)
class DirectionalLight:
    """Parallel rays from a distant source.

    Parameters
    ----------
    direction : (float, float)
        Direction in which the rays travel (any length, normalised here).  The default
        ``(0, -1)`` is light coming from the +y side (the target side of the transport
        experiments); heading 0 then points to +y.
    intensity : float
        Relative intensity (> 0); only ratios between sources matter.
    angular_radius_deg : float
        Angular radius of the source (deg) for soft shadows; 0 (default) gives hard
        shadows.  Below 90.
    """

    direction: tuple[float, float] = (0.0, -1.0)
    intensity: float = 1.0
    angular_radius_deg: float = 0.0

    def __post_init__(self) -> None:
        d = tuple(self.direction)
        check(
            len(d) == 2 and all(_finite(float(v)) for v in d) and math.hypot(*d) > 0,
            "direction",
            "a non-zero pair of finite numbers",
            self.direction,
        )
        norm = math.hypot(*d)
        object.__setattr__(self, "direction", (float(d[0]) / norm, float(d[1]) / norm))
        check(_finite(self.intensity) and self.intensity > 0, "intensity", "> 0", self.intensity)
        check(
            _finite(self.angular_radius_deg) and 0 <= self.angular_radius_deg < 90,
            "angular_radius_deg",
            "in [0, 90) degrees",
            self.angular_radius_deg,
        )

    @property
    def source_angle(self) -> float:
        """World angle (rad) pointing to the source: the opposite of the rays."""
        return math.atan2(-self.direction[1], -self.direction[0])


@dataclass(frozen=True)
class PointLight:
    """A lamp at a point.

    Parameters
    ----------
    position : (float, float)
        Position (mm).
    intensity : float
        Relative intensity (> 0).
    falloff : {"inverse_square", "inverse", "none"}
        Strength with distance ``r``: ``min(1, (r0 / r)^2)`` (a lamp in 3D space, the
        default), ``min(1, r0 / r)`` (a line source seen in 2D) or 1.  Capped at 1 so
        that the level stays in [0, 1]: a sensor closer than ``r0`` saturates.
    reference_distance : float
        ``r0`` (mm): the distance within which the lamp gives its full intensity
        (default 1000 mm: full strength across a 1 m arena, 1/4 at 2 m).
    radius : float
        Radius of the lamp (mm) for soft shadows; 0 (default) gives hard shadows.
    """

    position: tuple[float, float]
    intensity: float = 1.0
    falloff: Falloff = "inverse_square"
    reference_distance: float = 1000.0
    radius: float = 0.0

    def __post_init__(self) -> None:
        p = tuple(self.position)
        check(
            len(p) == 2 and all(_finite(float(v)) for v in p),
            "position",
            "a pair of finite numbers (mm)",
            self.position,
        )
        object.__setattr__(self, "position", (float(p[0]), float(p[1])))
        check(_finite(self.intensity) and self.intensity > 0, "intensity", "> 0", self.intensity)
        check(
            self.falloff in _FALLOFF_CODE,
            "falloff",
            "one of 'inverse_square', 'inverse', 'none'",
            self.falloff,
        )
        check(
            _finite(self.reference_distance) and self.reference_distance > 0,
            "reference_distance",
            "> 0 (mm)",
            self.reference_distance,
        )
        check(_finite(self.radius) and self.radius >= 0, "radius", ">= 0 (mm)", self.radius)


Light = DirectionalLight | PointLight

# Packed light row: kind (0 directional, 1 point), x, y (unit vector toward the source,
# or the position), weight I_i / sum I, falloff code, r0, alpha (rad) or radius (mm).
_NCOL = 7


def _pack_lights(lights: Light | Iterable[Light]) -> np.ndarray:
    if isinstance(lights, DirectionalLight | PointLight):
        lights = [lights]
    if isinstance(lights, Shapes | str | bytes) or not isinstance(lights, Iterable):
        raise InputError(
            "lights must be a DirectionalLight, a PointLight or a list of them, got "
            f"{type(lights).__name__} (argument order is: points, lights, occluders)"
        )
    items = list(lights)
    if not items:
        raise InputError("lights must contain at least one light source")
    out = np.zeros((len(items), _NCOL))
    for i, lt in enumerate(items):
        if isinstance(lt, DirectionalLight):
            out[i] = (
                0,
                -lt.direction[0],
                -lt.direction[1],
                lt.intensity,
                0,
                1.0,
                math.radians(lt.angular_radius_deg),
            )
        elif isinstance(lt, PointLight):
            out[i] = (
                1,
                lt.position[0],
                lt.position[1],
                lt.intensity,
                _FALLOFF_CODE[lt.falloff],
                lt.reference_distance,
                lt.radius,
            )
        else:
            raise InputError(
                f"lights[{i}] must be a DirectionalLight or a PointLight, got "
                f"{type(lt).__name__} (argument order is: points, lights, occluders)"
            )
    out[:, 3] /= out[:, 3].sum()
    return out


# --------------------------------------------------------------------------------------
# Sensing parameters


@dataclass(frozen=True)
class SensingParams:
    """How robots find heading 0 (TurnToAngle, Algorithm 1).

    Parameters
    ----------
    mode : {"photoresistor", "ideal"}
        Simulate the three sensors and the stepwise turn, or take the exact direction.
    sensor_angle_deg : float
        ``a``: l1 sits at ``+a``, l2 at ``-a`` from the heading (deg), in (0, 90).
    back_angle_deg : float
        Where l3 sits (deg from the heading), in [90, 270]; default 180.
    fov_deg : float
        Full field of view of each sensor (deg), in (2a, 360]: cosine response within
        ``+-fov/2`` of its axis, zero outside.  The default 160 deg with ``a = 30`` leaves
        no blind direction (the front pair covers +-110 deg, l3 the rest).
    noise_mult, noise_add : float
        Relative and absolute (light-level units) standard deviations of sensor noise.
    tolerance : float or None
        ``tol`` of the balance test ``|l1 - l2| <= tol * max(l1, l2)``, in [0, 1).
        ``None``: derived from ``step_deg`` so that the balance window is 0.75 step
        wide on each side (see :attr:`balance_tolerance`).
    step_deg : float
        Turn per iteration (deg), in (0, 90].
    max_steps : int or None
        Most iterations; ``None``: two full turns, ``ceil(720 / step_deg)``.
    dark_threshold : float
        A reading at or below this is "dark" (``l3 = 0``), in [0, 1); must exceed the
        ambient level.
    turn : {"toward", "fixed"}
        Turn direction: toward the brighter front sensor, or always counter-clockwise.
    turn_rate_deg : float
        Turning speed (deg/s) to convert steps into time (:meth:`turn_time`).  Default
        130 deg/s: wheels at 33 mm/s in opposite directions on an assumed 29 mm track
        (the paper gives no track width).
    ideal_noise_deg : float
        Ideal mode only: standard deviation (deg) of a Gaussian error added to the exact
        direction.
    """

    mode: Literal["photoresistor", "ideal"] = "photoresistor"
    sensor_angle_deg: float = 30.0
    back_angle_deg: float = 180.0
    fov_deg: float = 160.0
    noise_mult: float = 0.0
    noise_add: float = 0.0
    tolerance: float | None = None
    step_deg: float = 2.0
    max_steps: int | None = None
    dark_threshold: float = 0.05
    turn: Literal["toward", "fixed"] = "toward"
    turn_rate_deg: float = 130.0
    ideal_noise_deg: float = 0.0

    def __post_init__(self) -> None:
        check(
            self.mode in ("photoresistor", "ideal"),
            "mode",
            "'photoresistor' or 'ideal'",
            self.mode,
        )
        check(self.turn in ("toward", "fixed"), "turn", "'toward' or 'fixed'", self.turn)
        a = self.sensor_angle_deg
        check(_finite(a) and 0 < a < 90, "sensor_angle_deg", "in (0, 90) degrees", a)
        check(
            _finite(self.fov_deg) and 2 * a < self.fov_deg <= 360,
            "fov_deg",
            f"in (2 * sensor_angle_deg, 360] = ({2 * a:g}, 360] degrees so that both front "
            "sensors see a light straight ahead",
            self.fov_deg,
        )
        b = self.back_angle_deg
        # In [90, 270] l3 reads 0 facing the light: the response max(0, cos) is 0 there.
        check(_finite(b) and 90 <= b <= 270, "back_angle_deg", "in [90, 270] degrees", b)
        for name in ("noise_mult", "noise_add", "ideal_noise_deg"):
            v = getattr(self, name)
            check(_finite(v) and v >= 0, name, ">= 0", v)
        check(
            _finite(self.step_deg) and 0 < self.step_deg <= 90,
            "step_deg",
            "in (0, 90] degrees",
            self.step_deg,
        )
        if self.max_steps is not None:
            check(self.max_steps >= 1, "max_steps", ">= 1", self.max_steps)
        check(
            _finite(self.dark_threshold) and 0 <= self.dark_threshold < 1,
            "dark_threshold",
            "in [0, 1)",
            self.dark_threshold,
        )
        check(
            _finite(self.turn_rate_deg) and self.turn_rate_deg > 0,
            "turn_rate_deg",
            "> 0 (deg/s)",
            self.turn_rate_deg,
        )
        if self.tolerance is not None:
            tol = self.tolerance
            check(_finite(tol) and 0 <= tol < 1, "tolerance", "in [0, 1)", tol)
            if self.noise_mult == 0 and self.noise_add == 0:
                window = math.degrees(self.balance_window)
                check(
                    2 * window >= self.step_deg,
                    "tolerance",
                    f">= {self._tol_for_window(math.radians(self.step_deg) / 2):.4g}: with "
                    f"step_deg = {self.step_deg:g} the balance window (+-{window:.3g} deg) "
                    "is narrower than one step and noise-free robots would step over it",
                    tol,
                )

    def _tol_for_window(self, phi: float) -> float:
        x = math.tan(phi) * math.tan(math.radians(self.sensor_angle_deg))
        return min(2 * x / (1 + x), 0.999)

    @property
    def sensor_angles(self) -> tuple[float, float, float]:
        """Angles of l1, l2, l3 from the heading (rad)."""
        a = math.radians(self.sensor_angle_deg)
        return (a, -a, math.radians(self.back_angle_deg))

    @property
    def step(self) -> float:
        """Turn per iteration (rad)."""
        return math.radians(self.step_deg)

    @property
    def balance_tolerance(self) -> float:
        """``tol`` used: ``tolerance``, or the one whose window is 0.75 step."""
        if self.tolerance is not None:
            return self.tolerance
        return self._tol_for_window(0.75 * self.step)

    @property
    def balance_window(self) -> float:
        """Largest heading error (rad) that passes the balance test (no noise or ambient)."""
        tol = self.balance_tolerance
        return math.atan(tol / ((2 - tol) * math.tan(math.radians(self.sensor_angle_deg))))

    @property
    def steps_limit(self) -> int:
        """``max_steps``, or two full turns."""
        if self.max_steps is not None:
            return self.max_steps
        return math.ceil(720.0 / self.step_deg - 1e-9)

    def turn_time(self, steps: np.ndarray | int) -> np.ndarray | float:
        """Time (s) that ``steps`` turning steps take at ``turn_rate_deg``."""
        return np.asarray(steps) * (self.step_deg / self.turn_rate_deg)


class TurnResult(NamedTuple):
    """Where TurnToAngle ended: ``heading`` (rad, world), ``steps``, ``converged``."""

    heading: np.ndarray
    steps: np.ndarray
    converged: np.ndarray


@dataclass(frozen=True)
class SenseResult:
    """Everything a robot senses at the start of a control period.

    Attributes
    ----------
    zero_heading : ndarray (n,)
        Where TurnToAngle ended (rad, world frame).
    steps : ndarray of int (n,)
        Turning steps taken.
    converged : ndarray of bool (n,)
        False where the robot saw no light or ran out of steps.
    light : ndarray (n,)
        Light level at the robot, in [0, 1].
    turn_time : ndarray (n,)
        ``steps * step / turn_rate`` (s).
    """

    zero_heading: np.ndarray
    steps: np.ndarray
    converged: np.ndarray
    light: np.ndarray
    turn_time: np.ndarray


# --------------------------------------------------------------------------------------
# Numba kernels.  Hand-written: no library answers "is this ray blocked" for a million
# points against a handful of moving 2D occluders (shapely/GEOS works per geometry object
# and is orders of magnitude slower at this size).


@njit(cache=True)
def _dir_hard_range(points, i0, i1, ux, uy, dproj, sproj, weight, out, li):
    """Hard shadows of one directional source (unit vector ``u`` toward it) for points
    ``i0:i1``: is the ray from ``p`` along ``u`` blocked?

    Worked in the light's frame, ``perp = cross(u, p)`` and ``along = dot(u, p)``: two
    products per point, then comparisons, without branches (3x faster than branching on
    random points).  ``dproj`` rows are a disc's ``perp, along, r``: it blocks if
    ``|perp - perp_c| < r`` and it lies ahead, or if it contains ``p``.  ``sproj`` rows
    are a segment's perp range ``lo, hi``, its along coordinate at ``lo`` and its slope
    d(along)/d(perp): it blocks if ``lo <= perp <= hi`` and it lies ahead there (a
    grazing ray, exactly tangent to a disc, is not blocked; segments parallel to the rays
    have ``lo > hi`` and never block).
    """
    for i in range(i0, i1):
        px = points[i, 0]
        py = points[i, 1]
        perp = ux * py - uy * px
        along = ux * px + uy * py
        b = False
        for j in range(dproj.shape[0]):
            dp = perp - dproj[j, 0]
            da = dproj[j, 1] - along
            r2 = dproj[j, 2] * dproj[j, 2]
            b |= (dp * dp < r2) & ((da > 0.0) | (dp * dp + da * da < r2))
        for j in range(sproj.shape[0]):
            lo = sproj[j, 0]
            b |= (
                (lo <= perp)
                & (perp <= sproj[j, 1])
                & (sproj[j, 2] + (perp - lo) * sproj[j, 3] > along)
            )
        out[i, li] = 0.0 if b else weight


@njit(cache=True)
def _blocked_point(px, py, lx, ly, discs, segs):
    """Does the segment from ``p`` to the light at ``l`` cross an occluder?"""
    vx = lx - px
    vy = ly - py
    vv = vx * vx + vy * vy
    if vv == 0.0:
        return False
    for j in range(discs.shape[0]):
        wx = discs[j, 0] - px
        wy = discs[j, 1] - py
        r2 = discs[j, 2] * discs[j, 2]
        if wx * wx + wy * wy < r2:
            return True
        t = (wx * vx + wy * vy) / vv
        t = min(max(t, 0.0), 1.0)
        dx = wx - t * vx
        dy = wy - t * vy
        if dx * dx + dy * dy < r2:
            return True
    for j in range(segs.shape[0]):
        ax = segs[j, 0]
        ay = segs[j, 1]
        ex = segs[j, 2] - ax
        ey = segs[j, 3] - ay
        den = vx * ey - vy * ex
        if den == 0.0:
            continue
        qx = ax - px
        qy = ay - py
        tn = qx * ey - qy * ex
        sn = qx * vy - qy * vx
        if den < 0.0:
            den, tn, sn = -den, -tn, -sn
        if 0.0 < tn < den and 0.0 <= sn <= den:
            return True
    return False


@njit(cache=True)
def _push(buf, n, lo, hi, alpha):
    lo = max(lo, -alpha)
    hi = min(hi, alpha)
    if lo < hi:
        buf[n, 0] = lo
        buf[n, 1] = hi
        return n + 1
    return n


@njit(cache=True)
def _soft_visibility(px, py, ux, uy, dist, alpha, discs, segs, buf):
    """Unblocked share of a source of angular radius ``alpha`` centred on direction ``u``.

    ``dist`` is the distance to the source (inf for directional light): occluder parts
    farther than that do not block.  Angles are measured from ``u``.
    """
    n = 0
    for j in range(discs.shape[0]):
        wx = discs[j, 0] - px
        wy = discs[j, 1] - py
        r = discs[j, 2]
        d2 = wx * wx + wy * wy
        if d2 <= r * r:
            return 0.0
        d = math.sqrt(d2)
        if d - r >= dist:
            continue
        beta = math.atan2(ux * wy - uy * wx, ux * wx + uy * wy)
        if d2 - r * r <= dist * dist:
            h = math.asin(r / d)
        else:  # only the near part of the disc, up to distance dist, blocks
            c = (d2 + dist * dist - r * r) / (2.0 * d * dist)
            h = math.acos(min(1.0, max(-1.0, c)))
        n = _push(buf, n, beta - h, beta + h, alpha)
    for j in range(segs.shape[0]):
        ax = segs[j, 0]
        ay = segs[j, 1]
        bx = segs[j, 2]
        by = segs[j, 3]
        if dist < math.inf:  # clip the segment to the disc |q - p| <= dist
            ex = bx - ax
            ey = by - ay
            qx = ax - px
            qy = ay - py
            A = ex * ex + ey * ey
            B = 2.0 * (qx * ex + qy * ey)
            C = qx * qx + qy * qy - dist * dist
            disc = B * B - 4.0 * A * C
            if disc <= 0.0:
                continue
            sq = math.sqrt(disc)
            s1 = max((-B - sq) / (2.0 * A), 0.0)
            s2 = min((-B + sq) / (2.0 * A), 1.0)
            if s1 >= s2:
                continue
            bx = ax + s2 * ex
            by = ay + s2 * ey
            ax = ax + s1 * ex
            ay = ay + s1 * ey
        qax = ax - px
        qay = ay - py
        qbx = bx - px
        qby = by - py
        ta = math.atan2(ux * qay - uy * qax, ux * qax + uy * qay)
        tb = math.atan2(ux * qby - uy * qbx, ux * qbx + uy * qby)
        lo = min(ta, tb)
        hi = max(ta, tb)
        if hi - lo <= math.pi:
            n = _push(buf, n, lo, hi, alpha)
        else:  # the shorter arc passes through +-pi
            n = _push(buf, n, hi, math.pi, alpha)
            n = _push(buf, n, -math.pi, lo, alpha)
    if n == 0:
        return 1.0
    for i in range(1, n):  # insertion sort by start: n is a handful
        lo = buf[i, 0]
        hi = buf[i, 1]
        k = i - 1
        while k >= 0 and buf[k, 0] > lo:
            buf[k + 1, 0] = buf[k, 0]
            buf[k + 1, 1] = buf[k, 1]
            k -= 1
        buf[k + 1, 0] = lo
        buf[k + 1, 1] = hi
    covered = 0.0
    cur_lo = buf[0, 0]
    cur_hi = buf[0, 1]
    for i in range(1, n):
        if buf[i, 0] > cur_hi:
            covered += cur_hi - cur_lo
            cur_lo = buf[i, 0]
            cur_hi = buf[i, 1]
        elif buf[i, 1] > cur_hi:
            cur_hi = buf[i, 1]
    covered += cur_hi - cur_lo
    return max(0.0, 1.0 - covered / (2.0 * alpha))


@njit(cache=True)
def _direct_one(px, py, discs, segs, lights, li, buf):
    """Weight * visibility * falloff of light ``li`` at ``(px, py)`` (general path)."""
    w = lights[li, 3]
    if lights[li, 0] == 0.0:
        vis = _soft_visibility(
            px, py, lights[li, 1], lights[li, 2], math.inf, lights[li, 6], discs, segs, buf
        )
        return w * vis
    lx = lights[li, 1]
    ly = lights[li, 2]
    vx = lx - px
    vy = ly - py
    dist = math.sqrt(vx * vx + vy * vy)
    code = lights[li, 4]
    r0 = lights[li, 5]
    g = 1.0
    if dist > r0:
        if code == 1.0:
            g = r0 / dist
        elif code == 2.0:
            g = (r0 / dist) * (r0 / dist)
    radius = lights[li, 6]
    if radius > 0.0:
        if dist <= radius:
            vis = 1.0
        else:
            alpha = math.asin(radius / dist)
            vis = _soft_visibility(px, py, vx / dist, vy / dist, dist, alpha, discs, segs, buf)
    else:
        vis = 0.0 if _blocked_point(px, py, lx, ly, discs, segs) else 1.0
    return w * vis * g


@njit(cache=True)
def _direct_range(points, i0, i1, discs, segs, lights, dproj, sproj, buf, out):
    for li in range(lights.shape[0]):
        if lights[li, 0] == 0.0 and lights[li, 6] == 0.0:
            _dir_hard_range(
                points, i0, i1, lights[li, 1], lights[li, 2], dproj[li], sproj[li],
                lights[li, 3], out, li,
            )  # fmt: skip
        else:
            for i in range(i0, i1):
                out[i, li] = _direct_one(points[i, 0], points[i, 1], discs, segs, lights, li, buf)


# Robots per parallel work item, and the fewest robots for which the parallel kernels are
# used: waking threads costs more than it saves below that (much more on a busy machine).
_CHUNK = 4096
_PARALLEL_MIN = 65536


@njit(cache=True)
def _direct_serial(points, discs, segs, lights, dproj, sproj, out):
    buf = np.empty((2 * (discs.shape[0] + segs.shape[0]) + 2, 2))
    _direct_range(points, 0, points.shape[0], discs, segs, lights, dproj, sproj, buf, out)


@njit(cache=True, parallel=True)
def _direct_parallel(points, discs, segs, lights, dproj, sproj, out):
    n = points.shape[0]
    nbuf = 2 * (discs.shape[0] + segs.shape[0]) + 2
    for c in prange((n + _CHUNK - 1) // _CHUNK):
        buf = np.empty((nbuf, 2))
        i0 = c * _CHUNK
        _direct_range(points, i0, min(n, i0 + _CHUNK), discs, segs, lights, dproj, sproj, buf,
                      out)  # fmt: skip


def _project(lights: np.ndarray, occ: Shapes) -> tuple[np.ndarray, np.ndarray]:
    """Occluders in each directional light's frame (perp = cross(u, .), along = u . .)."""
    nl = lights.shape[0]
    dproj = np.zeros((nl, occ.n_discs, 3))
    sproj = np.zeros((nl, occ.n_segments, 4))
    d, sg = occ.discs, occ.segments
    for li in range(nl):
        if lights[li, 0] != 0.0:
            continue
        ux, uy = lights[li, 1], lights[li, 2]
        dproj[li, :, 0] = ux * d[:, 1] - uy * d[:, 0]
        dproj[li, :, 1] = ux * d[:, 0] + uy * d[:, 1]
        dproj[li, :, 2] = d[:, 2]
        pa = ux * sg[:, 1] - uy * sg[:, 0]
        aa = ux * sg[:, 0] + uy * sg[:, 1]
        pb = ux * sg[:, 3] - uy * sg[:, 2]
        ab = ux * sg[:, 2] + uy * sg[:, 3]
        swap = pb < pa
        lo = np.where(swap, pb, pa)
        hi = np.where(swap, pa, pb)
        alo = np.where(swap, ab, aa)
        ahi = np.where(swap, aa, ab)
        with np.errstate(divide="ignore", invalid="ignore"):
            slope = (ahi - alo) / (hi - lo)
        parallel = hi == lo
        sproj[li, :, 0] = np.where(parallel, np.inf, lo)
        sproj[li, :, 1] = np.where(parallel, -np.inf, hi)
        sproj[li, :, 2] = alo
        sproj[li, :, 3] = np.where(parallel, 0.0, slope)
    return dproj, sproj


@njit(cache=True)
def _casters_directional(qperp, qalong, cperp, calong, r, blocked):
    """Query ``i`` (sorted by ``qperp``) is blocked iff some caster with
    ``|cperp - qperp_i| < r`` (casters sorted by ``cperp``) lies farther toward the
    source (``calong > qalong_i``).  Sliding-window maximum with a monotone deque."""
    m = cperp.shape[0]
    dq = np.empty(max(m, 1), dtype=np.int64)
    head = 0
    tail = 0
    hi = 0
    for i in range(qperp.shape[0]):
        q = qperp[i]
        while hi < m and cperp[hi] < q + r:
            while tail > head and calong[dq[tail - 1]] <= calong[hi]:
                tail -= 1
            dq[tail] = hi
            tail += 1
            hi += 1
        while tail > head and cperp[dq[head]] <= q - r:
            head += 1
        blocked[i] = tail > head and calong[dq[head]] > qalong[i]


@njit(cache=True)
def _casters_point(points, lx, ly, ctheta, cx, cy, r, half_window, blocked):
    """Query ``i`` is blocked iff the segment to the light passes within ``r`` of a
    caster's centre lying ahead (its projection on the segment is > 0: a robot does not
    shadow its own centre); candidates are casters (sorted by angle ``ctheta`` around the
    light) within ``half_window`` of the query's angle."""
    m = ctheta.shape[0]
    r2 = r * r
    two_pi = 2.0 * math.pi
    for i in range(points.shape[0]):
        px = points[i, 0]
        py = points[i, 1]
        vx = lx - px
        vy = ly - py
        vv = vx * vx + vy * vy
        blocked[i] = False
        if vv == 0.0 or m == 0:
            continue
        start = math.atan2(py - ly, px - lx) - half_window
        if start < -math.pi:
            start += two_pi
        j = np.searchsorted(ctheta, start)
        for k in range(m):
            jj = (j + k) % m
            span = ctheta[jj] - start
            if span < 0.0:
                span += two_pi
            if span > 2.0 * half_window:
                break
            wx = cx[jj] - px
            wy = cy[jj] - py
            t = (wx * vx + wy * vy) / vv
            if t <= 0.0:
                continue  # the caster's centre is not ahead (e.g. the robot itself)
            t = min(t, 1.0)
            dx = wx - t * vx
            dy = wy - t * vy
            if dx * dx + dy * dy < r2:
                blocked[i] = True
                break


@njit(cache=True)
def _reading(ax, ay, w, ux, uy, cos_half_fov, ambient):
    s = 0.0
    for li in range(w.shape[0]):
        c = ax * ux[li] + ay * uy[li]
        if c >= cos_half_fov and c > 0.0:
            s += w[li] * c
    return ambient + s


@njit(cache=True)
def _noisy(v, sig_m, sig_a, rng):
    if sig_m > 0.0:
        v = v * (1.0 + sig_m * rng.standard_normal())
    if sig_a > 0.0:
        v = v + sig_a * rng.standard_normal()
    return max(v, 0.0)


@njit(cache=True)
def _source_dirs(px, py, lights, ux, uy):
    for li in range(lights.shape[0]):
        if lights[li, 0] == 0.0:
            ux[li] = lights[li, 1]
            uy[li] = lights[li, 2]
        else:
            vx = lights[li, 1] - px
            vy = lights[li, 2] - py
            d = math.sqrt(vx * vx + vy * vy)
            if d > 0.0:
                ux[li] = vx / d
                uy[li] = vy / d
            else:
                ux[li] = 1.0
                uy[li] = 0.0


@njit(cache=True)
def _read_kernel(points, heading, w, lights, sens, cos_half_fov, ambient, sig_m, sig_a, rng, out):
    nl = lights.shape[0]
    ux = np.empty(nl)
    uy = np.empty(nl)
    for i in range(points.shape[0]):
        _source_dirs(points[i, 0], points[i, 1], lights, ux, uy)
        ch = math.cos(heading[i])
        sh = math.sin(heading[i])
        for k in range(3):
            ax = ch * sens[k, 0] - sh * sens[k, 1]
            ay = sh * sens[k, 0] + ch * sens[k, 1]
            v = _reading(ax, ay, w[i], ux, uy, cos_half_fov, ambient)
            out[i, k] = _noisy(v, sig_m, sig_a, rng)


@njit(cache=True)
def _turn_one(
    px,
    py,
    h0,
    wi,
    lights,
    ux,
    uy,
    sens,
    cos_half_fov,
    ambient,
    sig_m,
    sig_a,
    tol,
    step,
    max_steps,
    dark,
    fixed,
    rng,
):
    """TurnToAngle for one robot: (final heading, steps, converged)."""
    nl = lights.shape[0]
    best = -1
    bw = 0.0
    for li in range(nl):
        if wi[li] > bw:
            bw = wi[li]
            best = li
    if best < 0:
        return h0, 0, False  # every source shadowed: ends at once
    _source_dirs(px, py, lights, ux, uy)
    c1 = sens[0, 0]
    s1 = sens[0, 1]
    c2 = sens[1, 0]
    s2 = sens[1, 1]
    c3 = sens[2, 0]
    s3 = sens[2, 1]
    # Would the front sensors read light facing the brightest source?  If not, the robot
    # sees no light: Algorithm 1 ends at once.
    hx = ux[best]
    hy = uy[best]
    f1 = _reading(hx * c1 - hy * s1, hy * c1 + hx * s1, wi, ux, uy, cos_half_fov, ambient)
    f2 = _reading(hx * c2 - hy * s2, hy * c2 + hx * s2, wi, ux, uy, cos_half_fov, ambient)
    if max(f1, f2) <= dark:
        return h0, 0, False
    noisy = sig_m > 0.0 or sig_a > 0.0  # the guard below halves the noise-free cost
    cs = math.cos(step)
    ss = math.sin(step)
    ch = math.cos(h0)
    sh = math.sin(h0)
    signed = 0
    k = 0
    conv = False
    while True:
        l1 = _reading(ch * c1 - sh * s1, sh * c1 + ch * s1, wi, ux, uy, cos_half_fov, ambient)
        l2 = _reading(ch * c2 - sh * s2, sh * c2 + ch * s2, wi, ux, uy, cos_half_fov, ambient)
        if noisy:
            l1 = _noisy(l1, sig_m, sig_a, rng)
            l2 = _noisy(l2, sig_m, sig_a, rng)
        m = max(l1, l2)
        if abs(l1 - l2) <= tol * m and m > dark:
            # l3 matters only here, so it is read only here: the same outcome, in law,
            # as reading all three every step, for two thirds of the work.
            l3 = _reading(ch * c3 - sh * s3, sh * c3 + ch * s3, wi, ux, uy, cos_half_fov, ambient)
            if noisy:
                l3 = _noisy(l3, sig_m, sig_a, rng)
            if l3 <= dark:
                conv = True
                break
        if k == max_steps:
            break
        # Counter-clockwise toward l1 (at +a) when it is brighter, and to search when both
        # front sensors read dark (no side to prefer: a noisy sign would random-walk).
        if fixed or l1 >= l2 or m <= dark:
            ch, sh = ch * cs - sh * ss, sh * cs + ch * ss
            signed += 1
        else:
            ch, sh = ch * cs + sh * ss, sh * cs - ch * ss
            signed -= 1
        k += 1
    return h0 + signed * step, k, conv


@njit(cache=True)
def _turn_kernel_serial(
    points,
    heading,
    w,
    lights,
    sens,
    cos_half_fov,
    ambient,
    sig_m,
    sig_a,
    tol,
    step,
    max_steps,
    dark,
    fixed,
    rng,
    out_h,
    out_steps,
    out_conv,
):
    """With noise: robots in order, so the draws from ``rng`` are reproducible."""
    nl = lights.shape[0]
    ux = np.empty(nl)
    uy = np.empty(nl)
    for i in range(points.shape[0]):
        out_h[i], out_steps[i], out_conv[i] = _turn_one(
            points[i, 0],
            points[i, 1],
            heading[i],
            w[i],
            lights,
            ux,
            uy,
            sens,
            cos_half_fov,
            ambient,
            sig_m,
            sig_a,
            tol,
            step,
            max_steps,
            dark,
            fixed,
            rng,
        )


@njit(cache=True, parallel=True)
def _turn_kernel_parallel(
    points,
    heading,
    w,
    lights,
    sens,
    cos_half_fov,
    ambient,
    tol,
    step,
    max_steps,
    dark,
    fixed,
    rng,
    out_h,
    out_steps,
    out_conv,
):
    """Without noise (``rng`` is never drawn from): chunks of robots in parallel."""
    n = points.shape[0]
    nl = lights.shape[0]
    for c in prange((n + _CHUNK - 1) // _CHUNK):
        ux = np.empty(nl)
        uy = np.empty(nl)
        for i in range(c * _CHUNK, min(n, (c + 1) * _CHUNK)):
            out_h[i], out_steps[i], out_conv[i] = _turn_one(
                points[i, 0],
                points[i, 1],
                heading[i],
                w[i],
                lights,
                ux,
                uy,
                sens,
                cos_half_fov,
                ambient,
                0.0,
                0.0,
                tol,
                step,
                max_steps,
                dark,
                fixed,
                rng,
            )


# --------------------------------------------------------------------------------------
# Public functions


def _points(value: object, name: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a numeric array of shape (n, 2) (mm)") from None
    if arr.ndim == 1 and arr.shape == (2,):
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise InputError(f"{name} must have shape (n, 2) (mm), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name} must be finite (mm)")
    return np.ascontiguousarray(arr)


def _headings(value: object, n: int) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError("heading must be a numeric array of shape (n,) (rad)") from None
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    if arr.shape != (n,):
        raise InputError(f"heading must have shape ({n},) (rad), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError("heading must be finite (rad)")
    return np.ascontiguousarray(arr)


def _check_ambient(ambient: float) -> float:
    check(_finite(ambient) and 0 <= ambient < 1, "ambient", "in [0, 1)", ambient)
    return float(ambient)


def _apply_casters(
    points: np.ndarray,
    w: np.ndarray,
    lights: np.ndarray,
    casters: object,
    caster_radius: float,
) -> None:
    c = _points(casters, "casters")
    check(
        _finite(caster_radius) and caster_radius > 0,
        "caster_radius",
        "> 0 (mm)",
        caster_radius,
    )
    r = float(caster_radius)
    if c.shape[0] == 0 or points.shape[0] == 0:
        return
    blocked = np.empty(points.shape[0], dtype=np.bool_)
    for li in range(lights.shape[0]):
        if lights[li, 0] == 0.0:
            ux, uy = lights[li, 1], lights[li, 2]
            qperp = points[:, 1] * ux - points[:, 0] * uy
            qalong = points[:, 0] * ux + points[:, 1] * uy
            cperp = c[:, 1] * ux - c[:, 0] * uy
            calong = c[:, 0] * ux + c[:, 1] * uy
            qo = np.argsort(qperp, kind="stable")
            co = np.argsort(cperp, kind="stable")
            b = np.empty(points.shape[0], dtype=np.bool_)
            _casters_directional(
                np.ascontiguousarray(qperp[qo]),
                np.ascontiguousarray(qalong[qo]),
                np.ascontiguousarray(cperp[co]),
                np.ascontiguousarray(calong[co]),
                r,
                b,
            )
            blocked[qo] = b
        else:
            lx, ly = lights[li, 1], lights[li, 2]
            theta = np.arctan2(c[:, 1] - ly, c[:, 0] - lx)
            order = np.argsort(theta, kind="stable")
            dmin = float(np.hypot(c[:, 0] - lx, c[:, 1] - ly).min())
            half = math.asin(r / dmin) if dmin > r else math.pi
            _casters_point(
                points,
                float(lx),
                float(ly),
                np.ascontiguousarray(theta[order]),
                np.ascontiguousarray(c[order, 0]),
                np.ascontiguousarray(c[order, 1]),
                r,
                half,
                blocked,
            )
        w[blocked, li] = 0.0


def _direct(
    points: np.ndarray,
    lights: np.ndarray,
    occluders: object,
    casters: object,
    caster_radius: float,
) -> np.ndarray:
    occ = as_shapes(occluders)
    w = np.empty((points.shape[0], lights.shape[0]))
    dproj, sproj = _project(lights, occ)
    kernel = _direct_parallel if points.shape[0] >= _PARALLEL_MIN else _direct_serial
    kernel(points, occ.discs, occ.segments, lights, dproj, sproj, w)
    if casters is not None:
        _apply_casters(points, w, lights, casters, caster_radius)
    return w


def direct_light(
    points: object,
    lights: Light | Iterable[Light],
    occluders: Shapes | Shape | Sequence[Shape] | None = None,
    *,
    casters: object = None,
    caster_radius: float = ROBOT_RADIUS,
) -> np.ndarray:
    """Share of each source reaching each point: ``(I_i / sum I) * s_i * g_i``.

    Parameters
    ----------
    points : array (n, 2)
        Positions (mm).
    lights : light or list of lights
    occluders : Shapes, shape, list of shapes or None
        Discs (the object: pass its current centre every call), segments, polygons,
        polylines.
    casters : array (m, 2) or None
        Robot positions (mm) casting hard shadows as discs of ``caster_radius``; off by
        default (see the module notes).
    caster_radius : float
        Radius (mm) of the casters.

    Returns
    -------
    ndarray (n, n_lights)
        Values in [0, 1] summing to at most 1 per point.
    """
    pts = _points(points, "points")
    return _direct(pts, _pack_lights(lights), occluders, casters, caster_radius)


def light_level(
    points: object,
    lights: Light | Iterable[Light],
    occluders: Shapes | Shape | Sequence[Shape] | None = None,
    *,
    ambient: float = 0.0,
    casters: object = None,
    caster_radius: float = ROBOT_RADIUS,
) -> np.ndarray:
    """Light level at each point, in [0, 1] (1: every source fully visible at full
    strength; ``ambient``: full shadow).

    Parameters are those of :func:`direct_light` plus ``ambient`` in [0, 1), the level
    in full shadow.

    Returns
    -------
    ndarray (n,)
    """
    amb = _check_ambient(ambient)
    w = direct_light(points, lights, occluders, casters=casters, caster_radius=caster_radius)
    return amb + (1.0 - amb) * w.sum(axis=1)


def _sensor_setup(params: SensingParams, ambient: float) -> tuple[np.ndarray, float]:
    if not isinstance(params, SensingParams):
        raise InputError(f"params must be a SensingParams, got {type(params).__name__}")
    if params.dark_threshold <= ambient:
        raise ConfigError(
            f"dark_threshold must exceed the ambient level {ambient:g} (l3 could never read "
            f"dark), got {params.dark_threshold!r}"
        )
    ang = np.array(params.sensor_angles)
    sens = np.ascontiguousarray(np.stack([np.cos(ang), np.sin(ang)], axis=1))
    half = math.radians(params.fov_deg) / 2
    cos_half = math.cos(half) if half < math.pi else -1.0
    return sens, cos_half


def _need_rng(rng: np.random.Generator | None, noisy: bool) -> np.random.Generator:
    if rng is None:
        if noisy:
            raise ConfigError("rng (a numpy Generator) is required when sensor noise is > 0")
        return np.random.default_rng(0)  # never drawn from: the kernels need a Generator
    if not isinstance(rng, np.random.Generator):
        raise InputError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    return rng


def read_sensors(
    position: object,
    heading: object,
    lights: Light | Iterable[Light],
    occluders: Shapes | Shape | Sequence[Shape] | None,
    params: SensingParams,
    rng: np.random.Generator | None = None,
    *,
    ambient: float = 0.0,
    casters: object = None,
    caster_radius: float = ROBOT_RADIUS,
) -> np.ndarray:
    """Readings of the three photoresistors (l1, l2, l3) of each robot.

    Parameters
    ----------
    position : array (n, 2)
        Robot centres (mm).
    heading : array (n,)
        Headings (rad, world frame).
    lights, occluders, casters, caster_radius, ambient
        As in :func:`light_level`.
    params : SensingParams
        Sensor angles, field of view and noise.
    rng : numpy.random.Generator or None
        Source of the noise; needed only when the noise is > 0.

    Returns
    -------
    ndarray (n, 3)
        Readings in light-level units (>= 0); without noise at most 1.
    """
    pts = _points(position, "position")
    hd = _headings(heading, pts.shape[0])
    amb = _check_ambient(ambient)
    lt = _pack_lights(lights)
    sens, cos_half = _sensor_setup(params, amb)
    g = _need_rng(rng, params.noise_mult > 0 or params.noise_add > 0)
    w = _direct(pts, lt, occluders, casters, caster_radius) * (1.0 - amb)
    out = np.empty((pts.shape[0], 3))
    _read_kernel(pts, hd, w, lt, sens, cos_half, amb, params.noise_mult, params.noise_add, g, out)
    return out


def _wrap(h: np.ndarray) -> np.ndarray:
    """Wrap to [-pi, pi), leaving angles already in range bit-for-bit unchanged."""
    return np.where((h >= -np.pi) & (h < np.pi), h, wrap_angle(h))


def _ideal(pts: np.ndarray, w: np.ndarray, lt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    best = np.argmax(w, axis=1) if w.shape[0] else np.zeros(0, dtype=np.intp)
    seen = w.max(axis=1) > 0 if w.shape[0] else np.zeros(0, dtype=bool)
    row = lt[best]
    ang = np.where(
        row[:, 0] == 0.0,
        np.arctan2(row[:, 2], row[:, 1]),
        np.arctan2(row[:, 2] - pts[:, 1], row[:, 1] - pts[:, 0]),
    )
    return ang, seen


def ideal_zero_heading(
    position: object,
    lights: Light | Iterable[Light],
    occluders: Shapes | Shape | Sequence[Shape] | None = None,
    *,
    casters: object = None,
    caster_radius: float = ROBOT_RADIUS,
    fallback: object = None,
) -> np.ndarray:
    """Exact direction (rad, world) to the brightest visible source from each robot.

    For a directional light it is the opposite of the rays; for a point light the
    direction to the lamp.  The brightest is the largest ``(I_i / sum I) s_i g_i`` (the
    first listed on ties).  Where no source is visible the result is ``fallback``
    (e.g. the current heading) or NaN when ``fallback`` is None.

    Returns
    -------
    ndarray (n,)
        Angles wrapped to ``[-pi, pi)``.
    """
    pts = _points(position, "position")
    lt = _pack_lights(lights)
    w = _direct(pts, lt, occluders, casters, caster_radius)
    ang, seen = _ideal(pts, w, lt)
    fb = np.full(pts.shape[0], np.nan) if fallback is None else _headings(fallback, pts.shape[0])
    return np.where(seen, _wrap(ang), fb)


def _turn(
    pts: np.ndarray,
    hd: np.ndarray,
    lt: np.ndarray,
    w: np.ndarray,
    params: SensingParams,
    rng: np.random.Generator | None,
    amb: float,
) -> TurnResult:
    n = pts.shape[0]
    step = params.step
    if params.mode == "ideal":
        ang, seen = _ideal(pts, w, lt)
        if params.ideal_noise_deg > 0:
            g = _need_rng(rng, True)
            ang = ang + math.radians(params.ideal_noise_deg) * g.standard_normal(n)
        target = np.where(seen, ang, hd)
        turn = np.abs(wrap_angle(target - hd))
        steps = np.where(seen, np.ceil(turn / step - 1e-9), 0).astype(np.int64)
        return TurnResult(_wrap(target), steps, seen)
    sens, cos_half = _sensor_setup(params, amb)
    g = _need_rng(rng, params.noise_mult > 0 or params.noise_add > 0)
    out_h = np.empty(n)
    out_steps = np.empty(n, dtype=np.int64)
    out_conv = np.empty(n, dtype=np.bool_)
    wa = np.ascontiguousarray(w * (1.0 - amb))
    tol = params.balance_tolerance
    fixed = params.turn == "fixed"
    if params.noise_mult > 0 or params.noise_add > 0 or n < _PARALLEL_MIN:
        _turn_kernel_serial(
            pts,
            hd,
            wa,
            lt,
            sens,
            cos_half,
            amb,
            params.noise_mult,
            params.noise_add,
            tol,
            step,
            params.steps_limit,
            params.dark_threshold,
            fixed,
            g,
            out_h,
            out_steps,
            out_conv,
        )
    else:
        _turn_kernel_parallel(
            pts,
            hd,
            wa,
            lt,
            sens,
            cos_half,
            amb,
            tol,
            step,
            params.steps_limit,
            params.dark_threshold,
            fixed,
            g,
            out_h,
            out_steps,
            out_conv,
        )
    return TurnResult(_wrap(out_h), out_steps, out_conv)


def turn_to_angle(
    position: object,
    heading: object,
    lights: Light | Iterable[Light],
    occluders: Shapes | Shape | Sequence[Shape] | None,
    params: SensingParams,
    rng: np.random.Generator | None = None,
    *,
    ambient: float = 0.0,
    casters: object = None,
    caster_radius: float = ROBOT_RADIUS,
) -> TurnResult:
    """Algorithm 1 (TurnToAngle) for every robot at once; robots turn in place.

    Parameters
    ----------
    position : array (n, 2)
        Robot centres (mm).
    heading : array (n,)
        Headings before turning (rad, world frame).
    lights, occluders, ambient, casters, caster_radius
        As in :func:`light_level`.
    params : SensingParams
        ``mode="photoresistor"`` runs the stepwise turn on simulated sensors;
        ``mode="ideal"`` takes the exact direction of the brightest visible source.
    rng : numpy.random.Generator or None
        Noise source; needed only with sensor noise or ``ideal_noise_deg`` > 0.

    Returns
    -------
    TurnResult
        ``heading`` (n,) where each robot stopped (rad, wrapped to ``[-pi, pi)``),
        ``steps`` (n,) int turning steps taken (``params.turn_time(steps)`` in s) and
        ``converged`` (n,) bool: False for robots that saw no light (unchanged heading,
        0 steps) or ran out of steps.
    """
    pts = _points(position, "position")
    hd = _headings(heading, pts.shape[0])
    amb = _check_ambient(ambient)
    lt = _pack_lights(lights)
    if not isinstance(params, SensingParams):
        raise InputError(f"params must be a SensingParams, got {type(params).__name__}")
    w = _direct(pts, lt, occluders, casters, caster_radius)
    return _turn(pts, hd, lt, w, params, rng, amb)


def sense(
    position: object,
    heading: object,
    lights: Light | Iterable[Light],
    occluders: Shapes | Shape | Sequence[Shape] | None,
    params: SensingParams,
    rng: np.random.Generator | None = None,
    *,
    ambient: float = 0.0,
    casters: object = None,
    caster_radius: float = ROBOT_RADIUS,
) -> SenseResult:
    """TurnToAngle and the light level in one pass (shadows are computed once).

    What the engine calls at the start of a control period; arguments as in
    :func:`turn_to_angle`.
    """
    pts = _points(position, "position")
    hd = _headings(heading, pts.shape[0])
    amb = _check_ambient(ambient)
    lt = _pack_lights(lights)
    if not isinstance(params, SensingParams):
        raise InputError(f"params must be a SensingParams, got {type(params).__name__}")
    w = _direct(pts, lt, occluders, casters, caster_radius)
    res = _turn(pts, hd, lt, w, params, rng, amb)
    light = amb + (1.0 - amb) * w.sum(axis=1)
    return SenseResult(
        zero_heading=res.heading,
        steps=res.steps,
        converged=res.converged,
        light=light,
        turn_time=np.asarray(params.turn_time(res.steps), dtype=np.float64),
    )
