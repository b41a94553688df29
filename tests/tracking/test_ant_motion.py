"""The tracker's defaults on ordinary ant motion at the frame rates ant labs film at.

Box detections (a detector's own boxes, as YOLO gives them: the axis-aligned box of
an ant of 1 x 0.35 body lengths at its heading, the body point at the box centre)
of ants walking as real ants do, at 5, 10 and 30 frames per second: straight at 6 body
lengths per second, circling, stop-and-go, two ants side by side on a 45 degree
diagonal, and a walker whose box is missed now and then.  Each ant must be one track
(no identity switch, no second identity) covering nearly all of its boxes.  The
pedestrian settings (``min_iou`` 0.3 on a new track at rest, duplicates by
axis-aligned box overlap, confirmation in frames without a miss) fail these
(docs/tracking.md, "Tests of ant motion").
"""

from __future__ import annotations

import numpy as np
import pytest

from thermoswarm.tracking.detection import FrameDetections
from thermoswarm.tracking.evaluate import evaluate_tables
from thermoswarm.tracking.track.tracker import track_detections

L = 30.0  # px per body length
W = 0.35  # body width, body lengths
FPS = [5.0, 10.0, 30.0]


def _boxes(xy: np.ndarray, heading: np.ndarray) -> np.ndarray:
    """MOT boxes ``(n, 4)`` of ants at body points ``xy`` ``(n, 2)`` px, headings
    ``heading`` ``(n,)`` rad: the axis-aligned box of a 1 x ``W`` body rectangle."""
    c, s = np.abs(np.cos(heading)), np.abs(np.sin(heading))
    wh = L * np.c_[c + W * s, s + W * c]
    return np.c_[xy - wh / 2, wh]


def _run(xy: np.ndarray, heading: np.ndarray, fps: float, seen=None, seed: int = 0):
    """Track the boxes of ants at ``xy`` ``(T, N, 2)`` with ``heading`` ``(T, N)`` (NaN
    rows: absent; ``seen`` ``(T, N)`` false: box missed) and score the tracks
    against the true boxes; returns :func:`evaluate_tables`' dict."""
    rng = np.random.default_rng(seed)
    T, N = heading.shape
    seen = np.ones((T, N), bool) if seen is None else seen
    gt, dets = [], []
    for k in range(T):
        ok = np.isfinite(heading[k])
        box = _boxes(xy[k, ok], heading[k, ok])
        ids = np.flatnonzero(ok) + 1
        for i, b in zip(ids, box, strict=True):
            gt.append([k + 1, i, *b, 1, -1, -1, -1])
        det = box[seen[k, ok]]
        det = det + 0.02 * L * rng.standard_normal(det.shape) * [1, 1, 0, 0]
        pts = np.full((len(det), 3, 2), np.nan)
        pts[:, 1] = det[:, :2] + det[:, 2:] / 2
        dets.append(FrameDetections(pts, np.full(len(det), 0.8), boxes=det))
    res = track_detections(dets, fps=fps, length_px=L)
    return evaluate_tables(np.asarray(gt, float), res.mot_table())


def _check(m: dict, n_ants: int, min_mota: float = 0.9) -> None:
    assert m["idsw"] == 0, m
    assert m["n_pred_ids"] == n_ants, m
    assert m["mota"] >= min_mota, m


def _walk(fps: float, seconds: float, speed_bl_s: float, heading: float, start=(0.0, 0.0)):
    t = np.arange(int(round(seconds * fps))) / fps
    d = speed_bl_s * L * t
    xy = np.asarray(start) + d[:, None] * [np.cos(heading), np.sin(heading)]
    return xy, np.full(t.size, heading)


@pytest.mark.parametrize("fps", FPS)
def test_straight_walk_at_6_body_lengths_a_second(fps):
    # Two ants, one along the image axis and one on a diagonal, 4 s each.
    a, ha = _walk(fps, 4.0, 6.0, 0.0, (100, 100))
    b, hb = _walk(fps, 4.0, 6.0, np.pi / 4, (100, 400))
    _check(_run(np.stack([a, b], 1), np.stack([ha, hb], 1), fps), 2)


@pytest.mark.parametrize("fps", FPS)
def test_circling_ants(fps):
    # Eight ants on circles of 2 body lengths radius at 6 body lengths a second
    # (3 rad/s), 4 s, far apart from each other.
    t = np.arange(int(4 * fps)) / fps
    n = 8
    centres = np.c_[np.arange(n) % 4, np.arange(n) // 4] * 8 * L + 4 * L
    phase = np.linspace(0, 2 * np.pi, n, endpoint=False)
    ang = phase[None, :] + 3.0 * t[:, None] * np.where(np.arange(n) % 2, 1, -1)
    xy = centres[None] + 2 * L * np.stack([np.cos(ang), np.sin(ang)], -1)
    heading = ang + np.where(np.arange(n) % 2, np.pi / 2, -np.pi / 2)
    _check(_run(xy, heading, fps), n)


@pytest.mark.parametrize("fps", FPS)
def test_stop_and_go(fps):
    # Walk 1 s at 6 body lengths a second, stop 1 s, walk on, stop, walk (5 s).
    T = int(5 * fps)
    t = np.arange(T) / fps
    moving = (t % 2) < 1
    step = np.where(moving, 6.0 * L / fps, 0.0)
    x = 50 + np.concatenate([[0], np.cumsum(step[:-1])])
    xy = np.stack([x, np.full(T, 200.0)], -1)[:, None]
    _check(_run(xy, np.zeros((T, 1)), fps), 1)


@pytest.mark.parametrize("fps", FPS)
def test_pair_side_by_side_on_a_diagonal(fps):
    # Two ants walking together along the 45 degree diagonal at 6 body lengths a
    # second, 0.5 body lengths apart (side by side): their axis-aligned boxes
    # overlap by most of their area, their bodies do not.
    h = np.pi / 4
    side = 0.5 * L * np.array([-np.sin(h), np.cos(h)])
    a, ha = _walk(fps, 4.0, 6.0, h, (100, 100))
    b, hb = _walk(fps, 4.0, 6.0, h, np.array([100, 100]) + side)
    _check(_run(np.stack([a, b], 1), np.stack([ha, hb], 1), fps), 2)


@pytest.mark.parametrize("fps", FPS)
def test_missed_boxes(fps):
    # A walker at 6 body lengths a second whose box is missed in its second frame and
    # then in one frame of every second: one identity throughout, the gaps filled.
    xy, h = _walk(fps, 4.0, 6.0, 0.3, (100, 100))
    seen = np.ones(h.size, bool)
    seen[1] = False
    seen[np.arange(h.size) % int(fps) == int(fps) // 2] = False
    m = _run(xy[:, None], h[:, None], fps, seen=seen[:, None])
    _check(m, 1, min_mota=0.75)


def test_presets_and_their_cli_option(tmp_path):
    import json

    from click.testing import CliRunner

    from thermoswarm.cli import cli
    from thermoswarm.errors import ConfigError
    from thermoswarm.io.mot import write_mot_table
    from thermoswarm.tracking.track.presets import preset

    ped = preset("pedestrians")
    assert ped.min_iou == 0.3 and ped.duplicate_overlap == 0.3 and ped.max_gap_s == 0.5
    assert preset("pedestrians", min_iou=0.1).min_iou == 0.1
    with pytest.raises(ConfigError, match="unknown tracker preset 'cars'"):
        preset("cars")
    # Durations are seconds: the same preset confirms after more frames at 30 fps than
    # at 5 fps, and no positive time rounds to 0 frames.
    ants = preset("ants")
    assert ants.n_init(30.0) > ants.n_init(5.0) >= 2
    assert ants.max_gap(0.5) == 1
    # The CLI: --preset starts from a preset, --set overrides it; an unknown one is a
    # one-line error, exit 2.
    xy, h = _walk(10.0, 2.0, 6.0, 0.0, (100, 100))
    b = _boxes(xy, h)
    rows = np.c_[np.arange(1, len(b) + 1), -np.ones(len(b)), b, np.ones((len(b), 4))]
    write_mot_table(tmp_path / "d.txt", rows)
    base = ["track", "--detections", str(tmp_path / "d.txt"), "--fps", "10"]
    r = CliRunner().invoke(
        cli, [*base, "--out", str(tmp_path / "o"), "--preset", "pedestrians",
              "--set", "tracker.max_gap_s=0.7"],
    )  # fmt: skip
    assert r.exit_code == 0, r.output
    used = json.loads((tmp_path / "o" / "summary.json").read_text())["tracker"]
    assert used["min_iou"] == 0.3 and used["max_gap_s"] == 0.7
    r = CliRunner().invoke(cli, [*base, "--out", str(tmp_path / "p"), "--preset", "cars"])
    assert r.exit_code == 2 and "unknown preset 'cars'" in r.output


def _views(fps: float, scale: dict[int, float]):
    """One ant walking at 6 body lengths a second for 4 s (true boxes), and its
    detector boxes, those of frames in ``scale`` scaled in area by that factor about
    the box's centre, each side by its square root (the part of the ant a detector
    sees as it leaves a hole, or two ants in one box: IoU with the true box ``a`` or
    ``1 / a``)."""
    xy, h = _walk(fps, 4.0, 6.0, 0.3, (100, 100))
    gt = _boxes(xy, h)
    det = gt.copy()
    for k, a in scale.items():
        c = det[k, :2] + det[k, 2:] / 2
        det[k, 2:] *= np.sqrt(a)
        det[k, :2] = c - det[k, 2:] / 2
    return gt, det


@pytest.mark.parametrize("fps", [5.0, 30.0])
def test_partial_and_merged_views_keep_the_identity_but_are_not_written(fps):
    # A box with a third of the area of the ant's usual one (the ant half in a hole)
    # or 2.5-3 times it (two ants in one box) overlaps the ant's true box by IoU < 0.5:
    # writing it is a false box and a miss; not writing it, a miss.  The track keeps
    # its identity across those frames.  (Its longer side: 0.55-0.63 or 1.58-1.73 of
    # the usual one; the default band is 1.5.)
    from thermoswarm.tracking.track.config import TrackerConfig

    odd = {5: 0.3, 6: 0.4, 12: 2.5, 13: 3.0}
    gt, det = _views(fps, odd)
    T = len(gt)
    gt_rows = np.c_[np.arange(1, T + 1), np.ones(T), gt, np.ones((T, 4))]
    pts = np.full((T, 1, 3, 2), np.nan)
    pts[:, 0, 1] = det[:, :2] + det[:, 2:] / 2
    dets = [FrameDetections(pts[k], np.full(1, 0.8), boxes=det[k : k + 1]) for k in range(T)]
    m_all = {}
    for band in (1.5, 0.0):
        res = track_detections(dets, fps=fps, length_px=L, config=TrackerConfig(size_band=band))
        t = res.mot_table()
        m_all[band] = evaluate_tables(gt_rows, t)
        assert m_all[band]["idsw"] == 0 and m_all[band]["n_pred_ids"] == 1, m_all[band]
        written = set(t[:, 0].astype(int) - 1)
        assert written.isdisjoint(odd) == (band > 0), sorted(written)
    assert m_all[0.0]["fp"] == len(odd) and m_all[1.5]["fp"] == 0
    assert m_all[1.5]["mota"] - m_all[0.0]["mota"] == pytest.approx(len(odd) / T)
    assert TrackerConfig().size_band == 1.5


@pytest.mark.parametrize("fps", [5.0, 30.0])
def test_a_turning_ants_boxes_are_all_written(fps):
    # An ant walking along the image's x axis that turns onto the diagonal for 1 s and
    # back: its axis-aligned box's area grows 2.6-fold there, its longer side by under
    # 5 %.  Every box is its own; none may be judged a partial or merged view.
    t = np.arange(int(4 * fps)) / fps
    h = np.interp(t, [0, 1.5, 1.75, 2.25, 2.5, 4], [0, 0, 1, 1, 0, 0]) * np.pi / 4
    step = 3.0 * L / fps * np.c_[np.cos(h), np.sin(h)]
    xy = 100 + np.cumsum(step, 0)
    area = np.prod(_boxes(xy, h)[:, 2:], 1)
    assert area.max() / area.min() > 2.5
    m = _run(xy[:, None], h[:, None], fps)
    _check(m, 1, min_mota=1.0)


def test_pose_boxes_are_written_whatever_their_size():
    # Pose detections (body points, no detector box): a body measured short (an ant
    # curled up) is still written; size_band judges only a detector's own boxes.
    fps = 10.0
    xy, h = _walk(fps, 3.0, 3.0, 0.0, (100, 100))
    T = len(xy)
    half = np.where(np.isin(np.arange(T), [8, 9, 10]), 0.2, 0.5) * L
    pts = np.stack([xy + np.c_[half, 0 * half], xy, xy - np.c_[half, 0 * half]], 1)
    dets = [FrameDetections(pts[k : k + 1], np.full(1, 0.8)) for k in range(T)]
    res = track_detections(dets, fps=fps, length_px=L)
    assert res.n_tracks == 1 and res.frames.size == T


def test_size_outliers_are_judged_against_each_tracks_own_median():
    from thermoswarm.tracking.track.result import size_outliers

    # Longer sides: track 1: 100 (x5), 45, 210; track 2 (a larger ant): 400 (x4),
    # 190, 790.
    ids = np.r_[np.ones(7), np.full(6, 2)]
    side = np.r_[[100] * 5, 45, 210, [400] * 4, 190, 790]
    boxes = np.c_[np.zeros((13, 2)), np.ones(13), side]
    assert np.flatnonzero(size_outliers(ids, boxes, 2.0)).tolist() == [5, 6, 11]
    assert np.flatnonzero(size_outliers(ids, boxes, 2.3)).tolist() == []
    assert not size_outliers(ids, boxes, 0.0).any()
