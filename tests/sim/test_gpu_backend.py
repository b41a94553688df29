"""The GPU engine's kernels against the CPU engine and theory.

Without a GPU the kernels run in numba-cuda's simulator (as Python: slow), so the swarms
and runs here are small; on a GPU machine the same tests run on the GPU.

Every comparison is statistical where the engines' random draws differ (the GPU engine
draws on the device), with fixed seeds and tolerances from the sample sizes: 4 standard
errors of the difference (a false alarm about 1 time in 16,000 for a normal statistic,
about 1 in 300 for a t statistic with 9 degrees of freedom).  Overlaps are checked
exactly with SciPy's k-d tree, which shares no code with either engine.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np
import pytest
import xarray as xr
from click.testing import CliRunner
from scipy import stats

from thermoswarm.cli import cli
from thermoswarm.errors import ConfigError
from thermoswarm.maxent import kT_for_mean_speed
from thermoswarm.policy import Action, BoltzmannUniform
from thermoswarm.scenarios import runner
from thermoswarm.sim.backend import make_simulator
from thermoswarm.sim.engine import EngineParams, Simulator, place_lattice
from thermoswarm.sim.gpu import GpuSimulator
from thermoswarm.sim.gpu.check import exact_max_overlap
from thermoswarm.sim.gpu.runtime import simulated
from thermoswarm.sim.world import Body, Piston, World, box_world, polygon_segments

R = 16.5
D = 2 * R
KT = kT_for_mean_speed(10.0)


def _pair(world, params, policy, n, seed, **kw):
    """The CPU and the GPU engine on the same world and initial positions."""
    out = []
    for make in (Simulator, lambda *a: GpuSimulator(*a, **kw)):
        rng = np.random.default_rng(seed)
        sim = make(world, params, policy, None)
        pos = place_lattice(world.bounds, n, params.radius, np.random.default_rng(seed + 1))
        out.append((sim, sim.init(pos, rng)))
    return out


def _box(n, phi):
    side = math.sqrt(n * math.pi * R * R / phi)
    return box_world(side, side)


# ----------------------------------------------------------------------------- overlaps
def test_overlaps_stay_within_the_cpu_engines_bound_checked_exactly():
    world = _box(150, 0.5)
    params = EngineParams(dt=0.1, tau=0.1, radius=R)
    tol = params.overlap_tol * D
    for sim, state in _pair(world, params, BoltzmannUniform(KT), 150, seed=2):
        for _ in range(3):
            for _ in range(10):
                sim.step(state)
            exact = exact_max_overlap(world, state.pos, R, state.bodies, state.pistons)
            # the sweeps stop once every overlap they see is below tol: the CPU's bound
            assert exact["max"] <= tol, (type(sim).__name__, exact)
            # the engine's own check agrees with the k-d tree (float32 rounding)
            assert sim.max_overlap(state) == pytest.approx(exact["max"], abs=2e-4)
        # dense: the sweeps had to work to meet the bound (non-vacuous)
        assert state.counters[1] / 1e6 > 0.5 * tol
        assert state.counters[0] > params.iterations * 30


def test_pair_search_cannot_miss_a_pair_when_the_grid_is_never_rebuilt():
    world = _box(120, 0.5)
    params = EngineParams(dt=0.1, tau=0.1, radius=R)
    sim = GpuSimulator(world, params, BoltzmannUniform(KT))
    rng = np.random.default_rng(4)
    state = sim.init(place_lattice(world.bounds, 120, R, rng), rng)
    sim._dev.rebuild_at = math.inf  # keep the first grid: robots drift far from it
    tol = params.overlap_tol * D
    for k in range(30):
        sim.step(state)
        if k % 6 == 5:
            exact = exact_max_overlap(world, state.pos, R)
            assert exact["max"] <= tol
            assert sim.max_overlap(state) == pytest.approx(exact["max"], abs=2e-4)
    # non-vacuous: robots moved so far since the build that the sweeps had to scan
    # more than one ring of cells
    d_bound = float(sim._dev.ctrl.copy_to_host()[1])  # D_IN
    assert 2 * R + 2 * d_bound > sim._dev.cs


def test_reordering_keeps_each_robots_data_with_its_id():
    world = _box(200, 0.4)
    # a thin skin, so that the grid is rebuilt (and the robots re-sorted) within 8 steps
    params = EngineParams(dt=0.1, tau=1.0, radius=R, desync=False, skin=0.1)
    sim = GpuSimulator(world, params, BoltzmannUniform(KT))
    rng = np.random.default_rng(6)
    group = np.arange(200) % 7
    state = sim.init(place_lattice(world.bounds, 200, R, rng), rng, group=group)
    sim.step(state)
    speed0 = state.by_id(state.speed).copy()
    rebuilds = 0
    for _ in range(8):  # within the control period: speeds are held
        rebuilds += sim._dev.need_rebuild
        sim.step(state)
    assert rebuilds >= 2  # the robots were re-sorted meanwhile
    assert np.array_equal(np.sort(state.ids), np.arange(200))
    assert np.array_equal(state.by_id(state.speed), speed0)
    assert np.array_equal(state.by_id(state.group), group)


def test_rebuild_sorts_by_cell_stably_through_a_tiled_prefix_sum():
    # 262 x 262 cells: the prefix sum over cells takes 17 tiles, each scanned in shared
    # memory, their totals scanned by one block and added back
    n = 1200
    world = box_world(13_000.0, 13_000.0)
    sim = GpuSimulator(world, EngineParams(radius=R, cell_size=50.0), BoltzmannUniform(KT))
    rng = np.random.default_rng(5)
    state = sim.init(place_lattice(world.bounds, n, R, rng), rng)  # robots in id order
    d = sim._dev
    assert d.nx * d.ny > 256**2 and d.scan.shape[0] > 10
    start = d.cell_start.copy_to_host()
    assert start[0] == 0 and start[-1] == n and np.all(np.diff(start) >= 0)
    x0, y0, cs = (float(v) for v in d.geo.copy_to_host()[:3])
    rel = d.x[d.cur].copy_to_host().astype(np.float64), d.y[d.cur].copy_to_host()
    cx = np.clip(np.floor((rel[0] - x0) / cs), 0, d.nx - 1)
    cy = np.clip(np.floor((rel[1] - y0) / cs), 0, d.ny - 1)
    cell = (cy * d.nx + cx).astype(np.int64)
    # every robot lies in the cell whose range holds it; the first build keeps id order
    # within a cell (stable), whatever order the atomic counts took
    assert np.array_equal(cell, np.searchsorted(start, np.arange(n), side="right") - 1)
    ids = state.ids
    assert np.array_equal(np.lexsort((ids, cell)), np.arange(n))
    assert np.allclose(state.by_id(state.pos), place_lattice(world.bounds, n, R,
                       np.random.default_rng(5)), atol=1e-3)  # fmt: skip


# ----------------------------------------------------------------------------- the draws
@pytest.mark.parametrize("law", ["boltzmann", "half-normal"])
def test_device_draws_follow_the_policys_laws(law):
    n = 4_000
    policy = BoltzmannUniform(KT, half_width=math.pi / 2, speed_law=law)
    world = _box(n, 0.1)
    sim = GpuSimulator(world, EngineParams(radius=R), policy)
    assert sim._on_device is not None
    rng = np.random.default_rng(8)
    state = sim.init(place_lattice(world.bounds, n, R, rng), rng)
    ks = stats.kstest(state.speed, policy._law.cdf)
    assert ks.pvalue > 1e-3, ks
    rel = state.heading - math.pi / 2
    ks = stats.kstest(rel, stats.uniform(-math.pi / 2, math.pi).cdf)
    assert ks.pvalue > 1e-3, ks


# ----------------------------------------------------------------------------- diffusion
def _diffusion(sim, state, tau, steps, lag_periods=4):
    """D from non-overlapping windows of lag_periods * tau with a gap of tau (the box
    scenario's estimator): windows are independent, so the se is the sample se."""
    every = int(round(tau / sim.params.dt))
    frames = [state.by_id(state.pos).copy()]
    for k in range(steps):
        sim.step(state)
        if (k + 1) % every == 0:
            frames.append(state.by_id(state.pos).copy())
    pos = np.array(frames)
    k = lag_periods
    starts = np.arange(0, pos.shape[0] - k, k + 1)
    sq = ((pos[starts + k] - pos[starts]) ** 2).sum(axis=2).ravel()
    T = k * tau
    est = (sq + 2 * KT * tau**2 / 3) / (4 * T)
    return est.mean(), est.std(ddof=1) / math.sqrt(est.size)


def test_diffusion_matches_the_cpu_engine_and_kT_tau_over_2():
    # dilute (phi = 0.005: mean free path ~ 2.6 m against a 10 mm persistence length),
    # so collisions change D by well under its 2 % standard error; dt = tau / 2 (the
    # motion is piecewise straight, so dt does not change D) keeps the simulator quick
    n, tau = 60, 1.0
    world = _box(n, 0.005)
    params = EngineParams(dt=0.5, tau=tau, radius=R)
    (cs, cst), (gs, gst) = _pair(world, params, BoltzmannUniform(KT), n, seed=10)
    d_cpu, se_cpu = _diffusion(cs, cst, tau, 300)
    d_gpu, se_gpu = _diffusion(gs, gst, tau, 300)
    theory = KT * tau / 2
    assert abs(d_gpu - d_cpu) < 4 * math.hypot(se_gpu, se_cpu), (d_gpu, d_cpu, se_gpu)
    assert abs(d_gpu - theory) < 4 * se_gpu, (d_gpu, theory, se_gpu)
    assert se_gpu < 0.03 * theory  # the test has power: 4 se < 12 % of D


# ----------------------------------------------------------------------------- pressure
def _slit(width, height, force=None):
    """Static side walls; top and bottom walls held in place (force gauges), or pushed
    by ``force`` with drag 50."""
    drag = math.inf if force is None else 50.0
    f = 0.0 if force is None else force
    pistons = (
        Piston(axis=1, position=0.0, side=1, lo=0.0, hi=width, force=f, drag=drag),
        Piston(axis=1, position=height, side=-1, lo=0.0, hi=width, force=f, drag=drag),
    )
    seg = np.array([[0, -50, 0, height + 50], [width, -50, width, height + 50]], float)
    return World((0.0, -50.0, width, height + 50.0), seg, pistons=pistons)


def _pressure(sim, state, steps, batches, width):
    """Mean pressure on the two walls (force per mm) and its batch-means error."""
    f = np.empty(steps)
    for k in range(steps):
        sim.step(state)
        # piston 0 (side +1) is pushed along -y, piston 1 (side -1) along +y
        f[k] = 0.5 * (state.piston_force[1] - state.piston_force[0]) / (width - D)
    b = f.reshape(batches, -1).mean(axis=1)
    return b.mean(), b.std(ddof=1) / math.sqrt(batches)


def _pressure_pair(n, width, height, steps, batches, seed, host_policy=False):
    # dt = tau / 2 keeps the simulator quick: a robot against a wall moves it by its
    # speed whatever dt, so the mean force does not depend on dt
    world = _slit(width, height)
    params = EngineParams(dt=0.5, tau=1.0, radius=R)
    # initial positions inside the slit, clear of the walls
    rng0 = np.random.default_rng(seed + 1)
    pos = place_lattice((0.0, 0.0, width, height), n, R, rng0)
    out = []
    for make in (Simulator, GpuSimulator):
        kw = {"host_policy": host_policy} if make is GpuSimulator else {}
        sim = make(world, params, BoltzmannUniform(KT), None, **kw)
        state = sim.init(pos, np.random.default_rng(seed))
        for _ in range(40):  # settle (20 s)
            sim.step(state)
        out.append(_pressure(sim, state, steps, batches, width))
    return out


@pytest.mark.slow  # 1-2.5 min in numba-cuda's simulator: kept out of make test
def test_wall_pressure_matches_the_cpu_engine():
    # slit 60 mm high: the density profile relaxes in h^2 / (pi^2 D) = 11 s, and the
    # 10 batches of 20 s are ~2 relaxation times each, so batch means are ~independent
    (p_cpu, se_cpu), (p_gpu, se_gpu) = _pressure_pair(
        18, 1200.0, 60.0, steps=400, batches=10, seed=12
    )
    assert p_cpu > 0 and p_gpu > 0
    assert abs(p_gpu - p_cpu) < 4 * math.hypot(se_gpu, se_cpu), (p_gpu, p_cpu, se_gpu, se_cpu)
    assert se_gpu < 0.1 * p_gpu  # the test has power


@pytest.mark.slow
def test_wall_pressure_matches_the_cpu_engine_large():
    # the same through the host path of the policy (decisions copied every step)
    (p_cpu, se_cpu), (p_gpu, se_gpu) = _pressure_pair(
        120, 3000.0, 150.0, steps=8_000, batches=20, seed=14, host_policy=True
    )
    assert abs(p_gpu - p_cpu) < 4 * math.hypot(se_gpu, se_cpu), (p_gpu, p_cpu, se_gpu, se_cpu)
    assert se_gpu < 0.03 * p_gpu


# ----------------------------------------------------------------------------- bodies, walls
@dataclass(frozen=True)
class _Drive:
    """Every robot heads along +x at a fixed speed (a host-side policy)."""

    speed: float

    def act(self, obs, rng):
        return Action(heading=np.zeros(obs.n), speed=np.full(obs.n, self.speed))


def test_a_robot_pushes_a_body_and_a_wall_at_the_rigid_contact_speed():
    # one robot behind a movable disc (drag 4), one behind a piston (drag 9): the
    # overdamped rigid solution moves them at v / (1 + drag) and the reported contact
    # force balances the drag (force = drag * velocity), on both engines
    body = Body(x=200.0 + R + 50.0, y=100.0, radius=50.0, drag=4.0)
    piston = Piston(axis=0, position=200.0 + R, side=-1, lo=250.0, hi=450.0, drag=9.0)
    world = World((0.0, 0.0, 2000.0, 500.0), polygon_segments([(0, 0), (2000, 0),
                  (2000, 500), (0, 500)]), bodies=(body,), pistons=(piston,))  # fmt: skip
    params = EngineParams(dt=0.1, tau=1.0, radius=R, desync=False)
    pos = np.array([[200.0, 100.0], [200.0, 350.0]])
    v = 10.0
    results = []
    for sim in (
        Simulator(world, params, _Drive(v)),
        GpuSimulator(world, params, _Drive(v)),
    ):
        state = sim.init(pos.copy(), np.random.default_rng(0))  # the CPU engine reuses it
        for _ in range(100):
            sim.step(state)
        results.append((state.body_pos[0].copy(), float(state.body_force[0, 0]),
                        float(state.piston_pos[0]), float(state.piston_force[0])))  # fmt: skip
        t = 100 * params.dt
        assert state.body_pos[0, 0] - body.x == pytest.approx(v / 5 * t, rel=1e-3)
        assert state.body_pos[0, 1] == pytest.approx(body.y, abs=1e-3)
        assert state.body_force[0, 0] == pytest.approx(4.0 * v / 5, rel=1e-3)
        assert state.piston_pos[0] - piston.position == pytest.approx(v / 10 * t, rel=1e-3)
        # the piston's side is -1: the robot pushes it along +x
        assert state.piston_force[0] == pytest.approx(9.0 * v / 10, rel=1e-3)
    (bc, fc, pc, qc), (bg, fg, pg, qg) = results
    # float32 positions ~800 mm from the world's centre round to 6e-5 mm, a few times a
    # step: after 100 steps the engines may differ by ~1e-2 mm
    assert np.allclose(bc, bg, atol=1e-2) and pc == pytest.approx(pg, abs=1e-2)
    assert fc == pytest.approx(fg, rel=1e-3) and qc == pytest.approx(qg, rel=1e-3)


# ----------------------------------------------------------------------------- runs
SMALL = ("n=40", "packing_fraction=0.3", "duration=20", "tau=0.5", "record.interval=0.5",
         "record.block=8", "engine.backend='gpu'")  # fmt: skip


@pytest.mark.slow  # 1-2.5 min in numba-cuda's simulator: kept out of make test
def test_a_gpu_run_records_to_zarr_and_resumes_to_the_uninterrupted_result(tmp_path, monkeypatch):
    from thermoswarm.scenarios.box import Box

    cfg = runner.resolve("box", overrides=SMALL, seed=3)
    runner.run(cfg, tmp_path / "ref", progress=False)
    real = Box.observe

    def crash(self, sim, state, acc):
        if state.step == 117:  # after two committed blocks, mid-block
            raise KeyboardInterrupt
        real(self, sim, state, acc)

    monkeypatch.setattr(Box, "observe", crash)
    with pytest.raises(KeyboardInterrupt):
        runner.run(cfg, tmp_path / "cut", progress=False)
    monkeypatch.setattr(Box, "observe", real)
    runner.resume(tmp_path / "cut", progress=False)
    ref = xr.open_dataset(tmp_path / "ref" / "tracks.nc")
    cut = xr.open_dataset(tmp_path / "cut" / "tracks.nc")
    for var in ("position", "heading", "speed"):
        assert np.array_equal(ref[var].values, cut[var].values, equal_nan=True), var
    assert not np.isnan(ref["position"].values).any()
    m = json.loads((tmp_path / "ref" / "metrics.json").read_text())
    assert m["final_max_overlap_fraction"] <= 0.005


@pytest.mark.slow  # 1-2.5 min in numba-cuda's simulator: kept out of make test
def test_compression_and_transport_run_on_the_gpu_backend(tmp_path):
    m = runner.run(runner.resolve("compression", overrides=("n=60", "duration=15",
                   "engine.backend='gpu'"), seed=1), tmp_path / "c", progress=False)  # fmt: skip
    assert m["pressure"] > 0 and m["final_max_overlap_fraction"] <= 0.005
    m = runner.run(runner.resolve("transport-free", overrides=("n=80", "duration=5",
                   "engine.backend='gpu'"), seed=1), tmp_path / "t", progress=False)  # fmt: skip
    assert m["max_overlap_fraction"] <= 0.005
    tracks = xr.open_dataset(tmp_path / "t" / "tracks.nc")
    assert set(np.unique(tracks["phase"].values)) <= {0, 1}
    assert tracks["object_position"].shape[0] == tracks.sizes["time"]


# ----------------------------------------------------------------------------- dispatch
def test_dispatch_and_what_the_gpu_backend_refuses(tmp_path):
    world = _box(10, 0.1)
    params = EngineParams(radius=R)
    assert isinstance(make_simulator(world, params, BoltzmannUniform(KT), backend="gpu",
                                     device="cpu"), GpuSimulator)  # fmt: skip
    assert isinstance(make_simulator(world, params, BoltzmannUniform(KT)), Simulator)
    with pytest.raises(ConfigError, match="backend"):
        make_simulator(world, params, BoltzmannUniform(KT), backend="tpu")
    with pytest.raises(ConfigError, match="overdamped"):
        GpuSimulator(world, EngineParams(mode="inertial"), None)
    # numba-cuda runs a process on the GPU or in its simulator, not both
    other = "cuda:0" if simulated() else "simulator"
    with pytest.raises(ConfigError, match="once per process"):
        GpuSimulator(world, params, BoltzmannUniform(KT), device=other)
    with pytest.raises(ConfigError, match="not available"):
        runner.run(runner.resolve("transport-connected", overrides=("engine.backend='gpu'",)),
                   tmp_path / "x", progress=False)  # fmt: skip
    res = CliRunner().invoke(cli, ["simulate", "box", "--out", str(tmp_path / "y"), "--set",
                                   "engine.backend='tpu'"])  # fmt: skip
    assert res.exit_code == 2 and "backend" in res.output


def test_bench_command_on_the_gpu_backend():
    res = CliRunner().invoke(cli, ["bench", "--backend", "gpu", "--n", "200",
                                   "--phi", "0.5", "--seconds", "2", "--json"])  # fmt: skip
    assert res.exit_code == 0, res.output
    out = json.loads(res.output.strip().splitlines()[-1])
    assert out["backend"] == "gpu" and out["n"] == 200 and out["steps"] == 20
    assert out["exact_max_overlap_fraction"] <= 0.005
    assert 0 < out["device_bytes_per_robot"] <= 100
