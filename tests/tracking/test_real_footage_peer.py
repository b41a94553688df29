"""benchmarks/bench_real_footage.py on real labelled footage: the held-out block by frame
number, reading part of a long SLEAP file, and a peer's 2-node SLEAP predictions scored
on the same frames (its own tracks).  Files are written here in the layout of SLEAP's
``tests/data/tracks`` (13-node labels, 2-node head-thorax predictions); the measured
numbers on the real files are in docs/real_footage.md."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sleap_io as sio
from tracking_fixtures import bench_module

from thermoswarm.tracking.train import fit as tr

L_PX = 100.0  # body length of the tests, px


@pytest.fixture(scope="module")
def bench():
    return bench_module("bench_real_footage")


def _ant(x: float, y: float) -> np.ndarray:
    """Head, thorax, abdomen of an animal facing +x, head-tail 0.66 L."""
    return np.array([[x + 35, y], [x, y], [x - 31, y]], float)


def _labelled(n_frames: int) -> tr.LabeledFrames:
    """Two animals walking right on 400x400 frames, tracks 0 and 1, frames 0.."""
    f = np.zeros((400, 400, 3), np.uint8)
    pts = [np.stack([_ant(60 + 2 * k, 100), _ant(60 + 2 * k, 300)]) for k in range(n_frames)]
    keys = [(0, k) for k in range(n_frames)]
    tracks = [np.array([0, 1])] * n_frames
    return tr.LabeledFrames([f] * n_frames, pts, 1.0, keys=keys, tracks=tracks)


def _peer_file(path: Path, data: tr.LabeledFrames, swap_at: int | None) -> Path:
    """A SLEAP file of 2-node (head, thorax) predictions equal to the labels; from
    frame ``swap_at`` on the two predicted tracks are exchanged (an identity switch)."""
    skel = sio.Skeleton(["head", "thorax"])
    video = sio.Video(filename="clip.mp4", open_backend=False)
    tracks = [sio.Track("female"), sio.Track("male")]
    lfs = []
    for k, p in enumerate(data.points):
        order = [1, 0] if swap_at is not None and k >= swap_at else [0, 1]
        insts = [
            sio.PredictedInstance.from_numpy(p[j, :2], skeleton=skel, score=0.9, track=tracks[t])
            for j, t in enumerate(order)
        ]
        lfs.append(sio.LabeledFrame(video=video, frame_idx=k, instances=insts))
    labels = sio.Labels(labeled_frames=lfs, videos=[video], skeletons=[skel], tracks=tracks)
    sio.save_slp(labels, str(path), embed=False, verbose=False)
    return path


def test_held_out_block_starts_at_the_given_frame(bench):
    data = _labelled(12)
    pool, test = bench.split_frames(data, 0.3, seed=0, test_from=8)
    assert sorted(pool) == list(range(8))
    assert test == [8, 9, 10, 11]


def test_a_perfect_two_node_peer_scores_one_and_has_no_tail(bench, tmp_path):
    data = _labelled(10)
    _, test = bench.split_frames(data, 0.3, seed=0, test_from=4)
    runs = bench.consecutive_runs(data, test)
    assert runs == [test]
    peer = _peer_file(tmp_path / "pred.slp", data, swap_at=None)
    dets, tables = bench.read_peer(peer, data, test, runs, L_PX, ["head", "thorax", "abdomen"])
    assert all(np.isnan(dets[i].points[:, 2]).all() for i in test)
    m = bench.score([dets[i] for i in test], data, test, L_PX)
    assert (m["tp"], m["fp"], m["fn"]) == (2 * len(test), 0, 0)
    assert m["body_error_median_px"] == 0.0 and np.isnan(m["tail_error_median_px"])
    t = bench.mota(None, data, runs, L_PX, 30.0, tables=tables)
    assert t["mota"] == 1.0 and t["idf1"] == 1.0 and t["idsw"] == 0


def test_a_peer_that_swaps_identities_is_charged_for_it(bench, tmp_path):
    data = _labelled(10)
    _, test = bench.split_frames(data, 0.3, seed=0, test_from=2)
    runs = bench.consecutive_runs(data, test)
    peer = _peer_file(tmp_path / "pred.slp", data, swap_at=6)
    _, tables = bench.read_peer(peer, data, test, runs, L_PX, ["head", "thorax", "abdomen"])
    t = bench.mota(None, data, runs, L_PX, 30.0, tables=tables)
    # 8 frames of 2 animals; both switch once at frame 6: 2 switches, IDF1 below 1.
    assert t["n_gt"] == 16 and t["idsw"] == 2
    assert t["mota"] == pytest.approx(1 - 2 / 16)
    assert t["idf1"] < 0.8


def _user_file(path: Path, n_frames: int) -> Path:
    """SLEAP user labels (head, thorax, abdomen, a wing) of two tracked animals; the
    second animal of frame 3 has no track (not ground truth for MOT)."""
    skel = sio.Skeleton(["head", "thorax", "abdomen", "wingL"])
    video = sio.Video(filename="clip.mp4", open_backend=False)
    tracks = [sio.Track("female"), sio.Track("male")]
    lfs = []
    for k in range(n_frames):
        insts = []
        for j in range(2):
            p = np.vstack([_ant(60 + 2 * k, 100 + 200 * j), [[50.0, 90.0]]])
            trk = None if (k, j) == (3, 1) else tracks[j]
            insts.append(sio.Instance.from_numpy(p, skeleton=skel, track=trk))
        lfs.append(sio.LabeledFrame(video=video, frame_idx=k, instances=insts))
    labels = sio.Labels(labeled_frames=lfs, videos=[video], skeletons=[skel], tracks=tracks)
    sio.save_slp(labels, str(path), embed=False, verbose=False)
    return path


def test_keep_frames_and_ground_truth_of_tracked_labels(bench, tmp_path):
    src = _user_file(tmp_path / "clip.slp", 10)
    (tmp_path / "sub").mkdir()
    sub = bench.keep_frames(src, "0:4:2,8:", tmp_path / "sub")
    kept = [lf.frame_idx for lf in sio.load_slp(str(sub)).labeled_frames]
    assert kept == [0, 2, 8, 9]
    out = tmp_path / "gt.txt"
    assert bench.write_gt_mot(src, ["head", "thorax", "abdomen"], L_PX, out) == 0
    gt = np.loadtxt(out, delimiter=",")
    assert gt.shape == (19, 9)  # 2 x 10 boxes less the untracked one
    assert not ((gt[:, 0] == 4) & (gt[:, 1] == 2)).any()
    # the box is centred on the thorax: frame 1 (video frame 0), track 1 at (60, 100)
    row = gt[(gt[:, 0] == 1) & (gt[:, 1] == 1)][0]
    assert row[2] + row[4] / 2 == pytest.approx(60.0)
    assert row[3] + row[5] / 2 == pytest.approx(100.0)
