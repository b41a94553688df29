"""Real-pixel robustness: tracking without a scale (the animals' size measured from the
video, tracks in px), the border/clutter crash of the classical detector, and videos in
which nothing is detected (one-line error, nothing written)."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner
from tracking_fixtures import small_video

from thermoswarm.cli import cli
from thermoswarm.errors import InputError
from thermoswarm.io import read_tracks
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.detect.classical import ClassicalConfig, ClassicalDetector
from thermoswarm.tracking.detect.size import estimate_length_px
from thermoswarm.tracking.synth.clip import write_sequence


def _one_line_error(res):
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), res.output
    assert "Traceback" not in res.output
    return lines[0]


def test_more_predicted_ants_than_max_split_in_one_blob():
    # Real tray photos: a large dark patch (food, a clump) on an odd-sized frame, with
    # tracks born on it; 7 predictions in one blob overflowed the 6-way split
    # ("could not broadcast input array from shape (7,) into shape (6,)").
    det = ClassicalDetector(3.0)
    bg = np.full((201, 301, 3), 200, np.uint8)
    det.prepare([bg] * 4)
    frame = bg.copy()
    frame[60:140, 80:240] = 40
    xs = np.linspace(90, 230, 7)
    y = np.full(7, 100.0)
    hints = np.stack([np.c_[xs + 5, y], np.c_[xs, y], np.c_[xs - 5, y]], axis=1)
    d = det.detect(frame, hints=hints)
    assert len(d) == det.config.max_split
    # Each piece continues one of the predictions it was started from.
    assert set(d.hint_index.tolist()) <= set(range(7))
    assert np.all((d.points[:, 1, 0] > 78) & (d.points[:, 1, 0] < 242))


@pytest.mark.parametrize("px_per_mm", [2.0, 5.0])
def test_length_measured_from_the_video(px_per_mm):
    # The body length (px) comes from the foreground alone; the calibration is within
    # 2 % at 2-5 px/mm on other seeds, so 6 % here leaves room for this seed's blobs.
    v = small_video(
        seed=4,
        width=int(160 * px_per_mm),
        height=int(66 * px_per_mm),
        n_ants=10,
        n_frames=60,
        px_per_mm=px_per_mm,
    )
    est = estimate_length_px(v.frames())
    truth = anatomy.ANT_LENGTH_MM * px_per_mm
    assert est.length_px == pytest.approx(truth, rel=0.06)
    assert est.n_single >= 0.5 * est.n_blobs  # most blobs are single ants


def test_length_needs_moving_animals():
    blank = [np.full((120, 160, 3), 180, np.uint8)] * 10
    with pytest.raises(InputError, match="cannot measure the animals' size.*likely causes"):
        estimate_length_px(blank, source="blank.mp4")


@pytest.fixture(scope="module")
def no_scale_run(tmp_path_factory):
    v = small_video(seed=17, n_ants=12, n_frames=60)
    seq = write_sequence(v, tmp_path_factory.mktemp("seq") / "seq")
    out = tmp_path_factory.mktemp("run") / "out"
    res = CliRunner().invoke(cli, ["track", str(seq / "video.mp4"), "--out", str(out), "--quiet"])
    assert res.exit_code == 0, res.output
    return v, seq, out


def test_track_without_scale_writes_pixels(no_scale_run):
    import json

    import xarray as xr

    v, seq, out = no_scale_run
    summary = json.loads((out / "summary.json").read_text())
    assert summary["px_per_mm"] is None and summary["space_unit"] == "px"
    assert summary["scale_source"] == "measured"
    truth_px = anatomy.ANT_LENGTH_MM * 3.04
    assert summary["length_px"] == pytest.approx(truth_px, rel=0.06)
    with xr.open_dataset(out / "tracks.nc") as ds:
        assert ds.attrs["space_unit"] == "px" and "px_per_mm" not in ds.attrs
        pos = ds["position"].sel(keypoints="body").values  # (time, space, individuals)
    # Body points in px near the true ones (ground truth in mm at 3.04 px/mm).
    gt = read_tracks(seq / "gt_tracks.nc")["position"].sel(keypoints="body").values * 3.04
    err = []
    for t in range(pos.shape[0]):
        p = pos[t][:, np.isfinite(pos[t, 0])]
        g = gt[t][:, np.isfinite(gt[t, 0])]
        if p.size and g.size:
            err.append(np.min(np.linalg.norm(p[:, :, None] - g[:, None, :], axis=0), axis=1))
    err = np.concatenate(err)
    assert np.median(err) < 0.1 * truth_px  # px, not mm (mm would be 3x smaller)


def test_pixel_tracks_are_read_with_their_unit(no_scale_run):
    _, _, out = no_scale_run
    with pytest.raises(InputError, match="in pixels; pass --px-per-mm"):
        read_tracks(out / "tracks.nc")
    import xarray as xr

    ds = read_tracks(out / "tracks.nc", px_per_mm=2.0)
    with xr.open_dataset(out / "tracks.nc") as raw:
        np.testing.assert_allclose(ds["position"].values, raw["position"].values / 2.0)
    assert ds.attrs["space_unit"] == "mm" and ds.attrs["px_per_mm"] == 2.0


def test_overlay_keeps_the_video_resolution(no_scale_run):
    import imageio_ffmpeg

    _, _, out = no_scale_run
    reader = imageio_ffmpeg.read_frames(str(out / "overlay.mp4"))
    meta = next(reader)
    reader.close()
    assert tuple(meta["size"]) == (480, 200)


def test_nothing_detected_is_a_one_line_error(tmp_path):
    # Uniform frames: no scale -> the size cannot be measured; with a scale -> nothing
    # detected.  Both name the video and the likely causes and write no tracks.
    import imageio_ffmpeg

    path = tmp_path / "soil.mp4"
    w = imageio_ffmpeg.write_frames(str(path), (160, 120), fps=10, macro_block_size=8)
    w.send(None)
    for _ in range(20):
        w.send(np.full((120, 160, 3), 90, np.uint8))
    w.close()
    runner = CliRunner()
    line = _one_line_error(
        runner.invoke(cli, ["track", str(path), "--out", str(tmp_path / "a"), "--quiet"])
    )
    assert "soil.mp4" in line and "likely causes" in line and "contrast" in line
    line = _one_line_error(
        runner.invoke(
            cli,
            ["track", str(path), "--out", str(tmp_path / "b"), "--px-per-mm", "3", "--quiet"],
        )
    )
    assert "no animals detected in 20 frames" in line and "likely causes" in line
    assert not (tmp_path / "b" / "tracks.nc").exists()
    assert not (tmp_path / "b" / "overlay.mp4").exists()


def test_folder_of_mixed_image_sizes_is_a_one_line_error(tmp_path):
    import cv2

    folder = tmp_path / "frames"
    folder.mkdir()
    for k in range(4):
        size = (120, 160) if k != 2 else (121, 160)
        cv2.imwrite(str(folder / f"f{k:03d}.png"), np.full((*size, 3), 150, np.uint8))
    res = CliRunner().invoke(
        cli, ["track", str(folder), "--out", str(tmp_path / "o"), "--fps", "1", "--quiet"]
    )
    line = _one_line_error(res)
    assert "f002.png" in line and "160x121" in line and "160x120" in line


def _light_on_black(seed: int = 4):
    """Light animals on a near-black floor (like SLEAP's flies): the synthetic ants
    inverted, a black band outside the arena, and 150 flickering bright specks a
    frame (dust, reflections)."""
    v = small_video(seed=seed, n_ants=8, n_frames=60)
    rng = np.random.default_rng(seed)
    frames = []
    for f in v.frames():
        g = 255.0 - f.astype(np.float64)
        g = np.clip((g - np.median(g)) * 1.2 + 4, 0, 255)
        g[:30] = 0
        ys, xs = rng.integers(30, 200, 150), rng.integers(0, 479, 150)
        g[ys, xs] = g[ys, xs + 1] = 120
        frames.append(g.astype(np.uint8))
    return v, frames


def test_light_animals_on_a_black_floor():
    # Before: the black band made the lighting gain 0 and the background NaN, and the
    # contrast relative to a near-black ground made specks and texture foreground:
    # about 590 "ants" a frame and a length of 0.39 of the truth.
    v, frames = _light_on_black()
    est = estimate_length_px(frames, {"polarity": "light"})
    assert est.length_px == pytest.approx(anatomy.ANT_LENGTH_MM * 3.04, rel=0.1)
    det = ClassicalDetector(
        est.length_px / anatomy.ANT_LENGTH_MM, ClassicalConfig(polarity="light")
    )
    det.prepare(frames[:30])
    counts = np.array([len(det.detect(f)) for f in frames])
    assert np.median(counts) == 8 and np.all(np.isfinite(det._bg))
    assert np.mean(np.abs(counts - 8) <= 1) >= 0.9


def test_unet_without_a_scale_gets_the_measured_one(tmp_path):
    # The same size measurement serves every detector: the U-Net is built at the
    # scale that makes the paper's ant as long as the measured animals (then it
    # resizes frames by its training scale over that one).
    torch = pytest.importorskip("torch")  # noqa: F841
    from thermoswarm.tracking.detect import unet
    from thermoswarm.tracking.pipeline import build_detector
    from thermoswarm.tracking.video import open_video

    v = small_video(seed=17, n_ants=12, n_frames=40)
    seq = write_sequence(v, tmp_path / "s")
    model = unet.save_model(
        unet.TopDownModel(
            unet.ModelConfig(centroid_channels=(8, 16, 16), pose_channels=(12, 16, 16))
        ),
        tmp_path / "m.pt",
    )
    det, info = build_detector(
        open_video(seq / "video.mp4"), 30, px_per_mm=None, detector=None, model=model, options=None
    )
    assert isinstance(det, unet.UNetDetector) and info["scale_source"] == "measured"
    assert det.px_per_mm == pytest.approx(3.04, rel=0.06)
    assert info["length_px"] == pytest.approx(anatomy.ANT_LENGTH_MM * det.px_per_mm)


def test_analyze_refuses_to_call_pixels_mm(no_scale_run, tmp_path):
    _, _, out = no_scale_run
    res = CliRunner().invoke(
        cli, ["analyze", str(out / "tracks.nc"), "--out", str(tmp_path / "a")]
    )
    line = _one_line_error(res)
    assert "in pixels; pass --px-per-mm" in line


def test_track_without_scale_on_the_light_on_black_stand_in(tmp_path):
    # The stand-in for SLEAP's fly clip (whose licence allows research use only, so it
    # is not shipped; the command on it is in docs/tracking.md): `track VIDEO --out DIR`
    # with no scale, 8 ants, tracks in px.
    import json

    import cv2

    # Written losslessly (a folder of PNG frames): on an x264 mp4 of this stand-in the
    # size measure fails (compression noise on its clipped floor texture; see the
    # limits in docs/tracking.md).
    v, frames = _light_on_black()
    (tmp_path / "dark").mkdir()
    for k, f in enumerate(frames):
        assert cv2.imwrite(str(tmp_path / "dark" / f"{k:06d}.png"), f)
    out = tmp_path / "o"
    args = ["track", str(tmp_path / "dark"), "--out", str(out), "--fps", "30", "--quiet"]
    res = CliRunner().invoke(cli, [*args, "--set", "detector.polarity=light"])
    assert res.exit_code == 0, res.output
    s = json.loads((out / "summary.json").read_text())
    assert s["space_unit"] == "px" and s["scale_source"] == "measured"
    assert s["length_px"] == pytest.approx(anatomy.ANT_LENGTH_MM * 3.04, rel=0.1)
    assert abs(s["detections_per_frame"] - 8) < 0.5
    assert 8 <= s["n_tracks"] <= 10
