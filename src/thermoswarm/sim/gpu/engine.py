"""The GPU engine: the overdamped robot engine in numba-cuda (a CUDA GPU or its simulator).

:class:`GpuSimulator` has the interface of :class:`thermoswarm.sim.engine.Simulator`
(``init``, ``step``, ``max_overlap``, ``workspace_bytes``, ``world``, ``params``,
``policy``, ``sensing``) and the same physics (see :mod:`thermoswarm.sim.engine`); the
kernels and the data layout are in :mod:`thermoswarm.sim.gpu.kernels`.

The state
---------
``init`` returns a :class:`GpuSwarmState`, a :class:`~thermoswarm.sim.engine.SwarmState`
whose robot arrays live on the device.  Reading ``state.pos``, ``state.fcols``,
``state.icols`` or ``state.udir`` (or ``heading``, ``speed``, ``ids``, ``group``,
``timer``, ``by_id``, ``to_arrays``) copies that array to the host once per step; if
the host copy is changed in place, it is copied back before the next step.  So
scenarios, recorders and checkpoints work unchanged, and a run that reads nothing per
step (the benchmark) has no per-robot transfer at all.  Bodies and force-driven walls
(a few numbers) are copied both ways every step when the world has any, so that
``state.body_force``, ``state.piston_force`` and a scenario's changes to them behave as
on the CPU.  A plain ``SwarmState`` (a checkpoint) passed to ``step`` is moved onto the
device.

Policies
--------
Algorithm 3 and 4 (:class:`~thermoswarm.policy.BoltzmannUniform`,
:class:`~thermoswarm.policy.ConnectedTransport`) with the default light direction run on
the device: their draws are made by a kernel (a counter-based hash generator, keyed by one 31-bit
integer drawn per step from the run's NumPy generator and by the robot id),
so their output never leaves the device.  Every other policy, and any sensing model
(light field, shadows, photoresistors), runs on the host as on the CPU: each step the
robots whose control period ends are found from the timers (copied to the host), the
policy sees exactly the CPU engine's ``Observation``, and the new headings and speeds
are copied back.

Precision: positions are float32 relative to the world's centre (rounding step
``|x| * 6e-8``: 0.006 mm at 100 m from the centre); contact arithmetic is float32.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from thermoswarm.errors import ConfigError
from thermoswarm.policy import (
    BoltzmannUniform,
    ConnectedTransport,
    Policy,
)
from thermoswarm.sim import kernels as K
from thermoswarm.sim.engine import (
    LIGHT_DIRECTION,
    EngineParams,
    Sensing,
    SwarmState,
    policy_action,
)
from thermoswarm.sim.gpu import kernels as G
from thermoswarm.sim.gpu.runtime import check_device, cuda, default_device, grid
from thermoswarm.sim.world import World

__all__ = ["GpuSimulator", "GpuSwarmState", "default_device", "device_policy"]

_ROBOT_FIELDS = ("pos", "fcols", "icols", "udir")
SCAN_CHUNK = 256  # entries per thread of the prefix sum over grid cells


def device_policy(
    policy: Policy | None, sensing: Sensing | None
) -> tuple[float, float, int] | None:
    """``(half_width, kT, half_normal)`` when the policy runs on the device, else None.

    Device policies: Algorithm 3 and 4 (a uniform heading about the light direction, a
    speed at one temperature) with the default sensing (light direction +y, full light).
    """
    if sensing is not None or type(policy) not in (BoltzmannUniform, ConnectedTransport):
        return None
    return (
        float(policy.half_width),  # type: ignore[union-attr]
        float(policy.kT),  # type: ignore[union-attr]
        int(policy.speed_law == "half-normal"),  # type: ignore[union-attr]
    )


def _pack_bodies(world: World) -> np.ndarray:
    out = np.zeros((len(world.bodies), K.B_COLS))
    for k, b in enumerate(world.bodies):
        out[k, [K.BX, K.BY, K.BR, K.BDRAG, K.BSH]] = b.x, b.y, b.radius, b.drag, 1.0
        out[k, [K.BFX, K.BFY]] = b.force
    return out


def _pack_pistons(world: World) -> np.ndarray:
    out = np.zeros((len(world.pistons), K.P_COLS))
    for k, p in enumerate(world.pistons):
        out[k, [K.PA, K.PP, K.PS, K.PLO, K.PHI, K.PDRAG, K.PF, K.PLL, K.PLH, K.PSH]] = (
            p.axis, p.position, p.side, p.lo, p.hi, p.drag, p.force, p.limits[0],
            p.limits[1], 1.0,
        )  # fmt: skip
    return out


def _wrap(h: np.ndarray) -> np.ndarray:
    return (h + np.pi) % (2 * np.pi) - np.pi


class GpuSwarmState(SwarmState):
    """A :class:`SwarmState` whose robot arrays live on the device (see the module doc).

    Do not construct directly: :meth:`GpuSimulator.init` returns one.
    """

    def __init__(self, sim: GpuSimulator, bodies, pistons, step, time, rng, counters) -> None:
        # not the dataclass __init__: the robot arrays are properties backed by the device
        self.__dict__["_sim"] = sim
        self.__dict__["_host"] = {}
        self.__dict__["_snap"] = {}
        self.vel = np.zeros((0, 2))
        self.bodies = bodies
        self.pistons = pistons
        self.step = step
        self.time = time
        self.rng = rng
        self.counters = counters

    @property
    def n(self) -> int:
        return self._sim._n

    def to_arrays(self) -> dict[str, np.ndarray]:
        # a checkpoint rebuilds the grid first, so that a run resumed from it (which
        # builds its grid from these arrays) repeats the uninterrupted run exactly
        self._sim._sync_from_host(self)
        self._sim._rebuild()
        arrays = super().to_arrays()
        del arrays["ref"]  # the device keeps its own grid, rebuilt above
        return arrays


def _robot_property(name: str) -> property:
    def get(self: GpuSwarmState) -> np.ndarray:
        host = self._host
        if name not in host:
            host[name] = self._sim._download(name)
            self._snap[name] = host[name].copy()
        return host[name]

    def set_(self: GpuSwarmState, value: np.ndarray) -> None:
        self._host[name] = np.asarray(value)
        self._snap.pop(name, None)  # replaced: always copied back

    return property(get, set_, doc=f"``{name}`` (copied from the device on first read)")


for _name in _ROBOT_FIELDS:
    setattr(GpuSwarmState, _name, _robot_property(_name))


class _Device:
    """The device arrays of one swarm (struct of arrays, float32 positions)."""

    def __init__(self, sim: GpuSimulator, n: int) -> None:
        p = sim.params
        w = sim.world
        r = p.radius
        x0, y0, x1, y1 = w.bounds
        self.origin = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
        area = (x1 - x0) * (y1 - y0)
        cutoff = 2 * r * (1 + p.skin)
        cs = p.cell_size or max(cutoff, math.sqrt(area / max(n, 1)))
        self.cs = cs
        self.nx = int(math.ceil((x1 - x0) / cs)) + 2  # one cell of margin on every side
        self.ny = int(math.ceil((y1 - y0) / cs)) + 2
        ncell = self.nx * self.ny
        if ncell > 50 * max(n, 1) + 10_000:
            raise ConfigError(
                f"grid of {ncell} cells is too large for {n} robots; increase cell_size"
            )
        gx0 = x0 - cs - self.origin[0]
        gy0 = y0 - cs - self.origin[1]
        self.gx0, self.gy0 = gx0, gy0
        eps = 1e-3
        # rebuild once a robot may have moved so far that one ring no longer suffices
        self.rebuild_at = max(0.0, (cs / (1 + eps) - 2 * r) / 2)

        def z(shape, dtype):
            return cuda.to_device(np.zeros(shape, dtype))

        f4, i4 = np.float32, np.int32
        self.x = [z(n, f4), z(n, f4)]
        self.y = [z(n, f4), z(n, f4)]
        self.cur = 0
        self.xr = z(n, f4)
        self.yr = z(n, f4)
        self.heading = z(n, f4)
        self.speed = z(n, f4)
        self.timer = z(n, i4)
        self.ids = z(n, i4)
        self.group = z(n, i4)
        # counting-sort buffers (cell, rank in cell, permutation), scratch otherwise
        self.keys = z(n, i4)
        self.slot = z(n, i4)
        self.perm = z(n, i4)
        self.fscratch = z(n, f4)
        self.cell_start = z(ncell + 1, i4)
        self.scan = []  # the prefix sum's chunk sums, one array per level
        m = ncell + 1
        while m > SCAN_CHUNK:
            m = -(-m // SCAN_CHUNK)
            self.scan.append(z(m, i4))
        self.cell_flag = cuda.to_device(self._cell_flags(w, r * (1 + p.skin)))
        self.geo = cuda.to_device(np.array([gx0, gy0, cs, r, eps], f4))
        self.ctrl_f = z(G.N_CTRL_F, f4)
        self.ctrl_i = z(G.N_CTRL_I, i4)
        o = self.origin
        seg = w.segments - np.concatenate([o, o])
        self.seg = cuda.to_device(np.ascontiguousarray(seg.astype(f4).reshape(-1, 4)))
        sd = w.static_discs.copy()
        sd[:, :2] -= o
        self.sdisc = cuda.to_device(np.ascontiguousarray(sd.astype(f4).reshape(-1, 3)))
        nb, npis = len(w.bodies), len(w.pistons)
        self.bodies = z((nb, K.B_COLS), f4)
        self.pistons = z((npis, K.P_COLS), f4)
        self.acc_b = z((nb, 3), np.float64)
        self.acc_p = z((npis, 2), np.float64)
        self.has_bodies = nb + npis > 0
        self.need_rebuild = True

    def _cell_flags(self, w: World, reach: float) -> np.ndarray:
        """1 for the cells within ``reach`` of a static segment or disc (the CPU
        engine's rule): robots elsewhere skip the static geometry."""
        nx, ny, cs = self.nx, self.ny, self.cs
        gx0 = self.gx0 + self.origin[0]
        gy0 = self.gy0 + self.origin[1]
        flags = np.zeros((ny, nx), np.uint8)
        half_diag = 0.7072 * cs
        for xa, ya, xb, yb in w.segments:
            lo_x, hi_x = min(xa, xb) - reach, max(xa, xb) + reach
            lo_y, hi_y = min(ya, yb) - reach, max(ya, yb) + reach
            i0 = max(0, int(math.floor((lo_x - gx0) / cs)))
            i1 = min(nx - 1, int(math.floor((hi_x - gx0) / cs)))
            j0 = max(0, int(math.floor((lo_y - gy0) / cs)))
            j1 = min(ny - 1, int(math.floor((hi_y - gy0) / cs)))
            if i1 < i0 or j1 < j0:
                continue
            mx = gx0 + (np.arange(i0, i1 + 1) + 0.5) * cs
            my = gy0 + (np.arange(j0, j1 + 1) + 0.5) * cs
            MX, MY = np.meshgrid(mx, my)
            ex, ey = xb - xa, yb - ya
            l2 = ex * ex + ey * ey
            t = np.clip(((MX - xa) * ex + (MY - ya) * ey) / l2, 0, 1) if l2 > 0 else 0.0
            d = np.hypot(MX - (xa + t * ex), MY - (ya + t * ey))
            flags[j0 : j1 + 1, i0 : i1 + 1] |= (d < reach + half_diag).astype(np.uint8)
        for sx, sy, sr in w.static_discs:
            R = sr + reach
            i0 = max(0, int(math.floor((sx - R - gx0) / cs)))
            i1 = min(nx - 1, int(math.floor((sx + R - gx0) / cs)))
            j0 = max(0, int(math.floor((sy - R - gy0) / cs)))
            j1 = min(ny - 1, int(math.floor((sy + R - gy0) / cs)))
            flags[j0 : j1 + 1, i0 : i1 + 1] = 1
        return flags.ravel()

    @property
    def nbytes(self) -> int:
        total = 0
        for v in vars(self).values():
            for a in v if isinstance(v, list) else [v]:
                if hasattr(a, "copy_to_host"):  # a device array
                    total += a.size * a.dtype.itemsize
        return total


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
        self._dev: _Device | None = None
        self._n = 0
        self._state: GpuSwarmState | None = None
        self._batch = max(params.iterations, 2)

    # ------------------------------------------------------------------ transfers
    def _launch(self, kernel, dim: int, inputs: list[Any]) -> None:
        """Launch a grid-stride kernel over ``dim`` items (one thread if ``dim`` is 1)."""
        blocks, threads = (1, 1) if dim == 1 else grid(dim)
        kernel[blocks, threads](*inputs)

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
                h = _wrap(h)  # the CPU engine, wrap only large headings (exact round trip)
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
        for name in _ROBOT_FIELDS:
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
        for k in (*_ROBOT_FIELDS, "vel"):
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
            self._dev = _Device(self, n)
            self._n = n

    def _rebuild(self) -> None:
        """Sort the robots by grid cell (counting sort, stable), re-order every robot
        array, and make the current positions the new build positions."""
        d = self._dev
        assert d is not None
        n, ncell = self._n, d.nx * d.ny
        self._launch(G.fill_int, ncell + 1, [d.cell_start, 0])
        if n:
            cur, oth = d.cur, 1 - d.cur
            self._launch(G.cell_keys, n, [d.x[cur], d.y[cur], d.geo, d.nx, d.ny, d.keys,
                                          d.slot, d.cell_start])  # fmt: skip
            self._scan(d.cell_start, ncell + 1, 0)  # counts -> starts; the last is n
            self._launch(G.scatter, n, [d.keys, d.slot, d.cell_start, d.perm])
            self._launch(G.order_cells, ncell, [d.cell_start, d.perm])
            self._launch(G.gather_xy, n, [d.perm, d.x[cur], d.y[cur], d.x[oth], d.y[oth],
                                          d.xr, d.yr])  # fmt: skip
            d.cur = oth
            # gather into a scratch array, then swap the two (no copy back)
            self._launch(G.gather, n, [d.perm, d.heading, d.fscratch])
            d.heading, d.fscratch = d.fscratch, d.heading
            self._launch(G.gather, n, [d.perm, d.speed, d.fscratch])
            d.speed, d.fscratch = d.fscratch, d.speed
            for name in ("timer", "ids", "group"):
                self._launch(G.gather, n, [d.perm, getattr(d, name), d.keys])
                old = getattr(d, name)
                setattr(d, name, d.keys)
                d.keys = old
        for slot in (G.D_IN, G.D_OUT):
            self._launch(G.set_float, 1, [d.ctrl_f, slot, 0.0])
        d.need_rebuild = False

    def _scan(self, a, m: int, level: int) -> None:
        """Exclusive prefix sum of ``a[:m]`` in place: chunk sums, their prefix sum (the
        same, one level up), then each chunk's own prefix."""
        d = self._dev
        assert d is not None
        if m <= SCAN_CHUNK:
            self._launch(G.scan_serial, 1, [a, m])
            return
        sums = d.scan[level]
        nch = sums.shape[0]
        self._launch(G.chunk_sums, nch, [a, m, SCAN_CHUNK, sums])
        self._scan(sums, nch, level + 1)
        self._launch(G.chunk_apply, nch, [a, m, SCAN_CHUNK, sums])

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
        state = GpuSwarmState(self, _pack_bodies(self.world), _pack_pistons(self.world), 0, 0.0,
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
            self._decide_device(state, everyone=1)
        else:
            self._decide(state, np.arange(state.n))

    def _decide_device(self, state: SwarmState, everyone: int) -> None:
        d = self._dev
        assert d is not None and self._on_device is not None
        half_width, kT, half_normal = self._on_device
        key = int(state.rng.integers(0, 2**31 - 1))
        self._launch(G.decide_uniform, self._n, [
            d.heading, d.speed, d.timer, d.ids, key, float(LIGHT_DIRECTION), half_width, kT,
            half_normal, self.params.tau_steps, everyone,
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
        n = self._n
        if self._on_device is not None:
            self._decide_device(gstate, everyone=0)
        else:
            due = np.flatnonzero(gstate.timer <= 0)
            if due.size:
                self._decide(gstate, due)
                gstate.timer[due] = p.tau_steps
            self._sync_from_host(gstate)
        self._launch(G.predict, n, [d.x[d.cur], d.y[d.cur], d.xr, d.yr, d.heading, d.speed,
                                    d.timer, p.dt, d.ctrl_f])  # fmt: skip
        if d.need_rebuild:
            self._rebuild()
        self._launch(G.move_bodies_external, 1,
                     [d.bodies, d.pistons, d.seg, d.sdisc, p.dt, d.ctrl_f, d.ctrl_i])  # fmt: skip
        tol = p.overlap_tol * 2 * p.radius
        cur0 = d.cur
        launched = 0
        while True:
            batch = min(self._batch, p.max_iterations) if launched == 0 else launched
            batch = min(batch, p.max_iterations - launched)
            for _ in range(batch):
                src = (cur0 + launched) % 2
                if d.has_bodies:
                    self._launch(G.contacts_with_bodies, n, [
                        d.x[src], d.y[src], p.radius, d.bodies, d.pistons, d.acc_b, d.acc_p,
                        d.ctrl_i,
                    ])  # fmt: skip
                    self._launch(G.solve_bodies, 1, [d.bodies, d.pistons, d.acc_b, d.acc_p,
                                                     p.drag, p.dt, d.ctrl_i])  # fmt: skip
                self._launch(G.sweep, n, [
                    d.x[src], d.y[src], d.x[1 - src], d.y[1 - src], d.xr, d.yr, d.cell_start,
                    d.cell_flag, d.nx, d.ny, d.geo, p.relax, d.seg, d.sdisc, d.bodies,
                    d.pistons, d.ctrl_f, d.ctrl_i,
                ])  # fmt: skip
                self._launch(G.end_sweep, 1, [d.bodies, d.pistons, d.seg, d.sdisc,
                                              p.iterations, p.max_iterations, tol, d.ctrl_f,
                                              d.ctrl_i])  # fmt: skip
                launched += 1
            ci = d.ctrl_i.copy_to_host()  # the step's one read back (more only if not converged)
            if ci[G.DONE] or launched >= p.max_iterations:
                break
        cf = d.ctrl_f.copy_to_host()
        sweeps = int(ci[G.SWEEPS])
        d.cur = (cur0 + sweeps) % 2
        # next step's first batch: what this one needed (no extra read back if steady)
        self._batch = max(p.iterations, sweeps)
        gstate.counters[0] += sweeps
        gstate.counters[1] = max(gstate.counters[1], int(float(cf[G.LAST_SEEN]) * 1e6))
        if cf[G.D_IN] > d.rebuild_at or cf[G.D_OUT] > d.rebuild_at:
            d.need_rebuild = True
        self._download_bodies(gstate)
        gstate._host.clear()
        gstate._snap.clear()
        gstate.step += 1
        gstate.time = gstate.step * p.dt
        return gstate

    def max_overlap(self, state: SwarmState) -> float:
        """Largest overlap (mm) of any robot with anything (exact: every pair is checked
        by the sweeps' search rule, which cannot miss one)."""
        self._sync_from_host(state)
        d = self._dev
        assert d is not None
        if d.need_rebuild:  # positions were set from the host: no displacement bound
            self._rebuild()
        self._launch(G.set_float, 1, [d.ctrl_f, G.OVERLAP, 0.0])
        if self._n:
            self._launch(G.max_overlap, self._n, [
                d.x[d.cur], d.y[d.cur], d.xr, d.yr, d.cell_start, d.nx, d.ny, d.geo, d.seg,
                d.sdisc, d.bodies, d.pistons, d.ctrl_f,
            ])  # fmt: skip
        return float(d.ctrl_f.copy_to_host()[G.OVERLAP])
