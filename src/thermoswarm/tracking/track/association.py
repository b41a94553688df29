"""Association of one frame's detections with the live tracks (paper, Methods).

Pure functions on arrays, used by :class:`~thermoswarm.tracking.track.tracker.Tracker`:

- :func:`pair_costs`: the cost of every (track, detection) pair inside the gate, for
  all live tracks at once (one compiled pass over the pairs);
- :func:`assign`: the Hungarian assignment of one group of tracks
  (:func:`scipy.optimize.linear_sum_assignment`), pairs above ``max_cost`` dropped;
- :func:`orient_matched` and :func:`orient_new`: the head-tail order of matched and of
  new detections.

Units: px and frames; weights as in
:class:`~thermoswarm.tracking.track.tracker.TrackerConfig`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit
from scipy.optimize import linear_sum_assignment

__all__ = [
    "BIG",
    "pair_costs",
    "assign",
    "orient_matched",
    "orient_new",
    "overlap_of_smaller",
    "within_body",
]

#: Cost of a pair outside the gate (never matched; larger than any sum of real costs).
BIG = 1e6


def pair_costs(
    c: Any,
    *,
    S: np.ndarray,
    pred: np.ndarray,
    track_boxes: np.ndarray,
    axes: np.ndarray,
    reach: np.ndarray,
    any_axis: bool,
    pts: np.ndarray,
    boxes: np.ndarray,
    length_px: float,
    hint_other: np.ndarray | None = None,
    given_boxes: bool = True,
) -> np.ndarray:
    """Costs ``(n, m)`` of tracks and detections, :data:`BIG` outside the gate.

    Cost ``iou_weight (1 - IoU) + distance_weight d / L + mahalanobis_weight m /
    gate_sigmas + angle_weight |sin(da)| [+ hint_weight]`` (``d`` the distance of the
    body points, ``m`` the Mahalanobis distance of the innovation, ``da`` the angle between
    the body axes when both are known, the hint term where the detection was split off
    another track's prediction: ``hint_other`` ``(n, m)``).  Gate: Mahalanobis distance
    of the innovation within ``gate_sigmas``, ``d`` within ``reach`` and, for a
    detector's own boxes (``given_boxes``; not boxes made from poses, whose overlap
    drops when an ant turns), the IoU of the predicted and detected boxes at least
    ``min_iou``.  With ``own_size`` ``d`` is in units of the track's own size (longer
    side of its box) instead of ``length_px``.

    Tracks: innovation covariances ``S`` ``(n, 2, 2)``, predicted body points ``pred``
    ``(n, 2)``, boxes ``track_boxes`` ``(n, 4)`` and axes (head - tail) ``axes``
    ``(n, 2)``, ``any_axis`` whether any is known
    (:func:`~thermoswarm.tracking.track.bank.prepare_costs`).  Detections: ``pts``
    ``(m, 3, 2)``, ``boxes`` ``(m, 4)``.  Each entry depends on its own track and
    detection only, so any subset of rows equals the costs of that subset of tracks.
    """
    Sinv = np.linalg.inv(S)
    body = np.ascontiguousarray(pts[:, 1])
    ta = da = _NO_AXES
    if c.angle_weight > 0 and any_axis:
        da_ = pts[:, 0] - pts[:, 2]
        if np.isfinite(da_).any():
            ta, da = axes, da_
    cost = np.empty((pred.shape[0], body.shape[0]))
    _gated_costs(
        pred,
        Sinv,
        reach,
        track_boxes,
        body,
        np.ascontiguousarray(boxes),
        ta,
        da,
        _NO_HINTS if hint_other is None else hint_other,
        float(c.gate_sigmas**2),
        float(c.iou_weight),
        float(c.distance_weight),
        float(getattr(c, "mahalanobis_weight", 0.0)) / float(c.gate_sigmas),
        float(c.angle_weight),
        float(c.hint_weight),
        float(c.min_iou) if given_boxes else 0.0,
        bool(c.own_size),
        float(length_px),
        cost,
    )
    return cost


_NO_AXES = np.zeros((0, 2))
_NO_HINTS = np.zeros((0, 0), bool)
_EPS = float(np.finfo(np.float64).eps)


@njit(cache=True, inline="always")
def _minimum(a: float, b: float) -> float:  # np.minimum: NaN wins
    if a != a or b != b:
        return a + b
    return a if a <= b else b


@njit(cache=True, inline="always")
def _maximum(a: float, b: float) -> float:  # np.maximum: NaN wins
    if a != a or b != b:
        return a + b
    return a if a >= b else b


@njit(cache=True, error_model="numpy")
def _gated_costs(
    pred, Sinv, reach, pboxes, body, dboxes, ta, da, hint_other,
    gate2, w_iou, w_dist, w_maha, w_angle, w_hint, min_iou, own_size, length_px, out,
):  # fmt: skip
    """The loop of :func:`pair_costs` (one pass over the pairs instead of some forty
    array operations, each of which costs more than its arithmetic at tens of
    objects).  The arithmetic is that of the array expressions it replaces, in the
    same order (``np.einsum("nmi,nij,nmj->nm")`` for the Mahalanobis distance,
    ``np.hypot``, :func:`~thermoswarm.tracking.anatomy.box_iou`), so the costs are the
    same numbers (tests/tracking/test_tracker_kernels.py compares them)."""
    n, m = out.shape
    use_angle = ta.shape[0] > 0
    use_hint = hint_other.shape[0] > 0
    for i in range(n):
        p0, p1 = pred[i, 0], pred[i, 1]
        s00, s01, s10, s11 = Sinv[i, 0, 0], Sinv[i, 0, 1], Sinv[i, 1, 0], Sinv[i, 1, 1]
        a0, a1, a2, a3 = pboxes[i, 0], pboxes[i, 1], pboxes[i, 2], pboxes[i, 3]
        ax1, ay1 = a0 + a2, a1 + a3
        area_a = a2 * a3
        for j in range(m):
            d0 = body[j, 0] - p0
            d1 = body[j, 1] - p1
            maha = (((d0 * s00) * d0 + (d0 * s01) * d1) + (d1 * s10) * d0) + (d1 * s11) * d1
            dist = np.hypot(d0, d1)
            if not (maha <= gate2 and dist <= reach[i]):
                out[i, j] = BIG
                continue
            b0, b1, b2, b3 = dboxes[j, 0], dboxes[j, 1], dboxes[j, 2], dboxes[j, 3]
            iw = _minimum(ax1, b0 + b2) - _maximum(a0, b0)
            ih = _minimum(ay1, b1 + b3) - _maximum(a1, b1)
            if iw < 0:
                iw = 0.0
            if ih < 0:
                ih = 0.0
            inter = iw * ih
            area_b = b2 * b3
            union = area_a + area_b - inter
            iou = 0.0
            if union > _EPS and area_a > _EPS and area_b > _EPS:
                iou = inter / union
            if iou < min_iou:
                out[i, j] = BIG
                continue
            size = length_px
            if own_size:
                # The track's own size (longer side of its box): objects of one kind
                # but of many sizes on the image (perspective) keep their own scale.
                size = a2 if a2 >= a3 else a3
                if not size > _EPS:
                    size = length_px
            total = w_iou * (1 - iou) + w_dist * dist / size
            if w_maha > 0 and maha > 0:
                total = total + w_maha * np.sqrt(maha)
            if use_angle:
                cross = ta[i, 0] * da[j, 1] - ta[i, 1] * da[j, 0]
                norm = np.hypot(ta[i, 0], ta[i, 1]) * np.hypot(da[j, 0], da[j, 1])
                sin = abs(cross) / norm
                total = total + w_angle * (sin if np.isfinite(sin) else 0.0)
            if use_hint:
                total = total + w_hint * (1.0 if hint_other[i, j] else 0.0)
            out[i, j] = total


def assign(cost: np.ndarray, max_cost: float) -> tuple[np.ndarray, np.ndarray]:
    """Rows and columns of the minimum-cost assignment of ``cost`` (``BIG`` outside the
    gate), pairs costing more than ``max_cost`` left out."""
    r, j = linear_sum_assignment(cost)
    keep = cost[r, j] <= max_cost
    return r[keep], j[keep]


def orient_matched(
    c: Any,
    p: np.ndarray,
    hc: np.ndarray,
    heading: np.ndarray,
    vel: np.ndarray,
    vel_sd: np.ndarray,
    motion_px: float,
) -> np.ndarray:
    """Head-tail order of matched detections ``p`` ``(n, 3, 2)``: a copy with head and
    tail swapped where the evidence says so.

    Evidence: ``shape_weight (2 hc - 1)`` (the detector's head confidence), plus
    ``continuity_weight`` times the agreement with the track's ``heading`` (NaN: none
    yet), plus ``motion_weight`` times the agreement with the predicted velocity
    ``vel``, scaled by how well it is known (``vel_sd``) and by ``|vel| / motion_px``
    up to 1.
    """
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
    certainty = spv / (spv + 2 * vel_sd) * np.minimum(1.0, spv / motion_px)
    mot = (a * vel).sum(1) / spv * certainty
    score = score + c.motion_weight * np.where(moving, mot, 0.0)
    flip = ok & (score < 0)
    p[flip] = p[flip][:, [2, 1, 0]]
    return p


def orient_new(c: Any, p: np.ndarray, hc: np.ndarray) -> np.ndarray:
    """Head-tail order of detections that start tracks (no heading or motion yet): a
    copy of ``p`` ``(n, 3, 2)`` with head and tail swapped where the detector's head
    confidence says so (``shape_weight (2 hc - 1) < 0``)."""
    p = p.copy()
    posed = np.isfinite(p[:, [0, 2]]).all(axis=(1, 2))
    if not posed.any():
        return p
    a = p[:, 0] - p[:, 2]
    with np.errstate(invalid="ignore"):
        na = np.hypot(a[:, 0], a[:, 1])
        flip = posed & ~(na < 1e-9) & (c.shape_weight * (2 * hc - 1) < 0)
    p[flip] = p[flip][:, [2, 1, 0]]
    return p


def overlap_of_smaller(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(len(a), len(b))``: intersection of MOT boxes over the smaller one's area
    (0 where either has no area)."""
    x0 = np.maximum(a[:, None, 0], b[None, :, 0])
    y0 = np.maximum(a[:, None, 1], b[None, :, 1])
    x1 = np.minimum(a[:, None, 0] + a[:, None, 2], b[None, :, 0] + b[None, :, 2])
    y1 = np.minimum(a[:, None, 1] + a[:, None, 3], b[None, :, 1] + b[None, :, 3])
    inter = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
    small = np.minimum((a[:, 2] * a[:, 3])[:, None], (b[:, 2] * b[:, 3])[None, :])
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(small > 0, inter / small, 0.0)


def within_body(a: np.ndarray, b: np.ndarray, along: float, across: float) -> np.ndarray:
    """``(len(a), len(b))``: whether pose ``a[i]``'s body point lies inside the ellipse
    of semi-axes ``along`` (px, on ``b[j]``'s head-tail axis) and ``across`` (px,
    across it) centred on ``b[j]``'s body point: the two bodies overlap along their
    length, as the pieces of one ant split in two do, and two ants side by side or
    end to end do not.  False where ``b[j]``'s head or tail is unknown (box-only
    detections) or a body point is.

    Parameters
    ----------
    a, b : ndarray, shape (n, 3, 2) and (m, 3, 2)
        Poses (head, body, tail; px).
    along, across : float
        Semi-axes of the ellipse (px), both positive.
    """
    ax = b[:, 0] - b[:, 2]
    norm = np.hypot(ax[:, 0], ax[:, 1])
    if not np.any(norm > 1e-9):  # box-only detections: nothing to compare
        return np.zeros((len(a), len(b)), bool)
    with np.errstate(invalid="ignore", divide="ignore"):
        u = ax / norm[:, None]
    d = a[:, None, 1, :] - b[None, :, 1, :]
    t = d[..., 0] * u[None, :, 0] + d[..., 1] * u[None, :, 1]
    s = d[..., 0] * u[None, :, 1] - d[..., 1] * u[None, :, 0]
    inside = (t / along) ** 2 + (s / across) ** 2 <= 1.0
    return inside & (norm > 1e-9)[None, :]
