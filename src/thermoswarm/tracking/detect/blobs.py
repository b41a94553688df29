"""Blob measurement for the classical detector: one frame's foreground mask to ant poses.

All blobs of a frame are measured at once, at full resolution and vectorised over
blobs: :func:`blob_pixels` labels the mask and gathers every blob's full-resolution
pixels weighted by their contrast above ``peak_fraction`` of the blob's peak;
:func:`split_counts` decides how many ants each blob holds (its area, the tracker's
predictions); :func:`measure_singles` places one pose per single-ant blob
(:func:`_moments_pose`) and :func:`measure_splits` splits the others
(:func:`_split`, k-means with segments) and places a pose per part (a part cut
short where it touches another ant from its whole end: :func:`_from_free_end`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass

import numpy as np

from thermoswarm.tracking import anatomy

__all__ = [
    "typical_area",
    "axis_lengths",
    "median_length",
    "spatial_response",
    "picture_background",
    "parts_at",
]

#: One measured part: points, head confidence, span, area, peak, split flag, hint.
Part = tuple[np.ndarray, ...]


@dataclass
class _Blobs:
    """Measured blobs of one frame (full-resolution px)."""

    points: np.ndarray  # (n, 3, 2)
    head_conf: np.ndarray  # (n,)
    span: np.ndarray  # (n,) silhouette length along the axis
    area: np.ndarray  # (n,) working-resolution px^2
    peak: np.ndarray  # (n,) peak relative contrast
    split: np.ndarray  # (n,) bool: part of a split blob
    hint: np.ndarray  # (n,) index of the hint this ant continues, -1 if none

    @classmethod
    def empty(cls) -> _Blobs:
        """No blobs."""
        return cls(
            np.zeros((0, 3, 2)),
            np.zeros(0),
            np.zeros(0),
            np.zeros(0),
            np.zeros(0),
            np.zeros(0, bool),
            np.zeros(0, np.int64),
        )

    @classmethod
    def join(cls, parts: list[Part]) -> _Blobs:
        """The blobs of ``parts`` (tuples of the seven fields), in order."""
        return cls(*(np.concatenate([p[j] for p in parts]) for j in range(7)))


@dataclass
class _Pixels:
    """One frame's labelled blobs and their measured full-resolution pixels."""

    n: int  # labels, background (0) included
    labels: np.ndarray  # (h, w) working-resolution labels
    lab_d: np.ndarray  # labels dilated by one working pixel (float32)
    area: np.ndarray  # (n,) working px^2
    good: np.ndarray  # (n,) bool: large enough
    peak: np.ndarray  # (n,) peak relative contrast
    fx: np.ndarray  # full-resolution pixel x
    fy: np.ndarray  # full-resolution pixel y
    lab: np.ndarray  # label of each pixel
    w: np.ndarray  # contrast above peak_fraction of the blob's peak


def blob_pixels(
    gray: np.ndarray,
    con: np.ndarray,
    expected: np.ndarray,
    thr: float,
    min_area: float,
    f: int,
    offsets: np.ndarray,
    peak_fraction: float,
    contrast: Callable[[np.ndarray, np.ndarray], np.ndarray],
) -> _Pixels | None:
    """Label the blobs of ``con > thr`` and gather their weighted full-resolution pixels.

    ``f`` is the working resolution's downsampling, ``offsets`` the ``(f*f, 2)`` (dy,
    dx) of a working pixel's full-resolution pixels, ``contrast(img, expected)`` the
    relative contrast.  ``None`` when no blob of at least ``min_area`` has pixels.
    """
    import cv2

    mask = (con > thr).view(np.uint8)
    # Labels without stats (cv2's stats are slow); areas and peaks from the pixels.
    n, labels = cv2.connectedComponents(mask, connectivity=8, ltype=cv2.CV_32S)
    nz = cv2.findNonZero(mask)
    if nz is None or n <= 1:
        return None
    nz = nz.reshape(-1, 2)
    xs, ys = nz[:, 0], nz[:, 1]
    lab = labels[ys, xs]
    area = np.bincount(lab, minlength=n).astype(np.float64)
    good = area >= min_area
    good[0] = False
    if not good.any():
        return None
    peak = np.zeros(n)
    np.maximum.at(peak, lab, con[ys, xs])
    # One working pixel of margin (the blurred rim), then every full-res pixel.
    kernel = np.ones((3, 3), np.uint8)
    lab_d = cv2.dilate(labels.astype(np.float32), kernel)
    nz = cv2.findNonZero(cv2.dilate(mask, kernel))
    nz = nz.reshape(-1, 2)
    xs, ys = nz[:, 0], nz[:, 1]
    lab = lab_d[ys, xs].astype(np.int64)
    keep = good[lab]
    xs, ys, lab = xs[keep], ys[keep], lab[keep]
    ff = f * f
    fy = (ys[:, None] * f + offsets[None, :, 0]).ravel()
    fx = (xs[:, None] * f + offsets[None, :, 1]).ravel()
    lab = np.repeat(lab, ff)
    rel = contrast(gray[fy, fx].astype(np.float32), np.repeat(expected[ys, xs], ff))
    w = rel - peak_fraction * peak[lab]
    sel = w > 0
    fx = fx[sel].astype(np.float64)
    fy = fy[sel].astype(np.float64)
    lab, w = lab[sel], w[sel].astype(np.float64)
    if lab.size == 0:
        return None
    return _Pixels(n, labels, lab_d, area, good, peak, fx, fy, lab, w)


def split_counts(
    px: _Pixels,
    area1: float,
    f: int,
    split_area: float,
    hint_split_area: float,
    max_split: int,
    hints: np.ndarray | None,
) -> tuple[np.ndarray, dict[int, list[int]]]:
    """How many ants each blob holds (``(n,)``) and the hints that fall in each blob.

    Blobs to split: larger than ``split_area`` single-ant areas ``area1``, or holding
    two or more predicted ants (``hints``, px) and larger than ``hint_split_area``.
    """
    area, good = px.area, px.good
    k = np.ones(px.n, np.int64)
    big = good & (area >= split_area * area1)
    k[big] = np.clip(np.round(area[big] / area1), 2, max_split)
    hint_at: dict[int, list[int]] = {}
    if hints is not None and len(hints):
        hb = np.asarray(hints, dtype=np.float64).reshape(-1, 3, 2)[:, 1, :]
        ok = np.all(np.isfinite(hb), axis=1)
        hx = np.clip((hb[ok, 0] / f).astype(np.int64), 0, px.labels.shape[1] - 1)
        hy = np.clip((hb[ok, 1] / f).astype(np.int64), 0, px.labels.shape[0] - 1)
        hl = px.lab_d[hy, hx].astype(np.int64)
        for j, L in zip(np.flatnonzero(ok), hl, strict=True):
            if L > 0 and good[L]:
                hint_at.setdefault(int(L), []).append(int(j))
        for L, js in hint_at.items():
            # Two ants cover more than one ant's area even when crossing.
            if len(js) >= 2 and area[L] >= hint_split_area * area1:
                k[L] = min(max(len(js), k[L]), max_split)
    return k, hint_at


def measure_singles(
    px: _Pixels, k: np.ndarray, hint_at: dict[int, list[int]], length: float, widen: float
) -> Part:
    """The poses of the single-ant blobs (``k == 1``)."""
    single = k[px.lab] == 1
    n, lab = px.n, px.lab
    pts, hc, span, valid = _moments_pose(
        px.fx[single], px.fy[single], px.w[single], lab[single], n, length, widen
    )
    ids = np.flatnonzero(px.good & (k == 1) & valid)
    # A single-ant blob that holds exactly one predicted ant continues it.
    one_hint = np.full(n, -1, np.int64)
    for L, js in hint_at.items():
        if len(js) == 1:
            one_hint[L] = js[0]
    return (
        pts[ids],
        hc[ids],
        span[ids],
        px.area[ids],
        px.peak[ids],
        np.zeros(ids.size, bool),
        one_hint[ids],
    )


def measure_splits(
    px: _Pixels,
    k: np.ndarray,
    hint_at: dict[int, list[int]],
    hints: np.ndarray | None,
    length: float,
    widen: float,
) -> list[Part]:
    """The poses of the parts of the blobs that hold several ants (``k > 1``)."""
    parts: list[Part] = []
    lab, w = px.lab, px.w
    multi = np.flatnonzero(px.good & (k > 1))
    if not multi.size:
        return parts
    order = np.argsort(lab, kind="stable")
    bounds = np.searchsorted(lab[order], np.stack([multi, multi + 1]))
    for i, lo, hi in zip(multi, bounds[0], bounds[1], strict=True):
        idx = order[lo:hi]
        if idx.size < 3:
            continue
        xy = np.column_stack([px.fx[idx], px.fy[idx]])
        # More predicted ants than max_split in one blob (a clump, or clutter
        # that tracks were born on): the blob is split max_split ways, started
        # from the first max_split predictions.
        js = hint_at.get(int(i), [])[: int(k[i])]
        init = np.asarray(hints, dtype=np.float64)[js] if len(js) >= 2 else None
        groups = _split(xy, w[idx], int(k[i]), length, init)
        m = len(groups)
        gl = np.empty(idx.size, np.int64)
        for j, gi in enumerate(groups):
            gl[gi] = j
        p2, h2, s2, v2 = _moments_pose(xy[:, 0], xy[:, 1], w[idx], gl, m, length, widen)
        v2 &= np.bincount(gl, minlength=m) >= 3
        p2 = _from_free_end(xy, gl, p2, v2, length, widen)
        # Segment j started from hint js[j]: it continues that predicted ant.
        src = np.full(m, -1, np.int64)
        if init is not None:
            src[: len(js)] = js
        parts.append(
            (
                p2[v2],
                h2[v2],
                s2[v2],
                np.full(v2.sum(), px.area[i] / m),
                np.full(v2.sum(), px.peak[i]),
                np.ones(v2.sum(), bool),
                src[v2],
            )
        )
    return parts


#: The most blur variance (px^2, a Gaussian of sd 1.4 px) that :func:`axis_lengths`
#: takes out of a blob's variance.  More variance across the body than its own is legs
#: and antennae: on the Niche-Lab ants (about 30 px) the sd across is 3.0-3.5 px
#: against the body's 2.3, and taking it all as blur read them 10-14 % short.
MAX_BLUR_VAR = 2.0


def axis_lengths(px: _Pixels, floor: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """Working-resolution areas and body lengths (px) of the blobs of ``px``.

    ``px`` must be gathered with ``peak_fraction=0`` (:func:`blob_pixels`), so that
    its weights are the pixels' relative contrast; pixels below ``floor`` times their
    blob's peak (noise, the blur's far tails) are left out.  With ``l1 >= l2`` the
    eigenvalues of the contrast-weighted covariance of a blob's pixels and ``a, b``
    the anatomy's silhouette standard deviations along and across, in body lengths
    (:func:`~thermoswarm.tracking.anatomy.silhouette_sd`), the moments of the image are
    those of the animal's darkness plus the blur's (optics, pixels), the same along and
    across: ``l1 = (a L)^2 + s2``, ``l2 = (b L)^2 + s2``, so ``L = sqrt((l1 - l2) /
    (a^2 - b^2))`` whatever the blur, and no threshold sets where the ends are.  Legs
    and antennae that show (larger animals) widen the blob across too, which is not
    blur: ``s2`` is taken as at most :data:`MAX_BLUR_VAR` and ``L = sqrt(l1 - s2) /
    a``.  For the blobs with ``px.good`` and at least 3 pixels.
    """
    keep = px.w > floor * px.peak[px.lab]
    lab, w, x, y = px.lab[keep], px.w[keep], px.fx[keep], px.fy[keep]
    n, bc = px.n, np.bincount
    m0 = bc(lab, w, n)
    s0 = np.where(m0 > 0, m0, 1.0)
    dx, dy = x - (bc(lab, w * x, n) / s0)[lab], y - (bc(lab, w * y, n) / s0)[lab]
    cxx, cyy = bc(lab, w * dx * dx, n) / s0, bc(lab, w * dy * dy, n) / s0
    cxy = bc(lab, w * dx * dy, n) / s0
    half_diff = np.sqrt(0.25 * (cxx - cyy) ** 2 + cxy**2)  # (l1 - l2) / 2
    l1, l2 = 0.5 * (cxx + cyy) + half_diff, 0.5 * (cxx + cyy) - half_diff
    a, b = anatomy.silhouette_sd()
    # The blur's variance: the across variance beyond the body's own (b L)^2, solved
    # with l1 = (a L)^2 + blur; at most MAX_BLUR_VAR (the rest is legs).
    blur = np.clip((a * a * l2 - b * b * l1) / (a * a - b * b), 0.0, MAX_BLUR_VAR)
    length = np.sqrt(np.maximum(l1 - blur, 0.0)) / a
    ok = px.good & (bc(lab, None, n) >= 3)
    return px.area[ok], length[ok]


def median_length(
    pixels: Iterable[_Pixels | None], areas: tuple[float, float], floor: float = 0.1
) -> float:
    """The median body length (px) of the blobs of ``pixels`` (frames gathered with
    ``peak_fraction=0``) whose area lies within ``areas`` (working px^2, exclusive;
    all blobs when none does), by :func:`axis_lengths` (pixels below ``floor`` of
    their blob's peak contrast left out)."""
    got = [np.stack(axis_lengths(p, floor)) for p in pixels if p is not None]
    a, length = np.concatenate(got, axis=1) if got else np.zeros((2, 0))
    typical = (a > areas[0]) & (a < areas[1])
    return float(np.median(length[typical] if typical.any() else length))


def typical_area(area: np.ndarray) -> float:
    """The typical single animal's blob area (the units of ``area``): the mode of the
    areas, found by trimming to a factor 2.5 around the median until it settles,
    starting from the blob that holds the median foreground pixel (the area-weighted
    median), so that many small specks (texture, reflections) do not outvote a few
    animals and clumps of touching animals fall outside."""
    ref = _weighted_median(area, area)
    for _ in range(20):
        sel = (area > ref / 2.5) & (area < ref * 2.5)
        new = float(np.median(area[sel]))
        if new == ref:
            break
        ref = new
    return ref


def _weighted_median(x: np.ndarray, w: np.ndarray) -> float:
    """The value below which half of the total weight ``w`` lies."""
    order = np.argsort(x)
    cw = np.cumsum(w[order])
    return float(x[order][np.searchsorted(cw, 0.5 * cw[-1])])


def _moments_pose(
    x: np.ndarray,
    y: np.ndarray,
    w: np.ndarray,
    lab: np.ndarray,
    n: int,
    length: float,
    widen: float = 0.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Poses of many single-ant blobs at once from their weighted pixels.

    ``length`` is the expected body length and ``widen`` how far each end of a
    silhouette reaches beyond the ant (px).  Returns points ``(n, 3, 2)``, head
    confidence ``(n,)``, silhouette span ``(n,)`` and a valid flag ``(n,)``, indexed
    by label.

    Method: the principal axis of the contrast-weighted pixels is the body axis; the
    silhouette is skewed towards the thin head (the gaster is the widest part, so most
    pixels sit at the back), which orients it, with a confidence ``0.5 + 0.5
    tanh(|skew| / 0.3)``; head and tail are placed from the silhouette's two ends by the
    anatomy (:mod:`~thermoswarm.tracking.anatomy`) and the body point is the mean of the
    two placements.
    """
    bc = np.bincount
    m0 = bc(lab, w, n)
    cnt = bc(lab, None, n).astype(np.float64)
    valid = cnt >= 3
    s0 = np.where(m0 > 0, m0, 1.0)
    mx = bc(lab, w * x, n) / s0
    my = bc(lab, w * y, n) / s0
    dx = x - mx[lab]
    dy = y - my[lab]
    cxx = bc(lab, w * dx * dx, n) / s0
    cyy = bc(lab, w * dy * dy, n) / s0
    cxy = bc(lab, w * dx * dy, n) / s0
    ang = 0.5 * np.arctan2(2 * cxy, cxx - cyy)
    ux, uy = np.cos(ang), np.sin(ang)
    t = dx * ux[lab] + dy * uy[lab]
    c1 = np.where(cnt > 0, cnt, 1.0)
    e1 = bc(lab, t, n) / c1
    e2 = bc(lab, t * t, n) / c1
    e3 = bc(lab, t**3, n) / c1
    m2 = e2 - e1**2
    m3 = e3 - 3 * e1 * e2 + 2 * e1**3
    skew = m3 / np.maximum(m2, 1e-12) ** 1.5
    sign = np.where(skew < 0, -1.0, 1.0)
    lo = np.full(n, np.inf)
    hi = np.full(n, -np.inf)
    np.minimum.at(lo, lab, t)
    np.maximum.at(hi, lab, t)
    lo, hi = np.where(sign > 0, lo, -hi), np.where(sign > 0, hi, -lo)
    lo = np.where(valid, lo, 0.0) - 0.5
    hi = np.where(valid, hi, 0.0) + 0.5
    ux, uy = ux * sign, uy * sign
    front, back = hi - widen, lo + widen
    # Each ant's own length from its silhouette, within 25 % of the expected one.
    L = np.clip((front - back) / (anatomy.FRONT - anatomy.BACK), 0.75 * length, 1.25 * length)
    s_body = 0.5 * ((front - anatomy.FRONT * L) + (back - anatomy.BACK * L))
    offs = s_body[:, None] + anatomy.KEYPOINT_OFFSETS[None, :] * L[:, None]  # (n, 3)
    pts = np.stack([mx[:, None] + offs * ux[:, None], my[:, None] + offs * uy[:, None]], -1)
    hc = 0.5 + 0.5 * np.tanh(np.abs(skew) / 0.3)
    return pts, hc, hi - lo, valid


def _split(
    px: np.ndarray, w: np.ndarray, k: int, length: float, init: np.ndarray | None, iters: int = 8
) -> list[np.ndarray]:
    """Split the weighted pixels of touching or crossing ants into ``k`` groups.

    Each ant is modelled as a segment of length ``0.6 length`` (its dark axis from
    gaster to head); pixels go to the nearest segment, and each segment is refitted to
    its pixels (weighted mean and principal axis) -- k-means with segments instead of
    points, which separates ants lying side by side, end to end or across each other.
    Segments start from ``init`` poses ``(m, 3, 2)`` (the tracker's predictions or one
    point per gaster; head/tail may be NaN), completed by points spread along the
    blob's principal axis.
    """
    sw = w.sum()
    mean = (px * w[:, None]).sum(0) / sw
    d = px - mean
    cov = (d * w[:, None]).T @ d / sw
    _, evecs = np.linalg.eigh(cov)
    u0 = evecs[:, -1]
    t0 = d @ u0
    qs = np.quantile(t0, (np.arange(k) + 0.5) / k)
    centres = mean[None, :] + qs[:, None] * u0[None, :]
    dirs = np.repeat(u0[None, :], k, axis=0)
    if init is not None:
        m = min(len(init), k)
        centres[:m] = init[:m, 1]
        ax = init[:m, 0] - init[:m, 2]
        norm = np.linalg.norm(ax, axis=1)
        ok = np.isfinite(norm) & (norm > 1e-6)
        dirs[:m][ok] = ax[ok] / norm[ok, None]
    half = 0.3 * length
    lab = np.full(px.shape[0], -1)
    x, y = px[:, 0], px[:, 1]
    for _ in range(iters):
        rx = x[:, None] - centres[None, :, 0]
        ry = y[:, None] - centres[None, :, 1]
        t = np.clip(rx * dirs[None, :, 0] + ry * dirs[None, :, 1], -half, half)
        dist = (rx - t * dirs[None, :, 0]) ** 2 + (ry - t * dirs[None, :, 1]) ** 2
        new = dist.argmin(1)
        if np.array_equal(new, lab):
            break
        lab = new
        # Refit every segment at once: weighted mean and principal axis (closed form).
        m0 = np.bincount(lab, w, k)
        okk = m0 > 0
        s0 = np.where(okk, m0, 1.0)
        cx = np.bincount(lab, w * x, k) / s0
        cy = np.bincount(lab, w * y, k) / s0
        dx, dy = x - cx[lab], y - cy[lab]
        a = np.bincount(lab, w * dx * dx, k) / s0
        b = np.bincount(lab, w * dx * dy, k) / s0
        cc = np.bincount(lab, w * dy * dy, k) / s0
        centres[okk, 0], centres[okk, 1] = cx[okk], cy[okk]
        disc = np.sqrt(np.maximum((a - cc) ** 2 / 4 + b * b, 0.0))
        elong = okk & (disc > 0.1 * (a + cc))
        ang = 0.5 * np.arctan2(2 * b, a - cc)
        dirs[elong, 0], dirs[elong, 1] = np.cos(ang[elong]), np.sin(ang[elong])
    return [np.flatnonzero(lab == j) for j in range(k)]


#: A split part's end is in contact with another ant of the blob when another part's
#: pixel lies within this many body lengths of it (a quarter body length: the gap
#: between two touching ants' silhouettes is a pixel or two, while the far end of an
#: ant lying end to end with another is a body length away from it).
FREE_END_RADIUS = 0.25


def _from_free_end(
    xy: np.ndarray, gl: np.ndarray, p: np.ndarray, valid: np.ndarray, length: float, widen: float
) -> np.ndarray:
    """The poses ``p`` ``(m, 3, 2)`` of a split blob's parts, each part with exactly one
    end in contact with another part re-placed from its other (free) end.

    Where two ants touch, the pixels at the contact go to one of them, so the other's
    silhouette is cut short at that end; :func:`_moments_pose` places the body point
    from both ends of the silhouette, which moves it by half the cut along the body
    axis (on the synthetic 1080p video, the along-axis error of split parts: median
    0.9 px, 90th percentile 3.6 px, against 0.45 / 1.1 px for single ants).  The free
    end is whole: the part is placed from it with the expected ``length`` (px; the
    silhouette reaching ``widen`` px beyond the ant).  Parts with both ends or neither
    in contact (side by side, crossing at the middle) keep their pose.  ``xy``
    ``(n, 2)``: the blob's pixels (px), ``gl`` their part, ``valid`` the parts measured.
    """
    out = p.copy()
    offsets = anatomy.KEYPOINT_OFFSETS[:, None] * length
    r2 = (FREE_END_RADIUS * length) ** 2
    for j in np.flatnonzero(valid):
        axis = p[j, 0] - p[j, 2]  # tail to head: the front of the silhouette
        norm = float(np.hypot(axis[0], axis[1]))
        mine = gl == j
        others = xy[~mine]
        if not (norm > 1e-9 and others.size):
            continue
        u = axis / norm
        t = (xy[mine] - p[j, 1]) @ u
        hi, lo = float(t.max()) + 0.5, float(t.min()) - 0.5  # as _moments_pose
        near_front = bool(np.any(((others - (p[j, 1] + hi * u)) ** 2).sum(1) < r2))
        near_back = bool(np.any(((others - (p[j, 1] + lo * u)) ** 2).sum(1) < r2))
        if near_front == near_back:
            continue
        if near_front:  # the back is free: back = body + BACK length - widen
            body = lo - (anatomy.BACK * length - widen)
        else:  # the front is free: front = body + FRONT length + widen
            body = hi - (anatomy.FRONT * length + widen)
        out[j] = p[j, 1] + (body + offsets) * u
    return out


def spatial_response(grey: np.ndarray, diameter: float, light: bool) -> np.ndarray:
    """How far each pixel of ``grey`` (float32) stands out of its own surroundings: the
    frame against its :func:`picture_background` (a grey top-hat for ``light``
    animals, a black-hat for dark ones, over a disc of ``diameter`` px), which holds no
    animal whether it moves or not (unlike a background learned over time)."""
    bg = picture_background(grey, diameter, light)
    return grey - bg if light else bg - grey


#: The widest disc (px) a grey opening or closing is computed over: larger ones on a
#: frame shrunk to keep it this wide (the cost grows with the disc).
_MAX_DISC = 41


def picture_background(grey: np.ndarray, diameter: float, light: bool) -> np.ndarray:
    """The spatial background of ``grey`` (float32, returned at its size): a grey
    opening (``light`` animals) or closing (dark ones) over a disc of ``diameter`` px,
    which removes every brighter (darker) thing narrower than the disc, animals
    included, moving or not.  Over a frame shrunk (area averaging) to keep the disc at
    most :data:`_MAX_DISC` px, then enlarged back (bilinear) and widened by a
    shrunk pixel toward the animals' side (a dilation for light animals, an erosion
    for dark ones), so that the steps it blurred are not foreground along their edge."""
    import cv2

    # Shrunk only where the disc's kernel would be wider than _MAX_DISC px: a diameter
    # a hair over it (a float's rounding) is not worth a resampled frame.
    shrink = _MAX_DISC / diameter if int(diameter) > _MAX_DISC else 1.0
    small = grey
    if shrink < 1:
        small = cv2.resize(grey, None, fx=shrink, fy=shrink, interpolation=cv2.INTER_AREA)
    k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (int(diameter * shrink) | 1,) * 2)
    bg = cv2.morphologyEx(small, cv2.MORPH_OPEN if light else cv2.MORPH_CLOSE, k)
    if shrink < 1:
        bg = cv2.resize(bg, grey.shape[::-1], interpolation=cv2.INTER_LINEAR)
        r = math.ceil(1 / shrink)
        bg = (cv2.dilate if light else cv2.erode)(bg, np.ones((2 * r + 1,) * 2, np.uint8))
    return bg.astype(np.float32, copy=False)


def parts_at(resp: np.ndarray, at: np.ndarray) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    """The connected parts (8-connected) of ``resp`` above half its median at the pixels
    ``at`` ``(n, 2)`` (x, y; inside the image): OpenCV's ``(n, labels, stats,
    centroids)``, label 0 the rest."""
    import cv2

    own = float(np.median(resp[at[:, 1], at[:, 0]]))
    mask = (resp > 0.5 * own).astype(np.uint8)
    return cv2.connectedComponentsWithStats(mask, connectivity=8)
