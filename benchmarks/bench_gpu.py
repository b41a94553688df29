"""The GPU engine at scale, beside JAX-MD, the CPU engine and the U-Net: one JSON.

    python benchmarks/bench_gpu.py --out gpu.json            # on a CUDA GPU (gpu_run.sh)
    python benchmarks/bench_gpu.py --out r.json --rehearse   # numba-cuda's simulator, tiny N

Sections of the JSON (written again after each part, atomically, so that a run cut
short keeps what it measured):

- ``meta``: device, commit, versions, host, whether the simulator ran the kernels;
- ``engine``: one row per (N, packing fraction): our engine (robot-steps per second,
  the exact largest overlap of its final state by SciPy's k-d tree on the host up to
  ``--kdtree-max`` robots, the device's exhaustive pair search above, bytes per robot
  on the device), JAX-MD on the same device where it imports (Brownian dynamics of
  soft discs with a cell-list neighbour list: a throughput peer, not the same contact
  model) and the CPU engine (Numba; one thread below 60,000 robots, both cores above:
  its own choice) up to ``--cpu-max``.  Workload: discs of
  33 mm in a walled square box, mean speed 10 mm/s, heading and speed re-drawn every
  0.1 s, ``dt = 0.1 s``; compilation and the first step excluded;
- ``unet``: the U-Net detector's frames per second on 1920x1080 frames (untrained
  weights of the shipped architecture: the same arithmetic; at most 40 detections per
  frame, the benchmark video's ant count), and with the pose network run on 40 crops
  per frame (``frames_per_second_with_40_poses``: untrained weights may find no ant);
- ``tests``: the GPU engine's tests (``tests/sim/test_gpu_backend.py``) on this device;
- ``goals``: the goal figures and whether this run met them.

A baseline that cannot run says why in its entry.  ``--budget`` (seconds) stops
starting new parts once spent, so the run fits a lent machine's time.
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import os
import platform
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

DIAMETER = 33.0
ROOT = Path(__file__).resolve().parent.parent
GOALS = {
    "robot_steps_per_second_at_1e7": 1e9,
    "max_overlap_fraction": 0.01,
    "device_bytes_per_robot": 100.0,
}


def _write(path: Path, doc: dict) -> None:
    """Write ``doc`` as JSON atomically (a temporary file renamed over the old one)."""
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(doc, indent=1, default=str))
    os.replace(tmp, path)


def _version(mod: str) -> str | None:
    from importlib import metadata

    try:
        return metadata.version(mod)
    except metadata.PackageNotFoundError:
        return None


def _meta(rehearse: bool) -> dict:
    from thermoswarm.sim.gpu.runtime import device_name, simulated

    commit = os.environ.get("THERMOSWARM_COMMIT")
    if not commit:
        try:
            commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, text=True,
                                    capture_output=True, check=True).stdout.strip()  # fmt: skip
        except (OSError, subprocess.CalledProcessError):
            commit = None
    return {
        "device": device_name(),
        "simulated": simulated(),
        "rehearse": rehearse,
        "commit": commit,
        "started_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "host": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cpus",
        "load_average": os.getloadavg(),
        "python": sys.version.split()[0],
        "versions": {
            m: _version(m)
            for m in ("numba", "numba-cuda", "numpy", "scipy", "torch", "jax", "jax-md")
        },  # fmt: skip
    }


def _free_device_memory() -> tuple[int, int] | None:
    """(free, total) bytes of the GPU, or None in the simulator."""
    from thermoswarm.sim.gpu.runtime import cuda, simulated

    if simulated():
        return None
    ctx = cuda.current_context()
    ctx.deallocations.clear()  # release arrays freed by Python but not yet by CUDA
    return ctx.get_memory_info()


def _ours(n: int, phi: float, kdtree_max: int, seconds: float | None) -> dict:
    from thermoswarm.sim.gpu.bench import run_bench_gpu

    mem = _free_device_memory()
    need = 80 * n  # ~66 bytes per robot on the device, plus margin
    if mem is not None and need > 0.9 * mem[0]:
        return {"skipped": f"needs ~{need / 2**30:.1f} GiB, {mem[0] / 2**30:.1f} GiB free"}
    out = run_bench_gpu(n, phi, seconds, exact_check=n <= kdtree_max)
    gc.collect()
    return out


def _cpu(n: int, phi: float, seconds: float | None) -> dict:
    from thermoswarm.sim.bench import run_bench

    return run_bench(n, phi, seconds)


def _jax_md(n: int, phi: float, steps: int) -> dict:
    """Brownian dynamics of soft discs (JAX-MD's soft sphere, cell-list neighbour list)
    in a periodic square of the same size (JAX-MD has no walls)."""
    import warnings

    import jax
    import jax.numpy as jnp
    from jax_md import energy, partition, simulate, space

    warnings.filterwarnings("ignore", message="Explicitly requested dtype")
    from scipy.spatial import cKDTree

    from thermoswarm.sim.engine import place_lattice

    side = math.sqrt(n * math.pi * (DIAMETER / 2) ** 2 / phi)
    rng = np.random.default_rng(0)
    pos = jnp.asarray(place_lattice((0, 0, side, side), n, DIAMETER / 2, rng), jnp.float32)
    displacement, shift = space.periodic(side)
    neighbor_fn, energy_fn = energy.soft_sphere_neighbor_list(
        displacement, side, sigma=DIAMETER, epsilon=1.0, dr_threshold=DIAMETER * 0.2,
        capacity_multiplier=1.5, format=partition.Sparse,
    )  # fmt: skip
    # the robots' diffusion coefficient D = kT tau / 2 (mean speed 10 mm/s, tau 0.1 s)
    # as Brownian D = kT' / gamma with gamma = 1; the robots' time step
    d_robot = (10.0 / math.sqrt(math.pi / 2)) ** 2 * 0.1 / 2
    init_fn, apply_fn = simulate.brownian(energy_fn, shift, dt=0.1, kT=d_robot, gamma=1.0)
    nbrs = neighbor_fn.allocate(pos)
    state = init_fn(jax.random.PRNGKey(0), pos)

    @jax.jit
    def step(carry, _):
        state, nbrs = carry
        state = apply_fn(state, neighbor=nbrs)
        return (state, nbrs.update(state.position)), None

    def run(k, carry):
        return jax.lax.scan(step, carry, None, length=k)[0]

    for _ in range(3):  # a neighbour list that overflowed is re-allocated and re-run
        carry = run(steps, (state, nbrs))  # compile (the scan length is static)
        jax.block_until_ready(carry[0].position)
        t0 = time.perf_counter()
        carry = run(steps, carry)
        jax.block_until_ready(carry[0].position)
        wall = time.perf_counter() - t0
        overflow = bool(carry[1].did_buffer_overflow)
        if not overflow:
            break
        nbrs = neighbor_fn.allocate(carry[0].position)
    p = np.asarray(carry[0].position, dtype=np.float64)
    dist, _ = cKDTree(p, boxsize=side).query(p, k=2, workers=-1)
    return {
        "robot_steps_per_second": n * steps / wall,
        "steps": steps,
        "max_overlap_fraction": max(0.0, DIAMETER - float(dist[:, 1].min())) / DIAMETER,
        "device": str(jax.devices()[0]),
        "neighbour_overflow": overflow,
    }


def _unet(frames: int) -> dict:
    """Frames per second of the U-Net detector on 1920x1080 RGB frames."""
    import torch

    from thermoswarm.tracking.detect.unet import (
        TopDownModel,
        UNetDetector,
        UNetOptions,
        to_model_scale,
    )

    torch.manual_seed(0)
    det = UNetDetector(TopDownModel(), px_per_mm=3.04, options=UNetOptions(max_detections=40))
    rng = np.random.default_rng(0)
    imgs = [rng.integers(0, 256, (1080, 1920, 3), dtype=np.uint8) for _ in range(2)]
    det.detect(imgs[0])  # warm-up (cuDNN autotuning, allocations)
    sync = torch.cuda.synchronize if det.device.type == "cuda" else (lambda: None)
    sync()
    t0 = time.perf_counter()
    found = 0
    for k in range(frames):
        found += len(det.detect(imgs[k % 2]).scores)
    sync()
    wall = time.perf_counter() - t0
    # the pose network on 40 crops (untrained weights may find no ant): its time per frame
    frame_m, _ = to_model_scale(imgs[0], det.ratio)
    h, w = frame_m.shape[:2]
    anchors = np.column_stack([rng.uniform(20, w - 20, 40), rng.uniform(20, h - 20, 40)])
    det.poses(frame_m, anchors)
    sync()
    t0 = time.perf_counter()
    for _ in range(frames):
        det.poses(frame_m, anchors)
    sync()
    pose = (time.perf_counter() - t0) / frames
    name = torch.cuda.get_device_name(0) if det.device.type == "cuda" else platform.machine()
    weights = "untrained (shipped architecture; at most 40 detections per frame)"
    return {"frames_per_second": frames / wall, "pose_40_seconds_per_frame": pose,
            "frames_per_second_with_40_poses": 1.0 / (wall / frames + pose), "frames": frames,
            "frame": "1920x1080 RGB",
            "device": f"{det.device.type}: {name}", "detections_per_frame": found / frames,
            "weights": weights}  # fmt: skip


def _tests(out_dir: Path, select: str | None, sites: list[str]) -> dict:
    """Run the GPU engine's tests on this process's device; counts from JUnit XML."""
    xml = out_dir / "gpu_tests.xml"
    args = ["tests/sim/test_gpu_backend.py", "-q", "-m", "not slow", "-p", "no:cacheprovider",
            f"--junitxml={xml}"]  # fmt: skip
    if select:
        args += ["-k", select]
    # pytest in a child process, with the extra folders at the end of its sys.path
    code = f"import sys; sys.path += {sites!r}; import pytest; sys.exit(pytest.main({args!r}))"
    cmd = [sys.executable, "-c", code]
    t0 = time.perf_counter()
    res = subprocess.run(cmd, cwd=ROOT, text=True, capture_output=True)
    out = {"command": "pytest " + " ".join(args), "exit_code": res.returncode,
           "wall_seconds": time.perf_counter() - t0, "tail": res.stdout[-1500:]}  # fmt: skip
    if xml.exists():
        suite = ET.parse(xml).getroot()
        suite = suite if suite.tag == "testsuite" else suite[0]
        for k in ("tests", "failures", "errors", "skipped"):
            out[k] = int(suite.get(k, 0))
    return out


def _guard(fn, *args) -> dict:
    """``fn(*args)``, or the one-line reason it could not run."""
    try:
        return fn(*args)
    except ImportError as exc:
        return {"skipped": f"not importable: {exc.name or exc}"}
    except Exception as exc:  # a baseline's failure must not lose the other figures
        return {"skipped": f"{type(exc).__name__}: {exc}"[:300]}


def _goals(rows: list[dict]) -> dict:
    """The goal figures and whether this run met them (None where not measured)."""
    at = [r["gpu"] for r in rows if r["n"] == 10**7 and "robot_steps_per_second" in r["gpu"]]
    ok = [r["gpu"] for r in rows if "robot_steps_per_second" in r["gpu"]]
    return {
        "goal": GOALS,
        "robot_steps_per_second_at_1e7": min(
            (g["robot_steps_per_second"] for g in at), default=None
        ),  # fmt: skip
        "max_overlap_fraction": max((g["max_overlap_fraction"] for g in ok), default=None),
        "device_bytes_per_robot": max((g["device_bytes_per_robot"] for g in ok), default=None),
    }


def _table(doc: dict) -> str:
    """The engine rows as a Markdown table."""

    def rate(d: dict) -> str:
        v = d.get("robot_steps_per_second")
        if not v:
            return f"skipped: {d.get('skipped', '-')}"
        return f"{v / 1e6:,.1f} M" if v >= 1e5 else f"{v:,.0f}"

    def pct(d: dict, key: str) -> str:
        v = d.get(key)
        return "-" if v is None else f"{100 * v:.2f} %"

    lines = ["| N | phi | ours robot-steps/s | exact max overlap (final state) | bytes/robot "
             "(device) | JAX-MD robot-steps/s | JAX-MD overlap | CPU engine robot-steps/s |",
             "|" + "---:|" * 8]  # fmt: skip
    for r in doc["engine"]:
        g, j, c = r["gpu"], r.get("jax_md", {}), r.get("cpu", {})
        bpr = g.get("device_bytes_per_robot")
        lines.append("| " + " | ".join([
            f"{r['n']:,}", str(r["phi"]), rate(g),
            pct(g, "exact_max_overlap_fraction") + f" ({g.get('exact_check', '-')})",
            "-" if bpr is None else f"{bpr:.0f}", rate(j), pct(j, "max_overlap_fraction"),
            rate(c),
        ]) + " |")  # fmt: skip
    return "\n".join(lines)


def _parse(argv: list[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, required=True, help="the JSON file to write")
    ap.add_argument(
        "--rehearse",
        action="store_true",
        help="tiny sizes, few steps, a subset of the tests (for the simulator)",
    )
    ap.add_argument(
        "--sizes",
        type=float,
        nargs="+",
        default=None,
        help="swarm sizes (default 1e5 1e6 1e7 1e8; rehearsal 300 1000)",
    )
    ap.add_argument("--phis", type=float, nargs="+", default=[0.18, 0.5])
    ap.add_argument(
        "--kdtree-max",
        type=float,
        default=1e7,
        help="largest N whose final state the host k-d tree checks",
    )
    ap.add_argument("--cpu-max", type=float, default=1e6, help="largest N for the CPU engine")
    ap.add_argument("--jax-max", type=float, default=1e7, help="largest N for JAX-MD")
    ap.add_argument("--unet-frames", type=int, default=None, help="default 50 (rehearsal 2)")
    ap.add_argument(
        "--budget", type=float, default=420.0, help="seconds after which no new part starts"
    )
    ap.add_argument(
        "--extra-site",
        action="append",
        default=[],
        help="folder appended to sys.path (wheels gpu_run.sh installed)",
    )
    ap.add_argument(
        "--skip",
        nargs="*",
        default=[],
        choices=["cpu", "jax", "unet", "tests"],
        help="parts to leave out",
    )
    return ap.parse_args(argv)  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    a = _parse(argv)
    for site in a.extra_site:  # after the image's own packages: theirs win
        sys.path.append(site)
    t_start = time.perf_counter()
    a.out.parent.mkdir(parents=True, exist_ok=True)
    doc: dict = {"meta": _meta(a.rehearse), "engine": [], "unet": None, "tests": None}
    sizes = [int(s) for s in (a.sizes or ([300, 1000] if a.rehearse else [1e5, 1e6, 1e7, 1e8]))]
    seconds = 0.5 if a.rehearse else None
    left = lambda: a.budget - (time.perf_counter() - t_start)  # noqa: E731

    def save() -> None:
        doc["goals"] = _goals(doc["engine"])
        doc["meta"]["elapsed_seconds"] = time.perf_counter() - t_start
        _write(a.out, doc)

    for n in sizes:  # our engine first: the figures that matter
        for phi in a.phis:
            row = {"n": n, "phi": phi}
            row["gpu"] = _guard(_ours, n, phi, int(a.kdtree_max), seconds) if left() > 0 else {
                "skipped": "time budget spent"}  # fmt: skip
            doc["engine"].append(row)
            print(json.dumps(row), flush=True)
            save()
    if "tests" not in a.skip:
        sel = "dispatch or draws or rebuild" if a.rehearse else None
        tests = _guard(_tests, a.out.parent, sel, a.extra_site) if left() > 0 else None
        doc["tests"] = tests or {"skipped": "time budget spent"}
        save()
    if "unet" not in a.skip:
        frames = a.unet_frames or (2 if a.rehearse else 50)
        doc["unet"] = _guard(_unet, frames) if left() > 0 else {"skipped": "time budget spent"}
        save()
    for row in doc["engine"]:
        n, phi = row["n"], row["phi"]
        if "jax" in a.skip or n > a.jax_max:
            row["jax_md"] = {"skipped": "--skip jax" if "jax" in a.skip else "n > --jax-max"}
        else:
            steps = 5 if a.rehearse else max(10, min(200, int(2e9 / n)))
            row["jax_md"] = _guard(_jax_md, n, phi, steps) if left() > 0 else {
                "skipped": "time budget spent"}  # fmt: skip
        if "cpu" in a.skip or n > a.cpu_max:
            row["cpu"] = {"skipped": "--skip cpu" if "cpu" in a.skip else "n > --cpu-max"}
        else:
            row["cpu"] = _guard(_cpu, n, phi, seconds) if left() > 0 else {"skipped": "budget"}
        save()
    print(_table(doc))
    print(json.dumps({"goals": doc["goals"], "unet": doc["unet"], "tests": {
        k: v for k, v in (doc["tests"] or {}).items() if k != "tail"}}, indent=1))  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
