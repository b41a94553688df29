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
