"""benchmarks/bench_tracking_real.py: the ground truth it scores against (MOTChallenge
"ignore" rows, MOT15's layout) and the frame rate it reads from ``seqinfo.ini``."""

from __future__ import annotations

import numpy as np
from tracking_fixtures import bench_module


def _bench():
    return bench_module("bench_tracking_real")


def test_ground_truth_drops_ignored_rows_and_reads_mot15_world_columns():
    b = _bench()
    gt = np.array(
        [
            [1, 1, 10, 10, 5, 9, 1, -4.2, 11.9, 0.7],  # MOT15: world x, y, z
            [1, 2, 30, 10, 5, 9, 0, -3.1, 16.3, 0.5],  # ignored
            [2, 1, 11, 10, 5, 9, 1, 2.0, 7.0, 1.0],
        ]
    )
    got = b.considered_gt(gt, mot15=True)
    assert got[:, 0].tolist() == [1, 2] and got[:, 1].tolist() == [1, 1]
    assert np.all(got[:, 7] == 1)  # every MOT15 row is of class 1 (pedestrian)
    # MOT17 layout: column 8 is the class, kept (a distractor stays a distractor).
    mot17 = gt.copy()
    mot17[:, 7:10] = [[1, 1, 0.9], [1, 1, 0.9], [7, 1, 0.9]]
    assert b.considered_gt(mot17)[:, 7].tolist() == [1, 7]


def test_frame_rate_comes_from_seqinfo_else_the_default(tmp_path):
    b = _bench()
    (tmp_path / "seq").mkdir()
    assert b.seq_fps(tmp_path / "seq", 25.0) == 25.0
    (tmp_path / "seq" / "seqinfo.ini").write_text("[Sequence]\nname=seq\nframeRate=7\n")
    assert b.seq_fps(tmp_path / "seq", 25.0) == 7.0
