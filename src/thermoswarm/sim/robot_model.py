"""The paper's robot as a body: differential drive, DC motors, photoresistors, battery.

The engine (:mod:`thermoswarm.sim.engine`) moves robots at the speed and heading their
policy commands, turns in no time and knows no top speed.  :class:`RobotModel` is what
a built robot can actually do: two wheels of diameter ``wheel_diameter`` on a track of
``track`` mm, each driven by a DC motor at ``rpm`` at its rated ``motor_volts`` through
a PWM H-bridge, three photoresistors at ``+-sensor_angle_deg`` and ``back_angle_deg``,
and a battery.  Its limits:

- top speed ``pi * wheel_diameter * rpm / 60``: 32.7 mm/s for the paper's 12 mm wheels
  at 52 rpm (the paper's Table "Robot hardware dimension");
- top turning rate in place ``2 * top_speed / track``: 2.25 rad/s (129 deg/s) on the
  29 mm track assumed throughout (the paper gives none).

:data:`ROBOTS` holds the presets; ``paper_robot`` is the paper's robot.  The closed loop
(:mod:`thermoswarm.robot.host.loop`) moves the robots that run the board's own code with
:meth:`RobotModel.wheel_speed` and :func:`drive_arc`; :func:`limit_report` says when a
scenario's policy asks for more than the robot can do, from the recorded tracks, and
:class:`RobotLimitWarning` is the warning the scenario runner gives then.

Motor model (first order, no inertia: an N20 gearmotor spins up in a few ms, less than a
control step): the wheel's speed is proportional to the motor's effective voltage
fraction ``f = duty * V_battery / motor_volts`` above a dead band,
``speed = gain * top_speed * (|f| - dead_band) / (1 - dead_band)``, zero below it; a
motor at rest starts only above ``start_band`` (static friction), which is why the
board's HAL gives each start a short full-duty kick.  Units: mm, s, rad, V, mA.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from thermoswarm.config import check
from thermoswarm.sim.light import SensingParams

__all__ = ["RobotModel", "ROBOTS", "paper_robot", "drive_arc", "limit_report",
           "RobotLimitWarning", "warn_limits"]  # fmt: skip


class RobotLimitWarning(UserWarning):
    """A scenario's policy asked for more than the robot model can do."""


@dataclass(frozen=True)
class RobotModel:
    """A differential-drive disc robot (mm, s, rad, V, mA, mAh).

    Attributes
    ----------
    diameter, height : float
        Body size (mm); the paper's robot is 33 mm across and 60 mm tall.
    wheel_diameter : float
        Wheel diameter (mm); the paper's are 12 mm.
    rpm : float
        Wheel speed at the motors' rated voltage (rev/min) after the gears; 52.
    track : float
        Distance between the wheels' contact points (mm); 29 assumed (not in the paper).
    motor_volts : float
        The motors' rated voltage (V); the paper's N20 motors are 3 V.
    dead_band : float
        Voltage fraction below which a turning motor stalls.
    start_band : float
        Voltage fraction a motor at rest needs to start (static friction), >= dead_band.
    gains : (float, float)
        Left and right motor's speed relative to the nominal (a real pair differs by a
        few per cent; the board's trim calibration measures and cancels it).
    sensor_angle_deg, back_angle_deg, fov_deg : float
        Photoresistors: l1 at ``+a``, l2 at ``-a`` of the heading, l3 at the back, each
        with this full field of view (the paper's Fig. (c)).
    battery_mah, runtime_h : float
        Battery capacity and the run time it gave (the paper: 250 mAh, 1.55 h).
    """

    diameter: float = 33.0
    height: float = 60.0
    wheel_diameter: float = 12.0
    rpm: float = 52.0
    track: float = 29.0
    motor_volts: float = 3.0
    dead_band: float = 0.15
    start_band: float = 0.3
    gains: tuple[float, float] = (1.0, 1.0)
    sensor_angle_deg: float = 30.0
    back_angle_deg: float = 180.0
    fov_deg: float = 160.0
    battery_mah: float = 250.0
    runtime_h: float = 1.55

    def __post_init__(self) -> None:
        for name in ("diameter", "height", "wheel_diameter", "rpm", "motor_volts",
                     "battery_mah", "runtime_h"):  # fmt: skip
            v = getattr(self, name)
            check(math.isfinite(v) and v > 0, name, "a positive number", v)
        check(0 < self.track <= self.diameter, "track", f"in (0, diameter = {self.diameter}]",
              self.track)  # fmt: skip
        check(0 <= self.dead_band < 1, "dead_band", "in [0, 1)", self.dead_band)
        check(self.dead_band <= self.start_band < 1, "start_band", "in [dead_band, 1)",
              self.start_band)  # fmt: skip
        check(len(self.gains) == 2 and all(g > 0 for g in self.gains), "gains",
              "two positive numbers (left, right)", self.gains)  # fmt: skip

    @property
    def top_speed(self) -> float:
        """Wheel rim speed at the rated voltage (mm/s): the fastest straight drive."""
        return math.pi * self.wheel_diameter * self.rpm / 60.0

    @property
    def max_turn_rate(self) -> float:
        """Fastest turn in place (rad/s): wheels at top speed in opposite directions."""
        return 2.0 * self.top_speed / self.track

    @property
    def mean_current_ma(self) -> float:
        """Average current (mA) that empties the battery in ``runtime_h``."""
        return self.battery_mah / self.runtime_h

    def sensing_params(self, **overrides: Any) -> SensingParams:
        """:class:`SensingParams` of this robot's photoresistors and turning rate."""
        kw: dict[str, Any] = dict(
            mode="photoresistor",
            sensor_angle_deg=self.sensor_angle_deg,
            back_angle_deg=self.back_angle_deg,
            fov_deg=self.fov_deg,
            turn_rate_deg=math.degrees(self.max_turn_rate),
        )
        kw.update(overrides)
        return SensingParams(**kw)

    def wheel_speed(self, drive: float, battery_volts: float, side: int, moving: bool) -> float:
        """Rim speed (mm/s, signed) of wheel ``side`` (0 left, 1 right) at PWM ``drive``
        in [-1, 1] (signed duty) with the battery at ``battery_volts``; ``moving``:
        whether the wheel turned in the last instant (a wheel at rest starts only above
        ``start_band``)."""
        f = abs(drive) * battery_volts / self.motor_volts
        if f <= (self.dead_band if moving else self.start_band):
            return 0.0
        v = self.gains[side] * self.top_speed * (f - self.dead_band) / (1.0 - self.dead_band)
        return math.copysign(v, drive)


#: Robot presets by name.
ROBOTS: dict[str, RobotModel] = {"paper_robot": RobotModel()}
#: The paper's robot (Tables "Robot hardware dimension", "Robots utility configurations").
paper_robot = ROBOTS["paper_robot"]


def drive_arc(
    x: float, y: float, phi: float, v_left: float, v_right: float, track: float, t: float
) -> tuple[float, float, float]:
    """Pose after ``t`` s of a differential drive at wheel speeds ``v_left``, ``v_right``
    (mm/s) on a ``track`` (mm): the exact arc.  Pose: centre (mm), heading (rad)."""
    v = 0.5 * (v_left + v_right)
    w = (v_right - v_left) / track
    if abs(w * t) < 1e-9:
        return x + v * t * math.cos(phi), y + v * t * math.sin(phi), phi
    r = v / w
    phi2 = phi + w * t
    return x + r * (math.sin(phi2) - math.sin(phi)), y - r * (math.cos(phi2) - math.cos(phi)), phi2


def limit_report(
    speed: Any, heading: Any, interval: float, tau: float, model: RobotModel,
    chunk: int = 256,
) -> dict[str, Any]:  # fmt: skip
    """What a run's policy asked beyond ``model``'s limits, from recorded commands.

    Parameters
    ----------
    speed, heading : array-like (time, robots)
        Commanded speed (mm/s) and heading (rad) per recorded frame (NumPy arrays or
        lazily loaded xarray variables: read ``chunk`` frames at a time).
    interval : float
        Seconds between frames.
    tau : float
        Control period (s): a new heading must be reached within it.
    model : RobotModel
    chunk : int
        Frames read at once.

    Returns
    -------
    dict
        ``top_speed`` (mm/s), ``max_turn_rate`` (rad/s), ``speed_over_fraction``
        (fraction of robot-frames commanded faster than the top speed), ``max_speed``,
        ``turn_over_fraction`` (fraction of heading changes between frames that the
        robot cannot turn within ``max(interval, tau)`` at its top rate), and
        ``max_turn_rate_asked`` (rad/s).  Frames further apart than ``tau`` merge
        decisions, so the turn figures are then lower bounds.
    """
    top, turn_max = model.top_speed, model.max_turn_rate
    frames = int(np.shape(speed)[0])
    n_v = over_v = n_h = over_h = 0
    max_v = max_rate = 0.0
    for a in range(0, frames, chunk):
        b = min(a + chunk, frames)
        v = np.asarray(speed[a:b], dtype=float)
        h = np.asarray(heading[max(a - 1, 0) : b], dtype=float)  # one frame of overlap
        n_v += v.size
        over_v += int(np.count_nonzero(v > top * (1 + 1e-9)))
        max_v = max(max_v, float(np.nanmax(v)) if v.size else 0.0)
        if h.shape[0] >= 2:
            rate = np.abs((np.diff(h, axis=0) + math.pi) % (2 * math.pi) - math.pi)
            rate /= max(interval, tau)
            n_h += rate.size
            over_h += int(np.count_nonzero(rate > turn_max))
            max_rate = max(max_rate, float(np.nanmax(rate)))
    return {
        "top_speed": top,
        "max_turn_rate": turn_max,
        "speed_over_fraction": over_v / n_v if n_v else 0.0,
        "max_speed": max_v,
        "turn_over_fraction": over_h / n_h if n_h else 0.0,
        "max_turn_rate_asked": max_rate,
    }


def warn_limits(report: dict[str, Any], name: str = "paper_robot") -> None:
    """Emit one :class:`RobotLimitWarning` when ``report`` (:func:`limit_report`) shows
    commands beyond the robot's limits."""
    parts = []
    if report["speed_over_fraction"] > 0:
        parts.append(
            f"speeds above its top speed {report['top_speed']:.1f} mm/s in "
            f"{100 * report['speed_over_fraction']:.2g}% of robot-frames (up to "
            f"{report['max_speed']:.1f} mm/s)"
        )
    if report["turn_over_fraction"] > 0:
        parts.append(
            f"turns faster than its {math.degrees(report['max_turn_rate']):.0f} deg/s in "
            f"{100 * report['turn_over_fraction']:.2g}% of heading changes (up to "
            f"{math.degrees(report['max_turn_rate_asked']):.0f} deg/s)"
        )
    if parts:
        warnings.warn(
            f"the policy asks more than {name} can do: " + "; ".join(parts),
            RobotLimitWarning,
            stacklevel=2,
        )
