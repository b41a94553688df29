"""Multi-ant tracker: adaptive Kalman prediction + Hungarian assignment (paper, Methods).

Each frame:

1. **Predict** every track's body point with its adaptive constant-velocity Kalman
   filter (:mod:`~thermoswarm.tracking.kalman`) and its body-centred box (the box of
   the predicted pose: last head/body/tail offsets moved to the predicted body point;
   :func:`~thermoswarm.tracking.anatomy.pose_boxes`).  The predicted poses are also
   given to detectors that accept them (``hints``), to split touching ants.
2. **Cost** of track ``i`` and detection ``j``:
   ``iou_weight (1 - IoU) + distance_weight d / L + angle_weight |sin(da)|`` with ``d``
   the distance of the body points, ``L`` the body length and ``da`` the angle between
   the body axes (head-tail ambiguity ignored).  A pair is allowed only inside the
   gate: Mahalanobis distance of the innovation below ``gate_sigmas`` and ``d`` below
   what ``max_speed_bl_s`` allows since the track's last detection.
3. **Assign** with :func:`scipy.optimize.linear_sum_assignment`, confirmed tracks
   first (including tracks that lost their ant within the last ``max_gap_s``), then
   tentative tracks with the detections left; pairs costing more than ``max_cost`` are
   not matched.
4. **Birth and death with hysteresis**: an unmatched detection starts a tentative
   track, confirmed after ``n_init`` hits (and dropped if it misses more than
   ``tentative_max_misses`` frames before that); a confirmed track survives
   ``max_gap_s`` without detections (coasting on its prediction).
   A track whose ant walks out of the frame (its prediction leaves the image)
   ends at once rather than coasting.
5. **Re-linking across short gaps**: a coasting track that gets a detection again, or
   a newly confirmed track that starts where a lost track would be (within
   ``max_speed_bl_s`` of its last position), continues the old identity; the missing
   frames are filled by linear interpolation (``interpolate``) and flagged.
6. **Head and tail**: each matched detection is oriented by the sum of three kinds of
   evidence for its head-tail order: agreement with the track's previous heading
   (``continuity_weight``), with the direction of motion (``motion_weight``, scaled
   by how well the speed is known relative to ``head_motion_speed_bl_s``), and the
   detector's own confidence (``shape_weight``); a negative sum swaps head and tail.

7. **At the end** (:meth:`Tracker.finish`): motion no ant can make is removed (a
   single misplaced row is interpolated; after a jump that stays, the first row is
   dropped so that no speed spans it; ``fix_jumps``), and each track's head-tail
   order is chosen over its whole life (Viterbi; :meth:`Tracker._orient_tracks`).
   Neither changes identities.

Online output is final with a fixed lag (``Tracker.lag`` frames): identities and rows
of frame ``k`` never change once frame ``k + lag`` has been processed, so overlays can
be drawn while the video streams; only step 7 then touches a few rows and the
head-tail order.

Scale: positions are px (full frame), and every length in the config is in body
lengths ``L`` (px per body length: given, derived from ``px_per_mm`` and the paper's
ant, or estimated from the first detections), every time in seconds (``fps``).  So
the same detections scaled by any factor give the same identities; the mm scale only
converts the exported trajectories (:meth:`TrackResult.dataset`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import linear_sum_assignment

from thermoswarm.config import check
from thermoswarm.errors import InputError
from thermoswarm.tracking import anatomy, kalman
from thermoswarm.tracking.detection import FrameDetections

__all__ = ["TrackerConfig", "Tracker", "TrackResult", "track_detections", "estimate_length_px"]

_BIG = 1e6


@dataclass(frozen=True)
class TrackerConfig:
    """Tracker options, in units of the objects' own size and of time.

    Lengths are in body lengths ``L`` (the tracked objects' length in px, given to the
    :class:`Tracker` or estimated from the detections), times in seconds (converted
    with ``fps``); nothing depends on the mm scale of the image.  See the module
    docstring for the role of each weight and limit.  ``accel_bl_s2``: initial sd of
    the objects' acceleration (sets the Kalman process noise, which then adapts within
    ``[q/adapt_range, q*adapt_range]``); ``meas_noise_bl``: sd of detected body points,
    divided by ``score ** score_noise_power`` for a detection of score below 1;
    ``width_bl``: object width, half of which pads body-centred pose boxes.  The
    defaults are the paper's ant (7.14 x 2.5 mm, 100 mm/s at most) in these units.
    """

    n_init: int = 3
    tentative_max_misses: int = 1
    max_gap_s: float = 1.0
    max_speed_bl_s: float = 14.0
    accel_bl_s2: float = 28.0
    adapt: bool = True
    adapt_range: float = 5.0
    meas_noise_bl: float = 0.04605  # 1 px at the paper's 3.04 px/mm
    score_noise_power: float = 4.0
    gate_sigmas: float = 5.0
    iou_weight: float = 1.0
    distance_weight: float = 1.0
    angle_weight: float = 0.3
    hint_weight: float = 1.0
    max_cost: float = 2.0
    min_score: float = 0.0
    duplicate_radius: float = 0.3
    interpolate: bool = True
    fix_jumps: bool = True
    head_motion_speed_bl_s: float = 0.42
    continuity_weight: float = 1.0
    motion_weight: float = 1.5
    shape_weight: float = 1.0
    width_bl: float = anatomy.ANT_WIDTH_MM / anatomy.ANT_LENGTH_MM

    def __post_init__(self) -> None:
        check(self.n_init >= 1, "n_init", "a positive integer", self.n_init)
        check(
            self.tentative_max_misses >= 0,
            "tentative_max_misses",
            "a non-negative integer",
            self.tentative_max_misses,
        )
        for name in ("max_gap_s", "duplicate_radius"):
            v = getattr(self, name)
            check(math.isfinite(v) and v >= 0, name, "a non-negative number", v)
        for name in (
            "max_speed_bl_s",
            "accel_bl_s2",
            "meas_noise_bl",
            "gate_sigmas",
            "max_cost",
            "head_motion_speed_bl_s",
            "width_bl",
        ):
            v = getattr(self, name)
            check(math.isfinite(v) and v > 0, name, "a positive number", v)
        check(self.adapt_range >= 1, "adapt_range", "at least 1", self.adapt_range)
        for name in (
            "iou_weight",
            "distance_weight",
            "angle_weight",
            "hint_weight",
            "continuity_weight",
            "motion_weight",
            "shape_weight",
        ):
            v = getattr(self, name)
            check(math.isfinite(v) and v >= 0, name, "a non-negative number", v)
        check(0 <= self.min_score <= 1, "min_score", "in [0, 1]", self.min_score)


def estimate_length_px(dets: FrameDetections) -> float | None:
    """Typical object length (px) of one frame's detections, or None if it has none.

    From poses (head and tail known) the median head-tail span divided by its share of
    the body (:data:`~thermoswarm.tracking.anatomy.KEYPOINT_OFFSETS`); otherwise the
    median of the boxes' longer sides (a box-only detector's object size).
    """
    if len(dets) == 0:
        return None
    p = dets.points
    span = np.linalg.norm(p[:, 0] - p[:, 2], axis=-1)
    span = span[np.isfinite(span) & (span > 0)]
    if span.size:
        k = float(anatomy.KEYPOINT_OFFSETS[0] - anatomy.KEYPOINT_OFFSETS[2])
        return float(np.median(span)) / k
    if dets.boxes is not None:
        side = np.max(dets.boxes[:, 2:4], axis=1)
        side = side[np.isfinite(side) & (side > 0)]
        if side.size:
            return float(np.median(side))
    return None


@dataclass(eq=False)
class _Track:
    x: np.ndarray
    P: np.ndarray
    q: float
    nis: float
    shape: np.ndarray  # (2, 2): head - body, tail - body (px); NaN if unknown
    half: np.ndarray  # (2,) half box size used when the shape is unknown
    heading: np.ndarray | None
    first: int
    last: int  # frame of the last detection
    last_points: np.ndarray
    last_box: np.ndarray
    hits: int = 1
    misses: int = 0
    out_id: int = 0
    history: list[tuple[int, np.ndarray, np.ndarray, float, float]] = field(default_factory=list)

    @property
    def confirmed(self) -> bool:
        return self.out_id > 0


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


def _flip(points: np.ndarray) -> np.ndarray:
    return points[[2, 1, 0]]


class Tracker:
    """Online tracker; call :meth:`update` once per frame, then :meth:`finish`.

    Parameters
    ----------
    config
        :class:`TrackerConfig`.
    fps
        Frame rate (converts the config's times).
    length_px
        The objects' body length in px, the unit of every gate and noise level.
        Default: ``ant_length * px_per_mm`` when ``px_per_mm`` is given, else estimated
        from the first frame that has detections (:func:`estimate_length_px`).
    px_per_mm
        Image scale; only used for the default ``length_px`` (the paper's ant).
    frame_size
        ``(width, height)`` px, if known: a track that misses its object while its
        prediction is outside the frame ends at once (it walked out).
    """

    def __init__(
        self,
        config: TrackerConfig | None = None,
        *,
        fps: float,
        length_px: float | None = None,
        px_per_mm: float | None = None,
        frame_size: tuple[int, int] | None = None,
    ) -> None:
        if px_per_mm is not None and not (px_per_mm > 0 and math.isfinite(px_per_mm)):
            raise InputError(f"px_per_mm must be a positive number, got {px_per_mm!r}")
        if length_px is not None and not (length_px > 0 and math.isfinite(length_px)):
            raise InputError(f"length_px must be a positive number, got {length_px!r}")
        if not (fps > 0 and math.isfinite(fps)):
            raise InputError(f"fps must be a positive number, got {fps!r}")
        self.config = c = config or TrackerConfig()
        self.frame_size = frame_size
        self.fps = float(fps)
        self.max_gap = int(round(c.max_gap_s * fps))
        #: Frames after which a frame's output can no longer change.
        self.lag = max(self.max_gap, c.n_init + c.tentative_max_misses) + 1
        self.frame = -1
        self._tracks: list[_Track] = []
        self._next_id = 1
        self._predicted = False
        self._chunks: list[tuple[Any, ...]] = []
        self._pending: dict[int, list[tuple[int, np.ndarray, np.ndarray]]] = {}
        self._popped = -1
        self._hinted: list[_Track] = []
        self.length_px: float | None = None
        if length_px is None and px_per_mm is not None:
            length_px = anatomy.ANT_LENGTH_MM * px_per_mm
        if length_px is not None:
            self._set_length(float(length_px))

    def _set_length(self, length_px: float) -> None:
        """Convert the config's body lengths and seconds to px and frames."""
        c, fps = self.config, self.fps
        L = self.length_px = length_px
        self.pad = 0.5 * c.width_bl * L
        self.step_px = c.max_speed_bl_s * L / fps
        self.motion_px = c.head_motion_speed_bl_s * L / fps
        q = (c.accel_bl_s2 * L / fps**2) ** 2
        rng_ = c.adapt_range if c.adapt else 1.0
        self.kp = kalman.KalmanParams(
            r=c.meas_noise_bl * L,
            q0=q,
            q_min=q / rng_,
            q_max=q * rng_,
            v0=self.step_px / 3,
            gain=0.5 if c.adapt else 0.0,
        )

    # ------------------------------------------------------------------ prediction
    def predict(self) -> np.ndarray:
        """Advance to the next frame; predicted poses ``(n, 3, 2)`` px of live tracks."""
        self.frame += 1
        if self._tracks:
            x = np.stack([t.x for t in self._tracks])
            P = np.stack([t.P for t in self._tracks])
            q = np.array([t.q for t in self._tracks])
            x, P = kalman.predict(x, P, q)
            for t, xi, Pi in zip(self._tracks, x, P, strict=True):
                t.x, t.P = xi, Pi
        self._predicted = True
        # Hints for the detector: tracks that are surely on an ant (confirmed and
        # detected in the previous frame); coasting and tentative tracks would make it
        # split single ants.
        sure = [t for t in self._tracks if t.confirmed and t.misses == 0]
        self._hinted = sure
        return self._predicted_poses_of(sure)

    # --------------------------------------------------------------------- update
    def _cost(
        self,
        tracks: list[_Track],
        pts: np.ndarray,
        boxes: np.ndarray,
        avail: np.ndarray,
        hinted: np.ndarray | None = None,
    ) -> np.ndarray:
        c = self.config
        n, m = len(tracks), pts.shape[0]
        cost = np.full((n, m), _BIG)
        if n == 0 or not avail.any():
            return cost
        X = np.array([t.x for t in tracks])
        pred = X[:, :2]
        _, S = kalman.innovation(X, np.array([t.P for t in tracks]), self.kp.r)
        Sinv = np.linalg.inv(S)
        d = pts[None, :, 1, :] - pred[:, None, :]  # (n, m, 2)
        maha = np.einsum("nmi,nij,nmj->nm", d, Sinv, d)
        dist = np.hypot(d[..., 0], d[..., 1])
        gap = np.array([self.frame - t.last for t in tracks], float)
        reach = self.step_px * gap + 2 * self.pad
        ok = (maha <= c.gate_sigmas**2) & (dist <= reach[:, None]) & avail[None, :]
        pposes = self._predicted_poses_of(tracks, pred)
        pboxes = self._boxes_of(pposes, tracks)
        iou = anatomy.box_iou(pboxes, boxes)
        total = c.iou_weight * (1 - iou) + c.distance_weight * dist / self.length_px
        ta = pposes[:, 0] - pposes[:, 2]
        da = pts[:, 0] - pts[:, 2]
        if c.angle_weight > 0 and np.isfinite(ta).any() and np.isfinite(da).any():
            cross = ta[:, None, 0] * da[None, :, 1] - ta[:, None, 1] * da[None, :, 0]
            norm = np.hypot(ta[:, 0], ta[:, 1])[:, None] * np.hypot(da[:, 0], da[:, 1])[None, :]
            with np.errstate(invalid="ignore", divide="ignore"):
                sin = np.abs(cross) / norm
            total = total + c.angle_weight * np.where(np.isfinite(sin), sin, 0.0)
        if hinted is not None:
            # A detection found from another track's prediction belongs to that track.
            owner = np.array([id(t) for t in tracks])
            other = (hinted[None, :] != 0) & (hinted[None, :] != owner[:, None])
            total = total + c.hint_weight * other
        cost[ok] = total[ok]
        return cost

    def _predicted_poses_of(
        self, tracks: list[_Track], body: np.ndarray | None = None
    ) -> np.ndarray:
        if not tracks:
            return np.empty((0, 3, 2))
        if body is None:
            body = np.array([t.x[:2] for t in tracks])
        shape = np.array([t.shape for t in tracks])  # (n, 2, 2)
        return np.stack([body + shape[:, 0], body, body + shape[:, 1]], axis=1)

    def _boxes_of(self, poses: np.ndarray, tracks: list[_Track]) -> np.ndarray:
        unknown = ~np.isfinite(poses[:, [0, 2]]).all(axis=(1, 2))
        if unknown.all():
            half = np.array([t.half for t in tracks]).reshape(-1, 2)
            return np.concatenate([poses[:, 1] - half, 2 * half], axis=1)
        boxes = anatomy.pose_boxes(poses, self.pad)
        if unknown.any():
            idx = np.flatnonzero(unknown)
            half = np.array([tracks[i].half for i in idx])
            boxes[idx, :2] = poses[idx, 1] - half
            boxes[idx, 2:] = 2 * half
        return boxes

    def _assign(
        self,
        tracks: list[_Track],
        pts: np.ndarray,
        boxes: np.ndarray,
        avail: np.ndarray,
        hinted: np.ndarray | None = None,
    ) -> list[tuple[int, int]]:
        if not tracks or not avail.any():
            return []
        cost = self._cost(tracks, pts, boxes, avail, hinted)
        r, cidx = linear_sum_assignment(cost)
        keep = cost[r, cidx] <= self.config.max_cost
        return list(zip(r[keep].tolist(), cidx[keep].tolist(), strict=True))

    def _orient_many(
        self,
        p: np.ndarray,
        hc: np.ndarray,
        heading: np.ndarray,
        vel: np.ndarray,
        vel_sd: np.ndarray,
    ) -> np.ndarray:
        """:meth:`_orient` for many detections at once (NaN heading: none yet)."""
        c = self.config
        p = p.copy()
        a = p[:, 0] - p[:, 2]
        na = np.linalg.norm(a, axis=1)
        ok = np.isfinite(na) & (na > 1e-9)
        a = a / np.where(ok, na, 1.0)[:, None]
        score = c.shape_weight * (2 * hc - 1)
        cont = (a * heading).sum(1)
        score = score + c.continuity_weight * np.where(np.isfinite(cont), cont, 0.0)
        sp = np.linalg.norm(vel, axis=1)
        moving = sp > 1e-9
        spv = np.where(moving, sp, 1.0)
        certainty = spv / (spv + 2 * vel_sd) * np.minimum(1.0, spv / self.motion_px)
        mot = (a * vel).sum(1) / spv * certainty
        score = score + c.motion_weight * np.where(moving, mot, 0.0)
        flip = ok & (score < 0)
        p[flip] = p[flip][:, [2, 1, 0]]
        return p

    def _orient(
        self, t: _Track | None, p: np.ndarray, hc: float, vel: np.ndarray | None, vel_sd: float
    ) -> np.ndarray:
        c = self.config
        if not (np.all(np.isfinite(p[0])) and np.all(np.isfinite(p[2]))):
            return p
        a = p[0] - p[2]
        na = float(np.hypot(*a))
        if na < 1e-9:
            return p
        a = a / na
        score = c.shape_weight * (2 * hc - 1)
        if t is not None and t.heading is not None:
            score += c.continuity_weight * float(a @ t.heading)
        if vel is not None:
            sp = float(np.hypot(*vel))
            if sp > 1e-9:
                certainty = sp / (sp + 2 * vel_sd) * min(1.0, sp / self.motion_px)
                score += c.motion_weight * float(a @ vel) / sp * certainty
        return _flip(p) if score < 0 else p

    def _emit(
        self,
        frame: int,
        out_id: int,
        points: np.ndarray,
        box: np.ndarray,
        score: float,
        interp: bool,
        hc: float = 0.5,
    ) -> None:
        self._chunks.append((frame, out_id, points, box, score, interp, hc))
        self._pending.setdefault(frame, []).append((out_id, points, box))

    def _touch(
        self, t: _Track, frame: int, p: np.ndarray, box: np.ndarray, score: float, hc: float = 0.5
    ) -> None:
        """Record detection of ``t`` at ``frame`` (filling the gap since its last one)."""
        c = self.config
        gap = frame - t.last
        if t.confirmed and c.interpolate and 1 < gap <= self.max_gap + 1:
            for g in range(1, gap):
                a = g / gap
                ip = (1 - a) * t.last_points + a * p
                ib = (1 - a) * t.last_box + a * box
                self._emit(t.last + g, t.out_id, ip, ib, 0.0, True)
        if t.confirmed:
            self._emit(frame, t.out_id, p, box, score, False, hc)
        else:
            t.history.append((frame, p, box, score, hc))
        t.last, t.last_points, t.last_box = frame, p, box

    def update(self, dets: FrameDetections) -> None:
        """Associate the detections of the next frame and update the tracks."""
        c = self.config
        if not self._predicted:
            self.predict()
        self._predicted = False
        k = self.frame
        n = len(dets)
        if self.length_px is None:
            est = estimate_length_px(dets)
            if est is None:
                return  # nothing to track yet, and no size to measure it by
            self._set_length(est)
        pts = dets.points
        hc = dets.head_confidence if dets.head_confidence is not None else np.ones(n)
        boxes = dets.box_array(self.pad) if n else np.zeros((0, 4))
        avail = np.ones(n, bool)
        hinted = None
        if dets.hint_index is not None and self._hinted:
            # Python ids of the tracks whose predictions the detections came from.
            owners = np.array([id(t) for t in self._hinted] + [0])
            hi = np.where(
                (dets.hint_index >= 0) & (dets.hint_index < len(self._hinted)),
                dets.hint_index,
                len(self._hinted),
            )
            hinted = owners[hi]
        confirmed = [t for t in self._tracks if t.confirmed]
        tentative = [t for t in self._tracks if not t.confirmed]
        matches: list[tuple[_Track, int]] = []
        for group in (confirmed, tentative):
            for i, j in self._assign(group, pts, boxes, avail, hinted):
                matches.append((group[i], j))
                avail[j] = False
        # Kalman update of the matched tracks, batched.
        if matches:
            ts = [t for t, _ in matches]
            js = np.array([j for _, j in matches])
            x = np.stack([t.x for t in ts])
            P = np.stack([t.P for t in ts])
            vel_before = x[:, 2:4].copy()
            vsd = np.sqrt(0.5 * (P[:, 2, 2] + P[:, 3, 3]))
            # Less certain detections (split blobs) move the filter less.
            sc = np.clip(dets.scores[js], 0.1, 1.0)
            x, P, nis = kalman.update(x, P, pts[js, 1], self.kp.r / sc**c.score_noise_power)
            q = np.array([t.q for t in ts])
            nm = np.array([t.nis for t in ts])
            q, nm = kalman.adapt(q, nm, nis, self.kp)
            heading = np.array(
                [t.heading if t.heading is not None else (np.nan, np.nan) for t in ts]
            )
            if np.isfinite(pts[js][:, [0, 2]]).any():
                p_all = self._orient_many(pts[js], hc[js], heading, vel_before, vsd)
            else:  # boxes only: no head and tail to orient
                p_all = pts[js].copy()
            box_all = boxes[js] if dets.boxes is not None else anatomy.pose_boxes(p_all, self.pad)
            posed = np.isfinite(p_all[:, [0, 2]]).all(axis=(1, 2))
            # Box-only tracks: half box size smoothed over the detections (vectorised).
            halves = np.array([t.half for t in ts])
            hits = np.array([t.hits for t in ts])
            bh = boxes[js, 2:4] / 2
            new_half = np.where((hits > 1)[:, None], 0.7 * halves + 0.3 * bh, bh)
            for i, (t, j) in enumerate(zip(ts, js, strict=True)):
                t.x, t.P, t.q, t.nis = x[i], P[i], float(q[i]), float(nm[i])
                if posed[i]:
                    self._set_shape(t, p_all[i], boxes[j], True)
                else:
                    t.half = new_half[i]
                t.hits += 1
                t.misses = 0
                self._touch(t, k, p_all[i], box_all[i], float(dets.scores[j]), float(hc[j]))
        matched = {id(t) for t, _ in matches}
        # Misses and deaths (an ant predicted outside the frame has walked out of it).
        alive = []
        for t in self._tracks:
            if id(t) not in matched:
                t.misses += 1
                if not t.confirmed and t.misses > c.tentative_max_misses:
                    continue
                if t.confirmed and k - t.last > self.max_gap:
                    continue
                if self._outside(t.x[:2]):
                    continue
            alive.append(t)
        self._tracks = alive
        # Births (not on top of a matched detection: split duplicates).
        used = ~avail
        for j in np.flatnonzero(avail):
            if dets.scores[j] < c.min_score or not (
                math.isfinite(pts[j, 1, 0]) and math.isfinite(pts[j, 1, 1])
            ):
                continue
            if used.any():
                dd = np.linalg.norm(pts[used, 1] - pts[j, 1], axis=-1)
                if np.any(dd < c.duplicate_radius * self.length_px):
                    continue
            x0, P0 = kalman.initial_state(pts[j, 1], self.kp)
            p = self._orient(None, pts[j].copy(), float(hc[j]), None, 0.0)
            box = boxes[j] if dets.boxes is not None else anatomy.pose_boxes(p, self.pad)[0]
            t = _Track(
                x=x0[0],
                P=P0[0],
                q=self.kp.q0,
                nis=2.0,
                shape=np.full((2, 2), np.nan),
                half=box[2:4] / 2,
                heading=None,
                first=k,
                last=k,
                last_points=p,
                last_box=box,
            )
            self._set_shape(t, p, box)
            t.history.append((k, p, box, float(dets.scores[j]), float(hc[j])))
            self._tracks.append(t)
        # Confirmation, with re-linking to a lost track.
        for t in list(self._tracks):
            if not t.confirmed and t.hits >= c.n_init:
                self._confirm(t)

    def _outside(self, xy: np.ndarray) -> bool:
        if self.frame_size is None:
            return False
        w, h = self.frame_size
        return bool(xy[0] < 0 or xy[1] < 0 or xy[0] > w - 1 or xy[1] > h - 1)

    def _set_shape(
        self, t: _Track, p: np.ndarray, box: np.ndarray, posed: bool | None = None
    ) -> None:
        if posed is None:
            posed = bool(np.isfinite(p[[0, 2]]).all())
        if posed:
            t.shape = np.stack([p[0] - p[1], p[2] - p[1]])
            a = p[0] - p[2]
            na = float(np.hypot(*a))
            if na > 1e-9:
                t.heading = a / na
        else:
            t.half = 0.7 * t.half + 0.3 * box[2:4] / 2 if t.hits > 1 else box[2:4] / 2

    def _confirm(self, t: _Track) -> None:
        """Give ``t`` an identity: a lost track's if it continues one, else a new one."""
        first_frame, first_p = t.history[0][0], t.history[0][1]
        best, best_score = None, 1.0
        for lost in self._tracks:
            if not lost.confirmed or lost is t or lost.last >= first_frame:
                continue
            gap = first_frame - lost.last
            if gap > self.max_gap + 1:
                continue
            reach = self.step_px * gap + 2 * self.pad
            d = float(np.hypot(*(first_p[1] - lost.last_points[1])))
            if d / reach < best_score:
                best, best_score = lost, d / reach
        if best is None:
            t.out_id = self._next_id
            self._next_id += 1
            hist, t.history = t.history, []
            f0, p0, b0, s0, h0 = hist[0]
            self._emit(f0, t.out_id, p0, b0, s0, False, h0)
            t.last, t.last_points, t.last_box = f0, p0, b0
            for frame, p, box, score, hcf in hist[1:]:
                self._touch(t, frame, p, box, score, hcf)
            return
        # Continue the lost identity: fill the gap, take over the new track's state.
        hist, t.history = t.history, []
        for frame, p, box, score, hcf in hist:
            self._touch(best, frame, p, box, score, hcf)
        best.x, best.P, best.q, best.nis = t.x, t.P, t.q, t.nis
        best.shape, best.half, best.heading = t.shape, t.half, t.heading
        best.hits += t.hits
        best.misses = t.misses
        self._tracks.remove(t)

    # --------------------------------------------------------------------- output
    def pop_final(self) -> list[tuple[int, list[tuple[int, np.ndarray, np.ndarray]]]]:
        """Frames whose rows can no longer change: ``[(frame, [(id, points, box)])]``."""
        upto = self.frame - self.lag
        out = []
        for f in range(self._popped + 1, upto + 1):
            out.append((f, self._pending.pop(f, [])))
        self._popped = max(self._popped, upto)
        return out

    def flush(self) -> list[tuple[int, list[tuple[int, np.ndarray, np.ndarray]]]]:
        """All remaining frames (at the end of the video)."""
        out = []
        for f in range(self._popped + 1, self.frame + 1):
            out.append((f, self._pending.pop(f, [])))
        self._popped = self.frame
        return out

    def finish(self) -> TrackResult:
        """All confirmed tracks (tentative ones at the end are dropped)."""
        n_frames = self.frame + 1
        if not self._chunks:
            return TrackResult(
                np.zeros(0, np.int64),
                np.zeros(0, np.int64),
                np.zeros((0, 3, 2)),
                np.zeros((0, 4)),
                np.zeros(0),
                np.zeros(0, bool),
                n_frames,
            )
        frames = np.array([r[0] for r in self._chunks], np.int64)
        ids = np.array([r[1] for r in self._chunks], np.int64)
        pts = np.stack([r[2] for r in self._chunks])
        boxes = np.stack([r[3] for r in self._chunks])
        scores = np.array([r[4] for r in self._chunks])
        interp = np.array([r[5] for r in self._chunks], bool)
        hc = np.array([r[6] for r in self._chunks])
        order = np.lexsort((frames, ids))
        frames, ids, pts, boxes = frames[order], ids[order], pts[order], boxes[order]
        scores, interp, hc = scores[order], interp[order], hc[order]
        if self.config.fix_jumps:
            keep = ~self._fix_jumps(frames, ids, pts, boxes, scores, interp)
            frames, ids, pts, boxes = frames[keep], ids[keep], pts[keep], boxes[keep]
            scores, interp, hc = scores[keep], interp[keep], hc[keep]
        pts = self._orient_tracks(frames, ids, pts, hc)
        res = TrackResult(frames, ids, pts, boxes, scores, interp, n_frames)
        order = np.lexsort((res.ids, res.frames))
        return TrackResult(
            res.frames[order],
            res.ids[order],
            res.points[order],
            res.boxes[order],
            res.scores[order],
            res.interpolated[order],
            n_frames,
        )

    def _fix_jumps(
        self,
        frames: np.ndarray,
        ids: np.ndarray,
        pts: np.ndarray,
        boxes: np.ndarray,
        scores: np.ndarray,
        interp: np.ndarray,
    ) -> np.ndarray:
        # Rows sorted by track, then frame.
        """Remove what no ant can do: moving faster than ``max_speed_bl_s``.

        Rows are sorted by track then frame; ``pts``, ``boxes``, ``scores`` and
        ``interp`` are changed in place.  A single row that jumps away and back (a
        misplaced detection) is replaced by the interpolation of its neighbours and
        flagged as interpolated (score 0); after a jump that stays (the track took
        over another ant, or the detections moved to another part of a merged blob) the
        first row is dropped, so that no speed is measured across the jump.  Returns the
        rows to drop.
        """
        drop = np.zeros(ids.size, bool)
        starts = np.flatnonzero(np.r_[True, ids[1:] != ids[:-1]])
        ends = np.r_[starts[1:], ids.size]
        limit = self.step_px
        for a, b in zip(starts, ends, strict=True):
            if b - a < 2:
                continue
            f = frames[a:b].astype(np.float64)
            body = pts[a:b, 1]
            step = np.linalg.norm(np.diff(body, axis=0), axis=1) / np.diff(f)
            fast = step > limit
            if not fast.any():
                continue
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

    def _orient_tracks(
        self, frames: np.ndarray, ids: np.ndarray, pts: np.ndarray, hc: np.ndarray
    ) -> np.ndarray:
        """Head-tail order of every track, chosen jointly over its whole life.

        Rows are sorted by track then frame.  Two states per row (as detected, or head
        and tail swapped); the evidence for a state is the agreement of its head
        direction with the direction of motion (central differences of the body
        point, weighted by ``v^2 / (v^2 + v_min^2)`` with ``v_min`` the
        ``head_motion_speed_bl_s``) times ``motion_weight``, plus ``shape_weight``
        times the detector's ``2 head_confidence - 1``; turning the head by an angle
        ``a`` between consecutive rows costs ``continuity_weight (1 - cos a)``.  The
        best sequence of states (Viterbi) is kept.  Boxes do not change (the
        body-centred box is the same either way).
        """
        c = self.config
        pts = pts.copy()
        starts = np.flatnonzero(np.r_[True, ids[1:] != ids[:-1]])
        ends = np.r_[starts[1:], ids.size]
        for a, b in zip(starts, ends, strict=True):
            rows = np.arange(a, b)
            ok = np.all(np.isfinite(pts[rows][:, [0, 2]]), axis=(1, 2))
            rows = rows[ok]
            if rows.size < 2:
                continue
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
            cert = sp2 / (sp2 + self.motion_px**2)
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


def track_detections(
    detections: list[FrameDetections],
    *,
    fps: float,
    length_px: float | None = None,
    px_per_mm: float | None = None,
    config: TrackerConfig | None = None,
    frame_size: tuple[int, int] | None = None,
) -> TrackResult:
    """Track a list of per-frame detections (frame ``k`` is ``detections[k]``); see
    :class:`Tracker` for the parameters."""
    tr = Tracker(config, fps=fps, length_px=length_px, px_per_mm=px_per_mm, frame_size=frame_size)
    for d in detections:
        tr.predict()
        tr.update(d)
    return tr.finish()
