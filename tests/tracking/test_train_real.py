"""Copy-paste augmentation (:mod:`thermoswarm.tracking.train.real`) on a shipped excerpt
of anTraX's JS16 data (real ant crops and a cut of the real background frame;
GPL-3.0, provenance in ``tests/data/antrax_crops/README.md``)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
from click.testing import CliRunner  # noqa: E402

from thermoswarm.cli import cli  # noqa: E402
from thermoswarm.errors import InputError  # noqa: E402
from thermoswarm.tracking import anatomy  # noqa: E402
from thermoswarm.tracking.train import real as trr  # noqa: E402

DATA = Path(__file__).parents[1] / "data" / "antrax_crops"
CROPS = DATA / "crops"
BACKGROUND = DATA / "background_cut.png"
ROI = DATA / "roimask_cut.png"


@pytest.fixture(scope="module")
def crops() -> dict[str, list[trr.AntCrop]]:
    return trr.load_crops(CROPS)


def test_crops_by_individual_keep_only_the_ant_labels(crops):
    # labels.csv lists Unknown as other_labels: its folder is left out.
    assert sorted(crops) == ["BB", "GP", "OO", "PP"]
    assert all(len(v) == 3 for v in crops.values())
    # anTraX aligns its crops on the body axis (vertical); O. biroi is about
    # 2.5 mm long, 27 px at the camera's 10.8 px/mm.
    for c in (c for v in crops.values() for c in v):
        assert abs(abs(np.degrees(c.angle)) - 90) < 15
        assert 20 < c.length < 34


def test_labels_land_where_the_crop_was_pasted(crops):
    # On a white background the composite is itself a background-removed image: the
    # body point measured on it is where the label says, the length the crop's.
    white = np.full((128, 128, 3), 255, np.uint8)
    cfg = trr.RealCropConfig(tile=128, ants_min=1, ants_max=1, touch_probability=0)
    data = trr.composite_frames(crops, white, np.ones((128, 128), bool), cfg,
                                np.random.default_rng(3), n_frames=30)  # fmt: skip
    err, ratio = [], []
    for frame, pts in zip(data.frames, data.points, strict=True):
        assert pts.shape == (1, 3, 2)
        assert np.isnan(pts[0, [0, 2]]).all()  # head and tail unlabelled
        m = trr.measure_crop(frame)
        assert m is not None
        edge = np.concatenate([frame[0], frame[-1], frame[:, 0], frame[:, -1]])
        if (edge < 250).any():
            continue  # cut by the tile's edge: its visible part has another centre
        err.append(np.linalg.norm(m.centre - pts[0, 1]))
        ratio.append(m.length / trr.crop_length_px(crops))
    assert len(err) >= 15
    # Bilinear resampling of a rotated crop moves its centroid by a fraction of a px.
    assert np.max(err) < 0.75, err
    # Scale jitter is +-10 %, crops differ by a few px: lengths stay within 20 %.
    assert 0.8 < np.min(ratio) and np.max(ratio) < 1.2


def test_pasted_ants_lie_inside_the_arena(crops):
    bg, roi = trr.load_background(BACKGROUND, ROI, 64)
    assert 0.2 < roi.mean() < 0.9  # the cut straddles the arena's edge
    # A disc-shaped ROI centred on a tile-sized background: the tile's turns and
    # mirrors leave it in place, so every body point must fall inside it.
    yy, xx = np.mgrid[0:64, 0:64]
    disc = np.hypot(xx - 31.5, yy - 31.5) < 20
    cfg = trr.RealCropConfig(tile=64, ants_min=1, ants_max=3, touch_probability=0)
    data = trr.composite_frames(crops, bg[:64, :64], disc, cfg, np.random.default_rng(0),
                                n_frames=20)  # fmt: skip
    body = np.concatenate([p[:, 1] for p in data.points])
    assert body.shape[0] >= 20 and all(f.shape == (64, 64, 3) for f in data.frames)
    assert np.hypot(body[:, 0] - 31.5, body[:, 1] - 31.5).max() < 20.5
    # px_per_mm: the crops' median length is the model's ant length (7.14 mm).
    assert data.px_per_mm == pytest.approx(trr.crop_length_px(crops) / anatomy.ANT_LENGTH_MM)


def test_hidden_ants_become_ignore_regions(crops):
    white = np.full((64, 64, 3), 255, np.uint8)
    cfg = trr.RealCropConfig(tile=64, ants_min=12, ants_max=12, touch_probability=1)
    data = trr.composite_frames(crops, white, np.ones((64, 64), bool), cfg,
                                np.random.default_rng(1), n_frames=10)  # fmt: skip
    n_lab = sum(p.shape[0] for p in data.points)
    n_ign = sum(g.shape[0] for g in data.ignore)
    assert n_ign > 0 and n_lab > 0
    assert n_lab + n_ign <= 120


def test_split_is_by_individual_and_seeded():
    names = [f"{a}{b}" for a in "BGOP" for b in "BGOP"]
    for seed in range(5):
        tr_, held = trr.split_identities(names, 0.25, np.random.default_rng(seed))
        assert len(held) == 4 and len(tr_) == 12
        assert not set(tr_) & set(held) and set(tr_) | set(held) == set(names)
    a = trr.split_identities(names, 0.25, np.random.default_rng(7))
    assert a == trr.split_identities(names, 0.25, np.random.default_rng(7))
    # Two individuals and any positive fraction: one each side.
    assert trr.split_identities(["x", "y"], 0.1, np.random.default_rng(0))[1] in (["x"], ["y"])


def test_same_seed_same_frames(crops):
    bg, roi = trr.load_background(BACKGROUND, ROI, 64)
    cfg = trr.RealCropConfig(tile=64)

    def make(seed: int) -> trr.LabeledFrames:
        return trr.composite_frames(crops, bg, roi, cfg, np.random.default_rng(seed), n_frames=5)

    a, b, c = make(11), make(11), make(12)
    assert all(np.array_equal(x, y) for x, y in zip(a.frames, b.frames, strict=True))
    assert all(
        np.array_equal(x, y, equal_nan=True) for x, y in zip(a.points, b.points, strict=True)
    )
    assert not all(np.array_equal(x, y) for x, y in zip(a.frames, c.frames, strict=True))


def test_bad_input_is_a_one_line_error(tmp_path, crops):
    (tmp_path / "empty" / "AA").mkdir(parents=True)
    with pytest.raises(InputError, match="no ant crops"):
        trr.load_crops(tmp_path / "empty")
    with pytest.raises(InputError, match="not a folder"):
        trr.load_crops(tmp_path / "nowhere")
    bad = tmp_path / "bad"
    shutil.copytree(CROPS / "BB", bad / "BB")
    (bad / "BB" / "zz.png").write_bytes(b"not a png")
    with pytest.raises(InputError, match=r"zz.png: cannot read the image"):
        trr.load_crops(bad)
    with pytest.raises(InputError, match="smaller than the 256 px tile"):
        trr.load_background(BACKGROUND, None, 256)
    with pytest.raises(InputError, match="cannot read the ROI mask"):
        trr.load_background(BACKGROUND, bad / "BB" / "zz.png", 64)


def _cli(tmp_path: Path, *extra: str, tile: int = 64) -> tuple[int, str]:
    args = ["track", "train", "--out", str(tmp_path / "m.pt"), "--quiet", "--threads", "1"]
    args += ["--set", "max_steps=2", "--set", "patch_size=32", "--set", "centroid_batch=2"]
    args += ["--set", "pose_batch=4", "--set", f"real.tile={tile}", "--set", "real.n_frames=6"]
    args += ["--set", "model.centroid_channels=[8,16,16]", "--set", "model.pose_channels=[8,8,8]"]
    res = CliRunner().invoke(cli, [*args, *extra])
    return res.exit_code, res.output


def test_cli_trains_on_composites_validated_on_held_out_individuals(tmp_path):
    code, out = _cli(
        tmp_path, "--real-crops", str(CROPS), "--background", str(BACKGROUND), "--roi", str(ROI)
    )
    assert code == 0, out
    report = json.loads((tmp_path / "m.json").read_text())
    src, val = report["data"]["source"], report["validation"]
    used = set(src.split("individuals ")[1].rstrip(")").split(", "))
    held = set(val.split("individuals ")[1].split(", "))
    assert len(held) == 1 and len(used) == 3 and not used & held
    assert report["data"]["n_frames"] == 6


def test_cli_bad_real_input(tmp_path):
    code, out = _cli(tmp_path, "--real-crops", str(CROPS))
    assert code == 2 and out.strip().count("\n") == 0 and "--background PNG" in out
    (tmp_path / "none").mkdir()
    code, out = _cli(tmp_path, "--real-crops", str(tmp_path / "none"), "--background",
                     str(BACKGROUND))  # fmt: skip
    assert code == 2 and out.startswith("error:") and "no ant crops" in out
    code, out = _cli(tmp_path, "--real-crops", str(CROPS), "--background", str(BACKGROUND),
                     tile=512)  # fmt: skip
    assert code == 2 and "smaller than the 512 px tile" in out
