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


def test_track_on_a_photo_series_warns_and_names_detect(tmp_path):
    """``track`` on photos taken apart writes its outputs with a warning that names
    the series and ``detect``; on video frames of the same scene it does not."""
    _write(tmp_path / "tray", _photos(5, 26), [f"t1_{k:03d}.png" for k in range(26)])
    _write(tmp_path / "clip", _video_frames(5, 26), [f"f_{k:03d}.png" for k in range(26)])
    warned = {}
    for name in ("tray", "clip"):
        out = tmp_path / f"o_{name}"
        res = CliRunner().invoke(
            cli, ["track", str(tmp_path / name), "--out", str(out), "--fps", "10"]
        )
        assert res.exit_code == 0, res.output
        warnings = json.loads((out / "summary.json").read_text())["warnings"]
        warned[name] = [w for w in warnings if "photo series" in w]
    assert len(warned["tray"]) == 1 and "thermoswarm detect" in warned["tray"][0]
    assert "differ as much as images 8 apart" in warned["tray"][0]
    assert warned["clip"] == []
