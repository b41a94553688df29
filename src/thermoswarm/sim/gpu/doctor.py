"""What this machine has, and lacks, for the GPU engine (``thermoswarm gpu check``).

The ``gpu`` extra installs numba-cuda with its ``cu13`` extra: the CUDA 13 compiler
(NVVM), NVRTC, the runtime and its device library (``libcudadevrt.a``, for the grid-wide
barriers), nvJitLink and the CCCL headers, all as NVIDIA's pip wheels.  A machine
then needs only an NVIDIA driver recent enough for CUDA 13 (:data:`MIN_DRIVER`).  Each
check below names the exact library or condition that is missing.
"""

from __future__ import annotations

import ctypes
import importlib.metadata as md
import importlib.util
from pathlib import Path
from typing import Any

__all__ = ["MIN_DRIVER", "MIN_DRIVER_CUDA", "diagnose", "format_report"]

#: The oldest driver the gpu extra's CUDA 13 works with (CUDA 13.0's minimum on Linux).
MIN_DRIVER = "580.65.06"
#: ... and the CUDA version such a driver reports (cuDriverGetVersion: 1000 x major + 10 x minor).
MIN_DRIVER_CUDA = 13000
#: The CUDA libraries the engine loads, as cuda-pathfinder names them.
LIBRARIES = ("nvvm", "nvrtc", "cudart", "nvJitLink")
WHEELS = ("numba-cuda", "cuda-bindings", "nvidia-nvvm", "nvidia-cuda-nvrtc",
          "nvidia-cuda-runtime", "nvidia-nvjitlink")  # fmt: skip


def _version(dist: str) -> str | None:
    try:
        return md.version(dist)
    except md.PackageNotFoundError:
        return None


def _driver() -> dict[str, Any]:
    """The CUDA driver: ``libcuda`` loaded directly (``cuDriverGetVersion``)."""
    out: dict[str, Any] = {"found": False}
    for name in ("libcuda.so.1", "libcuda.so", "nvcuda.dll"):
        try:
            lib = ctypes.CDLL(name)
        except OSError as exc:
            out.setdefault("error", str(exc))
            continue
        v = ctypes.c_int(0)
        rc = lib.cuDriverGetVersion(ctypes.byref(v))
        out = {"found": True, "library": name, "cuda": f"{v.value // 1000}.{v.value % 1000 // 10}"}
        if rc != 0:
            out["error"] = f"cuDriverGetVersion returned {rc}"
        elif v.value < MIN_DRIVER_CUDA:
            out["error"] = (f"the driver supports CUDA {out['cuda']}; the gpu extra's CUDA 13 "
                            f"needs driver {MIN_DRIVER} or newer")  # fmt: skip
        break
    proc = Path("/proc/driver/nvidia/version")
    if proc.exists():
        words = proc.read_text().split()
        if "Module" in words:
            out["version"] = words[words.index("Module") + 1]
    return out


def _libraries() -> dict[str, dict[str, Any]]:
    """Each CUDA library the engine loads: where cuda-pathfinder found it, or why not."""
    from cuda import pathfinder

    out: dict[str, dict[str, Any]] = {}
    for name in LIBRARIES:
        try:
            lib = pathfinder.load_nvidia_dynamic_lib(name)
            out[name] = {"found": True, "path": lib.abs_path, "via": lib.found_via}
        except Exception as exc:  # DynamicLibNotFoundError and kin: report the message
            out[name] = {"found": False, "error": f"{type(exc).__name__}: {exc}"}
    try:
        lib = pathfinder.locate_static_lib("cudadevrt")
        out["cudadevrt"] = {"found": True, "path": lib.abs_path, "via": lib.found_via}
    except Exception as exc:
        out["cudadevrt"] = {"found": False, "error": f"{type(exc).__name__}: {exc}"}
    try:
        from cuda.bindings import nvrtc, runtime

        _rc, major, minor = nvrtc.nvrtcVersion()
        out["nvrtc"]["version"] = f"{major}.{minor}"
        _rc, v = runtime.cudaRuntimeGetVersion()
        out["cudart"]["version"] = f"{v // 1000}.{v % 1000 // 10}"
    except Exception:  # noqa: S110 - a missing library is reported above
        pass
    return out


def _device() -> dict[str, Any]:
    """The device the engine would run on, as this process chose it (GPU or simulator)."""
    from thermoswarm.sim.gpu import runtime

    if runtime.simulated():
        return {"mode": "simulator"}
    cuda = runtime.cuda
    try:
        dev = cuda.get_current_device()
        free, total = cuda.current_context().get_memory_info()
    except Exception as exc:  # the driver's own reason
        return {"mode": "cuda", "error": f"{type(exc).__name__}: {exc}"}
    name = dev.name.decode() if isinstance(dev.name, bytes) else str(dev.name)
    return {
        "mode": "cuda", "name": name, "compute_capability": list(dev.compute_capability),
        "multiprocessors": int(dev.MULTIPROCESSOR_COUNT), "memory_bytes": int(total),
        "free_bytes": int(free),
        "cooperative_launch": bool(getattr(dev, "COOPERATIVE_LAUNCH", 1)),
    }  # fmt: skip


def diagnose(ptx: bool = False) -> dict[str, Any]:
    """Everything ``thermoswarm gpu check`` reports, with ``problems``: one line each
    for what keeps the GPU engine from running on a GPU here (empty: it can), and
    ``ptx`` (with ``ptx=True``): every kernel compiled for sm_80 and sm_90."""
    rep: dict[str, Any] = {"versions": {w: _version(w) for w in WHEELS}, "problems": []}
    if importlib.util.find_spec("numba_cuda") is None:
        rep["problems"].append("numba-cuda is not installed: pip install 'thermoswarm[gpu]'")
        return rep
    rep["driver"] = _driver()
    rep["libraries"] = _libraries()
    rep["device"] = _device()
    for name, lib in rep["libraries"].items():
        if not lib["found"]:
            rep["problems"].append(f"CUDA library {name} not found ({lib['error']}); "
                                   "pip install 'thermoswarm[gpu]' installs it")  # fmt: skip
    drv = rep["driver"]
    if not drv["found"]:
        rep["problems"].append(f"no CUDA driver ({drv.get('error')}): the kernels run in "
                               "numba-cuda's simulator")  # fmt: skip
    elif "error" in drv:
        rep["problems"].append(f"CUDA driver: {drv['error']}")
    if "error" in rep["device"]:
        rep["problems"].append(f"no usable GPU: {rep['device']['error']}")
    if ptx:
        from thermoswarm.sim.gpu.ptx import compile_kernels

        try:
            rows = compile_kernels()
        except RuntimeError as exc:
            rows = []
            rep["problems"].append(f"PTX check: {exc}".splitlines()[0])
        rep["ptx"] = rows
        for row in rows:
            if not row["ok"]:
                rep["problems"].append(f"{row['kernel']} does not compile for {row['arch']}: "
                                       f"{row['error']}".splitlines()[0])  # fmt: skip
    return rep


def format_report(rep: dict[str, Any]) -> str:
    """The report as lines of text."""
    lines = []
    v = rep["versions"]
    lines.append("packages: " + ", ".join(f"{k} {v[k] or 'MISSING'}" for k in WHEELS))
    drv = rep.get("driver", {})
    if drv.get("found"):
        lines.append(f"driver: {drv.get('version', '?')} (CUDA {drv['cuda']}; needs "
                     f"{MIN_DRIVER}+ for CUDA 13)")  # fmt: skip
    elif drv:
        lines.append("driver: none (no libcuda)")
    libs = rep.get("libraries", {})
    rt = libs.get("cudart", {}).get("version")
    if libs:
        nvrtc = libs["nvrtc"].get("version", "?")
        lines.append(f"CUDA runtime: {rt or 'MISSING'} (NVRTC {nvrtc})")
    for name, lib in libs.items():
        lines.append(f"  {name:9s} " + (lib["path"] if lib["found"] else "MISSING"))
    dev = rep.get("device", {})
    if dev.get("mode") == "simulator":
        lines.append("device: numba-cuda simulator (no GPU in this process)")
    elif "name" in dev:
        cc = "".join(map(str, dev["compute_capability"]))
        gib = dev["memory_bytes"] / 2**30
        sms = dev["multiprocessors"]
        lines.append(f"device: {dev['name']}, sm_{cc}, {sms} SMs, {gib:.1f} GiB")
    if "ptx" in rep:
        rows = rep["ptx"]
        ok = sum(r["ok"] for r in rows)
        archs = sorted({r["arch"] for r in rows})
        kernels = len({r["kernel"] for r in rows})
        lines.append(f"PTX: {ok} of {len(rows)} kernel signatures compiled ({kernels} kernels; "
                     f"{', '.join(archs)})")  # fmt: skip
    if rep["problems"]:
        lines += [f"problem: {p}" for p in rep["problems"]]
    else:
        lines.append("ok: the GPU engine can run on this machine's GPU")
    return "\n".join(lines)
