"""Real footage's traps, on drawn stand-ins with known answers: tiny animals measured
to within 10 %, scene cuts that end every track, and floods (glitter that flickers in
place, the lines of a plot) refused with the reason instead of written quietly."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from click.testing import CliRunner
from test_split_join import H, W, frame, scene
from tracking_fixtures import small_video

from thermoswarm.cli import cli
from thermoswarm.errors import InputError
from thermoswarm.io.mot import read_mot_table
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.detect.register import camera_path
from thermoswarm.tracking.detect.size import estimate_length_px
from thermoswarm.tracking.pipeline import track_video
from thermoswarm.tracking.pipeline.flood import flood_reasons
from thermoswarm.tracking.synth.clip import write_video
from thermoswarm.tracking.video import open_video


@pytest.mark.parametrize("length_px", [4.0, 5.0, 8.0])
def test_body_length_within_10_percent_down_to_4_px(length_px):
    # Rendered ants of a known length (the paper's 7.14 mm at length_px / 7.14 px/mm).
    v = small_video(seed=1, n_frames=40, n_ants=12, px_per_mm=length_px / 7.14)
    est = estimate_length_px(v.frames())
    assert abs(est.length_px / length_px - 1) < 0.10, est
    assert est.n_single >= 30 and 0.25 < est.fill < 0.6


def _exact_frame(rng: np.random.Generator, ants: list[tuple], k: int = 8) -> np.ndarray:
    """A noisy white frame with ``ants`` (:func:`test_split_join.scene`'s) drawn dark
    by their exact pixel coverage (drawn at ``k`` times the size, area-averaged down),
    the waist band of the split ones likewise, then a lens blur of 0.5 px: ants of
    exactly the stated length (``test_split_join.draw_ant``'s anti-aliased ellipses
    are about half a pixel fatter all round: at 6.5 px their darkness covers 2.1
    times the silhouette's area)."""
    big = np.zeros((H * k, W * k), np.uint8)

    def fx(p):  # px to cv2's fixed point (4 fractional bits) at k times the size
        return np.round((np.asarray(p) * k + (k - 1) / 2) * 16).astype(np.int32)

    for c, heading, length, gap in ants:
        u = np.array([math.cos(heading), math.sin(heading)])
        for at, a, b in (anatomy.HEAD, anatomy.MESOSOMA, anatomy.GASTER):
            axes = (round(a * length * k * 16), round(b * length * k * 16))
            centre = tuple(int(v) for v in fx(np.asarray(c) + at * length * u))
            cv2.ellipse(big, centre, axes, math.degrees(heading), 0, 360, 255, -1, 8, 4)
        if gap:
            v, mid = np.array([-u[1], u[0]]), np.asarray(c) - 0.13 * length * u
            h, s = 0.5 * gap * u, 0.5 * length * v
            cv2.fillConvexPoly(
                big, fx([mid - h - s, mid + h - s, mid + h + s, mid - h + s]), 0, 8, 4
            )
    cover = cv2.resize(big, (W, H), interpolation=cv2.INTER_AREA).astype(np.float32) / 255
    img = cv2.GaussianBlur(235 - 195 * cover, (0, 0), 0.5) + rng.normal(0, 2.0, (H, W))
    return np.repeat(np.clip(img, 0, 255).astype(np.uint8)[..., None], 3, axis=2)


@pytest.mark.parametrize("length_px", [4.0, 6.0, 8.0])
def test_drawn_ants_measured_within_10_percent(length_px):
    """Dark ants on white drawn at a known length (exact pixel coverage, a third split
    at the waist), 12 frames of 30: the length measured without a scale within 10 %
    (3.90, 5.89, 7.91 px; was 2.52 from 4 blobs, 4.07 and 5.90: the span less a blur
    fitted on rendered ants with antennae)."""
    rng = np.random.default_rng(4)
    frames = [_exact_frame(rng, scene(rng, 30, (length_px,) * 2, 1 / 3)) for _ in range(12)]
    est = estimate_length_px(frames)
    assert abs(est.length_px / length_px - 1) < 0.10, est
    assert est.n_single >= 30


def test_stand_in_of_tiny_ants_on_white_measured_within_10_percent():
    """The stand-in of issue 32's clip (ants 6-7 px on white, a third split at the
    waist; ``test_split_join``'s scene and 12 frames): 6.5 px within 10 % (6.77; was
    5.46; seeds 1-3 instead of 32: 6.84-6.91)."""
    rng = np.random.default_rng(32)
    frames = [frame(rng, scene(rng, 30, (6.0, 7.0), 1 / 3)) for _ in range(12)]
    est = estimate_length_px(frames, {"join_split": True})
    assert abs(est.length_px / 6.5 - 1) < 0.10, est


@pytest.fixture(scope="module")
def cut_clip(tmp_path_factory):
    """Two scenes of 30 frames (other ground, other ants), cut at frame 31."""
    a = small_video(seed=2, n_frames=30, n_ants=8)
    b = small_video(seed=9, n_frames=30, n_ants=8, narrow_fraction=0.2, road_wide_mm=55.0)
    path = tmp_path_factory.mktemp("cut") / "cut.mp4"
    write_video([*a.frames(), *b.frames()], path, a.config.fps)
    return a, path


def test_scene_cut_is_found(cut_clip):
    _, path = cut_clip
    p = camera_path(open_video(path).frames())
    assert p.cuts == (30,) and p.reach_px() < 3.0


def test_scene_cut_ends_every_track(cut_clip, tmp_path):
    a, path = cut_clip
    s = track_video(path, tmp_path / "o", px_per_mm=a.config.px_per_mm, overlay=False)
    assert s["camera"]["scene_cuts"] == [31] and not s["camera"]["registered"]
    rows = read_mot_table(tmp_path / "o" / "tracks_mot.txt")
    before = set(rows[rows[:, 0] <= 30, 1].tolist())
    after = set(rows[rows[:, 0] > 30, 1].tolist())
    assert before and after and not (before & after)
    # Both scenes are tracked: most of the 8 ants have a track in each.
    assert len(before) >= 6 and len(after) >= 6


def _rows(paths: np.ndarray) -> np.ndarray:
    """MOT detection rows (frames from 1) of body paths ``(T, n, 2)`` px, 4 px boxes."""
    T, n, _ = paths.shape
    rows = np.full((T * n, 10), -1.0)
    rows[:, 0] = np.repeat(np.arange(1, T + 1), n)
    rows[:, 2:4] = paths.reshape(-1, 2) - 2
    rows[:, 4:6] = 4.0
    return rows


def test_flood_reasons():
    rng = np.random.default_rng(0)
    # Crowding: 2,000 bodies of 10 px in a 320 x 240 image would cover 45 %... of 35
    # px^2 each: 91 %; 50 of them cover 2 %.
    assert any("would cover" in r for r in flood_reasons(np.full(20, 2000), (320, 240), 10.0))
    assert flood_reasons(np.full(20, 50), (320, 240), 10.0) == []
    # Flicker at 10 frames/s: 30 specks that jitter in place (0.5 px), each shown in a
    # random half of the frames, are not animals; the same 30 shown in every frame
    # (animals standing still) are, and so are 30 that walk 1.5 px a frame (1.5 body
    # lengths a second).
    still = rng.uniform(20, 300, (1, 30, 2)) + rng.normal(0, 0.5, (40, 30, 2))
    walk = still + np.arange(40)[:, None, None] * np.array([1.5, 0.0])
    shown = rng.random(40 * 30) < 0.5
    reasons = flood_reasons(np.full(40, 15), (320, 240), 10.0, _rows(still)[shown], fps=10.0)
    assert len(reasons) == 1 and "do not move like animals" in reasons[0]
    assert flood_reasons(np.full(40, 30), (320, 240), 10.0, _rows(still), fps=10.0) == []
    assert flood_reasons(np.full(40, 30), (320, 240), 10.0, _rows(walk), fps=10.0) == []


def _glitter(path, n_frames=60):
    """Dark specks at fixed places, each shown in a random half of the frames."""
    rng = np.random.default_rng(0)
    pos = rng.uniform([10, 10], [310, 230], (80, 2)).astype(int)
    frames = []
    for _ in range(n_frames):
        f = np.full((240, 320, 3), 200, np.uint8)
        for (x, y), on in zip(pos, rng.random(80) < 0.5, strict=True):
            if on:
                cv2.ellipse(f, (int(x), int(y)), (4, 2), 30, 0, 360, (40, 40, 40), -1)
        frames.append(f)
    write_video(frames, path, 10.0)


def test_glitter_is_refused_with_the_outputs_kept(tmp_path):
    _glitter(tmp_path / "glitter.mp4")
    with pytest.raises(InputError, match="do not move like animals") as e:
        track_video(tmp_path / "glitter.mp4", tmp_path / "o", overlay=False)
    assert "WARNING.txt" in str(e.value)
    assert (tmp_path / "o" / "WARNING.txt").is_file() and (tmp_path / "o" / "tracks.nc").is_file()


def test_plot_lines_are_refused_in_one_line(tmp_path):
    # A "3-D plot" of four thin lines that turn: moving, but no animal.
    frames = []
    for k in range(40):
        img = np.full((240, 320, 3), 255, np.uint8)
        for j in range(4):
            a = 0.05 * k + 0.8 * j
            cx, cy = 160 + 60 * np.cos(a + j), 120 + 40 * np.sin(a)
            dx, dy = 40 * np.cos(2 * a + j), 40 * np.sin(2 * a + j)
            p0, p1 = (int(cx - dx), int(cy - dy)), (int(cx + dx), int(cy + dy))
            cv2.line(img, p0, p1, (30, 30, 200), 1, cv2.LINE_AA)
        frames.append(img)
    write_video(frames, tmp_path / "plot.mp4", 10.0)
    res = CliRunner().invoke(
        cli, ["track", str(tmp_path / "plot.mp4"), "--out", str(tmp_path / "o"), "--quiet"]
    )
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and "thin lines, not animals" in lines[0]
    assert not (tmp_path / "o" / "tracks.nc").exists()
