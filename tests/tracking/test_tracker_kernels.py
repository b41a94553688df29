"""The tracker's compiled per-frame kernels give the same numbers as the array
expressions they replaced (written out here as straightforward references), and the
whole tracker gives exact, hand-checked tracks on a small case."""

from __future__ import annotations

import numpy as np
import pytest

from thermoswarm.tracking import anatomy
from thermoswarm.tracking.detection import FrameDetections
from thermoswarm.tracking.track import association, kalman, speed
from thermoswarm.tracking.track import bank as track_bank
from thermoswarm.tracking.track.bank import TrackBank
from thermoswarm.tracking.track.tracker import TrackerConfig, track_detections


def _random_bank(rng: np.random.Generator, n: int) -> TrackBank:
    """``n`` tracks in assorted states: some with a pose shape, some box-only, some
    confirmed, some coasting."""
    b = TrackBank(n_hist=3)
    b.append(n)
    A = rng.normal(size=(n, 4, 4))
    b.P[:] = A @ A.transpose(0, 2, 1) * rng.uniform(0.1, 20, (n, 1, 1)) + np.eye(4)
    b.x[:] = np.c_[rng.uniform(0, 200, (n, 2)), rng.normal(0, 3, (n, 2))]
    b.q[:] = rng.uniform(0.01, 3, n)
    shape = rng.normal(0, 6, (n, 2, 2))
    shape[rng.random(n) < 0.4] = np.nan  # box-only tracks
    b.shape[:] = shape
    b.half[:] = rng.uniform(3, 9, (n, 2))
    b.last[:] = rng.integers(90, 100, n)
    b.misses[:] = rng.integers(0, 3, n)
    b.out_id[:] = np.where(rng.random(n) < 0.7, np.arange(1, n + 1), 0)
    b.key[:] = np.arange(1, n + 1)
    return b


def _reference_costs(c, b, frame, r2, pad, step_px, pts, boxes, L, hint_other):
    """The cost matrix as array expressions (einsum, hypot, pose_boxes, box_iou)."""
    x, P = b.x.copy(), b.P.copy()
    pred = x[:, :2]
    Sinv = np.linalg.inv(P[:, :2, :2] + r2 * np.eye(2))
    d = pts[None, :, 1, :] - pred[:, None, :]
    maha = np.einsum("nmi,nij,nmj->nm", d, Sinv, d)
    dist = np.hypot(d[..., 0], d[..., 1])
    reach = speed.reach_px(b.x[:, 2:], frame - b.last, step_px, pad)
    ok = (maha <= c.gate_sigmas**2) & (dist <= reach[:, None])
    shape = b.shape
    poses = np.stack([pred + shape[:, 0], pred, pred + shape[:, 1]], axis=1)
    unknown = ~np.isfinite(poses[:, [0, 2]]).all(axis=(1, 2))
    pboxes = anatomy.pose_boxes(poses, pad)
    half = b.half
    pboxes[unknown] = np.concatenate([pred - half, 2 * half], axis=1)[unknown]
    iou = anatomy.box_iou(pboxes, boxes)
    ok &= iou >= c.min_iou
    size = np.full(len(pboxes), float(L))
    if c.own_size:
        side = np.maximum(pboxes[:, 2], pboxes[:, 3])
        size = np.where(side > np.finfo(np.float64).eps, side, L)
    total = c.iou_weight * (1 - iou) + c.distance_weight * dist / size[:, None]
    if c.mahalanobis_weight > 0:
        w = c.mahalanobis_weight / c.gate_sigmas
        total = total + np.where(maha > 0, w * np.sqrt(np.maximum(maha, 0)), 0.0)
    ta = poses[:, 0] - poses[:, 2]
    da = pts[:, 0] - pts[:, 2]
    if c.angle_weight > 0 and np.isfinite(ta).any() and np.isfinite(da).any():
        cross = ta[:, None, 0] * da[None, :, 1] - ta[:, None, 1] * da[None, :, 0]
        norm = np.hypot(ta[:, 0], ta[:, 1])[:, None] * np.hypot(da[:, 0], da[:, 1])[None, :]
        with np.errstate(invalid="ignore", divide="ignore"):
            sin = np.abs(cross) / norm
        total = total + c.angle_weight * np.where(np.isfinite(sin), sin, 0.0)
    if hint_other is not None:
        total = total + c.hint_weight * hint_other
    return np.where(ok, total, association.BIG)


@pytest.mark.parametrize("seed", range(12))
def test_pair_costs_equal_the_array_expressions(seed):
    rng = np.random.default_rng(seed)
    n, m = int(rng.integers(1, 25)), int(rng.integers(1, 30))
    b = _random_bank(rng, n)
    body = rng.uniform(0, 200, (m, 2))
    near = rng.random(m) < 0.6  # detections close to a track's body, the others anywhere
    body[near] = b.x[rng.integers(0, n, near.sum()), :2] + rng.normal(0, 3, (near.sum(), 2))
    axis = rng.normal(0, 8, (m, 2))
    pts = np.stack([body + axis / 2, body, body - axis / 2], axis=1)
    if seed % 3 == 0:
        pts[:, [0, 2]] = np.nan  # box-only detections
    else:
        sel = rng.random(m) < 0.3
        pts[sel, 0] = pts[sel, 2] = np.nan
    boxes = np.c_[body - 5, rng.uniform(4, 12, (m, 2))]
    boxes[0, 2] = 0.0  # a box of zero area: IoU 0
    c = TrackerConfig(
        iou_weight=[1.0, 0.7][seed % 2],
        distance_weight=[1.0, 1.3][seed % 2],
        mahalanobis_weight=[0.0, 1.0, 0.5][seed % 3],
        angle_weight=[0.3, 0.0, 0.45][seed % 3],
        gate_sigmas=[5.0, 2.0][seed % 2],
        min_iou=[0.0, 0.3, 0.05][seed % 3],
        own_size=seed % 4 < 2,
    )
    hint_other = (rng.random((n, m)) < 0.2) if seed % 4 == 1 else None
    frame, r2, pad, step, L = 100, 1.7, 3.2, 6.0, 20.0
    S, pred, tboxes, axes, reach, any_axis = track_bank.prepare_costs(
        b.F, b.I, b.n, frame, r2, pad, step, speed.SPEED_HEADROOM, speed.MAX_WIDENING
    )
    got = association.pair_costs(
        c, S=S, pred=pred, track_boxes=tboxes, axes=axes, reach=reach, any_axis=any_axis,
        pts=pts, boxes=boxes, length_px=L, hint_other=hint_other,
    )  # fmt: skip
    want = _reference_costs(c, b, frame, r2, pad, step, pts, boxes, L, hint_other)
    np.testing.assert_array_equal(got, want)
    # Both sides of the gate occur, so the test sees gating and costs.
    assert (got == association.BIG).any() or n * m < 4
    assert (got < association.BIG).any() or not near.any()


def test_predict_equals_the_matrix_products():
    rng = np.random.default_rng(1)
    b = _random_bank(rng, 17)
    x0, P0, q = b.x.copy(), b.P.copy(), b.q.copy()
    sure = (b.out_id > 0) & (b.misses == 0)
    poses, keys = track_bank.predict(b.F, b.I, b.n)
    F = kalman._F
    np.testing.assert_array_equal(b.x, x0 @ F.T)
    np.testing.assert_array_equal(b.P, F @ P0 @ F.T + q[:, None, None] * kalman._Q1)
    body = b.x[sure, :2]
    shape = b.shape[sure]
    want = np.stack([body + shape[:, 0], body, body + shape[:, 1]], axis=1)
    np.testing.assert_array_equal(poses, want)
    np.testing.assert_array_equal(keys, b.key[sure])
    # The array version in kalman gives the same numbers.
    x1, P1 = kalman.predict(x0, P0, q)
    np.testing.assert_array_equal(x1, b.x)
    np.testing.assert_array_equal(P1, b.P)


def test_kalman_update_equals_the_textbook_form():
    rng = np.random.default_rng(2)
    H = np.array([[1.0, 0, 0, 0], [0, 1, 0, 0]])
    for n in (1, 3, 20):
        A = rng.normal(size=(n, 4, 4))
        P = A @ A.transpose(0, 2, 1) + 0.1 * np.eye(4)
        x = rng.normal(0, 50, (n, 4))
        z = x[:, :2] + rng.normal(0, 2, (n, 2))
        r = rng.uniform(0.5, 3, n)
        got = kalman.update(x, P, z, r)
        S = P[:, :2, :2] + (r**2)[:, None, None] * np.eye(2)
        Sinv = np.linalg.inv(S)
        K = P @ H.T @ Sinv
        v = z - x[:, :2]
        IKH = np.eye(4)[None] - K @ H
        want = (
            x + np.einsum("nij,nj->ni", K, v),
            IKH @ P @ IKH.transpose(0, 2, 1) + (r**2)[:, None, None] * K @ K.transpose(0, 2, 1),
            np.einsum("ni,nij,nj->n", v, Sinv, v),
        )
        for g, w in zip(got, want, strict=True):
            np.testing.assert_array_equal(g, w)


def test_compiled_update_and_adapt_equal_the_array_form():
    # The tracker's one-pass kernel against kalman.update then kalman.adapt (the
    # products are written out in another order: equal to rounding, 1e-12 relative).
    rng = np.random.default_rng(5)
    p = kalman.KalmanParams(r=1.0, q0=0.3, q_min=0.01, q_max=10.0)
    for n in (1, 4, 30):
        A = rng.normal(size=(n, 4, 4))
        P = A @ A.transpose(0, 2, 1) + 0.1 * np.eye(4)
        x = rng.normal(0, 50, (n, 4))
        z = x[:, :2] + rng.normal(0, 2, (n, 2))
        r = rng.uniform(0.5, 3, n)
        q = rng.uniform(0.005, 20, n)  # some outside the bounds
        m = rng.uniform(0.5, 6, n)
        x1, P1, nis = kalman.update(x, P, z, r)
        q1, m1 = kalman.adapt(q, m, nis, p)
        got = kalman.update_adapt(x, P, z, r, q, m, p)
        for g, w in zip(got, (x1, P1, q1, m1), strict=True):
            np.testing.assert_allclose(g, w, rtol=1e-12, atol=1e-12 * np.abs(w).max())


def test_bookkeeping_kernels_equal_a_per_track_reference():
    rng = np.random.default_rng(3)
    b = _random_bank(rng, 12)
    # Matched below: rows 7, 2, 9, 0, 4; box-only detections for rows 2 (first hit
    # smoothing: none) and 0 (smoothed); tentative rows 2 and 9 (history written).
    b.hits[:] = np.where(np.arange(b.n) % 4 == 0, 2, 1)
    b.out_id[:] = np.arange(1, b.n + 1)
    b.out_id[[2, 9, 5]] = 0
    b.last_points[:] = rng.uniform(0, 200, (b.n, 3, 2))
    b.last_box[:] = rng.uniform(0, 200, (b.n, 4))
    before = TrackBank(3)
    before.append(b.n)
    before.F[: b.n] = b.F[: b.n]
    before.I[: b.n] = b.I[: b.n]
    rows = np.array([7, 2, 9, 0, 4])
    m = rows.size
    frame = 101
    p = rng.uniform(0, 200, (m, 3, 2))
    p[[1, 3], 0] = np.nan  # box-only detections
    box, det_box = rng.uniform(1, 50, (m, 4)), rng.uniform(1, 50, (m, 4))
    scores, hc = rng.uniform(0, 1, m), rng.uniform(0, 1, m)
    x, P = rng.normal(size=(m, 4)), rng.normal(size=(m, 4, 4))
    q, nis = rng.uniform(size=m), rng.uniform(size=m)
    # Gap filling first (it reads the last detection), then the new states.
    fr, ids, ip, ib = track_bank.fill_rows(b.F, b.I, rows, frame, p, box)
    want_rows = []
    for i, r in enumerate(rows):
        gap = frame - before.last[r]
        for g in range(1, gap):
            a = g / gap
            ip_ = (1 - a) * before.last_points[r] + a * p[i]
            ib_ = (1 - a) * before.last_box[r] + a * box[i]
            want_rows.append((before.last[r] + g, before.out_id[r], ip_, ib_))
    assert fr.tolist() == [w[0] for w in want_rows]
    assert ids.tolist() == [w[1] for w in want_rows]
    np.testing.assert_array_equal(ip, np.array([w[2] for w in want_rows]).reshape(-1, 3, 2))
    np.testing.assert_array_equal(ib, np.array([w[3] for w in want_rows]).reshape(-1, 4))
    track_bank.store_matched(b.F, b.I, rows, x, P, q, nis, p, box, det_box, scores, hc, frame)
    for i, r in enumerate(rows):
        np.testing.assert_array_equal(b.x[r], x[i])
        np.testing.assert_array_equal(b.P[r], P[i])
        assert b.q[r] == q[i] and b.nis[r] == nis[i]
        posed = np.isfinite(p[i, [0, 2]]).all()
        if posed:
            np.testing.assert_array_equal(b.shape[r], [p[i, 0] - p[i, 1], p[i, 2] - p[i, 1]])
            a = p[i, 0] - p[i, 2]
            np.testing.assert_array_equal(b.heading[r], a / np.hypot(*a))
            np.testing.assert_array_equal(b.half[r], before.half[r])
        else:
            bh = det_box[i, 2:4] / 2
            want = 0.7 * before.half[r] + 0.3 * bh if before.hits[r] > 1 else bh
            np.testing.assert_array_equal(b.half[r], want)
            np.testing.assert_array_equal(b.shape[r], before.shape[r])
        assert b.hits[r] == before.hits[r] + 1 and b.misses[r] == 0 and b.last[r] == frame
        np.testing.assert_array_equal(b.last_points[r], p[i])
        np.testing.assert_array_equal(b.last_box[r], box[i])
        if before.out_id[r] == 0:  # tentative: the detection goes to its history
            f, hp, hb, hs, hh = b.history(r)[before.hits[r]]
            assert f == frame and hs == scores[i] and hh == hc[i]
            np.testing.assert_array_equal(hp, p[i])
            np.testing.assert_array_equal(hb, box[i])
    # Misses and deaths: every unmatched track misses once; a tentative one dies after
    # more than 1 miss, a confirmed one 3 frames after its last detection, any track
    # predicted outside the 150 x 150 frame.
    matched = np.zeros(b.n, bool)
    matched[rows] = True
    misses0 = b.misses.copy()
    keep = track_bank.misses_and_deaths(b.F, b.I, b.n, matched, frame, 1, 3, True, 150, 150)
    for r in range(b.n):
        if matched[r]:
            assert keep[r] and b.misses[r] == 0
            continue
        assert b.misses[r] == misses0[r] + 1
        conf = b.out_id[r] > 0
        outside = not (0 <= b.x[r, 0] <= 149 and 0 <= b.x[r, 1] <= 149)
        dead = (frame - b.last[r] > 3 if conf else b.misses[r] > 1) or outside
        assert keep[r] == (not dead)
    assert not keep.all() and keep[~matched].any()


def test_new_tracks_start_as_kalman_initial_state():
    rng = np.random.default_rng(4)
    b = TrackBank(n_hist=2)
    b.append(3)
    p = rng.uniform(0, 100, (4, 3, 2))
    p[1, [0, 2]] = np.nan
    box = rng.uniform(1, 20, (4, 4))
    kp = kalman.KalmanParams(r=1.3, v0=2.2, q0=0.7)
    start = b.append(4)
    track_bank.init_rows(
        b.F, b.I, start, p, box, np.full(4, 0.9), np.full(4, 0.6), 12, kp.r**2, kp.v0**2,
        kp.q0, 50,
    )  # fmt: skip
    x0, P0 = kalman.initial_state(p[:, 1], kp)
    new = slice(3, 7)
    np.testing.assert_array_equal(b.x[new], x0)
    np.testing.assert_array_equal(b.P[new], P0)
    assert (b.q[new] == kp.q0).all() and (b.nis[new] == 2.0).all()
    np.testing.assert_array_equal(b.half[new], box[:, 2:4] / 2)
    assert np.isnan(b.shape[4]).all() and np.isnan(b.heading[4]).all()
    a = p[0, 0] - p[0, 2]
    np.testing.assert_array_equal(b.heading[3], a / np.hypot(*a))
    assert b.key[new].tolist() == [50, 51, 52, 53] and b.hits[new].tolist() == [1] * 4
    assert b.out_id[new].tolist() == [0] * 4 and b.last[new].tolist() == [12] * 4
    assert [h[0] for h in b.history(5)] == [12]


def _box(cx: float, cy: float, s: float = 10.0) -> list[float]:
    return [cx - s / 2, cy - s / 2, s, s]


def test_exact_tracks_on_a_hand_checkable_case():
    """Three objects and a false box, 12 frames at 10 fps, boxes 10 px (the unit): A
    moves +2 px/frame and is missed in frame 4; B moves -2 px/frame and is missed in
    frames 6-8 (it coasts and is found again); C appears in frame 5; a false box in
    frame 3 is never confirmed.  Expected: ids in order of confirmation (A and B in
    frame 2, C in frame 7, written from its first frame), the detections' own boxes
    and scores, and the gaps filled linearly (score 0)."""
    dets, want = [], []
    for k in range(12):
        rows, sc = [], []
        a, b_, c_ = (20 + 2 * k, 20), (100 - 2 * k, 80), (150 + k, 20)
        if k != 4:
            rows.append(_box(*a))
            sc.append(0.9)
        if not 6 <= k <= 8:
            rows.append(_box(*b_))
            sc.append(0.8)
        if k >= 5:
            rows.append(_box(*c_))
            sc.append(0.7)
        if k == 3:
            rows.append(_box(60, 150))
            sc.append(0.3)
        want.append((k, 1, _box(*a), 0.0 if k == 4 else 0.9))
        want.append((k, 2, _box(*b_), 0.0 if 6 <= k <= 8 else 0.8))
        if k >= 5:
            want.append((k, 3, _box(*c_), 0.7))
        bx = np.array(rows, float)
        pts = np.full((len(rows), 3, 2), np.nan)
        pts[:, 1] = bx[:, :2] + bx[:, 2:] / 2
        dets.append(FrameDetections(pts, np.array(sc), boxes=bx))
    # The confirmation and coasting this case was written for (3 detections at 10 fps,
    # one miss allowed while tentative, one second of coasting).
    cfg = TrackerConfig(confirm_s=0.2, tentative_gap_s=0.1, max_gap_s=1.0)
    res = track_detections(dets, fps=10, config=cfg)
    want.sort(key=lambda w: (w[0], w[1]))
    assert res.frames.tolist() == [w[0] for w in want]
    assert res.ids.tolist() == [w[1] for w in want]
    # Midpoints of dyadic steps: the filled boxes are exact too.
    np.testing.assert_array_equal(res.boxes, np.array([w[2] for w in want]))
    np.testing.assert_array_equal(res.scores, [w[3] for w in want])
    assert res.interpolated.tolist() == [w[3] == 0.0 for w in want]
    np.testing.assert_array_equal(res.points[:, 1], res.boxes[:, :2] + res.boxes[:, 2:] / 2)
