"""Every registered scenario builds from its defaults and runs a few steps soundly."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from thermoswarm import scenarios
from thermoswarm.scenarios import runner

STEPS = 20
OVERRIDES = [f"duration={STEPS * 0.1}", "record.interval=1.0", "record.netcdf=false"]


def _robot_overlap(pos: np.ndarray, r: float) -> float:
    """Largest overlap (mm) of two robots of radius ``r``, exactly (all pairs closer
    than 2 r, found by a k-d tree independent of the engine's cell lists)."""
    pairs = cKDTree(pos).query_pairs(2 * r, output_type="ndarray")
    if pairs.shape[0] == 0:
        return 0.0
    d = np.hypot(*(pos[pairs[:, 0]] - pos[pairs[:, 1]]).T)
    return float((2 * r - d).max())


def _strict_json(text: str):
    def refuse(token):
        raise ValueError(f"metrics.json holds {token}")

    return json.loads(text, parse_constant=refuse)


def _numbers(obj):
    if isinstance(obj, dict):
        for v in obj.values():
            yield from _numbers(v)
    elif isinstance(obj, list):
        for v in obj:
            yield from _numbers(v)
    elif isinstance(obj, int | float) and not isinstance(obj, bool):
        yield obj


def test_the_registry_lists_every_scenario_module():
    assert set(scenarios.names()) >= {
        "box", "compression", "narrow-road", "transport-connected", "transport-free",
    }  # fmt: skip
    for name in scenarios.names():
        assert scenarios.get(name).name == name


@pytest.mark.parametrize("name", scenarios.names())
def test_scenario_builds_and_steps_soundly(name, tmp_path):
    cfg = runner.resolve(name, overrides=OVERRIDES, seed=0)
    scen, setup, sim, state = runner.build(cfg)
    acc = scen.init_acc(setup, sim, state)
    r = sim.params.radius
    tol = sim.params.overlap_tol * 2 * r  # the engine's target largest overlap (mm)
    xmin, ymin, xmax, ymax = setup.world.bounds
    assert state.n >= 2 and setup.positions.shape == (state.n, 2)
    for _ in range(STEPS):
        sim.step(state)
        scen.observe(sim, state, acc)
        assert np.isfinite(state.pos).all() and np.isfinite(state.heading).all()
        assert np.isfinite(state.speed).all()
        x, y = state.pos[:, 0], state.pos[:, 1]
        assert x.min() >= xmin and x.max() <= xmax and y.min() >= ymin and y.max() <= ymax
        exact = _robot_overlap(state.pos, r)
        assert exact <= tol, f"robots overlap by {exact:.3g} mm > {tol:.3g} mm"
        # the engine's own measure (robots, walls, bodies) misses no robot pair
        assert sim.max_overlap(state) >= exact - 1e-9
    assert state.step == STEPS and state.time == pytest.approx(STEPS * sim.params.dt)

    # the same run through the runner: same seed, same swarm; outputs sound
    m = runner.run(cfg, tmp_path / "run", progress=False)
    on_disk = _strict_json((tmp_path / "run" / "metrics.json").read_text())
    assert on_disk.keys() == m.keys() and len(m) > 3
    assert all(math.isfinite(v) for v in _numbers(on_disk))
    assert m["performance"]["steps"] == STEPS
    tracks = runner.open_run_tracks(tmp_path / "run" / "tracks.zarr")
    pos = tracks["position"].isel(keypoints=0).transpose("time", "individuals", "space").values
    assert pos.shape == (STEPS // 10 + 1, state.n, 2) and np.isfinite(pos).all()
    np.testing.assert_allclose(pos[-1], state.by_id(state.pos), rtol=0, atol=1e-9)

    # the overlap figures the README promises for every scenario, from one definition:
    # the final one equals the engine's independent measure of the final configuration
    for key in ("max_overlap_fraction", "final_max_overlap_fraction", "mean_sweeps_per_step"):
        assert key in m, f"{name} does not report {key}"
    final = runner.build(cfg)[2].max_overlap(state) / (2 * r)
    assert m["final_max_overlap_fraction"] == pytest.approx(final, abs=1e-12)
    assert 0 <= m["final_max_overlap_fraction"] <= sim.params.overlap_tol
    if sim.params.mode != "inertial":
        assert 0 <= m["max_overlap_fraction"] <= 2 * sim.params.overlap_tol
        assert m["mean_sweeps_per_step"] >= 0
