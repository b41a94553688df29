"""Multi-ant tracker: adaptive Kalman prediction + Hungarian assignment (paper, Methods).

Each frame:

1. **Predict** every track's body point with its adaptive constant-velocity Kalman
   filter (:mod:`~thermoswarm.tracking.track.kalman`) and its body-centred box (the box of
   the predicted pose: last head/body/tail offsets moved to the predicted body point;
   :func:`~thermoswarm.tracking.anatomy.pose_boxes`).  The predicted poses are also
   given to detectors that accept them (``hints``), to split touching ants.
2. **Cost** of track ``i`` and detection ``j``:
   ``iou_weight (1 - IoU) + distance_weight d / L + mahalanobis_weight m / gate_sigmas
   + angle_weight |sin(da)|`` with ``d`` the distance of the body points, ``L`` the
   body length, ``m`` the Mahalanobis distance of the innovation (``d`` in units of
   the track's predicted uncertainty: a new track, whose velocity is unknown, reaches
   as far as an ant walks) and ``da`` the angle between the body axes (head-tail
   ambiguity ignored).  A pair is allowed only inside the gate: ``m`` below
   ``gate_sigmas``, ``d`` below what ``max_speed_bl_s`` (or 1.5 x the track's speed,
   :mod:`.speed`) allows since its last detection, a detector's boxes' IoU ``min_iou``.
3. **Assign** with :func:`scipy.optimize.linear_sum_assignment`, confirmed tracks
   first (including tracks that lost their ant within the last ``max_gap_s``), then
   tentative tracks with the detections left; pairs costing more than ``max_cost`` are
   not matched.
4. **Birth and death with hysteresis**: an unmatched detection (not within
   ``duplicate_radius`` body lengths, nor ``duplicate_body`` of the oriented body, of a
   matched or better-scored one) starts a tentative track, confirmed once detected
   over ``confirm_s`` (and dropped if it misses more than ``tentative_gap_s``); a
   confirmed track survives
   ``max_gap_s`` without detections (coasting on its prediction).  Every time is in
   seconds, converted with the frame rate (:func:`~thermoswarm.tracking.track.config.frames`).
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
   dropped so that no speed spans it; ``fix_jumps``), a detector's boxes much shorter
   or longer than their track's usual one are not written (partial or merged views;
   ``size_band``, :func:`~thermoswarm.tracking.track.result.size_outliers`), and each
   track's head-tail order is chosen over its whole life (Viterbi;
   :func:`~thermoswarm.tracking.track.result.orient_tracks`).
   None of these changes identities.

Online output is final with a fixed lag (``Tracker.lag`` frames): identities and rows
of frame ``k`` never change once frame ``k + lag`` has been processed, so overlays can
be drawn while the video streams; only step 7 then touches a few rows and the
head-tail order.

Code: the live tracks are rows of packed arrays
(:mod:`~thermoswarm.tracking.track.bank`), the costs and the assignment are in
:mod:`~thermoswarm.tracking.track.association`, the output and the end-of-video corrections in
:mod:`~thermoswarm.tracking.track.result`, the options in
:mod:`~thermoswarm.tracking.track.config` (named sets:
:mod:`~thermoswarm.tracking.track.presets`); this module holds the loop.

Scale: positions are px (full frame), and every length in the config is in body
lengths ``L`` (px per body length: given, derived from ``px_per_mm`` and the paper's
ant, or estimated from the first detections), every time in seconds (``fps``).  So
the same detections scaled by any factor give the same identities; the mm scale only
converts the exported trajectories (:meth:`TrackResult.dataset`).
"""

from __future__ import annotations

import math

import numpy as np

from thermoswarm.errors import InputError
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.detection import FrameDetections
from thermoswarm.tracking.track import association, kalman, speed
from thermoswarm.tracking.track import bank as track_bank
from thermoswarm.tracking.track.bank import TrackBank
from thermoswarm.tracking.track.config import TrackerConfig
from thermoswarm.tracking.track.result import (
    TrackResult,
    fix_jumps,
    orient_tracks,
    size_outliers,
)
from thermoswarm.tracking.track.smooth import smooth_boxes

__all__ = ["TrackerConfig", "Tracker", "TrackResult", "track_detections", "estimate_length_px"]

PendingRows = list[tuple[int, list[tuple[int, np.ndarray, np.ndarray]]]]


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
        self.max_gap = c.max_gap(fps)
        self.n_init = c.n_init(fps)
        self.tentative_max_misses = c.tentative_max_misses(fps)
        #: Frames after which a frame's output can no longer change.
        self.lag = max(self.max_gap, self.n_init + self.tentative_max_misses) + 1
        self.frame = -1
        self._bank = TrackBank(self.n_init)
        self._next_id = 1
        self._next_key = 1
        self._predicted = False
        # Output rows, in blocks of arrays (frames, ids, points, boxes, scores,
        # interpolated, head confidence); rows per frame for pop_final.
        self._blocks: list[tuple[np.ndarray, ...]] = []
        self._pending: dict[int, list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = {}
        self._popped = -1
        self._hinted = np.zeros(0, np.int64)  # keys of the tracks given as hints
        self._given_boxes = False  # a detector gave its own boxes (size_band applies)
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
            v0=c.birth_speed_bl_s * L / fps,
            gain=0.5 if c.adapt else 0.0,
        )
        # Measurement variance r^2, as kalman.innovation forms it.
        self._r2 = float(np.asarray(self.kp.r, dtype=np.float64) ** 2)

    # ------------------------------------------------------------------ prediction
    def predict(self) -> np.ndarray:
        """Advance to the next frame; predicted poses ``(n, 3, 2)`` px of the tracks
        that are surely on an ant (confirmed and detected in the previous frame;
        coasting and tentative tracks would make a detector split single ants)."""
        self.frame += 1
        b = self._bank
        poses, self._hinted = track_bank.predict(b.F, b.I, b.n)
        self._predicted = True
        return poses

    def cut(self) -> None:
        """A scene cut before the next frame: every track ends here, so that no
        identity carries over to another animal (tentative tracks are dropped)."""
        self._bank.keep(np.zeros(self._bank.n, bool))

    # --------------------------------------------------------------------- update
    def update(self, dets: FrameDetections) -> None:
        """Associate the detections of the next frame and update the tracks."""
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
        self._given_boxes |= n > 0 and dets.boxes is not None
        hc = dets.head_confidence if dets.head_confidence is not None else np.ones(n)
        boxes = dets.box_array(self.pad) if n else np.zeros((0, 4))
        b = self._bank
        avail = np.ones(n, bool)
        matched = np.zeros(b.n, bool)
        if b.n and n:
            rows, cols = self._associate(dets, pts, boxes, avail)
            if rows.size:
                self._update_matched(dets, pts, boxes, hc, rows, cols)
                matched[rows] = True
        # Misses and deaths (an ant predicted outside the frame has walked out of it).
        if b.n:
            w, h = self.frame_size if self.frame_size is not None else (0, 0)
            keep = track_bank.misses_and_deaths(
                b.F, b.I, b.n, matched, k, self.tentative_max_misses, self.max_gap,
                self.frame_size is not None, w, h,
            )  # fmt: skip
            b.keep(keep)
        # Births (not on top of a matched detection: split duplicates).
        if n and avail.any():
            self._births(dets, pts, boxes, hc, avail)
        # Confirmation, with re-linking to a lost track.
        ready = np.flatnonzero((b.out_id == 0) & (b.hits >= self.n_init))
        if ready.size:
            removed = np.zeros(b.n, bool)
            for t in ready.tolist():
                self._confirm(t, removed)
            b.keep(~removed)

    def _associate(
        self, dets: FrameDetections, pts: np.ndarray, boxes: np.ndarray, avail: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Matched track rows and detection columns (confirmed tracks first, then
        tentative ones with the detections left); ``avail`` is cleared where matched."""
        c, b = self.config, self._bank
        hint_other = None
        if dets.hint_index is not None and self._hinted.size:
            # Keys of the tracks whose predictions the detections came from (0: none).
            m = self._hinted.size
            owners = np.append(self._hinted, 0)
            hi = dets.hint_index
            hinted = owners[np.where((hi >= 0) & (hi < m), hi, m)]
            # A detection found from another track's prediction belongs to that track.
            hint_other = (hinted[None, :] != 0) & (hinted[None, :] != b.key[:, None])
        S, pred, tboxes, axes, reach, any_axis = track_bank.prepare_costs(
            b.F, b.I, b.n, self.frame, self._r2, self.pad, self.step_px,
            speed.SPEED_HEADROOM, speed.MAX_WIDENING,
        )  # fmt: skip
        cost = association.pair_costs(
            c,
            S=S,
            pred=pred,
            track_boxes=tboxes,
            axes=axes,
            reach=reach,
            any_axis=any_axis,
            pts=pts,
            boxes=boxes,
            length_px=self.length_px,
            hint_other=hint_other,
            given_boxes=dets.boxes is not None,
        )
        conf = b.out_id > 0
        if c.coast_last:
            # Tracks seen in the previous frame first, then coasting ones, then
            # tentative ones: a coasting track cannot take a detection that a track
            # on its object wants.
            seen = b.misses == 0
            groups = [conf & seen, conf & ~seen, ~conf]
        else:
            groups = [conf, ~conf]
        rows, cols = [], []
        for mask in groups:
            group = np.flatnonzero(mask)
            if not group.size or not avail.any():
                continue
            if group.size == b.n:
                r, j = association.assign(cost, c.max_cost)
            else:
                sub = np.where(avail, cost[group], association.BIG)
                r, j = association.assign(sub, c.max_cost)
            rows.append(group[r])
            cols.append(j)
            avail[j] = False
        if not rows:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        if len(rows) == 1:
            return rows[0], cols[0]
        return np.concatenate(rows), np.concatenate(cols)

    def _update_matched(
        self,
        dets: FrameDetections,
        pts: np.ndarray,
        boxes: np.ndarray,
        hc: np.ndarray,
        rows: np.ndarray,
        js: np.ndarray,
    ) -> None:
        """Kalman update, shape, orientation and output of the matched tracks."""
        c, b, k = self.config, self._bank, self.frame
        x0, P0, q, nm, heading = track_bank.gather(b.F, rows)
        # Less certain detections (split blobs) move the filter less.
        scores = dets.scores[js]
        sc = np.clip(scores, 0.1, 1.0)
        r = self.kp.r / sc**c.score_noise_power
        x, P, q, nm = kalman.update_adapt(x0, P0, pts[js, 1], r, q, nm, self.kp)
        p_all = pts[js]
        if np.isfinite(p_all[:, [0, 2]]).any():
            vsd = np.sqrt(0.5 * (P0[:, 2, 2] + P0[:, 3, 3]))
            p_all = association.orient_matched(
                c, p_all, hc[js], heading, x0[:, 2:4], vsd, self.motion_px
            )
        det_box = boxes[js]
        box_all = det_box if dets.boxes is not None else anatomy.pose_boxes(p_all, self.pad)
        hcs = hc[js]
        # Output: confirmed tracks write their row (after filling a gap they coasted
        # over); tentative ones keep the detection until they are confirmed.
        ids = b.out_id[rows]
        conf = ids > 0
        if c.interpolate:
            gap = k - b.last[rows]
            fill = conf & (gap > 1) & (gap <= self.max_gap + 1)
            if fill.any():
                self._fill(rows[fill], k, p_all[fill], box_all[fill])
        track_bank.store_matched(
            b.F, b.I, rows, x, P, q, nm, p_all, box_all, det_box, scores, hcs, k
        )
        if conf.all():
            self._emit(k, ids, p_all, box_all, scores, hcs)
        elif conf.any():
            self._emit(k, ids[conf], p_all[conf], box_all[conf], scores[conf], hcs[conf])

    def _births(
        self,
        dets: FrameDetections,
        pts: np.ndarray,
        boxes: np.ndarray,
        hc: np.ndarray,
        avail: np.ndarray,
    ) -> None:
        """New tentative tracks on the detections left, except those with no score or
        position and those on top of a matched detection (split duplicates)."""
        c, b = self.config, self._bank
        cand = np.flatnonzero(avail)
        ok = ~(dets.scores[cand] < c.min_score) & np.isfinite(pts[cand, 1]).all(axis=1)
        used = ~avail
        if used.any() and ok.any():
            ok &= ~np.any(self._duplicates(pts, boxes, cand, np.flatnonzero(used)), axis=1)
        new = self._distinct(cand[ok], dets.scores, pts, boxes)
        if not new.size:
            return
        p = association.orient_new(c, pts[new], hc[new])
        box = boxes[new] if dets.boxes is not None else anatomy.pose_boxes(p, self.pad)
        start = b.append(new.size)
        track_bank.init_rows(
            b.F, b.I, start, p, box, dets.scores[new], hc[new], self.frame,
            self.kp.r**2, self.kp.v0**2, self.kp.q0, self._next_key,
        )  # fmt: skip
        self._next_key += new.size

    def _duplicates(
        self, pts: np.ndarray, boxes: np.ndarray, a: np.ndarray, b: np.ndarray
    ) -> np.ndarray:
        """``(len(a), len(b))``: whether detection ``a[i]`` duplicates ``b[j]``: body
        points within ``duplicate_radius`` body lengths or ``duplicate_body`` of ``b[j]``'s
        oriented body (:func:`.association.within_body`), or boxes whose intersection
        covers ``duplicate_overlap`` of the smaller one (below 1: a fragment, a doubled box)."""
        c, L = self.config, self.length_px
        d = pts[b, 1][None] - pts[a, 1][:, None]
        dup = np.hypot(d[..., 0], d[..., 1]) < c.duplicate_radius * L
        if c.duplicate_body > 0:
            k = c.duplicate_body * L
            dup |= association.within_body(pts[a], pts[b], k, k * c.width_bl)
        if c.duplicate_overlap < 1:
            dup |= association.overlap_of_smaller(boxes[a], boxes[b]) >= c.duplicate_overlap
        return dup

    def _distinct(
        self, new: np.ndarray, scores: np.ndarray, pts: np.ndarray, boxes: np.ndarray
    ) -> np.ndarray:
        """Birth candidates ``new`` less those that duplicate a better-scored candidate
        (:meth:`_duplicates`: a split blob or doubled box starts one track, not two);
        kept in their original order."""
        if new.size < 2:
            return new
        order = new[np.argsort(-np.nan_to_num(scores[new], nan=-1.0), kind="stable")]
        dup = self._duplicates(pts, boxes, order, order)
        keep: list[int] = []
        for k in range(order.size):
            if not any(dup[k, i] for i in keep):
                keep.append(k)
        return np.sort(order[keep])

    def _confirm(self, t: int, removed: np.ndarray) -> None:
        """Give row ``t`` an identity: a lost track's if it continues one (the row is
        then marked in ``removed``), else a new one."""
        b = self._bank
        hist = b.history(t)
        first_frame, first_p = hist[0][0], hist[0][1]
        # The lost track (confirmed, last seen before this one began, within the gap)
        # nearest, relative to how far it could have gone.
        last = b.last
        lost = np.flatnonzero(
            (b.out_id > 0) & (last < first_frame) & (first_frame - last <= self.max_gap + 1)
        )
        best = None
        if lost.size:
            reach = speed.reach_px(b.x[lost, 2:], first_frame - last[lost], self.step_px, self.pad)
            dv = first_p[1] - b.last_points[lost, 1]
            s = np.hypot(dv[:, 0], dv[:, 1]) / reach
            s = np.where(np.isnan(s), np.inf, s)
            if self.config.relink_gate:
                # Beyond a one-frame gap, only where the lost track's motion leads.
                near = (first_frame - last[lost] <= 2) | self._in_coasting_gate(t, lost, hist[0])
                s = np.where(near, s, np.inf)
            i = int(np.argmin(s))
            if s[i] < 1.0:
                best = int(lost[i])
        if best is None:
            out = self._next_id
            self._next_id += 1
            b.out_id[t] = out
            f0, p0, b0, s0, h0 = hist[0]
            self._emit_one(f0, out, p0, b0, s0, h0)
            b.last[t], b.last_points[t], b.last_box[t] = f0, p0, b0
            for row in hist[1:]:
                self._touch(t, *row)
            return
        # Continue the lost identity: fill the gap, take over the new track's state.
        for row in hist:
            self._touch(best, *row)
        b.copy_state(best, t)
        b.hits[best] += b.hits[t]
        b.misses[best] = b.misses[t]
        removed[t] = True

    def _in_coasting_gate(self, t: int, lost: np.ndarray, first: tuple) -> np.ndarray:
        """Whether new track ``t`` lies within ``gate_sigmas`` (Mahalanobis) of where
        each lost track in ``lost`` has coasted to: now (its Kalman prediction for this
        frame, covariance grown over the gap), and at the new track's first detection
        ``first`` (frame, points; the prediction moved back along its velocity, the
        position covariance scaled by the square of the shorter time coasted)."""
        b, g2 = self._bank, self.config.gate_sigmas**2
        eye = self._r2 * np.eye(2)
        d = b.x[t, :2][None, :] - b.x[lost, :2]
        S = b.P[lost][:, :2, :2] + eye
        ok = np.einsum("ni,nij,nj->n", d, np.linalg.inv(S), d) <= g2
        coasted = np.maximum(self.frame - b.last[lost], 1).astype(float)
        back = (self.frame - first[0]) * b.x[lost, 2:4]
        d = first[1][1][None, :] - (b.x[lost, :2] - back)
        scale = ((first[0] - b.last[lost]) / coasted) ** 2
        S = b.P[lost][:, :2, :2] * scale[:, None, None] + eye
        return ok & (np.einsum("ni,nij,nj->n", d, np.linalg.inv(S), d) <= g2)

    # --------------------------------------------------------------------- output
    def _emit(
        self,
        frame: int,
        ids: np.ndarray,
        points: np.ndarray,
        boxes: np.ndarray,
        scores: np.ndarray,
        hc: np.ndarray,
    ) -> None:
        """Rows of detected objects at ``frame`` (arrays, one entry per track)."""
        m = ids.size
        self._blocks.append(
            (np.full(m, frame, np.int64), ids, points, boxes, scores, np.zeros(m, bool), hc)
        )
        self._pending.setdefault(frame, []).append((ids, points, boxes))

    def _emit_one(
        self, frame: int, out_id: int, p: np.ndarray, box: np.ndarray, score: float, hc: float
    ) -> None:
        self._emit(
            frame,
            np.array([out_id], np.int64),
            p[None],
            box[None],
            np.array([score]),
            np.array([hc]),
        )

    def _fill(self, rows: np.ndarray, frame: int, p: np.ndarray, box: np.ndarray) -> None:
        """Interpolated rows of the tracks in ``rows`` between their last detection and
        ``frame`` (detected at ``p``, ``box``)."""
        b = self._bank
        fr, ids, ip, ib = track_bank.fill_rows(b.F, b.I, rows, frame, p, box)
        k = fr.size
        self._blocks.append((fr, ids, ip, ib, np.zeros(k), np.ones(k, bool), np.full(k, 0.5)))
        for i, f in enumerate(fr.tolist()):
            self._pending.setdefault(f, []).append((ids[i : i + 1], ip[i : i + 1], ib[i : i + 1]))

    def _touch(
        self, row: int, frame: int, p: np.ndarray, box: np.ndarray, score: float, hc: float
    ) -> None:
        """Output a detection of confirmed track ``row`` at ``frame`` (filling the gap
        since its last one)."""
        b = self._bank
        gap = frame - int(b.last[row])
        if self.config.interpolate and 1 < gap <= self.max_gap + 1:
            self._fill(np.array([row]), frame, p[None], box[None])
        self._emit_one(frame, int(b.out_id[row]), p, box, score, hc)
        b.last[row], b.last_points[row], b.last_box[row] = frame, p, box

    @staticmethod
    def _rows(blocks: list[tuple[np.ndarray, np.ndarray, np.ndarray]]) -> list:
        return [
            (int(i), p, box)
            for ids, pts, boxes in blocks
            for i, p, box in zip(ids.tolist(), pts, boxes, strict=True)
        ]

    def pop_final(self) -> PendingRows:
        """Frames whose rows can no longer change: ``[(frame, [(id, points, box)])]``."""
        upto = self.frame - self.lag
        out = []
        for f in range(self._popped + 1, upto + 1):
            out.append((f, self._rows(self._pending.pop(f, []))))
        self._popped = max(self._popped, upto)
        return out

    def flush(self) -> PendingRows:
        """All remaining frames (at the end of the video)."""
        out = []
        for f in range(self._popped + 1, self.frame + 1):
            out.append((f, self._rows(self._pending.pop(f, []))))
        self._popped = self.frame
        return out

    def finish(self) -> TrackResult:
        """All confirmed tracks (tentative ones at the end are dropped)."""
        n_frames = self.frame + 1
        if not self._blocks:
            return TrackResult.empty(n_frames)
        frames, ids, pts, boxes, scores, interp, hc = (
            np.concatenate(col) for col in zip(*self._blocks, strict=True)
        )
        order = np.lexsort((frames, ids))
        rows = [col[order] for col in (frames, ids, pts, boxes, scores, interp, hc)]
        frames, ids, pts, boxes, scores, interp, hc = rows
        keep = np.ones(ids.size, bool)
        if self.config.fix_jumps:
            lim = speed.track_limits(frames, ids, pts[:, 1], self.step_px)
            keep &= ~fix_jumps(frames, ids, pts, boxes, scores, interp, lim)  # in place
        if self._given_boxes and self.config.size_band:
            keep &= ~size_outliers(ids, boxes, self.config.size_band)
        frames, ids, pts, boxes, scores, interp, hc = (col[keep] for col in rows)
        pts = orient_tracks(self.config, frames, ids, pts, hc, self.motion_px)
        if self.config.smooth and (self.config.smooth_given or not self._given_boxes):
            v0 = self.config.birth_speed_bl_s * self.length_px
            boxes = smooth_boxes(frames, ids, boxes, interp, fps=self.fps, speed_px_s=v0,
                                 own_weight=self.config.smooth_weight)  # fmt: skip
        order = np.lexsort((ids, frames))
        return TrackResult(
            frames[order],
            ids[order],
            pts[order],
            boxes[order],
            scores[order],
            interp[order],
            n_frames,
        )


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
