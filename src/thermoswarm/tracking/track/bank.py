"""The live tracks of :class:`~thermoswarm.tracking.track.tracker.Tracker`, as arrays.

One row per live track, in the order the tracks were created (the order in which the
assignment sees them, which decides ties).  All numbers of a track sit in one row of
two packed blocks, a float block ``F`` and an integer block ``I``; every field is a view
into them (``x`` ``(n, 4)``, ``P`` ``(n, 4, 4)``, ...).  Removing dead tracks is one
gather per block, and the per-frame bookkeeping (prediction, the matched tracks'
states, misses and deaths, births) is one compiled pass over the rows each
(:func:`predict`, :func:`store_matched`, :func:`misses_and_deaths`, :func:`init_rows`)
instead of a Python loop over track objects or dozens of small array operations: at
10-30 objects the fixed cost of a frame is what the tracker's speed is made of
(docs/tracking.md, "Speed of the tracker").  The arithmetic of each kernel is that of
the array code it replaced, in the same order, so the numbers are the same.

Fields (px, frames; see :mod:`~thermoswarm.tracking.track.kalman` for ``x``, ``P``, ``q``,
``nis``):

``x`` ``(n, 4)``, ``P`` ``(n, 4, 4)``, ``q``, ``nis``
    Kalman state, covariance, process-noise intensity, running mean NIS.
``shape`` ``(n, 2, 2)``
    head - body and tail - body of the last pose (NaN if never posed).
``half`` ``(n, 2)``
    smoothed half box size (used when the shape is unknown: box-only detections).
``heading`` ``(n, 2)``
    unit head direction (NaN until a pose gave one).
``last_points`` ``(n, 3, 2)``, ``last_box`` ``(n, 4)``, ``last``
    pose, MOT box and frame of the last detection.
``hits``, ``misses``, ``out_id``, ``key``
    detections so far, frames missed since the last one, output identity (0 while
    tentative), and a serial number unique to the track (hint ownership).
``h_frame``, ``h_points``, ``h_box``, ``h_score``, ``h_hc``
    ``(n, H)``, ``(n, H, 3, 2)``, ...: the detections of a tentative track (slot ``i``
    is its ``i``-th hit; ``H = n_init``, the most a tentative track can have), written
    out when it is confirmed.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = [
    "TrackBank",
    "predict",
    "prepare_costs",
    "gather",
    "store_matched",
    "fill_rows",
    "misses_and_deaths",
    "init_rows",
]

# Columns of the float block: fixed fields, then H history slots of _HW columns.
_X, _P, _Q, _NIS, _SHAPE, _HALF, _HEAD, _LP, _LB, _HIST = 0, 4, 20, 21, 22, 26, 28, 30, 36, 40
_HW = 12  # per slot: points (6), box (4), score, head confidence
# Columns of the integer block: fixed fields, then H history frames.
_LAST, _HITS, _MISSES, _OUT, _KEY, _HFRAME = 0, 1, 2, 3, 4, 5

#: The process noise shape of one frame (kalman._Q1), entry by entry.
_Q1 = ((1 / 3, 0.0, 1 / 2, 0.0), (0.0, 1 / 3, 0.0, 1 / 2), (1 / 2, 0.0, 1.0, 0.0),
       (0.0, 1 / 2, 0.0, 1.0))  # fmt: skip


class TrackBank:
    """Packed arrays of the live tracks; fields are views of length :attr:`n`.

    Parameters
    ----------
    n_hist
        Detections kept per tentative track (the tracker's ``n_init``).
    capacity
        Initial number of rows (grows by doubling).
    """

    def __init__(self, n_hist: int, capacity: int = 64) -> None:
        self.n_hist = H = int(n_hist)
        self._wf = _HIST + _HW * H
        self._wi = _HFRAME + H
        self.n = 0
        cap = max(int(capacity), 1)
        self.F = np.zeros((cap, self._wf))
        self.I = np.zeros((cap, self._wi), np.int64)

    def _grow(self, cap: int) -> None:
        F = np.zeros((cap, self._wf))
        Ib = np.zeros((cap, self._wi), np.int64)
        F[: self.n] = self.F[: self.n]
        Ib[: self.n] = self.I[: self.n]
        self.F, self.I = F, Ib

    def append(self, m: int) -> int:
        """Add ``m`` rows at the end (zeros); returns the first new row."""
        n = self.n
        if n + m > self.F.shape[0]:
            self._grow(max(2 * self.F.shape[0], n + m))
        self.F[n : n + m] = 0.0
        self.I[n : n + m] = 0
        self.n = n + m
        return n

    def keep(self, mask: np.ndarray) -> None:
        """Keep the rows where ``mask`` is true (in order), drop the others."""
        n = self.n
        k = int(np.count_nonzero(mask))
        if k == n:
            return
        self.F[:k] = self.F[:n][mask]
        self.I[:k] = self.I[:n][mask]
        self.n = k

    # Views of the live rows (for the array code; the kernels use the blocks).
    def _f(self, a: int, b: int, *shape: int) -> np.ndarray:
        v = self.F[: self.n, a:b]
        return v.reshape(self.n, *shape) if shape else v[:, 0]

    @property
    def x(self) -> np.ndarray:
        return self._f(_X, _X + 4, 4)

    @property
    def P(self) -> np.ndarray:
        return self._f(_P, _P + 16, 4, 4)

    @property
    def q(self) -> np.ndarray:
        return self._f(_Q, _Q + 1)

    @property
    def nis(self) -> np.ndarray:
        return self._f(_NIS, _NIS + 1)

    @property
    def shape(self) -> np.ndarray:
        return self._f(_SHAPE, _SHAPE + 4, 2, 2)

    @property
    def half(self) -> np.ndarray:
        return self._f(_HALF, _HALF + 2, 2)

    @property
    def heading(self) -> np.ndarray:
        return self._f(_HEAD, _HEAD + 2, 2)

    @property
    def last_points(self) -> np.ndarray:
        return self._f(_LP, _LP + 6, 3, 2)

    @property
    def last_box(self) -> np.ndarray:
        return self._f(_LB, _LB + 4, 4)

    @property
    def last(self) -> np.ndarray:
        return self.I[: self.n, _LAST]

    @property
    def hits(self) -> np.ndarray:
        return self.I[: self.n, _HITS]

    @property
    def misses(self) -> np.ndarray:
        return self.I[: self.n, _MISSES]

    @property
    def out_id(self) -> np.ndarray:
        return self.I[: self.n, _OUT]

    @property
    def key(self) -> np.ndarray:
        return self.I[: self.n, _KEY]

    def history(self, row: int) -> list[tuple[int, np.ndarray, np.ndarray, float, float]]:
        """The detections of tentative track ``row``: ``[(frame, points (3, 2), box (4,),
        score, head confidence)]`` (copies), oldest first."""
        out = []
        for s in range(min(int(self.I[row, _HITS]), self.n_hist)):
            c = _HIST + _HW * s
            f = self.F[row]
            out.append(
                (
                    int(self.I[row, _HFRAME + s]),
                    f[c : c + 6].reshape(3, 2).copy(),
                    f[c + 6 : c + 10].copy(),
                    float(f[c + 10]),
                    float(f[c + 11]),
                )
            )
        return out

    def copy_state(self, dst: int, src: int) -> None:
        """Row ``dst`` takes over the filter, shape, half box and heading of ``src``."""
        self.F[dst, _X:_LP] = self.F[src, _X:_LP]


# ------------------------------------------------------------------------ kernels
@njit(cache=True)
def predict(F, I, n):
    """Advance every filter one frame (``x' = F x``, ``P' = F P F' + q Q1``, as
    :func:`~thermoswarm.tracking.track.kalman.predict`) and return the predicted
    poses ``(k, 3, 2)`` and keys of the tracks surely on an object (confirmed and
    detected in the previous frame)."""
    k = 0
    for r in range(n):
        F[r, _X] += F[r, _X + 2]
        F[r, _X + 1] += F[r, _X + 3]
        for j in range(4):  # F P: rows 0, 1 += rows 2, 3
            F[r, _P + j] += F[r, _P + 8 + j]
            F[r, _P + 4 + j] += F[r, _P + 12 + j]
        for i in range(4):  # (F P) F': columns 0, 1 += columns 2, 3
            F[r, _P + 4 * i] += F[r, _P + 4 * i + 2]
            F[r, _P + 4 * i + 1] += F[r, _P + 4 * i + 3]
        q = F[r, _Q]
        for i in range(4):
            for j in range(4):
                F[r, _P + 4 * i + j] += q * _Q1[i][j]
        if I[r, _OUT] > 0 and I[r, _MISSES] == 0:
            k += 1
    poses = np.empty((k, 3, 2))
    keys = np.empty(k, np.int64)
    s = 0
    for r in range(n):
        if I[r, _OUT] > 0 and I[r, _MISSES] == 0:
            for a in range(2):
                b = F[r, _X + a]
                poses[s, 0, a] = b + F[r, _SHAPE + a]
                poses[s, 1, a] = b
                poses[s, 2, a] = b + F[r, _SHAPE + 2 + a]
            keys[s] = I[r, _KEY]
            s += 1
    return poses, keys


@njit(cache=True)
def prepare_costs(F, I, n, frame, r2, pad, step_px, headroom, widening):
    """What :func:`~thermoswarm.tracking.track.association.pair_costs` needs of the tracks:
    innovation covariances ``S`` ``(n, 2, 2)`` (``P[:2, :2] + r2 I``), predicted body
    points ``(n, 2)``, predicted boxes ``(n, 4)``, predicted body axes (head - tail)
    ``(n, 2)``, the gate's reach in px (the track's cap per frame since the last
    detection plus ``2 pad``; the cap is ``headroom`` times the track's speed, within
    ``step_px`` and ``widening * step_px``: :func:`~thermoswarm.tracking.track.speed.cap_px`),
    and whether any axis is known.

    The predicted box is the body-centred box of the predicted pose (the last head and
    tail offsets moved to the predicted body point; as
    :func:`~thermoswarm.tracking.anatomy.pose_boxes`), or for a track without a known
    shape (box-only detections) its smoothed half box size around the body point.
    """
    S = np.empty((n, 2, 2))
    pred = np.empty((n, 2))
    boxes = np.empty((n, 4))
    axes = np.empty((n, 2))
    reach = np.empty(n)
    any_axis = False
    for r in range(n):
        S[r, 0, 0] = F[r, _P] + r2
        S[r, 0, 1] = F[r, _P + 1] + 0.0
        S[r, 1, 0] = F[r, _P + 4] + 0.0
        S[r, 1, 1] = F[r, _P + 5] + r2
        v = headroom * np.hypot(F[r, _X + 2], F[r, _X + 3])
        cap = min(max(v, step_px), widening * step_px) if v == v else step_px
        reach[r] = cap * float(frame - I[r, _LAST]) + 2 * pad
        known_pose = True
        for a in range(2):
            b = F[r, _X + a]
            pred[r, a] = b
            head = b + F[r, _SHAPE + a]
            tail = b + F[r, _SHAPE + 2 + a]
            axes[r, a] = head - tail
            if not (np.isfinite(head) and np.isfinite(tail)):
                known_pose = False
        if np.isfinite(axes[r, 0]) or np.isfinite(axes[r, 1]):
            any_axis = True
        for a in range(2):
            b = pred[r, a]
            if known_pose:
                eh = abs((b + F[r, _SHAPE + a]) - b)
                et = abs((b + F[r, _SHAPE + 2 + a]) - b)
                half = eh if eh >= et else et  # both finite: the farther end
                if not np.isfinite(half):
                    half = 0.0
                half = half + pad
            else:
                half = F[r, _HALF + a]
            boxes[r, a] = b - half
            boxes[r, 2 + a] = 2 * half
    return S, pred, boxes, axes, reach, any_axis


@njit(cache=True)
def gather(F, rows):
    """States ``x`` ``(m, 4)``, covariances ``P`` ``(m, 4, 4)``, ``q``, ``nis`` and
    headings ``(m, 2)`` of the tracks in ``rows`` (contiguous copies)."""
    m = rows.size
    x = np.empty((m, 4))
    P = np.empty((m, 4, 4))
    q = np.empty(m)
    nis = np.empty(m)
    heading = np.empty((m, 2))
    for i in range(m):
        r = rows[i]
        for a in range(4):
            x[i, a] = F[r, _X + a]
            for b in range(4):
                P[i, a, b] = F[r, _P + 4 * a + b]
        q[i] = F[r, _Q]
        nis[i] = F[r, _NIS]
        heading[i, 0] = F[r, _HEAD]
        heading[i, 1] = F[r, _HEAD + 1]
    return x, P, q, nis, heading


@njit(cache=True)
def fill_rows(F, I, rows, frame, p, box):
    """Rows interpolated linearly between the last detection of each track in
    ``rows`` and its detection ``p[i]``, ``box[i]`` at ``frame``: frames, output ids,
    points ``(k, 3, 2)`` and boxes ``(k, 4)`` (for a gap of ``g`` frames, the weight of
    the new detection is ``1/g, 2/g, ...``)."""
    k = 0
    for i in range(rows.size):
        k += frame - I[rows[i], _LAST] - 1
    frames = np.empty(k, np.int64)
    ids = np.empty(k, np.int64)
    ip = np.empty((k, 3, 2))
    ib = np.empty((k, 4))
    s = 0
    for i in range(rows.size):
        r = rows[i]
        last = I[r, _LAST]
        gap = frame - last
        for g in range(1, gap):
            a = g / gap
            frames[s] = last + g
            ids[s] = I[r, _OUT]
            for u in range(3):
                for v in range(2):
                    ip[s, u, v] = (1 - a) * F[r, _LP + 2 * u + v] + a * p[i, u, v]
            for u in range(4):
                ib[s, u] = (1 - a) * F[r, _LB + u] + a * box[i, u]
            s += 1
    return frames, ids, ip, ib


@njit(cache=True)
def store_matched(F, I, rows, x, P, q, nis, p, box, det_box, scores, hc, frame):
    """Write the matched tracks' new states (``x``, ``P``, ``q``, ``nis`` of row
    ``rows[i]``), their shape and heading (posed detections ``p``) or smoothed half
    box (from the detection's box ``det_box``), hits and misses, and their detection:
    the last one, and for tentative tracks also the next history slot."""
    for i in range(rows.size):
        r = rows[i]
        for a in range(4):
            F[r, _X + a] = x[i, a]
        for a in range(4):
            for b in range(4):
                F[r, _P + 4 * a + b] = P[i, a, b]
        F[r, _Q] = q[i]
        F[r, _NIS] = nis[i]
        hits = I[r, _HITS]
        if not _store_pose(F, r, p[i]):
            for a in range(2):
                bh = det_box[i, 2 + a] / 2
                if hits > 1:
                    F[r, _HALF + a] = 0.7 * F[r, _HALF + a] + 0.3 * bh
                else:
                    F[r, _HALF + a] = bh
        I[r, _HITS] = hits + 1
        I[r, _MISSES] = 0
        if I[r, _OUT] == 0 and hits < (F.shape[1] - _HIST) // _HW:
            _store_history(F, I, r, hits, frame, p[i], box[i], scores[i], hc[i])
        I[r, _LAST] = frame
        for a in range(3):
            for b in range(2):
                F[r, _LP + 2 * a + b] = p[i, a, b]
        for a in range(4):
            F[r, _LB + a] = box[i, a]


@njit(cache=True, inline="always")
def _store_pose(F, r, p):
    """For a posed detection ``p`` (3, 2) (head and tail finite): its shape (head and
    tail relative to the body point) and unit heading (tail to head) into row ``r``;
    returns whether it was posed (nothing is written otherwise)."""
    for a in range(2):
        for kp in (0, 2):
            if not np.isfinite(p[kp, a]):
                return False
    for a in range(2):
        F[r, _SHAPE + a] = p[0, a] - p[1, a]
        F[r, _SHAPE + 2 + a] = p[2, a] - p[1, a]
    a0 = p[0, 0] - p[2, 0]
    a1 = p[0, 1] - p[2, 1]
    na = np.hypot(a0, a1)
    if na > 1e-9:
        F[r, _HEAD] = a0 / na
        F[r, _HEAD + 1] = a1 / na
    return True


@njit(cache=True, inline="always")
def _store_history(F, I, r, slot, frame, p, box, score, hc):
    c = _HIST + _HW * slot
    I[r, _HFRAME + slot] = frame
    for a in range(3):
        for b in range(2):
            F[r, c + 2 * a + b] = p[a, b]
    for a in range(4):
        F[r, c + 6 + a] = box[a]
    F[r, c + 10] = score
    F[r, c + 11] = hc


@njit(cache=True)
def misses_and_deaths(F, I, n, matched, frame, tentative_max_misses, max_gap, has_size, w, h):
    """Count a miss for every unmatched track; return the rows to keep: an unmatched
    tentative track dies after more than ``tentative_max_misses`` misses, a confirmed
    one ``max_gap`` frames after its last detection, and (if ``has_size``) any
    unmatched track whose prediction lies outside the ``w`` x ``h`` frame."""
    keep = np.ones(n, np.bool_)
    for r in range(n):
        if matched[r]:
            continue
        I[r, _MISSES] += 1
        if I[r, _OUT] > 0:
            dead = frame - I[r, _LAST] > max_gap
        else:
            dead = I[r, _MISSES] > tentative_max_misses
        if has_size:
            x, y = F[r, _X], F[r, _X + 1]
            if x < 0 or y < 0 or x > w - 1 or y > h - 1:
                dead = True
        keep[r] = not dead
    return keep


@njit(cache=True)
def init_rows(F, I, start, p, box, scores, hc, frame, r2, v02, q0, first_key):
    """Start tentative tracks in rows ``start, start + 1, ...`` (zeroed) at the
    detections ``p`` ``(m, 3, 2)`` (already oriented) with boxes ``box``: state at the
    body point at rest (``kalman.initial_state``: variances ``r2`` and ``v02``), process
    noise ``q0``, running NIS 2, shape and heading from the pose if it has head and
    tail, half box from the box, one hit, the detection in history slot 0."""
    for i in range(p.shape[0]):
        r = start + i
        F[r, _X] = p[i, 1, 0]
        F[r, _X + 1] = p[i, 1, 1]
        F[r, _P] = r2
        F[r, _P + 5] = r2
        F[r, _P + 10] = v02
        F[r, _P + 15] = v02
        F[r, _Q] = q0
        F[r, _NIS] = 2.0
        for a in range(4):
            F[r, _SHAPE + a] = np.nan
        F[r, _HEAD] = np.nan
        F[r, _HEAD + 1] = np.nan
        F[r, _HALF] = box[i, 2] / 2
        F[r, _HALF + 1] = box[i, 3] / 2
        _store_pose(F, r, p[i])
        I[r, _LAST] = frame
        I[r, _HITS] = 1
        I[r, _KEY] = first_key + i
        for a in range(3):
            for b in range(2):
                F[r, _LP + 2 * a + b] = p[i, a, b]
        for a in range(4):
            F[r, _LB + a] = box[i, a]
        _store_history(F, I, r, 0, frame, p[i], box[i], scores[i], hc[i])
