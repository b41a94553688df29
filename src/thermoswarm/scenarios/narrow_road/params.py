"""``narrow-road``'s parameters (lengths mm, times s, energies mm^2/s^2 per unit mass).

Defaults and their measurements: ``docs/scenarios_road_compression.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

from thermoswarm.config import check, check_positive
from thermoswarm.maxent import kT_for_mean_speed
from thermoswarm.policy import STEERING_LAWS
from thermoswarm.scenarios.base import Numerics, Recording
from thermoswarm.sim.light import SensingParams

__all__ = ["NarrowRoadParams", "PAPER_OCCUPATION", "ROAD_SCALE", "DIRECTIONS"]

#: The ants' occupation ratio: 80 ants on 448 ant places (PAPER_NOTES section 5).
PAPER_OCCUPATION = 80 / 448
#: Scale from the ants' ~100 mm road to the simulated 381 mm road.
ROAD_SCALE = 381.0 / 100.0
DIRECTIONS = ("+x", "-x")


@dataclass(frozen=True)
class NarrowRoadParams:
    """Parameters of ``narrow-road`` (lengths mm, times s, angles as named).

    Attributes
    ----------
    length : float
        Road length (mm); the paper's simulated road is 381.
    section_fractions : tuple of float
        Lengths of the sections as fractions of ``length`` (sum 1), from ``x = 0``.
    section_widths : tuple of float
        Widths of the sections (mm); default the ants' 40 and 20 mm times 3.81.
    section_names : tuple of str
        Names used in the metrics.
    taper : float
        Length (mm) of a linear transition between sections of different widths
        (0: a square step).
    occupation : float
        Robot area / road area, from which the number of robots is derived.
    n : int or None
        Number of robots; overrides ``occupation``.
    diameter : float
        Robot diameter (mm).
    kT : float
        Speed temperature (mm^2/s^2 per unit mass); default: mean speed 20 mm/s (the
        robots top out near 33 mm/s; ``docs/scenarios_road_compression.md``).
    tau : float
        Control period (s).
    steering : {"normal", "exponential"}
        Heading law of Algorithm 2 (:class:`thermoswarm.policy.NarrowRoad`).
    sigma_deg : float
        Spread of the normal heading law (deg).
    T_theta_max, T_theta_min : float
        Steering temperatures (rad/s) of the exponential law at speed 0 and high speed.
    v_scale : float
        Speed scale (mm/s) of the fall of the steering temperature.
    speed_law : {"boltzmann", "half-normal"}
        The speed law (PAPER_NOTES 6.1).
    ends : {"open", "walls"}
        Open road ends (robots leave the road across them) or end walls.
    arrive_depth : float or None
        A robot whose centre comes this close (mm) to its far end has arrived.
        Default 0 with open ends (the centre crosses the end line) and two diameters
        with end walls (``docs/scenarios_road_compression.md``).
    entry_depth : float
        Re-entry spots are centres within this distance (mm) of the start wall.
    entry_clearance : float
        A robot is put back only while no robot heading the other way has its centre
        within this distance (mm) of the start wall (0: no such rule).
    flow_bin : float
        Width (s) of the bins of ``flow_over_time``.
    duration : float
        Simulated seconds; default the paper's 5,600 s test.
    sensing : SensingParams
        How robots find heading 0 (``mode = "ideal"`` or ``"photoresistor"``).
    """

    length: float = 381.0
    section_fractions: tuple[float, ...] = (0.5, 0.5)
    section_widths: tuple[float, ...] = (40.0 * ROAD_SCALE, 20.0 * ROAD_SCALE)
    section_names: tuple[str, ...] = ("wide", "narrow")
    taper: float = 0.0
    occupation: float = round(PAPER_OCCUPATION, 5)
    n: int | None = None
    diameter: float = 33.0
    kT: float = field(default_factory=lambda: round(kT_for_mean_speed(20.0), 6))
    tau: float = 1.0
    steering: Literal["normal", "exponential"] = "normal"
    sigma_deg: float = 45.0
    T_theta_max: float = 1.0
    T_theta_min: float = 0.2
    v_scale: float = 10.0
    speed_law: Literal["boltzmann", "half-normal"] = "boltzmann"
    ends: Literal["open", "walls"] = "open"
    arrive_depth: float | None = None
    entry_depth: float = 33.0
    entry_clearance: float = 0.0
    flow_bin: float = 60.0
    duration: float = 5600.0
    sensing: SensingParams = SensingParams(mode="ideal")
    engine: Numerics = Numerics()
    record: Recording = Recording(interval=0.1, block=1000)

    def __post_init__(self) -> None:
        self._check_road()
        self._check_motion()

    def _check_road(self) -> None:
        """The road's sections, the robot size, the ends and the entry/arrival depths."""
        fin = math.isfinite
        check_positive("length", self.length, "a positive length (mm)")
        k = len(self.section_fractions)
        check(k >= 1, "section_fractions", "a non-empty list", self.section_fractions)
        check(
            all(fin(f) and f > 0 for f in self.section_fractions)
            and abs(sum(self.section_fractions) - 1) < 1e-6,
            "section_fractions",
            "positive fractions of the road length that sum to 1",
            self.section_fractions,
        )
        check(
            len(self.section_widths) == k,
            "section_widths",
            f"a list of {k} widths (one per section)",
            self.section_widths,
        )
        check(
            len(self.section_names) == k and len(set(self.section_names)) == k,
            "section_names",
            f"a list of {k} distinct names (one per section)",
            self.section_names,
        )
        check_positive("diameter", self.diameter, "a positive length (mm)")
        check(
            all(fin(w) and w >= self.diameter + 2 for w in self.section_widths),
            "section_widths",
            f"widths of at least the robot diameter + 2 = {self.diameter + 2:g} mm",
            self.section_widths,
        )
        shortest = min(self.section_fractions) * self.length
        check(
            fin(self.taper) and 0 <= self.taper < shortest,
            "taper",
            f"in [0, {shortest:g}) mm (shorter than the shortest section)",
            self.taper,
        )
        check(self.ends in ("open", "walls"), "ends", "'open' or 'walls'", self.ends)
        lo = self.diameter / 2 + 1
        check(
            fin(self.entry_depth) and lo < self.entry_depth <= self.length / 4,
            "entry_depth",
            f"in ({lo:g}, {self.length / 4:g}] mm (more than a robot radius + 1 mm, at most a "
            "quarter of the road)",
            self.entry_depth,
        )
        if self.arrive_depth is not None:
            a = self.arrive_depth
            if self.ends == "walls":
                ok = fin(a) and lo < a <= self.length / 3
                want = f"in ({lo:g}, {self.length / 3:g}] mm with end walls (a centre cannot come "
                want += "closer than a radius to a wall)"
            else:
                ok = fin(a) and 0 <= a <= self.length / 3
                want = f"in [0, {self.length / 3:g}] mm"
            check(ok, "arrive_depth", want, a)

    def _check_motion(self) -> None:
        """The swarm (occupation, n, entry clearance), its speed and steering laws, the
        flow bins and the duration."""
        fin = math.isfinite
        check(
            fin(self.occupation) and 0 < self.occupation < 0.6,
            "occupation",
            "in (0, 0.6) (robot area / road area)",
            self.occupation,
        )
        if self.n is not None:
            check(self.n >= 2, "n", "an integer >= 2 (two groups)", self.n)
        check(
            fin(self.entry_clearance) and 0 <= self.entry_clearance <= self.length / 2,
            "entry_clearance",
            f"in [0, {self.length / 2:g}] mm",
            self.entry_clearance,
        )
        check_positive("kT", self.kT, "a positive number (mm^2/s^2)")
        check_positive("tau", self.tau, "a positive number of seconds")
        check(
            self.steering in STEERING_LAWS,
            "steering",
            "'normal' or 'exponential'",
            self.steering,
        )
        check(
            fin(self.sigma_deg) and 0 < self.sigma_deg <= 360,
            "sigma_deg",
            "in (0, 360] degrees",
            self.sigma_deg,
        )
        for name in ("T_theta_max", "T_theta_min", "v_scale"):
            v = getattr(self, name)
            check(fin(v) and v > 0, name, "a positive number", v)
        check(
            self.T_theta_min <= self.T_theta_max,
            "T_theta_min",
            f"at most T_theta_max = {self.T_theta_max}",
            self.T_theta_min,
        )
        check_positive("flow_bin", self.flow_bin, "a positive number of seconds")
        check_positive("duration", self.duration, "a positive number of seconds")

    @property
    def radius(self) -> float:
        return self.diameter / 2

    @property
    def arrival(self) -> float:
        """``arrive_depth``, or its default for the kind of ends (mm)."""
        if self.arrive_depth is not None:
            return self.arrive_depth
        return 0.0 if self.ends == "open" else 2 * self.diameter
