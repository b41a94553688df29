"""The robot's controller: the paper's Algorithms 1-5 for one robot.

This file is deliberately plain: it runs unchanged on MicroPython (copy it to the
board; ``mpy-cross controller.py`` compiles it) and on CPython, where the simulator
runs it (``thermoswarm.robot.sim``).  It imports only ``math``; no NumPy, no
dataclasses, no type annotations; the random numbers come from a small portable
generator (:class:`Rng`) so that a seed gives the same draws on the board and in the
simulator.

Every algorithm is one loop (PAPER_NOTES section 4)::

    TurnToAngle(0)          # Algorithm 1: turn in steps until l1 == l2 and l3 == 0
    sample (theta, v)       # the maximum-entropy laws of the algorithm
    turn to theta; move at v for one control period

Laws (PAPER_NOTES 6.1, 6.2, 6.4): the energy ``E ~ Exponential(kT)`` and the speed
``v = sqrt(2 E)`` (Rayleigh); headings relative to the light:

==========================  ================================================
``compression`` (Alg. 3)    ``theta ~ U(-180, 180)``
``transport-connected`` (4) ``theta ~ U(-90, 90)``
``transport-free`` (5)      ``theta ~ U(-180, 180)``, ``kT`` switched by light
``narrow-road`` (2)         ``theta ~ N(goal, sigma)``, goal 0 or 180 deg
==========================  ================================================

Hardware: the robot talks to its motors and photoresistors through a small "HAL"
object that the board's ``main.py`` provides (see :class:`HAL`).  Units: mm, s, rad;
the HAL converts to PWM and milliseconds.
"""

import math

TWO_PI = 2.0 * math.pi

ALGORITHMS = ("compression", "transport-connected", "transport-free", "narrow-road")

DEFAULTS = {
    "algorithm": "compression",
    "kT": 63.66,  # mm^2/s^2 per unit mass: mean speed 10 mm/s
    "tau": 1.0,  # s, control period
    "v_max": 33.0,  # mm/s: N20 motors at 52 rpm on 12 mm wheels
    # Algorithm 5: the temperature switched by the light level
    "kT_hot": 254.6,  # mean speed 20 mm/s
    "kT_cold": 15.9,  # mean speed 5 mm/s
    "light_threshold": 0.5,
    "mapping": "lit_hot",  # or "lit_cold" (PAPER_NOTES 6.3)
    # Algorithm 2
    "group": 0,  # 0: goal at 0 deg (toward the light), 1: at 180 deg
    "sigma": 0.7854,  # rad (45 deg), the spread the paper does not give
    # Algorithm 1
    "step": 0.0349,  # rad per turning step (2 deg)
    "tolerance": 0.03,  # |l1 - l2| <= tolerance * max(l1, l2)
    "dark": 0.05,  # a reading at or below this is dark ("l3 = 0")
    "max_steps": 360,
}


class Rng:
    """xorshift32 (Marsaglia 2003): 32-bit integer arithmetic only, so MicroPython
    boards and CPython give the same sequence for a seed.

    Not for cryptography; its period (2^32 - 1) is ample for a robot's decisions.
    """

    def __init__(self, seed):
        s = (int(seed) * 2654435761 + 0x6D2B79F5) & 0xFFFFFFFF
        self.state = s if s else 0x9E3779B9

    def u32(self):
        x = self.state
        x ^= (x << 13) & 0xFFFFFFFF
        x ^= x >> 17
        x ^= (x << 5) & 0xFFFFFFFF
        self.state = x
        return x

    def random(self):
        """Uniform on the open interval (0, 1)."""
        return (self.u32() + 0.5) / 4294967296.0

    def uniform(self, a, b):
        return a + (b - a) * self.random()

    def exponential(self, mean):
        return -mean * math.log(self.random())

    def normal(self):
        """Standard normal (Box-Muller)."""
        return math.sqrt(-2.0 * math.log(self.random())) * math.cos(TWO_PI * self.random())


def wrap(a):
    """Angle into [-pi, pi)."""
    return (a + math.pi) % TWO_PI - math.pi


class Config:
    """The controller's settings: :data:`DEFAULTS` with keyword overrides.

    An unknown setting or a bad value raises ``ValueError`` naming it.
    """

    def __init__(self, **settings):
        for k in settings:
            if k not in DEFAULTS:
                raise ValueError("unknown setting " + repr(k))
        for k, v in DEFAULTS.items():
            setattr(self, k, settings.get(k, v))
        if self.algorithm not in ALGORITHMS:
            raise ValueError("algorithm must be one of " + ", ".join(ALGORITHMS))
        for k in ("kT", "tau", "kT_hot", "kT_cold", "sigma", "step"):
            if not getattr(self, k) > 0:
                raise ValueError(k + " must be positive")
        if self.mapping not in ("lit_hot", "lit_cold"):
            raise ValueError("mapping must be 'lit_hot' or 'lit_cold'")
        if self.group not in (0, 1):
            raise ValueError("group must be 0 or 1")
        if self.v_max is not None and not self.v_max > 0:
            raise ValueError("v_max must be positive (or None)")


class HAL:
    """What the controller needs from the board (override every method).

    ``light()`` -> (l1, l2, l3) normalised readings in [0, 1] (l1 front-left at +a,
    l2 front-right at -a, l3 at the back); ``turn(angle)`` turns in place by ``angle``
    rad (counter-clockwise positive) and returns when done; ``drive(speed, seconds)``
    drives straight at ``speed`` mm/s for ``seconds`` (blocking).
    """

    def light(self):
        raise NotImplementedError

    def turn(self, angle):
        raise NotImplementedError

    def drive(self, speed, seconds):
        raise NotImplementedError


class Controller:
    """One robot running one algorithm.

    ``decide(light)`` is the pure decision (used by the simulator); ``turn_to_light()``
    is Algorithm 1 on the hardware; ``period()`` does one whole control period.
    """

    def __init__(self, config, hal=None, seed=0):
        self.config = config
        self.hal = hal
        self.rng = Rng(seed)
        self.phase = 0  # 1: hot ("gas"), 0: cold ("liquid"); Algorithm 5 only

    def temperature(self, light):
        """``kT`` of this period: constant, or switched by the light (Algorithm 5)."""
        c = self.config
        if c.algorithm != "transport-free":
            return c.kT
        lit = light > c.light_threshold
        hot = lit if c.mapping == "lit_hot" else not lit
        self.phase = 1 if hot else 0
        return c.kT_hot if hot else c.kT_cold

    def decide(self, light=1.0):
        """Sample ``(theta, v)``: heading relative to the light (rad) and speed (mm/s)."""
        c = self.config
        kT = self.temperature(light)
        energy = self.rng.exponential(kT)
        v = math.sqrt(2.0 * energy)
        if c.v_max is not None and v > c.v_max:
            v = c.v_max  # the motors' limit
        a = c.algorithm
        if a == "transport-connected":
            theta = self.rng.uniform(-0.5 * math.pi, 0.5 * math.pi)
        elif a == "narrow-road":
            goal = 0.0 if c.group == 0 else math.pi
            theta = wrap(goal + c.sigma * self.rng.normal())
        else:
            theta = self.rng.uniform(-math.pi, math.pi)
        return theta, v

    def turn_to_light(self):
        """Algorithm 1: step toward the brighter front sensor until ``l1 == l2`` (within
        the tolerance) with ``l3`` dark.  Returns ``(converged, steps)``; a robot that
        sees no light at all stops at once (``(False, 0)``)."""
        c = self.config
        steps = 0
        while True:
            l1, l2, l3 = self.hal.light()
            m = l1 if l1 > l2 else l2
            if m <= c.dark and l3 <= c.dark:
                return False, steps  # no light anywhere
            if m > c.dark and abs(l1 - l2) <= c.tolerance * m and l3 <= c.dark:
                return True, steps
            if steps >= c.max_steps:
                return False, steps
            # counter-clockwise toward l1 when it is brighter, and to search when the
            # light is behind (both front sensors dark)
            self.hal.turn(c.step if (l1 >= l2 or m <= c.dark) else -c.step)
            steps += 1

    def light_level(self):
        l1, l2, l3 = self.hal.light()
        return max(l1, l2, l3)

    def period(self):
        """One control period on the hardware; returns ``(theta, v, converged)``."""
        converged, _ = self.turn_to_light()
        theta, v = self.decide(self.light_level())
        self.hal.turn(theta)
        self.hal.drive(v, self.config.tau)
        return theta, v, converged

    def run(self, periods=None):
        """Run forever (or ``periods`` times)."""
        k = 0
        while periods is None or k < periods:
            self.period()
            k += 1
