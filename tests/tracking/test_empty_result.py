"""No silent empty result: a run that confirms no track writes its outputs and says,
on stderr and in ``WARNING.txt`` and ``summary.json``, why (detections, frames, frame
rate, the confirmation needed) and what to try (issue 32, item 2)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr
from click.testing import CliRunner
from tracking_fixtures import small_video

from thermoswarm.cli import cli
from thermoswarm.io.mot import write_mot_table
from thermoswarm.tracking.synth.clip import write_sequence


@pytest.fixture(scope="module")
def clip(tmp_path_factory):
    """12 frames of 8 ants at 30 frames/s, as mp4."""
    v = small_video(seed=3, n_frames=12)
    return write_sequence(v, tmp_path_factory.mktemp("clip") / "seq") / "video.mp4"


def _track(*args: str):
    return CliRunner().invoke(cli, ["track", *args, "--quiet", "--no-overlay"])


def test_too_few_frames_warns_with_the_reason_and_writes_the_result(clip, tmp_path):
    # 3 frames at 30 frames/s: the ants preset confirms a track after 0.1 s, that is
    # 1 + 3 = 4 detections, so no track can be confirmed.
    out = tmp_path / "o"
    res = _track(str(clip), "--out", str(out), "--px-per-mm", "paper", "--max-frames", "3")
    assert res.exit_code == 0, res.output
    assert "0 tracks" in res.stdout
    err = " ".join(res.stderr.split())
    assert "WARNING: no track was confirmed" in err
    assert "in 3 frames" in err and "at 30 frames/s" in err
    assert "tracker.confirm_s = 0.1 s = 4 detections" in err
    assert "fewer frames (3)" in err
    assert "--set tracker.confirm_s=0" in err and "detector." in err
    summary = json.loads((out / "summary.json").read_text())
    n_det = summary["n_detections"]
    assert n_det > 0 and f"{n_det} detections in 3 frames" in err
    assert len(summary["warnings"]) == 1 and "no track" in summary["warnings"][0]
    assert "no track was confirmed" in (out / "WARNING.txt").read_text()
    with xr.open_dataset(out / "tracks.nc") as ds:  # written, with no individual
        assert ds.sizes["individuals"] == 0
    # What the warning suggests works: confirmed at once, tracks, no warning left.
    res = _track(str(clip), "--out", str(out), "--px-per-mm", "paper", "--max-frames", "3",
                 "--set", "tracker.confirm_s=0")  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "WARNING" not in res.stderr
    assert json.loads((out / "summary.json").read_text())["n_tracks"] > 0
    assert json.loads((out / "summary.json").read_text())["warnings"] == []
    assert not (out / "WARNING.txt").exists()


def test_detections_file_without_a_track_warns(tmp_path):
    # One ant's box in frames 1, 3 and 5 at 10 frames/s: 0.1 s is 1 + 1 = 2 detections,
    # but a new track may not miss a frame (tentative_gap_s 0).
    rows = np.array([[1, -1, 100, 100, 30, 10, 1, -1, -1, -1],
                     [3, -1, 104, 100, 30, 10, 1, -1, -1, -1],
                     [5, -1, 108, 100, 30, 10, 1, -1, -1, -1]], float)  # fmt: skip
    write_mot_table(tmp_path / "d.txt", rows)
    out = tmp_path / "o"
    res = _track("--detections", str(tmp_path / "d.txt"), "--fps", "10", "--out", str(out))
    assert res.exit_code == 0, res.output
    err = " ".join(res.stderr.split())
    assert "WARNING: no track was confirmed" in err
    assert "3 detections in 5 frames (3 frames with any) at 10 frames/s" in err
    assert "= 2 detections at 10 frames/s, with no missed frame between them" in err
    assert "--object-size-px" in err and "--max-frames" not in err
    assert json.loads((out / "summary.json").read_text())["warnings"]
    res = _track("--detections", str(tmp_path / "d.txt"), "--fps", "10", "--out", str(out),
                 "--set", "tracker.tentative_gap_s=0.1")  # fmt: skip
    assert res.exit_code == 0 and "WARNING" not in res.stderr, res.output
