"""The GPU backend of the overdamped engine (NVIDIA Warp; also runs on Warp's CPU device).

``GpuSimulator`` has the interface of :class:`thermoswarm.sim.engine.Simulator`; build
one with :func:`thermoswarm.sim.backend.make_simulator` (``backend="gpu"``).  Needs the
``gpu`` extra (``pip install 'thermoswarm[gpu]'``: ``warp-lang``).  Design, library
choice and measurements: ``docs/gpu.md``.
"""

from __future__ import annotations

from thermoswarm.errors import ConfigError

try:
    import warp  # noqa: F401
except ImportError:  # pragma: no cover - the gpu extra is part of `make install`
    raise ConfigError(
        "engine.backend = 'gpu' needs NVIDIA Warp: pip install 'thermoswarm[gpu]'"
    ) from None

from thermoswarm.sim.gpu.engine import GpuSimulator, GpuSwarmState, default_device, device_policy

__all__ = ["GpuSimulator", "GpuSwarmState", "default_device", "device_policy"]
