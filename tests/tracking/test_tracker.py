"""Kalman filter and tracker, on detections made from the ground truth."""

from __future__ import annotations

import numpy as np
import pytest
from tracking_fixtures import small_video

from thermoswarm.errors import ConfigError
from thermoswarm.tracking.detect.classical import FrameDetections
from thermoswarm.tracking.evaluate import evaluate_tables
from thermoswarm.tracking.track import kalman
from thermoswarm.tracking.track.result import fix_jumps
from thermoswarm.tracking.track.tracker import Tracker, TrackerConfig, track_detections


def _gt_detections(video, *, noise=0.0, drop=None, flip_rng=None, seed=0):
    """Per-frame detections from the true keypoints (optionally noisy, with some ants
    removed in some frames, or head and tail swapped at random)."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(video.n_frames):
        kp = video.keypoints[k]
        alive = np.flatnonzero(np.isfinite(kp[:, 1, 0]))
        if drop is not None:
            alive = np.array([i for i in alive if not drop(k, video.ids[i])], int)
        pts = kp[alive] + noise * rng.standard_normal((alive.size, 3, 2))
        hc = None
        if flip_rng is not None:
            flip = flip_rng.random(alive.size) < 0.5
            pts[flip] = pts[flip][:, [2, 1, 0]]
            hc = np.full(alive.size, 0.5)
        out.append(FrameDetections(pts, np.ones(alive.size), head_confidence=hc))
    return out


def test_kalman_tracks_constant_velocity_and_nis_is_consistent():
    rng = np.random.default_rng(3)
    p = kalman.KalmanParams(r=0.5, q0=0.01, gain=0.0)
    truth = np.array([10.0, 20.0]) + np.arange(200)[:, None] * np.array([1.5, -0.5])
    z = truth + 0.5 * rng.standard_normal(truth.shape)
    x, P = kalman.initial_state(z[:1], p)
    q = np.array([p.q0])
    nis = []
    for k in range(1, 200):
        x, P = kalman.predict(x, P, q)
        x, P, n = kalman.update(x, P, z[k : k + 1], p.r)
        nis.append(n[0])
    np.testing.assert_allclose(x[0, 2:], [1.5, -0.5], atol=0.1)
    assert np.linalg.norm(x[0, :2] - truth[-1]) < 0.5
    # Mean NIS of a consistent filter is 2 (chi-square, 2 dof): 4 standard errors.
    nis = np.array(nis[20:])
    assert abs(nis.mean() - 2.0) < 4 * 2.0 / np.sqrt(nis.size)


def test_process_noise_adapts_to_manoeuvres():
    rng = np.random.default_rng(4)
    p = kalman.KalmanParams(r=0.5, q0=0.05, q_min=0.001, q_max=50.0)

    def run(accel_sd):
        v = np.cumsum(accel_sd * rng.standard_normal((300, 2)), axis=0)
        truth = np.cumsum(v, axis=0)
        z = truth + 0.5 * rng.standard_normal(truth.shape)
        x, P = kalman.initial_state(z[:1], p)
        q, m = np.array([p.q0]), np.array([2.0])
        for k in range(1, 300):
            x, P = kalman.predict(x, P, q)
            x, P, n = kalman.update(x, P, z[k : k + 1], p.r)
            q, m = kalman.adapt(q, m, n, p)
        return q[0]

    q_steady, q_wild = run(0.01), run(2.0)
    assert q_wild > 10 * q_steady
    assert q_wild > p.q0 > q_steady


def test_config_is_checked():
    with pytest.raises(ConfigError, match="confirm_s"):
        TrackerConfig(confirm_s=-0.1)
    with pytest.raises(ConfigError, match="max_speed_bl_s"):
        TrackerConfig(max_speed_bl_s=-1)
    # at 0 every birth would be a "duplicate" of any matched box: no track born
    for bad in (0.0, -0.1, float("nan")):
        with pytest.raises(ConfigError, match="duplicate_overlap"):
            TrackerConfig(duplicate_overlap=bad)


@pytest.fixture(scope="module")
def video():
    return small_video(seed=13, n_ants=10, n_frames=150)


def _unconfirmable_rows(video, n_init: int | None = None) -> int:
    """Ground-truth rows that no tracker with confirmation after ``n_init`` hits can
    output from exact detections: those of ants seen in fewer than ``n_init`` frames
    (tentative rows are written once a track is confirmed, so every other row is)."""
    n_init = TrackerConfig().n_init(30.0) if n_init is None else n_init  # SMALL's fps
    _, counts = np.unique(video.mot_gt[:, 1], return_counts=True)
    return int(counts[counts < n_init].sum())


def test_perfect_detections_give_perfect_tracks(video):
    res = track_detections(_gt_detections(video), px_per_mm=3.04, fps=30, frame_size=(480, 200))
    m = evaluate_tables(video.mot_gt, res.mot_table())
    # Exact detections: every row is found except the unconfirmable ones, nothing is
    # false, and no identity is lost (exact, no tolerance).
    assert m["fn"] == _unconfirmable_rows(video)
    assert m["fp"] == 0 and m["idsw"] == 0
    assert m["idf1"] > 0.99


def test_noisy_detections(video):
    res = track_detections(_gt_detections(video, noise=0.7, seed=1), px_per_mm=3.04, fps=30)
    m = evaluate_tables(video.mot_gt, res.mot_table())
    assert m["mota"] > 0.97 and m["idf1"] > 0.9


def test_short_gaps_are_relinked_and_interpolated(video):
    victim = int(video.ids[0])

    def drop(k, ident):
        return ident == victim and 40 <= k < 55  # 0.5 s < max_gap_s

    res = track_detections(
        _gt_detections(video, drop=drop), px_per_mm=3.04, fps=30, frame_size=(480, 200)
    )
    m = evaluate_tables(video.mot_gt, res.mot_table())
    # The 15 dropped frames are filled, so the counts are those of exact detections.
    assert m["idsw"] == 0 and m["fn"] == _unconfirmable_rows(video)
    assert res.interpolated.sum() >= 15
    # Interpolated body points stay near the truth over half a second.
    rows = np.flatnonzero(res.interpolated)
    gt_body = video.keypoints[res.frames[rows], 0, 1]
    err = np.linalg.norm(res.points[rows, 1] - gt_body, axis=-1)
    assert np.median(err) < 3.0


def test_long_gaps_start_a_new_identity(video):
    # An ant on the road throughout frames 30..120.
    vi = int(np.flatnonzero(np.all(np.isfinite(video.keypoints[30:121, :, 1, 0]), axis=0))[0])
    victim = int(video.ids[vi])

    def drop(k, ident):
        return ident == victim and 40 <= k < 100  # 2 s > max_gap_s

    cfg = TrackerConfig(max_gap_s=0.5)
    res = track_detections(_gt_detections(video, drop=drop), px_per_mm=3.04, fps=30, config=cfg)

    def track_at(k):
        sel = np.flatnonzero(res.frames == k)
        d = np.linalg.norm(res.points[sel, 1] - video.keypoints[k, vi, 1], axis=-1)
        return int(res.ids[sel][np.argmin(d)]) if d.min() < 1e-6 else None

    before, after = track_at(39), track_at(110)
    assert before is not None and after is not None and before != after
    assert not np.any(res.interpolated[np.isin(res.ids, [before, after])])


def test_spurious_detections_do_not_make_tracks(video):
    rng = np.random.default_rng(2)
    dets = _gt_detections(video)
    noisy = []
    for d in dets:
        if rng.random() < 0.3:  # an isolated false detection, never repeated
            junk = np.array([[[5.0, 5.0], [0.0, 5.0], [-5.0, 5.0]]]) + rng.uniform(
                [0, 0], [480, 200]
            )
            d = FrameDetections(np.concatenate([d.points, junk]), np.append(d.scores, 1.0))
        noisy.append(d)
    res = track_detections(noisy, px_per_mm=3.04, fps=30)
    m = evaluate_tables(video.mot_gt, res.mot_table())
    assert m["fp"] == 0


def test_head_and_tail_from_motion(video):
    # The detector cannot tell head from tail (random order, confidence 0.5): the
    # tracker orients the ants by their motion.
    dets = _gt_detections(video, flip_rng=np.random.default_rng(5))
    res = track_detections(dets, px_per_mm=3.04, fps=30)
    gt_ax = video.keypoints[res.frames, :, 0] - video.keypoints[res.frames, :, 2]
    body = video.keypoints[res.frames, :, 1]
    nearest = np.nanargmin(np.linalg.norm(body - res.points[:, None, 1], axis=-1), axis=1)
    gt_ax = gt_ax[np.arange(len(nearest)), nearest]
    ax = res.points[:, 0] - res.points[:, 2]
    agree = (gt_ax * ax).sum(-1) > 0
    speed = video.tracks["speed"].values[res.frames, nearest]
    moving = speed > 5.0  # mm/s
    assert agree[moving].mean() > 0.95


def test_output_is_final_after_the_lag(video):
    dets = _gt_detections(video, noise=0.5, seed=3)
    tr = Tracker(px_per_mm=3.04, fps=30)
    popped = {}
    for d in dets:
        tr.predict()
        tr.update(d)
        for f, rows in tr.pop_final():
            popped[f] = rows
    for f, rows in tr.flush():
        popped[f] = rows
    res = tr.finish()
    assert sorted(popped) == list(range(video.n_frames))
    for f in (10, 75, 149):
        sel = res.frames == f
        got = sorted((i, tuple(p[1])) for i, p, _ in popped[f])
        want = sorted((i, tuple(p[1])) for i, p in zip(res.ids[sel], res.points[sel], strict=True))
        assert got == want


def test_box_only_detections(video):
    from thermoswarm.tracking.pipeline import detections_from_table

    table = video.mot_gt.copy()
    table[:, 1] = -1
    res = track_detections(detections_from_table(table), px_per_mm=3.04, fps=30)
    m = evaluate_tables(video.mot_gt, res.mot_table())
    assert m["mota"] > 0.99
    assert np.all(np.isnan(res.points[:, 0]))
    ds = res.dataset(px_per_mm=3.04, fps=30)
    assert ds["position"].sel(keypoints="body").notnull().any()


def test_impossible_speeds_are_removed():
    # One track moving 1 px/frame; row 5 misplaced by 30 px (a spike), and from row 12
    # on the track sits 30 px away (a jump).  At 30 fps and 3.04 px/mm, 100 mm/s is
    # 10.1 px/frame.
    tr = Tracker(px_per_mm=3.04, fps=30)
    n = 20
    frames = np.arange(n)
    ids = np.ones(n, np.int64)
    body = np.column_stack([np.arange(n, dtype=float), np.zeros(n)])
    body[5, 1] += 30
    body[12:, 1] += 30
    pts = np.repeat(body[:, None, :], 3, axis=1) + np.array([[4.0, 0], [0, 0], [-4.0, 0]])
    boxes = np.column_stack([body - 5, np.full((n, 2), 10.0)])
    scores = np.ones(n)
    interp = np.zeros(n, bool)
    drop = fix_jumps(frames, ids, pts, boxes, scores, interp, tr.step_px)
    np.testing.assert_allclose(pts[5, 1], [5.0, 0.0])
    assert interp[5] and scores[5] == 0 and interp.sum() == 1
    assert np.flatnonzero(drop).tolist() == [12]


def _box_frames(centres_per_frame: list[np.ndarray], scores: list[float]) -> list:
    """Box-only detections (40 x 20 px boxes) with body points at the given centres."""
    out = []
    for c in centres_per_frame:
        pts = np.full((len(c), 3, 2), np.nan)
        pts[:, 1] = c
        boxes = np.column_stack([c - [20.0, 10.0], np.tile([40.0, 20.0], (len(c), 1))])
        out.append(FrameDetections(pts, np.asarray(scores, float), boxes=boxes))
    return out


@pytest.mark.parametrize(
    ("offset", "n_tracks"),
    [(4.0, 1), (200.0, 2)],  # a doubled box (4 px apart) vs two separate animals
)
def test_doubled_boxes_born_together_start_one_track(offset, n_tracks):
    # Two boxes from the first frame on, moving together at 1 px/frame, the second
    # scored lower: a box doubled by the detector (4 px apart, so that each covers
    # nearly all of the other: duplicate_overlap) must start one track, two animals
    # far apart two.
    n = 30
    frames = [np.array([[100.0 + k, 100.0], [100.0 + k + offset, 100.0]]) for k in range(n)]
    res = track_detections(_box_frames(frames, [0.9, 0.6]), fps=25, length_px=40.0)
    table = res.mot_table()
    assert len(np.unique(table[:, 1])) == n_tracks
    # The kept track follows the better-scored box.
    first = table[table[:, 1] == table[0, 1]]
    np.testing.assert_allclose(first[:, 2] + first[:, 4] / 2, 100.0 + first[:, 0] - 1, atol=1.0)


def _sized_boxes(objects_per_frame):
    """FrameDetections of box-only detections: per frame a list of ``(cx, cy, w, h)``."""
    out = []
    for objs in objects_per_frame:
        b = np.array([[cx - w / 2, cy - h / 2, w, h] for cx, cy, w, h in objs], float)
        b = b.reshape(-1, 4)
        pts = np.full((len(b), 3, 2), np.nan)
        pts[:, 1] = b[:, :2] + b[:, 2:] / 2
        out.append(FrameDetections(pts, np.ones(len(b)), boxes=b))
    return out


@pytest.mark.parametrize("where", ["on its path", "elsewhere"])
def test_a_lost_identity_continues_only_where_its_motion_leads(where):
    # One 20 x 40 px object walks right at 2 px/frame (30 fps) for 20 frames, is missed
    # for 4 frames (0.13 s < max_gap_s), then a box appears either where it has walked
    # to, or 80 px above that path (within the max-speed reach of 14 body lengths a
    # second, outside the coasted Kalman gate): the first continues the identity,
    # the second is another object.
    frames = [[(100 + 2 * k, 100, 20, 40)] for k in range(20)] + [[] for _ in range(4)]
    dy = 0 if where == "on its path" else 80
    frames += [[(100 + 2 * k, 100 + dy, 20, 40)] for k in range(24, 34)]
    res = track_detections(_sized_boxes(frames), fps=30)
    ids = np.unique(res.ids)
    assert len(ids) == (1 if where == "on its path" else 2)
    # Re-linking by reach alone (the previous default) gives the box above the identity.
    old = TrackerConfig(relink_gate=False)
    assert np.unique(track_detections(_sized_boxes(frames), fps=30, config=old).ids).size == 1


def test_a_fragment_inside_an_object_starts_no_track_but_a_close_neighbour_does():
    # Two 20 x 60 px objects side by side, 24 px apart (closer than half their length:
    # the old duplicate_radius would have suppressed one), and in every frame a small
    # false box inside the first (a fragment: all of it within the object's box).
    frames = [
        [(100 + k, 100, 20, 60), (124 + k, 100, 20, 60), (100 + k, 90, 8, 10)] for k in range(30)
    ]
    res = track_detections(_sized_boxes(frames), fps=10)
    assert np.unique(res.ids).size == 2
    assert np.all(np.bincount(res.frames) == 2)
    old = TrackerConfig(duplicate_radius=0.5, duplicate_overlap=1.0)
    assert np.unique(track_detections(_sized_boxes(frames), fps=10, config=old).ids).size == 1


def _poses(bodies: list[np.ndarray], heading: float, length: float) -> np.ndarray:
    """Poses ``(n, 3, 2)`` of ants ``length`` px long at body points ``bodies`` ``(n, 2)``,
    all at ``heading`` rad (head, body and tail by the anatomy)."""
    from thermoswarm.tracking import anatomy

    u = np.array([np.cos(heading), np.sin(heading)])
    off = anatomy.KEYPOINT_OFFSETS[None, :, None] * length * u[None, None, :]
    return np.asarray(bodies, float)[:, None, :] + off


@pytest.mark.parametrize(
    ("second", "n_tracks"),
    [((-0.6, 0.0), 1), ((0.0, 0.5), 2), ((-1.1, 0.0), 2)],
    ids=["piece-0.6-behind", "side-by-side-0.5", "head-to-tail"],
)
def test_the_pieces_of_one_split_ant_start_no_second_track(second, n_tracks):
    # An ant 21.7 px long walks on the 30 degree diagonal at 3 body lengths a second
    # (30 fps) and, in every frame, a second pose lies ``second`` (along, across its
    # heading; body lengths) from it, both scored 0.6 (a split blob's parts): 0.6
    # body lengths behind on its own axis it is a piece of the same ant (the blob of
    # one ant cut in two, the classical detector's over-split; before oriented
    # duplicates: a second track), 0.5 body lengths to its side or one body length
    # behind it is another ant (tracked).
    L, h, n = 21.7, np.pi / 6, 40
    u, v = np.array([np.cos(h), np.sin(h)]), np.array([-np.sin(h), np.cos(h)])
    dets = []
    for k in range(n):
        a = np.array([100.0, 100.0]) + 3 * L / 30 * k * u
        b = a + L * (second[0] * u + second[1] * v)
        dets.append(FrameDetections(_poses([a, b], h, L), np.full(2, 0.6)))
    res = track_detections(dets, fps=30, length_px=L)
    assert np.unique(res.ids).size == n_tracks
    assert res.ids.size >= n_tracks * (n - 7)  # each track from its confirmation on
