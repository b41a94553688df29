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
first moves by ``v dt``; then Jacobi sweeps remove overlaps.  In a sweep, each
overlapping robot pair moves apart by half the overlap each (``relax`` scales it), a
robot touching a static wall moves out by the whole overlap, and a robot touching a
movable body or a force-driven wall shares the overlap with it in proportion to the
mobilities (``1/drag``) -- which is exactly how an overdamped body of drag ``g_b`` pushed
by ``k`` robots of drag ``g_r`` moves: at ``k g_r v / (k g_r + g_b)``.  The contact force
that robots exert on a body or wall is ``g_r x (the correction the robots received) / dt``,
summed over the step; for a force-driven wall in steady state it balances the applied
force, which is how pressure is measured.

Jams: robots that keep pushing into a wall or a crowd need one Jacobi sweep per robot
layer of the pile for a push to cross it.  When :data:`GS_AFTER` sweeps have not
resolved a step, symmetric projected Gauss-Seidel passes take over (forward, then
backward in row order), over-relaxed (:data:`OMEGA`), with each contact's push
accumulated so that an overshoot is taken back.  The pushes a jammed step ends with
are kept (``state.held_pairs``), and the next step starts from them (a warm start,
:data:`KEEP`) if they carry a push through a pile (:data:`JAM_PUSH`): its passes are
over-relaxed less (:data:`WARM_OMEGA`) and the first :data:`WARM_BLIND` rounds go
unmeasured, and a steady jam then takes a few passes a step.  The contact force on a
body or piston is taken from the corrections its robots received in each pass.  The
result is the same on any number of threads.

Sweeping stops once the largest overlap is below ``overlap_tol`` (0.5 % of the diameter
by default).  The overlap each sweep measures is exact, and the step's result is the
configuration the last sweep measured, so the overlap the engine reports
(``state.counters[1]``) is the largest overlap actually left by any step.

Neighbour search: **Verlet lists with a skin** (see :mod:`thermoswarm.sim.kernels`).
Each robot's list holds the robots within ``2 r + skin`` of it when the list was built;
the lists are rebuilt as soon as any robot is more than ``skin / 2`` from where it was
then -- checked after the commanded motion *and after every sweep*, since the sweeps
move robots too.  Why this method: it cannot miss a pair (a pair farther apart than
``2 r + skin`` cannot close that gap while neither moves ``skin / 2``), at any density
and speed, and the lists survive several steps, so the cost of finding neighbours is
paid every few steps instead of every step.  (Lists rebuilt once per step without this
check missed pairs that came into contact during the sweeps: up to 8 % of the diameter
of overlap at packing fraction 0.7, unseen by the overlap counter.)

Time step: ``dt = 0.1 s`` by default.  At the paper's speeds (mean 10-20 mm/s; robots top
out near 33 mm/s) a robot moves a few mm per step.  Overlaps stay below 2 % of the
diameter at packing fractions up to 0.8 and mean speeds up to 33 mm/s at this ``dt``
(tested with an independent KD-tree check after every step, ``tests/sim``).  The control
period ``tau`` must be a multiple of ``dt``.

Why not soft springs: keeping overlaps below 2 % with springs needs a stiffness, and
hence a time step, an order of magnitude smaller; projection has no stiffness.

Threads: the kernels run on Numba's threads.  An explicit count -- :func:`set_threads`,
``numba.set_num_threads`` before the first step, ``thermoswarm bench --threads`` -- is
always respected; only when none was given does the engine choose (one thread below
:data:`SERIAL_BELOW` robots, where waking a second thread costs more than it saves).

Inertial mode (particles)
-------------------------
Elastic hard discs of equal mass: ballistic flight, and each overlapping approaching
pair is rewound to its moment of contact and exchanges normal velocities -- energy and
momentum are conserved to round-off.  This is the paper's "physical particles": its
speeds relax to the 2D Maxwell-Boltzmann (Rayleigh) law.

Units: mm, s; forces in units of the robot drag (``drag`` = 1: force = mm/s).
Angles: radians counter-clockwise from +x.  The light direction (heading 0 of the
paper) is +y unless a sensing model says otherwise.

Where the rest lives (every name re-exported here): the parameters and the state,
:mod:`thermoswarm.sim.state`; the thread count, :mod:`thermoswarm.sim.threads`; the
initial lattice, :mod:`thermoswarm.sim.placement`; the kernels,
:mod:`thermoswarm.sim.kernels` and its ``kernels_*`` modules.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numba
import numpy as np

from thermoswarm.errors import ConfigError
from thermoswarm.policy import Action, Observation, Policy
from thermoswarm.sim import kernels as K
from thermoswarm.sim.placement import place_lattice
from thermoswarm.sim.state import EngineParams, Sensing, SwarmState, pack_bodies, pack_pistons
from thermoswarm.sim.threads import SERIAL_BELOW, auto_threads, set_threads, threads_for
from thermoswarm.sim.world import World

__all__ = [
    "EngineParams",
    "SwarmState",
    "Sensing",
    "Simulator",
    "simulator",
    "place_lattice",
    "LIGHT_DIRECTION",
    "SERIAL_BELOW",
    "set_threads",
    "threads_for",
]

#: World-frame direction of heading 0 (towards the light) when no light model is set.
LIGHT_DIRECTION = math.pi / 2


def _unit_directions(
    heading: np.ndarray, out: np.ndarray | None = None, max_abs: float | None = None
) -> np.ndarray:
    """(2, m) float32 cos and sin of headings (into ``out`` when given).

    float32 because NumPy evaluates float32 sin/cos with SIMD, ~25x faster than float64
    here; the direction error (~3e-7) moves a robot ~1e-5 mm over a 10 s period.
    Headings are wrapped first when large, so that float32 keeps their precision.
    """
    h = np.asarray(heading, dtype=np.float32)
    if max_abs is None:
        max_abs = float(np.abs(h).max()) if h.size else 0.0
    if max_abs > 64.0:
        h = ((np.asarray(heading, dtype=np.float64) + np.pi) % (2 * np.pi) - np.pi).astype(
            np.float32
        )
    if out is None:
        out = np.empty((2, h.size), np.float32)
    np.cos(h, out=out[0])
    np.sin(h, out=out[1])
    return out


def _has_fast_path(policy: Policy | None) -> bool:
    """Whether ``policy.act_into`` (see :meth:`BoltzmannUniform.act_into`) stands for its
    ``act``: both defined by the same class (a subclass that overrides ``act`` alone
    takes the general path)."""

    def owner(name: str) -> type | None:
        return next((c for c in type(policy).__mro__ if name in vars(c)), None)

    return (
        policy is not None and owner("act_into") is not None and owner("act_into") is owner("act")
    )


_BROADCAST: dict[int, tuple[np.ndarray, np.ndarray]] = {}


def _default_sensing(state: SwarmState, index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    # read-only broadcast views: no memory per robot (cached: this runs every step)
    m = index.size
    views = _BROADCAST.get(m)
    if views is None:
        if len(_BROADCAST) > 64:
            _BROADCAST.clear()
        views = _BROADCAST[m] = (np.broadcast_to(LIGHT_DIRECTION, (m,)),
                                 np.broadcast_to(1.0, (m,)))  # fmt: skip
    return views


#: Over-relaxation of the Gauss-Seidel passes of a jammed step (robot pairs and walls):
#: projected successive over-relaxation converges for 0 < omega < 2, the fastest near
#: 2 / (1 + sin(pi / (2 L + 1))) for a chain of L robots pressed into a wall (1.7 for L
#: of 10).  On the mechanism study's jam (``benchmarks/engine_jam.py``, cold passes)
#: 1.7 made the fewest sweeps of 1.0, 1.5, 1.7, 1.8, 1.9 and 1.95.
OMEGA = 1.7
#: The same against static walls.
WALL_OMEGA = 1.7
#: Over-relaxation of a warm-started step's passes (robot pairs and walls).  The warm
#: start is close to the solution, and a smaller step overshoots it less: on the
#: mechanism study's jam (``benchmarks/engine_jam.py``, 400 s, seeds 0-3) 1.4 made the
#: fewest sweeps of 1.2-1.7 (1.2 let a step reach the sweep limit).
WARM_OMEGA = 1.4
#: Symmetric rounds (forward + backward pass) a warm-started step makes before its first
#: measure.  On that jam no warm step ended in fewer than 3 rounds, so the measures
#: before them were sweeps paid for nothing; 4 made fewer sweeps than 2 or 3 over
#: seeds 0-3 (a steady jam whose warm start is already converged pays 8 passes).
WARM_BLIND = 4
#: Jacobi sweeps a step without held pushes makes before the Gauss-Seidel passes take
#: over.  A free swarm never gets there (1,200 robots at packing 0.5, 10 mm/s, tau 0.1 s:
#: at most 10 sweeps in 1,500 steps), nor does a crowd pushing an object
#: (``transport-free``'s defaults: 13 a step on average): their steps are the parallel
#: Jacobi sweeps', bit for bit.  With 12, a third of that crowd's steps reached the
#: serial passes.
GS_AFTER = 40
#: A step is warm-started only if the largest push held exceeds this many times the
#: largest commanded displacement (a push carried through a pile of robots: a jam).  A
#: free swarm's occasional crowd, resolved by the passes, holds pushes of one or two
#: displacements, and its next step is cold again (else its passes would go on step
#: after step).  On the mechanism study's jam the ratio is 6.4-14 (5th-95th percentile).
JAM_PUSH = 3.0
#: Fraction of the last step's held pushes a jammed step starts from: pushes that only
#: cancel each other (self-stress, which a hyperstatic jam can build up without moving
#: anything) decay instead of growing step after step.
KEEP = 0.95
#: The Gauss-Seidel passes stop once no accumulated push exceeds what its contact
#: needs by more than this many times ``overlap_tol``.
SLACK = 1.0


def _held(
    state: SwarmState, ws: _Workspace, n_segments: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The state's held pushes (pairs, walls, wall indices), or empty arrays when there
    are none or they are of another shape or name walls this world does not have
    (another engine's: the step starts cold; the kernels index walls unchecked)."""
    n, cap = state.n, ws.neighbours.shape[1]
    ok = (
        state.held_pairs is not None and state.held_pairs.shape == (n, cap)
        and state.held_walls is not None and state.held_walls.shape == (2, n)
        and state.held_wall_ids is not None and state.held_wall_ids.shape == (2, n)
        and (n == 0 or (-1 <= int(state.held_wall_ids.min())  # -1: no wall held
                        and int(state.held_wall_ids.max()) < n_segments))
    )  # fmt: skip
    if not ok:
        return _NO_PAIRS, _NO_WALLS, _NO_IDS
    return state.held_pairs, state.held_walls, state.held_wall_ids


_NO_PAIRS = np.zeros((0, 0), np.float32)
_NO_WALLS = np.zeros((0, 0), np.float32)
_NO_IDS = np.zeros((0, 0), np.int32)


def neighbour_capacity(skin: float) -> int:
    """Neighbour-list capacity from geometry, for discs of diameter d listed within
    ``(1 + skin) d``: they fit in a circle of radius ``(1.5 + skin) d``, so there are at
    most ``0.9069 ((1.5 + skin) / 0.5)^2 - 1`` of them; and while ``1 + skin < sqrt(3)``
    they form one ring, at least ``2 asin(1 / (2 (1 + skin)))`` apart in angle.  Exceeded
    only with large overlaps; a robot whose list overflows is handled by scanning the grid.
    """
    cap = int(0.9069 * ((1.5 + skin) / 0.5) ** 2)
    if 1 + skin < math.sqrt(3):
        cap = min(cap, int(math.pi / math.asin(0.5 / (1 + skin))) + 1)
    return cap


class _Workspace:
    """Work arrays of the kernels, sized for one swarm (O(n + cells) memory)."""

    def __init__(self, world: World, params: EngineParams, n: int) -> None:
        r = params.radius
        x0, y0, x1, y1 = world.bounds
        area = (x1 - x0) * (y1 - y0)
        skin_mm = 2 * r * params.skin
        self.cutoff = 2 * r + skin_mm
        cs = params.cell_size or max(self.cutoff, math.sqrt(area / max(n, 1)))
        # one extra cell of margin on every side: robots pressed into a wall stay in range
        nx = int(math.ceil((x1 - x0) / cs)) + 2
        ny = int(math.ceil((y1 - y0) / cs)) + 2
        if nx * ny > 50 * max(n, 1) + 10_000:
            raise ConfigError(
                f"grid of {nx * ny} cells is too large for {n} robots; increase cell_size"
            )
        self.grid = K.Grid(x0 - cs, y0 - cs, float(cs), nx, ny)
        self.numerics = K.Numerics(
            radius=float(r), drag=float(params.drag), dt=float(params.dt),
            tol=params.overlap_tol * 2 * r, relax=float(params.relax),
            cutoff=float(self.cutoff), half_skin=0.5 * skin_mm,
            min_sweeps=params.iterations, max_sweeps=params.max_iterations,
            slack_tol=SLACK * params.overlap_tol * 2 * r,
            keep=KEEP,
        )  # fmt: skip
        ncell = nx * ny
        self.cell = np.empty(n, np.int32)  # each robot's cell when the lists were built
        self.cell_start = np.zeros(ncell + 1, np.int32)
        self.perm = np.empty(n, np.int32)  # rows in cell order
        # the sweeps' second position buffer (swapped with the state's), and the
        # scratch space of the re-sorting
        self.scratch = np.empty((n, 2))
        self.neighbours = np.empty((n, neighbour_capacity(params.skin)), np.int32)
        self.n_neighbours = np.zeros(n, np.int32)
        self.overflows = np.zeros(1, np.int64)  # robots whose list overflowed
        self.visits = np.empty((2, n), np.int32)  # the robots a sweep visits, and the next
        self.result = np.zeros(n, np.uint8)  # each visited robot: moved, overlapping
        # padded to a multiple of 8 bytes: kernels_sweep._collect_marked reads it by words
        self.mark = np.zeros(-(-max(n, 1) // 8) * 8, np.uint8)
        self.near_moved = np.zeros(n, np.uint8)  # near a body or piston that moved
        self.cell_near_static = np.zeros(ncell, np.uint8)
        K.flag_cells_near(world.segments, world.static_discs, self.grid, r + skin_mm,
                          self.cell_near_static)  # fmt: skip
        #: the ``ref`` array of the state whose lists these are (None: no lists yet)
        self.lists_of: np.ndarray | None = None

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes for a in vars(self).values() if isinstance(a, np.ndarray)) - (
            0 if self.lists_of is None else self.lists_of.nbytes
        )


def policy_action(
    policy: Policy, state: SwarmState, index: np.ndarray, sel: slice | np.ndarray,
    zero: np.ndarray | float, light: np.ndarray | float, tau: float,
) -> tuple[np.ndarray, np.ndarray, float]:  # fmt: skip
    """Ask ``policy`` for new headings and speeds of the robots at rows ``index``
    (``sel``: the same rows, ``slice(None)`` when every robot decides), given their
    ``zero`` heading and ``light``; the observation reads the state lazily.  Returns
    float64 ``(heading, speed, max |heading|)``, checked: one value per robot, finite,
    speeds >= 0 (a ``ValueError`` otherwise)."""
    obs = Observation(
        time=state.time,
        index=index,
        tau=tau,
        ids=lambda: state.ids[sel],
        position=lambda: state.pos[sel],
        heading=lambda: state.heading[sel],
        speed=lambda: state.speed[sel],
        group=lambda: state.group[sel],
        zero_heading=np.asarray(zero, dtype=np.float64),
        light=np.asarray(light, dtype=np.float64),
    )
    act: Action = policy.act(obs, state.rng)
    h = np.asarray(act.heading, dtype=np.float64)
    v = np.asarray(act.speed, dtype=np.float64)
    if h.shape != (index.size,) or v.shape != (index.size,):
        raise ValueError(f"policy returned shapes {h.shape}, {v.shape} for {index.size} robots")
    bad, max_abs = K.check_action(h, v)  # one pass: finite headings, speeds >= 0
    if bad:
        raise ValueError("policy returned a non-finite heading or a negative speed")
    return h, v, max_abs


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
        # the policy whose act_into() is the fast path (see _decide)
        self._fast_policy = policy if _has_fast_path(policy) else None
        self._ws: _Workspace | None = None
        #: neighbour-list builds so far (statistics: at step starts and within steps)
        self.list_builds = 0
        self._tau_steps = params.tau_steps

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
        fcols[K.HEADING] = rng.uniform(-np.pi, np.pi, n) if headings is None else headings
        udir = _unit_directions(fcols[K.HEADING])
        icols = np.zeros((3, n), np.int32)
        icols[0] = np.arange(n)
        if group is not None:
            icols[1] = np.asarray(group, dtype=np.int32)
        vel = np.zeros((0, 2))  # only the elastic mode has velocities
        if self.params.mode == "inertial":
            vel = np.zeros((n, 2))
            if velocities is None:
                raise ConfigError("inertial mode needs initial velocities")
            vel[:] = velocities
        w = self.world
        state = SwarmState(
            pos=pos, fcols=fcols, icols=icols, udir=udir, vel=vel, bodies=pack_bodies(w),
            pistons=pack_pistons(w), step=0, time=0.0, rng=rng,
        )  # fmt: skip
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
    def _decide(self, state: SwarmState, index: np.ndarray | None) -> None:
        """New headings and speeds for the robots at rows ``index`` (``arange(n)``, or
        ``None``: every robot)."""
        everyone = index is None or index.size == state.n  # then use views, not copies
        fast = self._fast_policy
        if fast is not None and self.policy is fast and self.sensing is _default_sensing:
            self._decide_fast(state, None if everyone else index)
            return
        if index is None:
            index = np.arange(state.n)
        sel = slice(None) if everyone else index
        zero, light = self.sensing(state, index)
        h, v, max_abs = policy_action(self.policy, state, index, sel, zero, light,
                                      self.params.tau)  # fmt: skip
        state.heading[sel] = h
        state.speed[sel] = v
        if everyone:
            _unit_directions(h, out=state.udir, max_abs=max_abs)  # in place: no temporaries
        else:
            state.udir[:, sel] = _unit_directions(h, max_abs=max_abs)

    def _decide_fast(self, state: SwarmState, index: np.ndarray | None) -> None:
        """:meth:`_decide` for a policy with ``act_into`` and the default sensing: the
        same draws and the same results, without the observation, the checks (the
        policy's own outputs are finite, speeds >= 0, headings within pi/2 +- pi) and
        the temporaries."""
        pol = self.policy
        if index is None:
            h = state.heading
            pol.act_into(state.rng, LIGHT_DIRECTION, h, state.speed)  # type: ignore[union-attr]
            # float32 cos/sin of the heading rounded to float32, as _unit_directions
            np.cos(h, out=state.udir[0], dtype=np.float32)
            np.sin(h, out=state.udir[1], dtype=np.float32)
            return
        m = index.size
        h = np.empty(m)
        v = np.empty(m)
        pol.act_into(state.rng, LIGHT_DIRECTION, h, v)  # type: ignore[union-attr]
        state.heading[index] = h
        state.speed[index] = v
        state.udir[:, index] = _unit_directions(h, max_abs=0.0)  # |h| < 2 pi: no wrapping

    def step(self, state: SwarmState) -> SwarmState:
        """Advance ``state`` by one time step ``dt``."""
        ws = self._ensure_ws(state)
        p = self.params
        w = self.world
        if p.mode == "overdamped":
            # the robots whose period is over (their timers refilled), then their decisions
            due, everyone = K.due_robots(state.icols[K.TIMER], self._tau_steps)
            if everyone:
                self._decide(state, None)
            elif due.size:
                self._decide(state, due)
            restore, serial = auto_threads(state.n)
            try:
                lam, lamw, lamid = _held(state, ws, len(self.world.segments))
                sweeps, overlap, builds, in_scratch, lam, lamw, lamid, held = K.overdamped_step(
                    state.pos, ws.scratch, state.ref, state.fcols, state.icols, state.udir,
                    lam, lamw, lamid, lam.shape[0] == state.n, ws.grid,
                    ws.numerics, OMEGA, WALL_OMEGA, WARM_OMEGA, WARM_BLIND, GS_AFTER, JAM_PUSH,
                    ws.lists_of is state.ref,
                    ws.cell,
                    ws.cell_start,
                    ws.perm, ws.neighbours, ws.n_neighbours, ws.overflows, ws.visits,
                    ws.result, ws.mark, ws.near_moved, ws.cell_near_static, w.segments,
                    w.static_discs, state.bodies, state.pistons, serial,
                )  # fmt: skip
            finally:
                if restore is not None:
                    numba.set_num_threads(restore)
            ws.lists_of = state.ref
            # the pushes a jammed step ended with travel with the state (None: not jammed)
            state.held_pairs = lam if held else None
            state.held_walls = lamw if held else None
            state.held_wall_ids = lamid if held else None
            if in_scratch:  # the final positions are in the second buffer: swap, no copy
                state.pos, ws.scratch = ws.scratch, state.pos
            self.list_builds += builds
            counters = state.counters
            counters[0] += sweeps
            top = int(overlap * 1e6)
            if top > counters[1]:
                counters[1] = top
        else:
            restore, _ = auto_threads(state.n)
            try:
                K.inertial_step(
                    state.pos, state.vel, state.fcols, state.icols, ws.grid, ws.cell,
                    ws.cell_start, ws.perm, ws.scratch, p.radius, p.dt,
                    w.segments, state.counters,
                )  # fmt: skip
            finally:
                if restore is not None:
                    numba.set_num_threads(restore)
        state.step += 1
        state.time = state.step * p.dt
        return state

    def max_overlap(self, state: SwarmState) -> float:
        """Largest overlap (mm) of any robot with anything, on the current configuration.

        An independent check: a fresh cell list of a sorted copy, every pair of
        neighbouring cells scanned (the step's own measure goes through its lists).
        """
        ws = self._ensure_ws(state)
        n = state.n
        pos = state.pos.copy()
        cell_start = np.zeros_like(ws.cell_start)
        K.sort_by_cell(pos, np.zeros((0, n)), np.zeros((0, n), np.int32), ws.grid,
                       np.empty(n, np.int32), cell_start, np.empty(n, np.int32),
                       np.empty((n, 2)))  # fmt: skip
        return float(
            K.max_overlap(
                pos,
                cell_start,
                ws.grid,
                self.params.radius,
                self.world.segments,
                self.world.static_discs,
                state.bodies,
                state.pistons,
            )  # fmt: skip
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
