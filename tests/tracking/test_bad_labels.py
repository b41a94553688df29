"""``thermoswarm track train`` on labels whose frames are missing: one-line errors
(exit 2) naming the file and the missing frame or image, never a traceback."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from thermoswarm.cli import cli

sio = pytest.importorskip("sleap_io")


def _one_line_error(res):
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), res.output
    assert "Traceback" not in res.output
    return lines[0]


def _train(labels, tmp_path):
    args = ["track", "train", "--labels", str(labels), "--out", str(tmp_path / "m.pt")]
    return CliRunner().invoke(cli, [*args, "--px-per-mm", "3"])


def _slp(tmp_path, frame_idx, *, write_video=True):
    from thermoswarm.tracking.synth.clip import write_video as wv

    frames = [np.full((48, 64, 3), 200, np.uint8) for _ in range(3)]
    if write_video:
        wv(frames, tmp_path / "clip.mp4", fps=10)
    skel = sio.Skeleton(["head", "body", "tail"])
    video = sio.Video(filename=str(tmp_path / "clip.mp4"), open_backend=False)
    inst = sio.Instance.from_numpy(np.array([[10.0, 10], [20, 10], [30, 10]]), skeleton=skel)
    lf = sio.LabeledFrame(video=video, frame_idx=frame_idx, instances=[inst])
    labels = sio.Labels(labeled_frames=[lf], videos=[video], skeletons=[skel])
    path = tmp_path / "labels.slp"
    sio.save_slp(labels, str(path), embed=False, verbose=False)
    return path


def test_slp_whose_video_is_missing(tmp_path):
    line = _one_line_error(_train(_slp(tmp_path, 0, write_video=False), tmp_path))
    assert "labels.slp" in line and "clip.mp4" in line


def test_slp_whose_labelled_frame_is_past_the_video_end(tmp_path):
    line = _one_line_error(_train(_slp(tmp_path, 40), tmp_path))
    assert "labels.slp" in line and "frame 40" in line


def test_coco_whose_images_are_missing(tmp_path):
    doc = {
        "images": [{"id": 1, "file_name": "frame_0001.png", "width": 64, "height": 48}],
        "annotations": [
            {
                "id": 1,
                "image_id": 1,
                "category_id": 1,
                "bbox": [5, 5, 30, 10],
                "keypoints": [10, 10, 2, 20, 10, 2, 30, 10, 2],
                "num_keypoints": 3,
            }
        ],
        "categories": [{"id": 1, "name": "ant", "keypoints": ["head", "body", "tail"]}],
    }
    path = tmp_path / "labels.json"
    path.write_text(json.dumps(doc))
    line = _one_line_error(_train(path, tmp_path))
    assert "labels.json" in line and "frame_0001.png" in line and "missing" in line
