"""Robot policies: what each robot does at the start of a control period, vectorised.

Every algorithm of the paper has the same shape (PAPER_NOTES section 4)::

    TurnToAngle(0)            # face the light: this defines heading 0
    sample (theta, v)         # from the maximum-entropy laws
    turn to theta; move at v  # for one control period tau

A policy implements the middle line for many robots at once.  The engine (or the
sensing model) does ``TurnToAngle(0)`` and passes where it ended as
``Observation.zero_heading`` (world frame, radians); the policy returns world-frame
headings ``zero_heading + theta`` and speeds.  Policies hold parameters only: any
per-robot memory they need (a persistent heading) is read back from the observation,
so the engine state alone is enough to checkpoint and resume a run.

Angles are radians, measured counter-clockwise from the world +x axis; speeds mm/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from thermoswarm.maxent import DecayingTemperature, SteeringLaw, speed_law

__all__ = ["Observation", "Action", "Policy", "BoltzmannUniform"]


class Observation:
    """What the robots that start a control period know.

    All arrays have one entry per acting robot, in the engine's current order.  Fields
    are gathered from the engine state only when a policy reads them (a policy that
    needs only ``zero_heading`` costs nothing for the rest), so construct observations
    with keyword arguments: each value may be an array or a zero-argument callable.

    Attributes
    ----------
    time : float
        Simulated time (s).
    index : ndarray of int
        Positions of these robots in the engine's state arrays.
    ids : ndarray of int
        Persistent robot ids (stable across the engine's re-sorting).
    position : ndarray (m, 2)
        Positions (mm).  A real robot does not know this; policies of the paper do not
        use it, but scenario policies that model a goal region may.
    heading : ndarray (m,)
        Current heading (world frame): the heading held during the last period.
    speed : ndarray (m,)
        Current commanded speed (mm/s).
    zero_heading : ndarray (m,)
        Where ``TurnToAngle(0)`` ended, world frame: the direction of the light in ideal
        sensing, an estimate of it with photoresistors.
    light : ndarray (m,)
        Light level at the robot in [0, 1] (1 where no light model is set).
    group : ndarray of int (m,)
        A label set by the scenario (0/1 for the two directions of the narrow road).
    tau : float
        Control period (s).
    """

    _FIELDS = ("ids", "position", "heading", "speed", "zero_heading", "light", "group")

    def __init__(self, *, time: float, index: np.ndarray, tau: float, **fields) -> None:
        unknown = set(fields) - set(self._FIELDS)
        if unknown:
            raise TypeError(f"unknown observation fields {sorted(unknown)}")
        self.time = float(time)
        self.index = np.asarray(index)
        self.tau = float(tau)
        self._src = fields

    def __getattr__(self, name: str):
        if name in Observation._FIELDS:
            try:
                value = self._src[name]
            except KeyError:
                raise AttributeError(f"observation has no {name!r}") from None
            if callable(value):
                value = value()
            self.__dict__[name] = value  # cache: later reads skip __getattr__
            return value
        raise AttributeError(name)

    @property
    def n(self) -> int:
        return int(self.index.size)


@dataclass(frozen=True)
class Action:
    """World-frame heading (rad) and speed (mm/s) for each acting robot."""

    heading: np.ndarray
    speed: np.ndarray


@runtime_checkable
class Policy(Protocol):
    """``act(obs, rng) -> Action`` for the robots in ``obs``; must draw only from ``rng``."""

    def act(self, obs: Observation, rng: np.random.Generator) -> Action: ...


# ---------------------------------------------------------------------------------------
# Algorithm 2 (narrow road)

#: The steering laws of Algorithm 2 (:class:`NarrowRoad`).
STEERING_LAWS = ("normal", "exponential")


@dataclass(frozen=True)
class NarrowRoad:
    """Algorithm 2 (narrow road): Boltzmann speed at constant ``kT``, heading toward the
    robot's own goal end of the road.

    Each control period a robot of group ``g`` draws its energy ``E ~ Exponential(kT)``
    and moves at ``v = sqrt(2E)`` (Rayleigh; PAPER_NOTES 6.1), at the heading
    ``theta = goals[g] + delta`` relative to the light direction (heading 0), where
    ``delta`` follows one of two laws (PAPER_NOTES 6.2):

    ``"normal"``
        The Methods' equation: ``delta ~ N(0, sigma)``.  The paper writes ``N(0, 180)``
        for both groups, a typo: one group's mean is 0 deg, the other's 180 deg
        (``goals = (0, pi)``); the spread ``sigma`` is not given and is a parameter.
    ``"exponential"``
        The Discussion's table: robots crossing the road steer as ants do, with a
        steering-angle *rate* ``w`` whose magnitude is exponential with a temperature
        that falls with speed, ``|w| ~ Exponential(mean T_theta(v))``, random sign
        (PAPER_NOTES 6.4), ``T_theta(v) = T_min + (T_max - T_min) exp(-v / v_scale)``
        (:class:`~thermoswarm.maxent.DecayingTemperature`) evaluated at the speed ``v``
        drawn for the same period.  How a rate becomes a heading: the robot re-aligns
        with the light at the start of every period (TurnToAngle), so it carries no
        heading over from the last period; it leaves along its goal direction and its
        steering rate acts for the period ``tau``, so its heading deviates from the goal
        by ``delta = w tau`` (a Laplace law of scale ``T_theta(v) tau``).  The deviation
        per unit time ``delta / tau`` is then exactly the paper's exponential steering law
        with temperature ``T_theta(v)``; fast robots keep closer to their goal.

    Parameters
    ----------
    kT : float
        Speed temperature (mm^2/s^2 per unit mass); mean speed ``sqrt(pi kT / 2)``.
    steering : {"normal", "exponential"}
        The heading law (above).
    sigma : float
        Standard deviation of the normal law (rad).
    T_theta_max, T_theta_min : float
        Steering temperatures (rad/s) of the exponential law at speed 0 and at high
        speed; equal values give a speed-independent law.
    v_scale : float
        Speed scale (mm/s) over which ``T_theta`` falls.
    goals : tuple of float
        Goal heading of each group relative to the light (rad): ``goals[g]`` for group
        ``g``.  Default ``(0, pi)``: group 0 heads to the light end, group 1 away from it.
    speed_law : {"boltzmann", "half-normal"}
        As in :class:`BoltzmannUniform`.
    """

    kT: float
    steering: str = "normal"
    sigma: float = math.radians(30.0)
    T_theta_max: float = 1.0
    T_theta_min: float = 0.2
    v_scale: float = 10.0
    goals: tuple[float, ...] = (0.0, math.pi)
    speed_law: str = "boltzmann"

    def __post_init__(self) -> None:
        speed_law(self.speed_law, self.kT)  # validates kT and the name
        if self.steering not in STEERING_LAWS:
            raise ValueError(
                f"steering must be one of {', '.join(map(repr, STEERING_LAWS))}, "
                f"got {self.steering!r}"
            )
        if not (math.isfinite(self.sigma) and self.sigma > 0):
            raise ValueError(f"sigma must be a positive angle (rad), got {self.sigma!r}")
        steer = SteeringLaw(DecayingTemperature(self.T_theta_max, self.T_theta_min, self.v_scale))
        goals = tuple(float(g) for g in self.goals)
        if not goals or not all(math.isfinite(g) for g in goals):
            raise ValueError(f"goals must be finite angles (rad), got {self.goals!r}")
        object.__setattr__(self, "goals", goals)
        # built once: act() runs every control period for a handful of robots, where
        # constructing and validating the laws would cost more than the draws
        object.__setattr__(self, "_speed", speed_law(self.speed_law, self.kT))
        object.__setattr__(self, "_steer", steer)
        object.__setattr__(self, "_goals", np.asarray(goals))

    @property
    def steering_law(self) -> SteeringLaw:
        """The exponential steering-rate law (rad/s) as a function of speed."""
        return self._steer

    def act(self, obs: Observation, rng: np.random.Generator) -> Action:
        n = obs.n
        v = self._speed.sample(rng, n)
        group = np.asarray(obs.group)
        if n and (group.min() < 0 or group.max() >= len(self.goals)):
            bad = group[(group < 0) | (group >= len(self.goals))][0]
            raise ValueError(
                f"robot group {int(bad)} has no goal: goals are given for groups "
                f"0..{len(self.goals) - 1}"
            )
        if self.steering == "normal":
            delta = rng.standard_normal(n)
            delta *= self.sigma
        else:
            delta = self._steer.sample(rng, v, n)
            delta *= obs.tau
        delta += self._goals[group]
        delta += obs.zero_heading
        return Action(heading=delta, speed=v)


__all__ += ["NarrowRoad", "STEERING_LAWS"]


@dataclass(frozen=True)
class BoltzmannUniform:
    """Algorithm 3 (compression): Boltzmann speed at constant ``kT``, uniform heading.

    ``E ~ Exponential(kT)``, ``v = sqrt(2E)`` (Rayleigh; PAPER_NOTES 6.1) and
    ``theta ~ U(-half_width, half_width)`` relative to the light direction.  With the
    default half width ``pi`` this is Algorithm 3; with ``pi / 2`` it is the heading law
    of Algorithm 4.

    Parameters
    ----------
    kT : float
        Temperature, mm^2/s^2 per unit mass (mean speed ``sqrt(pi kT / 2)``).
    half_width : float
        Half width of the uniform heading law (rad).
    speed_law : str
        ``"boltzmann"`` (default) or ``"half-normal"`` (the literal formula, as an option).
    """

    kT: float
    half_width: float = math.pi
    speed_law: str = "boltzmann"

    def __post_init__(self) -> None:
        # validates kT and the name; kept, since act() runs every control period
        object.__setattr__(self, "_law", speed_law(self.speed_law, self.kT))
        if not (0 < self.half_width <= math.pi):
            raise ValueError(f"half_width must be in (0, pi], got {self.half_width!r}")

    def act(self, obs: Observation, rng: np.random.Generator) -> Action:
        v = self._law.sample(rng, obs.n)
        theta = rng.uniform(-self.half_width, self.half_width, obs.n)
        theta += obs.zero_heading  # in place: millions of robots, no extra temporaries
        # headings need not be wrapped: the engine uses cos/sin, recordings wrap
        return Action(heading=theta, speed=v)
