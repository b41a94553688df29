"""The engine: a 2D swarm of rigid disc robots, overdamped or elastic.

Shape (after JAX-MD's ``simulate``): :func:`simulator` takes the world, the engine
parameters, a policy and an optional sensing model and returns ``init`` and ``step``
functions.  The state is plain data (:class:`SwarmState`); the random generator is
carried in it, so a state is all that is needed to continue a run.

Overdamped mode (robots)
------------------------
Each robot moves at the velocity its policy commands -- speed and heading held for
one control period ``tau`` -- and contacts correct the motion.  Contact method:
**mass-weighted position projection** (the overdamped limit of rigid contact, as in
Maury & Venel's crowd model and in position-based dynamics).  Each step every robot
first moves by ``v dt``; then ``iterations`` Jacobi sweeps remove overlaps.  In a sweep,
each overlapping robot pair moves apart by half the overlap each (``relax`` scales it),
a robot touching a static wall moves out by the whole overlap, and a robot touching a
movable body or a force-driven wall shares the overlap with it in proportion to the
mobilities (``1/drag``) -- which is exactly how an overdamped body of drag ``g_b`` pushed
by ``k`` robots of drag ``g_r`` moves: at ``k g_r v / (k g_r + g_b)``.  The contact force
that robots exert on a body or wall is ``g_r x (the correction the robots received) / dt``,
summed over the step; for a force-driven wall in steady state it balances the applied
force, which is how pressure is measured.

Time step: ``dt = 0.1 s`` by default.  At the paper's speeds (mean 10-20 mm/s; robots top
out near 33 mm/s) a robot moves at most a few mm per step (about 10 % of its 33 mm
diameter even at the 1e-4 quantile of the Rayleigh law), so a few Jacobi sweeps keep
overlaps below 2 % of the diameter at packing fraction 0.5 (measured: ``make bench``,
and ``tests/sim``).  A smaller ``dt`` is needed only for much faster robots; the
control period ``tau`` must be a multiple of ``dt``.

Why not soft springs: keeping overlaps below 2 % with springs needs a stiffness, and
hence a time step, an order of magnitude smaller; projection has no stiffness.

Inertial mode (particles)
-------------------------
Elastic hard discs of equal mass: ballistic flight, and each overlapping approaching
pair is rewound to its moment of contact and exchanges normal velocities -- energy and
momentum are conserved to round-off.  This is the paper's "physical particles": its
speeds relax to the 2D Maxwell-Boltzmann (Rayleigh) law.

Units: mm, s; forces in units of the robot drag (``drag`` = 1: force = mm/s).
Angles: radians counter-clockwise from +x.  The light direction (heading 0 of the
paper) is +y unless a sensing model says otherwise.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from thermoswarm.config import check
from thermoswarm.errors import ConfigError
from thermoswarm.policy import Action, Observation, Policy
from thermoswarm.sim import kernels as K
from thermoswarm.sim.world import World

__all__ = [
    "EngineParams",
    "SwarmState",
    "Sensing",
    "Simulator",
    "simulator",
    "place_lattice",
    "LIGHT_DIRECTION",
]

#: World-frame direction of heading 0 (towards the light) when no light model is set.
LIGHT_DIRECTION = math.pi / 2


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
        Minimum Jacobi projection sweeps per step (overdamped).
    max_iterations : int
        Most sweeps per step; sweeping stops earlier once the largest overlap found is
        below ``overlap_tol``.
    overlap_tol : float
        Target largest overlap, as a fraction of the diameter.
    relax : float
        Relaxation of the robot-robot correction (1 = move apart by the whole overlap).
    drag : float
        Robot drag coefficient (force per mm/s); sets the force unit.
    skin : float
        Extra cell width as a fraction of the diameter (contacts found at any sweep).
    cell_size : float or None
        Grid cell size (mm); default ``max(2 r (1 + skin), sqrt(area / n))``.
    desync : bool
        Stagger the robots' control periods (real robots are not synchronised).
    """

    dt: float = 0.1
    tau: float = 1.0
    radius: float = 16.5
    mode: Literal["overdamped", "inertial"] = "overdamped"
    iterations: int = 2
    max_iterations: int = 50
    overlap_tol: float = 0.01
    relax: float = 1.0
    drag: float = 1.0
    skin: float = 0.1
    cell_size: float | None = None
    desync: bool = True

    def __post_init__(self) -> None:
        check(self.dt > 0 and math.isfinite(self.dt), "dt", "a positive number (s)", self.dt)
        check(self.tau > 0 and math.isfinite(self.tau), "tau", "a positive number (s)", self.tau)
        ratio = self.tau / self.dt
        check(
            abs(ratio - round(ratio)) < 1e-6 * max(1.0, ratio) and round(ratio) >= 1,
            "tau",
            f"a multiple of dt = {self.dt}",
            self.tau,
        )
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
            check(
                self.cell_size >= 2 * self.radius,
                "cell_size",
                f"at least the diameter {2 * self.radius} mm",
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
    pos : (n, 2) mm; fcols : (2, n) rows heading (rad), speed (mm/s);
    icols : (3, n) rows id, group, steps left in the control period;
    vel : (n, 2) mm/s (inertial mode; zeros otherwise);
    body_pos : (B, 2) mm, body_force : (B, 2) mean contact force of the last step;
    piston_pos : (P,) mm, piston_force : (P,) mean contact force of the last step
    (along the axis, positive = away from the robots);
    step : int, time : float (s); rng : the run's only random generator.
    """

    pos: np.ndarray
    fcols: np.ndarray
    icols: np.ndarray
    vel: np.ndarray
    body_pos: np.ndarray
    body_force: np.ndarray
    piston_pos: np.ndarray
    piston_force: np.ndarray
    step: int
    time: float
    rng: np.random.Generator
    counters: np.ndarray = field(default_factory=lambda: np.zeros(2, np.int64))

    @property
    def n(self) -> int:
        return self.pos.shape[0]

    @property
    def heading(self) -> np.ndarray:
        return self.fcols[0]

    @property
    def speed(self) -> np.ndarray:
        return self.fcols[1]

    @property
    def ids(self) -> np.ndarray:
        return self.icols[0]

    @property
    def group(self) -> np.ndarray:
        return self.icols[1]

    @property
    def timer(self) -> np.ndarray:
        return self.icols[2]

    def by_id(self, a: np.ndarray) -> np.ndarray:
        """Re-order a per-robot array (first axis) from storage order to id order."""
        out = np.empty_like(a)
        out[self.ids] = a
        return out

    def to_arrays(self) -> dict[str, np.ndarray]:
        """Arrays for a checkpoint (the generator's state is saved separately)."""
        return {
            "pos": self.pos,
            "fcols": self.fcols,
            "icols": self.icols,
            "vel": self.vel,
            "body_pos": self.body_pos,
            "body_force": self.body_force,
            "piston_pos": self.piston_pos,
            "piston_force": self.piston_force,
            "counters": self.counters,
            "step": np.array(self.step),
            "time": np.array(self.time),
        }

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray], rng: np.random.Generator) -> SwarmState:
        return cls(
            pos=np.ascontiguousarray(arrays["pos"]),
            fcols=np.ascontiguousarray(arrays["fcols"]),
            icols=np.ascontiguousarray(arrays["icols"]),
            vel=np.ascontiguousarray(arrays["vel"]),
            body_pos=np.array(arrays["body_pos"]),
            body_force=np.array(arrays["body_force"]),
            piston_pos=np.array(arrays["piston_pos"]),
            piston_force=np.array(arrays["piston_force"]),
            counters=np.array(arrays["counters"]),
            step=int(arrays["step"]),
            time=float(arrays["time"]),
            rng=rng,
        )


#: ``sensing(state, index) -> (zero_heading, light)`` for the robots at ``index``.
Sensing = Callable[[SwarmState, np.ndarray], tuple[np.ndarray, np.ndarray]]


def _default_sensing(state: SwarmState, index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.full(index.size, LIGHT_DIRECTION), np.ones(index.size)


class _Workspace:
    """Work arrays of the kernels, sized for one swarm (O(n + cells) memory)."""

    def __init__(self, world: World, params: EngineParams, n: int) -> None:
        r = params.radius
        x0, y0, x1, y1 = world.bounds
        area = (x1 - x0) * (y1 - y0)
        cs = params.cell_size or max(2 * r * (1 + params.skin), math.sqrt(area / max(n, 1)))
        # one extra cell of margin on every side: robots pressed into a wall stay in range
        self.x0 = x0 - cs
        self.y0 = y0 - cs
        self.cs = cs
        self.nx = int(math.ceil((x1 - x0) / cs)) + 2
        self.ny = int(math.ceil((y1 - y0) / cs)) + 2
        ncell = self.nx * self.ny
        if ncell > 50 * max(n, 1) + 10_000:
            raise ConfigError(
                f"grid of {ncell} cells is too large for {n} robots; increase cell_size"
            )
        self.cell = np.empty(n, np.int64)
        self.cell_start = np.zeros(ncell + 1, np.int64)
        self.perm = np.empty(n, np.int64)
        self.tmpf2 = np.empty((n, 2))
        self.tmpf = np.empty(n)
        self.tmpi = np.empty(n, np.int64)
        self.cell_flag = np.zeros(ncell, np.uint8)
        K.flag_cells_near(
            world.segments,
            world.static_discs,
            self.x0,
            self.y0,
            cs,
            self.nx,
            self.ny,
            r * (1 + params.skin),
            self.cell_flag,
        )
        nb, npis = len(world.bodies), len(world.pistons)
        self.brad = np.array([b.radius for b in world.bodies], dtype=np.float64)
        self.bdrag = np.array([b.drag / 1.0 for b in world.bodies], dtype=np.float64)
        self.bdisp = np.zeros((nb, 2))
        self.bshare = np.ones(nb)
        ps = world.pistons
        self.paxis = np.array([p.axis for p in ps], dtype=np.int64)
        self.pside = np.array([p.side for p in ps], dtype=np.float64)
        self.plo = np.array([p.lo for p in ps], dtype=np.float64)
        self.phi = np.array([p.hi for p in ps], dtype=np.float64)
        self.pdrag = np.array([p.drag for p in ps], dtype=np.float64)
        self.pforce_ext = np.array([p.force for p in ps], dtype=np.float64)
        self.plim_lo = np.array([p.limits[0] for p in ps], dtype=np.float64)
        self.plim_hi = np.array([p.limits[1] for p in ps], dtype=np.float64)
        self.pdisp = np.zeros(npis)
        self.pshare = np.ones(npis)

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes for a in vars(self).values() if isinstance(a, np.ndarray))


def place_lattice(
    bounds: tuple[float, float, float, float],
    n: int,
    radius: float,
    rng: np.random.Generator,
    *,
    inside: Callable[[np.ndarray], np.ndarray] | None = None,
    jitter: bool = True,
) -> np.ndarray:
    """Place ``n`` non-overlapping discs on a jittered triangular lattice (mm).

    The lattice spacing is the largest that gives at least ``n`` admissible sites in the
    rectangle ``bounds`` shrunk by ``radius`` (and satisfying ``inside(points)`` when given,
    which should also keep discs clear of walls); ``n`` sites are drawn at random and each
    is jittered inside the free space around it, so no two discs overlap.  Raises
    :class:`ConfigError` when ``n`` discs cannot be placed (packing fraction too high).
    """
    if n < 0:
        raise ConfigError(f"number of robots must be non-negative, got {n}")
    if n == 0:
        return np.zeros((0, 2))
    x0, y0, x1, y1 = bounds
    x0, y0, x1, y1 = x0 + radius, y0 + radius, x1 - radius, y1 - radius
    if x1 < x0 or y1 < y0:
        raise ConfigError(f"region {bounds} is smaller than one robot of radius {radius}")

    def sites(a: float) -> np.ndarray:
        dy = a * math.sqrt(3) / 2
        nyr = int(math.floor((y1 - y0) / dy)) + 1
        nxr = int(math.floor((x1 - x0) / a)) + 1
        if nxr * nyr > 50 * n + 1_000_000:
            return np.zeros((nxr * nyr, 2))  # plenty: only the count matters here
        gy, gx = np.mgrid[0:nyr, 0:nxr].astype(np.float64)
        px = x0 + gx * a + (gy % 2) * a / 2
        py = y0 + gy * dy
        pts = np.column_stack([px.ravel(), py.ravel()])
        pts = pts[(pts[:, 0] <= x1) & (pts[:, 1] <= y1)]
        if inside is not None and len(pts):
            pts = pts[inside(pts)]
        return pts

    d = 2 * radius
    hi = math.sqrt((x1 - x0 + d) * (y1 - y0 + d) * 2 / (math.sqrt(3) * n)) * 2 + d
    if len(sites(d * 1.0001)) < n:
        area = (bounds[2] - bounds[0]) * (bounds[3] - bounds[1])
        phi = n * math.pi * radius**2 / area
        raise ConfigError(
            f"cannot place {n} robots of radius {radius} mm in {bounds}: packing fraction "
            f"{phi:.3f} is above what fits (at most {len(sites(d * 1.0001))} robots)"
        )
    lo = d * 1.0001
    for _ in range(60):  # bisection on the spacing
        mid = 0.5 * (lo + hi)
        if len(sites(mid)) >= n:
            lo = mid
        else:
            hi = mid
    a = lo
    pts = sites(a)
    pick = rng.choice(len(pts), size=n, replace=False)
    pts = pts[np.sort(pick)]
    if jitter and a > d:
        room = 0.5 * (a - d) * 0.999
        rr = room * np.sqrt(rng.random(n))
        th = rng.uniform(0, 2 * np.pi, n)
        cand = pts + np.column_stack([rr * np.cos(th), rr * np.sin(th)])
        ok = (cand[:, 0] >= x0) & (cand[:, 0] <= x1) & (cand[:, 1] >= y0) & (cand[:, 1] <= y1)
        if inside is not None:
            ok &= inside(cand)
        pts[ok] = cand[ok]
    return pts


class Simulator:
    """``init`` and ``step`` for one world, parameter set, policy and sensing model.

    Build with :func:`simulator`.  ``step`` mutates the state's arrays in place (for
    speed with millions of robots) and returns the state.
    """

    def __init__(
        self,
        world: World,
        params: EngineParams,
        policy: Policy | None = None,
        sensing: Sensing | None = None,
    ) -> None:
        if params.mode == "overdamped" and policy is None:
            raise ConfigError("an overdamped (robot) simulation needs a policy")
        self.world = world
        self.params = params
        self.policy = policy
        self.sensing = sensing or _default_sensing
        self._ws: _Workspace | None = None

    # ------------------------------------------------------------------ init
    def init(
        self,
        positions: np.ndarray,
        rng: np.random.Generator,
        *,
        headings: np.ndarray | None = None,
        group: np.ndarray | None = None,
        velocities: np.ndarray | None = None,
    ) -> SwarmState:
        """A state with robots at ``positions`` (n, 2) mm.

        Overdamped: every robot takes its first decision at t = 0; with ``desync`` their
        next decisions are staggered uniformly over one control period.  Inertial:
        ``velocities`` (n, 2) mm/s are required.
        """
        pos = np.ascontiguousarray(positions, dtype=np.float64).reshape(-1, 2)
        n = pos.shape[0]
        if not np.all(np.isfinite(pos)):
            raise ConfigError("initial positions must be finite")
        fcols = np.zeros((2, n))
        fcols[0] = rng.uniform(-np.pi, np.pi, n) if headings is None else headings
        icols = np.zeros((3, n), np.int64)
        icols[0] = np.arange(n)
        if group is not None:
            icols[1] = np.asarray(group, dtype=np.int64)
        vel = np.zeros((n, 2))
        if self.params.mode == "inertial":
            if velocities is None:
                raise ConfigError("inertial mode needs initial velocities")
            vel[:] = velocities
        w = self.world
        state = SwarmState(
            pos=pos,
            fcols=fcols,
            icols=icols,
            vel=vel,
            body_pos=np.array([[b.x, b.y] for b in w.bodies], dtype=np.float64).reshape(-1, 2),
            body_force=np.zeros((len(w.bodies), 2)),
            piston_pos=np.array([p.position for p in w.pistons], dtype=np.float64),
            piston_force=np.zeros(len(w.pistons)),
            step=0,
            time=0.0,
            rng=rng,
        )
        self._ws = _Workspace(w, self.params, n)
        if self.params.mode == "overdamped":
            ts = self.params.tau_steps
            everyone = np.arange(n)
            self._decide(state, everyone)
            if self.params.desync:
                state.timer[:] = rng.integers(1, ts + 1, n)
            else:
                state.timer[:] = ts
        return state

    def workspace_bytes(self) -> int:
        return 0 if self._ws is None else self._ws.nbytes

    def _ensure_ws(self, state: SwarmState) -> _Workspace:
        if self._ws is None or self._ws.cell.shape[0] != state.n:
            self._ws = _Workspace(self.world, self.params, state.n)
        return self._ws

    # ------------------------------------------------------------------ step
    def _decide(self, state: SwarmState, index: np.ndarray) -> None:
        everyone = index.size == state.n  # then index is arange(n): use views, not copies
        sel = slice(None) if everyone else index
        zero, light = self.sensing(state, index)
        obs = Observation(
            time=state.time,
            index=index,
            tau=self.params.tau,
            ids=lambda: state.ids[sel],
            position=lambda: state.pos[sel],
            heading=lambda: state.heading[sel],
            speed=lambda: state.speed[sel],
            group=lambda: state.group[sel],
            zero_heading=np.asarray(zero, dtype=np.float64),
            light=np.asarray(light, dtype=np.float64),
        )
        act: Action = self.policy.act(obs, state.rng)  # type: ignore[union-attr]
        h = np.asarray(act.heading, dtype=np.float64)
        v = np.asarray(act.speed, dtype=np.float64)
        if h.shape != (index.size,) or v.shape != (index.size,):
            raise ValueError(
                f"policy returned shapes {h.shape}, {v.shape} for {index.size} robots"
            )
        if not (np.isfinite(h.sum()) and np.isfinite(v.sum()) and v.min(initial=0.0) >= 0):
            raise ValueError("policy returned a non-finite heading or a negative speed")
        state.heading[sel] = h
        state.speed[sel] = v

    def step(self, state: SwarmState) -> SwarmState:
        """Advance ``state`` by one time step ``dt``."""
        ws = self._ensure_ws(state)
        p = self.params
        if p.mode == "overdamped":
            due = np.flatnonzero(state.timer <= 0)
            if due.size == state.n:
                due = np.arange(state.n)
            if due.size:
                self._decide(state, due)
                state.timer[due] = p.tau_steps
            sweeps, seen = K.overdamped_step(
                state.pos,
                state.fcols[0],
                state.fcols[1],
                state.fcols,
                state.icols,
                2,
                ws.x0,
                ws.y0,
                ws.cs,
                ws.nx,
                ws.ny,
                ws.cell,
                ws.cell_start,
                ws.perm,
                ws.tmpf2,
                ws.tmpf,
                ws.tmpi,
                ws.tmpf2,
                ws.cell_flag,
                p.radius,
                p.drag,
                p.dt,
                p.iterations,
                p.max_iterations,
                p.overlap_tol * 2 * p.radius,
                p.relax,
                self.world.segments,
                self.world.static_discs,
                state.body_pos,
                ws.brad,
                ws.bdrag,
                ws.bdisp,
                ws.bshare,
                state.body_force,
                ws.paxis,
                state.piston_pos,
                ws.pside,
                ws.plo,
                ws.phi,
                ws.pdrag,
                ws.pforce_ext,
                ws.pdisp,
                ws.pshare,
                state.piston_force,
                ws.plim_lo,
                ws.plim_hi,
            )
            state.counters[0] += sweeps
            state.counters[1] = max(state.counters[1], int(seen * 1e6))
        else:
            K.inertial_step(
                state.pos,
                state.vel,
                state.fcols,
                state.icols,
                ws.x0,
                ws.y0,
                ws.cs,
                ws.nx,
                ws.ny,
                ws.cell,
                ws.cell_start,
                ws.perm,
                ws.tmpf2,
                ws.tmpf,
                ws.tmpi,
                p.radius,
                p.dt,
                self.world.segments,
                state.counters,
            )
        state.step += 1
        state.time = state.step * p.dt
        return state

    def max_overlap(self, state: SwarmState) -> float:
        """Largest overlap (mm) of any robot with anything, on the current configuration."""
        ws = self._ensure_ws(state)
        # the cell lists are built by the step; rebuild so this is valid at any time
        fc = np.zeros((0, state.n))
        ic = np.zeros((0, state.n), np.int64)
        pos = state.pos.copy()
        K.sort_by_cell(
            pos,
            fc,
            ic,
            ws.x0,
            ws.y0,
            1.0 / ws.cs,
            ws.nx,
            ws.ny,
            ws.cell,
            ws.cell_start,
            ws.perm,
            ws.tmpf2,
            ws.tmpf,
            ws.tmpi,
        )
        return float(
            K.max_overlap(
                pos,
                ws.cell_start,
                ws.x0,
                ws.y0,
                ws.cs,
                ws.nx,
                ws.ny,
                self.params.radius,
                self.world.segments,
                self.world.static_discs,
                state.body_pos,
                ws.brad,
                ws.paxis,
                state.piston_pos,
                ws.pside,
                ws.plo,
                ws.phi,
            )
        )


def simulator(
    world: World,
    params: EngineParams,
    policy: Policy | None = None,
    sensing: Sensing | None = None,
) -> tuple[Callable[..., SwarmState], Callable[[SwarmState], SwarmState]]:
    """``(init, step)`` functions for a world, parameters, policy and sensing model.

    Example
    -------
    >>> world = box_world(1000, 1000)
    >>> init, step = simulator(world, EngineParams(), BoltzmannUniform(kT=50.0))
    >>> rng = np.random.default_rng(1)
    >>> state = init(place_lattice(world.bounds, 100, 16.5, rng), rng)
    >>> for _ in range(10):
    ...     state = step(state)
    """
    sim = Simulator(world, params, policy, sensing)
    return sim.init, sim.step
