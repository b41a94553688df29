"""Fast ants tracked when the body length the tracker is given is 30 % off (issue 32).

On small animals the body length is often measured from the video, and 30 % off
(4.7 px measured against 6-7 px by eye).  Every gate is in body lengths, so a length
measured short turns the top speed of 14 body lengths a second into 9.8 true ones,
below what fast ants run.  Here eight ants walk at 8-10 true body lengths a second,
turning (an Ornstein-Uhlenbeck angular speed, sd 1.5 rad/s, 0.3 s correlation; turned
back from the walls at up to 4 rad/s), 6 s at 10 and 30 frames per second, with
head, body and tail detected (sd 0.05 body length each, 2 % of detections missed);
the tracker is given 0.7 and 1.3 times the true length.

Score: each true position is matched to a track's body point in its frame (within
half a true body length, Hungarian); each ant is then given the one track that
covers most of it (one track per ant, Hungarian on the counts), and the share of
true positions covered by the ant's own track is the score (IDF1's recall, IDR).

Bound: the goal is the issue's 95 % of ants tracked.  A lost ant stays lost for
a run of frames (until a new track is confirmed), so the trials are not the frames
but about the ant-seconds: n = 3 runs x 8 ants x 6 s = 144.  The pooled share must
not be more than 3 binomial standard errors below 0.95:
``0.95 - 3 sqrt(0.95 x 0.05 / 144) = 0.895``.  Identity switches (an ant's matched
track changing) at most 2 a run, one crossing of two ants each way; at most 2 tracks
more than ants in a run.  Before the per-track cap
(:mod:`thermoswarm.tracking.track.speed`) the 0.7 x runs scored 0.85 (10 fps) and
0.63 (30 fps); after, 0.99 and 0.98 (docs/real_footage.md).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from thermoswarm.tracking.detection import FrameDetections
from thermoswarm.tracking.track.tracker import track_detections

L = 10.0  # true body length, px
SIZE = (640.0, 360.0)  # the frame, px
N_ANTS, SECONDS, SEEDS = 8, 6.0, (2026, 2027, 2028)
GOAL = 0.95
BOUND = GOAL - 3 * math.sqrt(GOAL * (1 - GOAL) / (len(SEEDS) * N_ANTS * SECONDS))


def _walk(fps: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Body points ``(T, N, 2)`` px and headings ``(T, N)`` rad of fast, turning ants."""
    T, dt, n = int(round(SECONDS * fps)), 1 / fps, N_ANTS
    w, h = SIZE
    xy, hd = np.zeros((T, n, 2)), np.zeros((T, n))
    p = np.c_[rng.uniform(4 * L, w - 4 * L, n), rng.uniform(4 * L, h - 4 * L, n)]
    th, om = rng.uniform(-np.pi, np.pi, n), np.zeros(n)
    v = rng.uniform(8.0, 10.0, n) * L
    tau, sd = 0.3, 1.5
    for k in range(T):
        xy[k], hd[k] = p, th
        om += -om * dt / tau + sd * math.sqrt(2 * dt / tau) * rng.standard_normal(n)
        edge = (np.minimum(p, [w, h] - p) < 4 * L).any(axis=1)
        home = np.arctan2(h / 2 - p[:, 1], w / 2 - p[:, 0])
        om = np.where(edge, np.clip(4 * np.angle(np.exp(1j * (home - th))), -4, 4), om)
        th = th + om * dt
        p = p + v[:, None] * dt * np.c_[np.cos(th), np.sin(th)]
    return xy, hd


def _detections(xy, hd, rng: np.random.Generator) -> list[FrameDetections]:
    out = []
    for k in range(len(xy)):
        u = 0.5 * L * np.c_[np.cos(hd[k]), np.sin(hd[k])]
        pts = np.stack([xy[k] + u, xy[k], xy[k] - u], 1)
        pts = pts + 0.05 * L * rng.standard_normal(pts.shape)
        seen = rng.random(len(pts)) > 0.02
        out.append(FrameDetections(pts[seen], np.full(seen.sum(), 0.9)))
    return out


def _score(xy: np.ndarray, res) -> tuple[float, int, int]:
    """(share of true positions covered by the ant's own track, switches, tracks)."""
    T, n, _ = xy.shape
    ids = np.unique(res.ids)
    counts = np.zeros((n, ids.size))
    match = np.full((T, n), -1)
    for k in range(T):
        rows = np.flatnonzero(res.frames == k)
        d = np.linalg.norm(xy[k][:, None] - res.points[rows, 1][None], axis=-1)
        a, b = linear_sum_assignment(d)
        ok = d[a, b] < 0.5 * L
        t = np.searchsorted(ids, res.ids[rows[b[ok]]])
        counts[a[ok], t] += 1
        match[k, a[ok]] = t
    a, b = linear_sum_assignment(-counts)
    switches = sum(int((np.diff(m[m >= 0]) != 0).sum()) for m in match.T)
    return counts[a, b].sum() / (T * n), switches, ids.size


def run(fps: float, factor: float, seed: int) -> tuple[float, int, int]:
    """Track one seed's ants with ``factor`` times the true length; :func:`_score`."""
    rng = np.random.default_rng(seed)
    xy, hd = _walk(fps, rng)
    res = track_detections(_detections(xy, hd, rng), fps=fps, length_px=factor * L)
    return _score(xy, res)


@pytest.mark.parametrize("fps", [10.0, 30.0])
@pytest.mark.parametrize("factor", [0.7, 1.3])
def test_fast_ants_kept_when_the_body_length_is_30_percent_off(fps, factor):
    runs = [run(fps, factor, seed) for seed in SEEDS]
    share = np.mean([r[0] for r in runs])  # equal runs: the pooled share
    assert share >= BOUND, (runs, BOUND)
    assert all(sw <= 2 and nt <= N_ANTS + 2 for _, sw, nt in runs), runs
