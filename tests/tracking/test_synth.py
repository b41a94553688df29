"""The synthetic ant videos: motion law, geometry, ground truth, rendering, writing."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy import stats
from tracking_fixtures import SMALL, small_video

from thermoswarm.config import from_mapping
from thermoswarm.errors import ConfigError, InputError
from thermoswarm.io import read_tracks
from thermoswarm.io.mot import read_mot_table
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.synth.clip import SynthConfig, generate, write_sequence, write_video


def _road_coords(video, pos_mm):
    """Image mm (..., 2) -> road (s, u)."""
    road = video.config.road
    rel = pos_mm - np.asarray(road.origin)
    return rel if road.horizontal else rel[..., ::-1]


def test_config_rejects_bad_values():
    with pytest.raises(ConfigError, match="width"):
        SynthConfig(width=8)
    with pytest.raises(ConfigError, match="phi"):
        SynthConfig(phi=1.5)
    # 40 mm of road at 3.04 px/mm is 122 px: a 100 px high frame cannot hold it.
    with pytest.raises(ConfigError, match="road_wide_mm"):
        SynthConfig(width=400, height=100)
    with pytest.raises(ConfigError, match="unknown key 'n_ant'"):
        from_mapping(SynthConfig, {"n_ant": 3})


def test_same_seed_same_video_and_frames_in_any_order():
    a = small_video(seed=3, n_frames=12)
    b = small_video(seed=3, n_frames=12)
    c = small_video(seed=4, n_frames=12)
    np.testing.assert_array_equal(a.keypoints, b.keypoints)
    np.testing.assert_array_equal(a.mot_gt, b.mot_gt)
    assert not np.array_equal(a.keypoints[:, :8], c.keypoints[:, :8])
    frames = list(a.frames())
    np.testing.assert_array_equal(frames[7], b.render(7))
    np.testing.assert_array_equal(frames[2], a.render(2))
    assert frames[0].shape == (SMALL["height"], SMALL["width"], 3)
    assert frames[0].dtype == np.uint8
    assert not np.array_equal(frames[0], c.render(0))


@pytest.mark.parametrize("portrait", [False, True])
def test_ants_stay_on_the_road_and_their_number_is_constant(portrait):
    w, h = (SMALL["width"], SMALL["height"])
    v = small_video(
        seed=11, n_ants=12, n_frames=300, **({"width": h, "height": w} if portrait else {})
    )
    cfg = v.config
    alive = np.isfinite(v.keypoints[:, :, 1, 0])
    assert np.all(alive.sum(axis=1) == cfg.n_ants)
    su = _road_coords(v, v.keypoints[:, :, 1, :] / cfg.px_per_mm)[alive]
    road = cfg.road
    margin = cfg.ant_width_mm / 2
    assert np.all(np.abs(su[:, 1]) <= road.half_width(su[:, 0]) - margin + 1e-9)
    assert np.all((su[:, 0] >= 0) & (su[:, 0] <= road.length))
    # Ants leave and new ones enter at the ends over 10 s: identities turn over.
    assert v.ids.size > cfg.n_ants
    # The road runs along the frame's long axis.
    assert road.horizontal is (not portrait)


def test_positions_carry_the_sampled_speed_and_steering_rate_exactly():
    v = small_video(seed=5, n_ants=10, n_frames=200)
    ds = v.tracks
    dt = 1.0 / v.config.fps
    body = ds["position"].sel(keypoints="body").transpose("time", "individuals", "space").values
    speed = ds["speed"].values
    rate = ds["steering_rate"].values
    wall = ds["wall_contact"].values
    step = body[1:] - body[:-1]  # (T-1, N, 2)
    ok = np.all(np.isfinite(step), axis=-1) & ~wall[:-1]
    measured = np.linalg.norm(step, axis=-1)
    np.testing.assert_allclose(measured[ok], speed[:-1][ok] * dt, rtol=1e-9, atol=1e-12)
    heading = np.arctan2(step[..., 1], step[..., 0])
    turn = (heading[1:] - heading[:-1] + np.pi) % (2 * np.pi) - np.pi
    ok2 = ok[1:] & ok[:-1] & (speed[:-2] > 1e-6) & (speed[1:-1] > 1e-6)
    np.testing.assert_allclose(turn[ok2], rate[:-2][ok2] * dt, atol=1e-9)
    assert ok2.sum() > 1000


def test_energy_law_with_memoryless_draws():
    # With vanishing holding times every frame draws afresh: the energies are iid from
    # the two-phase mixture (and the phases iid Bernoulli(phi)).
    cfg = SynthConfig(
        **SMALL,
        n_ants=20,
        n_frames=400,
        speed_tau_s=1e-9,
        phase_tau_s=1e-9,
        phi=0.35,
        kT1=25.0,
        kT2=250.0,
    )
    v = generate(cfg, np.random.default_rng(12))
    e = 0.5 * v.tracks["speed"].values ** 2
    e = e[np.isfinite(e)]
    assert e.size == 20 * 400
    res = stats.kstest(e, cfg.energy_law.cdf)
    assert res.pvalue > 1e-3
    phase = v.tracks["phase"].values
    frac1 = np.mean(phase[phase > 0] == 1)
    se = np.sqrt(0.35 * 0.65 / phase[phase > 0].size)
    assert abs(frac1 - 0.35) < 4 * se
    # A single exponential with the same mean is rejected: the test has power.
    assert stats.kstest(e, stats.expon(scale=cfg.energy_law.mean()).cdf).pvalue < 1e-6


def test_held_speeds_keep_the_energy_marginal():
    # With holding (the default), successive frames repeat a draw, but every frame's
    # energy is still a draw from the mixture: use every 90th frame (3 s apart).
    cfg = SynthConfig(**SMALL, n_ants=30, n_frames=2700, phase_tau_s=0.5, speed_tau_s=0.25)
    v = generate(cfg, np.random.default_rng(21))
    e = 0.5 * v.tracks["speed"].values[::90] ** 2
    e = e[np.isfinite(e)]
    assert stats.kstest(e, cfg.energy_law.cdf).pvalue > 1e-3


def test_steering_rate_law():
    v = small_video(seed=8, n_ants=20, n_frames=400)
    law = v.config.steering_law
    w = v.tracks["steering_rate"].values
    s = v.tracks["speed"].values
    ok = np.isfinite(w)
    z = np.abs(w[ok]) / law.temperature(s[ok])
    assert stats.kstest(z, stats.expon().cdf).pvalue > 1e-3
    # The temperature falls with speed: slow ants turn more.
    slow, fast = s[ok] < np.quantile(s[ok], 0.2), s[ok] > np.quantile(s[ok], 0.8)
    assert np.abs(w[ok][slow]).mean() > 2 * np.abs(w[ok][fast]).mean()


def test_mot_ground_truth_matches_keypoints(video_small):
    v = video_small
    gt = v.mot_gt
    alive = np.isfinite(v.keypoints[:, :, 1, 0])
    assert gt.shape == (alive.sum(), 9)
    t = gt[:, 0].astype(int) - 1
    i = np.searchsorted(v.ids, gt[:, 1].astype(int))
    assert np.all(alive[t, i])
    pad = v.box_pad_px
    boxes = anatomy.pose_boxes(v.keypoints[t, i], pad)
    np.testing.assert_allclose(gt[:, 2:6], boxes)
    # Every keypoint lies inside its box, at least pad from the edges.
    kp = v.keypoints[t, i]
    assert np.all(kp[..., 0] >= gt[:, 2:3] + pad - 1e-9)
    assert np.all(kp[..., 0] <= gt[:, 2:3] + gt[:, 4:5] - pad + 1e-9)
    assert np.all((gt[:, 8] > 0) & (gt[:, 8] <= 1))


def test_ants_are_rendered_where_the_ground_truth_says(video_small, frames_small):
    v = video_small
    bg = v.background()[..., 1]
    hits, total = 0, 0
    for k in (0, 30, 59):
        g = frames_small[k][..., 1].astype(float)
        tail = v.keypoints[k, :, 2]
        ok = np.all(np.isfinite(tail), axis=1)
        xi, yi = np.round(tail[ok]).astype(int).T
        inside = (xi >= 0) & (xi < v.config.width) & (yi >= 0) & (yi < v.config.height)
        rel = 1 - g[yi[inside], xi[inside]] / bg[yi[inside], xi[inside]]
        hits += int((rel > 0.4).sum())
        total += int(inside.sum())
    assert total >= 20
    assert hits / total > 0.95
    # Far from every ant the frame is the (lit) background: mean relative change small.
    g = frames_small[30][..., 1].astype(float)
    yy, xx = np.mgrid[0 : v.config.height, 0 : v.config.width]
    far = np.ones_like(g, bool)
    for p in v.keypoints[30, :, 1]:
        if np.all(np.isfinite(p)):
            far &= (xx - p[0]) ** 2 + (yy - p[1]) ** 2 > (2 * 7.14 * 3.04) ** 2
    ratio = np.median(g[far] / bg[far])
    assert 0.6 < ratio < 1.4


def test_write_video_mp4_and_frames(tmp_path, video_small, frames_small):
    frames = frames_small[:10]
    mp4 = write_video(frames, tmp_path / "v.mp4", fps=30)
    cap = cv2.VideoCapture(str(mp4))
    back = []
    while True:
        ok, f = cap.read()
        if not ok:
            break
        back.append(cv2.cvtColor(f, cv2.COLOR_BGR2RGB))
    assert len(back) == 10
    err = np.mean([np.abs(a.astype(float) - b).mean() for a, b in zip(frames, back, strict=True)])
    assert err < 6.0
    folder = write_video(frames, tmp_path / "img1", fps=30)
    names = sorted(p.name for p in folder.iterdir())
    assert names[0] == "000001.png" and len(names) == 10
    f3 = cv2.cvtColor(cv2.imread(str(folder / "000003.png")), cv2.COLOR_BGR2RGB)
    np.testing.assert_array_equal(f3, frames[2])
    assert not list(tmp_path.glob(".*tmp"))  # no temporary left behind


def test_write_sequence_round_trip(tmp_path):
    v = small_video(seed=2, n_frames=8)
    out = write_sequence(v, tmp_path / "seq", video_format="frames")
    table = read_mot_table(out / "gt" / "gt.txt")
    np.testing.assert_allclose(table[:, :6], v.mot_gt[:, :6], atol=1e-3)
    ds = read_tracks(out / "gt_tracks.nc")
    np.testing.assert_allclose(ds["position"].values, v.tracks["position"].values)
    assert list(ds["keypoints"].values) == ["head", "body", "tail"]
    assert ds.attrs["fps"] == 30.0
    assert (out / "seqinfo.ini").read_text().count("seqLength=8") == 1
    assert len(list((out / "img1").iterdir())) == 8
    with np.load(out / "gt" / "keypoints.npz") as z:
        np.testing.assert_array_equal(z["keypoints"], v.keypoints)
        np.testing.assert_array_equal(z["ids"], v.ids)
        assert list(z["keypoint_names"]) == ["head", "body", "tail"]
    with pytest.raises(InputError, match="video_format"):
        write_sequence(v, tmp_path / "seq2", video_format="gif")


def test_command_line_reports_ants_at_a_time_and_over_the_video(tmp_path):
    """``python -m thermoswarm.tracking.synth`` states the configured number of ants on
    the road and, separately, how many distinct ants the video holds."""
    import subprocess
    import sys

    out = subprocess.run(
        [sys.executable, "-m", "thermoswarm.tracking.synth", str(tmp_path / "s"), "--seed", "1",
         "--format", "frames", "--set", "n_ants=6", "--set", "n_frames=40",
         "--set", "width=480", "--set", "height=200"],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    v = generate(
        SynthConfig(n_ants=6, n_frames=40, width=480, height=200), np.random.default_rng(1)
    )
    assert f"6 ants on the road at a time, {v.ids.size} over the video" in out.stdout
