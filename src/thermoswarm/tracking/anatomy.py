"""The ant's shape, its three keypoints and the body-centred box.

One place for the geometry that the renderer (:mod:`~thermoswarm.tracking.synth.clip`), the
classical detector, the tracker and the MOT tables share.

Keypoints are ``head`` (centre of the head), ``body`` (centre of the mesosoma, the
"thorax") and ``tail`` (centre of the gaster), in that order, as annotated in the paper
(PAPER_NOTES section 3).  Offsets are given along the body axis in units of the body
length ``L`` (the paper's 7.14 mm), forward positive, measured from the body keypoint.
The proportions are those of a *Formica* worker: a round head, a slender mesosoma and
an oval gaster that is the widest part (the paper's 2.5 mm width).

The body-centred box (paper, Methods, "Tracking method") is the axis-aligned box centred
on the body keypoint whose half-extents reach the farther of head and tail in each image
axis, plus half the ant's width.  Ground-truth MOT tables, tracker outputs and the
evaluation all use :func:`pose_boxes`, so a perfect pose gives IoU 1.
"""

from __future__ import annotations

from functools import cache

import numpy as np

KEYPOINTS: tuple[str, str, str] = ("head", "body", "tail")

#: Paper's ant size (Methods, narrow-road configuration): 100/14 mm by 20/8 mm.
ANT_LENGTH_MM = 100.0 / 14.0
ANT_WIDTH_MM = 20.0 / 8.0

#: Body parts as (centre offset, semi-length, semi-width) in units of body length.
HEAD = (0.36, 0.115, 0.105)
MESOSOMA = (0.03, 0.19, 0.075)
GASTER = (-0.30, 0.20, 0.175)

#: Keypoint offsets along the axis (units of body length): head, body, tail.
KEYPOINT_OFFSETS = np.array([HEAD[0], 0.0, GASTER[0]])

#: Front and back extremities of the silhouette (units of body length).
FRONT = HEAD[0] + HEAD[1]
BACK = GASTER[0] - GASTER[1]


@cache
def silhouette_sd() -> tuple[float, float]:
    """Standard deviations of the silhouette's area along and across the body axis,
    in body lengths (the union of the head, mesosoma and gaster ellipses, uniform).

    Measured on a grid of 1/1000 body length; about ``(0.281, 0.074)``.  The length
    of an animal follows from its image's second moments: a blur adds the same
    variance along and across, so ``sqrt(var_along - var_across) / sqrt(along**2 -
    across**2)`` is the body length (as ``sd * sqrt(12)`` is a thin uniform rod's;
    :func:`thermoswarm.tracking.detect.blobs.axis_lengths`).
    """
    t = np.arange(BACK - 0.01, FRONT + 0.01, 1e-3)
    s = np.arange(0.0, 0.2, 1e-3) + 5e-4  # one side; the silhouette is symmetric
    tt, ss = np.meshgrid(t, s, indexing="ij")
    inside = np.zeros(tt.shape, bool)
    for at, a, b in (HEAD, MESOSOMA, GASTER):
        inside |= ((tt - at) / a) ** 2 + (ss / b) ** 2 <= 1.0
    n = inside.sum()
    mean = tt[inside].sum() / n
    along = np.sqrt(((tt[inside] - mean) ** 2).sum() / n)
    across = np.sqrt((ss[inside] ** 2).sum() / n)
    return float(along), float(across)


def pose_boxes(
    points: np.ndarray, pad: float, fallback_half: tuple[float, float] | None = None
) -> np.ndarray:
    """Body-centred boxes ``(n, 4)`` as MOT ``(left, top, width, height)`` in px.

    Parameters
    ----------
    points
        ``(n, 3, 2)`` head, body, tail in px; head or tail may be NaN.
    pad
        Added to each half-extent (half the ant's width), px.
    fallback_half
        ``(half_width, half_height)`` in px used where neither head nor tail is known;
        default ``(pad, pad)``.
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3, 2)
    body = points[:, 1, :]
    ends = np.abs(points[:, [0, 2], :] - body[:, None, :])  # (n, 2, 2)
    with np.errstate(invalid="ignore"):
        known = np.isfinite(ends).any(axis=1)
        half = np.where(known, np.nanmax(np.where(np.isfinite(ends), ends, -np.inf), axis=1), 0.0)
    half = np.where(np.isfinite(half), half, 0.0) + pad
    if fallback_half is not None:
        fb = np.asarray(fallback_half, dtype=np.float64)
        half = np.where(known, half, fb[None, :])
    out = np.empty((points.shape[0], 4))
    out[:, 0:2] = body - half
    out[:, 2:4] = 2 * half
    return out


def box_iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """IoU matrix ``(len(a), len(b))`` of MOT boxes ``(left, top, width, height)``.

    Continuous coordinates (no ``+1`` on widths), as TrackEval computes it; boxes of
    zero area have IoU 0 with everything.
    """
    a = np.asarray(a, dtype=np.float64).reshape(-1, 4)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 4)
    ax1, ay1 = a[:, 0] + a[:, 2], a[:, 1] + a[:, 3]
    bx1, by1 = b[:, 0] + b[:, 2], b[:, 1] + b[:, 3]
    iw = np.minimum(ax1[:, None], bx1[None, :]) - np.maximum(a[:, None, 0], b[None, :, 0])
    ih = np.minimum(ay1[:, None], by1[None, :]) - np.maximum(a[:, None, 1], b[None, :, 1])
    inter = np.clip(iw, 0, None) * np.clip(ih, 0, None)
    area_a = a[:, 2] * a[:, 3]
    area_b = b[:, 2] * b[:, 3]
    union = area_a[:, None] + area_b[None, :] - inter
    eps = np.finfo(np.float64).eps
    ok = (union > eps) & (area_a[:, None] > eps) & (area_b[None, :] > eps)
    return np.where(ok, inter / np.where(ok, union, 1.0), 0.0)
