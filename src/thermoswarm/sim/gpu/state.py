"""The GPU engine's state on the host: a :class:`~thermoswarm.sim.engine.SwarmState`
whose robot arrays live on the device (see :mod:`thermoswarm.sim.gpu.engine`)."""

from __future__ import annotations

from typing import Any

import numpy as np

from thermoswarm.policy import BoltzmannUniform, ConnectedTransport, Policy
from thermoswarm.sim import kernels as K
from thermoswarm.sim.engine import Sensing, SwarmState
from thermoswarm.sim.world import World

__all__ = ["GpuSwarmState", "ROBOT_FIELDS", "device_policy"]

ROBOT_FIELDS = ("pos", "fcols", "icols", "udir")


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


def pack_bodies(world: World) -> np.ndarray:
    out = np.zeros((len(world.bodies), K.B_COLS))
    for k, b in enumerate(world.bodies):
        out[k, [K.BX, K.BY, K.BR, K.BDRAG, K.BSH]] = b.x, b.y, b.radius, b.drag, 1.0
        out[k, [K.BFX, K.BFY]] = b.force
    return out


def pack_pistons(world: World) -> np.ndarray:
    out = np.zeros((len(world.pistons), K.P_COLS))
    for k, p in enumerate(world.pistons):
        out[k, [K.PA, K.PP, K.PS, K.PLO, K.PHI, K.PDRAG, K.PF, K.PLL, K.PLH, K.PSH]] = (
            p.axis, p.position, p.side, p.lo, p.hi, p.drag, p.force, p.limits[0],
            p.limits[1], 1.0,
        )  # fmt: skip
    return out


def wrap(h: np.ndarray) -> np.ndarray:
    return (h + np.pi) % (2 * np.pi) - np.pi


class GpuSwarmState(SwarmState):
    """A :class:`SwarmState` whose robot arrays live on the device (see the module doc).

    Do not construct directly: :meth:`GpuSimulator.init` returns one.
    """

    def __init__(self, sim: Any, bodies, pistons, step, time, rng, counters) -> None:
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


for _name in ROBOT_FIELDS:
    setattr(GpuSwarmState, _name, _robot_property(_name))
