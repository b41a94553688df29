"""Fixed-interval smoothing of the finished tracks' boxes.

A detector's box jitters about the animal from frame to frame; once a track is
complete, every box can be estimated from the detections before *and* after it.
:func:`smooth_boxes` runs a Rauch-Tung-Striebel smoother (a forward Kalman filter,
then a backward pass) with a constant-velocity model on each track's box centres,
each axis apart; the box sizes and the body points are left as detected, so
``analyze`` sees the same positions with or without it.  Interpolated rows (no
detection) are predicted, not measured.  A smoothed centre stays within
:data:`CLIP` noise sds of its detection.

The smoother's two noises are measured on the tracks themselves, not tuned
(:func:`measure_noise`): the second differences ``x[i+1] - 2 x[i] + x[i-1]`` of
detected centres in consecutive frames have variance ``g0 = 6 r^2 + a^2 / 2`` and
lag-one covariance ``g1 = -4 r^2 + a^2 / 4`` when each detection is off by noise of
sd ``r`` and the animal's velocity changes by a random acceleration of sd ``a /
dt^2`` each frame, so ``r^2 = (g0 - 2 g1) / 14`` and ``a^2 = 2 (g0 - 6 r^2)``.  A
precise detector (small ``r``) is hardly smoothed; a jittery one is.

Hand-written (in Numba) because no maintained library runs an RTS smoother over
thousands of short, ragged tracks at once without a Python loop per track
(``filterpy`` and ``pykalman`` smooth one sequence per call); it runs inside the
tracker's ``finish``, which the speed benchmark times.

The detector's noise is one for all tracks; the acceleration is each track's own
(:func:`_own_accel`: its own second differences, shrunk toward the colony's), since
running ants turn harder than resting ones.

The tracker smooths the boxes it builds from body points (its own detectors'); a
detector's own boxes only with ``smooth_given``.  On real ant boxes (AntTracking's
``output_4``, tuning half, YOLO ``post09``, with the detections' frames aligned to the
ground truth's) smoothing them left MOTA unchanged (+0.000 / -0.001 / +0.002 at 15,
7.5 and 5 fps) and lowered HOTA by 0.016-0.024 (docs/tracking.md, "Real ant boxes").
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["measure_noise", "smooth_boxes"]

#: A smoothed centre moves at most this many noise sds from its detection: a larger
#: correction is not detection noise but a turn or a jump the smooth-motion model
#: does not describe, and there the detection is the better estimate.  2 sds on
#: the tuning half of the real ant boxes: MOTA + IDF1 + HOTA 4.208 (3 sds 4.201, no
#: limit 4.200, 1.5 sds 4.211); on the generated boxes of tests/tracking/test_detfiles.py
#: without a limit MOTA fell by 0.017 where ants crossed.
CLIP = 2.0


@njit(cache=True)
def _rts_axis(
    z: np.ndarray, t: np.ndarray, meas: np.ndarray, q: float, r: float, v0: float
) -> None:
    """Smooth one track's coordinate ``z`` (in place) at times ``t`` (s); ``meas``
    marks measured rows; ``q`` the acceleration sd (px/s^2), ``r`` the measurement sd
    (px), ``v0`` the sd of the first velocity (px/s; in px units, so the result
    scales with the image)."""
    n = z.size
    xs = np.zeros((n, 2))
    ps = np.zeros((n, 3))  # filtered covariance: p00, p01, p11
    xp = np.zeros((n, 2))
    pp = np.zeros((n, 3))
    x0, x1 = z[0], 0.0
    p00, p01, p11 = r * r, 0.0, v0 * v0
    for i in range(n):
        if i > 0:
            dt = t[i] - t[i - 1]
            x0 = x0 + dt * x1
            q2 = q * q
            p00, p01, p11 = (
                p00 + 2 * dt * p01 + dt * dt * p11 + q2 * dt**4 / 4,
                p01 + dt * p11 + q2 * dt**3 / 2,
                p11 + q2 * dt * dt,
            )
        xp[i, 0], xp[i, 1] = x0, x1
        pp[i, 0], pp[i, 1], pp[i, 2] = p00, p01, p11
        if meas[i]:
            s = p00 + r * r
            k0, k1 = p00 / s, p01 / s
            innov = z[i] - x0
            x0, x1 = x0 + k0 * innov, x1 + k1 * innov
            p00, p01, p11 = (1 - k0) * p00, (1 - k0) * p01, p11 - k1 * p01
        xs[i, 0], xs[i, 1] = x0, x1
        ps[i, 0], ps[i, 1], ps[i, 2] = p00, p01, p11
    for i in range(n - 2, -1, -1):
        dt = t[i + 1] - t[i]
        # C = P_i F^T (P_pred,i+1)^-1, with F = [[1, dt], [0, 1]]
        a00 = ps[i, 0] + dt * ps[i, 1]
        a01 = ps[i, 1]
        a10 = ps[i, 1] + dt * ps[i, 2]
        a11 = ps[i, 2]
        b00, b01, b11 = pp[i + 1, 0], pp[i + 1, 1], pp[i + 1, 2]
        det = b00 * b11 - b01 * b01
        if det <= 0:
            continue
        i00, i01, i11 = b11 / det, -b01 / det, b00 / det
        c00 = a00 * i00 + a01 * i01
        c01 = a00 * i01 + a01 * i11
        c10 = a10 * i00 + a11 * i01
        c11 = a10 * i01 + a11 * i11
        d0 = xs[i + 1, 0] - xp[i + 1, 0]
        d1 = xs[i + 1, 1] - xp[i + 1, 1]
        xs[i, 0] += c00 * d0 + c01 * d1
        xs[i, 1] += c10 * d0 + c11 * d1
        # the smoothed covariance, needed by the earlier rows' gains: P + C (Ps - Pp) C^T
        e00 = ps[i + 1, 0] - b00
        e01 = ps[i + 1, 1] - b01
        e11 = ps[i + 1, 2] - b11
        f00 = c00 * e00 + c01 * e01
        f01 = c00 * e01 + c01 * e11
        f10 = c10 * e00 + c11 * e01
        f11 = c10 * e01 + c11 * e11
        ps[i, 0] += f00 * c00 + f01 * c01
        ps[i, 1] += f00 * c10 + f01 * c11
        ps[i, 2] += f10 * c10 + f11 * c11
    for i in range(n):
        z[i] = xs[i, 0]


#: The default weight, in second differences, of the colony's acceleration in each
#: track's own (:func:`_own_accel`; ``TrackerConfig.smooth_weight``): a track measured
#: over 10 of them is half its own, half the colony's.  Chosen on the tuning half of the
#: real ant boxes scored one frame off (docs/tracking.md, "Before the alignment": 4.238
#: against the colony's 4.209); with the frames aligned those boxes are no longer
#: smoothed (``smooth_given``).  On the boxes it smooths now, those built from body
#: points, the weight makes no measurable difference: the synthetic 1080p video, MOTA at
#: seeds 1-3, 0.9760 / 0.9575 / 0.9607 against 0.9758 / 0.9580 / 0.9619 with the
#: colony's for every track (``bench_tracking.py --set smooth_weight=1e9``); SLEAP's fly
#: clip HOTA 0.8372 against 0.8375 (``thermoswarm track ... --set
#: tracker.smooth_weight=1e9``).
OWN_WEIGHT = 10.0


@njit(cache=True)
def _own_accel(
    frames: np.ndarray,
    boxes: np.ndarray,
    interp: np.ndarray,
    q: float,
    r: float,
    fps: float,
    weight: float,
) -> float:
    """One track's acceleration sd (px/s^2): the moment estimate of
    :func:`measure_noise` on its own second differences (the noise ``r`` px the
    detector's, measured on all tracks), shrunk toward the colony's ``q`` with the
    weight of :data:`OWN_WEIGHT` second differences.  Ants run, turn and rest, each
    its own way: on drawn hard-turning runners the colony's acceleration smooths their
    turns away (``test_each_track_is_smoothed_with_its_own_acceleration``); the real-box
    evidence that chose it was scored one frame off (:data:`OWN_WEIGHT`)."""
    g0 = 0.0
    nk = 0
    for i in range(2, frames.size):
        if frames[i] - frames[i - 2] == 2 and not (interp[i] or interp[i - 1] or interp[i - 2]):
            for ax in range(2):
                c2 = boxes[i, ax] + boxes[i, ax + 2] / 2
                c1 = boxes[i - 1, ax] + boxes[i - 1, ax + 2] / 2
                c0 = boxes[i - 2, ax] + boxes[i - 2, ax + 2] / 2
                g0 += (c2 - 2 * c1 + c0) ** 2
            nk += 1
    a2 = (q / (fps * fps)) ** 2
    if nk:
        own = max(2 * (g0 / (2 * nk) - 6 * r * r), r * r / 4)
        a2 = (nk * own + weight * a2) / (nk + weight)
    return np.sqrt(a2) * fps * fps


@njit(cache=True)
def _smooth_runs(
    frames: np.ndarray,
    ids: np.ndarray,
    boxes: np.ndarray,
    interp: np.ndarray,
    fps: float,
    q: float,
    r: float,
    v0: float,
    weight: float,
) -> None:
    n = ids.size
    start = 0
    while start < n:
        end = start + 1
        while end < n and ids[end] == ids[start]:
            end += 1
        if end - start >= 3:
            t = frames[start:end].astype(np.float64) / fps
            meas = ~interp[start:end]
            qk = _own_accel(
                frames[start:end], boxes[start:end], interp[start:end], q, r, fps, weight
            )
            for ax in range(2):
                c0 = boxes[start:end, ax] + boxes[start:end, ax + 2] / 2
                c = c0.copy()
                _rts_axis(c, t, meas, qk, r, v0)
                for j in range(c.size):
                    if meas[j]:
                        c[j] = min(max(c[j], c0[j] - CLIP * r), c0[j] + CLIP * r)
                boxes[start:end, ax] = c - boxes[start:end, ax + 2] / 2
        start = end


def measure_noise(
    frames: np.ndarray, ids: np.ndarray, boxes: np.ndarray, interp: np.ndarray, fps: float
) -> tuple[float, float] | None:
    """The detections' centre noise and the objects' acceleration, measured on tracks.

    Parameters are those of :func:`smooth_boxes`.  Returns ``(noise_px,
    accel_px_s2)``, or None with fewer than 20 pairs of second differences (too
    little to measure) or no measurable noise.  The acceleration is at least half
    the noise per frame squared: the moment estimate can come out near 0 on short
    samples, and a smoother that then trusts its straight line would cut every turn.
    """
    f = np.asarray(frames, np.int64)
    c = boxes[:, :2] + boxes[:, 2:4] / 2
    ok = ~np.asarray(interp, bool)
    same = (ids[2:] == ids[:-2]) & (f[2:] - f[:-2] == 2)
    valid = same & ok[2:] & ok[1:-1] & ok[:-2]
    d2 = c[2:] - 2 * c[1:-1] + c[:-2]
    pair = valid[1:] & valid[:-1]
    if pair.sum() < 20:
        return None
    g0 = float(np.mean(d2[valid] ** 2))
    g1 = float(np.mean(d2[1:][pair] * d2[:-1][pair]))
    r2 = (g0 - 2 * g1) / 14
    if not r2 > 0:
        return None
    a2 = max(2 * (g0 - 6 * r2), r2 / 4)
    return float(np.sqrt(r2)), float(np.sqrt(a2)) * fps * fps


def smooth_boxes(
    frames: np.ndarray,
    ids: np.ndarray,
    boxes: np.ndarray,
    interp: np.ndarray,
    *,
    fps: float,
    speed_px_s: float,
    own_weight: float = OWN_WEIGHT,
) -> np.ndarray:
    """The boxes with each track's centres smoothed (sizes unchanged), with the noises
    :func:`measure_noise` finds (the boxes as given where it finds none), each track
    with its own acceleration (:func:`_own_accel`).

    Parameters
    ----------
    frames, ids : ndarray of int, shape (n,)
        Rows sorted by track id, then frame.
    boxes : ndarray, shape (n, 4)
        ``left, top, width, height`` (px); not modified.
    interp : ndarray of bool, shape (n,)
        Rows without a detection (predicted, not measured).
    fps : float
        Frames per second.
    speed_px_s : float
        The sd of a track's unknown first velocity (px/s).
    own_weight : float
        The colony's acceleration's weight in each track's own, in second differences.

    Returns
    -------
    ndarray, shape (n, 4)
        A new array; tracks of fewer than 3 rows are returned as given.
    """
    out = np.array(boxes, dtype=np.float64, copy=True)
    noise = measure_noise(frames, ids, out, interp, fps) if ids.size > 3 else None
    if noise is not None:
        noise_px, accel_px_s2 = noise
        _smooth_runs(
            np.asarray(frames, np.int64),
            np.asarray(ids, np.int64),
            out,
            np.asarray(interp, bool),
            float(fps),
            accel_px_s2,
            noise_px,
            float(speed_px_s),
            float(own_weight),
        )
    return out
