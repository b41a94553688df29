"""``box``: N robots (or elastic particles) in a square walled box.

The simplest experiment, and the engine's test bench: robots run Algorithm 3
(Boltzmann speed at temperature ``kT``, uniform heading, re-sampled every ``tau``);
with ``mode = "inertial"`` the discs are the paper's physical particles (elastic
collisions, initial speeds from the 2D Maxwell-Boltzmann law at ``kT``).

Metrics (``metrics.json``): ``n``, ``packing_fraction``, ``side`` (mm), ``kT``,
``tau``, ``kT_measured`` (mean ``v^2 / 2`` over recorded frames), ``diffusion``
(measured from non-overlapping displacement windows, with its standard error, and the
theory ``D = kT tau / 2``; overdamped only), ``max_overlap_fraction`` (largest overlap
left by any step's projection, as a fraction of the diameter), ``final_max_overlap_
fraction`` (exact check of the final state), ``robots_outside`` and, in inertial mode,
``energy_relative_drift``, ``collisions_per_particle`` and the KS test of the final
speeds against the Rayleigh law of the same mean energy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import xarray as xr
from scipy import stats

from thermoswarm.config import check
from thermoswarm.maxent import SpeedLaw, kT_for_mean_speed
from thermoswarm.policy import BoltzmannUniform
from thermoswarm.scenarios.base import Numerics, Recording, Scenario, Setup
from thermoswarm.scenarios.registry import register
from thermoswarm.sim.engine import Simulator, SwarmState, place_lattice
from thermoswarm.sim.world import box_world

__all__ = ["BoxParams", "Box"]


@dataclass(frozen=True)
class BoxParams:
    """Parameters of ``box``.

    Attributes
    ----------
    n : int
        Number of robots.
    packing_fraction : float
        Robot area / box area; sets the box side.
    duration : float
        Simulated seconds.
    kT : float
        Temperature (mm^2/s^2 per unit mass); the default gives a mean speed of 10 mm/s.
    tau : float
        Control period (s): heading and speed are re-sampled every ``tau``.
    diameter : float
        Robot diameter (mm).
    speed_law : {"boltzmann", "half-normal"}
        The speed law (PAPER_NOTES 6.1).
    mode : {"overdamped", "inertial"}
        Robots or elastic particles.
    """

    n: int = 200
    packing_fraction: float = 0.1
    duration: float = 60.0
    kT: float = field(default_factory=lambda: round(kT_for_mean_speed(10.0), 6))
    tau: float = 1.0
    diameter: float = 33.0
    speed_law: Literal["boltzmann", "half-normal"] = "boltzmann"
    mode: Literal["overdamped", "inertial"] = "overdamped"
    engine: Numerics = Numerics()
    #: every engine step (0.1 s): the displacements resolve the 1 s control period
    record: Recording = Recording(interval=0.1)

    def __post_init__(self) -> None:
        check(self.n >= 1, "n", "a positive integer (number of robots)", self.n)
        check(
            0 < self.packing_fraction < 0.9,
            "packing_fraction",
            "in (0, 0.9)",
            self.packing_fraction,
        )
        check(
            self.duration > 0 and math.isfinite(self.duration),
            "duration",
            "a positive number of seconds",
            self.duration,
        )
        check(
            self.kT > 0 and math.isfinite(self.kT), "kT", "a positive number (mm^2/s^2)", self.kT
        )
        check(self.tau > 0, "tau", "a positive number of seconds", self.tau)
        check(self.diameter > 0, "diameter", "a positive number (mm)", self.diameter)

    @property
    def side(self) -> float:
        return math.sqrt(self.n * math.pi * (self.diameter / 2) ** 2 / self.packing_fraction)


@register
class Box(Scenario):
    name = "box"
    description = "N robots (Algorithm 3) or elastic particles in a square walled box"
    Params = BoxParams

    def build(self, rng: np.random.Generator) -> Setup:
        p: BoxParams = self.params
        r = p.diameter / 2
        L = p.side
        world = box_world(L, L)
        engine = p.engine.engine(tau=p.tau, radius=r, mode=p.mode)
        pos = place_lattice(world.bounds, p.n, r, rng)
        velocities = None
        policy = None
        if p.mode == "inertial":
            speed = SpeedLaw(p.kT).sample(rng, p.n)
            th = rng.uniform(-np.pi, np.pi, p.n)
            velocities = np.column_stack([speed * np.cos(th), speed * np.sin(th)])
        else:
            policy = BoltzmannUniform(kT=p.kT, speed_law=p.speed_law)
        return Setup(
            world=world,
            engine=engine,
            policy=policy,
            positions=pos,
            velocities=velocities,
            info={"side": L},
        )

    def init_acc(self, setup: Setup, sim: Simulator, state: SwarmState) -> dict[str, np.ndarray]:
        e0 = 0.5 * float(np.sum(state.vel**2)) if self.params.mode == "inertial" else 0.0
        return {"energy0": np.array(e0)}

    def metrics(
        self,
        setup: Setup,
        acc: dict[str, np.ndarray],
        tracks: xr.Dataset,
        sim: Simulator,
        state: SwarmState,
    ) -> dict[str, Any]:
        p: BoxParams = self.params
        r = p.diameter / 2
        L = setup.info["side"]
        tol = 0.02 * p.diameter
        outside = int(np.sum((state.pos < r - tol) | (state.pos > L - r + tol)))
        speed = tracks["speed"].values.astype(np.float64)
        out: dict[str, Any] = {
            "n": p.n,
            "packing_fraction": p.packing_fraction,
            "side": L,
            "kT": p.kT,
            "tau": p.tau,
            "mode": p.mode,
            "duration": p.duration,
            "kT_measured": float(np.nanmean(speed**2) / 2),
            "robots_outside": outside,
        }
        if p.mode == "overdamped":
            out["diffusion"] = diffusion_from_tracks(tracks, p.tau, p.kT)
        else:
            e1 = 0.5 * float(np.sum(state.vel**2))
            e0 = float(acc["energy0"])
            v = np.hypot(state.vel[:, 0], state.vel[:, 1])
            ks = stats.kstest(v, SpeedLaw(e1 / p.n).cdf)
            out.update(
                {
                    "energy_initial": e0,
                    "energy_final": e1,
                    "energy_relative_drift": abs(e1 - e0) / e0,
                    "collisions_per_particle": 2.0 * float(state.counters[0]) / p.n,
                    "wall_collisions_per_particle": float(state.counters[1]) / p.n,
                    "speed_ks": {
                        "statistic": float(ks.statistic),
                        "p_value": float(ks.pvalue),
                        "n": p.n,
                        "law": "Rayleigh with kT = mean energy per particle",
                    },
                }
            )
        return out


def diffusion_from_tracks(
    tracks: xr.Dataset, tau: float, kT: float, lag_periods: int = 4
) -> dict[str, float]:
    """Diffusion coefficient (mm^2/s) from non-overlapping displacement windows.

    For a walker that holds a velocity for ``tau`` and then redraws it with a uniform
    direction, the displacement ``dr`` over a window ``T >= tau`` has
    ``<|dr|^2> = 4 D T - <v^2> tau^2 / 3`` with ``D = <v^2> tau / 4 = kT tau / 2``
    (PAPER_NOTES 6.5).  Windows are ``lag_periods * tau`` long and separated by a gap of
    one ``tau``, so no control period touches two windows and the windows are
    independent: the standard error of ``D`` is the sample standard error of
    ``(|dr|^2 + <v^2> tau^2 / 3) / 4T``.
    """
    t = tracks["time"].values
    pos = tracks["position"].isel(keypoints=0).values  # (time, space, individuals)
    if t.size < 2:  # one recorded frame: no displacement to measure
        nan = float("nan")
        return {"D": nan, "se": nan, "theory": kT * tau / 2, "window": nan, "n_windows": 0}
    dt_frame = float(np.median(np.diff(t)))
    k = max(1, int(round(lag_periods * tau / dt_frame)))
    gap = max(1, int(math.ceil(tau / dt_frame)))
    T = k * dt_frame
    if pos.shape[0] <= k:
        return {
            "D": float("nan"),
            "se": float("nan"),
            "theory": kT * tau / 2,
            "window": T,
            "n_windows": 0,
        }
    starts = np.arange(0, pos.shape[0] - k, k + gap)
    dr = pos[starts + k] - pos[starts]  # (windows, space, individuals)
    sq = (dr**2).sum(axis=1).ravel()
    v2 = 2.0 * kT
    est = (sq + v2 * tau**2 / 3) / (4 * T)
    return {
        "D": float(est.mean()),
        "se": float(est.std(ddof=1) / math.sqrt(est.size)),
        "theory": kT * tau / 2,
        "window": T,
        "n_windows": int(est.size),
    }
