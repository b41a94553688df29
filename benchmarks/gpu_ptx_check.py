"""Compile every kernel of the GPU engine to PTX for a GPU architecture, without a GPU.

numba-cuda's simulator runs the kernels as Python, which accepts code that the CUDA
compiler rejects (types it cannot infer, unsupported calls).  This check closes that
gap on a machine without a GPU: it runs small workloads in the simulator (in a child
process) and records the argument types of every kernel launch, then compiles each
kernel for those types with NVVM (``numba.cuda.compile_ptx``, compute capability
``--cc``, default 9.0 = H100/H200).  It needs NVVM and NVRTC, which the ``gpu`` extra
does not install::

    pip download --no-deps -d /tmp/nv nvidia-nvvm nvidia-cuda-nvrtc   # ~130 MB
    (cd /tmp/nv && for w in *.whl; do unzip -oq "$w" -d site; done)
    LD_LIBRARY_PATH=/tmp/nv/site/nvidia/cu13/lib PYTHONPATH=/tmp/nv/site \\
        python benchmarks/gpu_ptx_check.py

Prints one line per kernel and signature (PTX size, float64 instructions) and exits 1
if any kernel fails to compile.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import types

RECORD = r"""
import json, numpy as np, numba
from thermoswarm.sim.gpu import engine as E, kernels as G
from thermoswarm.sim.engine import EngineParams, place_lattice
from thermoswarm.sim.world import Body, Piston, World, box_world, polygon_segments
from thermoswarm.policy import BoltzmannUniform

sigs, orig = {}, E.GpuSimulator._launch

def typ(a):
    return str(numba.typeof(a.copy_to_host() if hasattr(a, "copy_to_host") else a))

def rec(self, kernel, dim, inputs):
    name = next(k for k, v in vars(G).items() if v is kernel)
    sigs.setdefault(name, set()).add(tuple(typ(a) for a in inputs))
    return orig(self, kernel, dim, inputs)

E.GpuSimulator._launch = rec
body = Body(x=300.0, y=100.0, radius=50.0, drag=4.0)
piston = Piston(axis=0, position=300.0, side=-1, lo=250.0, hi=450.0, drag=9.0)
walls = polygon_segments([(0, 0), (2000, 0), (2000, 500), (0, 500)])
worlds = [World((0.0, 0.0, 2000.0, 500.0), walls, bodies=(body,), pistons=(piston,)),
          box_world(13000.0, 13000.0)]  # the second: a grid with a chunked prefix sum
for world, cs, n in zip(worlds, (None, 50.0), (30, 1200)):
    for law in ("boltzmann", "half-normal"):
        sim = E.GpuSimulator(world, EngineParams(radius=16.5, cell_size=cs),
                             BoltzmannUniform(63.7, speed_law=law))
        rng = np.random.default_rng(0)
        st = sim.init(place_lattice((0, 0, 600, 200) if n == 30 else world.bounds, n, 16.5,
                                    rng), rng)
        for _ in range(3):
            sim.step(st)
        sim.max_overlap(st)
print(json.dumps({k: sorted(v) for k, v in sigs.items()}))
"""


def _record() -> dict[str, list[list[str]]]:
    env = dict(os.environ, THERMOSWARM_GPU_DEVICE="simulator", NUMBA_ENABLE_CUDASIM="1")
    res = subprocess.run([sys.executable, "-c", RECORD], env=env, text=True,
                         capture_output=True)  # fmt: skip
    if res.returncode:
        sys.exit(f"error: recording the kernels' argument types failed:\n{res.stderr[-3000:]}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def _parse(numba_types, s: str):
    if s.startswith("array("):
        dtype, ndim, layout = s[len("array(") : -1].split(", ")
        return numba_types.Array(getattr(numba_types, dtype), int(ndim[0]), layout)
    return getattr(numba_types, s)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cc", default="9.0", help="compute capability (default 9.0)")
    a = ap.parse_args(argv)
    cc = tuple(int(v) for v in a.cc.split("."))
    sigs = _record()
    os.environ["THERMOSWARM_GPU_DEVICE"] = "cuda"  # compile for CUDA in this process
    os.environ.pop("NUMBA_ENABLE_CUDASIM", None)
    import numba.cuda.dispatcher as dispatcher
    from numba import cuda
    from numba.core import types as nt

    # device functions compile for the current device's architecture: there is none
    dispatcher.get_current_device = lambda: types.SimpleNamespace(compute_capability=cc)
    from thermoswarm.sim.gpu import kernels as G

    failed = 0
    for name, variants in sorted(sigs.items()):
        for sig in variants:
            try:
                ptx, _ = cuda.compile_ptx(getattr(G, name).py_func,
                                          tuple(_parse(nt, s) for s in sig), cc=cc)  # fmt: skip
            except Exception as exc:  # report every kernel, then fail
                failed += 1
                print(f"FAIL {name} {sig}: {type(exc).__name__}: {exc}"[:2000])
                continue
            print(f"ok   {name:22s} sm_{cc[0]}{cc[1]}  {len(ptx):7d} chars of PTX, "
                  f"{ptx.count('.f64')} float64 instructions")  # fmt: skip
    print(f"{sum(len(v) for v in sigs.values())} kernel signatures, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
