"""CI compiles every GPU kernel for real GPUs, without a GPU (issue 34 item 2).

numba-cuda's simulator runs the kernels as Python and accepts code that the CUDA
compiler rejects; here every kernel the engine launches, with every argument type it
launches it with (recorded from small runs in the simulator: walls, a body, a piston,
both speed laws, a large sparse grid, a jam), is compiled to PTX by NVVM for sm_80
(A100) and sm_90 (H100/H200), from the lock's packages (the ``gpu`` extra brings NVVM
and NVRTC as NVIDIA's wheels).  A kernel that only the GPU compiler rejects fails here.
"""

from __future__ import annotations

from thermoswarm.sim.gpu import kernels as G
from thermoswarm.sim.gpu import kernels_grid as KG
from thermoswarm.sim.gpu import kernels_gs as KS
from thermoswarm.sim.gpu.ptx import ARCHS, compile_kernels, record_signatures
from thermoswarm.sim.gpu.runtime import simulated


def _kernels() -> set[str]:
    """Every kernel (not device function) the GPU modules define."""
    out = set()
    for mod in (G, KG, KS):
        for name, v in vars(mod).items():
            device = getattr(v, "_device", None)
            if device is None:  # numba-cuda's dispatcher on a GPU
                device = getattr(v, "targetoptions", {}).get("device", True)
            if hasattr(v, "py_func") and device is False:
                out.add(name)
    return out


def test_every_kernel_compiles_to_ptx_for_sm80_and_sm90():
    sigs = record_signatures() if simulated() else None
    rows = compile_kernels(ARCHS, sigs)
    failed = [f"{r['kernel']} {r['arch']}: {r['error']}" for r in rows if not r["ok"]]
    assert not failed, "\n".join(failed)
    # every kernel of the engine was launched by the workloads, so compiled, for both
    assert {r["kernel"] for r in rows} == _kernels()
    assert {r["arch"] for r in rows} == {"sm_80", "sm_90"}
    # non-vacuous: real PTX for the sweeps and the grid-wide barriers of the solves
    by = {(r["kernel"], r["arch"]): r for r in rows}
    assert by[("jacobi", "sm_90")]["ptx_chars"] > 10_000
    assert by[("gauss_seidel", "sm_80")]["ptx_chars"] > 10_000


def test_gpu_check_names_what_is_missing(monkeypatch):
    """``thermoswarm gpu check`` (issue 34 item 1): the lock's CUDA 13 libraries are
    found in site-packages; a missing one, or a missing driver, is named exactly."""
    import json

    from click.testing import CliRunner
    from cuda import pathfinder

    from thermoswarm.cli import cli
    from thermoswarm.sim.gpu import doctor

    res = CliRunner().invoke(cli, ["gpu", "check", "--json"])
    rep = json.loads(res.output.strip().splitlines()[-1])
    libs = rep["libraries"]
    assert all(libs[k]["found"] for k in ("nvvm", "nvrtc", "cudart", "nvJitLink", "cudadevrt"))
    assert libs["nvrtc"]["version"].startswith("13.")
    assert res.exit_code == (1 if rep["problems"] else 0)
    if not rep["driver"]["found"]:  # this machine: no driver, the simulator
        assert rep["device"] == {"mode": "simulator"}
        assert any("no CUDA driver" in p for p in rep["problems"])
    real = pathfinder.load_nvidia_dynamic_lib

    def without_nvrtc(name):
        if name == "nvrtc":
            raise pathfinder.DynamicLibNotFoundError('Failure finding "libnvrtc.so.13"')
        return real(name)

    monkeypatch.setattr(pathfinder, "load_nvidia_dynamic_lib", without_nvrtc)
    rep = doctor.diagnose()
    assert any("nvrtc" in p and "libnvrtc.so.13" in p for p in rep["problems"]), rep["problems"]
    text = doctor.format_report(rep)
    assert "nvrtc     MISSING" in text and "problem: CUDA library nvrtc not found" in text
