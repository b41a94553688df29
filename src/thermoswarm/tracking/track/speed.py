"""The speed cap of each track: the assumed top speed, widened by the track's own speed.

Every gate of the tracker is in body lengths ``L``, and ``L`` is often measured from
the video: on small animals the measurement can be 30 % off (issue 32: 4.7 px
measured against 6-7 px by eye).  A cap of ``max_speed_bl_s`` assumed body lengths a
second is then ``0.7 x`` that in true body lengths, and fast ants (8-10 body lengths
a second) run past it: their tracks lose every detection the cap rejects, and
:func:`~thermoswarm.tracking.track.result.fix_jumps` drops rows of tracks that keep
the pace.  So a track's cap is its own measured speed with headroom, where that is
higher than the assumed cap:

``cap = clip(SPEED_HEADROOM * speed, step_px, MAX_WIDENING * step_px)`` px per frame

with ``speed`` the Kalman velocity's magnitude (association and re-linking) or the
median of the track's steps (the end-of-video jump removal), ``step_px`` the assumed
cap (``max_speed_bl_s L / fps``).  A track that walks at ``v`` is thereby never
refused a step of ``1.5 v``, while an identity swap or a misplaced detection (a step
of over a body length in a frame at 30 fps, many times the track's speed) still is;
``MAX_WIDENING`` bounds how far a bad velocity can widen it.  At the true scale
nothing changes for ants under ``max_speed_bl_s / 1.5`` (9.3 body lengths a second).
The Mahalanobis gate is unchanged: it is in units of each track's own uncertainty.
"""

from __future__ import annotations

import numpy as np

__all__ = ["SPEED_HEADROOM", "MAX_WIDENING", "cap_px", "reach_px", "track_limits"]

#: A track is never refused a step of this many times its own speed (within the bounds).
SPEED_HEADROOM = 1.5
#: The cap is widened to at most this many times the assumed one.
MAX_WIDENING = 3.0


def cap_px(speed: np.ndarray, step_px: float) -> np.ndarray:
    """Per-frame caps (px/frame) of tracks moving at ``speed`` (px/frame; NaN: unknown,
    the assumed cap) when the assumed cap is ``step_px`` (px/frame)."""
    s = np.nan_to_num(np.asarray(speed, dtype=np.float64), nan=0.0)
    return np.clip(SPEED_HEADROOM * s, step_px, MAX_WIDENING * step_px)


def reach_px(velocity: np.ndarray, frames: np.ndarray, step_px: float, pad: float) -> np.ndarray:
    """How far (px) each track may have gone in ``frames`` frames since its last
    detection, for Kalman velocities ``velocity`` ``(n, 2)`` px/frame: its cap
    (:func:`cap_px`) times ``frames`` plus ``2 pad`` (px), as the gate's reach."""
    v = np.asarray(velocity, dtype=np.float64).reshape(-1, 2)
    cap = cap_px(np.hypot(v[:, 0], v[:, 1]), step_px)
    return cap * np.asarray(frames, dtype=np.float64) + 2 * pad


def track_limits(
    frames: np.ndarray, ids: np.ndarray, body: np.ndarray, step_px: float
) -> np.ndarray:
    """Per-row speed limits (px/frame) for
    :func:`~thermoswarm.tracking.track.result.fix_jumps`: each track's cap at the median
    of its steps' speeds (rows sorted by track then frame; ``body`` ``(k, 2)`` px)."""
    out = np.full(ids.size, float(step_px))
    if ids.size < 2:
        return out
    starts = np.flatnonzero(np.r_[True, ids[1:] != ids[:-1]])
    ends = np.r_[starts[1:], ids.size]
    f = frames.astype(np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        step = np.hypot(*np.diff(body, axis=0).T) / np.diff(f)
    for a, b in zip(starts.tolist(), ends.tolist(), strict=True):
        s = step[a : b - 1]
        s = s[np.isfinite(s)]
        if s.size:
            out[a:b] = cap_px(np.median(s), step_px)
    return out
