"""Compile every kernel of the GPU engine to PTX for GPU architectures, without a GPU.

The fast suite does this for sm_80 and sm_90 (``tests/sim/test_gpu_ptx.py``); this
prints one line per kernel, signature and architecture (PTX size, float64
instructions left) and exits 1 if any fails.  NVVM and NVRTC come with the ``gpu``
extra (``pip install 'thermoswarm[gpu]'``; see :mod:`thermoswarm.sim.gpu.ptx`)::

    python benchmarks/gpu_ptx_check.py                 # sm_80 and sm_90
    python benchmarks/gpu_ptx_check.py --cc 8.6 --cc 9.0
"""

from __future__ import annotations

import argparse
import sys

from thermoswarm.sim.gpu.ptx import ARCHS, compile_kernels


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cc", action="append", help="compute capability (repeatable)")
    a = ap.parse_args(argv)
    archs = tuple(tuple(int(v) for v in c.split(".")) for c in a.cc) if a.cc else ARCHS
    rows = compile_kernels(archs)  # type: ignore[arg-type]
    for r in rows:
        if r["ok"]:
            print(f"ok   {r['kernel']:16s} {r['arch']}  {r['ptx_chars']:7d} chars of PTX, "
                  f"{r['f64']} float64 instructions")  # fmt: skip
        else:
            print(f"FAIL {r['kernel']} {r['arch']}: {r['error']}")
    failed = sum(not r["ok"] for r in rows)
    kernels = len({r["kernel"] for r in rows})
    print(f"{len(rows)} kernel signatures ({kernels} kernels) compiled, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
