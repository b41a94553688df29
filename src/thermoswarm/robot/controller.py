"""The robot's controller: the paper's Algorithms 1-5 for one robot.

Runs unchanged on MicroPython and on CPython (the simulator runs it through
``thermoswarm.sim.robot``): it imports only ``math`` and has no annotations or
dataclasses.  Random numbers come from :class:`Rng`, 32-bit integer arithmetic, so a
seed gives the same draws on the board and in the simulator.  The board supplies a
:class:`HAL`.  Units: mm, s, rad; energies in mm^2/s^2 per unit mass.  The laws of each
algorithm, and what changes on boards with single-precision floats: ``docs/robot.md``.
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
    "kT_hot": 143.2,  # mean speed 15 mm/s
    "kT_cold": 5.73,  # mean speed 3 mm/s
    "light_threshold": 0.5,
    "mapping": "lit_cold",  # or "lit_hot" (PAPER_NOTES 6.3)
    "heading_law": "persistent",  # or "uniform" (Algorithm 5 as written)
    "kT_theta": 0.8,  # rad/s, steering temperature of the persistent law
    "kT_theta_cold": None,  # rad/s, of cold robots (None: kT_theta in both phases)
    # Algorithm 2
    "group": 0,  # 0: goal at 0 deg (toward the light), 1: at 180 deg
    "sigma": 0.7854,  # rad (45 deg), the spread the paper does not give
    # Algorithm 1
    "step": 0.0349,  # rad per turning step (2 deg)
    "tolerance": 0.03,  # |l1 - l2| <= tolerance * max(l1, l2)
    "dark": 0.05,  # a reading at or below this is dark ("l3 = 0")
    "max_steps": 360,
}


M32 = 0xFFFFFFFF


def _rotl(x, k):
    return ((x << k) | (x >> (32 - k))) & M32


class Rng:
    """xoshiro128** (Blackman and Vigna 2018), seeded with splitmix32.

    32-bit integer arithmetic only, so MicroPython boards and CPython give the same
    sequence for a seed, and good statistical quality (a weaker xorshift32 showed
    detectable structure in its every-other outputs in our tests).  Not for
    cryptography.
    """

    def __init__(self, seed):
        z = int(seed) & M32
        s = []
        for _ in range(4):  # splitmix32: spreads any seed over the four state words
            z = (z + 0x9E3779B9) & M32
            t = z
            t = ((t ^ (t >> 16)) * 0x85EBCA6B) & M32
            t = ((t ^ (t >> 13)) * 0xC2B2AE35) & M32
            s.append(t ^ (t >> 16))
        if not any(s):
            s[0] = 1
        self.s = s

    def u32(self):
        s = self.s
        result = (_rotl((s[1] * 5) & M32, 7) * 9) & M32
        t = (s[1] << 9) & M32
        s[2] ^= s[0]
        s[3] ^= s[1]
        s[1] ^= s[2]
        s[0] ^= s[3]
        s[2] ^= t
        s[3] = _rotl(s[3], 11)
        return result

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
        for k in ("kT", "tau", "kT_hot", "kT_cold", "sigma", "step", "kT_theta"):
            if not getattr(self, k) > 0:
                raise ValueError(k + " must be positive")
        if self.mapping not in ("lit_hot", "lit_cold"):
            raise ValueError("mapping must be 'lit_hot' or 'lit_cold'")
        if self.heading_law not in ("uniform", "persistent"):
            raise ValueError("heading_law must be 'uniform' or 'persistent'")
        if self.group not in (0, 1):
            raise ValueError("group must be 0 or 1")
        if self.kT_theta_cold is not None and not self.kT_theta_cold > 0:
            raise ValueError("kT_theta_cold must be positive (or None)")
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
        self.theta = self.rng.uniform(-math.pi, math.pi)  # last heading vs the light
        self.net = 0.0  # Algorithm 1's net turn in this period (rad)
        self.previous = 0.0  # the heading the persistent law turned from (rad)

    def temperature(self, light):
        """``kT`` of this period: constant, or switched by the light (Algorithm 5)."""
        c = self.config
        if c.algorithm != "transport-free":
            return c.kT
        lit = light > c.light_threshold
        hot = lit if c.mapping == "lit_hot" else not lit
        self.phase = 1 if hot else 0
        return c.kT_hot if hot else c.kT_cold

    def decide(self, light=1.0, previous=None):
        """Sample ``(theta, v)``: heading relative to the light (rad) and speed (mm/s).

        ``previous`` is the last heading relative to the light (the persistent law of
        Algorithm 5 turns from it); by default the controller's own memory.
        """
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
        elif a == "transport-free" and c.heading_law == "persistent":
            # keep the heading; turn by omega * tau, |omega| ~ Exponential(kT_theta)
            k = c.kT_theta if c.kT_theta_cold is None or self.phase else c.kT_theta_cold
            turn = self.rng.exponential(k * c.tau)
            if self.rng.random() < 0.5:
                turn = -turn
            theta = wrap((self.theta if previous is None else previous) + turn)
        else:
            theta = self.rng.uniform(-math.pi, math.pi)
        self.theta = theta
        return theta, v

    def turn_to_light(self):
        """Algorithm 1: step toward the brighter front sensor until ``l1 == l2`` (within
        the tolerance) with ``l3`` dark.  Returns ``(converged, steps)``; a robot that
        sees no light at all stops at once (``(False, 0)``)."""
        c = self.config
        steps = 0
        self.net = 0.0  # rad turned so far (counter-clockwise > 0)
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
            a = c.step if (l1 >= l2 or m <= c.dark) else -c.step
            self.hal.turn(a)
            self.net += a
            steps += 1

    def light_level(self):
        l1, l2, l3 = self.hal.light()
        return max(l1, l2, l3)

    def period(self):
        """One control period on the hardware; returns ``(theta, v, converged)``.

        The persistent law turns from the heading the robot had before Algorithm 1,
        relative to where Algorithm 1 left it: ``-net`` (the light's direction when it
        converged; in the dark, where it stops at once, its own facing, as the
        simulator's heading 0 there), kept in :attr:`previous`."""
        converged, _ = self.turn_to_light()
        self.previous = -self.net
        theta, v = self.decide(self.light_level(), self.previous)
        self.hal.turn(theta)
        self.hal.drive(v, self.config.tau)
        return theta, v, converged

    def run(self, periods=None):
        """Run forever (or ``periods`` times)."""
        k = 0
        while periods is None or k < periods:
            self.period()
            k += 1
