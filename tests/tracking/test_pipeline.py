"""End to end: synthetic video -> ``thermoswarm track`` -> trajectories and MOT files;
``thermoswarm evaluate``; bad inputs give one-line errors with exit status 2."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.optimize import linear_sum_assignment
from tracking_fixtures import small_video

from thermoswarm.cli import cli
from thermoswarm.errors import InputError
from thermoswarm.io import read_tracks
from thermoswarm.io.mot import read_mot_table, write_mot_table
from thermoswarm.tracking.evaluate import METRIC_KEYS, evaluate_files
from thermoswarm.tracking.pipeline import track_video
from thermoswarm.tracking.synth.clip import write_sequence


@pytest.fixture(scope="module")
def sequence(tmp_path_factory):
    """A 3 s, 12-ant synthetic sequence written as mp4 with its ground truth."""
    v = small_video(seed=17, n_ants=12, n_frames=90)
    out = write_sequence(v, tmp_path_factory.mktemp("seq") / "seq")
    return v, out


@pytest.fixture(scope="module")
def tracked(sequence, tmp_path_factory):
    v, seq = sequence
    out = tmp_path_factory.mktemp("run") / "out"
    res = CliRunner().invoke(
        cli,
        ["track", str(seq / "video.mp4"), "--out", str(out), "--px-per-mm", "paper", "--quiet"],
    )
    assert res.exit_code == 0, res.output
    return v, seq, out, res.output


def _errors_mm(gt, tr):
    """Per-frame matched keypoint errors (mm) between two trajectory datasets."""
    G = gt["position"].transpose("time", "individuals", "keypoints", "space").values
    P = tr["position"].transpose("time", "individuals", "keypoints", "space").values
    err, agree = [], []
    for t in range(G.shape[0]):
        gi = np.flatnonzero(np.isfinite(G[t, :, 1, 0]))
        pi = np.flatnonzero(np.isfinite(P[t, :, 1, 0]))
        if not (gi.size and pi.size):
            continue
        D = np.linalg.norm(G[t][gi][:, None, 1] - P[t][pi][None, :, 1], axis=-1)
        r, c = linear_sum_assignment(D)
        ok = D[r, c] < 2.0
        err.append(D[r, c][ok])
        g, p = G[t, gi[r[ok]]], P[t, pi[c[ok]]]
        agree.append(((g[:, 0] - g[:, 2]) * (p[:, 0] - p[:, 2])).sum(-1) > 0)
    return np.concatenate(err), np.concatenate(agree)


def test_track_writes_every_output(tracked):
    v, seq, out, output = tracked
    assert "90 frames" in output
    names = {p.name for p in out.iterdir()}
    assert names == {
        "tracks.nc",
        "tracks_mot.txt",
        "detections.txt",
        "overlay.mp4",
        "summary.json",
    }
    summary = json.loads((out / "summary.json").read_text())
    assert summary["n_frames"] == 90 and summary["fps"] == 30.0
    assert summary["fps_source"] == "video" and summary["px_per_mm"] == 3.04
    assert summary["detector"] == "classical" and summary["frame_size"] == [480, 200]
    ds = read_tracks(out / "tracks.nc")
    assert list(ds["keypoints"].values) == ["head", "body", "tail"]
    assert ds.attrs["space_unit"] == "mm" and ds.attrs["fps"] == 30.0
    assert ds.sizes["time"] == 90 and ds.sizes["individuals"] == summary["n_tracks"]
    assert "interpolated" in ds and "confidence" in ds
    dets = read_mot_table(out / "detections.txt")
    assert np.all(dets[:, 1] == -1)


def test_tracks_match_the_ground_truth(tracked):
    v, seq, out, _ = tracked
    m = evaluate_files(seq / "gt" / "gt.txt", out / "tracks_mot.txt")
    assert m["mota"] > 0.9
    assert m["idsw_rate"] < 0.01
    # Positions in mm: the ant is 7.14 mm long, a pixel is 0.33 mm.
    err, agree = _errors_mm(v.tracks, read_tracks(out / "tracks.nc"))
    assert np.median(err) < 0.25
    assert np.quantile(err, 0.9) < 1.0  # merged ants: 90 % within 3 px
    assert agree.mean() > 0.95


def test_speeds_from_tracks_follow_the_truth(tracked):
    # The per-frame speed of the tracked body points against the true speed: pixel
    # noise adds a floor (~ sqrt(2) * 0.17 mm * 30 / s ~ 7 mm/s per frame), so compare
    # speeds over 5 frames (1/6 s), where it drops to ~1.5 mm/s.
    v, seq, out, _ = tracked
    tr = read_tracks(out / "tracks.nc")
    G = v.tracks["position"].sel(keypoints="body").transpose("time", "individuals", "space").values
    P = tr["position"].sel(keypoints="body").transpose("time", "individuals", "space").values
    lag = 5
    true_v, est_v = [], []
    for t in range(0, 90 - lag):
        gi = np.flatnonzero(np.all(np.isfinite(G[[t, t + lag]]), axis=(0, 2)))
        pi = np.flatnonzero(np.all(np.isfinite(P[[t, t + lag]]), axis=(0, 2)))
        if not (gi.size and pi.size):
            continue
        D = np.linalg.norm(G[t][gi][:, None] - P[t][pi][None, :], axis=-1)
        r, c = linear_sum_assignment(D)
        ok = D[r, c] < 2.0
        a, b = gi[r[ok]], pi[c[ok]]
        # Same ant at both ends.
        same = np.linalg.norm(G[t + lag, a] - P[t + lag, b], axis=-1) < 2.0
        a, b = a[same], b[same]
        true_v.append(np.linalg.norm(G[t + lag, a] - G[t, a], axis=-1) * 30 / lag)
        est_v.append(np.linalg.norm(P[t + lag, b] - P[t, b], axis=-1) * 30 / lag)
    true_v, est_v = np.concatenate(true_v), np.concatenate(est_v)
    assert true_v.size > 500
    assert np.median(np.abs(est_v - true_v)) < 1.5
    assert abs(np.mean(est_v**2) / np.mean(true_v**2) - 1) < 0.1


def test_retrack_from_detections(tracked, tmp_path):
    v, seq, out, _ = tracked
    res = CliRunner().invoke(
        cli,
        [
            "track",
            "--detections",
            str(out / "detections.txt"),
            "--out",
            str(tmp_path / "re"),
            "--px-per-mm",
            "3.04",
            "--fps",
            "30",
        ],
    )
    assert res.exit_code == 0, res.output
    ds = read_tracks(tmp_path / "re" / "tracks.nc")
    assert ds["position"].sel(keypoints="head").isnull().all()
    m = evaluate_files(seq / "gt" / "gt.txt", tmp_path / "re" / "tracks_mot.txt")
    assert m["mota"] > 0.85


def test_evaluate_cli_prints_json(tracked):
    v, seq, out, _ = tracked
    res = CliRunner().invoke(
        cli, ["evaluate", str(seq / "gt" / "gt.txt"), str(out / "tracks_mot.txt"), "--iou", "0.5"]
    )
    assert res.exit_code == 0, res.output
    m = json.loads(res.output)
    assert set(METRIC_KEYS) <= set(m)
    ref = evaluate_files(seq / "gt" / "gt.txt", out / "tracks_mot.txt")
    assert m["mota"] == pytest.approx(ref["mota"]) and m["idsw"] == ref["idsw"]


def test_frames_folder_needs_fps(sequence, tmp_path):
    v, _ = sequence
    seq = write_sequence(small_video(seed=3, n_frames=12), tmp_path / "s", video_format="frames")
    with pytest.raises(InputError, match="pass --fps"):
        track_video(seq / "img1", tmp_path / "o", px_per_mm=3.04)
    summary = track_video(seq / "img1", tmp_path / "o", px_per_mm=3.04, fps=30, overlay=False)
    assert summary["n_frames"] == 12 and summary["fps_source"] == "user"


def _one_line_error(res):
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), res.output
    assert "Traceback" not in res.output
    return lines[0]


@pytest.mark.parametrize(
    "content", [b"", b"\x00\x01garbage" * 100, b"\x00\x00\x00\x18ftypmp42" + b"\x00" * 500]
)
def test_corrupt_video_is_a_one_line_error(tmp_path, content):
    bad = tmp_path / "broken.mp4"
    bad.write_bytes(content)
    res = CliRunner().invoke(
        cli, ["track", str(bad), "--out", str(tmp_path / "o"), "--px-per-mm", "paper"]
    )
    line = _one_line_error(res)
    assert "broken.mp4" in line
    assert not (tmp_path / "o" / "tracks.nc").exists()


def test_cli_input_errors(tmp_path, tracked):
    v, seq, out, _ = tracked
    runner = CliRunner()
    empty = tmp_path / "empty.txt"
    empty.write_text("")
    line = _one_line_error(
        runner.invoke(
            cli,
            [
                "track",
                "--detections",
                str(empty),
                "--out",
                str(tmp_path / "o"),
                "--px-per-mm",
                "3",
                "--fps",
                "30",
            ],
        )
    )
    assert "empty.txt" in line and "empty" in line
    line = _one_line_error(
        runner.invoke(cli, ["track", "--out", str(tmp_path / "o"), "--px-per-mm", "3"])
    )
    assert "VIDEO or --detections" in line
    line = _one_line_error(
        runner.invoke(
            cli,
            [
                "track",
                str(tmp_path / "nope.mp4"),
                "--out",
                str(tmp_path / "o"),
                "--px-per-mm",
                "3",
            ],
        )
    )
    assert "nope.mp4" in line
    line = _one_line_error(
        runner.invoke(
            cli,
            [
                "track",
                str(seq / "video.mp4"),
                "--out",
                str(tmp_path / "o"),
                "--px-per-mm",
                "3",
                "--set",
                "tracker.max_gapp=1",
            ],
        )
    )
    assert "max_gapp" in line
    line = _one_line_error(
        runner.invoke(
            cli,
            [
                "track",
                str(seq / "video.mp4"),
                "--out",
                str(tmp_path / "o"),
                "--px-per-mm",
                "3",
                "--set",
                "detector.threshold=7",
            ],
        )
    )
    assert "threshold" in line
    # A model file that is not a model of the expected shape.
    junk = tmp_path / "model.pt"
    junk.write_bytes(b"not weights")
    line = _one_line_error(
        runner.invoke(
            cli,
            [
                "track",
                str(seq / "video.mp4"),
                "--out",
                str(tmp_path / "o"),
                "--px-per-mm",
                "3",
                "--model",
                str(junk),
            ],
        )
    )
    assert "model" in line or "unet" in line
    dets = tmp_path / "d.txt"
    write_mot_table(dets, np.array([[1, -1, 0, 0, 5, 5, 1, -1, -1, -1]]))
    line = _one_line_error(
        runner.invoke(
            cli,
            ["track", "--detections", str(dets), "--out", str(tmp_path / "o"), "--px-per-mm", "3"],
        )
    )
    assert "--fps" in line
    line = _one_line_error(runner.invoke(cli, ["evaluate", str(empty), str(dets)]))
    assert "empty.txt" in line


def test_truncated_video_is_a_one_line_error(sequence, tmp_path):
    _, seq = sequence
    data = (seq / "video.mp4").read_bytes()
    bad = tmp_path / "cut.mp4"
    bad.write_bytes(data[: len(data) // 3])  # no index (moov) at the end
    res = CliRunner().invoke(
        cli, ["track", str(bad), "--out", str(tmp_path / "o"), "--px-per-mm", "paper"]
    )
    assert "cut.mp4" in _one_line_error(res)
