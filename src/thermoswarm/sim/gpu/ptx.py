"""Compile every kernel of the GPU engine to PTX for real GPUs, without a GPU.

numba-cuda's simulator runs the kernels as Python, which accepts code that the CUDA
compiler rejects (types it cannot infer, unsupported calls).  This check closes that
gap on any machine: the engine makes every launch it has with the launcher replaced by
a recorder (kernel, argument types: :func:`record_signatures`), then each kernel is
compiled for those types by NVVM (``numba.cuda.compile_ptx``) for each architecture
asked for (:func:`compile_kernels`, in a child process: numba-cuda picks simulator or
CUDA once per process).  NVVM and NVRTC come with the ``gpu`` extra (NVIDIA's wheels); no GPU,
driver or CUDA toolkit is needed.  ``tests/sim/test_gpu_ptx.py`` runs it in the fast
suite for sm_80 (A100) and sm_90 (H100/H200); ``thermoswarm gpu check --ptx`` on demand.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from typing import Any

__all__ = ["ARCHS", "compile_kernels", "record_signatures"]

#: Compute capabilities compiled by default: A100 (sm_80), H100/H200 (sm_90).
ARCHS = ((8, 0), (9, 0))

_RECORD = """
import json
from thermoswarm.sim.gpu.ptx import record_signatures
print(json.dumps(record_signatures()))
"""


def _workloads() -> None:
    """Every launch the engine makes, made dry (the launcher records and skips): a step,
    a rebuild with held pushes, each Gauss-Seidel mode, the overlap check, on a world
    with walls, a body and a piston (argument types do not depend on the values)."""
    import numpy as np

    from thermoswarm.policy import BoltzmannUniform
    from thermoswarm.sim.engine import EngineParams, place_lattice
    from thermoswarm.sim.gpu import kernels_gs as KS
    from thermoswarm.sim.gpu.engine import GpuSimulator
    from thermoswarm.sim.world import Body, Piston, World, polygon_segments

    body = Body(x=300.0, y=100.0, radius=50.0, drag=4.0)
    piston = Piston(axis=0, position=300.0, side=-1, lo=250.0, hi=450.0, drag=9.0)
    walls = polygon_segments([(0, 0), (2000, 0), (2000, 500), (0, 500)])
    world = World((0.0, 0.0, 2000.0, 500.0), walls, bodies=(body,), pistons=(piston,))
    sim = GpuSimulator(world, EngineParams(radius=16.5, tau=1.0), BoltzmannUniform(63.7))
    rng = np.random.default_rng(0)
    state = sim.init(place_lattice((0, 0, 600, 200), 30, 16.5, rng), rng)
    sim.step(state)
    sim._dev.alloc_tables()
    sim._held = True
    sim._rebuild()
    for mode in (KS.WARM, KS.COLD_START, KS.RESUME):
        sim._gauss_seidel(mode)
    sim.max_overlap(state)


def record_signatures() -> dict[str, list[list[str]]]:
    """``{kernel name: [argument types, ...]}`` of every launch the engine makes (call
    it in a process where numba-cuda runs its simulator: the device arrays are its)."""
    import numba

    from thermoswarm.sim.gpu import engine as E
    from thermoswarm.sim.gpu import kernels as G
    from thermoswarm.sim.gpu import kernels_grid as KG
    from thermoswarm.sim.gpu import kernels_gs as KS

    names = {}
    for mod in (G, KG, KS):
        for k, v in vars(mod).items():
            if hasattr(v, "py_func") and not getattr(v, "_device", True):
                names[id(v)] = k
    sigs: dict[str, set[tuple[str, ...]]] = {}

    def typ(a: Any) -> str:
        return str(numba.typeof(a.copy_to_host() if hasattr(a, "copy_to_host") else a))

    def record(self, kernel, dim, inputs):
        self.launches += 1
        sigs.setdefault(names[id(kernel)], set()).add(tuple(typ(a) for a in inputs))

    saved = E.GpuSimulator._launch, E.GpuSimulator._launch_coop
    E.GpuSimulator._launch = E.GpuSimulator._launch_coop = record
    try:
        _workloads()
    finally:
        E.GpuSimulator._launch, E.GpuSimulator._launch_coop = saved
    return {k: [list(s) for s in sorted(v)] for k, v in sorted(sigs.items())}


def _parse(nt, s: str):
    if s.startswith("array("):
        dtype, ndim, layout = s[len("array(") : -1].split(", ")
        return nt.Array(getattr(nt, dtype), int(ndim[0]), layout)
    return getattr(nt, s)


def _compile_child(sigs: dict, archs: list[list[int]]) -> list[dict]:
    """In a process that chose CUDA (not the simulator): compile every signature."""
    import types

    import numba.cuda.dispatcher as dispatcher
    from numba import cuda
    from numba.core import types as nt

    from thermoswarm.sim.gpu import kernels as G
    from thermoswarm.sim.gpu import kernels_grid as KG
    from thermoswarm.sim.gpu import kernels_gs as KS

    out = []
    for cc in archs:
        # device functions compile for the current device's architecture: there is none
        dispatcher.get_current_device = lambda cc=cc: types.SimpleNamespace(
            compute_capability=tuple(cc)
        )
        for name, variants in sigs.items():
            kernel = next(getattr(m, name) for m in (G, KG, KS) if hasattr(m, name))
            for sig in variants:
                row = {"kernel": name, "arch": f"sm_{cc[0]}{cc[1]}", "ok": False}
                try:
                    argtys = tuple(_parse(nt, s) for s in sig)
                    ptx, _ = cuda.compile_ptx(kernel.py_func, argtys, cc=tuple(cc))
                    row.update(ok=True, ptx_chars=len(ptx), f64=ptx.count(".f64"))
                except Exception as exc:  # every kernel is reported, then the check fails
                    row["error"] = f"{type(exc).__name__}: {exc}"[:2000]
                out.append(row)
    return out


def compile_kernels(
    archs: tuple[tuple[int, int], ...] = ARCHS, sigs: dict | None = None
) -> list[dict]:
    """Compile every kernel signature (``sigs``; default: :func:`record_signatures` in
    a simulator child process) to PTX for each compute capability in ``archs``, in a
    child process that uses NVVM (no GPU needed).  One row per kernel, signature and
    architecture: ``kernel``, ``arch``, ``ok``, and ``ptx_chars`` and ``f64`` (float64
    instructions) or ``error``."""
    env = dict(os.environ)
    env.pop("NUMBA_ENABLE_CUDASIM", None)
    if sigs is None:
        sim_env = dict(env, THERMOSWARM_GPU_DEVICE="simulator")
        res = subprocess.run([sys.executable, "-c", _RECORD], env=sim_env, text=True,
                             capture_output=True)  # fmt: skip
        if res.returncode:
            raise RuntimeError(f"recording the kernels' launches failed:\n{res.stderr[-3000:]}")
        sigs = json.loads(res.stdout.strip().splitlines()[-1])
    child = dict(env, THERMOSWARM_GPU_DEVICE="cuda")
    payload = json.dumps({"sigs": sigs, "archs": [list(a) for a in archs]})
    res = subprocess.run([sys.executable, "-m", "thermoswarm.sim.gpu.ptx"], env=child,
                         input=payload, text=True, capture_output=True)  # fmt: skip
    if res.returncode:
        raise RuntimeError(f"compiling the kernels failed:\n{res.stderr[-3000:]}")
    return json.loads(res.stdout.strip().splitlines()[-1])


if __name__ == "__main__":  # the compiling child of compile_kernels
    job = json.loads(sys.stdin.read())
    print(json.dumps(_compile_child(job["sigs"], job["archs"])))
