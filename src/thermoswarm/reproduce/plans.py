"""How big each experiment of ``thermoswarm reproduce`` is: the smoke, quick and
full plans."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass(frozen=True)
class Plan:
    """How big each experiment is (durations in simulated seconds)."""

    name: str
    road_duration: float = 5600.0
    compression_duration: float = 3600.0
    pictures_duration: float = 600.0  # the compression run that is drawn
    connected_seeds: int = 10
    connected_duration: float | None = None  # None: the scenario's default (600 s)
    free_seeds: int = 10
    # None: the scenario's durations (1200 s; zig-zag 1800 s), in which every seed arrives
    free_duration: float | None = None
    free_n: int | None = None  # None: the scenario's default (1,200 robots)
    variant_duration: float | None = None
    study: str = "full"  # mechanism and regime settings ("quick" or "full")
    study_seeds: int | None = None  # None: the setting's
    mechanism_seeds: int | None = None  # None: study_seeds
    study_overrides: dict[str, Any] = field(default_factory=dict)  # dotted keys
    regime_maps: tuple[str, ...] | None = None  # None: every map
    scaling_settings: tuple[str, ...] = ("fixed", "density")
    scaling_ns: tuple[int, ...] | None = None  # None: the setting's
    unified_robots: int = 1200
    unified_duration: float = 120.0
    gas_duration: float = 400.0
    ant_frames: int = 600
    n_bootstrap: int = 200
    #: CPU seconds per step, ``(in the main process, in the worker pool)``, for the
    #: estimate of what is left (:mod:`thermoswarm.reproduce.progress`, which rescales
    #: them by this machine's measured speed); quick: ``results.json``'s ``cpu_seconds``
    #: of a warm-cache run (docs/reproduce.md)
    cost: dict[str, tuple[float, float]] = field(default_factory=dict)


#: The quick mechanism study runs 5 of its 10 seeds: at the transport's defaults the
#: captions' mapping with persistent headings drives nearly every robot hot and straight
#: into the walls, where the jammed crowd needs the engine's full sweep limit each step
#: (45-55 s a run against 2-4 s for the other combinations: 84 % of the study's time).
QUICK = Plan("quick", compression_duration=1600.0, connected_seeds=3, free_seeds=3,
             study="quick", mechanism_seeds=5, regime_maps=("cold", "hot"),
             scaling_settings=("quick",), unified_duration=60.0,
             cost={"unified_law": (18.7, 0.0), "narrow_road": (10.1, 0.3),
                   "compression": (5.5, 33.6), "transport_connected": (7.6, 0.2),
                   "transport_free": (95.0, 1.1), "regime": (1.4, 74.5),
                   "mechanism": (0.8, 175.6), "scaling": (0.6, 31.2)})  # fmt: skip
#: Not measured (hours): the former wall-second estimates, the studies' on two cores.
FULL = Plan("full", cost={"unified_law": (60, 0), "narrow_road": (25, 0),
                          "compression": (10, 160), "transport_connected": (30, 0),
                          "transport_free": (200, 0), "regime": (5, 2000),
                          "mechanism": (5, 6000), "scaling": (5, 5600)})  # fmt: skip
#: Every step at a toy scale (a minute or two on 2 cores): checks that an install runs
#: end to end; the numbers mean nothing.
SMOKE = Plan("smoke", road_duration=40.0, compression_duration=150.0, pictures_duration=60.0,
             connected_seeds=2, connected_duration=40.0, free_seeds=2, free_duration=30.0,
             free_n=300, variant_duration=20.0, study="quick", study_seeds=2,
             study_overrides={"n": 150, "duration": 30.0, "warmup": 10.0},
             regime_maps=("cold",), scaling_settings=("quick",), scaling_ns=(50, 150),
             unified_robots=200, unified_duration=10.0, gas_duration=20.0, ant_frames=150,
             n_bootstrap=19,
             cost={"unified_law": (8, 0), "narrow_road": (3, 0), "compression": (2, 12),
                   "transport_connected": (3, 0), "transport_free": (6, 0), "regime": (1, 10),
                   "mechanism": (1, 22), "scaling": (1, 10)})  # fmt: skip
PLANS = {p.name: p for p in (SMOKE, QUICK, FULL)}
