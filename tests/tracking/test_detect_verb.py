"""``thermoswarm detect``: COCO keypoints and MOTChallenge detections from videos,
folders and images, read back by ``thermoswarm track --detections``."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner
from tracking_fixtures import small_video

from thermoswarm.cli import cli
from thermoswarm.io.mot import read_mot_table
from thermoswarm.tracking.detect.files import read_detections
from thermoswarm.tracking.evaluate import evaluate_files
from thermoswarm.tracking.pipeline import track_video
from thermoswarm.tracking.synth.clip import write_sequence


def _one_line_error(res):
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), res.output
    assert "Traceback" not in res.output
    return lines[0]


@pytest.fixture(scope="module")
def detected(tmp_path_factory):
    v = small_video(seed=17, n_ants=12, n_frames=60)
    seq = write_sequence(v, tmp_path_factory.mktemp("seq") / "seq")
    out = tmp_path_factory.mktemp("det") / "out"
    res = CliRunner().invoke(cli, ["detect", str(seq / "video.mp4"), "--out", str(out)])
    assert res.exit_code == 0, res.output
    return v, seq, out


def test_detect_writes_coco_keypoints_and_mot(detected):
    v, seq, out = detected
    coco = json.loads((out / "video.json").read_text())
    (cat,) = coco["categories"]
    assert cat["keypoints"] == ["head", "body", "tail"] and cat["skeleton"] == [[1, 2], [2, 3]]
    assert len(coco["images"]) == 60
    assert {im["width"] for im in coco["images"]} == {480}
    anns = coco["annotations"]
    assert all(len(a["keypoints"]) == 9 and 0 <= a["score"] <= 1 for a in anns)
    mot = read_mot_table(out / "video_det.txt")
    assert len(mot) == len(anns)
    np.testing.assert_allclose(mot[:, 2:6], [a["bbox"] for a in anns], atol=1e-3)
    # The body keypoints lie on the rendered ants: most ground-truth ants of every
    # frame have a detection within a quarter body length (12 ants x 60 frames).
    gt = read_mot_table(seq / "gt" / "gt.txt")
    L = coco["info"]["thermoswarm"]["length_px"]
    hits = total = 0
    for f in range(1, 61):
        g = gt[gt[:, 0] == f]
        gc = g[:, 2:4] + g[:, 4:6] / 2
        body = np.array([a["keypoints"][3:5] for a in anns if a["image_id"] == f])
        if len(gc) and len(body):
            d = np.linalg.norm(gc[:, None] - body[None], axis=-1).min(1)
            hits += int((d < 0.25 * L).sum())
        total += len(gc)
    assert hits >= 0.9 * total


def test_coco_read_back_gives_the_same_tracks(detected, tmp_path):
    import xarray as xr

    _, seq, out = detected
    res = CliRunner().invoke(
        cli,
        [
            "track",
            "--detections",
            str(out / "video.json"),
            "--fps",
            "30",
            "--out",
            str(tmp_path / "f"),
        ],
    )
    assert res.exit_code == 0, res.output
    track_video(seq / "video.mp4", tmp_path / "v", hints=False, overlay=False)
    a = read_mot_table(tmp_path / "v" / "tracks_mot.txt")
    b = read_mot_table(tmp_path / "f" / "tracks_mot.txt")
    assert a.shape == b.shape and len(a) > 500
    np.testing.assert_allclose(a, b, atol=2e-3)  # the MOT text keeps 3 decimals
    with (
        xr.open_dataset(tmp_path / "v" / "tracks.nc") as dv,
        xr.open_dataset(tmp_path / "f" / "tracks.nc") as df,
    ):
        assert dv.attrs["space_unit"] == df.attrs["space_unit"] == "px"
        np.testing.assert_allclose(dv["position"].values, df["position"].values, atol=1e-6)


def test_mot_read_back_tracks_the_boxes(detected, tmp_path):
    # MOT rows carry boxes only (no head or tail): the tracks are not identical, but
    # they follow the video's own tracks and the ground truth closely.
    _, seq, out = detected
    res = CliRunner().invoke(
        cli,
        [
            "track",
            "--detections",
            str(out / "video_det.txt"),
            "--fps",
            "30",
            "--out",
            str(tmp_path / "m"),
        ],
    )
    assert res.exit_code == 0, res.output
    track_video(seq / "video.mp4", tmp_path / "v", hints=False, overlay=False)
    m = evaluate_files(tmp_path / "v" / "tracks_mot.txt", tmp_path / "m" / "tracks_mot.txt")
    assert m["mota"] > 0.85 and m["idf1"] > 0.85
    g = evaluate_files(seq / "gt" / "gt.txt", tmp_path / "m" / "tracks_mot.txt")
    assert g["mota"] > 0.8


def test_detect_folders_and_images(tmp_path):
    v = small_video(seed=5, n_ants=6, n_frames=12)
    seq = write_sequence(v, tmp_path / "s", video_format="frames")
    frames = sorted((seq / "img1").iterdir())
    out = tmp_path / "o"
    res = CliRunner().invoke(
        cli,
        [
            "detect",
            str(seq / "img1"),
            *map(str, frames[:8]),
            "--out",
            str(out),
            "--px-per-mm",
            "paper",
        ],
    )
    assert res.exit_code == 0, res.output
    assert {p.name for p in out.iterdir()} == {
        "img1.json",
        "img1_det.txt",
        "images.json",
        "summary.json",
    }
    folder = read_detections(out / "img1.json")
    images = read_detections(out / "images.json")
    assert folder.points is not None and images.points is not None
    assert len(set(folder.frames.tolist())) >= 11 and set(images.frames.tolist()) <= set(
        range(1, 9)
    )
    names = [im["file_name"] for im in json.loads((out / "images.json").read_text())["images"]]
    assert names == [f.name for f in frames[:8]]


@pytest.mark.parametrize("content", [b"", b"\x00\x01garbage" * 100])
def test_detect_corrupt_video_is_a_one_line_error(tmp_path, content):
    bad = tmp_path / "broken.mp4"
    bad.write_bytes(content)
    line = _one_line_error(
        CliRunner().invoke(cli, ["detect", str(bad), "--out", str(tmp_path / "o")])
    )
    assert "broken.mp4" in line


def test_detect_mixed_image_sizes_is_a_one_line_error(tmp_path):
    import cv2

    paths = []
    for k, size in enumerate([(120, 160), (120, 160), (90, 160)]):
        p = tmp_path / f"photo{k}.png"
        cv2.imwrite(str(p), np.full((*size, 3), 150, np.uint8))
        paths.append(str(p))
    line = _one_line_error(
        CliRunner().invoke(
            cli, ["detect", *paths, "--out", str(tmp_path / "o"), "--px-per-mm", "3"]
        )
    )
    assert "photo2.png" in line and "160x90" in line


def test_coco_keypoints_of_other_tools(tmp_path):
    # A COCO file whose category names head/body/tail among other keypoints, with an
    # unknown (v = 0) head: poses read by name, the box centre stands for no body.
    data = {
        "images": [{"id": 7, "file_name": "frame_000003.png", "width": 100, "height": 80}],
        "categories": [{"id": 1, "name": "ant", "keypoints": ["tail", "x", "body", "head"]}],
        "annotations": [
            {
                "id": 1,
                "image_id": 7,
                "bbox": [10, 10, 20, 10],
                "keypoints": [12, 15, 2, 0, 0, 0, 20, 15, 2, 0, 0, 0],
            },
            {"id": 2, "image_id": 7, "bbox": [50, 40, 10, 10]},
        ],
    }
    p = tmp_path / "k.json"
    p.write_text(json.dumps(data))
    t = read_detections(p)
    assert t.frames.tolist() == [3, 3] and not t.pose_boxes
    np.testing.assert_allclose(t.points[0], [[np.nan, np.nan], [20, 15], [12, 15]])
    np.testing.assert_allclose(t.points[1, 1], [55, 45])
    d = t.per_frame(first_frame=1)[1][2]  # frames 1, 2, 3
    assert d.boxes is not None and len(d) == 2
