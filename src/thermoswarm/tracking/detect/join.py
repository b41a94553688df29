"""One animal, one detection: the two blobs of one body split at its waist, joined.

On small dark ants the thin waist (petiole) between mesosoma and gaster is often
lighter than the threshold, and one ant becomes two blobs, two detections and two
tracks (issue 32: 60 duplicate boxes on 705 ants).  :func:`join_split_bodies` merges
two blobs into one when their union has the shape of one body at the measured body
length ``length`` (a shape prior; moments weighted by the pixels' contrast):

* **size**: each blob is smaller than one ant (below ``0.85`` of the single-ant area
  ``area1``) and together they are one ant's area (``0.5`` to ``1.4 area1``: the waist
  is missing);
* **a body's shape**: the union is elongated as one ant (its standard deviations
  along and across its principal axis differ by :data:`_BODY` times at least; one
  split ant measured 3.3-4.9 on drawn 6.5-10 px ants, two halves of neighbours side
  by side mostly 2.4-3.4), and its length (four standard deviations along the axis) is
  ``0.95`` to ``1.35`` times one body's silhouette ``span`` (one split ant: 1.12-1.29);
* **one axis** (pose): a piece clearly elongated (standard deviations differing by
  :data:`_LONG` times: a head and mesosoma resolved) lies along the union's axis
  within 30 degrees, and the two pieces do not both lie across it (two halves of ants
  side by side do; one ant's gaster may, its front half does not).  On ants of 6-7 px
  the pieces are a few pixels and barely have an orientation: there the union's shape
  decides;
* **end to end**: along the axis the two blobs do not lie side by side (their
  extents overlap by at most a quarter of the shorter one), the gap between them is
  at most ``0.5`` body length, their centres within ``0.25`` body length of the axis,
  and the union is at most ``0.8`` body length wide.

Two whole ants have two ants' area and fail the size test (and a blob of two ants is
split again by area afterwards); two halves of two ants side by side fail the shape
and axis tests.  Each blob joins at most one other.  Where a blob could join several
(two split ants side by side: the two gasters, end to end, also look like one small
body), the joins are chosen to join as many blobs as possible, then with the
smallest gaps (an exact search per group of neighbouring blobs,
:func:`_best_matching`): each ant's own two halves, not one ant's gaster with its
neighbour's.  Lengths are in full-resolution px.

Limits (measured on the drawn stand-ins, ``tests/tracking/test_split_join.py``,
``benchmarks/bench_split_join.py``): when most ants of the frames the detector learns
from are split, their single-ant area is half an ant's and nothing is joined; two
split ants whose halves touch (side by side closer than about 0.6 body lengths, or
head to tail at 0.3 body lengths on 6-7 px ants) make merged blobs that joining does
not undo.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["join_split_bodies", "MAX_GAP_BL"]

#: The widest gap (body lengths) between the two blobs of one body.
MAX_GAP_BL = 0.5
#: The least ratio of the standard deviations along and across the union of one body.
_BODY = 3.2
#: The ratio of standard deviations from which a piece is elongated (has a direction).
_LONG = 1.9
#: Groups of candidate pairs larger than this are matched greedily (smallest gap first).
_EXACT_EDGES = 16


def _label_moments(px: Any) -> np.ndarray:
    """Contrast-weighted sums of all labels, ``(6, n)``: weight, x, y, xx, yy, xy."""
    bc, n, w = np.bincount, px.n, px.w
    lab, x, y = px.lab, px.fx, px.fy
    return np.stack([bc(lab, v, n) for v in (w, w * x, w * y, w * x * x, w * y * y, w * x * y)])


def _axes(mom: np.ndarray) -> tuple[np.ndarray, ...]:
    """Centres x, y (px), major and minor variances (px^2) and the major axes' angles
    (rad) of the moment sums ``mom`` (``(6, k)``)."""
    cnt, sx, sy, sxx, syy, sxy = mom
    mx, my = sx / cnt, sy / cnt
    cxx, cyy, cxy = sxx / cnt - mx * mx, syy / cnt - my * my, sxy / cnt - mx * my
    half = np.hypot(0.5 * (cxx - cyy), cxy)
    mean = 0.5 * (cxx + cyy)
    big, small = mean + half, np.maximum(mean - half, 1e-9)
    return mx, my, big, small, 0.5 * np.arctan2(2 * cxy, cxx - cyy)


def _shape_ok(mom: np.ndarray, pairs: np.ndarray, span: float) -> np.ndarray:
    """Which ``pairs`` (``(m, 2)`` labels) have the union and pieces of one body
    (module docstring: a body's shape, one axis), ``(m,)`` bool.

    One axis: every clearly elongated piece (standard deviations differing by
    :data:`_LONG` times: a head and mesosoma resolved) lies along the union's axis
    within 30 degrees, and not both lie across it (beyond 45 degrees, with axes that
    differ by 1.1 times at least): two halves side by side lie across the line that
    joins them, the front half of one ant along it."""
    _, _, big, small, ang = _axes(mom[:, pairs[:, 0]] + mom[:, pairs[:, 1]])
    long = 4 * np.sqrt(big)
    ok = (big >= _BODY**2 * small) & (long >= 0.95 * span) & (long <= 1.35 * span)
    across = np.zeros(len(pairs), np.int64)
    for k in (0, 1):
        _, _, pb, ps, pa = _axes(mom[:, pairs[:, k]])
        sin = np.abs(np.sin(pa - ang))
        ok &= ~((pb >= _LONG**2 * ps) & (sin > 0.5))
        across += (sin > math.sqrt(0.5)) & (pb >= 1.1**2 * ps)
    return ok & (across < 2)


def _gaps(px: Any, pairs: np.ndarray, mom: np.ndarray, length: float, span: float) -> np.ndarray:
    """The gap (px) between the two blobs of each of ``pairs`` (``(m, 2)`` labels)
    along their union's axis where they lie end to end as the two ends of one body
    (module docstring), else ``inf``; ``(m,)``, vectorised over the pairs' pixels."""
    mx, my, _, _, ang = _axes(mom[:, pairs[:, 0]] + mom[:, pairs[:, 1]])
    order = np.argsort(px.lab, kind="stable")
    bounds = np.searchsorted(px.lab[order], np.arange(px.n + 1))
    seg = pairs.ravel()  # piece k of pair k // 2
    lens = bounds[seg + 1] - bounds[seg]
    starts = np.concatenate([[0], np.cumsum(lens)[:-1]])
    idx = order[np.repeat(bounds[seg] - starts, lens) + np.arange(lens.sum())]
    pair = np.repeat(np.arange(seg.size) // 2, lens)
    dx, dy = px.fx[idx] - mx[pair], px.fy[idx] - my[pair]
    c, s = np.cos(ang)[pair], np.sin(ang)[pair]
    t, v = dx * c + dy * s, dy * c - dx * s
    lo = (np.minimum.reduceat(t, starts) - 0.5).reshape(-1, 2)
    hi = (np.maximum.reduceat(t, starts) + 0.5).reshape(-1, 2)
    off = np.abs(np.add.reduceat(v, starts) / lens).reshape(-1, 2)
    vlo = np.minimum.reduceat(v, starts).reshape(-1, 2).min(axis=1)
    vhi = np.maximum.reduceat(v, starts).reshape(-1, 2).max(axis=1)
    first = np.argmin(lo, axis=1)  # the piece behind along the axis
    rows = np.arange(len(pairs))
    lo1, hi1 = lo[rows, first], hi[rows, first]
    lo2, hi2 = lo[rows, 1 - first], hi[rows, 1 - first]
    gap = lo2 - hi1
    ok = (
        (np.maximum(hi1, hi2) - lo1 <= 1.4 * span)
        & (vhi - vlo + 1.0 <= 0.8 * length)
        & (np.minimum(hi1, hi2) - lo2 <= 0.25 * np.minimum(hi1 - lo1, hi2 - lo2))
        & (gap <= MAX_GAP_BL * length)
        & (off.max(axis=1) <= 0.25 * length)
    )
    return np.where(ok, np.maximum(gap, 0.0), np.inf)


def _exact(edges: list[int], inv: np.ndarray, gaps: np.ndarray) -> list[int]:
    """The most pairs of ``edges`` (indices of the node pairs ``inv``) that share no
    node, then the smallest sum of ``gaps``: an exhaustive search (few edges)."""
    best: tuple[int, float, list[int]] = (0, 0.0, [])

    def search(k: int, used: frozenset, picked: list[int], cost: float) -> None:
        nonlocal best
        if (len(picked), -cost) > (best[0], -best[1]):
            best = (len(picked), cost, list(picked))
        for j in range(k, len(edges)):
            e = edges[j]
            p, q = int(inv[e, 0]), int(inv[e, 1])
            if p not in used and q not in used:
                search(j + 1, used | {p, q}, [*picked, e], cost + gaps[e])

    search(0, frozenset(), [], 0.0)
    return best[2]


def _best_matching(pairs: np.ndarray, gaps: np.ndarray) -> list[int]:
    """Indices of ``pairs`` (``(m, 2)`` blob labels) to join: no blob twice, as many
    pairs as possible, then the smallest sum of ``gaps``; an exact search per
    connected group of pairs (greedy by gap in groups over ``_EXACT_EDGES`` pairs)."""
    nodes, inv = np.unique(pairs, return_inverse=True)
    inv = inv.reshape(-1, 2)
    root = list(range(len(nodes)))  # union-find over the blobs

    def find(i: int) -> int:
        while root[i] != i:
            root[i] = root[root[i]]
            i = root[i]
        return i

    for p, q in inv:
        root[find(int(p))] = find(int(q))
    groups: dict[int, list[int]] = {}
    for e in np.argsort(gaps, kind="stable"):
        groups.setdefault(find(int(inv[e, 0])), []).append(int(e))
    chosen: list[int] = []
    for edges in groups.values():
        if len(edges) == 1:
            chosen += edges
        elif len(edges) <= _EXACT_EDGES:
            chosen += _exact(edges, inv, gaps)
        else:
            used: set[int] = set()
            for e in edges:
                ends = {int(inv[e, 0]), int(inv[e, 1])}
                if not used & ends:
                    used |= ends
                    chosen.append(e)
    return chosen


def join_split_bodies(px: Any, area1: float, length: float, span: float, f: int = 1) -> int:
    """Merge the pairs of blobs that are the two ends of one body into one blob.

    Parameters
    ----------
    px
        One frame's blobs (:class:`~thermoswarm.tracking.detect.blobs._Pixels`),
        changed in place: the second blob of each pair is relabelled as the first,
        its area added, and marked not ``good``.
    area1
        The single-ant area (working-resolution px^2).
    length
        The body length (full-resolution px).
    span
        The expected silhouette length of one ant (full-resolution px).
    f
        The working resolution's downsampling (``px.labels`` is at ``1/f``).

    Returns
    -------
    int
        The number of pairs joined.
    """
    from scipy.spatial import cKDTree

    area = px.area
    small = np.flatnonzero(px.good & (area < 0.85 * area1))
    if small.size < 2:
        return 0
    mom = _label_moments(px)
    cnt = mom[0, small]
    small, cnt = small[cnt > 0], cnt[cnt > 0]
    if small.size < 2:
        return 0
    centres = np.column_stack([mom[1, small], mom[2, small]]) / cnt[:, None]
    pairs = cKDTree(centres).query_pairs(r=length, output_type="ndarray")
    if not len(pairs):
        return 0
    pairs = small[pairs]
    both = area[pairs].sum(axis=1)
    pairs = pairs[(both >= 0.5 * area1) & (both <= 1.4 * area1)]
    if len(pairs):
        pairs = pairs[_shape_ok(mom, pairs, span)]
    if not len(pairs):
        return 0
    gaps = _gaps(px, pairs, mom, length, span)
    ok = np.isfinite(gaps)
    pairs, gaps = pairs[ok], gaps[ok]
    if not len(pairs):
        return 0
    to = np.arange(px.n)
    chosen = _best_matching(pairs, gaps)
    h, w = px.labels.shape
    for p in chosen:
        a, b = (int(q) for q in pairs[p])
        to[b] = a
        px.area[a] += px.area[b]
        px.peak[a] = max(px.peak[a], px.peak[b])
        px.area[b], px.good[b] = 0.0, False
        # Relabel b as a in its box (working px; the dilated labels reach one further).
        on = px.lab == b
        x0, x1 = int(px.fx[on].min()) // f - 2, int(px.fx[on].max()) // f + 3
        y0, y1 = int(px.fy[on].min()) // f - 2, int(px.fy[on].max()) // f + 3
        box = slice(max(y0, 0), min(y1, h)), slice(max(x0, 0), min(x1, w))
        for arr in (px.labels, px.lab_d):
            sub = arr[box]
            sub[sub == b] = a
    if chosen:
        px.lab = to[px.lab]
    return len(chosen)
