"""One animal, one detection: ants split at the waist are joined, two ants are never
joined (issue 32: 60 duplicate boxes on 705 small dark ants on white).

Stand-ins drawn as the paper's ant (head, mesosoma and gaster ellipses,
:mod:`thermoswarm.tracking.anatomy`), dark on a white 640 x 360 frame with pixel
noise; a light band across the waist splits an ant in two blobs.  The detector
learns the background and the ants' size from 12 frames of the same kind of scene,
then each drawn ant is matched to a detection (body points within half a body length,
Hungarian): every ant found once, no duplicate.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from thermoswarm.tracking import anatomy
from thermoswarm.tracking.detect.classical import make_detector
from thermoswarm.tracking.detect.size import estimate_length_px

cv2 = pytest.importorskip("cv2")

W, H = 640, 360
GRID = [(x, y) for y in range(30, H - 20, 60) for x in range(32, W - 20, 64)]  # 60 cells
#: The along-body offset (body lengths) of two ants head to tail 0.3 body lengths apart.
HEAD_TO_TAIL = anatomy.FRONT - anatomy.BACK + 0.3


def draw_ant(img: np.ndarray, c, heading: float, length: float, gap: float = 0.0) -> None:
    """Draw one dark ant ``length`` px long (body point ``c`` px, ``heading`` rad); a
    light band ``gap`` px wide across the waist splits it in two blobs."""
    u = np.array([math.cos(heading), math.sin(heading)])
    deg = math.degrees(heading)
    for at, a, b in (anatomy.HEAD, anatomy.MESOSOMA, anatomy.GASTER):
        p = np.asarray(c) + at * length * u
        axes = tuple(int(round(v * length * 16)) for v in (a, b))
        centre = tuple(int(round(v * 16)) for v in p)
        cv2.ellipse(img, centre, axes, deg, 0, 360, 40, -1, cv2.LINE_AA, 4)
    if gap:
        v = np.array([-u[1], u[0]])
        mid = np.asarray(c) - 0.13 * length * u
        h, s = 0.5 * gap * u, 0.5 * length * v
        band = np.array([mid - h - s, mid + h - s, mid + h + s, mid - h + s])
        cv2.fillConvexPoly(img, np.round(band * 16).astype(np.int32), 235, cv2.LINE_AA, 4)


def frame(rng: np.random.Generator, ants: list[tuple]) -> np.ndarray:
    """A noisy white RGB frame with ``ants`` (``draw_ant``'s arguments) drawn."""
    img = np.full((H, W), 235, np.uint8)
    for ant in ants:
        draw_ant(img, *ant)
    noisy = img + rng.normal(0, 2.0, img.shape)
    return np.repeat(np.clip(noisy, 0, 255).astype(np.uint8)[..., None], 3, axis=2)


def scene(rng: np.random.Generator, n: int, lengths, split: float) -> list[tuple]:
    """``n`` ants in distinct cells of ``GRID``, lengths drawn from ``lengths`` (px),
    a share ``split`` of them split at the waist by a band 0.8-1.0 px wide."""
    ants = []
    for i in rng.choice(len(GRID), n, replace=False):
        length = float(rng.uniform(*lengths))
        gap = float(rng.uniform(0.8, 1.0)) if rng.random() < split else 0.0
        c = np.add(GRID[i], rng.uniform(-8, 8, 2))
        ants.append((c, float(rng.uniform(-np.pi, np.pi)), length, gap))
    return ants


def score(det, img: np.ndarray, truth: np.ndarray, length: float) -> tuple[int, int, int]:
    """Ants found, duplicates (further detections within one body length of an ant)
    and other detections, of the drawn body points ``truth`` (``(n, 2)`` px)."""
    body = copy.deepcopy(det).detect(img).points[:, 1, :]  # the background stays
    d = np.linalg.norm(body[:, None, :] - truth[None, :, :], axis=2)
    r, c = linear_sum_assignment(np.where(d <= 0.5 * length, d, 1e6))
    hit = d[r, c] <= 0.5 * length
    rest = np.setdiff1d(np.arange(len(body)), r[hit])
    dup = int(np.sum(d[rest].min(axis=1, initial=np.inf) <= length)) if len(truth) else 0
    return int(hit.sum()), dup, len(rest) - dup


def prepared(
    length: float | None, lengths, split: float, seed: int = 32, join: bool = True
):  # fmt: skip
    """A classical detector that has learned the background and size from 12 frames of
    30 ants (``lengths``, ``split`` as in :func:`scene`), told the body length
    ``length`` px or, when ``None``, measuring it as ``track`` does without a scale
    (:func:`~thermoswarm.tracking.detect.size.estimate_length_px`); ``join``:
    its ``join_split``."""
    rng = np.random.default_rng(seed)
    frames = [frame(rng, scene(rng, 30, lengths, split)) for _ in range(12)]
    opts = {"join_split": join}
    if length is None:
        length = estimate_length_px(frames, opts).length_px
    px_per_mm = length / anatomy.ANT_LENGTH_MM
    det = make_detector("classical", px_per_mm=px_per_mm, options=opts)
    det.prepare(frames)
    return det


@pytest.fixture(scope="module", params=[10.0, 6.5], ids=["10px", "6.5px"])
def detector(request):
    length = request.param
    return prepared(length, (length, length), 0.0), length


@pytest.fixture(scope="module")
def detector10():
    return prepared(10.0, (10.0, 10.0), 0.0)


@pytest.fixture(scope="module")
def detector10_off():
    return prepared(10.0, (10.0, 10.0), 0.0, join=False)


def _pairs(length: float, offset_bl: tuple[float, float], gap: float):
    """24 pairs of ants ``length`` px long, the second at ``offset_bl`` (along, across
    the first's heading; body lengths), both split by a waist band ``gap`` px wide."""
    rng = np.random.default_rng(5)
    ants = []
    for i in rng.choice(len(GRID), 24, replace=False):
        c, h = np.add(GRID[i], rng.uniform(-4, 4, 2)), float(rng.uniform(-np.pi, np.pi))
        u, v = np.array([math.cos(h), math.sin(h)]), np.array([-math.sin(h), math.cos(h)])
        ants.append((c, h, length, gap))
        ants.append((c + length * (offset_bl[0] * u + offset_bl[1] * v), h, length, gap))
    return frame(rng, ants), np.array([a[0] for a in ants])


def test_ants_split_at_the_waist_are_one_detection_each(detector):
    """48 ants, 3 body lengths apart, split by a band of 0.8 px (6.5 px ants) or 1 px
    (10 px): one detection each (without joining: 9 and 44 duplicates)."""
    det, length = detector
    img, truth = _pairs(length, (0.0, 3.0), 0.8 if length < 8 else 1.0)
    assert score(det, img, truth, length) == (len(truth), 0, 0)


@pytest.mark.parametrize(
    "offset", [(0.0, 0.5), (HEAD_TO_TAIL, 0.0), (0.2, 0.6)],
    ids=["side-by-side-0.5", "head-to-tail-0.3", "staggered"],
)  # fmt: skip
def test_two_whole_ants_are_never_joined(detector, offset):
    """Two ants 0.5 body lengths apart side by side (centres), 0.3 body lengths head to
    tail (gap), or staggered: two detections.  (A joiner without the size rule joins
    them; at the default ``split_area`` the joined blob is split again by its area,
    at the photo series' 2.5 it is not: 5 of these 6 fail.)"""
    det, length = detector
    img, truth = _pairs(length, offset, 0.0)
    assert score(det, img, truth, length) == (len(truth), 0, 0)


@pytest.mark.parametrize(
    "offset", [(0.0, 0.7), (HEAD_TO_TAIL, 0.0), (0.2, 0.6)],
    ids=["side-by-side-0.7", "head-to-tail-0.3", "staggered"],
)  # fmt: skip
def test_two_split_ants_are_two_detections(detector10, offset):
    """Both ants of a pair split (four blobs, of which one ant's gaster and its
    neighbour's front, or the two gasters, also look like one body): each joined with
    its own other half.  (At 0.5 body lengths side by side the two gasters touch and
    are one blob: not a case joining can mend.)"""
    img, truth = _pairs(10.0, offset, 1.0)
    assert score(detector10, img, truth, 10.0) == (len(truth), 0, 0)


@pytest.mark.parametrize(
    "offset", [(0.0, 0.5), (HEAD_TO_TAIL, 0.0), (0.2, 0.6)],
    ids=["side-by-side-0.5", "head-to-tail-0.3", "staggered"],
)  # fmt: skip
def test_pairs_of_small_ants_lose_nothing_to_joining(detector10, detector10_off, offset):
    """Ants 0.7 of the learned length (7 px; a minor worker: each below one ant's area,
    two of them one ant's area) in pairs: joining finds as many as without it (two
    small ants side by side are not one body).  Without joining this detector finds
    24, 14 and 32 of the 48 (it merges the close pairs into one blob: not joining's
    business)."""
    img, truth = _pairs(7.0, offset, 0.0)
    on, off = score(detector10, img, truth, 7.0), score(detector10_off, img, truth, 7.0)
    assert on[0] == off[0]


def test_duplicates_on_a_scene_of_tiny_ants():
    """60 ants 6-7 px long, a third split at the waist, the size measured from such
    frames without a scale (as ``track`` does; 6.77 px): at most 3 % duplicates, 95 %
    found (issue 32's goal), over 4 frames of 60 (without joining: 45 duplicates)."""
    det = prepared(None, (6.0, 7.0), 1 / 3)
    rng = np.random.default_rng(60)
    found = dup = ants = 0
    for _ in range(4):
        drawn = scene(rng, 60, (6.0, 7.0), 1 / 3)
        f, d, _ = score(det, frame(rng, drawn), np.array([a[0] for a in drawn]), 6.5)
        found, dup, ants = found + f, dup + d, ants + len(drawn)
    assert dup <= 0.03 * ants
    assert found >= 0.95 * ants


@pytest.fixture(scope="module")
def detector20():
    return prepared(20.0, (20.0, 20.0), 0.0)


@pytest.mark.parametrize(
    ("offset", "turn"),
    [((0.9, 0.0), 0.0), ((0.8, 0.0), 0.0), ((0.55, 0.3), math.pi / 2)],
    ids=["end-to-end", "end-to-end-overlapping", "T"],
)
def test_touching_ants_are_placed_from_their_free_ends(detector20, offset, turn):
    """32 ants 20 px long in pairs that touch end to end (the second 0.9 or 0.8 body
    lengths ahead on the first's axis) or in a T (the second turned 90 degrees, its
    gaster against the first's side): each pair is one blob, split in two, and each
    part's silhouette is cut short where it touches the other.  Placed from both ends
    of the cut silhouette the body points were off by 1.0-1.6 px (median), 1.9-2.9 px
    (90th percentile) along the body; placed from the free end, under 0.5 px."""
    rng = np.random.default_rng(5)
    cells = [(x, y) for y in range(40, H - 30, 80) for x in range(40, W - 30, 90)]
    ants = []
    for i in rng.choice(len(cells), 16, replace=False):
        c, h = np.add(cells[i], rng.uniform(-4, 4, 2)), float(rng.uniform(-np.pi, np.pi))
        u, v = np.array([math.cos(h), math.sin(h)]), np.array([-math.sin(h), math.cos(h)])
        ants.append((c, h, 20.0, 0.0))
        ants.append((c + 20.0 * (offset[0] * u + offset[1] * v), h + turn, 20.0, 0.0))
    truth = np.array([a[0] for a in ants])
    d = copy.deepcopy(detector20).detect(frame(rng, ants))
    assert np.all(d.scores < 0.8)  # every ant a part of a split blob
    err = np.linalg.norm(d.points[:, None, 1, :] - truth[None, :, :], axis=2)
    r, c = linear_sum_assignment(err)
    assert len(r) == len(truth)
    assert np.quantile(err[r, c], 0.9) < 1.0
