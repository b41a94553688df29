"""Photo series recognised without clocks (``thermoswarm.tracking.pipeline.series``):
by the times in their names, by how much changes between consecutive images, and a
plain frame sequence that must stay a video.  All images are drawn here: a textured
floor and dark elliptic ants, 320 x 240 px."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from click.testing import CliRunner

from thermoswarm.cli import cli
from thermoswarm.tracking.pipeline.series import (
    MIN_CHANGE_RATIO,
    name_times,
    sequence_order,
    series_evidence,
)

W, H, N_ANTS = 320, 240, 8


def _floor(rng: np.random.Generator) -> np.ndarray:
    tex = cv2.GaussianBlur(rng.normal(0, 10, (H, W)).astype(np.float32), (0, 0), 2)
    return 185 + tex


def _draw(floor: np.ndarray, ants: np.ndarray, rng, gain: float = 1.0) -> np.ndarray:
    """The floor (times ``gain``, the light) with ants at ``ants`` (n, 3: x, y, deg) and
    sensor noise (sd 3 grey levels)."""
    img = floor * gain
    for x, y, a in ants:
        cv2.ellipse(img, (int(round(x)), int(round(y))), (7, 2), float(a), 0, 360, 40.0, -1)
    img = img + rng.normal(0, 3, img.shape)
    return np.clip(img, 0, 255).astype(np.uint8)


def _video_frames(seed: int, n: int = 30) -> list[np.ndarray]:
    """A video: ants 14 px long walking 1.2 px a frame (2.6 body lengths/s at 30
    frames/s), the light still."""
    rng = np.random.default_rng(seed)
    floor = _floor(rng)
    pos = np.column_stack([rng.uniform(30, W - 30, N_ANTS), rng.uniform(30, H - 30, N_ANTS)])
    ang = rng.uniform(0, 2 * np.pi, N_ANTS)
    out = []
    for _ in range(n):
        ang += rng.normal(0, 0.1, N_ANTS)
        pos += 1.2 * np.column_stack([np.cos(ang), np.sin(ang)])
        pos = np.clip(pos, 15, [W - 15, H - 15])
        out.append(_draw(floor, np.column_stack([pos, np.degrees(ang)]), rng))
    return out


def _photos(seed: int, n: int = 30) -> list[np.ndarray]:
    """Photos 30 min apart: the ants somewhere else each time (8 of a 4 x 3 grid of
    80 px cells, so that no two touch), the light drifting."""
    rng = np.random.default_rng(seed)
    floor = _floor(rng)
    out = []
    for k in range(n):
        cells = rng.permutation(12)[:N_ANTS]
        ants = np.column_stack(
            [
                40 + 80 * (cells % 4) + rng.uniform(-15, 15, N_ANTS),
                40 + 80 * (cells // 4) + rng.uniform(-15, 15, N_ANTS),
                rng.uniform(0, 180, N_ANTS),
            ]
        )
        out.append(_draw(floor, ants, rng, gain=1.0 + 0.08 * np.sin(k / 3)))
    return out


def _write(folder: Path, frames: list[np.ndarray], names: list[str]) -> list[Path]:
    folder.mkdir(parents=True)
    for img, name in zip(frames, names, strict=True):
        assert cv2.imwrite(str(folder / name), img)
    return sorted(folder.iterdir())


def test_series_recognised_by_the_times_in_names(tmp_path):
    frames = _video_frames(1, 16)  # the pictures alone say "video"
    stamps = [f"tray_2024-05-01_{8 + k // 2:02d}-{30 * (k % 2):02d}-00.png" for k in range(16)]
    named = series_evidence(_write(tmp_path / "named", frames, stamps))
    assert named["series"] and named["by"] == "names"
    assert named["median_gap_s"] == pytest.approx(1800.0)
    # The same pictures as numbered frames: not a series; a second apart by their
    # names: not a series either.
    plain = series_evidence(
        _write(tmp_path / "plain", frames, [f"f{k:04d}.png" for k in range(16)])
    )
    assert not plain["series"] and plain["by"] == "changes"
    secs = [f"cam_20240501_0830{k:02d}.png" for k in range(16)]
    fast = series_evidence(_write(tmp_path / "fast", frames, secs))
    assert not fast["series"] and fast["by"] == "names" and fast["median_gap_s"] == 1.0
    # One "time" in every name is no clock: the changes decide.
    same = series_evidence(
        _write(tmp_path / "same", frames, [f"ant_3d_{k:03d}.png" for k in range(16)])
    )
    assert not same["series"] and same["by"] == "changes"


def test_names_with_spans_and_order(tmp_path):
    names = [Path(n) for n in ("p_1h30m.png", "p_0min.png", "p_30min.png", "p_1h.png")]
    assert name_times(names).tolist() == [5400.0, 0.0, 1800.0, 3600.0]
    assert name_times([Path("t1_411.JPG"), Path("t1_412.JPG")]) is None
    assert name_times([Path("tray_20240501_083000.png"), Path("x.png")]) is None
    # A camera counter that wrapped (trial 6: 826..999 then 000..019).
    wrapped = [Path(f"t6_{n:03d}.JPG") for n in (0, 1, 19, 826, 827, 999)]
    order = [p.stem for p in sequence_order(wrapped)]
    assert order == ["t6_826", "t6_827", "t6_999", "t6_000", "t6_001", "t6_019"]
    plain = [Path(f"t1_{n}.JPG") for n in (413, 411, 412)]
    assert [p.stem for p in sequence_order(plain)] == ["t1_411", "t1_412", "t1_413"]
    unpadded = [Path(f"f{n}.png") for n in (10, 9, 100, 1)]
    assert [p.stem for p in sequence_order(unpadded)] == ["f1", "f9", "f10", "f100"]


@pytest.mark.parametrize("seed", [2, 3])
def test_series_recognised_by_changes_and_frames_are_not(tmp_path, seed):
    names = [f"img_{k:04d}.png" for k in range(30)]
    photos = series_evidence(_write(tmp_path / "photos", _photos(seed), names))
    frames = series_evidence(_write(tmp_path / "frames", _video_frames(seed), names))
    assert photos["by"] == frames["by"] == "changes"
    assert photos["series"], photos
    assert not frames["series"], frames
    # Clear of the line on both sides (drawn: about 1.0 and 0.49).
    assert photos["change_ratio"] > MIN_CHANGE_RATIO + 0.3
    assert frames["change_ratio"] < MIN_CHANGE_RATIO - 0.08


def test_still_frames_are_not_a_series(tmp_path):
    rng = np.random.default_rng(4)
    floor = _floor(rng)
    still = [_draw(floor, np.zeros((0, 3)), rng) for _ in range(12)]
    ev = series_evidence(_write(tmp_path / "still", still, [f"{k}.png" for k in range(12)]))
    assert not ev["series"] and ev["changed_share"] < 2e-4


def test_detect_takes_a_series_without_clocks_in_windows(tmp_path):
    folder = tmp_path / "tray"
    _write(folder, _photos(5, 26), [f"t1_{k:03d}.png" for k in range(26)])
    out = tmp_path / "d"
    res = CliRunner().invoke(cli, ["detect", str(folder), "--out", str(out)])
    assert res.exit_code == 0, res.output
    rec = json.loads((out / "summary.json").read_text())["inputs"][0]
    assert rec["photo_series"]["recognised_by"] == "changes"
    assert rec["photo_series"]["series_window"] == 12
    coco = json.loads((out / "tray.json").read_text())
    per = np.bincount([a["image_id"] for a in coco["annotations"]], minlength=27)[1:]
    # 8 ants apart in every photo, each at a new place: each window's background
    # holds none of them, so every photo's count is 8 (one miss or extra in all 26).
    assert np.abs(per - N_ANTS).sum() <= 1, per
    res = CliRunner().invoke(cli, ["detect", str(folder), "--out", str(out), "--series", "no"])
    assert res.exit_code == 0, res.output
    assert json.loads((out / "summary.json").read_text())["inputs"][0]["photo_series"] is None


def _run(*args: str) -> None:
    res = CliRunner().invoke(cli, list(args))
    assert res.exit_code == 0, res.output


def test_track_on_a_photo_series_detects_as_detect_and_links_no_photos(tmp_path):
    """``track`` on photos recognised as a series by their changes: the detections are
    ``detect``'s, photo for photo; no photo is linked to the next (the interval is
    unknown and the ants are elsewhere in every photo), and the summary says so."""
    tray = tmp_path / "tray"
    _write(tray, _photos(5, 26), [f"t1_{k:03d}.png" for k in range(26)])
    _run("detect", str(tray), "--out", str(tmp_path / "d"))
    _run("track", str(tray), "--out", str(tmp_path / "t"))  # no --fps: not needed
    det_txt = (tmp_path / "d" / "tray_det.txt").read_text()
    assert (tmp_path / "t" / "detections.txt").read_text() == det_txt
    assert len(det_txt.splitlines()) >= 26 * N_ANTS - 1  # 8 ants in each photo
    summary = json.loads((tmp_path / "t" / "summary.json").read_text())
    ps = summary["photo_series"]
    assert ps["recognised_by"] == "changes" and ps["series_window"] == 12
    assert ps["series_options"] == {"shift_px": 1, "split_area": 2.5}
    assert ps["interval_s"] is None and ps["fps_source"] == "assumed" and ps["fps"] == 1.0
    assert not ps["linked"] and ps["files"] == [f"t1_{k:03d}.png" for k in range(26)]
    assert summary["n_tracks"] == 0 and summary["n_frames"] == 26
    assert (tmp_path / "t" / "tracks_mot.txt").read_text() == ""
    (note,) = summary["warnings"]
    assert note == ps["note"] == (tmp_path / "t" / "WARNING.txt").read_text().strip()
    for words in ("interval between them is unknown", "1 photo/s (assumed)",
                  "identities cannot be followed", "thermoswarm detect", "--regions"):  # fmt: skip
        assert words in note, words
    # --series no: video frames at --fps, from a still camera (photos 30 min apart
    # never register to each other), no series record and no such warning.
    _run("track", str(tray), "--out", str(tmp_path / "v"), "--series", "no", "--fps", "10")
    summary = json.loads((tmp_path / "v" / "summary.json").read_text())
    assert summary["photo_series"] is None and summary["fps"] == 10.0
    assert not summary["camera"]["registered"]
    assert not any("photo" in w for w in summary["warnings"])


def test_track_links_photos_only_when_close_in_time(tmp_path):
    """Photos whose names put them 0.1 s apart (``--series yes``) are linked into
    tracks; photos 30 min apart by their names are not, whatever ``--fps`` says."""
    clip = tmp_path / "clip"
    _write(clip, _video_frames(5, 26), [f"clip_{k / 10:.1f}s.png" for k in range(26)])
    _run("detect", str(clip), "--out", str(tmp_path / "d"), "--series", "yes")
    _run("track", str(clip), "--out", str(tmp_path / "t"), "--series", "yes")
    det_txt = (tmp_path / "d" / "clip_det.txt").read_text()
    assert (tmp_path / "t" / "detections.txt").read_text() == det_txt
    summary = json.loads((tmp_path / "t" / "summary.json").read_text())
    ps = summary["photo_series"]
    assert ps["recognised_by"] == "--series yes" and ps["interval_source"] == "names"
    assert ps["interval_s"] == pytest.approx(0.1) and summary["fps"] == pytest.approx(10.0)
    assert ps["reach_bl"] == pytest.approx(1.4) and ps["linked"] and ps["note"] is None
    # 8 ants walking 0.86 body lengths/s, never touching for long: a track each.
    assert N_ANTS - 1 <= summary["n_tracks"] <= N_ANTS + 1
    assert summary["warnings"] == []
    stamps = [f"tray_2024-05-01_{8 + k // 2:02d}-{30 * (k % 2):02d}-00.png" for k in range(26)]
    _write(tmp_path / "named", _photos(5, 26), stamps)
    _run("track", str(tmp_path / "named"), "--out", str(tmp_path / "n"), "--fps", "10")
    summary = json.loads((tmp_path / "n" / "summary.json").read_text())
    ps = summary["photo_series"]
    assert ps["recognised_by"] == "names" and ps["interval_s"] == 1800.0
    assert ps["reach_bl"] == pytest.approx(14 * 1800) and not ps["linked"]
    assert summary["fps"] == pytest.approx(1 / 1800) and summary["n_tracks"] == 0
    assert "1800 s apart (the median gap of the times in their names)" in ps["note"]
    assert "--fps 10 not used" in ps["fps_ignored"]


def test_series_timing_rules():
    """The interval and the link decision without images: clocks win over ``--fps``;
    ``--fps`` sets it for photos forced into a series; photos recognised by their
    changes never link; the reach scales with the tracker's top speed."""
    from thermoswarm.tracking.pipeline.series_track import MAX_REACH_BL, series_timing
    from thermoswarm.tracking.track.tracker import TrackerConfig

    cfg = TrackerConfig()
    files = [Path(f"{k}.png") for k in range(30)]
    clocks = {"series": True, "by": "clocks", "median_gap_s": 60.0, "files": files}
    t = series_timing(clocks, 10.0, cfg, "x")
    assert (t["interval_s"], t["linked"], t["fps_source"]) == (60.0, False, "clocks")
    assert "fps_ignored" in t
    slow = TrackerConfig(max_speed_bl_s=MAX_REACH_BL / 60.0)  # 60 s apart, just in reach
    assert series_timing(clocks, None, slow, "x")["linked"]
    forced = {"series": False, "by": "changes", "change_ratio": 0.3, "files": files}
    t = series_timing(forced, 10.0, cfg, "x")
    assert (t["interval_s"], t["interval_source"], t["linked"]) == (0.1, "--fps", True)
    t = series_timing(forced, 2.0, cfg, "x")  # 7 body lengths between photos
    assert not t["linked"] and "7.0 body lengths" in t["note"]
    changes = {**forced, "series": True, "change_ratio": 0.95}
    t = series_timing(changes, 30.0, cfg, "x")
    assert t["interval_s"] is None and not t["linked"] and t["fps"] == 30.0
    assert t["fps_source"] == "--fps" and "30 photos/s (--fps)" in t["note"]


@pytest.mark.parametrize("flag", [["--series", "yes"], ["--series", "no"], ["--detector", "unet"]])
def test_video_options_with_a_detections_file_are_refused(tmp_path, flag):
    det = tmp_path / "det.txt"
    det.write_text("1,-1,10,10,8,3,1,-1,-1,-1\n2,-1,12,10,8,3,1,-1,-1,-1\n")
    args = ["track", "--detections", str(det), "--fps", "10", "--out", str(tmp_path / "o")]
    res = CliRunner().invoke(cli, [*args, *flag])
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and "not to --detections" in lines[0], res.output
    assert not (tmp_path / "o").exists()
