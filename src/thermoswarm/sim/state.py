"""The engine's parameters and its state: plain data, no stepping.

:class:`EngineParams` (the numerics and the robots' size and drag), :class:`SwarmState`
(everything that changes during a run, the random generator included, so that a state
is all that is needed to continue one), the :data:`Sensing` signature, and the packing
of a world's movable bodies and pistons into the state's arrays.  The stepping is in
:mod:`thermoswarm.sim.engine`, which re-exports these names.

Units: mm, s; forces in units of the robot drag.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from thermoswarm.config import check
from thermoswarm.sim import kernels as K
from thermoswarm.sim.world import World

__all__ = ["EngineParams", "SwarmState", "Sensing", "pack_bodies", "pack_pistons"]


@dataclass(frozen=True)
class EngineParams:
    """Numerical and physical parameters of the engine.

    Attributes
    ----------
    dt : float
        Time step (s).
    tau : float
        Control period (s): how long a robot holds a sampled heading and speed.  A
        multiple of ``dt``.
    radius : float
        Robot radius (mm); the paper's robots are 33 mm across.
    mode : {"overdamped", "inertial"}
        Robots (commanded velocity + contacts) or elastic particles.
    iterations : int
        Minimum Jacobi projection sweeps per step (overdamped).  Each sweep measures the
        overlaps of the current configuration; all but the last also correct them.
    max_iterations : int
        Most sweeps per step; sweeping stops earlier once the largest overlap measured is
        below ``overlap_tol``.
    overlap_tol : float
        Target largest overlap, as a fraction of the diameter.
    relax : float
        Relaxation of the robot-robot correction (1 = move apart by the whole overlap).
    drag : float
        Robot drag coefficient (force per mm/s); sets the force unit.
    skin : float
        Verlet-list margin as a fraction of the diameter: the lists hold the pairs closer
        than ``2 r (1 + skin)``, and are rebuilt once any robot has moved ``r skin`` (half
        the margin) since they were built.  Any value is exact; it trades list length
        against how often lists are rebuilt.
    cell_size : float or None
        Grid cell size (mm); at least ``2 r (1 + skin)``; default
        ``max(2 r (1 + skin), sqrt(area / n))``.
    desync : bool
        Stagger the robots' control periods (real robots are not synchronised).
    """

    dt: float = 0.1
    tau: float = 1.0
    radius: float = 16.5
    mode: Literal["overdamped", "inertial"] = "overdamped"
    iterations: int = 2
    max_iterations: int = 500
    overlap_tol: float = 0.005
    relax: float = 1.0
    drag: float = 1.0
    skin: float = 0.5
    cell_size: float | None = None
    desync: bool = True

    def __post_init__(self) -> None:
        check(self.dt > 0 and math.isfinite(self.dt), "dt", "a positive number (s)", self.dt)
        check(self.tau > 0 and math.isfinite(self.tau), "tau", "a positive number (s)", self.tau)
        ratio = self.tau / self.dt
        if self.mode == "overdamped":  # elastic particles have no control period
            check(
                abs(ratio - round(ratio)) < 1e-6 * max(1.0, ratio) and round(ratio) >= 1,
                "tau", f"a multiple of dt = {self.dt}", self.tau,
            )  # fmt: skip
        check(self.radius > 0, "radius", "a positive number (mm)", self.radius)
        check(
            self.mode in ("overdamped", "inertial"),
            "mode",
            "'overdamped' or 'inertial'",
            self.mode,
        )
        check(
            1 <= self.iterations <= 1000, "iterations", "an integer in [1, 1000]", self.iterations
        )
        check(
            self.iterations <= self.max_iterations <= 10_000,
            "max_iterations",
            f"an integer in [iterations = {self.iterations}, 10000]",
            self.max_iterations,
        )
        check(0 < self.overlap_tol < 0.5, "overlap_tol", "in (0, 0.5)", self.overlap_tol)
        check(0 < self.relax <= 1.5, "relax", "in (0, 1.5]", self.relax)
        check(self.drag > 0 and math.isfinite(self.drag), "drag", "a positive number", self.drag)
        check(0 <= self.skin <= 1, "skin", "in [0, 1]", self.skin)
        if self.cell_size is not None:
            reach = 2 * self.radius * (1 + self.skin)
            check(
                self.cell_size >= reach,
                "cell_size",
                f"at least the list reach 2 r (1 + skin) = {reach:g} mm",
                self.cell_size,
            )

    @property
    def tau_steps(self) -> int:
        return int(round(self.tau / self.dt))


@dataclass
class SwarmState:
    """Everything that changes during a run (plain NumPy data + the generator).

    Robot arrays are kept sorted by grid cell; ``ids`` maps each row to the robot's
    permanent id.  Use :meth:`by_id` to get arrays in id order.

    Attributes
    ----------
    pos : (n, 2) mm
    fcols : (2, n) float64 rows heading (rad), speed (mm/s) (row indices
        :data:`kernels.HEADING`, :data:`kernels.SPEED`; views ``heading``, ``speed``)
    icols : (3, n) int32 rows id, group, steps left in the control period
        (:data:`kernels.ID`, :data:`kernels.GROUP`, :data:`kernels.TIMER`; views ``ids``,
        ``group``, ``timer``)
    udir : (2, n) float32 cos and sin of each heading, computed once per decision (the
        kernels move robots along it: no trigonometry per step)
    vel : (n, 2) mm/s (inertial mode; empty otherwise)
    bodies : (B, 11) packed movable discs (columns ``kernels.BODY_*``); use the views
        ``body_pos``, ``body_force`` (mean contact force robots exerted during the last
        step) and ``body_ext_force`` (an external force a scenario may set)
    pistons : (P, 12) packed force-driven walls; views ``piston_pos`` and
        ``piston_force`` (contact force robots exerted in the last step, as its
        component along the world's +axis: it points away from the robots, so it is
        positive for a piston with ``side = -1`` and negative for ``side = +1``)
    step : int; time : float (s); rng : the run's only random generator
    counters : int64 (2,) overdamped: total sweeps, largest overlap left by any step
        (in 1e-6 mm, exact: measured on the final positions of each step); inertial: pair
        collisions, wall collisions
    ref : (n, 2) mm, where each robot was when the neighbour lists were last built (the
        lists are a function of it, so it travels with the state: a resumed run rebuilds
        exactly the lists it had).  Default: a copy of ``pos``.
    held_pairs : (n, capacity) float32 mm, the push each listed pair held at the end of
        the last step (row i, the slot of its neighbour in i's list), the next step's
        warm start; ``held_walls`` : (2, n) float32 mm, each robot's pushes off up to
        two static segments, whose indices are in ``held_wall_ids`` (2, n) int32.  None:
        no pushes held (the last step was not jammed).
    """

    pos: np.ndarray
    fcols: np.ndarray
    icols: np.ndarray
    udir: np.ndarray
    vel: np.ndarray
    bodies: np.ndarray
    pistons: np.ndarray
    step: int
    time: float
    rng: np.random.Generator
    counters: np.ndarray = field(default_factory=lambda: np.zeros(2, np.int64))
    ref: np.ndarray | None = None
    held_pairs: np.ndarray | None = None
    held_walls: np.ndarray | None = None
    held_wall_ids: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.ref is None or self.ref.shape != self.pos.shape:
            self.ref = np.array(self.pos, dtype=np.float64, order="C", copy=True)

    @property
    def n(self) -> int:
        return self.pos.shape[0]

    @property
    def heading(self) -> np.ndarray:
        return self.fcols[K.HEADING]

    @property
    def speed(self) -> np.ndarray:
        return self.fcols[K.SPEED]

    @property
    def ids(self) -> np.ndarray:
        return self.icols[K.ID]

    @property
    def group(self) -> np.ndarray:
        return self.icols[K.GROUP]

    @property
    def timer(self) -> np.ndarray:
        return self.icols[K.TIMER]

    @property
    def body_pos(self) -> np.ndarray:
        return self.bodies[:, K.BODY_X : K.BODY_Y + 1]

    @property
    def body_force(self) -> np.ndarray:
        return self.bodies[:, K.BODY_CONTACT_X : K.BODY_CONTACT_Y + 1]

    @property
    def body_ext_force(self) -> np.ndarray:
        return self.bodies[:, K.BODY_FORCE_X : K.BODY_FORCE_Y + 1]

    @property
    def piston_pos(self) -> np.ndarray:
        return self.pistons[:, K.PISTON_POSITION]

    @property
    def piston_force(self) -> np.ndarray:
        return self.pistons[:, K.PISTON_CONTACT]

    def by_id(self, a: np.ndarray) -> np.ndarray:
        """Re-order a per-robot array (first axis) from storage order to id order."""
        out = np.empty_like(a)
        out[self.ids] = a
        return out

    def to_arrays(self) -> dict[str, np.ndarray]:
        """Arrays for a checkpoint (the generator's state is saved separately)."""
        out = {
            "pos": self.pos, "fcols": self.fcols, "icols": self.icols, "udir": self.udir,
            "vel": self.vel,
            "bodies": self.bodies, "pistons": self.pistons, "counters": self.counters,
            "step": np.array(self.step), "time": np.array(self.time), "ref": self.ref,
        }  # fmt: skip
        if self.held_pairs is not None:
            out["held_pairs"] = self.held_pairs
            out["held_walls"] = self.held_walls
            out["held_wall_ids"] = self.held_wall_ids
        return out

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], rng: np.random.Generator) -> SwarmState:
        c = np.ascontiguousarray
        return cls(
            pos=c(arrays["pos"]), fcols=c(arrays["fcols"]), icols=c(arrays["icols"]),
            udir=c(arrays["udir"]), vel=c(arrays["vel"]), bodies=c(arrays["bodies"]),
            pistons=c(arrays["pistons"]),
            counters=np.array(arrays["counters"]), step=int(arrays["step"]),
            time=float(arrays["time"]), rng=rng,
            ref=c(arrays["ref"]) if "ref" in arrays else None,
            held_pairs=c(arrays["held_pairs"]) if "held_pairs" in arrays else None,
            held_walls=c(arrays["held_walls"]) if "held_walls" in arrays else None,
            held_wall_ids=c(arrays["held_wall_ids"]) if "held_wall_ids" in arrays else None,
        )  # fmt: skip

    def copy(self) -> SwarmState:
        """An independent copy: every array and the random generator's state (the copy
        stepped by any simulator of the same world continues bit for bit)."""
        out = type(self).from_arrays(
            {k: np.array(v) for k, v in self.to_arrays().items()}, np.random.default_rng(0)
        )
        out.rng.bit_generator.state = self.rng.bit_generator.state
        return out


def pack_bodies(world: World) -> np.ndarray:
    out = np.zeros((len(world.bodies), K.BODY_COLUMNS))
    for k, b in enumerate(world.bodies):
        out[k, K.BODY_X], out[k, K.BODY_Y] = b.x, b.y
        out[k, K.BODY_RADIUS], out[k, K.BODY_DRAG] = b.radius, b.drag
        out[k, K.BODY_FORCE_X], out[k, K.BODY_FORCE_Y] = b.force
        out[k, K.BODY_SHARE] = 1.0
    return out


def pack_pistons(world: World) -> np.ndarray:
    out = np.zeros((len(world.pistons), K.PISTON_COLUMNS))
    for k, p in enumerate(world.pistons):
        out[k, K.PISTON_AXIS], out[k, K.PISTON_POSITION] = p.axis, p.position
        out[k, K.PISTON_SIDE], out[k, K.PISTON_LO], out[k, K.PISTON_HI] = p.side, p.lo, p.hi
        out[k, K.PISTON_DRAG], out[k, K.PISTON_FORCE] = p.drag, p.force
        out[k, K.PISTON_MIN], out[k, K.PISTON_MAX] = p.limits
        out[k, K.PISTON_SHARE] = 1.0
    return out


#: ``sensing(state, index) -> (zero_heading, light)`` for the robots at ``index``.
Sensing = Callable[[SwarmState, np.ndarray], tuple[np.ndarray, np.ndarray]]
