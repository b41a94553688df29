"""Exact agreement with TrackEval where the per-frame assignment ties (issue 37).

Two ground-truth objects on one box make two assignments of the same total IoU; the
Hungarian step then decides on the last bits of the IoU matrix, so the scorer must
compute IoU in TrackEval's arithmetic (right = left + width, area = (right - left) x
(bottom - top)), not width x height, to count the same identity switches.
"""

from __future__ import annotations

import numpy as np
import pytest
from tracking_fixtures import bench_module

from thermoswarm.tracking.anatomy import box_iou
from thermoswarm.tracking.evaluate import evaluate_tables

#: Ground-truth objects 1 and 2 share box X in frame 3; predictions 11 and 12 overlap
#: it by IoU 0.593 and 0.831.
X = (182.9, 62.9, 20.3, 10.5)
P = (183.9, 61.9, 18.3, 8.5)
Q = (182.9, 62.9, 22.3, 9.5)


def _row(frame, ident, box):
    return [frame, ident, *box, 1.0, 1.0, 1.0, -1.0]


def _tie_tables() -> tuple[np.ndarray, np.ndarray]:
    """Frame 1: gt 1 and 2 matched to predictions 11 and 12 (boxes equal).  Frame 2:
    only gt 3 and prediction 13 (so 1 and 2 have no match in the previous frame and
    no continuity bonus in frame 3).  Frame 3: gt 1 and 2 on the same box X,
    predictions 11 and 12 near it: 1->11, 2->12 and 1->12, 2->11 tie exactly."""
    gt = [_row(1, 1, (10, 10, 20, 10)), _row(1, 2, (60, 10, 20, 10)),
          _row(2, 3, (110, 10, 20, 10)), _row(3, 1, X), _row(3, 2, X)]  # fmt: skip
    pred = [_row(1, 11, (10, 10, 20, 10)), _row(1, 12, (60, 10, 20, 10)),
            _row(2, 13, (110, 10, 20, 10)), _row(3, 11, P), _row(3, 12, Q)]  # fmt: skip
    return np.array(gt, float), np.array(pred, float)


def _bench():
    return bench_module("bench_tracking_real")


def test_tied_assignment_is_broken_as_trackeval_breaks_it():
    """Hand-derived: with TrackEval's IoU bits, scipy's Hungarian step picks 1->12 and
    2->11 in frame 3 (what TrackEval 1.3 reports), two switches against frame 1: MOTA
    (5 - 0 - 2) / 5.  The width x height IoU picked 1->11, 2->12: 0 switches, MOTA 1."""
    gt, pred = _tie_tables()
    # the tie is exact: both rows of frame 3 are the same, in any arithmetic
    s = box_iou(np.array([X, X]), np.array([P, Q]))
    assert np.array_equal(s[0], s[1]) and 0.5 < s[0, 0] < s[0, 1]
    m = evaluate_tables(gt, pred)
    assert (m["tp"], m["fp"], m["fn"], m["idsw"]) == (5, 0, 0, 2)
    assert m["mota"] == pytest.approx(0.6, abs=1e-12)
    assert m["frag"] == 2 and m["mt"] == 3  # 1 and 2 resume after frame 2


def test_iou_is_trackevals_bit_for_bit():
    trackeval = pytest.importorskip("trackeval")
    from thermoswarm.tracking.evaluate import _iou

    calc = trackeval.datasets._base_dataset._BaseDataset._calculate_box_ious
    rng = np.random.default_rng(37)
    a = np.round(np.c_[rng.uniform(0, 3000, (40, 2)), rng.uniform(0, 130, (40, 2))], 3)
    b = np.round(a[rng.permutation(40)] + rng.normal(0, 8, (40, 4)), 3)
    a[0, 2] = 0.0  # a box of zero width
    for x, y in [(a, b), (np.array([X, X]), np.array([P, Q]))]:
        assert np.array_equal(_iou(x, y), calc(x, y, box_format="xywh"))


def test_tie_case_agrees_with_trackeval_and_the_check_is_strict(tmp_path):
    pytest.importorskip("trackeval")
    bench = _bench()
    gt, pred = _tie_tables()
    m = evaluate_tables(gt, pred)
    bench._trackeval_check(gt, pred, m, tmp_path / "a")  # raises on any difference
    # the check fails loudly on one switch too many, and on a float off by 1e-6
    with pytest.raises(AssertionError, match="idsw: ours 3 != TrackEval 2"):
        bench._trackeval_check(gt, pred, {**m, "idsw": 3}, tmp_path / "b")
    with pytest.raises(AssertionError, match="hota: ours"):
        bench._trackeval_check(gt, pred, {**m, "hota": m["hota"] + 1e-6}, tmp_path / "c")
