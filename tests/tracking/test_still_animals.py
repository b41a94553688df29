"""Animals that stand still, on real pixels: SLEAP's two-fly clip, shrunk
(``tests/data/sleap_fly_clip``: 500 frames at 10 frames/s, 256 x 256, labelled boxes).

The flies stand still for the first seconds.  A background learned from those seconds
holds them, so the classical detector missed them until they walked off (MOTA 0.309,
681 of 1,000 boxes missed, with the background from the first 3 s); learned from frames
spread over the clip, it finds both from the first frame.  The same clip, moved by a
known camera path, checks the registration on real pixels."""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest

from thermoswarm.io.mot import read_mot_table
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.detect.register import camera_path
from thermoswarm.tracking.evaluate import evaluate_tables
from thermoswarm.tracking.pipeline import track_video
from thermoswarm.tracking.pipeline.common import SPREAD_WINDOWS, _samples
from thermoswarm.tracking.video import open_video

DATA = Path(__file__).resolve().parents[1] / "data" / "sleap_fly_clip"
#: The clip's scale (14.94 px/mm at full size, shrunk 4x): a body length of 26.7 px.
PX_PER_MM = 14.94 / 4


def _truth() -> np.ndarray:
    with gzip.open(DATA / "gt.txt.gz", "rt") as f:
        return np.loadtxt(f, delimiter=",", ndmin=2)


@pytest.fixture(scope="module")
def fly_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("flies") / "run"
    s = track_video(
        DATA / "clip.mp4", out, px_per_mm=PX_PER_MM, overlay=False,
        detector_options={"polarity": "light"})  # fmt: skip
    return s, read_mot_table(out / "tracks_mot.txt")


def test_flies_standing_still_at_first_are_tracked_from_the_first_frame(fly_run):
    s, pred = fly_run
    gt = _truth()
    m = evaluate_tables(gt, pred)
    # 1,000 labelled boxes, 2 flies: both tracked the whole clip, one track each.
    assert m["mota"] >= 0.95 and m["idsw"] == 0, m
    assert s["n_tracks"] == 2 and not s["warnings"]
    # The first 3 s, when they stand still (the frames the background came from before).
    first = evaluate_tables(gt[gt[:, 0] <= 30], pred[pred[:, 0] <= 30])
    assert first["recall"] >= 0.95, first
    # The background was learned from frames spread over the clip.
    lo, hi = s["prepare_frames"]
    assert lo == 1 and hi >= 400 and s["prepare_step"] > 2


def test_spread_sample_stays_in_the_clip_and_its_first_scene():
    class Src:
        n_frames, size = 3000, (64, 64)

    # 90-frame windows read every other frame: 45 frames spread over the first
    # SPREAD_WINDOWS windows, then the first window.
    samples, total = _samples(Src(), 90, 2, None, 10**9)
    start, stop, every = samples[0]
    assert total == 3000 and start == 0 and every == SPREAD_WINDOWS * 90 // 45
    assert len(range(start, stop, every)) == 45 and stop <= SPREAD_WINDOWS * 90
    assert samples[1] == (0, 90, 2)
    # Within the first scene (a cut at frame 400) and the first max_frames.
    samples, _ = _samples(Src(), 90, 2, None, 400)
    assert samples[0][1] <= 400 and len(range(*samples[0])) == 45
    samples, _ = _samples(Src(), 90, 2, 300, 10**9)
    assert samples[0][1] <= 300
    # A registered clip tries its first window first, then the spread sample.
    samples, _ = _samples(Src(), 90, 2, None, 10**9, at=1)
    assert samples[0] == (0, 90, 2) and samples[1][2] == SPREAD_WINDOWS * 90 // 45
    # No spread where the clip (or its first scene) is under two windows, or unasked.
    assert _samples(Src(), 90, 2, None, 150)[0][0] == (0, 90, 2)
    assert _samples(Src(), 90, 2, None, None)[0][0] == (0, 90, 2)


VIEW = (200, 200)


def _camera(k: int) -> np.ndarray:
    """Camera px -> clip px at frame ``k``: a drift, a turn and a hand's shake."""
    ang = np.radians(0.08 * k + 0.3 * np.sin(k / 5))
    tx, ty = 20 + 0.4 * k + 1.5 * np.sin(k / 3), 15 + 0.3 * k + 1.5 * np.cos(k / 4)
    c, s = np.cos(ang), np.sin(ang)
    return np.array([[c, -s, tx], [s, c, ty], [0, 0, 1.0]])


def test_real_clip_moved_by_a_known_path_is_recovered():
    import cv2

    frames = open_video(DATA / "clip.mp4").frames(60)
    filmed = (
        cv2.warpAffine(f, _camera(k)[:2], VIEW, flags=cv2.WARP_INVERSE_MAP | cv2.INTER_LINEAR)
        for k, f in enumerate(frames)
    )
    p = camera_path(filmed)
    c0 = np.linalg.inv(_camera(0))
    truth = np.stack([(c0 @ _camera(k))[:2] for k in range(60)])
    w, h = VIEW
    corners = np.array([[0, 0, 1], [w, 0, 1], [0, h, 1], [w, h, 1.0]])
    err = np.abs(np.einsum("nij,kj->nki", p.matrices - truth, corners)).max()
    # The path reaches about 39 px and 6 deg; every corner of every frame within a
    # tenth of a fly's body length (26.7 px; measured 1.9 px on these real pixels).
    assert err < 0.1 * anatomy.ANT_LENGTH_MM * PX_PER_MM, err
    assert p.reach_px() > 30 and not p.cuts


def _hand(k: int) -> np.ndarray:
    """A slower hand for the whole clip (50 s): drift, a small turn and shake."""
    ang = np.radians(0.002 * k + 0.3 * np.sin(k / 5))
    tx, ty = 10 + 0.05 * k + 2 * np.sin(k / 3), 8 + 0.03 * k + 1.5 * np.cos(k / 4)
    c, s = np.cos(ang), np.sin(ang)
    return np.array([[c, -s, tx], [s, c, ty], [0, 0, 1.0]])


def test_flies_standing_still_seen_by_a_moving_camera(tmp_path):
    """The whole clip seen by a moving camera (registered): its first window shows no
    fly that moves, so the background comes from the sample spread over the clip, as
    for a still camera.  On this shrunk clip a later window (where the flies walk)
    also tracks them all; on the full-size clip the later window found flies that
    still stood where they were (MOTA 0.315 against 0.999, docs/real_footage.md)."""
    import cv2

    from thermoswarm.tracking.synth.clip import write_video

    frames = open_video(DATA / "clip.mp4").frames()
    filmed = (
        cv2.warpAffine(f, _hand(k)[:2], VIEW, flags=cv2.WARP_INVERSE_MAP | cv2.INTER_LINEAR)
        for k, f in enumerate(frames)
    )
    write_video(filmed, tmp_path / "moved.mp4", 10.0)
    s = track_video(
        tmp_path / "moved.mp4", tmp_path / "o", px_per_mm=PX_PER_MM, overlay=False,
        detector_options={"polarity": "light"})  # fmt: skip
    assert s["camera"]["registered"] and s["prepare_step"] > 2
    gt = _truth()
    gt[:, 2:4] -= _hand(0)[:2, 2]  # the first frame's px (not turned at frame 0)
    m = evaluate_tables(gt, read_mot_table(tmp_path / "o" / "tracks_mot.txt"))
    assert m["mota"] >= 0.9 and m["idsw"] == 0, m


def _specks_clip(path: Path, seed: int, grey: int, body: int = 40) -> Path:
    """160 frames at 10 frames/s: 5-px specks of ``grey`` on a floor of 180 flicker in
    frames 1-30 while a 40 x 12 px ellipse of grey ``body`` stands still; it walks from
    frame 121."""
    import cv2

    rng = np.random.default_rng(seed)
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 10, (200, 200))
    for k in range(160):
        img = np.full((200, 200, 3), 180, np.uint8)
        x = 60 + 2 * max(0, k - 120)  # walks from frame 121 on
        cv2.ellipse(img, (x, 100), (20, 6), 0, 0, 360, (body,) * 3, -1)
        if k < 30:
            for cx, cy in rng.integers(20, 180, (6, 2)):
                img[cy : cy + 5, cx : cx + 5] = grey
        w.write(img)
    w.release()
    return path


def test_with_a_scale_moving_specks_do_not_choose_the_background(tmp_path):
    """Drawn: 5-px specks flicker in frames 1-30 while the animal (a 40 x 12 px dark
    ellipse) stands still; it walks in frames 121-150.  With a scale that makes the
    animal about 40 px long, the sample where it walks is the one the background is
    learned from, not the specks' (as on SLEAP's fly clip's first 1,100 frames: MOTA
    0.073 -> 1.000); without a scale, or with one that fits neither, the first."""
    from thermoswarm.tracking.pipeline.common import _measure_size

    src = open_video(_specks_clip(tmp_path / "specks.mp4", 3, 40))
    samples = [(0, 30, 1), (60, 90, 1), (120, 150, 1)]
    pick = {
        expect: _measure_size(src, samples, 160, 30, None, None, expect)[1]
        for expect in (None, 40.0, 400.0)
    }
    assert pick[None] == (0, 30, 1)  # anything that moves: the specks
    assert pick[40.0] == (120, 150, 1)  # moving blobs near 40 px: the animal
    assert pick[400.0] == (0, 30, 1)  # none near 400 px: the first, as before


def test_faint_specks_do_not_choose_the_sample_without_a_scale(tmp_path):
    """Drawn: faint 5-px specks (a grey level 25 below the floor's 180, relative
    contrast 0.14: compression noise) flicker in frames 1-30 while the animal (a dark
    40 x 12 px ellipse) stands still; it walks in frames 121-150.  Without a scale the
    size is measured where blobs stand out of the noise (``SizeEstimate.clear`` at least
    ``MIN_CLEAR``), the walking animal, not the specks (as on SLEAP's fly clip's first
    1,100 frames: 12.3 px and 41 tracks of specks before, 71.8 px and 2 tracks now;
    the flies' labels span 70.4 px)."""
    from thermoswarm.tracking.detect.size import estimate_length_px
    from thermoswarm.tracking.pipeline.common import MIN_CLEAR, _measure_size, _read

    src = open_video(_specks_clip(tmp_path / "faint.mp4", 4, 155))
    samples = [(0, 30, 1), (60, 90, 1), (120, 150, 1)]
    specks = estimate_length_px(_read(src, samples[0]))
    walker = estimate_length_px(_read(src, samples[2]))
    assert specks.clear < MIN_CLEAR < walker.clear, (specks, walker)
    est, pick = _measure_size(src, samples, 160, 30, None)
    assert pick == (120, 150, 1)
    assert abs(est.length_px - 40.0) <= 4.0, est  # the ellipse's 40 px, within 10 %
    # Only faint blobs anywhere: they are measured, as before (the first that moves).
    assert _measure_size(src, samples[:2], 160, 30, None)[1] == (0, 30, 1)


def test_with_a_scale_a_faint_animal_that_fits_beats_specks_that_do_not(tmp_path):
    """Drawn: dark 5-px specks in frames 1-30, a faint animal (grey 150 on 180: contrast
    0.17, under ``MIN_CLEAR`` times the noise threshold) walking from frame 121.  With a
    scale that makes it 40 px long, its sample is chosen: the scale says it is an
    animal; the specks stand out more but fit no animal."""
    from thermoswarm.tracking.detect.size import estimate_length_px
    from thermoswarm.tracking.pipeline.common import MIN_CLEAR, _measure_size, _read

    src = open_video(_specks_clip(tmp_path / "faint_animal.mp4", 5, 40, body=150))
    samples = [(0, 30, 1), (60, 90, 1), (120, 150, 1)]
    walker = estimate_length_px(_read(src, samples[2]))
    assert walker.clear < MIN_CLEAR and 10 <= walker.length_px <= 160, walker
    assert _measure_size(src, samples, 160, 30, None, None, 40.0)[1] == (120, 150, 1)


def _creeping(path: Path, amp: float, walk: bool, specks: int = 0) -> Path:
    """Two dark 40 x 12 px ellipses on a light floor, 60 frames at 10 frames/s: walking
    2 px a frame, or creeping back and forth by ``amp`` px in place; ``specks`` still
    dark dots 9 px wide on the floor, away from the ellipses."""
    import cv2

    floor = np.full((200, 200, 3), 180, np.uint8)
    pts = np.random.default_rng(0).uniform(5, 195, (4 * specks, 2)).astype(int)
    far = np.minimum(abs(pts[:, 1] - 60), abs(pts[:, 1] - 140)) > 14
    for x, y in pts[far][:specks]:
        cv2.circle(floor, (int(x), int(y)), 4, (60, 60, 60), -1)
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 10, (200, 200))
    for k in range(60):
        img = floor.copy()
        for y, phase in ((60, 0.0), (140, 2.0)):
            x = 60 + (2 * k if walk else 0) + amp * np.sin(k / 2 + phase)
            cv2.ellipse(img, (int(round(x)), y), (20, 6), 0, 0, 360, (40, 40, 40), -1)
        w.write(img)
    w.release()
    return path


def _near_truth(amp: float, out: Path) -> float:
    """The share of the two creeping ellipses' frames (centres known) with a tracked
    body point within a quarter of their 40-px length."""
    from thermoswarm.io.mot import read_mot_table

    t = read_mot_table(out / "tracks_mot.txt")
    hit = 0
    for k in range(60):
        rows = t[t[:, 0] == k + 1]
        c = rows[:, 2:4] + rows[:, 4:6] / 2
        for y, phase in ((60, 0.0), (140, 2.0)):
            x = 60 + amp * np.sin(k / 2 + phase)
            hit += bool(len(c)) and np.hypot(c[:, 0] - x, c[:, 1] - y).min() <= 10
    return hit / 120


@pytest.mark.parametrize("amp", [3.0, 5.0])
def test_animals_that_stood_nearly_still_are_found_in_the_picture(tmp_path, amp):
    """Animals that only creep in the frames the background is learned from are partly
    background: only their moving ends are blobs (about 16-18 px of a 40 px body).  In
    the picture itself they are 40 px long, so the run compares each frame with its own
    surroundings instead (``background`` ``"picture"``), finds both whole, and says so
    (SLEAP's two flies standing nearly still for 6 s: 32.5 px moved, 65 px in the
    picture; 6 tracks of pieces before, 2 tracks and every labelled fly point found
    now).  ``--set detector.background=time`` keeps the pieces, and the warning names
    the option; walking animals get neither.  At 5 px of creep the clip was refused
    before as a camera that "moved up to 611 px and turned up to 131.5 deg": a path
    measured from the two animals on the plain floor, now checked against a still
    camera first."""
    from thermoswarm.tracking.detect.size import STILL_LOOK

    clip = _creeping(tmp_path / "creep.mp4", amp, False)
    s = track_video(clip, tmp_path / "c", overlay=False)
    assert s["background"] == "picture"
    assert s["moved_length_px"] < 0.6 * 40, s["moved_length_px"]  # pieces moved
    assert abs(s["picture_length_px"] - 40) <= 4, s["picture_length_px"]
    assert s["length_px"] == s["picture_length_px"]  # no scale: the length in the picture
    assert s["n_tracks"] == 2
    assert _near_truth(amp, tmp_path / "c") == 1.0
    said = [w for w in s["warnings"] if "stood nearly still" in w]
    assert len(said) == 1 and "background=picture" in said[0], said
    assert said[0] in (tmp_path / "c" / "WARNING.txt").read_text()
    # Kept over time: what moved is the animals' ends, and the warning says what to try.
    kept = track_video(clip, tmp_path / "t", overlay=False,
                       detector_options={"background": "time"})  # fmt: skip
    assert kept["background"] == "time" and kept["length_px"] == kept["moved_length_px"]
    assert kept["length_px"] < 0.6 * 40, kept["length_px"]
    said = [w for w in kept["warnings"] if "stood nearly still" in w]
    assert len(said) == 1 and "--set detector.background=picture" in said[0], said
    walking = track_video(_creeping(tmp_path / "walk.mp4", 0.0, True), tmp_path / "w",
                          overlay=False)  # fmt: skip
    assert walking["picture_length_px"] < STILL_LOOK * walking["moved_length_px"]
    assert walking["background"] == "time"
    assert not any("stood nearly still" in w for w in walking["warnings"]), walking["warnings"]


@pytest.mark.parametrize("length", [10.0, 40.0])
def test_picture_background_holds_no_animal_and_keeps_steps(length):
    """The spatial background (a grey closing over a disc of 3 body lengths; for a
    40-px animal over a frame shrunk to keep the disc 41 px) holds none of a still dark
    animal, and a wide step in the floor stays background along its whole edge: no
    pixel there differs from it by the relative contrast of a faint animal (0.1; the
    step's own is 0.5)."""
    import cv2

    from thermoswarm.tracking.detect.blobs import picture_background

    left = np.broadcast_to(np.arange(300)[None, :] < 150, (300, 300))
    floor = np.where(left, 180.0, 90.0).astype(np.float32)  # a wide step: two floors
    body = np.zeros((300, 300), np.uint8)
    ax = (int(length / 2), max(int(length * 0.15), 2))
    cv2.ellipse(body, (70, 150), ax, 30, 0, 360, 1, -1)
    cv2.ellipse(body, (230, 150), ax, -30, 0, 360, 1, -1)
    on = body > 0
    img = np.where(on, np.where(left, 60.0, 30.0), floor).astype(np.float32)
    bg = picture_background(img, 3 * length, light=False)
    assert np.abs(bg[on] - floor[on]).max() <= 0.05 * 180, "an animal in the background"
    rel = (bg - img) / np.maximum(bg, 8.0)
    edge = ~on & (np.abs(np.arange(300)[None, :] - 149.5) < 12)
    assert rel[edge].max() < 0.1, rel[edge].max()
    assert rel[on].min() > 0.5  # the animals stand out of it


def test_picture_background_asked_for_without_a_scale_measures_what_moves(tmp_path):
    """``--set detector.background=picture`` without a scale: the body length is that of
    what moved, measured in the picture (40 px, the creeping ellipses), not the typical
    blob of the picture itself (here 30 still 9-px specks, every frame's most common
    blob: 5.0 px and 103 tracks when measured so)."""
    clip = _creeping(tmp_path / "specks.mp4", 3.0, False, specks=30)
    s = track_video(clip, tmp_path / "p", overlay=False,
                    detector_options={"background": "picture"})  # fmt: skip
    assert s["background"] == "picture"
    assert abs(s["length_px"] - 40) <= 4, s["length_px"]


def test_top_variance_is_each_parts_covariance():
    """The major-axis variance of many parts at once equals NumPy's sample covariance's
    largest eigenvalue, part by part."""
    import cv2

    from thermoswarm.tracking.detect.size import _top_variance

    rng = np.random.default_rng(3)
    img = np.zeros((200, 200), np.uint8)
    for _ in range(30):
        c = (int(rng.uniform(10, 190)), int(rng.uniform(10, 190)))
        ax = (int(rng.uniform(2, 12)), int(rng.uniform(1, 5)))
        cv2.ellipse(img, c, ax, float(rng.uniform(0, 180)), 0, 360, 1, -1)
    n, lab = cv2.connectedComponents(img)
    held = np.ones(n, bool)
    held[[0, 3]] = False
    want = []
    for label in np.flatnonzero(held):
        ys, xs = np.nonzero(lab == label)
        if len(xs) >= 5:
            want.append(np.linalg.eigvalsh(np.cov(np.stack([xs, ys]).astype(float)))[-1])
    np.testing.assert_allclose(_top_variance(lab, held), want, rtol=1e-9)


def test_real_flies_that_stood_nearly_still_are_found_whole(tmp_path):
    """Real pixels: the excerpt's last 50 frames (SLEAP's frames 1351-1500, 5 s at 10
    frames/s), where both flies creep less than half their length.  Against the
    background learned over time only their moving wings and legs are blobs (8.6 px, 5
    tracks, 4.3 detections a frame); the run sees it (16.7 px in the picture) and
    compares each frame with its own surroundings: 2 tracks, the flies' length within
    10 % of their labels' (70.4 px head to abdomen tip at full size: 17.6 px here), and
    every labelled fly within a quarter of that of a track's box centre."""
    from thermoswarm.tracking.synth.clip import write_video

    frames = [f for i, f in enumerate(open_video(DATA / "clip.mp4").frames()) if i >= 450]
    clip = tmp_path / "last50.mp4"
    write_video(iter(frames), clip, 10.0)
    truth = _truth()
    truth = truth[truth[:, 0] > 450]
    truth[:, 0] -= 450
    label_length = 70.4 / 4
    s = track_video(clip, tmp_path / "auto", overlay=False, detector_options={"polarity": "light"})
    assert s["background"] == "picture" and s["n_tracks"] == 2
    assert abs(s["length_px"] - label_length) <= 0.1 * label_length, s["length_px"]
    rows = read_mot_table(tmp_path / "auto" / "tracks_mot.txt")
    hit = 0
    for t in truth:
        at = rows[rows[:, 0] == t[0]]
        d = np.hypot(*(at[:, 2:4] + at[:, 4:6] / 2 - t[2:4] - t[4:6] / 2).T)
        hit += bool(at.size) and d.min() <= label_length / 4
    assert hit == len(truth) == 100
    kept = track_video(clip, tmp_path / "time", overlay=False,
                       detector_options={"polarity": "light", "background": "time"})  # fmt: skip
    assert kept["length_px"] < 0.6 * label_length and kept["n_tracks"] > 2


def test_the_size_is_measured_on_what_moves_whatever_the_background(tmp_path):
    """``estimate_length_px`` (also the photo series' size) measures what moves even
    when the options ask for a picture background (which at its unknown scale took the
    floor's specks for animals: 5.0 px on this clip); the picture's length of those
    blobs is ``length_for("picture")``."""
    from thermoswarm.tracking.detect.size import estimate_length_px

    frames = list(open_video(_creeping(tmp_path / "s.mp4", 3.0, False, specks=30)).frames())
    asked = estimate_length_px(frames, {"background": "picture"})
    assert asked == estimate_length_px(frames)
    assert asked.length_for("time") == asked.length_px < 0.6 * 40
    assert abs(asked.length_for("picture") - 40) <= 4, asked
