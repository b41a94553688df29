"""Counts per region (the bait-choice assay) on a drawn stand-in photo series: a still
floor with two bait patches (the regions TOML that ``analyze`` reads) and dark ants
drawn at known places, a different number on each patch in every photo."""

from __future__ import annotations

import csv

import cv2
import numpy as np
import pytest
from click.testing import CliRunner

from thermoswarm.cli import cli

REGIONS = """
[[region]]
name = "sucrose"
rect = [10, 10, 140, 230]

[[region]]
name = "peptone"
polygon = [[180, 10], [310, 10], [310, 230], [180, 230]]
"""


def _ant(img, x, y, ang):
    cv2.ellipse(img, (int(x), int(y)), (6, 2), float(ang), 0, 360, (35, 30, 25), -1)


@pytest.fixture(scope="module")
def photos(tmp_path_factory):
    """24 photos 320 x 240 and the true counts ``(24, 3)``: sucrose, peptone, outside."""
    rng = np.random.default_rng(11)
    root = tmp_path_factory.mktemp("photos")
    folder = root / "tray"
    folder.mkdir()
    floor = cv2.GaussianBlur(rng.normal(0, 8, (240, 320)).astype(np.float32), (0, 0), 2)
    floor = np.clip(190 + floor, 0, 255).astype(np.uint8)
    floor = np.dstack([floor, floor, (floor * 0.8).astype(np.uint8)])
    boxes = [(20, 20, 130, 220), (190, 20, 300, 220), (150, 20, 170, 220)]
    truth = []
    for k in range(24):
        img = floor.copy()
        n = [int(rng.integers(0, 6)), int(rng.integers(0, 4)), int(rng.integers(0, 2))]
        for (x0, y0, x1, y1), m in zip(boxes, n, strict=True):
            # spread out on a grid so that no two ants touch
            cells = rng.permutation(6)[:m]
            for c in cells:
                x = x0 + (x1 - x0) * (0.25 + 0.5 * (c % 2)) + rng.uniform(-4, 4)
                y = y0 + (y1 - y0) * (1 + 2 * (c // 2)) / 6 + rng.uniform(-4, 4)
                _ant(img, x, y, rng.uniform(0, 180))
        truth.append(n)
        cv2.imwrite(str(folder / f"t1_{30 * k:04d}.png"), cv2.cvtColor(img, cv2.COLOR_RGB2BGR))
    (root / "regions.toml").write_text(REGIONS)
    return root, folder, np.array(truth)


def test_counts_per_photo_and_region(photos, tmp_path):
    root, folder, truth = photos
    out = tmp_path / "d"
    res = CliRunner().invoke(
        cli, ["detect", str(folder), "--out", str(out), "--regions", str(root / "regions.toml")]
    )
    assert res.exit_code == 0, res.output
    with open(out / "tray_regions.csv") as f:
        rows = list(csv.DictReader(f))
    assert [r["file"] for r in rows] == [f"t1_{30 * k:04d}.png" for k in range(24)]
    got = np.array([[int(r["sucrose"]), int(r["peptone"]), int(r["outside"])] for r in rows])
    # Every ant of every photo in its region: at most one miss or extra in all 24.
    assert np.abs(got - truth).sum() <= 1, np.column_stack([got, truth])
    pics = sorted((out / "tray_regions").iterdir())
    assert len(pics) == 24 and pics[0].suffix == ".jpg"
    img = cv2.imread(str(pics[0]))
    assert img.shape == (240, 320, 3)


def test_bad_regions_file_is_a_one_line_error(photos, tmp_path):
    root, folder, _ = photos
    bad = tmp_path / "bad.toml"
    bad.write_text('[[region]]\nname = "a"\nrect = [1, 2]\n')
    res = CliRunner().invoke(
        cli, ["detect", str(folder), "--out", str(tmp_path / "o"), "--regions", str(bad)]
    )
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and "bad.toml" in lines[0]


def test_photo_series_recognised_by_their_clocks(photos, tmp_path):
    import datetime as dt
    import json

    from PIL import Image

    from thermoswarm.tracking.pipeline.series import series_evidence

    root, folder, truth = photos
    series = tmp_path / "series"
    series.mkdir()
    t0 = dt.datetime(2024, 5, 1, 8, 0, 0)
    for k, f in enumerate(sorted(folder.glob("*.png"))):
        exif = Image.Exif()
        exif[306] = (t0 + dt.timedelta(minutes=30 * k)).strftime("%Y:%m:%d %H:%M:%S")
        Image.open(f).save(series / f"{f.stem}.jpg", quality=95, exif=exif.tobytes())
    clocks = series_evidence(sorted(series.glob("*.jpg")))
    assert clocks["series"] and clocks["by"] == "clocks" and clocks["median_gap_s"] == 1800
    # Without clocks the same photos are a series by how much changes between them
    # (the ants are elsewhere in every photo; tests/tracking/test_series.py).
    assert series_evidence(sorted(folder.glob("*.png")))["by"] == "changes"
    out = tmp_path / "d"
    args = ["detect", str(series), "--out", str(out), "--regions", str(root / "regions.toml")]
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    rec = json.loads((out / "summary.json").read_text())["inputs"][0]
    assert rec["photo_series"]["series_window"] == 12
    assert rec["photo_series"]["recognised_by"] == "clocks"
    with open(out / "series_regions.csv") as f:
        rows = list(csv.DictReader(f))
    got = np.array([[int(r["sucrose"]), int(r["peptone"]), int(r["outside"])] for r in rows])
    # Two windows of 12 photos, each with its own background: every ant counted.
    assert np.abs(got - truth).sum() <= 1, np.column_stack([got, truth])
