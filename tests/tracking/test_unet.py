"""The trained top-down detector: networks, geometry of peaks and crops, training,
weights files, SLEAP and COCO readers, the ``track train`` command."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

# Before torch starts its OpenMP runtime (see thermoswarm.tracking.detect.unet).
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
import torch  # noqa: E402  (a missing torch fails: make install installs it)
from click.testing import CliRunner  # noqa: E402
from tracking_fixtures import small_video  # noqa: E402

from thermoswarm.cli import cli  # noqa: E402
from thermoswarm.errors import InputError  # noqa: E402
from thermoswarm.tracking.detect import unet  # noqa: E402
from thermoswarm.tracking.detect.classical import make_detector  # noqa: E402
from thermoswarm.tracking.train import fit as tr  # noqa: E402

# A small model and small batches: the tests train for seconds, not minutes.
SMALL_MODEL = unet.ModelConfig(centroid_channels=(8, 16, 16), pose_channels=(12, 16, 16))


def _tiny_data(seed: int = 3, n_videos: int = 2) -> tr.LabeledFrames:
    cfg = tr.SynthDataConfig(
        n_videos=n_videos, frames_per_video=3, width=400, height=160, codec=False
    )
    return tr.synthetic_data(cfg, np.random.default_rng(seed))


def _tiny_train_config(**kw) -> tr.TrainConfig:
    args = dict(
        max_steps=4,
        eval_every=1000,
        centroid_batch=2,
        patch_size=64,
        pose_batch=8,
        val_fraction=0.0,
        model=SMALL_MODEL,
        threads=1,  # tiny networks: one thread is fastest, and xdist runs two workers
    )
    args.update(kw)
    return tr.TrainConfig(**args)


# ------------------------------------------------------------------ networks


def test_network_shapes():
    m = unet.TopDownModel(SMALL_MODEL).eval()
    with torch.no_grad():
        c = m.centroid(torch.rand(2, 3, 48, 80))
        p = m.pose(torch.rand(5, 3, 32, 32))
    # The confidence map has the input's resolution, one logit map per keypoint has
    # the crop's.
    assert c.shape == (2, 1, 48, 80)
    assert p.shape == (5, 3, 32, 32)
    xy, var = unet.soft_argmax(p)
    assert xy.shape == (5, 3, 2) and var.shape == (5, 3)


def test_soft_argmax_finds_the_peak_to_subpixel():
    # Logits of a sharp Gaussian at a known sub-pixel point: the expectation is that
    # point (the tails are symmetric and far from the border).
    H = W = 32
    yy, xx = np.mgrid[0:H, 0:W]
    pts = np.array([[10.3, 20.6], [16.0, 5.25], [22.75, 22.1]])
    logits = np.stack([-((xx - x) ** 2 + (yy - y) ** 2) / (2 * 1.0**2) for x, y in pts])
    xy, var = unet.soft_argmax(torch.tensor(logits[None], dtype=torch.float64))
    np.testing.assert_allclose(xy[0].numpy(), pts, atol=1e-6)
    np.testing.assert_allclose(var[0].numpy(), 2.0, atol=1e-3)  # sigma^2 per axis


def test_find_peaks_subcell_and_separation():
    H, W = 40, 60
    yy, xx = np.mgrid[0:H, 0:W]
    true = np.array([[10.3, 12.6], [13.2, 12.8], [40.0, 30.0]])  # two 3 cells apart
    m = np.max([np.exp(-((xx - x) ** 2 + (yy - y) ** 2) / 2.0) for x, y in true], axis=0)
    xy, vals = unet.find_peaks(m, 0.3)
    assert len(xy) == 3
    order = np.argsort(xy[:, 0])
    # The 3x3 weighted centroid is biased towards the cell centre by less than a
    # quarter cell for sigma = 1 cell (a bound of the method, not a fitted number).
    np.testing.assert_allclose(xy[order], true[np.argsort(true[:, 0])], atol=0.25)
    assert np.all(vals > 0.8) and np.all(np.diff(vals) <= 0)
    assert len(unet.find_peaks(m, 1.0)[0]) == 0  # strictly above the threshold


def test_crop_at_centres_the_rounded_anchor_and_repeats_edges():
    frame = np.arange(20 * 30 * 3, dtype=np.int64).reshape(20, 30, 3).astype(np.uint8)
    crops, origin = unet.crop_at(frame, np.array([[10.4, 7.6], [0.2, 19.0]]), 8)
    np.testing.assert_array_equal(origin, [[6, 4], [-4, 15]])
    np.testing.assert_array_equal(crops[0, 4, 4], frame[8, 10])  # pixel C//2 = anchor
    np.testing.assert_array_equal(crops[1, 0, 0], frame[15, 0])  # clamped to the edge
    np.testing.assert_array_equal(crops[1, 4, 4], frame[19, 0])


def test_model_scale_maps_points_back():
    frame = np.zeros((100, 200, 3), np.uint8)
    small, (fx, fy) = unet.to_model_scale(frame, 0.5)
    assert small.shape == (50, 100, 3) and fx == fy == 0.5
    # The centre of pixel 10 at half size covers pixels 20 and 21: (10 + .5)/.5 - .5.
    assert (10 + 0.5) / fx - 0.5 == 20.5
    grey, _ = unet.to_model_scale(np.zeros((10, 12), np.uint8), 1.0)
    assert grey.shape == (10, 12, 3)
    with pytest.raises(InputError, match="uint8"):
        unet.to_model_scale(np.zeros((10, 12, 3), np.float32), 1.0)


def test_deduplicate_keeps_the_strongest_of_one_pose():
    ant = np.array([[8.0, 0.0], [0.0, 0.0], [-7.0, 0.0]])
    crossing = np.array([[0.0, 8.0], [0.5, 0.0], [0.0, -7.0]])  # same body, across
    pts = np.stack([ant, ant + [1.0, 0.5], crossing, ant + [40.0, 0.0], ant + [41.0, 0.0]])
    scores = np.array([0.9, 0.8, 0.7, 0.6, 0.95])
    keep = unet._deduplicate(pts, scores, 3.5)
    # The shifted copy of the first ant and the weaker of the far pair go; the
    # crossing ant, whose body point coincides with the first one's, stays.
    assert sorted(keep.tolist()) == [0, 2, 4]
    pts[1, 0] = np.nan  # an unknown point does not count in the mean
    assert sorted(unet._deduplicate(pts, scores, 3.5).tolist()) == [0, 2, 4]


# ------------------------------------------------------------------ weights


def test_save_load_roundtrip_weights_only(tmp_path):
    torch.manual_seed(0)
    m = unet.TopDownModel(SMALL_MODEL)
    path = unet.save_model(m, tmp_path / "m.pt", info={"note": "test"})
    raw = torch.load(path, weights_only=True)  # no pickled code in the file
    assert raw["format"] == unet.FORMAT and raw["version"] == unet.VERSION
    back = unet.load_model(path)
    assert back.config == SMALL_MODEL and back.info == {"note": "test"}
    sd0, sd1 = m.state_dict(), back.state_dict()
    assert sd0.keys() == sd1.keys()
    for k in sd0:
        assert torch.equal(sd0[k], sd1[k]), k
    # A plain state dict of the default architecture loads with the default config.
    torch.save(unet.TopDownModel().state_dict(), tmp_path / "plain.pt")
    assert unet.load_model(tmp_path / "plain.pt").config == unet.ModelConfig()


def test_wrong_model_files_are_one_line_input_errors(tmp_path):
    m = unet.TopDownModel(SMALL_MODEL)
    # Weights of the small architecture presented as the default one.
    torch.save(m.state_dict(), tmp_path / "shape.pt")
    with pytest.raises(
        InputError, match=r"shape.pt: tensor 'centroid\.stem\.0\.weight' has shape"
    ):
        unet.load_model(tmp_path / "shape.pt")
    torch.save({"weight": torch.zeros(3)}, tmp_path / "other.pt")
    with pytest.raises(InputError, match="lacks tensor"):
        unet.load_model(tmp_path / "other.pt")
    (tmp_path / "junk.pt").write_bytes(b"not a model")
    with pytest.raises(InputError, match="not a PyTorch weights file"):
        unet.load_model(tmp_path / "junk.pt")
    torch.save({"format": "something.else", "state_dict": m.state_dict()}, tmp_path / "f.pt")
    with pytest.raises(InputError, match="expected a 'thermoswarm.unet' model"):
        unet.load_model(tmp_path / "f.pt")
    with pytest.raises(InputError, match="does not exist"):
        unet.load_model(tmp_path / "missing.pt")
    for err in (InputError,):
        try:
            unet.load_model(tmp_path / "shape.pt")
        except err as exc:
            assert "\n" not in str(exc)


def test_registry_builds_the_unet_detector(tmp_path):
    path = unet.save_model(unet.TopDownModel(SMALL_MODEL), tmp_path / "m.pt")
    det = make_detector(model=path, px_per_mm=6.08, options={"peak_threshold": 0.5})
    assert isinstance(det, unet.UNetDetector) and det.name == "unet"
    assert det.ratio == pytest.approx(0.5)  # the video has twice the model's scale
    assert det.threshold == 0.5
    with pytest.raises(Exception, match="unknown key 'nope'"):
        make_detector(model=path, px_per_mm=3.04, options={"nope": 1})
    d = det.detect(np.full((64, 96, 3), 128, np.uint8))  # runs on any frame size
    assert d.points.shape[1:] == (3, 2)


# ------------------------------------------------------------------ training


def test_training_reduces_the_losses(tmp_path):
    data = _tiny_data()
    cfg = _tiny_train_config(max_steps=80, lr=1e-2)
    torch.manual_seed(1)
    init = unet.save_model(
        unet.TopDownModel(tr.dataclasses.replace(SMALL_MODEL, px_per_mm=data.px_per_mm)),
        tmp_path / "init.pt",
    )
    # A fixed evaluation batch, drawn with its own seed.
    sampler = tr._Sampler(
        data, tr.dataclasses.replace(cfg, pose_batch=64), np.random.default_rng(9)
    )
    cx, cy, cw = sampler.centroid_batch()
    px, pp = sampler.pose_batch()

    def losses(model):
        with torch.no_grad():
            model.eval()
            x = torch.from_numpy(cx).permute(0, 3, 1, 2).float() / 255
            lc = tr._centroid_loss(model.centroid(x), torch.from_numpy(cy)[:, None], 1.0)
            xc = torch.from_numpy(px).permute(0, 3, 1, 2).float() / 255
            xy, _ = unet.soft_argmax(model.pose(xc))
            d2 = ((xy - torch.from_numpy(pp).float()) ** 2).sum(-1)
            return float(lc), float(d2.mean())

    c0, p0 = losses(unet.load_model(init))
    report = tr.train(data, tmp_path / "m.pt", cfg, init=init)
    c1, p1 = losses(unet.load_model(tmp_path / "m.pt"))
    assert report["steps"] == 80 and report["stopped"] == "max_steps"
    # Untrained, the soft-argmax sits near the crop's centre: head and tail are ~7 px
    # off, the body point only in off-centre crops (~45 px^2 over the three points).
    # 80 steps must at least halve both losses (measured with this seed: pose 45 ->
    # 19 px^2, centroid 1.5 -> 0.24).
    assert p1 < 0.5 * p0, (p0, p1)
    assert c1 < 0.5 * c0, (c0, c1)
    # The score reference measured on the training frames is stored with the weights.
    ref = unet.load_model(tmp_path / "m.pt").config.peak_reference
    assert 0 < ref <= 1 and ref == pytest.approx(report["best"]["peak_reference"])
    saved = json.loads((tmp_path / "m.json").read_text())
    assert saved["steps"] == 80 and saved["data"]["n_frames"] == len(data)


def test_training_is_reproducible(tmp_path):
    data = _tiny_data(n_videos=1)
    cfg = _tiny_train_config(max_steps=3, seed=5)
    tr.train(data, tmp_path / "a.pt", cfg)
    tr.train(data, tmp_path / "b.pt", cfg)
    tr.train(data, tmp_path / "c.pt", tr.dataclasses.replace(cfg, seed=6))
    a, b, c = (unet.load_model(tmp_path / f"{n}.pt").state_dict() for n in "abc")
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert not all(torch.equal(a[k], c[k]) for k in a)


def test_synthetic_data_are_labelled_frames():
    data = _tiny_data()
    assert len(data) == 6 and data.px_per_mm == 3.04
    for f, p in zip(data.frames, data.points, strict=True):
        assert f.dtype == np.uint8 and f.ndim == 3 and f.shape[2] == 3
        assert f.shape[0] % 2 == 0 and f.shape[1] % 2 == 0
        assert p.ndim == 3 and p.shape[1:] == (3, 2) and np.isfinite(p).all()
        # Ants are darker than the road at their body points.
        inside = (p[:, 1, 0] > 2) & (p[:, 1, 0] < f.shape[1] - 3)
        inside &= (p[:, 1, 1] > 2) & (p[:, 1, 1] < f.shape[0] - 3)
        q = np.round(p[inside, 1]).astype(int)
        assert f[q[:, 1], q[:, 0], 1].mean() < np.median(f[..., 1])
    # Same seed, same data.
    again = _tiny_data()
    assert all(np.array_equal(a, b) for a, b in zip(data.frames, again.frames, strict=True))


def test_detection_metrics_counts_and_errors():
    from thermoswarm.tracking.detect.classical import FrameDetections

    gt = [np.array([[[10, 0], [0, 0], [-8, 0]], [[110, 50], [100, 50], [92, 50]]], float)]
    pred = gt[0][:1] + np.array([0.0, 1.0])  # first ant, 1 px off; second missed
    pred = np.concatenate([pred, [[[300, 0], [290, 0], [282, 0]]]])  # a false positive
    m = tr.detection_metrics([FrameDetections(pred, np.ones(2))], gt, radius_px=5)
    assert (m["tp"], m["fp"], m["fn"]) == (1, 1, 1)
    assert m["body_error_median_px"] == pytest.approx(1.0)
    assert m["f1"] == pytest.approx(0.5)
    assert m["head_tail_swapped"] == 0.0


# ------------------------------------------------------------------ readers


def _labelled_images(tmp_path, n=2):
    import cv2

    rng = np.random.default_rng(4)
    imgs, pts = [], []
    for k in range(n):
        img = rng.integers(0, 255, (40, 60, 3), dtype=np.uint8)
        cv2.imwrite(str(tmp_path / f"img{k}.png"), cv2.cvtColor(img, cv2.COLOR_RGB2BGR))
        imgs.append(img)
        p = rng.uniform(5, 35, (k + 1, 3, 2))
        pts.append(p)
    return imgs, pts


def test_read_slp_with_embedded_images(tmp_path):
    import sleap_io as sio  # a missing sleap-io fails: make install installs it

    imgs, pts = _labelled_images(tmp_path)
    skel = sio.Skeleton(["gaster", "thorax", "head", "antenna"])
    video = sio.Video.from_filename([str(tmp_path / "img0.png"), str(tmp_path / "img1.png")])
    frames = []
    for k, p in enumerate(pts):
        insts = []
        for q in p:
            xy = np.stack([q[2], q[1], q[0], [np.nan, np.nan]])  # skeleton order
            insts.append(sio.Instance.from_numpy(xy, skeleton=skel))
        frames.append(sio.LabeledFrame(video=video, frame_idx=k, instances=insts))
    labels = sio.Labels(labeled_frames=frames, videos=[video], skeletons=[skel])
    path = tmp_path / "labels.pkg.slp"
    sio.save_slp(labels, str(path), embed="user", verbose=False)
    # Remove the source images: the frames must come from the file itself.
    for k in range(2):
        (tmp_path / f"img{k}.png").unlink()
    data = tr.read_slp(path, px_per_mm=3.04)
    assert len(data) == 2 and data.px_per_mm == 3.04
    for k in range(2):
        np.testing.assert_array_equal(data.frames[k], imgs[k])
        np.testing.assert_allclose(data.points[k], pts[k], atol=1e-5)
    with pytest.raises(InputError, match="no node 'tail'"):
        tr.read_slp(path, px_per_mm=3.04, nodes=["head", "thorax", "tail"])
    with pytest.raises(InputError, match="no such file"):
        tr.read_slp(tmp_path / "missing.slp", px_per_mm=3.04)


def test_read_coco_keypoints(tmp_path):
    imgs, pts = _labelled_images(tmp_path)
    anns = []
    for k, p in enumerate(pts):
        for q in p:
            kp = []
            for name in ("head", "body", "tail"):
                x, y = q[("head", "body", "tail").index(name)]
                kp += [float(x), float(y), 2]
            anns.append(
                {"id": len(anns) + 1, "image_id": k + 1, "category_id": 1, "keypoints": kp}
            )
    anns[0]["keypoints"][8] = 0  # first ant's tail not labelled
    doc = {
        "images": [{"id": k + 1, "file_name": f"img{k}.png"} for k in range(2)],
        "annotations": anns,
        "categories": [{"id": 1, "name": "ant", "keypoints": ["head", "body", "tail"]}],
    }
    path = tmp_path / "coco.json"
    path.write_text(json.dumps(doc))
    data = tr.read_labels(path, px_per_mm=2.0)
    assert len(data) == 2
    np.testing.assert_array_equal(data.frames[1], imgs[1])
    expect = pts[0].copy()
    expect[0, 2] = np.nan
    np.testing.assert_allclose(data.points[0], expect)
    np.testing.assert_allclose(data.points[1], pts[1])
    doc["images"][0]["file_name"] = "nowhere.png"
    path.write_text(json.dumps(doc))
    with pytest.raises(InputError, match="nowhere.png is missing"):
        tr.read_coco(path, px_per_mm=2.0)
    path.write_text("{]")
    with pytest.raises(InputError, match="not a JSON file"):
        tr.read_coco(path, px_per_mm=2.0)


def test_cli_trains_on_coco_labels_and_fine_tunes(tmp_path):
    imgs, pts = _labelled_images(tmp_path, n=4)
    anns = [
        {"id": i, "image_id": k + 1, "category_id": 1, "keypoints": [*q[0], 2, *q[1], 2, *q[2], 2]}
        for i, (k, q) in enumerate((k, q) for k, p in enumerate(pts) for q in p.tolist())
    ]
    doc = {
        "images": [{"id": k + 1, "file_name": f"img{k}.png"} for k in range(4)],
        "annotations": anns,
        "categories": [{"id": 1, "keypoints": ["Head", "Thorax", "Gaster"]}],
    }
    (tmp_path / "coco.json").write_text(json.dumps(doc))
    base = unet.save_model(unet.TopDownModel(SMALL_MODEL), tmp_path / "base.pt")
    common = ["--px-per-mm", "3.04", "--quiet", "--threads", "1", "--set", "max_steps=2"]
    common += ["--set", "patch_size=32", "--set", "val_fraction=0.25"]
    out = tmp_path / "tuned.pt"
    res = CliRunner().invoke(
        cli,
        ["track", "train", "--labels", str(tmp_path / "coco.json"), "--out", str(out)]
        + ["--init", str(base)]
        + common,
    )
    assert res.exit_code == 0, res.output
    assert "validation F1" in res.output
    report = json.loads(out.with_suffix(".json").read_text())
    assert report["init"] == str(base) and report["data"]["n_frames"] == 3  # 1 held out
    assert "f1" in report["best"] and "mota" not in report["best"]
    # Fine-tuning keeps the architecture of the initial model.
    assert unet.load_model(out).config.centroid_channels == SMALL_MODEL.centroid_channels
    res = CliRunner().invoke(
        cli,
        ["track", "train", "--labels", str(tmp_path / "coco.json"), "--out", str(out)]
        + ["--nodes", "head,thorax"]
        + common,
    )
    assert res.exit_code == 2 and "--nodes must be three names" in res.output


def test_labels_rescale_to_the_model_scale():
    f = np.zeros((40, 60, 3), np.uint8)
    d = tr.LabeledFrames([f], [np.array([[[10.5, 20.5], [20.5, 20.5], [30.5, 20.5]]])], 6.0)
    r = d.rescaled(3.0)
    assert r.frames[0].shape == (20, 30, 3)
    np.testing.assert_allclose(r.points[0][0, 1], [10.0, 10.0])  # (20.5 + .5) / 2 - .5


# ------------------------------------------------------------------ command line


@pytest.fixture(scope="module")
def tiny_video(tmp_path_factory):
    from thermoswarm.tracking.synth.clip import write_sequence

    v = small_video(seed=21, n_ants=4, n_frames=12)
    return write_sequence(v, tmp_path_factory.mktemp("seq") / "seq")


def test_cli_train_then_track(tmp_path, tiny_video):
    out = tmp_path / "model.pt"
    args = [
        "track",
        "train",
        "--synthetic",
        "--out",
        str(out),
        "--quiet",
        "--seed",
        "2",
        "--threads",
        "1",
        "--set",
        "max_steps=2",
        "--set",
        "centroid_batch=2",
        "--set",
        "patch_size=64",
        "--set",
        "pose_batch=4",
        "--set",
        "model.centroid_channels=[4, 8, 8]",
        "--set",
        "model.pose_channels=[4, 8, 8]",
        "--set",
        "synth.n_videos=1",
        "--set",
        "synth.frames_per_video=2",
        "--set",
        "validation.width=320",
        "--set",
        "validation.height=160",
        "--set",
        "validation.n_ants=3",
        "--set",
        "validation.n_frames=10",
    ]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    assert "2 steps" in res.output and "validation MOTA" in res.output
    report = json.loads(out.with_suffix(".json").read_text())
    assert report["stopped"] == "max_steps" and report["config"]["seed"] == 2
    assert {"mota", "idsw_rate", "f1", "body_error_median_px"} <= set(report["history"][-1])
    assert unet.load_model(out).config.centroid_channels == (4, 8, 8)
    # The spelling `track-train` is the same command.
    res = CliRunner().invoke(cli, ["track-train", "--out", str(out)])
    assert res.exit_code == 2 and "give training data" in res.output
    # Track with it: the detector is 'unet' (an untrained model may find nothing).
    res = CliRunner().invoke(
        cli,
        [
            "track",
            str(tiny_video / "video.mp4"),
            "--out",
            str(tmp_path / "run"),
            "--model",
            str(out),
            "--px-per-mm",
            "paper",
            "--no-overlay",
            "--quiet",
        ],
    )
    if res.exit_code == 0:
        summary = json.loads((tmp_path / "run" / "summary.json").read_text())
        assert summary["detector"] == "unet" and summary["model"] == str(out)
    else:
        # A 2-step model that finds nothing says so (exit 2), naming the detector.
        assert res.exit_code == 2, res.output
        assert "no animals detected" in res.output and "(unet detector)" in res.output
        assert not (tmp_path / "run" / "tracks.nc").exists()


def test_cli_wrong_model_file_exits_2(tmp_path, tiny_video):
    bad = tmp_path / "bad.pt"
    torch.save(unet.TopDownModel(SMALL_MODEL).state_dict(), bad)
    res = CliRunner().invoke(
        cli,
        [
            "track",
            str(tiny_video / "video.mp4"),
            "--out",
            str(tmp_path / "run"),
            "--model",
            str(bad),
            "--px-per-mm",
            "paper",
            "--quiet",
        ],
    )
    assert res.exit_code == 2
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and "has shape" in lines[0]
    res = CliRunner().invoke(
        cli, ["track", "train", "--labels", str(bad), "--out", str(tmp_path / "m.pt")]
    )
    assert res.exit_code == 2 and "--px-per-mm" in res.output
    res = CliRunner().invoke(
        cli,
        ["track", "train", "--synthetic", "--out", str(tmp_path / "m.pt"), "--set", "lr=-1"],
    )
    assert res.exit_code == 2 and "lr must be a positive number" in res.output


# ------------------------------------------------------------------ slow


@pytest.mark.slow
def test_briefly_trained_model_finds_the_ants(tmp_path):
    """600 steps on small synthetic videos (about 2 CPU-minutes): on frames of a video
    with another seed, the detector finds the ants and places their points.

    Tolerances: the fully trained model reaches precision and recall of 0.97-0.98 and a
    median body error of 0.45 px on the benchmark videos (docs/tracking_unet.md); a
    brief training must give at least 0.9, 0.9 and 1 px (1/20 of an ant's length), and
    fewer than 5 % of the ants with head and tail swapped (measured: precision 1.0,
    recall 0.95 of 100 ants, 0.50 px, none swapped).
    """
    cfg = tr.SynthDataConfig(n_videos=12, frames_per_video=8, width=480, height=200)
    data = tr.synthetic_data(cfg, np.random.default_rng(11))
    tcfg = tr.TrainConfig(max_steps=600, eval_every=10_000, val_fraction=0.0, threads=1)
    tr.train(data, tmp_path / "m.pt", tcfg)
    video = small_video(seed=99, n_ants=10, n_frames=40)
    frames = [video.render(k) for k in range(0, 40, 4)]
    truth = [video.keypoints[k][np.isfinite(video.keypoints[k, :, 1, 0])] for k in range(0, 40, 4)]
    det = make_detector(model=tmp_path / "m.pt", px_per_mm=video.config.px_per_mm)
    m = tr.detection_metrics([det.detect(f) for f in frames], truth, radius_px=10.0)
    assert m["recall"] >= 0.9 and m["precision"] >= 0.9, m
    assert m["body_error_median_px"] <= 1.0, m
    assert m["head_tail_swapped"] < 0.05, m
