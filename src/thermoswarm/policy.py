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

from thermoswarm.maxent import speed_law

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
