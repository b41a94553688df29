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
from numba import njit

from thermoswarm.maxent import DecayingTemperature, HalfNormalSpeed, SteeringLaw, speed_law

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

    def act_into(
        self, rng: np.random.Generator, zero_heading: float, heading: np.ndarray,
        speed: np.ndarray,
    ) -> None:  # fmt: skip
        """:meth:`act` for ``len(heading)`` robots that share one ``zero_heading``,
        written into ``heading`` and ``speed`` (contiguous float64, views allowed).

        The same draws in the same order as :meth:`act` and the same arithmetic, so the
        results are bit-identical (``tests/sim/test_decide.py``); the engine's fast path
        when every robot has the default sensing: two NumPy draws into the outputs and
        one compiled pass instead of a dozen small array operations and their
        temporaries.  Headings lie within ``zero_heading +- half_width``.
        """
        law = self._law
        if isinstance(law, HalfNormalSpeed):
            rng.standard_normal(out=speed)
            kind, scale = 1, law.sigma
        else:  # Boltzmann: v = sqrt(2 E / m), E ~ Exponential(kT)
            rng.standard_exponential(out=speed)
            kind, scale = 0, 2.0 * law.kT / law.mass
        rng.random(out=heading)  # uniform(low, high) is low + (high - low) * random()
        low = -self.half_width
        if not _finish_draws(
            speed, heading, kind, scale, low, self.half_width - low, zero_heading
        ):
            # act's speeds would be infinite too, which the engine refuses
            raise ValueError(f"kT = {law.kT!r} is too large: speeds overflow")


@njit(cache=True)
def _finish_draws(speed, heading, kind, scale, low, width, zero):
    """Raw draws to speeds and headings, rounding as NumPy does in :meth:`act`
    (``sqrt(e * scale)`` or ``|z| * scale``; ``(low + width u) + zero``).  Returns
    whether every speed is finite."""
    finite = True
    for i in range(speed.shape[0]):
        v = math.sqrt(speed[i] * scale) if kind == 0 else abs(speed[i]) * scale
        speed[i] = v
        finite &= v < math.inf  # false for inf and nan
        heading[i] = (low + width * heading[i]) + zero
    return finite


# --------------------------------------------------------------------------------------
# Algorithms 4 and 5 (object transport)
#
# Algorithm 4 (transport with connection) is Algorithm 3 with the heading law narrowed to
# the half plane facing the light: theta ~ U(-90, 90) deg.  Algorithm 5 (transport without
# connection) switches the temperature of the speed law by the light level ``l`` against a
# threshold.  The paper assigns hot and cold to light and shadow in opposite ways (its
# equation: T_liquid where l > threshold; its captions and text: lit robots gas-like), so
# the mapping is a parameter (PAPER_NOTES 6.3).  Besides the paper's fresh uniform heading,
# Algorithm 5 offers a persistent heading steered by the exponential steering-rate law
# (PAPER_NOTES 6.4): the mechanism study (``thermoswarm.studies.mechanism``) shows that the
# heading law, not only the mapping, decides whether the object moves.

__all__ += [
    "ConnectedTransport",
    "LightSwitchedTransport",
    "TurnTimeCharged",
    "PHASE_COLD",
    "PHASE_HOT",
]

#: Phase codes of Algorithm 5 (recorded per robot by ``transport-free``).
PHASE_COLD = 0
PHASE_HOT = 1


def _speeds(kind: str, kT: np.ndarray | float, rng: np.random.Generator, n: int) -> np.ndarray:
    """Speeds (mm/s) at per-robot temperatures ``kT`` (mm^2/s^2).

    Both laws scale with ``sqrt(kT)``: draw at unit temperature and scale, so that one
    vectorised draw serves robots at different temperatures.
    """
    v = speed_law(kind, 1.0).sample(rng, n)
    v *= np.sqrt(kT)
    return v


@dataclass(frozen=True)
class ConnectedTransport:
    """Algorithm 4 (transport with connection): Boltzmann speed at constant ``kT``,
    heading ``theta ~ U(-half_width, half_width)`` relative to the light direction.

    Parameters
    ----------
    kT : float
        Temperature (mm^2/s^2 per unit mass).
    half_width : float
        Half width of the heading law (rad); the paper's ``pi / 2`` (90 deg).
    speed_law : {"boltzmann", "half-normal"}
        Speed law (PAPER_NOTES 6.1).

    Notes
    -----
    With ideal sensing every robot's heading has mean component ``E[cos theta] =
    sin(w) / w`` (``2 / pi`` for ``w = pi / 2``) along the light direction: ``k`` robots
    rigidly attached to an object of drag ``g_o`` drive it toward the light at
    ``k <v> sin(w) / (w (k + g_o))`` mm/s (robot drag 1).
    """

    kT: float
    half_width: float = math.pi / 2
    speed_law: str = "boltzmann"

    def __post_init__(self) -> None:
        speed_law(self.speed_law, self.kT)
        if not (0 < self.half_width <= math.pi):
            raise ValueError(f"half_width must be in (0, pi], got {self.half_width!r}")

    def act(self, obs: Observation, rng: np.random.Generator) -> Action:
        v = speed_law(self.speed_law, self.kT).sample(rng, obs.n)
        theta = rng.uniform(-self.half_width, self.half_width, obs.n)
        theta += obs.zero_heading
        return Action(heading=theta, speed=v)

    def mean_drive(self) -> float:
        """Mean velocity component (mm/s) along the light of one robot (ideal sensing)."""
        w = self.half_width
        return speed_law(self.speed_law, self.kT).mean() * math.sin(w) / w


@dataclass(frozen=True)
class LightSwitchedTransport:
    """Algorithm 5 (transport without connection): temperature switched by the light.

    A robot whose light level ``l`` exceeds ``threshold`` is *lit*, otherwise *dark*;
    ``mapping`` says which of the two is hot (``kT_hot``, gas-like) and which is cold
    (``kT_cold``, liquid-like).  Speed: Boltzmann at that temperature.  Heading:

    - ``"uniform"``: ``theta ~ U(-pi, pi)`` relative to the light, drawn fresh every
      control period (Algorithm 5 as written);
    - ``"persistent"``: the robot keeps its heading and turns by ``omega * tau`` with the
      exponential steering law ``|omega| ~ Exponential(kT_theta)``, random sign
      (PAPER_NOTES 6.4).  The heading is read back from ``obs.heading`` (world frame);
      the light direction is not needed, only the light level.

    Parameters
    ----------
    kT_hot, kT_cold : float
        Temperatures (mm^2/s^2) of the gas-like and liquid-like phases.
    mapping : {"lit_hot", "lit_cold"}
        ``"lit_hot"``: lit robots are hot (the paper's captions and text);
        ``"lit_cold"``: lit robots are cold (the paper's equation, T_liquid where
        ``l > l_threshold``).
    threshold : float
        Light level (in [0, 1]) above which a robot is lit.
    heading_law : {"uniform", "persistent"}
    kT_theta : float
        Steering temperature (rad/s) of the persistent law: the mean absolute turning
        rate.  Per period the heading turns by a Laplace variable of scale
        ``kT_theta * tau``; the heading correlation decays as ``(1 + (kT_theta tau)^2)^-k``
        after ``k`` periods.
    speed_law : {"boltzmann", "half-normal"}
    kT_theta_cold : float or None
        Steering temperature (rad/s) of cold robots; ``None``: ``kT_theta`` for both
        phases.  The paper's steering law has a temperature ``E(v)`` that falls with
        speed (slow ants turn more: its Discussion table), so cold robots may steer
        hotter than hot ones.
    v_max : float or None
        Top speed (mm/s): sampled speeds above it are cut to it, as a motor saturates
        (the paper's robot: about 33 mm/s).  ``None``: no cut.
    """

    kT_hot: float
    kT_cold: float
    mapping: str = "lit_cold"
    threshold: float = 0.5
    heading_law: str = "uniform"
    kT_theta: float = 0.3
    speed_law: str = "boltzmann"
    kT_theta_cold: float | None = None
    v_max: float | None = None

    def __post_init__(self) -> None:
        speed_law(self.speed_law, self.kT_hot)
        speed_law(self.speed_law, self.kT_cold)
        if self.mapping not in ("lit_hot", "lit_cold"):
            raise ValueError(f"mapping must be 'lit_hot' or 'lit_cold', got {self.mapping!r}")
        if self.heading_law not in ("uniform", "persistent"):
            raise ValueError(
                f"heading_law must be 'uniform' or 'persistent', got {self.heading_law!r}"
            )
        if not (math.isfinite(self.threshold) and 0 <= self.threshold < 1):
            raise ValueError(f"threshold must be in [0, 1), got {self.threshold!r}")
        if not (math.isfinite(self.kT_theta) and self.kT_theta > 0):
            raise ValueError(f"kT_theta must be a positive number (rad/s), got {self.kT_theta!r}")
        c = self.kT_theta_cold
        if c is not None and not (math.isfinite(c) and c > 0):
            raise ValueError(f"kT_theta_cold must be a positive number (rad/s), got {c!r}")
        if self.v_max is not None and not (self.v_max > 0):
            raise ValueError(f"v_max must be a positive number (mm/s), got {self.v_max!r}")

    def phase(self, light: np.ndarray) -> np.ndarray:
        """Phase of robots at light levels ``light``: :data:`PHASE_HOT` (1) or
        :data:`PHASE_COLD` (0), int8."""
        lit = np.asarray(light) > self.threshold
        hot = lit if self.mapping == "lit_hot" else ~lit
        return hot.astype(np.int8)

    def temperature(self, light: np.ndarray) -> np.ndarray:
        """Temperature (mm^2/s^2) of robots at light levels ``light``."""
        return np.where(self.phase(light) == PHASE_HOT, self.kT_hot, self.kT_cold)

    def act(self, obs: Observation, rng: np.random.Generator) -> Action:
        hot = self.phase(obs.light) == PHASE_HOT
        v = _speeds(self.speed_law, np.where(hot, self.kT_hot, self.kT_cold), rng, obs.n)
        if self.v_max is not None:
            np.minimum(v, self.v_max, out=v)
        if self.heading_law == "uniform":
            heading = rng.uniform(-math.pi, math.pi, obs.n)
            heading += obs.zero_heading
        else:
            turn = rng.standard_exponential(obs.n)
            if self.kT_theta_cold is None:
                turn *= self.kT_theta * obs.tau
            else:
                turn *= np.where(hot, self.kT_theta, self.kT_theta_cold) * obs.tau
            turn[rng.random(obs.n) < 0.5] *= -1.0
            heading = turn + obs.heading
        return Action(heading=heading, speed=v)


@dataclass(frozen=True)
class TurnTimeCharged:
    """Charge the time a robot spends turning in place against its control period.

    The paper's robot turns in place before it moves: TurnToAngle (Algorithm 1) to face
    the light, then to the sampled heading.  The engine holds one speed for a whole
    period ``tau``; a robot that turns for ``t_turn`` seconds and then drives at ``v`` for
    the rest covers ``v (tau - t_turn)``, which this wrapper reproduces by commanding
    ``v * max(0, 1 - t_turn / tau)`` for the whole period (same displacement per period;
    the within-period timing is not resolved).

    ``t_turn = (|zero - h_prev| + |h_new - zero|) / turn_rate`` (short-way angles) for a
    robot that sees light (``obs.light > dark_threshold``) and whose inner policy samples
    relative to the light (``turns_to_light``); otherwise ``|h_new - h_prev| / turn_rate``
    (TurnToAngle ends at once in the dark: PAPER_NOTES 4, ``docs/light.md``).  The
    TurnToAngle part is the ideal count of steps; with noisy photoresistors the real
    count differs by a few steps.

    Parameters
    ----------
    inner : Policy
    turn_rate : float
        Turning speed (rad/s); :class:`thermoswarm.sim.light.SensingParams` assumes
        130 deg/s.
    dark_threshold : float
        Light level at or below which TurnToAngle finds no light.
    turns_to_light : bool
        Whether the inner policy turns to the light before sampling its heading.
    """

    inner: Policy
    turn_rate: float
    dark_threshold: float = 0.05
    turns_to_light: bool = True

    def __post_init__(self) -> None:
        if not (math.isfinite(self.turn_rate) and self.turn_rate > 0):
            raise ValueError(f"turn_rate must be a positive number (rad/s), got {self.turn_rate}")

    def act(self, obs: Observation, rng: np.random.Generator) -> Action:
        act = self.inner.act(obs, rng)
        h_prev = obs.heading
        h_new = np.asarray(act.heading, dtype=np.float64)

        def short(a: np.ndarray) -> np.ndarray:
            return np.abs((a + np.pi) % (2 * np.pi) - np.pi)

        if self.turns_to_light:
            zero = obs.zero_heading
            sees = np.asarray(obs.light) > self.dark_threshold
            angle = np.where(
                sees, short(zero - h_prev) + short(h_new - zero), short(h_new - h_prev)
            )
        else:
            angle = short(h_new - h_prev)
        factor = np.clip(1.0 - angle / (self.turn_rate * obs.tau), 0.0, 1.0)
        return Action(heading=h_new, speed=np.asarray(act.speed, dtype=np.float64) * factor)
