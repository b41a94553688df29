"""The GPU engine: the overdamped robot engine in numba-cuda (a CUDA GPU or its simulator).

:class:`GpuSimulator` has the interface of :class:`thermoswarm.sim.engine.Simulator`
(``init``, ``step``, ``max_overlap``, ``workspace_bytes``, ``world``, ``params``,
``policy``, ``sensing``) and the same physics, jams included (see
:mod:`thermoswarm.sim.engine`); the kernels and the data layout are in
:mod:`thermoswarm.sim.gpu.kernels`, the jam solve in
:mod:`thermoswarm.sim.gpu.kernels_gs`.

A step is two launches -- :func:`~thermoswarm.sim.gpu.kernels.begin_step` (decisions
and motion) and one cooperative launch of every Jacobi sweep
(:func:`~thermoswarm.sim.gpu.kernels.jacobi`) -- and one read back of the control
block (15 floats).  A grid rebuild adds one launch; a jam one more launch and one more
read back (a warm-started jam: the Gauss-Seidel launch instead of the Jacobi one).
:attr:`GpuSimulator.launches` counts the launches.

The state
---------
``init`` returns a :class:`~thermoswarm.sim.gpu.state.GpuSwarmState`, a
:class:`~thermoswarm.sim.engine.SwarmState` whose robot arrays live on the device.
Reading ``state.pos``, ``state.fcols``, ``state.icols`` or ``state.udir`` (or
``heading``, ``speed``, ``ids``, ``group``, ``timer``, ``by_id``, ``to_arrays``) copies
that array to the host once per step; if the host copy is changed in place, it is
copied back before the next step.  So scenarios, recorders and checkpoints work
unchanged, and a run that reads nothing per step (the benchmark) has no per-robot
transfer at all.  Bodies and force-driven walls (a few numbers) are copied both ways
every step when the world has any.  A plain ``SwarmState`` (a checkpoint) passed to
``step`` is moved onto the device.  The pushes a jammed step holds stay on the device
(a checkpoint does not carry them: a run resumed in a jam starts its next step cold).

Policies
--------
Algorithm 3 and 4 (:class:`~thermoswarm.policy.BoltzmannUniform`,
:class:`~thermoswarm.policy.ConnectedTransport`) with the default light direction run on
the device: their draws are made in ``begin_step`` (a counter-based hash generator,
keyed by one 31-bit integer drawn per step from the run's NumPy generator and by the
robot id), so their output never leaves the device.  Every other policy, and any
sensing model, runs on the host as on the CPU: each step the robots whose control
period ends are found from the timers (copied to the host), the policy sees exactly
the CPU engine's ``Observation``, and the new headings and speeds are copied back.

Precision: positions are float32 relative to the world's centre (rounding step
``|x| * 6e-8``: 0.006 mm at 100 m from the centre); contact arithmetic is float32.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from thermoswarm.errors import ConfigError
from thermoswarm.policy import Policy
from thermoswarm.sim import engine as E
from thermoswarm.sim import kernels as K
from thermoswarm.sim.engine import (
    LIGHT_DIRECTION,
    EngineParams,
    Sensing,
    SwarmState,
    policy_action,
)
from thermoswarm.sim.gpu import kernels as G
from thermoswarm.sim.gpu import kernels_gs as GS
from thermoswarm.sim.gpu.device import Device
from thermoswarm.sim.gpu.kernels_grid import rebuild as rebuild_kernel
from thermoswarm.sim.gpu.runtime import check_device, default_device, grid, simulated
from thermoswarm.sim.gpu.state import (
    ROBOT_FIELDS,
    GpuSwarmState,
    device_policy,
    pack_bodies,
    pack_pistons,
    wrap,
)
from thermoswarm.sim.world import World

__all__ = ["GpuSimulator", "GpuSwarmState", "default_device", "device_policy"]


class GpuSimulator:
    """The overdamped engine on a CUDA GPU (or numba-cuda's simulator); the interface
    of ``Simulator``.

    Parameters
    ----------
    world, params, policy, sensing
        As for :class:`thermoswarm.sim.engine.Simulator` (overdamped mode only).
    device : str, optional
        ``"cuda:0"`` or ``"simulator"`` (``"cpu"`` is a synonym); default
        :func:`default_device`, the only device the process can use (numba-cuda picks
        GPU or simulator once per process: :mod:`thermoswarm.sim.gpu.runtime`).
    host_policy : bool
        Run the policy on the host even when it has a device version (to measure what
        copying the decisions costs, or to compare).
    """

    def __init__(
        self,
        world: World,
        params: EngineParams,
        policy: Policy | None = None,
        sensing: Sensing | None = None,
        *,
        device: str | None = None,
        host_policy: bool = False,
    ) -> None:
        if params.mode != "overdamped":
            raise ConfigError(
                f"engine.backend = 'gpu' runs the overdamped (robot) mode only, got "
                f"mode = {params.mode!r}"
            )
        if policy is None:
            raise ConfigError("an overdamped (robot) simulation needs a policy")
        self.world = world
        self.params = params
        self.policy = policy
        self.sensing = sensing
        self.device = check_device(device)
        self._on_device = None if host_policy else device_policy(policy, sensing)
        self._dev: Device | None = None
        self._n = 0
        self._state: GpuSwarmState | None = None
        self._coop_cap: dict[Any, int] = {}
        self._tol = params.overlap_tol * 2 * params.radius
        self._half_skin = params.radius * params.skin
        self._held = False  # the last step ended with pushes held (a jam)
        #: kernel launches so far (:mod:`thermoswarm.sim.gpu.engine`: two a step)
        self.launches = 0
        #: control-block read backs so far (one a step, two in a cold jam)
        self.readbacks = 0
        #: grid rebuilds so far
        self.rebuilds = 0

    # ------------------------------------------------------------------ launches
    def _launch(self, kernel, dim: int, inputs: list[Any]) -> None:
        """Launch a grid-stride kernel over ``dim`` items (one thread if ``dim`` is 1)."""
        blocks, threads = (1, 1) if dim == 1 else grid(dim)
        self.launches += 1
        kernel[blocks, threads](*inputs)

    def _launch_coop(self, kernel, dim: int, inputs: list[Any]) -> None:
        """Launch a cooperative kernel (grid-wide barriers) over ``dim`` items: at most as
        many blocks as the device runs at once (a cooperative launch's condition)."""
        blocks, threads = grid(dim)
        if not simulated():
            cap = self._coop_cap.get(kernel)
            if cap is None:
                spec = kernel.specialize(*inputs)
                (kern,) = spec.overloads.values()
                cap = self._coop_cap[kernel] = max(1, kern.max_cooperative_grid_blocks(threads))
            blocks = min(blocks, cap)
        self.launches += 1
        kernel[blocks, threads](*inputs)

    # ------------------------------------------------------------------ transfers
    def _download(self, name: str) -> np.ndarray:
        d = self._dev
        assert d is not None
        if name == "pos":
            out = np.empty((self._n, 2))
            out[:, 0] = d.x[d.cur].copy_to_host()
            out[:, 1] = d.y[d.cur].copy_to_host()
            out += d.origin
            return out
        if name == "fcols":
            return np.stack([d.heading.copy_to_host(), d.speed.copy_to_host()]).astype(np.float64)
        if name == "icols":
            cols = (d.ids, d.group, d.timer)
            return np.stack([a.copy_to_host() for a in cols]).astype(np.int32)
        if name == "udir":
            h = d.heading.copy_to_host()
            return np.stack([np.cos(h), np.sin(h)]).astype(np.float32)
        raise KeyError(name)

    def _upload(self, name: str, value: np.ndarray) -> None:
        d = self._dev
        assert d is not None
        n = self._n
        if name == "pos":
            v = np.asarray(value, dtype=np.float64).reshape(n, 2) - d.origin
            d.x[d.cur].copy_to_device(np.ascontiguousarray(v[:, 0], np.float32))
            d.y[d.cur].copy_to_device(np.ascontiguousarray(v[:, 1], np.float32))
            d.need_rebuild = True  # the displacement bound no longer holds
        elif name == "fcols":
            v = np.asarray(value, dtype=np.float64).reshape(2, n)
            h = v[0]
            if h.size and float(np.abs(h).max()) > 64.0:  # keep float32 precision; as
                h = wrap(h)  # the CPU engine, wrap only large headings (exact round trip)
            d.heading.copy_to_device(np.ascontiguousarray(h, np.float32))
            d.speed.copy_to_device(np.ascontiguousarray(v[1], np.float32))
        elif name == "icols":
            v = np.asarray(value).reshape(3, n).astype(np.int32)
            d.ids.copy_to_device(np.ascontiguousarray(v[0]))
            d.group.copy_to_device(np.ascontiguousarray(v[1]))
            d.timer.copy_to_device(np.ascontiguousarray(v[2]))
        # udir is derived from the heading on the device

    def _sync_from_host(self, state: SwarmState) -> None:
        """Make ``state`` this simulator's device state and copy host changes over."""
        if not isinstance(state, GpuSwarmState) or state._sim is not self:
            self._adopt(state)
            return
        if state is not self._state:
            raise ValueError("this GPU state belongs to an earlier init of the simulator")
        host, snap = state._host, state._snap
        for name in ROBOT_FIELDS:
            if name in host and (name not in snap or not np.array_equal(host[name], snap[name])):
                self._upload(name, host[name])
        host.clear()
        snap.clear()
        self._upload_bodies(state)

    def _adopt(self, state: SwarmState) -> None:
        """Move a host state (a checkpoint, another simulator's state) onto this device,
        turning the object into a :class:`GpuSwarmState` in place (the caller keeps its
        reference, as with the CPU engine)."""
        arrays = {k: np.array(getattr(state, k)) for k in ("pos", "fcols", "icols")}
        n = arrays["pos"].shape[0]
        self._alloc(n)
        for k, v in arrays.items():
            self._upload(k, v)
        d = state.__dict__
        for k in (*ROBOT_FIELDS, "vel"):
            d.pop(k, None)
        d.pop("_sim", None)
        state.__class__ = GpuSwarmState
        d["_sim"] = self
        d["_host"] = {}
        d["_snap"] = {}
        state.vel = np.zeros((0, 2))
        state.bodies = np.array(state.bodies, dtype=np.float64)
        state.pistons = np.array(state.pistons, dtype=np.float64)
        state.counters = np.array(state.counters, dtype=np.int64)
        self._state = state  # type: ignore[assignment]
        self._upload_bodies(state)  # type: ignore[arg-type]
        self._rebuild()

    def _upload_bodies(self, state: SwarmState) -> None:
        d = self._dev
        if d is None or not d.has_bodies:
            return
        o = d.origin
        b = np.array(state.bodies, dtype=np.float64)
        if b.size:
            b[:, K.BX] -= o[0]
            b[:, K.BY] -= o[1]
            d.bodies.copy_to_device(np.ascontiguousarray(b, np.float32))
        p = np.array(state.pistons, dtype=np.float64)
        if p.size:
            for k in range(p.shape[0]):
                a = int(p[k, K.PA])
                p[k, [K.PP, K.PLL, K.PLH]] -= o[a]
                p[k, [K.PLO, K.PHI]] -= o[1 - a]
            d.pistons.copy_to_device(np.ascontiguousarray(p, np.float32))

    def _download_bodies(self, state: SwarmState) -> None:
        d = self._dev
        if d is None or not d.has_bodies:
            return
        o = d.origin
        if state.bodies.size:
            b = d.bodies.copy_to_host().astype(np.float64)
            b[:, K.BX] += o[0]
            b[:, K.BY] += o[1]
            state.bodies[:] = b
        if state.pistons.size:
            p = d.pistons.copy_to_host().astype(np.float64)
            for k in range(p.shape[0]):
                a = int(p[k, K.PA])
                p[k, [K.PP, K.PLL, K.PLH]] += o[a]
                p[k, [K.PLO, K.PHI]] += o[1 - a]
            state.pistons[:] = p

    # ------------------------------------------------------------------ grid
    def _alloc(self, n: int) -> None:
        if self._dev is None or self._n != n:
            self._dev = None  # free first: two swarms of 1e8 robots do not fit
            self._dev = Device(self, n)
            self._n = n
        self._held = False

    def _rebuild(self) -> None:
        """Sort the robots by grid cell (one cooperative launch: counting sort, stable),
        re-order every robot array (and the held pushes), and make the current positions
        the new build positions."""
        d = self._dev
        assert d is not None
        n = self._n
        self.rebuilds += 1
        if n:
            cur, oth = d.cur, 1 - d.cur
            self._launch_coop(rebuild_kernel, max(n, d.nx * d.ny + 1), [
                d.x[cur], d.y[cur], d.x[oth], d.y[oth], d.xr, d.yr, d.geo, d.nx, d.ny,
                d.keys, d.slot, d.cell_start, d.scan, d.perm, d.heading, d.speed,
                d.fscratch, d.fscratch2, d.timer, d.ids, d.group, d.keys, d.slot, d.iscratch,
                d.ctrl, float(oth),
            ])  # fmt: skip
            d.cur = oth
            d.heading, d.fscratch = d.fscratch, d.heading
            d.speed, d.fscratch2 = d.fscratch2, d.speed
            d.timer, d.keys = d.keys, d.timer
            d.ids, d.slot = d.slot, d.ids
            d.group, d.iscratch = d.iscratch, d.group
            if d.tables is not None and self._held:
                self._launch_coop(GS.gather_tables, n, [d.perm, d.keys, *d.tables,
                                                        *d.tables2])  # fmt: skip
                d.tables, d.tables2 = d.tables2, d.tables
        else:  # no robots: an empty grid, the displacement bounds restart
            d.cell_start.copy_to_device(np.zeros(d.nx * d.ny + 1, np.int32))
            for slot in (G.D_IN, G.D_OUT):
                self._launch(G.set_value, 1, [d.ctrl, slot, 0.0])
        d.need_rebuild = False

    # ------------------------------------------------------------------ init
    def init(
        self,
        positions: np.ndarray,
        rng: np.random.Generator,
        *,
        headings: np.ndarray | None = None,
        group: np.ndarray | None = None,
        velocities: np.ndarray | None = None,
    ) -> GpuSwarmState:
        """A state with robots at ``positions`` (n, 2) mm (see ``Simulator.init``)."""
        pos = np.ascontiguousarray(positions, dtype=np.float64).reshape(-1, 2)
        if not np.all(np.isfinite(pos)):
            raise ConfigError("initial positions must be finite")
        n = pos.shape[0]
        self._dev = None
        self._held = False
        self._alloc(n)
        fcols = np.zeros((2, n))
        fcols[0] = rng.uniform(-np.pi, np.pi, n) if headings is None else headings
        icols = np.zeros((3, n), np.int32)
        icols[0] = np.arange(n)
        if group is not None:
            icols[1] = np.asarray(group, dtype=np.int32)
        self._upload("pos", pos)
        self._upload("fcols", fcols)
        self._upload("icols", icols)
        state = GpuSwarmState(self, pack_bodies(self.world), pack_pistons(self.world), 0, 0.0,
                              rng, np.zeros(2, np.int64))  # fmt: skip
        self._state = state
        self._upload_bodies(state)
        self._decide_all(state)
        ts = self.params.tau_steps
        timers = rng.integers(1, ts + 1, n) if self.params.desync else np.full(n, ts)
        state.icols[2] = timers
        self._sync_from_host(state)
        self._rebuild()
        return state

    def workspace_bytes(self) -> int:
        """Bytes held on the device for this swarm (every array of the engine)."""
        return 0 if self._dev is None else self._dev.nbytes

    # ------------------------------------------------------------------ decisions
    def _decide_all(self, state: GpuSwarmState) -> None:
        if self._on_device is not None:
            self._begin_step(state, everyone=1, dt=0.0)
        else:
            self._decide(state, np.arange(state.n))

    def _begin_step(self, state: SwarmState, everyone: int, dt: float) -> None:
        """Decisions of the device policy (if any) and the commanded motion (``dt``)."""
        d = self._dev
        assert d is not None
        half_width, kT, half_normal = self._on_device or (0.0, 0.0, 0)
        draw = int(self._on_device is not None)
        key = int(state.rng.integers(0, 2**31 - 1)) if draw else 0
        self._launch(G.begin_step, self._n, [
            d.x[d.cur], d.y[d.cur], d.xr, d.yr, d.heading, d.speed, d.timer, d.ids, draw, key,
            float(LIGHT_DIRECTION), half_width, kT, half_normal, self.params.tau_steps,
            everyone, dt, d.ctrl,
        ])  # fmt: skip

    def _decide(self, state: GpuSwarmState, index: np.ndarray) -> None:
        """The host path: the CPU engine's observation, the policy, the checks."""
        everyone = index.size == state.n
        sel = slice(None) if everyone else index
        if self.sensing is None:
            zero = np.full(index.size, LIGHT_DIRECTION)
            light = np.ones(index.size)
        else:
            zero, light = self.sensing(state, index)
        h, v, _ = policy_action(self.policy, state, index, sel, zero, light,  # type: ignore[arg-type]
                                self.params.tau)  # fmt: skip
        state.fcols[0, sel] = h
        state.fcols[1, sel] = v

    # ------------------------------------------------------------------ step
    def step(self, state: SwarmState) -> SwarmState:
        """Advance ``state`` by one time step ``dt`` (in place; returns it)."""
        self._sync_from_host(state)
        gstate: GpuSwarmState = state  # type: ignore[assignment]
        d = self._dev
        assert d is not None
        p = self.params
        if self._on_device is not None:
            self._begin_step(gstate, everyone=0, dt=p.dt)
        else:
            due = np.flatnonzero(gstate.timer <= 0)
            if due.size:
                self._decide(gstate, due)
                gstate.timer[due] = p.tau_steps
            self._sync_from_host(gstate)
            self._begin_step(gstate, everyone=0, dt=p.dt)
        if d.need_rebuild:
            self._rebuild()
        c = self._solve()
        d.cur = int(c[G.CUR])
        gstate.counters[0] += int(c[G.SWEEPS])
        gstate.counters[1] = max(gstate.counters[1], int(float(c[G.LAST_SEEN]) * 1e6))
        if c[G.D_IN] > d.rebuild_at or c[G.D_OUT] > d.rebuild_at:
            d.need_rebuild = True
        self._download_bodies(gstate)
        gstate._host.clear()
        gstate._snap.clear()
        gstate.step += 1
        gstate.time = gstate.step * p.dt
        return gstate

    def _solve(self) -> np.ndarray:
        """The step's projection (see the module doc); returns the control block."""
        d = self._dev
        assert d is not None
        if self._held:  # the last step was jammed: warm-started passes, if still a jam
            c = self._gauss_seidel(GS.WARM)
            if c[G.STATUS] != G.COLD:
                return c
            self._held = False
            return self._jacobi(start=0)
        return self._jacobi(start=1)

    def _read(self) -> np.ndarray:
        d = self._dev
        assert d is not None
        self.readbacks += 1
        return d.ctrl.copy_to_host()

    def _jacobi(self, start: int) -> np.ndarray:
        d = self._dev
        assert d is not None
        p = self.params
        self._launch_coop(G.jacobi, self._n, [
            d.x[0], d.y[0], d.x[1], d.y[1], d.xr, d.yr, d.cell_start, d.cell_flag, d.nx,
            d.ny, d.geo, np.float32(0.5 * p.relax), d.seg, d.sdisc, d.bodies, d.pistons,
            d.acc, d.contact, d.moved, p.drag, p.dt, p.iterations, p.max_iterations,
            E.GS_AFTER, self._tol, start, d.ctrl,
        ])  # fmt: skip
        c = self._read()
        if c[G.STATUS] == G.JAM:
            d.alloc_tables()
            c = self._gauss_seidel(GS.COLD_START)
        return c

    def _gauss_seidel(self, mode: int) -> np.ndarray:
        """The Gauss-Seidel launch, again after each rebuild it asks for."""
        d = self._dev
        assert d is not None and d.tables is not None
        p = self.params
        warm = mode == GS.WARM
        while True:
            omega, blind = (E.WARM_OMEGA, E.WARM_BLIND) if warm else (E.OMEGA, 0)
            wall_omega = E.WARM_OMEGA if warm else E.WALL_OMEGA
            self._launch_coop(GS.gauss_seidel, max(self._n, d.nx * d.ny // 9 + 1), [
                d.x[0], d.y[0], d.x[1], d.y[1], d.xr, d.yr, d.cell_start, d.cell_flag, d.nx,
                d.ny, d.geo, d.seg, d.sdisc, d.bodies, d.pistons, d.acc, d.contact, d.moved,
                *d.tables, d.keys, p.drag, p.dt, omega, wall_omega, E.KEEP,
                self._half_skin**2, E.JAM_PUSH, blind, p.iterations, p.max_iterations,
                self._tol, E.SLACK * self._tol, mode, d.ctrl,
            ])  # fmt: skip
            c = self._read()
            self._held = c[G.STATUS] != G.COLD
            if c[G.STATUS] != G.REBUILD:
                return c
            d.cur = int(c[G.CUR])
            self._rebuild()
            mode = GS.RESUME

    def max_overlap(self, state: SwarmState) -> float:
        """Largest overlap (mm) of any robot with anything (exact: every pair is checked
        by the sweeps' search rule, which cannot miss one)."""
        self._sync_from_host(state)
        d = self._dev
        assert d is not None
        if d.need_rebuild:  # positions were set from the host: no displacement bound
            self._rebuild()
        self._launch(G.set_value, 1, [d.ctrl, G.OVERLAP, 0.0])
        if self._n:
            self._launch(G.max_overlap, self._n, [
                d.x[d.cur], d.y[d.cur], d.xr, d.yr, d.cell_start, d.nx, d.ny, d.geo, d.seg,
                d.sdisc, d.bodies, d.pistons, d.ctrl,
            ])  # fmt: skip
        return float(d.ctrl.copy_to_host()[G.OVERLAP])
