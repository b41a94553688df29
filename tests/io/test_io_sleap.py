"""SLEAP readers: .slp and analysis .h5 written by sleap-io itself."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
import sleap_io as sio  # part of the [io] extra: a missing one must fail, not skip
from io_truth import FPS, SCALE, Truth, assert_tracks

from thermoswarm.errors import InputError
from thermoswarm.io import detect_format, read_tracks


def _labels(truth: Truth, *, tracks: bool = True):
    skeleton = sio.Skeleton(nodes=list(truth.keypoints))  # sleap-io converts in place
    video = sio.Video(filename="ants.mp4", open_backend=False)
    track_objs = [sio.Track(name=n) for n in truth.individuals] if tracks else []
    frames = []
    for t in range(truth.n_t):
        insts = []
        for i in range(len(truth.individuals) if tracks else 1):
            pts = truth.px[t, :, :, i].T  # (nodes, 2)
            if np.all(np.isnan(pts)):
                continue
            insts.append(
                sio.PredictedInstance.from_numpy(
                    points_data=pts,
                    skeleton=skeleton,
                    point_scores=truth.conf[t, :, i],
                    score=0.9,
                    track=track_objs[i] if tracks else None,
                )
            )
        frames.append(sio.LabeledFrame(video=video, frame_idx=t, instances=insts))
    return sio.Labels(
        labeled_frames=frames, videos=[video], skeletons=[skeleton], tracks=track_objs
    )


def test_slp_round_trip(tmp_path, truth):
    path = tmp_path / "preds.slp"
    sio.save_slp(_labels(truth), str(path))
    assert detect_format(path) == "sleap"
    ds = read_tracks(path, fps=FPS, px_per_mm="paper")
    assert_tracks(ds, truth.mm, truth.times, truth.individuals, truth.keypoints, truth.conf)
    assert ds.attrs["px_per_mm"] == SCALE
    assert ds.attrs["fps"] == FPS
    assert ds.attrs["source_software"] == "SLEAP"


def test_slp_single_animal_without_tracks(tmp_path, truth):
    path = tmp_path / "single.slp"
    sio.save_slp(_labels(truth, tracks=False), str(path))
    ds = read_tracks(path, fps=FPS, px_per_mm=SCALE)
    assert_tracks(
        ds, truth.mm[..., :1], truth.times, ["id_0"], truth.keypoints, truth.conf[..., :1]
    )


@pytest.mark.parametrize("preset", ["matlab", "standard"])
def test_analysis_h5_round_trip(tmp_path, truth, preset):
    path = tmp_path / "preds.analysis.h5"
    sio.save_analysis_h5(_labels(truth), str(path), preset=preset)
    assert detect_format(path) == "sleap"
    ds = read_tracks(path, fps=FPS, px_per_mm=SCALE)
    assert_tracks(ds, truth.mm, truth.times, truth.individuals, truth.keypoints, truth.conf)


def test_analysis_h5_legacy_sleap_layout(tmp_path, truth):
    """SLEAP's own exporter: matlab order, no ``dims`` attributes."""
    path = tmp_path / "legacy.h5"
    with h5py.File(path, "w") as f:
        f["tracks"] = np.transpose(truth.px, (3, 1, 2, 0))  # (track, xy, node, frame)
        f["point_scores"] = np.transpose(truth.conf, (2, 1, 0))
        f["node_names"] = np.array([n.encode() for n in truth.keypoints])
        f["track_names"] = np.array([n.encode() for n in truth.individuals])
        f["track_occupancy"] = np.ones((truth.n_t, 2), dtype=np.uint8)
    ds = read_tracks(path, fps=FPS, px_per_mm=SCALE)
    assert_tracks(ds, truth.mm, truth.times, truth.individuals, truth.keypoints, truth.conf)


def test_sleap_needs_fps_and_scale(tmp_path, truth):
    path = tmp_path / "p.slp"
    sio.save_slp(_labels(truth), str(path))
    with pytest.raises(InputError, match=r"p\.slp.*--fps"):
        read_tracks(path, px_per_mm=SCALE)
    with pytest.raises(InputError, match=r"p\.slp.*--px-per-mm.*paper"):
        read_tracks(path, fps=FPS)


def test_truncated_slp_is_one_line_error(tmp_path, truth):
    good = tmp_path / "good.slp"
    sio.save_slp(_labels(truth), str(good))
    bad = tmp_path / "bad.slp"
    bad.write_bytes(good.read_bytes()[:700])
    with pytest.raises(InputError, match=r"bad\.slp") as err:
        read_tracks(bad, fps=FPS, px_per_mm=SCALE)
    assert "\n" not in str(err.value)


def test_analysis_h5_wrong_shape(tmp_path):
    path = tmp_path / "odd.h5"
    with h5py.File(path, "w") as f:
        f["tracks"] = np.zeros((2, 3, 4))
        f["node_names"] = np.array([b"a"])
    with pytest.raises(InputError, match=r"odd\.h5.*4-D"):
        read_tracks(path, fps=FPS, px_per_mm=SCALE)


def test_slp_only_options_rejected_for_h5(tmp_path, truth):
    path = tmp_path / "a.h5"
    sio.save_analysis_h5(_labels(truth), str(path))
    with pytest.raises(InputError, match="only"):
        read_tracks(path, fps=FPS, px_per_mm=SCALE, video=0)


def test_slp_user_label_preferred_over_prediction(tmp_path, truth):
    labels = _labels(truth)
    lf = labels.labeled_frames[3]
    pred = lf.instances[0]
    user_pts = truth.px[3, :, :, 0].T + 5.0
    lf.instances.append(
        sio.Instance.from_numpy(
            points_data=user_pts, skeleton=labels.skeletons[0], track=pred.track
        )
    )
    path = tmp_path / "mixed.slp"
    sio.save_slp(labels, str(path))
    ds = read_tracks(path, fps=FPS, px_per_mm=SCALE)
    got = ds.position.isel(time=3).sel(individuals="ant_a").values  # (space, keypoints)
    np.testing.assert_allclose(got, user_pts.T / SCALE, rtol=1e-12)
    ds_pred = read_tracks(path, fps=FPS, px_per_mm=SCALE, user_instances=False)
    np.testing.assert_allclose(
        ds_pred.position.isel(time=3).sel(individuals="ant_a").values,
        truth.mm[3, :, :, 0],
        rtol=1e-12,
    )
