"""Labels as real projects write them: skeletons with other node names (an 18-node ant
skeleton with upper and lower thorax, names with spaces, nodes in another order),
videos stored at the labeller's absolute path, frames labelled in part (predicted
instances beside user ones), predictions only, instances without their body node.

The files are made here in the layout of public SLEAP ant projects (no third-party
data is shipped)."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
import sleap_io as sio  # noqa: E402  (a missing sleap-io fails: make install installs it)
from click.testing import CliRunner  # noqa: E402

from thermoswarm.cli import cli  # noqa: E402
from thermoswarm.errors import InputError  # noqa: E402
from thermoswarm.tracking.train import fit as tr  # noqa: E402
from thermoswarm.tracking.train.data import NodeMap, node_map  # noqa: E402

#: The node order of one public leaf-cutter project's file (names with spaces).
NODES = ["Neck", "Abdomen", "Head", "Lower Thorax", "Upper Thorax", "LHindLeg"]


# ------------------------------------------------------------------ node mapping


def test_node_map_defaults_average_the_thorax_nodes():
    m = node_map(NODES, None, "f.slp")
    assert m.roles == ((2,), (3, 4), (1,))
    assert m.text == "head=Head, body=Lower Thorax+Upper Thorax, tail=Abdomen"
    xy = np.array([[0, 0], [10, 0], [40, 0], [20, 2], [30, 4], [np.nan, np.nan]], float)
    np.testing.assert_allclose(m.apply(xy), [[40, 0], [25, 3], [10, 0]])
    xy[3] = np.nan  # one thorax node unlabelled: no body point
    assert np.isnan(m.apply(xy)[1]).all()


def test_node_map_explicit_names_match_without_case_and_spaces():
    m = node_map(NODES, ["head", "upper_thorax", "ABDOMEN"], "f.slp")
    assert m.roles == ((2,), (4,), (1,))
    m = node_map(NODES, ["Head", "UpperThorax+LowerThorax", "Abdomen"], "f.slp")
    assert m.roles == ((2,), (4, 3), (1,))
    with pytest.raises(InputError, match="f.slp: skeleton has no node 'Thorax'; its nodes"):
        node_map(NODES, ["Head", "Thorax", "Abdomen"], "f.slp")
    with pytest.raises(InputError, match="several match it"):
        node_map(["a b", "a_b", "c"], ["ab", "c", "c"], "f.slp")
    with pytest.raises(InputError, match="empty node name"):
        node_map(NODES, ["Head", "Neck+", "Abdomen"], "f.slp")
    # Exact (case-blind) names win over normalised ones.
    assert node_map(["ab", "a b", "h", "t"], ["h", "a b", "t"], "f").roles[1] == (1,)


def test_node_map_without_a_body_node_is_a_one_line_error():
    with pytest.raises(InputError, match=r"no body node among Head, Neck, Abdomen .*\+"):
        node_map(["Head", "Neck", "Abdomen"], None, "f.slp")
    assert isinstance(node_map(["head", "body", "tail"], None, "f"), NodeMap)


# ----------------------------------------------------------- a real-layout file


def _ant(head, body_upper, body_lower, tail):
    """An instance's node array in NODES order (legs unlabelled)."""
    xy = np.full((len(NODES), 2), np.nan)
    xy[NODES.index("Head")] = head
    xy[NODES.index("Upper Thorax")] = body_upper
    xy[NODES.index("Lower Thorax")] = body_lower
    xy[NODES.index("Abdomen")] = tail
    xy[NODES.index("Neck")] = (np.asarray(head) + np.asarray(body_upper)) / 2
    return xy


def _project(tmp_path, *, video_beside=True, predicted_frames_only=False):
    """A SLEAP file whose video is stored at a path of another machine, like the files
    of public ant projects: frame 0 labelled in part (3 user instances, one without its
    lower thorax; a prediction repeating a user instance and one of an ant nobody
    labelled), frame 3 with predictions only; two tracks."""
    from thermoswarm.tracking.synth.clip import write_video

    rng = np.random.default_rng(5)
    frames = [rng.integers(0, 255, (64, 96, 3), dtype=np.uint8) for _ in range(4)]
    src = tmp_path / "elsewhere"
    src.mkdir()
    write_video(frames, src / "Col9.mp4", fps=10)
    skel = sio.Skeleton(list(NODES))  # (it turns the names of its list into nodes)
    tracks = [sio.Track("ant1"), sio.Track("ant2")]
    video = sio.Video(filename="D:/Downloads/Ant videos/Col9.mp4", open_backend=False)
    a = _ant([10, 10], [20, 10], [26, 10], [36, 10])
    b = _ant([60, 40], [60, 30], [60, 26], [60, 14])
    c = _ant([80, 50], [74, 50], [np.nan, np.nan], [64, 50])  # no lower thorax
    other = _ant([20, 50], [30, 50], [34, 50], [44, 50])  # predicted only: unlabelled ant
    users = [
        sio.Instance.from_numpy(a, skeleton=skel, track=tracks[0]),
        sio.Instance.from_numpy(b, skeleton=skel, track=tracks[1]),
        sio.Instance.from_numpy(c, skeleton=skel),
    ]
    preds = [
        sio.PredictedInstance.from_numpy(a + 1.0, skeleton=skel, score=0.9),  # repeats a
        sio.PredictedInstance.from_numpy(other, skeleton=skel, score=0.8),
    ]
    lfs = [
        sio.LabeledFrame(video=video, frame_idx=0, instances=users + preds),
        sio.LabeledFrame(
            video=video,
            frame_idx=3,
            instances=[sio.PredictedInstance.from_numpy(b + 2.0, skeleton=skel, score=0.7)],
        ),
    ]
    if predicted_frames_only:
        lfs = lfs[1:]
    labels = sio.Labels(labeled_frames=lfs, videos=[video], skeletons=[skel], tracks=tracks)
    path = tmp_path / "col9.v001.slp"
    sio.save_slp(labels, str(path), embed=False, verbose=False)
    if video_beside:
        (src / "Col9.mp4").rename(tmp_path / "Col9.mp4")
    return path, src


def _decoded(path, k):
    import cv2

    cap = cv2.VideoCapture(str(path))
    for _ in range(k + 1):
        ok, bgr = cap.read()
        assert ok
    cap.release()
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def test_read_slp_of_a_real_project_layout(tmp_path):
    path, _ = _project(tmp_path)
    d = tr.read_slp(path, px_per_mm=20.0)
    # The video stored as D:/Downloads/... is found beside the labels by its name.
    assert len(d) == 1 and d.keys == [(0, 0)]
    np.testing.assert_array_equal(d.frames[0], _decoded(tmp_path / "Col9.mp4", 0))
    # Head, mean of the two thorax nodes, abdomen; the ant without its lower thorax is
    # no labelled ant but an ignore region at the mean of its known points.
    np.testing.assert_allclose(
        d.points[0], [[[10, 10], [23, 10], [36, 10]], [[60, 40], [60, 28], [60, 14]]]
    )
    ign = np.sort(d.ignore[0], axis=0)
    np.testing.assert_allclose(ign, np.sort([[72, 50], [32, 50]], axis=0))
    # The prediction repeating a user instance is not an ignore region.
    assert d.n_ignored == 2
    np.testing.assert_array_equal(d.tracks[0], [0, 1])
    assert "body=Lower Thorax+Upper Thorax" in d.source
    assert "1 frames with predictions only skipped" in d.source
    # Predictions as labels when asked: frame 3 comes in with its predicted ant.
    d = tr.read_slp(path, px_per_mm=20.0, include_predicted=True)
    assert [k for _, k in d.keys] == [0, 3]
    np.testing.assert_allclose(d.points[1], [[[62, 42], [62, 30], [62, 16]]])
    np.testing.assert_array_equal(d.frames[1], _decoded(tmp_path / "Col9.mp4", 3))


def test_read_slp_finds_the_video_in_image_root_or_names_it(tmp_path):
    path, src = _project(tmp_path, video_beside=False)
    with pytest.raises(InputError, match="put the video 'Col9.mp4' beside the labels"):
        tr.read_slp(path, px_per_mm=20.0)
    d = tr.read_slp(path, px_per_mm=20.0, image_root=src)
    assert len(d) == 1 and d.n_instances == 2


def test_read_slp_with_predictions_only_says_how_to_use_them(tmp_path):
    path, _ = _project(tmp_path, predicted_frames_only=True)
    with pytest.raises(InputError, match="1 frames hold predicted instances only; pass --pred"):
        tr.read_slp(path, px_per_mm=20.0)
    assert tr.read_slp(path, px_per_mm=20.0, include_predicted=True).n_instances == 1


def test_labelled_frames_carry_ignore_regions_through_subset_and_scale():
    f = np.zeros((40, 60, 3), np.uint8)
    pts = np.array([[[10.5, 20.5], [20.5, 20.5], [30.5, 20.5]]])
    d = tr.LabeledFrames([f, f], [pts, pts[:0]], 6.0, ignore=[np.zeros((0, 2)), [[40.5, 8.5]]])
    r = d.subset([1]).rescaled(3.0)
    np.testing.assert_allclose(r.ignore[0], [[20.0, 4.0]])  # (x + .5) / 2 - .5
    c = tr.LabeledFrames.concat([tr.LabeledFrames([f], [pts], 6.0), d.subset([1])])
    assert c.n_ignored == 1 and c.ignore[0].shape == (0, 2)
    with pytest.raises(ValueError, match="ignore must have one entry per frame"):
        tr.LabeledFrames([f], [pts], 6.0, ignore=[])


# ------------------------------------------------------- training and scoring


def test_centroid_patches_do_not_teach_background_on_unlabelled_ants():
    """Without augmentation a patch is a translation of the frame: the zero-weight
    cells form a disc of half a body length around the unlabelled ant, at its offset
    from the labelled ant's target peak."""
    px_per_mm = 3.04
    L = tr.anatomy.ANT_LENGTH_MM * px_per_mm  # 21.7 px
    f = np.full((160, 160, 3), 200, np.uint8)
    body = np.array([60.0, 80.0])
    pts = np.array([[body + [7, 0], body, body - [7, 0]]])
    off = np.array([30.0, 10.0])
    d = tr.LabeledFrames([f], [pts], px_per_mm, ignore=[(body + off)[None]])
    aug = tr.AugmentConfig(
        rotate=False, flip=False, scale=0.0, brightness=0.0, contrast=0.0, colour=0.0,
        noise_sigma=0.0, blur_probability=0.0,
    )  # fmt: skip
    cfg = tr.TrainConfig(centroid_batch=6, patch_size=96, augment=aug, val_fraction=0.0)
    sampler = tr._Sampler(d, cfg, np.random.default_rng(0))
    _, targets, weights = sampler.centroid_batch()
    s = cfg.model.input_scale
    h = targets.shape[1]
    cells = (np.arange(h) + 0.5) / s - 0.5  # cell centres in patch px
    X, Y = np.meshgrid(cells, cells)
    n_checked = n_zero = 0
    for t, w in zip(targets, weights, strict=True):
        if t.max() < 0.7:  # exp(-2 / 8): the peak cell is within sqrt(2) px of it
            continue  # the labelled ant's peak is outside this patch
        k = np.unravel_index(np.argmax(t), t.shape)
        peak = np.array([X[k], Y[k]])  # within sqrt(2) px of the body point
        dist = np.hypot(X - (peak + off)[0], Y - (peak + off)[1])
        # Cells clearly inside the disc have weight 0, cells clearly outside weight 1
        # (1.5 px margin: the peak cell is up to sqrt(2) px from the body point).
        assert (w[dist < 0.5 * L - 1.5] == 0).all()
        assert (w[dist > 0.5 * L + 1.5] == 1).all()
        assert (w[t > 0.5] == 1).all()  # the labelled ant is still taught
        n_checked += 1
        n_zero += int((w == 0).any())
    assert n_checked >= 2 and n_zero >= 1
    d.ignore = None
    _, _, weights = tr._Sampler(d, cfg, np.random.default_rng(0)).centroid_batch()
    assert (weights == 1).all()


def test_detections_on_unlabelled_ants_are_not_false_positives():
    from thermoswarm.tracking.detect.classical import FrameDetections

    gt = np.array([[[0, 0], [10, 0], [20, 0]]], float)
    pts = np.array(
        [[[0, 1], [10, 1], [20, 1]], [[50, 0], [52, 0], [54, 0]], [[90, 0], [95, 0], [99, 0]]],
        float,
    )
    det = FrameDetections(points=pts, scores=np.ones(3))
    m = tr.detection_metrics([det], [gt], 5.0)
    assert (m["tp"], m["fp"], m["fn"], m["ignored"]) == (1, 2, 0, 0)
    m = tr.detection_metrics([det], [gt], 5.0, ignore=[np.array([[50.0, 0.0]])])
    assert (m["tp"], m["fp"], m["fn"], m["ignored"]) == (1, 1, 0, 1)
    assert m["precision"] == 0.5
    # A detection matched to a labelled ant is a match even inside an ignore region.
    m = tr.detection_metrics([det], [gt], 5.0, ignore=[np.array([[10.0, 0.0]])])
    assert (m["tp"], m["fp"], m["ignored"]) == (1, 2, 0)


def test_coco_annotation_without_body_or_crowd_is_ignored(tmp_path):
    import cv2

    img = np.zeros((40, 60, 3), np.uint8)
    cv2.imwrite(str(tmp_path / "a.png"), img)
    anns = [
        {"id": 1, "image_id": 1, "category_id": 1, "keypoints": [5, 5, 2, 10, 5, 2, 15, 5, 2]},
        {"id": 2, "image_id": 1, "category_id": 1, "keypoints": [30, 5, 2, 0, 0, 0, 40, 5, 1]},
        {"id": 3, "image_id": 1, "category_id": 1, "iscrowd": 1, "bbox": [50, 30, 6, 4]},
    ]
    doc = {
        "images": [{"id": 1, "file_name": "a.png"}],
        "annotations": anns,
        "categories": [{"id": 1, "keypoints": ["Head", "Thorax", "Gaster"]}],
    }
    (tmp_path / "c.json").write_text(json.dumps(doc))
    d = tr.read_coco(tmp_path / "c.json", px_per_mm=3.0)
    np.testing.assert_allclose(d.points[0], [[[5, 5], [10, 5], [15, 5]]])
    np.testing.assert_allclose(d.ignore[0], [[35, 5], [53, 32]])


def test_cli_trains_on_a_real_layout_slp_with_node_sums(tmp_path):
    path, _ = _project(tmp_path)
    out = tmp_path / "m.pt"
    args = ["track", "train", "--labels", str(path), "--out", str(out), "--quiet"]
    args += ["--px-per-mm", "3.04", "--threads", "1", "--predicted"]
    args += ["--nodes", "head,upper thorax+lower_thorax,ABDOMEN"]
    args += ["--set", "max_steps=2", "--set", "patch_size=32", "--set", "val_fraction=0"]
    args += ["--set", "centroid_batch=2", "--set", "pose_batch=4"]
    args += ["--set", "model.centroid_channels=[8,16,16]", "--set", "model.pose_channels=[8,8,8]"]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    data = json.loads(out.with_suffix(".json").read_text())["data"]
    assert (data["n_frames"], data["n_instances"], data["n_ignored"]) == (2, 3, 2)
    assert "body=Upper Thorax+Lower Thorax" in data["source"]
    bad = [
        a if a != "head,upper thorax+lower_thorax,ABDOMEN" else "Head,Thorax,Abdomen" for a in args
    ]
    res = CliRunner().invoke(cli, bad)
    assert res.exit_code == 2 and "skeleton has no node 'Thorax'" in res.output
