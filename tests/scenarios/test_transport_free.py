"""``transport-free``: builds and runs for every variant, phases follow the light, the
net force flips sign with the mapping, metric helpers on constructed cases, bad configs."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

from thermoswarm.cli import cli
from thermoswarm.errors import ConfigError
from thermoswarm.policy import PHASE_HOT
from thermoswarm.scenarios import runner
from thermoswarm.scenarios._transport import (
    batch_mean_se,
    first_crossing_time,
    segment_distance,
    shadow_polygon,
)
from thermoswarm.scenarios.transport_free import (
    transport_metrics,
    zigzag_centreline,
)

R_ROBOT = 16.5


def _build(*overrides, seed=0):
    cfg = runner.resolve("transport-free", overrides=list(overrides), seed=seed)
    return runner.build(cfg)


def _advance(scen, setup, sim, state, steps):
    acc = scen.init_acc(setup, sim, state)
    for _ in range(steps):
        sim.step(state)
        scen.observe(sim, state, acc)
    return acc


@pytest.mark.parametrize("variant", ["free", "obstacle", "zigzag"])
def test_every_variant_builds_and_runs(variant):
    scen, setup, sim, state = _build(f"variant={variant}", "n=150", "duration=5")
    g = setup.info
    walls = np.asarray(g["walls"])
    _advance(scen, setup, sim, state, 30)
    # no robot overlaps anything by more than 2 % of a diameter, nor leaves the arena
    assert sim.max_overlap(state) < 0.02 * 33
    x0, y0, x1, y1 = g["bounds"]
    assert state.pos[:, 0].min() > x0 and state.pos[:, 0].max() < x1
    assert state.pos[:, 1].min() > y0 and state.pos[:, 1].max() < y1
    # robots keep clear of every wall, the object clear of walls and obstacles
    assert segment_distance(state.pos, walls).min() > R_ROBOT - 0.02 * 33
    obj = state.body_pos[0]
    assert segment_distance(obj[None], walls)[0] >= 50 - 1e-6
    for x, y, r in np.asarray(g["obstacles"]).reshape(-1, 3):
        assert math.hypot(obj[0] - x, obj[1] - y) >= 50 + r - 1e-6
    if variant == "zigzag":
        ch = np.asarray(g["channel"])
        above = state.pos[:, 1] > ch[0, 1]
        xc = np.interp(state.pos[above, 1], ch[:, 1], ch[:, 0])
        assert np.all(np.abs(state.pos[above, 0] - xc) < g["channel_width"] / 2)
        assert above.sum() > 0  # some robots start in the channel


@pytest.mark.parametrize("mapping", ["lit_cold", "lit_hot"])
def test_initial_phase_is_the_mapping_of_the_object_shadow(mapping):
    """At t = 0 every robot decided at its start: the shadow strip behind the object
    (|x - x_obj| < R, y < y_obj for light from +y) is hot under lit_cold and cold under
    lit_hot; everywhere else the opposite."""
    scen, setup, sim, state = _build(f"mapping={mapping}", "n=400")
    pos = state.pos
    ox, oy = setup.info["object_start"]
    shadow = (np.abs(pos[:, 0] - ox) < 50) & (pos[:, 1] < oy)
    assert shadow.sum() >= 3
    hot = state.group == PHASE_HOT
    expect = shadow if mapping == "lit_cold" else ~shadow
    assert np.array_equal(hot, expect)


def test_swapping_hot_and_cold_flips_the_sign_of_the_net_force():
    """Held object (a force gauge), persistent headings, a 300 mm object so that the
    shadow region is wider than a hot robot's persistence length (about 30 mm): the hot
    side pushes toward the cold side.  lit_cold (hot shadow behind): force toward the
    light; lit_hot: away.  Each sign must hold beyond 3 batch-means standard errors."""
    common = [
        "n=300",
        "width=1000",
        "height=1000",
        "object_radius=150",
        "object_drag=inf",
        "heading_law=persistent",
        "duration=100",
    ]
    out = {}
    for mapping in ("lit_cold", "lit_hot"):
        scen, setup, sim, state = _build(*common, f"mapping={mapping}", seed=7)
        acc = _advance(scen, setup, sim, state, 1000)
        assert np.allclose(state.body_pos[0], setup.info["object_start"])  # held
        out[mapping] = batch_mean_se(acc["force_sum"][:, 1], acc["force_count"])
    (m_cold, se_cold, _), (m_hot, se_hot, _) = out["lit_cold"], out["lit_hot"]
    assert m_cold > 3 * se_cold
    assert m_hot < -3 * se_hot


def test_run_writes_metrics_phases_and_object_path(tmp_path):
    cfg = runner.resolve(
        "transport-free",
        overrides=["n=120", "width=700", "height=700", "duration=20", "record.interval=2"],
    )
    m = runner.run(cfg, tmp_path / "run")
    for key in (
        "displacement_toward_target",
        "max_displacement_toward_target",
        "time_to_target",
        "force_toward_target",
        "object_path",
        "hot_fraction_mean",
        "speed_by_phase",
    ):
        assert key in m
    on_disk = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert on_disk["displacement_toward_target"] == m["displacement_toward_target"]
    tracks = runner.open_run_tracks(tmp_path / "run" / "tracks.zarr")
    assert tracks["phase"].shape == (11, 120)
    assert set(np.unique(tracks["phase"].values)) <= {0, 1}
    obj = tracks["object_position"].values
    # the path in the metrics is the recorded object position; displacement agrees
    np.testing.assert_allclose(m["object_path"]["y"], obj[:, 1])
    assert m["displacement_toward_target"] == pytest.approx(obj[-1, 1] - obj[0, 1])
    assert m["max_displacement_toward_target"] >= max(m["displacement_toward_target"], 0)
    assert m["max_displacement_toward_target"] >= np.max(obj[:, 1] - obj[0, 1]) - 1e-9
    # measured temperature of each phase near the set one (Rayleigh speeds)
    hot = m["speed_by_phase"]["hot"]
    assert hot["samples"] > 30
    assert hot["kT_measured"] == pytest.approx(hot["kT_set"], rel=5 / math.sqrt(hot["samples"]))


@pytest.mark.parametrize("charge", [False, True])
def test_photoresistor_sensing_and_turn_time_charge(charge):
    """Photoresistor sensing runs; charging the turning time cuts the speeds of the cold
    phase well below their Boltzmann mean, while without it they follow the law."""
    scen, setup, sim, state = _build(
        "n=200",
        "width=800",
        "height=800",
        "sensor.mode=photoresistor",
        "heading_law=uniform",
        f"sensor.charge_turn_time={'true' if charge else 'false'}",
    )
    _advance(scen, setup, sim, state, 50)
    cold = state.group != PHASE_HOT
    assert cold.sum() > 50
    from thermoswarm.maxent import SpeedLaw

    law = SpeedLaw(scen.params.kT_cold)
    v = state.speed[cold]
    se = math.sqrt(law.mean_square() - law.mean() ** 2) / math.sqrt(v.size)
    if charge:
        assert v.mean() < law.mean() - 6 * se
    else:
        assert abs(v.mean() - law.mean()) < 4 * se


def test_warmup_holds_the_object_then_releases_it(tmp_path):
    cfg = runner.resolve(
        "transport-free",
        overrides=[
            "n=300",
            "width=800",
            "height=800",
            "duration=30",
            "warmup=10",
            "mapping=lit_hot",
            "target_y=401",
            "record.interval=1",
        ],
    )
    m = runner.run(cfg, tmp_path / "w")
    tracks = runner.open_run_tracks(tmp_path / "w" / "tracks.zarr")
    obj = tracks["object_position"].values
    t = tracks["time"].values
    held = t <= 10.0
    assert np.all(obj[held] == obj[0])  # not a hair of motion while held
    assert np.any(obj[~held] != obj[0])  # moves once released
    assert m["force_held"]["batches"] == 20 and math.isfinite(m["force_held"]["se"])
    assert m["warmup"] == 10.0
    # the target 1 mm above the start is reached after the release, timed from it
    assert m["time_to_target"] is not None and 0 < m["time_to_target"] <= 20.0
    first = t[np.argmax(obj[:, 1] >= 401.0)]
    assert first - 10.0 >= m["time_to_target"] - 1.0 - 1e-9


@pytest.mark.parametrize(
    ("overrides", "names"),
    [
        (["object_drag=-1"], "object_drag"),
        (["object_x=5000"], "object_x/object_y"),
        (["object_y=-10"], "object_x/object_y"),
        (["variant=spiral"], "variant"),
        (["target_y=100"], "target_y"),
        (["mapping=dark_hot"], "mapping"),
        (["variant=zigzag", "channel_width=80"], "channel_width"),
        (["variant=obstacle", "obstacle_dx=5000"], "obstacle_dx/obstacle_dy"),
        (["sensor.noise_add=-0.1"], "sensor.noise_add"),
        (["warmup=1300"], "warmup"),
    ],
)
def test_bad_config_is_a_one_line_error_naming_the_field(overrides, names):
    with pytest.raises(ConfigError, match=names.replace("/", "/")) as exc:
        runner.resolve("transport-free", overrides=overrides)
    assert "\n" not in str(exc.value)


def test_cli_bad_value_exits_2_with_one_line(tmp_path):
    res = CliRunner().invoke(
        cli,
        ["simulate", "transport-free", "--out", str(tmp_path / "x"), "--set", "object_drag=-3"],
    )
    assert res.exit_code == 2
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:") and "object_drag" in lines[0]
    assert not (tmp_path / "x").exists()


# ------------------------------------------------------------------ helpers
def test_transport_metrics_on_a_constructed_path():
    t = np.arange(6) * 10.0
    progress = np.array([0.0, 20.0, 55.0, 40.0, 70.0, 65.0])
    m = transport_metrics(t, progress, target_distance=50.0)
    assert m["displacement_toward_target"] == 65.0
    assert m["max_displacement_toward_target"] == 70.0
    assert m["time_to_target"] == 20.0
    assert m["mean_velocity_toward_target"] == pytest.approx(65.0 / 50.0)
    assert transport_metrics(t, -progress, 50.0)["time_to_target"] is None
    assert first_crossing_time(t, progress, 70.0) == 40.0
    assert first_crossing_time(t, progress, 70.1) is None


def test_batch_mean_se_matches_hand_computation():
    # batches of equal size: mean of means and sample sd / sqrt(k)
    sums = np.array([10.0, 20.0, 30.0, 40.0])
    counts = np.array([5, 5, 5, 5])
    mean, se, k = batch_mean_se(sums, counts)
    m = np.array([2.0, 4.0, 6.0, 8.0])
    assert mean == pytest.approx(5.0) and k == 4
    assert se == pytest.approx(m.std(ddof=1) / 2)
    # an empty batch is ignored; a single batch has no se
    mean2, se2, k2 = batch_mean_se([10.0, 0.0, 30.0], [5, 0, 5])
    assert (mean2, k2) == (pytest.approx(4.0), 2)
    assert se2 == pytest.approx(np.std([2.0, 6.0], ddof=1) / math.sqrt(2))
    assert math.isnan(batch_mean_se([3.0], [3])[1])


def test_segment_distance_known_cases():
    seg = np.array([[0.0, 0.0, 10.0, 0.0], [20.0, -5.0, 20.0, 5.0]])
    pts = np.array([[5.0, 3.0], [-4.0, 3.0], [16.0, 0.0], [25.0, 9.0]])
    np.testing.assert_allclose(segment_distance(pts, seg), [3.0, 5.0, 4.0, math.hypot(5, 4)])
    assert np.isinf(segment_distance(pts, np.zeros((0, 4)))).all()


def test_shadow_polygon_directional_and_point():
    poly = shadow_polygon(
        (100.0, 200.0), 50.0, {"kind": "directional", "direction": [0.0, -1.0]}, (0, 0, 400, 400)
    )
    # a strip from the disc's tangent points downward
    assert set(np.round(poly[:, 0], 9)) == {50.0, 150.0}
    assert poly[0, 1] == 200.0 and poly[3, 1] == 200.0
    assert poly[1, 1] < 0 and poly[2, 1] < 0
    # point light straight above: the edges are tangent to the disc
    lamp = (100.0, 500.0)
    poly = shadow_polygon(
        (100.0, 200.0), 50.0, {"kind": "point", "position": list(lamp)}, (0, 0, 400, 400)
    )
    for a, b in ((poly[0], poly[1]), (poly[3], poly[2])):
        d = b - a
        # distance from the disc centre to the edge line equals the radius
        dist = abs(d[0] * (200.0 - a[1]) - d[1] * (100.0 - a[0])) / np.hypot(*d)
        assert dist == pytest.approx(50.0)
        # and the edge points away from the lamp
        assert np.dot(d, a - np.array(lamp)) > 0


def test_zigzag_centreline_vertices():
    pts = zigzag_centreline(100.0, 0.0, 700.0, amplitude=50.0, leg=200.0, straight=100.0)
    expect = [(100, 0), (100, 100), (150, 300), (100, 500), (150, 700)]
    np.testing.assert_allclose(pts, expect)
    # a last leg cut by the top moves sideways in proportion
    pts = zigzag_centreline(0.0, 0.0, 250.0, amplitude=40.0, leg=200.0, straight=0.0)
    np.testing.assert_allclose(pts[-1], (40.0 - 40.0 * 0.25, 250.0))


def test_plot_frame_colours_robots_by_phase(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import to_rgba

    from thermoswarm.scenarios.transport_free import plot_frame

    cfg = runner.resolve(
        "transport-free",
        overrides=[
            "n=80",
            "width=600",
            "height=600",
            "duration=2",
            "variant=obstacle",
            "object_y=200",
            "obstacle_dy=200",
            "record.interval=1",
        ],
    )
    runner.run(cfg, tmp_path / "r")
    _, setup, _, _ = runner.build(cfg)
    tracks = runner.open_run_tracks(tmp_path / "r" / "tracks.zarr")
    fig, ax = plt.subplots()
    sc = plot_frame(ax, tracks, 1.2, setup.info)
    hot = tracks["phase"].values[1] == PHASE_HOT
    colors = sc.get_facecolors()
    assert len(colors) == 80
    red = np.all(np.isclose(colors, to_rgba("tab:red")), axis=1)
    assert np.array_equal(red, hot)
    plt.close(fig)


@pytest.mark.parametrize("scenario", ["transport-free", "transport-connected"])
def test_crash_then_resume_gives_the_uninterrupted_metrics(tmp_path, monkeypatch, scenario):
    """Everything a transport scenario accumulates lives in the checkpointed ``acc``:
    a run that dies mid-way (here after the warm-up's release) and is resumed writes
    the same metrics as an uninterrupted run."""
    from thermoswarm.scenarios import get

    if scenario == "transport-free":
        sets = [
            "n=150",
            "width=700",
            "height=700",
            "duration=40",
            "warmup=10",
            "mapping=lit_hot",
            "record.interval=1",
            "record.block=5",
        ]
    else:
        sets = ["duration=40", "record.interval=1", "record.block=5"]
    cfg = runner.resolve(scenario, overrides=sets, seed=4)
    ref = runner.run(cfg, tmp_path / "ref")

    cls = get(scenario)
    original = cls.observe

    def dying(self, sim, state, acc):
        original(self, sim, state, acc)
        if state.step == 237:
            raise KeyboardInterrupt("simulated kill")

    monkeypatch.setattr(cls, "observe", dying)
    with pytest.raises(KeyboardInterrupt):
        runner.run(cfg, tmp_path / "crashed")
    monkeypatch.setattr(cls, "observe", original)
    assert not (tmp_path / "crashed" / "metrics.json").exists()
    resumed = runner.resume(tmp_path / "crashed")
    ref.pop("performance"), resumed.pop("performance")
    assert json.loads(json.dumps(resumed)) == json.loads(json.dumps(ref))


@pytest.mark.slow
def test_default_moves_the_object_toward_the_target_over_ten_seeds(tmp_path):
    """The brief's claim for the default configuration: over 10 seeds the mean
    displacement toward the target is more than 3 standard errors above zero."""
    disp = []
    for seed in range(10):
        cfg = runner.resolve(
            "transport-free", overrides=["record.interval=20", "record.netcdf=false"], seed=seed
        )
        disp.append(runner.run(cfg, tmp_path / f"s{seed}")["displacement_toward_target"])
    d = np.asarray(disp)
    se = d.std(ddof=1) / math.sqrt(d.size)
    assert d.mean() > 3 * se
