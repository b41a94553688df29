"""``transport-connected``: the rigid composite, its drift against theory, walls and the
door, the target room, bad configs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from thermoswarm.errors import ConfigError
from thermoswarm.maxent import SpeedLaw
from thermoswarm.scenarios import runner
from thermoswarm.scenarios._transport import batch_mean_se, segment_distance
from thermoswarm.scenarios.transport_connected import attachment_offsets, max_attached


def _build(*overrides, seed=0):
    return runner.build(
        runner.resolve("transport-connected", overrides=list(overrides), seed=seed)
    )


def test_attachment_geometry():
    off = attachment_offsets(8, 50.0, 16.5)
    np.testing.assert_allclose(np.hypot(off[:, 0], off[:, 1]), 66.5)
    # evenly spaced, symmetric about the +y axis (mirror x -> -x maps the set to itself)
    mirrored = off * [-1, 1]
    d = np.hypot(*(mirrored[:, None, :] - off[None, :, :]).transpose(2, 0, 1))
    assert np.allclose(d.min(axis=1), 0, atol=1e-9)
    gaps = np.hypot(*(off - np.roll(off, 1, axis=0)).T)
    np.testing.assert_allclose(gaps, gaps[0])
    # the most robots that fit: neighbours at least one diameter apart, one more would not
    k = max_attached(50.0, 16.5)
    for kk, fits in ((k, True), (k + 1, False)):
        o = attachment_offsets(kk, 50.0, 16.5)
        assert (np.hypot(*(o - np.roll(o, 1, axis=0)).T).min() >= 33.0) == fits


def test_builds_and_steps_with_robots_fixed_around_the_object():
    scen, setup, sim, state = _build("duration=5")
    off = np.asarray(setup.info["offsets"])
    for _ in range(40):
        sim.step(state)
        np.testing.assert_allclose(state.by_id(state.pos) - state.body_pos[0], off, atol=1e-9)
    assert state.body_pos[0, 1] > setup.info["object_start"][1]  # moved toward the light


@pytest.mark.parametrize("shadow", [True, False])
def test_open_space_drift_matches_rigid_composite_theory(shadow):
    """Far from walls the composite moves toward the light at k_lit <v> (2/pi) / (k + g_o):
    the robots the object shadows keep their heading, so their sampled headings random-
    walk and add no mean drive.  Measured over 300 s, tolerance 4 batch-means SE."""
    scen, setup, sim, state = _build(
        "width=6000",
        "height=6000",
        "object_y=1000",
        "duration=300",
        f"object_shadow={'true' if shadow else 'false'}",
        seed=3,
    )
    acc = scen.init_acc(setup, sim, state)
    for _ in range(3000):
        sim.step(state)
        scen.observe(sim, state, acc)
    p = scen.params
    k_lit = 6 if shadow else 8  # 2 of 8 robots sit in the object's shadow strip
    theory = k_lit * SpeedLaw(p.kT).mean() * 2 / math.pi / (p.n_attached + p.object_drag)
    drag = p.n_attached + p.object_drag
    mean_f, se_f, _ = batch_mean_se(acc["force_sum"][:, 1], acc["force_count"])
    assert abs(mean_f / drag - theory) < 4 * se_f / drag
    # the object's displacement is the integral of the drive (no walls touched)
    dy = state.body_pos[0, 1] - setup.info["object_start"][1]
    assert dy == pytest.approx(mean_f / drag * 300.0, rel=1e-6)


def test_default_run_passes_the_door_and_reaches_the_target_room(tmp_path):
    m = runner.run(
        runner.resolve("transport-connected", overrides=["record.interval=2"]), tmp_path / "r"
    )
    assert m["reached_target"]
    assert m["time_to_target"] is not None and 0 < m["time_to_target"] <= 600
    assert m["displacement_toward_target"] >= m["target_distance"]
    tracks = runner.open_run_tracks(tmp_path / "r" / "tracks.zarr")
    obj = tracks["object_position"].values
    _, setup, _, _ = runner.build(runner.resolve("transport-connected"))
    walls = np.asarray(setup.info["walls"])
    # the composite (object + robots) never enters a wall
    assert segment_distance(obj, walls).min() >= setup.info["composite_radius"] - 1e-6
    x0, y0, x1, y1 = setup.info["target_room"]
    t = tracks["time"].values
    inside = obj[:, 1] >= m["target_y"]
    assert np.all((obj[inside, 0] > x0) & (obj[inside, 0] < x1))
    assert t[np.argmax(inside)] >= m["time_to_target"]


@pytest.mark.parametrize(
    ("overrides", "name"),
    [
        (["object_drag=-2"], "object_drag"),
        (["n_attached=13"], "n_attached"),
        (["door_width=120"], "door_width"),
        (["object_x=-400"], "object_x/object_y"),
        (["object_y=5000"], "object_x/object_y"),
        (["door_x=20"], "door_x"),
        (["sensor.mode=sonar"], "sensor.mode"),
    ],
)
def test_bad_config_names_the_field(overrides, name):
    with pytest.raises(ConfigError, match=name) as exc:
        runner.resolve("transport-connected", overrides=overrides)
    assert "\n" not in str(exc.value)


def test_plot_frame_draws_the_robots_and_their_drive(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from thermoswarm.scenarios.transport_connected import plot_frame

    cfg = runner.resolve("transport-connected", overrides=["duration=3", "record.interval=1"])
    runner.run(cfg, tmp_path / "r")
    _, setup, _, _ = runner.build(cfg)
    tracks = runner.open_run_tracks(tmp_path / "r" / "tracks.zarr")
    fig, ax = plt.subplots()
    q = plot_frame(ax, tracks, 2.0, setup.info)
    h = tracks["heading"].values[2].astype(float)
    v = tracks["speed"].values[2].astype(float)
    np.testing.assert_allclose(q.U, v * np.cos(h), rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(q.V, v * np.sin(h), rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(q.X, tracks["position"].values[2, 0, 0, :])
    plt.close(fig)
