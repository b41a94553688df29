"""The box smoother of finished tracks (thermoswarm.tracking.track.smooth)."""

from __future__ import annotations

import numpy as np
import pytest

from thermoswarm.tracking.track.presets import preset
from thermoswarm.tracking.track.smooth import CLIP, measure_noise, smooth_boxes

FPS = 10.0


def _tracks(rng, n_tracks=200, n=60, accel=400.0, noise=2.0):
    """Tracks of the smoother's own model: each frame the velocity changes by a
    random acceleration (sd ``accel`` px/s^2 held over the frame), each detection is
    off by white noise of sd ``noise`` px.  Rows sorted by id, then frame."""
    dt = 1 / FPS
    a = rng.normal(0, accel, (n_tracks, n, 2))
    v = rng.normal(0, 30, (n_tracks, 1, 2)) + np.cumsum(a * dt, axis=1)
    # x[k] = x[k-1] + v[k-1] dt + a[k] dt^2 / 2
    x = np.cumsum((v - a * dt) * dt + a * dt * dt / 2, axis=1) + rng.uniform(
        0, 500, (n_tracks, 1, 2)
    )
    z = x + rng.normal(0, noise, x.shape)
    frames = np.tile(np.arange(n), n_tracks)
    ids = np.repeat(np.arange(n_tracks), n)
    size = np.full((n_tracks * n, 2), 20.0)
    boxes = np.c_[z.reshape(-1, 2) - 10, size]
    return frames, ids, boxes, x.reshape(-1, 2)


def test_noise_and_acceleration_measured_on_the_tracks(rng):
    """The method of moments recovers the detection noise and the acceleration of
    tracks of known noise (11,600 second differences an axis).  The estimates' relative
    sd is 0.7 % for both (20 seeds of this generator); 5 sds: 4 %."""
    frames, ids, boxes, _ = _tracks(rng)
    r, a = measure_noise(frames, ids, boxes, np.zeros(ids.size, bool), FPS)
    assert r == pytest.approx(2.0, rel=0.04)
    assert a == pytest.approx(400.0, rel=0.04)


def test_smoothing_brings_the_boxes_closer_to_the_truth(rng):
    """On tracks of known truth the smoothed centres are closer to it than the
    detections, and no centre moved more than CLIP noise sds from its detection."""
    frames, ids, boxes, truth = _tracks(rng)
    out = smooth_boxes(frames, ids, boxes, np.zeros(ids.size, bool), fps=FPS, speed_px_s=50)
    r, _ = measure_noise(frames, ids, boxes, np.zeros(ids.size, bool), FPS)
    raw = np.sqrt(np.mean((boxes[:, :2] + 10 - truth) ** 2))
    smooth = np.sqrt(np.mean((out[:, :2] + 10 - truth) ** 2))
    assert smooth < 0.8 * raw
    np.testing.assert_array_equal(out[:, 2:], boxes[:, 2:])
    assert np.abs(out[:, :2] - boxes[:, :2]).max() <= CLIP * r + 1e-9


def test_too_few_rows_or_no_noise_leave_the_boxes_as_detected(rng):
    frames, ids, boxes, truth = _tracks(rng, n_tracks=2, n=8)
    none = np.zeros(ids.size, bool)
    assert measure_noise(frames, ids, boxes, none, FPS) is None
    np.testing.assert_array_equal(
        smooth_boxes(frames, ids, boxes, none, fps=FPS, speed_px_s=50), boxes
    )
    # straight lines at constant speed: no measurable noise
    frames, ids, _, _ = _tracks(rng)
    exact = np.c_[frames * 3.0, frames * 1.0, np.full((ids.size, 2), 20.0)]
    assert measure_noise(frames, ids, exact, np.zeros(ids.size, bool), FPS) is None


def test_the_pedestrians_preset_writes_the_detections_boxes():
    assert preset("ants").smooth and not preset("pedestrians").smooth


def test_each_track_is_smoothed_with_its_own_acceleration(rng):
    """A colony of calm walkers (acceleration sd 100 px/s^2) and a few runners that
    turn hard (1,600 px/s^2), all detected with the same 2-px noise.  With the
    colony's acceleration for every track the runners' turns are cut (their smoothed
    centres end up farther from the truth than their detections) and the walkers,
    smoothed for the runners' turns, gain less; measured on each track (shrunk toward
    the colony's), both gain.  RMS error smoothed / detected over 20 seeds of this
    generator, mean +- sd: runners 0.857 +- 0.010 (before 1.107 +- 0.026), walkers
    0.571 +- 0.005 (before 0.647 +- 0.005); the bounds sit over 5 sds above now and
    below before."""
    calm = _tracks(rng, n_tracks=180, accel=100.0)
    fast = _tracks(rng, n_tracks=20, accel=1600.0)
    frames = np.r_[calm[0], fast[0]]
    ids = np.r_[calm[1], fast[1] + 180]
    boxes = np.r_[calm[2], fast[2]]
    truth = np.r_[calm[3], fast[3]]
    out = smooth_boxes(frames, ids, boxes, np.zeros(ids.size, bool), fps=FPS, speed_px_s=50)

    def rms(b, sel):
        return np.sqrt(np.mean((b[sel, :2] + 10 - truth[sel]) ** 2))

    runners = ids >= 180
    assert rms(out, runners) < 0.95 * rms(boxes, runners)
    assert rms(out, ~runners) < 0.62 * rms(boxes, ~runners)
    # The colony's acceleration for every track (TrackerConfig.smooth_weight very large):
    # the runners' turns cut again, as before.
    colony = smooth_boxes(frames, ids, boxes, np.zeros(ids.size, bool), fps=FPS,
                          speed_px_s=50, own_weight=1e12)  # fmt: skip
    assert rms(colony, runners) > rms(boxes, runners)


def test_smooth_weight_is_checked():
    from thermoswarm.errors import ConfigError
    from thermoswarm.tracking.track.config import TrackerConfig

    assert TrackerConfig().smooth_weight == 10.0
    with pytest.raises(ConfigError, match="smooth_weight"):
        TrackerConfig(smooth_weight=-1.0)


def test_a_detectors_own_boxes_are_written_as_detected_unless_asked(rng):
    """The tracker smooths boxes it built from body points; a detector's own boxes
    (YOLO's: on real ant boxes smoothing them lowered HOTA) are written as detected
    unless ``smooth_given`` is set."""
    from thermoswarm.tracking.detection import FrameDetections
    from thermoswarm.tracking.track.config import TrackerConfig
    from thermoswarm.tracking.track.tracker import track_detections

    frames, ids, boxes, _ = _tracks(rng, n_tracks=3, n=60, accel=40.0, noise=1.0)
    dets = []
    for k in range(60):
        b = boxes[frames == k]
        pts = np.full((len(b), 3, 2), np.nan)
        pts[:, 1] = b[:, :2] + b[:, 2:] / 2
        dets.append(FrameDetections(pts, np.full(len(b), 0.9), boxes=b))
    ours = track_detections(dets, fps=FPS, length_px=20.0)
    assert ours.n_tracks == 3 and ours.frames.size == boxes.shape[0]
    got = {tuple(np.round(r, 6)) for r in ours.boxes}
    assert got == {tuple(np.round(r, 6)) for r in boxes}
    asked = track_detections(
        dets, fps=FPS, length_px=20.0, config=TrackerConfig(smooth_given=True)
    )
    moved = {tuple(np.round(r, 6)) for r in asked.boxes} - got
    assert len(moved) > 0.9 * boxes.shape[0]
