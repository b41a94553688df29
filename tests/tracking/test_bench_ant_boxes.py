"""benchmarks/bench_ant_boxes.py: the detections' frames renumbered as the ground
truth's (the files count from 1 and from 0), and the measure that shows it."""

from __future__ import annotations

import gzip

import numpy as np
from tracking_fixtures import bench_module


def _write(path, rows):
    with gzip.open(path, "wt") as f:
        np.savetxt(f, rows, delimiter=",", fmt="%.3f")


def test_detections_are_renumbered_as_the_ground_truths_frames(tmp_path):
    b = bench_module("bench_ant_boxes")
    # One ant walking 15 px a frame through frames 3558-3600 of the ground truth
    # (numbered from 0); the detector's file numbers the same video frames from 1.
    f = np.arange(3558, 3601)
    x = 100 + 15.0 * (f - 3558)
    gt = np.c_[f, np.ones(f.size), x, np.full(f.size, 50), np.full((f.size, 2), 70),
               np.ones(f.size), -np.ones((f.size, 3))]  # fmt: skip
    det = gt.copy()
    det[:, 0] += 1
    det[:, 1] = -1
    det[:, 2] += 2.0  # a detector's own small offset
    _write(tmp_path / b.GT, gt)
    _write(tmp_path / b.DETS["post09"], det)
    data = b.load_data(tmp_path, ["post09"])
    np.testing.assert_array_equal(data["post09"][:, 0], gt[:, 0])
    best = min(b.alignment(data, "post09"), key=lambda r: r[1])
    assert best[0] == 0 and best[1] == 2.0 and best[2] == 1.0
    # Read as the files are, the same measure finds the detections a frame late.
    raw = b.load_data(tmp_path, ["post09"], offset=0)
    by_offset = {o: med for o, med, _ in b.alignment(raw, "post09")}
    assert by_offset[1] == 2.0 and by_offset[0] == 13.0
