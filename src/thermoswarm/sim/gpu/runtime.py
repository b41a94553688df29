"""Where the GPU engine's kernels run: a CUDA GPU, or numba-cuda's simulator.

numba-cuda decides once per process, when ``numba.cuda`` is first imported, whether
kernels go to a GPU or to its simulator (``NUMBA_ENABLE_CUDASIM=1``: the same kernels
run as Python, one Python thread per GPU thread -- slow, for tests and rehearsals).
This module is imported before ``numba.cuda``: it turns the simulator on when the
process has not chosen and no CUDA driver can be loaded, so that ``engine.backend =
"gpu"`` runs (slowly) everywhere, as the tests need.  ``THERMOSWARM_GPU_DEVICE``
(``cuda``, ``simulator``) or ``NUMBA_ENABLE_CUDASIM`` set beforehand take precedence.
"""

from __future__ import annotations

import ctypes
import importlib.util
import os

from thermoswarm.errors import ConfigError

# numba still ships its own deprecated ``numba.cuda``, which imports without the package;
# the engine is written for numba-cuda, so without it the ``gpu`` extra is missing.
if importlib.util.find_spec("numba_cuda") is None:
    raise ImportError("numba-cuda is not installed", name="numba_cuda")

__all__ = ["SIMULATOR", "default_device", "grid", "simulated"]

SIMULATOR = "simulator"


def _driver_present() -> bool:
    for name in ("libcuda.so.1", "libcuda.so", "nvcuda.dll"):
        try:
            ctypes.CDLL(name)
        except OSError:
            continue
        return True
    return False


def _choose() -> None:
    want = os.environ.get("THERMOSWARM_GPU_DEVICE", "").strip().lower()
    if want and want not in ("cuda", SIMULATOR, "cpu") and not want.startswith("cuda:"):
        raise ConfigError(
            f"THERMOSWARM_GPU_DEVICE must be 'cuda', 'cuda:N' or 'simulator', got {want!r}"
        )
    if "NUMBA_ENABLE_CUDASIM" in os.environ:
        return
    if want in (SIMULATOR, "cpu") or (not want and not _driver_present()):
        os.environ["NUMBA_ENABLE_CUDASIM"] = "1"


_choose()

import numba  # noqa: E402

if os.environ.get("NUMBA_ENABLE_CUDASIM") == "1":
    numba.config.ENABLE_CUDASIM = True  # numba read its config before this module ran

from numba import cuda  # noqa: E402

#: Threads per block on a GPU; the simulator runs a few Python threads in one block.
THREADS = 256
SIM_THREADS = 2


def simulated() -> bool:
    """True when numba-cuda runs the kernels in its simulator (no GPU)."""
    return (
        bool(cuda.simulator_enabled)
        if hasattr(cuda, "simulator_enabled")
        else bool(numba.config.ENABLE_CUDASIM)
    )


def default_device() -> str:
    """``"cuda:0"`` (the current CUDA device) or ``"simulator"``."""
    if simulated():
        return SIMULATOR
    if not cuda.is_available():
        from numba.cuda.cudadrv.driver import driver

        why = getattr(driver, "initialization_error", None) or "no CUDA device found"
        raise ConfigError(
            f"engine.backend = 'gpu' found a CUDA driver but no usable GPU ({why}); "
            "`thermoswarm gpu check` says more; THERMOSWARM_GPU_DEVICE=simulator runs the "
            "kernels in numba-cuda's simulator"
        )
    missing = toolchain_error()
    if missing:
        raise ConfigError(f"engine.backend = 'gpu': {missing}")
    return f"cuda:{cuda.get_current_device().id}"


def toolchain_error() -> str | None:
    """Why numba-cuda cannot compile and link kernels here (a CUDA library it needs is
    missing: its exact name and where it was looked for), or None."""
    from cuda import pathfinder

    try:
        for name in ("nvvm", "nvrtc"):
            pathfinder.load_nvidia_dynamic_lib(name)
        pathfinder.locate_static_lib("cudadevrt")
    except Exception as exc:  # cuda-pathfinder's own message names the library
        return (f"{type(exc).__name__}: {exc}; pip install 'thermoswarm[gpu]' installs the "
                "CUDA 13 libraries (NVVM, NVRTC, cudadevrt)")  # fmt: skip
    return None


def check_device(device: str | None) -> str:
    """The device to run on: ``device`` if this process can use it, else a one-line error."""
    have = default_device()
    if device is None:
        return have
    want = SIMULATOR if device in ("cpu", SIMULATOR) else device
    if want == "cuda":
        want = "cuda:0"
    if want != have:
        raise ConfigError(
            f"GPU device {device!r} is not this process's device {have!r}: numba-cuda "
            "chooses GPU or simulator once per process (THERMOSWARM_GPU_DEVICE)"
        )
    return have


def grid(n: int) -> tuple[int, int]:
    """Launch shape ``(blocks, threads)`` for a grid-stride kernel over ``n`` items."""
    if simulated():
        return 1, SIM_THREADS
    return max(1, -(-n // THREADS)), THREADS


def device_name() -> str:
    """The GPU's name (``"numba-cuda simulator"`` in the simulator)."""
    if simulated():
        return "numba-cuda simulator"
    name = cuda.get_current_device().name
    return name.decode() if isinstance(name, bytes) else str(name)
