"""Moving cameras: a drawn stand-in clip (synthetic ants on a textured road, known
sizes and positions) filmed by a camera that drifts, turns and shakes along a known
path; :func:`camera_path` recovers the path, ``track`` tracks the ants in the first
frame's px, and a camera that cannot be followed is refused with its motion named."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment
from tracking_fixtures import small_video

from thermoswarm.errors import InputError
from thermoswarm.io.mot import read_mot_table
from thermoswarm.tracking.detect.register import camera_path, register_source
from thermoswarm.tracking.pipeline import track_video
from thermoswarm.tracking.synth.clip import write_video
from thermoswarm.tracking.video import open_video

VIEW = (480, 220)  # the camera's frame (px), inside the 600 x 300 rendered scene


def camera_matrix(k: int) -> np.ndarray:
    """Camera px -> scene px at frame ``k``: a drift of 0.6, 0.3 px/frame, a turn of
    0.05 deg/frame and a hand's shake (2 px, 0.3 deg)."""
    ang = np.radians(0.05 * k + 0.3 * np.sin(k / 5))
    tx = 40 + 0.6 * k + 2 * np.sin(k / 3)
    ty = 20 + 0.3 * k + 1.5 * np.cos(k / 4)
    c, s = np.cos(ang), np.sin(ang)
    return np.array([[c, -s, tx], [s, c, ty], [0, 0, 1.0]])


def filmed(frames):
    """The frames as the moving camera sees them."""
    import cv2

    for k, big in enumerate(frames):
        m = camera_matrix(k)[:2]
        yield cv2.warpAffine(big, m, VIEW, flags=cv2.WARP_INVERSE_MAP | cv2.INTER_LINEAR)


@pytest.fixture(scope="module")
def moved(tmp_path_factory):
    v = small_video(seed=3, width=600, height=300, n_frames=60, n_ants=10)
    path = tmp_path_factory.mktemp("moved") / "moved.mp4"
    write_video(filmed(v.frames()), path, v.config.fps)
    return v, path


def _truth(n: int) -> np.ndarray:
    """``(n, 2, 3)``: each frame's px -> the first frame's px."""
    c0 = np.linalg.inv(camera_matrix(0))
    return np.stack([(c0 @ camera_matrix(k))[:2] for k in range(n)])


def test_camera_path_is_recovered(moved):
    v, path = moved
    p = camera_path(open_video(path).frames())
    w, h = VIEW
    corners = np.array([[0, 0, 1], [w, 0, 1], [0, h, 1], [w, h, 1.0]])
    err = np.einsum("nij,kj->nki", p.matrices - _truth(v.n_frames), corners)
    # Recovered to within a pixel at every corner of every frame (the path reaches
    # 50 px and 2.7 deg); no frame fails to register.
    assert np.abs(err).max() < 1.0, np.abs(err).max()
    assert p.reach_px() > 40 and not p.cuts


def test_large_walkers_do_not_pull_the_camera_path():
    """Two large light animals (60 x 22 px) walking 3 px a frame over a dark textured
    floor, filmed by the moving camera: they are a large share of the picture's
    contrast, and a fit over every pixel followed them (the path 203 px off by frame
    60); with the blobs left out of the fit, within a pixel."""
    import cv2

    rng = np.random.default_rng(1)
    tex = cv2.GaussianBlur(rng.normal(0, 25, (300, 600)).astype(np.float32), (0, 0), 3)
    floor = np.clip(35 + tex, 0, 255)
    starts = rng.uniform([100, 60], [450, 200], (2, 2))
    vel = rng.normal(0, 3, (2, 2))
    frames = []
    for k in range(60):
        f = floor.copy()
        for c0, v in zip(starts, vel, strict=True):
            c = c0 + k * v
            ang = float(np.degrees(np.arctan2(v[1], v[0])))
            cv2.ellipse(f, ((float(c[0]), float(c[1])), (60, 22), ang), 210.0, -1, cv2.LINE_AA)
        f = np.clip(f + rng.normal(0, 2, f.shape), 0, 255).astype(np.uint8)
        frames.append(np.repeat(f[..., None], 3, axis=2))
    p = camera_path(filmed(frames))
    w, h = VIEW
    corners = np.array([[0, 0, 1], [w, 0, 1], [0, h, 1], [w, h, 1.0]])
    err = np.einsum("nij,kj->nki", p.matrices - _truth(60), corners)
    assert np.abs(err).max() < 1.0, np.abs(err).max()


def test_still_camera_is_left_alone(tmp_path):
    v = small_video(seed=5, n_frames=30)
    path = tmp_path / "still.mp4"
    write_video(v.frames(), path, v.config.fps)
    src = open_video(path)
    same, p = register_source(src)
    assert same is src and p.reach_px() < 3.0 and not p.cuts


def test_moved_clip_tracked_in_first_frame_px(moved, tmp_path):
    v, path = moved
    out = tmp_path / "trk"
    s = track_video(path, out, px_per_mm=v.config.px_per_mm, overlay=False)
    assert s["camera"]["registered"] and (out / "camera_path.csv").is_file()
    rows = read_mot_table(out / "tracks_mot.txt")
    # The truth in the first frame's px: the scene's px through camera 0's inverse.
    c0 = np.linalg.inv(camera_matrix(0))
    body = v.keypoints[:, :, 1, :]
    gt = body @ c0[:2, :2].T + c0[:2, 2]
    w, h = VIEW
    errs, n_gt, n_hit = [], 0, 0
    for k in range(5, v.n_frames):
        fr = rows[rows[:, 0] == k + 1]
        centre = fr[:, 2:4] + fr[:, 4:6] / 2
        g = gt[k][np.all(np.isfinite(gt[k]), axis=1)]
        # the ants inside the camera's current view
        cam = np.linalg.inv(camera_matrix(k)) @ np.linalg.inv(c0)
        gc = g @ cam[:2, :2].T + cam[:2, 2]
        g = g[(gc[:, 0] > 10) & (gc[:, 0] < w - 10) & (gc[:, 1] > 10) & (gc[:, 1] < h - 10)]
        n_gt += len(g)
        if not len(g) or not len(centre):
            continue
        d = np.linalg.norm(g[:, None] - centre[None], axis=2)
        r, c = linear_sum_assignment(d)
        ok = d[r, c] < 0.5 * v.config.ant_length_mm * v.config.px_per_mm
        n_hit += ok.sum()
        errs.append(d[r, c][ok])
    recall = n_hit / n_gt
    err = np.median(np.concatenate(errs))
    assert recall > 0.85, recall
    assert err < 3.0, err


def test_camera_that_cannot_be_followed_is_named(tmp_path):
    rng = np.random.default_rng(0)
    frames = [rng.integers(0, 255, (120, 160, 3), dtype=np.uint8) for _ in range(20)]
    path = tmp_path / "noise.mp4"
    write_video(frames, path, 10.0)
    with pytest.raises(InputError, match="camera cannot be followed") as e:
        register_source(open_video(path), "moving")
    assert "frames do not register" in str(e.value) and "moved up to" in str(e.value)


def test_summary_names_a_still_camera(tmp_path):
    v = small_video(seed=5, n_frames=30)
    path = tmp_path / "still.mp4"
    write_video(v.frames(), path, v.config.fps)
    s = track_video(path, tmp_path / "o", px_per_mm=v.config.px_per_mm, overlay=False)
    cam = json.loads((tmp_path / "o" / "summary.json").read_text())["camera"]
    assert cam == s["camera"] and not cam["registered"] and cam["coordinates"] == "image px"


def test_moved_floor_without_animals_is_refused_not_tracked(tmp_path):
    """A dark floor with a grid of light holes (as under SLEAP's flies) and no animal,
    filmed by the moving camera: resampling leaves specks along the holes' edges,
    which the registered detector must not take for animals (was: dozens of tracks)."""
    import cv2

    floor = np.full((300, 600, 3), 35, np.uint8)
    for y in range(10, 300, 22):
        for x in range(10, 600, 22):
            cv2.circle(floor, (x, y), 4, (190, 190, 190), -1, cv2.LINE_AA)
    rng = np.random.default_rng(2)
    frames = [
        np.clip(floor + rng.normal(0, 2, floor.shape), 0, 255).astype(np.uint8) for _ in range(60)
    ]
    # a hand that also breathes toward the floor: +-0.4 % scale, which the rotation and
    # shift model of the registration leaves as a residual of up to 1 px at the edges
    breathe = (
        cv2.resize(f, None, fx=z, fy=z)
        for f, z in zip(frames, 1 + 0.004 * np.sin(np.arange(60) / 4), strict=True)
    )
    path = tmp_path / "floor.mp4"
    write_video(filmed(breathe), path, 30.0)
    with pytest.raises(InputError, match="not animals|cannot measure the animals. size") as e:
        track_video(path, tmp_path / "o", overlay=False, detector_options={"polarity": "light"})
    assert "\n" not in str(e.value)


def test_registered_detector_tolerates_one_px_of_residual(moved, tmp_path):
    v, path = moved
    s = track_video(path, tmp_path / "t", px_per_mm=v.config.px_per_mm, overlay=False)
    assert s["camera"]["registered"]
    assert s["detector_info"]["config"]["shift_px"] == 1
    assert s["detector_info"]["options"] == {}  # the user set nothing


def test_ants_walking_on_a_plain_floor_do_not_move_the_camera(tmp_path):
    """A still camera over a plain white floor, 40 small dark ants walking one way
    (a trail): their motion is the only texture, and the measured path follows them
    (beyond the still camera's 3 px); the still background explains the frames as
    well, so the frames stay as they are (was: registered, tracks moved by the
    ants' own path: 3 % of the ants tracked on bench_tiny_clip.py, now 97 %)."""
    from test_split_join import H, W, draw_ant

    rng = np.random.default_rng(8)
    pos = rng.uniform([20, 20], [W - 200, H - 20], (40, 2))
    frames = []
    for _ in range(60):
        pos[:, 0] += 2.0  # 9 body lengths/s at 30 frames/s
        pos[:, 1] += rng.normal(0, 0.3, 40)
        img = np.full((H, W), 235, np.uint8)
        for c in pos:
            draw_ant(img, c, 0.05, 6.5)
        noisy = np.clip(img + rng.normal(0, 2.0, img.shape), 0, 255).astype(np.uint8)
        frames.append(np.repeat(noisy[..., None], 3, axis=2))
    path = tmp_path / "trail.mp4"
    write_video(frames, path, 30.0)
    src = open_video(path)
    p = camera_path(src.frames())
    same, _ = register_source(src)
    assert p.reach_px() > 3.0  # the path alone would have registered it
    assert same is src


def _ants_on_white(rng, n_frames: int, cut_at: int | None):
    """30 small dark ants walking on a plain white floor (still camera); at ``cut_at``
    every ant is drawn somewhere else (an edited clip's cut)."""
    from test_split_join import H, W, draw_ant

    pos = rng.uniform([30, 30], [W - 30, H - 30], (30, 2))
    head = rng.uniform(-np.pi, np.pi, 30)
    frames = []
    for k in range(n_frames):
        if k == cut_at:
            pos = rng.uniform([30, 30], [W - 30, H - 30], (30, 2))
        head += rng.normal(0, 0.1, 30)
        pos = np.clip(pos + 1.5 * np.c_[np.cos(head), np.sin(head)], 15, [W - 15, H - 15])
        img = np.full((H, W), 235, np.uint8)
        for c, h in zip(pos, head, strict=True):
            draw_ant(img, c, float(h), 6.5)
        noisy = np.clip(img + rng.normal(0, 2.0, img.shape), 0, 255).astype(np.uint8)
        frames.append(np.repeat(noisy[..., None], 3, axis=2))
    return frames


@pytest.mark.parametrize("cut_at", [None, 30])
def test_a_cut_seen_only_in_the_detections_ends_every_track(tmp_path, cut_at):
    """The same white floor before and after the cut: registration sees no jump, the
    detections do (was: ids carried over onto other ants); no cut where there is none."""
    path = tmp_path / "clip.mp4"
    write_video(_ants_on_white(np.random.default_rng(3), 60, cut_at), path, 30.0)
    s = track_video(path, tmp_path / "o", overlay=False)
    cuts = s["camera"].get("scene_cuts", [])
    assert cuts == ([] if cut_at is None else [cut_at + 1])
    rows = read_mot_table(tmp_path / "o" / "tracks_mot.txt")
    if cut_at is not None:
        before = set(rows[rows[:, 0] == cut_at, 1])
        after = set(rows[rows[:, 0] == cut_at + 1, 1])
        assert before and after and not before & after


def test_a_clip_path_is_measured_once_per_file_and_frame_count(moved, monkeypatch, tmp_path):
    """``track --detector self-trained`` registers one clip three times in a process: the
    path is measured once, and again for another frame count or a changed file."""
    import os
    import shutil

    from thermoswarm.tracking.detect import register

    calls = []

    def counted(frames, **kw):
        calls.append(kw.get("source"))
        return camera_path(frames, **kw)

    monkeypatch.setattr(register, "camera_path", counted)
    monkeypatch.setattr(register, "_LAST_PATH", {})
    clip = tmp_path / "clip.mp4"
    shutil.copy(moved[1], clip)
    first = register_source(open_video(clip), "moving")[1]
    again = register_source(open_video(clip), "moving")[1]
    assert len(calls) == 1 and again is first
    shorter = register_source(open_video(clip), "moving", max_frames=30)[1]
    assert len(calls) == 2 and len(shorter.matrices) == 30
    st = os.stat(clip)
    os.utime(clip, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))  # the file changed
    register_source(open_video(clip), "moving", max_frames=30)
    assert len(calls) == 3
