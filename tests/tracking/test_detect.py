"""Detector interface, registry, model loading and the classical detector."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment
from tracking_fixtures import small_video

from thermoswarm.errors import InputError
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.detect.classical import (
    ClassicalDetector,
    Detector,
    DetectorEntry,
    FrameDetections,
    detectors,
    load_state_dict,
    load_weights,
    make_detector,
    register_detector,
)


def test_frame_detections_validates_and_boxes():
    pts = np.array([[[10.0, 5.0], [4.0, 5.0], [-2.0, 5.0]]])
    d = FrameDetections(pts, [0.9])
    assert len(d) == 1 and d.points.shape == (1, 3, 2)
    np.testing.assert_allclose(d.box_array(2.0), [[-4.0, 3.0, 16.0, 4.0]])
    given = FrameDetections(pts, [0.9], boxes=[[0, 0, 3, 3]])
    np.testing.assert_allclose(given.box_array(2.0), [[0, 0, 3, 3]])
    with pytest.raises(ValueError, match="scores"):
        FrameDetections(pts, [0.9, 0.1])
    with pytest.raises(ValueError, match="head_confidence"):
        FrameDetections(pts, [0.9], head_confidence=[0.5, 0.5])
    assert len(FrameDetections.empty()) == 0
    assert len(d.subset(np.array([False]))) == 0


def test_pose_boxes_and_iou():
    # Head/tail unknown: the fallback half sizes.
    pts = np.array([[[np.nan, np.nan], [10.0, 10.0], [np.nan, np.nan]]])
    np.testing.assert_allclose(anatomy.pose_boxes(pts, 1.0, (3.0, 2.0)), [[7, 8, 6, 4]])
    a = np.array([[0.0, 0.0, 2.0, 2.0]])
    b = np.array([[1.0, 0.0, 2.0, 2.0], [5.0, 5.0, 1.0, 1.0], [0.0, 0.0, 0.0, 2.0]])
    np.testing.assert_allclose(anatomy.box_iou(a, b), [[2 / 6, 0.0, 0.0]])


def test_registry_and_errors():
    assert "classical" in detectors() and "unet" in detectors()
    det = make_detector(px_per_mm=3.04)
    assert isinstance(det, ClassicalDetector) and isinstance(det, Detector)
    with pytest.raises(InputError, match="unknown detector 'nope'"):
        make_detector("nope", px_per_mm=3.04)
    with pytest.raises(InputError, match="needs a trained model"):
        make_detector("unet", px_per_mm=3.04)
    with pytest.raises(InputError, match="takes no model"):
        make_detector("classical", px_per_mm=3.04, model="x.pt")
    with pytest.raises(InputError, match="unknown key 'thresh'"):
        make_detector(px_per_mm=3.04, options={"thresh": 0.2})
    with pytest.raises(InputError, match="px_per_mm"):
        make_detector(px_per_mm=0.0)


def test_model_detector_missing_module_is_an_input_error(tmp_path):
    register_detector(
        DetectorEntry(
            "ghost", "thermoswarm.tracking.no_such_module:make", "test", needs_model=True
        )
    )
    try:
        model = tmp_path / "m.pt"
        model.write_bytes(b"x")
        with pytest.raises(InputError, match="not available"):
            make_detector("ghost", px_per_mm=3.04, model=model)
        with pytest.raises(InputError, match="does not exist"):
            make_detector("ghost", px_per_mm=3.04, model=tmp_path / "absent.pt")
    finally:
        from thermoswarm.tracking.detect import classical as detect

        detect._DETECTORS.pop("ghost")


def test_load_weights_checks_shapes(tmp_path):
    import torch  # a missing torch fails here: make install installs it

    net = torch.nn.Sequential(torch.nn.Conv2d(3, 4, 3), torch.nn.Linear(4, 2))
    good = tmp_path / "good.pt"
    torch.save(net.state_dict(), good)
    other = torch.nn.Sequential(torch.nn.Conv2d(3, 4, 3), torch.nn.Linear(4, 2))
    load_weights(other, good)
    for a, b in zip(net.parameters(), other.parameters(), strict=True):
        assert torch.equal(a, b)
    # Wrapped checkpoints are unwrapped.
    wrapped = tmp_path / "ckpt.pt"
    torch.save({"state_dict": net.state_dict(), "epoch": 3}, wrapped)
    assert set(load_state_dict(wrapped)) == set(net.state_dict())
    wrong = tmp_path / "wrong.pt"
    torch.save(
        torch.nn.Sequential(torch.nn.Conv2d(3, 8, 3), torch.nn.Linear(8, 2)).state_dict(), wrong
    )
    with pytest.raises(InputError, match=r"wrong.pt: tensor '0.weight' has shape \(8, 3, 3, 3\)"):
        load_weights(other, wrong)
    partial = tmp_path / "partial.pt"
    torch.save({"0.weight": net.state_dict()["0.weight"]}, partial)
    with pytest.raises(InputError, match="lacks tensor '0.bias'"):
        load_weights(other, partial)
    junk = tmp_path / "junk.pt"
    junk.write_bytes(b"not a model at all")
    with pytest.raises(InputError, match="junk.pt: not a PyTorch weights file"):
        load_weights(other, junk)
    with pytest.raises(InputError, match="does not exist"):
        load_state_dict(tmp_path / "absent.pt")


def _match(gt_points, det_points, radius=6.0):
    """Body-point matching: (gt index, det index) pairs within ``radius`` px."""
    if len(det_points) == 0 or len(gt_points) == 0:
        return np.zeros(0, int), np.zeros(0, int)
    D = np.linalg.norm(gt_points[:, None, 1] - det_points[None, :, 1], axis=-1)
    r, c = linear_sum_assignment(D)
    ok = D[r, c] < radius
    return r[ok], c[ok]


def _score(video, frames, det, hints=False):
    tp = fn = fp = flips = 0
    errs = []
    for k, f in enumerate(frames):
        gt = video.keypoints[k]
        gt = gt[np.isfinite(gt[:, 1, 0])]
        d = det.detect(f, hints=gt if hints else None)
        r, c = _match(gt, d.points)
        tp += r.size
        fn += len(gt) - r.size
        fp += len(d) - r.size
        errs.append(np.linalg.norm(gt[r, 1] - d.points[c, 1], axis=-1))
        ax = ((gt[r, 0] - gt[r, 2]) * (d.points[c, 0] - d.points[c, 2])).sum(-1)
        flips += int((ax < 0).sum())
    return tp, fn, fp, flips, np.concatenate(errs)


def test_classical_detector_finds_the_ants(video_small, frames_small):
    det = make_detector(px_per_mm=3.04)
    det.prepare(frames_small)
    # The learned ant length is close to the rendered one (7.14 mm * 3.04 px/mm,
    # lengthened a little by blur).
    assert 0.9 * 21.7 < det.length_px < 1.3 * 21.7
    tp, fn, fp, flips, err = _score(video_small, frames_small, det)
    n = tp + fn
    assert tp / n > 0.93
    assert fp / (tp + fp) < 0.07
    assert np.median(err) < 1.5
    assert flips / tp < 0.1


def test_hints_split_touching_ants():
    # Dense ants touch often; the tracker's predictions tell the detector how many
    # ants a blob holds.
    v = small_video(seed=31, n_ants=24, n_frames=40)
    frames = list(v.frames())
    base = make_detector(px_per_mm=3.04)
    base.prepare(frames)
    guided = make_detector(px_per_mm=3.04)
    guided.prepare(frames)
    tp0, fn0, fp0, _, _ = _score(v, frames, base)
    tp1, fn1, fp1, _, _ = _score(v, frames, guided, hints=True)
    assert fn1 + fp1 < fn0 + fp0
    assert tp1 / (tp1 + fn1) > 0.95


def test_lighting_change_does_not_matter(video_small, frames_small):
    # A frame 30 % darker than the ones prepared on: relative contrast is unchanged.
    det = make_detector(px_per_mm=3.04)
    det.prepare(frames_small[:30])
    k = 45
    dim = (frames_small[k].astype(float) * 0.7).astype(np.uint8)
    gt = video_small.keypoints[k]
    gt = gt[np.isfinite(gt[:, 1, 0])]
    r, _ = _match(gt, det.detect(dim).points)
    assert r.size >= len(gt) - 1


def test_classical_detector_rejects_bad_frames(video_small, frames_small):
    det = make_detector(px_per_mm=3.04)
    det.prepare(frames_small[:5])
    with pytest.raises(InputError, match="uint8"):
        det.detect(frames_small[0].astype(np.float32))
    with pytest.raises(InputError, match="differs from the first frame"):
        det.detect(frames_small[0][:100])
    det.reset()
    # A new video (the top 100 rows) after reset(): its first frame becomes the
    # background (nothing found), then the ants that moved are found where they are
    # (the spot an ant left in that background may show as one more blob).
    assert len(det.detect(frames_small[0][:100])) == 0
    d = det.detect(frames_small[1][:100])
    truth = video_small.keypoints[1][:, 1]
    truth = truth[np.isfinite(truth[:, 0]) & (truth[:, 1] < 100)]
    dist = np.linalg.norm(d.points[:, None, 1] - truth[None], axis=-1).min(axis=1)
    half_ant = 0.5 * anatomy.ANT_LENGTH_MM * 3.04
    assert len(d) >= 3 and np.sum(dist < half_ant) >= len(d) - 1
    with pytest.raises(InputError, match="at least one frame"):
        ClassicalDetector(3.04).prepare([])


def test_empty_road_gives_no_detections(video_small):
    bg = np.clip(video_small.background(), 0, 255).astype(np.uint8)
    det = make_detector(px_per_mm=3.04)
    det.prepare([bg] * 5)
    rng = np.random.default_rng(0)
    noisy = np.clip(bg + rng.normal(0, 4, bg.shape), 0, 255).astype(np.uint8)
    assert len(det.detect(noisy)) == 0
