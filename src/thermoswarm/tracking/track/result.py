"""The tracker's output and what is done to it at the end of the video.

:class:`TrackResult` holds every confirmed track's rows; :func:`fix_jumps` removes motion
no ant can make and :func:`orient_tracks` chooses each track's head-tail order over its
whole life (both called by :meth:`~thermoswarm.tracking.track.tracker.Tracker.finish`; neither
changes identities).  Both take rows sorted by track, then frame, and work on one track
at a time only where there is something to do (a speed over the limit, a track with
head and tail): the checks that find those tracks are made on all rows at once.
Positions in px, frames as indices of the frames given to the tracker.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from thermoswarm.tracking import anatomy

__all__ = ["TrackResult", "fix_jumps", "orient_tracks"]


@dataclass
class TrackResult:
    """All confirmed tracks, one row per (frame, track), sorted by frame then id.

    ``frames`` are 0-based frame indices (of the frames given to the tracker);
    ``points`` ``(k, 3, 2)`` px [head, body, tail] (head/tail NaN when the detector
    gave boxes only); ``boxes`` ``(k, 4)`` MOT boxes px (the detections' own boxes
    where they had some); ``scores`` detection scores (0 for interpolated rows);
    ``interpolated`` flags rows filled across a gap; ``first_frame`` the number that
    the MOT table gives the first frame (1 as MOTChallenge counts, 0 for 0-based
    inputs).
    """

    frames: np.ndarray
    ids: np.ndarray
    points: np.ndarray
    boxes: np.ndarray
    scores: np.ndarray
    interpolated: np.ndarray
    n_frames: int
    first_frame: int = 1

    @classmethod
    def empty(cls, n_frames: int) -> TrackResult:
        """No tracks over ``n_frames`` frames."""
        z = np.zeros(0)
        return cls(z.astype(np.int64), z.astype(np.int64), np.zeros((0, 3, 2)),
                   np.zeros((0, 4)), z, z.astype(bool), n_frames)  # fmt: skip

    @property
    def n_tracks(self) -> int:
        return int(np.unique(self.ids).size)

    def mot_table(self) -> np.ndarray:
        """MOTChallenge rows ``frame, id, box, conf, -1, -1, -1`` (frames numbered from
        ``first_frame``)."""
        t = np.full((self.frames.size, 10), -1.0)
        t[:, 0] = self.frames + self.first_frame
        t[:, 1] = self.ids
        t[:, 2:6] = self.boxes
        t[:, 6] = self.scores
        return t

    def dataset(
        self,
        *,
        px_per_mm: float,
        fps: float,
        source_file: str | None = None,
        attrs: dict[str, Any] | None = None,
    ) -> Any:
        """The trajectory Dataset (mm, s; keypoints head, body, tail; one individual
        per track, ``track_<id>``).  ``confidence`` is the detection score (0 where
        interpolated, NaN where absent); ``interpolated`` flags filled samples."""
        from thermoswarm.tracks import make_tracks

        uid, col = np.unique(self.ids, return_inverse=True)
        T = max(self.n_frames, 1)
        pos = np.full((T, 2, 3, uid.size), np.nan)
        conf = np.full((T, 3, uid.size), np.nan, dtype=np.float32)
        interp = np.zeros((T, uid.size), bool)
        pos[self.frames, :, :, col] = self.points.transpose(0, 2, 1) / px_per_mm
        has = np.isfinite(self.points[:, :, 0])
        conf[self.frames, :, col] = np.where(has, self.scores[:, None], np.nan)
        interp[self.frames, col] = self.interpolated
        ds = make_tracks(
            pos,
            fps=fps,
            individuals=[f"track_{i}" for i in uid],
            keypoints=list(anatomy.KEYPOINTS),
            confidence=conf,
            source_software="thermoswarm track",
            source_file=source_file,
            attrs={"px_per_mm": float(px_per_mm), **(attrs or {})},
        )
        ds["interpolated"] = (
            ("time", "individuals"),
            interp,
            {"long_name": "position filled across a detection gap"},
        )
        return ds


def _track_bounds(ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    starts = np.flatnonzero(np.r_[True, ids[1:] != ids[:-1]])
    return starts, np.r_[starts[1:], ids.size]


def size_outliers(ids: np.ndarray, boxes: np.ndarray, band: float) -> np.ndarray:
    """Rows whose box's longer side is outside ``[median / band, median * band]`` of
    their own track's (rows sorted by track): partial views (an ant at the frame's edge,
    half in a hole) and merged ones (two ants end to end in one box), whose boxes
    overlap the ant's true box by less than IoU 0.5 (real ant boxes, docs/tracking.md).

    The longer side, not the area: the axis-aligned box of an ant 1 x 0.35 body
    lengths has an area 2.6 times larger on a diagonal than along an image axis, but a
    longer side within 5 % of its body length at every heading, so a turning ant is
    never judged a partial view.  Each track's median is taken in one pass over the
    rows sorted by track, then by side."""
    if ids.size == 0 or band <= 0:
        return np.zeros(ids.size, bool)
    side = np.max(boxes[:, 2:4], axis=1)
    starts, ends = _track_bounds(ids)
    srt = side[np.lexsort((side, ids))]
    lo, hi = (starts + ends - 1) // 2, (starts + ends) // 2
    med = np.repeat(0.5 * (srt[lo] + srt[hi]), ends - starts)
    with np.errstate(invalid="ignore", divide="ignore"):
        r = side / med
    return (r < 1.0 / band) | (r > band)


def fix_jumps(
    frames: np.ndarray,
    ids: np.ndarray,
    pts: np.ndarray,
    boxes: np.ndarray,
    scores: np.ndarray,
    interp: np.ndarray,
    limit: float | np.ndarray,
) -> np.ndarray:
    """Remove what no ant can do: moving faster than ``limit`` px per frame (one number,
    or one per row: each track's own, :func:`~thermoswarm.tracking.track.speed.track_limits`).

    Rows are sorted by track then frame; ``pts``, ``boxes``, ``scores`` and ``interp``
    are changed in place.  A single row that jumps away and back (a misplaced
    detection) is replaced by the interpolation of its neighbours and flagged as
    interpolated (score 0); after a jump that stays (the track took over another ant,
    or the detections moved to another part of a merged blob) the first row is
    dropped, so that no speed is measured across the jump.  Returns the rows to drop.
    """
    drop = np.zeros(ids.size, bool)
    if ids.size < 2:
        return drop
    # Speeds of all consecutive rows at once; only tracks with a fast step go on.
    f_all = frames.astype(np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):  # across tracks: not used
        step_all = np.linalg.norm(np.diff(pts[:, 1], axis=0), axis=1) / np.diff(f_all)
    lim = np.broadcast_to(np.asarray(limit, dtype=np.float64), ids.shape)
    fast_all = (step_all > lim[1:]) & (ids[1:] == ids[:-1])
    if not fast_all.any():
        return drop
    starts, ends = _track_bounds(ids)
    owner = np.searchsorted(starts, np.flatnonzero(fast_all), side="right") - 1
    for t in np.unique(owner):
        a, b = starts[t], ends[t]
        f, limit = f_all[a:b], lim[a]
        body = pts[a:b, 1]
        step = np.linalg.norm(np.diff(body, axis=0), axis=1) / np.diff(f)
        fast = step > limit
        for i in np.flatnonzero(fast[:-1] & fast[1:]) + 1:  # spikes
            span = (body[i + 1] - body[i - 1]) / (f[i + 1] - f[i - 1])
            if np.linalg.norm(span) <= limit:
                w = (f[i] - f[i - 1]) / (f[i + 1] - f[i - 1])
                r = a + i
                pts[r] = (1 - w) * pts[r - 1] + w * pts[r + 1]
                boxes[r] = (1 - w) * boxes[r - 1] + w * boxes[r + 1]
                scores[r], interp[r] = 0.0, True
        body = pts[a:b, 1]
        step = np.linalg.norm(np.diff(body, axis=0), axis=1) / np.diff(f)
        for i in np.flatnonzero(step > limit):  # jumps: no speed across them
            drop[a + i + 1] = True
    return drop


def orient_tracks(
    c: Any,
    frames: np.ndarray,
    ids: np.ndarray,
    pts: np.ndarray,
    hc: np.ndarray,
    motion_px: float,
) -> np.ndarray:
    """Head-tail order of every track, chosen jointly over its whole life.

    Rows are sorted by track then frame; returns a copy of ``pts``.  Two states per row
    (as detected, or head and tail swapped); the evidence for a state is the agreement
    of its head direction with the direction of motion (central differences of the
    body point, weighted by ``v^2 / (v^2 + motion_px^2)``) times ``c.motion_weight``,
    plus ``c.shape_weight`` times the detector's ``2 head_confidence - 1``; turning the
    head by an angle ``a`` between consecutive rows costs ``c.continuity_weight
    (1 - cos a)``.  The best sequence of states (Viterbi) is kept.  Boxes do not change
    (the body-centred box is the same either way).  Rows without head and tail (box
    detections) are left as they are.
    """
    pts = pts.copy()
    posed = np.all(np.isfinite(pts[:, [0, 2]]), axis=(1, 2))
    if np.count_nonzero(posed) < 2:
        return pts
    starts, ends = _track_bounds(ids)
    n_posed = np.add.reduceat(posed.astype(np.int64), starts)
    for a, b in zip(starts[n_posed >= 2], ends[n_posed >= 2], strict=True):
        rows = a + np.flatnonzero(posed[a:b])
        f = frames[rows].astype(np.float64)
        body = pts[rows, 1]
        vel = np.stack([np.gradient(body[:, i], f) for i in (0, 1)], -1)
        if rows.size >= 5:
            kern = np.ones(5) / 5
            vel = np.stack(
                [
                    np.convolve(np.pad(vel[:, i], 2, mode="edge"), kern, mode="valid")
                    for i in (0, 1)
                ],
                -1,
            )
        ax = pts[rows, 0] - pts[rows, 2]
        ax /= np.maximum(np.linalg.norm(ax, axis=1, keepdims=True), 1e-9)
        sp2 = (vel**2).sum(1)
        cert = sp2 / (sp2 + motion_px**2)
        e = c.motion_weight * cert * (ax * vel).sum(1) / np.sqrt(np.maximum(sp2, 1e-18))
        e = e + c.shape_weight * (2 * hc[rows] - 1)
        unary = np.stack([-e, e], 1)  # state 0 keeps, 1 swaps
        dots = (ax[1:] * ax[:-1]).sum(1)
        n = rows.size
        cost = unary[0].copy()
        back = np.zeros((n, 2), np.int64)
        sign = np.array([1.0, -1.0])
        for k in range(1, n):
            # trans[i, j]: from state i to state j
            trans = c.continuity_weight * (1 - np.outer(sign, sign) * dots[k - 1])
            tot = cost[:, None] + trans
            back[k] = tot.argmin(0)
            cost = tot.min(0) + unary[k]
        state = np.empty(n, np.int64)
        state[-1] = int(cost.argmin())
        for k in range(n - 1, 0, -1):
            state[k - 1] = back[k, state[k]]
        swap = rows[state == 1]
        pts[swap] = pts[swap][:, [2, 1, 0]]
    return pts
