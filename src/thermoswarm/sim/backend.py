"""Choose the engine's backend: the CPU engine (Numba) or the GPU engine (numba-cuda).

``make_simulator(world, params, policy, sensing, backend="gpu")`` returns a
:class:`thermoswarm.sim.gpu.GpuSimulator`, which has the interface of
:class:`thermoswarm.sim.engine.Simulator`; scenarios take the backend from
``[engine] backend`` (``--set engine.backend="gpu"``).
"""

from __future__ import annotations

from typing import Any

from thermoswarm.errors import ConfigError
from thermoswarm.policy import Policy
from thermoswarm.sim.engine import EngineParams, Sensing, Simulator
from thermoswarm.sim.world import World

__all__ = ["BACKENDS", "make_simulator"]

#: ``"cpu"``: the Numba engine; ``"gpu"``: the numba-cuda engine (a CUDA GPU when a
#: driver is present, else numba-cuda's simulator).
BACKENDS = ("cpu", "gpu")


def make_simulator(
    world: World,
    params: EngineParams,
    policy: Policy | None = None,
    sensing: Sensing | None = None,
    *,
    backend: str = "cpu",
    device: str | None = None,
) -> Any:
    """A simulator for ``backend`` (``device``: the GPU backend's device, see
    :mod:`thermoswarm.sim.gpu.runtime`)."""
    if backend == "cpu":
        return Simulator(world, params, policy, sensing)
    if backend == "gpu":
        from thermoswarm.sim.gpu import GpuSimulator

        return GpuSimulator(world, params, policy, sensing, device=device)
    raise ConfigError(
        f"engine.backend must be one of {', '.join(map(repr, BACKENDS))}, got {backend!r}"
    )
