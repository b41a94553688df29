"""What every scenario has: parameter sections, the setup it builds, and its hooks.

A scenario is one file in this package: a frozen ``Params`` dataclass with the paper's
defaults (validated in ``__post_init__`` with :func:`thermoswarm.config.check`), and a
:class:`Scenario` subclass registered by name with :func:`thermoswarm.scenarios.register`.
The generic runner (:mod:`thermoswarm.scenarios.runner`) builds it, steps the engine,
records frames, calls the hooks and writes the outputs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, Literal

from thermoswarm.config import check
from thermoswarm.errors import ConfigError

# Only the config loader at import time: the parameter classes are read (and `--set`
# checked) before NumPy, the engine, xarray and SciPy are imported.
if TYPE_CHECKING:
    import numpy as np
    import xarray as xr

    from thermoswarm.policy import Policy
    from thermoswarm.sim.engine import EngineParams, Sensing, Simulator, SwarmState
    from thermoswarm.sim.world import World

__all__ = [
    "Numerics",
    "Recording",
    "Setup",
    "Scenario",
    "wrap",
    "build_simulator",
    "overlap_metrics",
]


@dataclass(frozen=True)
class Numerics:
    """The ``[engine]`` section: numerical settings (see :class:`EngineParams`).

    Attributes
    ----------
    dt : float
        Time step (s).
    iterations : int
        Fewest contact-projection sweeps per step.
    max_iterations : int
        Most contact-projection sweeps per step.
    overlap_tol : float
        Sweeping stops once the largest overlap is below this fraction of the diameter.
    relax : float
        Fraction of a robot-robot overlap removed per sweep (1: all of it).
    skin : float
        Neighbour-list margin as a fraction of the diameter.
    cell_size : float or None
        Neighbour-grid cell size (mm); default from the diameter and the density.
    desync : bool
        Stagger the robots' control periods (real robots are not synchronised).
    backend : str
        ``"cpu"`` (Numba) or ``"gpu"`` (numba-cuda: :mod:`thermoswarm.sim.gpu`).
    """

    dt: float = 0.1
    iterations: int = 2
    max_iterations: int = 500
    overlap_tol: float = 0.005
    relax: float = 1.0
    skin: float = 0.5
    cell_size: float | None = None
    desync: bool = True
    backend: Literal["cpu", "gpu"] = "cpu"

    def engine(
        self, *, tau: float, radius: float, mode: str = "overdamped", drag: float = 1.0
    ) -> EngineParams:
        from thermoswarm.sim.engine import EngineParams

        return EngineParams(
            dt=self.dt,
            tau=tau,
            radius=radius,
            mode=mode,  # type: ignore[arg-type]
            iterations=self.iterations,
            max_iterations=self.max_iterations,
            overlap_tol=self.overlap_tol,
            relax=self.relax,
            drag=drag,
            skin=self.skin,
            cell_size=self.cell_size,
            desync=self.desync,
        )


@dataclass(frozen=True)
class Recording:
    """The ``[record]`` section.

    Attributes
    ----------
    interval : float
        Simulated seconds between recorded frames (a multiple of ``engine.dt``).
    block : int
        Frames per committed block: a killed run loses at most this many frames.
    dtype : {"f8", "f4"}
        Position precision in the Zarr store.
    netcdf : bool
        Also export ``tracks.nc`` at the end.
    """

    interval: float = 1.0
    block: int = 50
    dtype: Literal["f8", "f4"] = "f8"
    netcdf: bool = True

    def __post_init__(self) -> None:
        check(
            self.interval > 0 and math.isfinite(self.interval),
            "record.interval",
            "a positive number of seconds",
            self.interval,
        )
        check(1 <= self.block <= 100_000, "record.block", "an integer in [1, 100000]", self.block)


@dataclass
class Setup:
    """What a scenario builds: the world, the engine, the policy and the initial swarm."""

    world: World
    engine: EngineParams
    policy: Policy | None
    positions: np.ndarray
    sensing: Sensing | None = None
    group: np.ndarray | None = None
    headings: np.ndarray | None = None
    velocities: np.ndarray | None = None
    info: dict[str, Any] = field(default_factory=dict)

    def simulator(self) -> Simulator:
        from thermoswarm.sim.engine import Simulator

        return Simulator(self.world, self.engine, self.policy, self.sensing)


def build_simulator(setup: Setup, backend: str = "cpu") -> Simulator:
    """``setup.simulator()`` on the CPU; the ``[engine] backend`` engine otherwise."""
    if backend == "cpu":
        return setup.simulator()
    if type(setup).simulator is not Setup.simulator:
        raise ConfigError(
            f"engine.backend = {backend!r} is not available here: this scenario moves its "
            "robots with a simulator of its own, which runs on the CPU"
        )
    from thermoswarm.sim.backend import make_simulator

    return make_simulator(setup.world, setup.engine, setup.policy, setup.sensing, backend=backend)


def wrap(a: np.ndarray) -> np.ndarray:
    """Angles into [-pi, pi)."""
    return (a + math.pi) % (2 * math.pi) - math.pi  # math.pi == np.pi


def overlap_metrics(sim: Simulator, state: SwarmState) -> dict[str, float | None]:
    """The engine's overlap figures that every scenario reports (the runner adds them).

    Returns
    -------
    dict
        ``max_overlap_fraction``: the largest overlap any step's projection left (robot
        with robot, wall or body), as a fraction of the robot diameter; ``final_max_
        overlap_fraction``: the largest overlap of the final configuration, measured
        independently of the step (:meth:`Simulator.max_overlap`), same unit;
        ``mean_sweeps_per_step``: projection sweeps per step.  In inertial mode no step
        projects (collisions are rewound), so the first and last are ``None``.  A
        scenario whose robots never overlap by construction (``transport-connected``:
        rigidly attached) reports 0 for the step's figures.
    """
    diameter = 2.0 * float(sim.params.radius)
    out: dict[str, float | None] = {
        "final_max_overlap_fraction": float(sim.max_overlap(state)) / diameter,
        "max_overlap_fraction": None,
        "mean_sweeps_per_step": None,
    }
    if sim.params.mode != "inertial":
        out["max_overlap_fraction"] = float(state.counters[1]) / 1e6 / diameter
        out["mean_sweeps_per_step"] = float(state.counters[0]) / max(state.step, 1)
    return out


class Scenario:
    """Base class: override :meth:`build`, optionally the hooks.

    Hooks run in the runner's loop; every piece of state they keep must live in the
    accumulator dict ``acc`` (NumPy arrays), which is saved in checkpoints, so that a
    resumed run gives the same metrics as an uninterrupted one.
    """

    name: ClassVar[str]
    description: ClassVar[str] = ""
    Params: ClassVar[type]

    def __init__(self, params: Any) -> None:
        self.params = params

    # -- what to build
    def build(self, rng: np.random.Generator) -> Setup:
        raise NotImplementedError

    @property
    def duration(self) -> float:
        return float(self.params.duration)

    @property
    def recording(self) -> Recording:
        return self.params.record

    def robot_count(self) -> tuple[str, int]:
        """The config key that sets the number of robots, and that number (before
        anything is built: the runner checks the run's memory with it)."""
        return "n", int(getattr(self.params, "n", 0) or 0)

    # -- per-frame variables besides position: name -> (dims, shape without time, dtype)
    def extras(self, setup: Setup) -> dict[str, tuple[tuple[str, ...], tuple[int, ...], str]]:
        n = setup.positions.shape[0]
        return {
            "heading": (("time", "individuals"), (n,), "f4"),
            "speed": (("time", "individuals"), (n,), "f4"),
        }

    def extra_coords(self, setup: Setup) -> dict[str, list[str]]:
        return {}

    def frame(
        self, sim: Simulator, state: SwarmState, acc: dict[str, np.ndarray]
    ) -> dict[str, np.ndarray]:
        """Per-frame extras in id order."""
        import numpy as np

        if sim.params.mode == "inertial":
            v = state.by_id(state.vel)
            return {"heading": np.arctan2(v[:, 1], v[:, 0]), "speed": np.hypot(v[:, 0], v[:, 1])}
        return {"heading": wrap(state.by_id(state.heading)), "speed": state.by_id(state.speed)}

    # -- online accumulation (every step)
    def init_acc(self, setup: Setup, sim: Simulator, state: SwarmState) -> dict[str, np.ndarray]:
        return {}

    def observe(self, sim: Simulator, state: SwarmState, acc: dict[str, np.ndarray]) -> None:
        pass

    # -- the end
    def metrics(
        self,
        setup: Setup,
        acc: dict[str, np.ndarray],
        tracks: xr.Dataset,
        sim: Simulator,
        state: SwarmState,
    ) -> dict[str, Any]:
        return {}
