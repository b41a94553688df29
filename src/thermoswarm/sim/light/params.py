"""The sensing parameters of :mod:`thermoswarm.sim.light` (:class:`SensingParams`: the
photoresistors and TurnToAngle, Algorithm 1) and the results the sensing functions
return (:class:`TurnResult`, :class:`SenseResult`).

Re-exported by :mod:`thermoswarm.sim.light.api` and :mod:`thermoswarm.sim.light`.
Units: mm, rad, s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np

from thermoswarm.config import check
from thermoswarm.sim.light.sources import _finite

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
