"""Kinematics on constructed tracks with known answers, and every messy case counted."""

from __future__ import annotations

import numpy as np
import pytest
from analysis_helpers import MIXTURE, STEER_T, circle_tracks, straight_tracks
from scipy.signal import savgol_coeffs

from thermoswarm.analysis.kinematics import DATA_QUALITY_KEYS, compute_kinematics, data_quality
from thermoswarm.analysis.synthetic import synthetic_tracks
from thermoswarm.errors import ConfigError, InputError
from thermoswarm.maxent import SteeringLaw
from thermoswarm.tracks import make_tracks


def test_circle_speed_heading_and_turn_rate_are_exact():
    R, w, fps = 100.0, 0.5, 30.0
    k = compute_kinematics(circle_tracks(R, w, fps, n=200))
    chord = 2 * R * np.sin(w / fps / 2) * fps
    speed = k["speed"].values[:-1, 0]
    np.testing.assert_allclose(speed, chord, rtol=1e-9)
    assert np.isnan(k["speed"].values[-1, 0])  # no step starts at the last sample
    np.testing.assert_allclose(k["energy"].values[:-1, 0], chord**2 / 2, rtol=1e-9)
    rate = k["steering_rate"].values[1:-1, 0]
    np.testing.assert_allclose(rate, w, rtol=1e-9)  # counter-clockwise: positive
    # heading of chord k: the tangent at the chord's middle, w (t_k + dt/2) + pi/2
    t = k["time"].values[:-1]
    expect = np.angle(np.exp(1j * (w * (t + 0.5 / fps) + np.pi / 2)))
    np.testing.assert_allclose(np.angle(np.exp(1j * (k["heading"].values[:-1, 0] - expect))), 0,
                               atol=1e-9)  # fmt: skip
    dq = data_quality(k)
    assert dq["n_steps_used"] == 199 and dq["n_steering_samples"] == 198
    assert set(dq) == {*DATA_QUALITY_KEYS, "step_buckets"}


def test_clockwise_turns_are_negative_and_mass_gives_joules():
    R, w, fps, m = 50.0, -1.0, 20.0, 1e-5
    k = compute_kinematics(circle_tracks(R, w, fps, n=50), mass=m)
    assert np.all(k["steering_rate"].values[1:-1, 0] < 0)
    v = 2 * R * np.sin(abs(w) / fps / 2) * fps  # mm/s
    np.testing.assert_allclose(k["energy"].values[:-1, 0], 0.5 * m * (v / 1000) ** 2, rtol=1e-9)
    assert k["energy"].attrs["units"] == "J" and k.attrs["energy_unit"] == "J"


@pytest.mark.parametrize("irregular", [False, True])
def test_synthetic_steps_are_recovered_exactly(irregular):
    rng = np.random.default_rng(3)
    n = 200
    time = np.cumsum(rng.uniform(0.02, 0.06, n)) if irregular else None
    ds, truth = synthetic_tracks(
        5, n, energy=MIXTURE, steering=SteeringLaw(STEER_T), time=time, fps=25.0, rng=4
    )
    k = compute_kinematics(ds, gap_factor=10.0)
    np.testing.assert_allclose(k["speed"].values[:-1], truth["speed"], rtol=1e-7)
    np.testing.assert_allclose(k["energy"].values[:-1], truth["energy"], rtol=1e-6)
    np.testing.assert_allclose(
        k["steering_rate"].values[1:-1], truth["steering_rate"][1:], rtol=1e-6, atol=1e-9
    )
    assert (k.attrs["n_irregular_steps"] > 0) == irregular


def test_missing_positions_break_steps_and_are_counted():
    ds = straight_tracks(speed=10.0, fps=10.0, n=30, n_ind=2)
    pos = ds["position"].values.copy()
    pos[5, :, 0, 0] = np.nan  # a one-sample gap inside track 0
    pos[10:13, :, 0, 0] = np.nan  # a three-sample gap
    pos[0:2, :, 0, 1] = np.nan  # track 1 starts late (not a gap inside the track)
    k = compute_kinematics(ds.assign(position=(ds["position"].dims, pos)))
    dq = data_quality(k)
    assert dq["n_missing_positions"] == 6
    assert dq["n_gaps"] == 2
    # steps touching a missing sample: 4..5, 5..6 and 9..13 for track 0; 0..2 for track 1
    valid = k["valid"].values
    bad0 = {4, 5, 9, 10, 11, 12}
    assert set(np.nonzero(~valid[:-1, 0])[0]) == bad0
    assert set(np.nonzero(~valid[:-1, 1])[0]) == {0, 1}
    assert dq["n_steps_missing_position"] == 8
    np.testing.assert_allclose(k["speed"].values[:-1][valid[:-1]], 10.0, rtol=1e-9)
    # segments: track 0 has 3, track 1 has 1
    assert dq["n_segments"] == 4


def test_short_gaps_are_interpolated_when_asked():
    ds = straight_tracks(speed=10.0, fps=10.0, n=30)
    pos = ds["position"].values.copy()
    pos[5, :, 0, 0] = np.nan  # 0.2 s between neighbours
    pos[10:14, :, 0, 0] = np.nan  # 0.5 s
    k = compute_kinematics(ds.assign(position=(ds["position"].dims, pos)), max_gap=0.25)
    assert k.attrs["n_interpolated_positions"] == 1
    np.testing.assert_allclose(k["speed"].values[3:6, 0], 10.0, rtol=1e-9)
    assert not k["valid"].values[9:14, 0].any()


def test_repeated_timestamps_follow_the_duplicates_rule():
    ds = straight_tracks(speed=10.0, fps=10.0, n=20)
    pos = ds["position"].values
    t = ds["time"].values
    # row 7 three more times: once identical, then displaced by +1 mm and -1 mm in x
    rows = [*range(8), 7, 7, 7, *range(8, 20)]
    pos2 = pos[rows].copy()
    pos2[9, 0] += 1.0
    pos2[10, 0] -= 1.0
    messy = make_tracks(pos2, time=t[rows])
    with pytest.raises(InputError, match=r"individual 'id_0' at time 0.7 s: two different"):
        compute_kinematics(messy)
    clean = compute_kinematics(ds)
    k = compute_kinematics(messy, duplicates="mean")
    assert k.attrs["n_duplicate_rows"] == 1 and k.attrs["n_conflicting_duplicates"] == 2
    assert k.sizes["time"] == 20
    np.testing.assert_allclose(k["speed"].values, clean["speed"].values, rtol=1e-9)
    first = compute_kinematics(messy, duplicates="first")
    np.testing.assert_allclose(first["speed"].values, clean["speed"].values, rtol=1e-9)
    assert list(first["input_row"].values[:10, 0]) == [*range(8), 11, 12]  # rows of the input


def test_decreasing_and_missing_timestamps_are_sorted_and_dropped():
    ds = straight_tracks(speed=5.0, fps=10.0, n=25, n_ind=2)
    rng = np.random.default_rng(0)
    order = rng.permutation(25)
    t = ds["time"].values[order].copy()
    t_nan = np.append(t, np.nan)
    pos = np.concatenate([ds["position"].values[order], np.zeros((1, 2, 1, 2))])
    k = compute_kinematics(make_tracks(pos, time=t_nan))
    clean = compute_kinematics(ds)
    assert k.attrs["n_missing_timestamps"] == 2  # one row, two individuals
    assert k.attrs["n_decreasing_timestamps"] == 2 * int((np.diff(t) < 0).sum())
    np.testing.assert_allclose(k["speed"].values, clean["speed"].values, rtol=1e-9)
    np.testing.assert_array_equal(k["time"].values, clean["time"].values)


def test_time_gaps_are_not_used_as_steps():
    ds = straight_tracks(speed=10.0, fps=10.0, n=40)
    keep = np.r_[0:15, 20:40]  # 0.6 s jump after row 14
    gappy = make_tracks(ds["position"].values[keep], time=ds["time"].values[keep])
    k = compute_kinematics(gappy)
    assert k.attrs["n_steps_time_gap"] == 1
    assert not k["valid"].values[14, 0]
    assert np.isnan(k["steering_rate"].values[15, 0])
    np.testing.assert_allclose(k["speed"].values[k["valid"].values], 10.0, rtol=1e-9)
    k2 = compute_kinematics(gappy, gap_factor=10.0)
    assert k2["valid"].values[14, 0] and k2.attrs["n_steps_time_gap"] == 0
    assert k2.attrs["n_steps_used_irregular"] == 1  # used with its own duration


def test_rounded_timestamps_are_regular_steps():
    # 10 Hz stamps rounded to the millisecond, with +-3 ms of clock noise
    rng = np.random.default_rng(1)
    t = np.round(np.arange(200) * 0.1 + rng.uniform(-0.003, 0.003, 200), 3)
    pos = np.stack([t * 10.0, np.zeros_like(t)], axis=1)[:, :, None]
    k = compute_kinematics(make_tracks(pos, time=t))
    assert k.attrs["n_irregular_steps"] == 0
    assert k.attrs["n_steps_used_regular"] == 199
    np.testing.assert_allclose(k["speed"].values[:-1, 0], 10.0, rtol=1e-9)


def test_resting_steps_are_counted_and_left_out_unless_kept():
    fps = 10.0
    x = np.concatenate([np.arange(10) * 1.0, np.full(15, 9.0), 9.0 + np.arange(1, 11) * 1.0])
    pos = np.stack([x, np.zeros_like(x)])[None].transpose(2, 1, 0)  # (time, 2, 1)
    k = compute_kinematics(make_tracks(pos, fps=fps), stationary_duration=1.0)
    dq = data_quality(k)
    # 15 repeated positions: steps 9..23 have zero length (15 steps, 1.5 s)
    assert dq["n_steps_resting"] == 15 and dq["n_steps_used"] == 19
    assert dq["resting_fraction"] == pytest.approx(15 / 34)
    assert dq["n_stationary_periods"] == 1 and dq["n_stationary_steps"] == 15
    assert dq["stationary_seconds"] == pytest.approx(1.5)
    assert not k["valid"].values[9:24, 0].any()
    assert np.all(np.isnan(k["heading"].values[9:24, 0]))
    kept = compute_kinematics(make_tracks(pos, fps=fps), keep_resting=True)
    dq = data_quality(kept)
    assert kept["valid"].values[9:24, 0].all()  # zero energies, announced
    assert dq["n_resting_kept"] == 15 and dq["n_zero_speed"] == 15
    # turns into and out of the stop are undefined; 16 turns in all touch a stop
    assert dq["n_steering_undefined"] == 16
    k2 = compute_kinematics(make_tracks(pos, fps=fps), keep_resting=True, drop_stationary=True)
    assert not k2["valid"].values[9:24, 0].any()
    assert k2.attrs["n_steps_stationary_dropped"] == 15
    k3 = compute_kinematics(make_tracks(pos, fps=fps), stationary_duration=2.0)
    assert k3.attrs["n_stationary_periods"] == 0
    held = compute_kinematics(make_tracks(pos, fps=fps), held_positions="missing")
    # the 15 held samples are missing: the 16 steps touching them, nothing rests
    assert held.attrs["n_held_positions"] == 15 and held.attrs["n_steps_resting"] == 0
    assert held.attrs["n_steps_missing_position"] == 16


def test_min_speed_max_speed_and_wrap_counts():
    ds = straight_tracks(speed=10.0, fps=10.0, n=40)
    pos = ds["position"].values.copy()
    pos[10, 0, 0, 0] += 50.0  # a 500 mm/s jump out and back
    k = compute_kinematics(ds.assign(position=(ds["position"].dims, pos)), max_speed=100.0)
    assert k.attrs["n_steps_over_max_speed"] == 2
    assert not k["valid"].values[9:11, 0].any()
    k2 = compute_kinematics(ds.assign(position=(ds["position"].dims, pos)))
    assert k2.attrs["n_steps_implausible"] == 2  # 50 x the other speeds
    k2 = compute_kinematics(ds.assign(position=(ds["position"].dims, pos)), keep_implausible=True)
    assert k2.attrs["n_implausible_kept"] == 2
    assert k2.attrs["n_steering_near_wrap"] == 2  # turning back at and after the outlier
    k3 = compute_kinematics(ds, min_speed=10.5)
    assert k3.attrs["n_zero_speed"] == 39 and k3.attrs["n_steering_samples"] == 0


def test_savgol_noise_reduction_matches_the_linear_filter_theory():
    """Velocity noise after smoothing: sigma^2 sum(d^2) / dt^2 with d the filter's step."""
    fps, n, n_ind, sigma = 20.0, 41, 3000, 0.5
    clean = straight_tracks(speed=10.0, fps=fps, n=n, n_ind=n_ind)
    rng = np.random.default_rng(5)
    noisy = clean["position"].values + rng.normal(0, sigma, clean["position"].shape)
    ds = clean.assign(position=(clean["position"].dims, noisy))
    window_s, order = 0.45, 2  # 9 samples
    k = compute_kinematics(ds, smooth=window_s, polyorder=order)
    assert k.attrs["smooth_window_samples"] == 9
    assert k.attrs["n_segments_smoothed"] == n_ind
    mid = n // 2  # an interior step, one per track: independent samples
    vx = k["speed"].values[mid] * np.cos(k["heading"].values[mid])
    vy = k["speed"].values[mid] * np.sin(k["heading"].values[mid])
    err = np.concatenate([vx - 10.0 * np.cos(0.3), vy - 10.0 * np.sin(0.3)])
    s = savgol_coeffs(9, order)
    d = np.append(s, 0.0) - np.append(0.0, s)
    theory = sigma**2 * (d**2).sum() * fps**2
    rel_se = np.sqrt(2.0 / err.size)
    assert abs(err.var() / theory - 1) < 3 * rel_se
    raw = compute_kinematics(ds)
    vx_raw = raw["speed"].values[mid] * np.cos(raw["heading"].values[mid]) - 10 * np.cos(0.3)
    assert abs(vx_raw.var() / (2 * sigma**2 * fps**2) - 1) < 3 * np.sqrt(2.0 / n_ind)


def test_smoothing_irregular_and_short_segments():
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.08, 0.12, 60))
    pos = np.zeros((60, 2, 2))
    pos[:, 0, 0] = 7.0 * t  # a line at 7 mm/s: every step of the pipeline is exact
    pos[:, 0, 1] = 7.0 * t
    pos[::3, :, 1] = np.nan  # track 1: segments of two samples only
    k = compute_kinematics(make_tracks(pos, time=t), smooth=0.5, gap_factor=3.0)
    assert k.attrs["n_segments_resampled"] == 1
    assert k.attrs["n_segments_unsmoothed"] == 20
    np.testing.assert_allclose(k["speed"].values[:-1, 0], 7.0, rtol=1e-6)
    with pytest.raises(ConfigError, match="smoothing window"):
        compute_kinematics(make_tracks(pos, time=t), smooth=0.1, polyorder=3)


def test_confidence_threshold_and_keypoint_choice():
    ds = straight_tracks(speed=10.0, fps=10.0, n=20)
    conf = np.ones((20, 1, 1))
    conf[4] = 0.1
    ds = make_tracks(ds["position"].values, fps=10.0, confidence=conf)
    k = compute_kinematics(ds, min_confidence=0.5)
    assert k.attrs["n_low_confidence"] == 1
    assert not k["valid"].values[3:5, 0].any()
    with pytest.raises(InputError, match="keypoint 'head'"):
        compute_kinematics(ds, keypoint="head")
    assert compute_kinematics(ds, keypoint="centroid")["valid"].values[:-1].all()


def test_frame_numbers_need_a_frame_rate():
    pos = straight_tracks(n=10)["position"].values
    ds = make_tracks(pos)  # time in frames
    with pytest.raises(InputError, match="--fps"):
        compute_kinematics(ds)
    k = compute_kinematics(ds, fps=10.0)
    np.testing.assert_allclose(k["speed"].values[:-1, 0], 10.0)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"smooth": -1}, "smooth"),
        ({"mass": 0}, "mass"),
        ({"gap_factor": 0.5}, "gap_factor"),
        ({"min_speed": "fast"}, "min_speed"),
        ({"polyorder": 0}, "polyorder"),
    ],
)
def test_bad_options_are_config_errors(kwargs, match):
    with pytest.raises(ConfigError, match=match):
        compute_kinematics(straight_tracks(n=10), **kwargs)


def test_too_few_times_is_an_input_error():
    with pytest.raises(InputError, match="at least 2 samples of one individual"):
        compute_kinematics(make_tracks(np.zeros((1, 2, 1)), fps=1.0))


def test_a_table_too_large_is_refused_at_once(monkeypatch):
    # fragmented identities: one long track beside many short ones would need a
    # (samples x individuals) table far larger than the samples; the bound is checked
    # before anything is allocated (lowered here so the test stays small)
    import thermoswarm.analysis.kinematics as kinematics

    monkeypatch.setattr(kinematics, "MAX_CELLS", 100)
    with pytest.raises(InputError, match=r"merge fragmented track ids"):
        compute_kinematics(straight_tracks(n=60, n_ind=2))
