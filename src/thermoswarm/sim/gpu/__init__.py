"""The GPU backend of the overdamped engine (numba-cuda: a CUDA GPU, or its simulator).

``GpuSimulator`` has the interface of :class:`thermoswarm.sim.engine.Simulator`; build
one with :func:`thermoswarm.sim.backend.make_simulator` (``backend="gpu"``).  Needs the
``gpu`` extra (``pip install 'thermoswarm[gpu]'``: ``numba-cuda``).  Without a CUDA
driver the kernels run in numba-cuda's simulator (slow: for tests); see
:mod:`thermoswarm.sim.gpu.runtime`.  Design, library choice and measurements:
``docs/gpu.md``.
"""

from __future__ import annotations

from thermoswarm.errors import ConfigError

try:
    from thermoswarm.sim.gpu import runtime  # noqa: F401  (picks GPU or simulator)
except ImportError:  # pragma: no cover - the gpu extra is part of `make install`
    raise ConfigError(
        "engine.backend = 'gpu' needs numba-cuda: pip install 'thermoswarm[gpu]'"
    ) from None

from thermoswarm.sim.gpu.engine import GpuSimulator, GpuSwarmState, device_policy
from thermoswarm.sim.gpu.runtime import default_device

__all__ = ["GpuSimulator", "GpuSwarmState", "default_device", "device_policy"]
