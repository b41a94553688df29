"""Small data for the viewer's tests, made in code with fixed seeds."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from thermoswarm.view.browser import find_chromium


@pytest.fixture(scope="package")
def small_run(tmp_path_factory) -> Path:
    """A 40-robot, 8 s transport-free run folder (config.toml, tracks.zarr, tracks.nc)."""
    from thermoswarm.scenarios import runner

    out = tmp_path_factory.mktemp("view") / "run"
    cfg = runner.resolve(
        "transport-free",
        overrides=["n=40", "duration=8", "record.interval=0.5", "record.block=4"],
        seed=7,
    )
    runner.run(cfg, out, progress=False)
    return out


def write_track_output(folder: Path, rng: np.random.Generator) -> dict:
    """A ``track --out`` folder over a 12-frame PNG video, with one lost and one new id.

    Frames are 96 x 64 px, dark grey with a bright square block at (10..30, 10..30) px;
    three ants at 4 px/mm; ant 2 is lost after frame 5 and ant 3 starts at frame 7
    near where ant 2 was lost (a possible id switch).
    """
    import cv2

    from thermoswarm.io.netcdf import write as write_nc
    from thermoswarm.tracks import make_tracks

    video = folder / "frames"
    out = folder / "out"
    video.mkdir(parents=True)
    out.mkdir()
    T, scale = 12, 4.0
    for k in range(T):
        img = np.full((64, 96, 3), 40, np.uint8)
        img[10:30, 10:30] = (255, 255, 255)
        cv2.imwrite(str(video / f"{k + 1:06d}.png"), img)
    body = np.full((T, 2, 3), np.nan)  # px
    body[:, :, 0] = np.c_[40 + 2 * np.arange(T), np.full(T, 40.0)]
    body[:6, :, 1] = np.c_[60 + rng.normal(0, 0.5, 6), np.full(6, 20.0)]
    body[7:, :, 2] = np.c_[62 + np.arange(5.0), np.full(5, 21.0)]
    pos = np.stack([body + [[-3.0], [0.0]], body, body + [[3.0], [0.0]]], axis=2) / scale
    ds = make_tracks(
        pos,
        fps=10.0,
        individuals=["track_1", "track_2", "track_3"],
        keypoints=["head", "body", "tail"],
        attrs={"px_per_mm": scale},
    )
    write_nc(ds, out / "tracks.nc")
    rows = []
    for k in range(T):
        for i in range(3):
            if np.isfinite(body[k, 0, i]):
                x, y = body[k, :, i]
                rows.append(f"{k + 1},{i + 1},{x - 5:.2f},{y - 3:.2f},10,6,1,-1,-1,-1")
    (out / "tracks_mot.txt").write_text("\n".join(rows) + "\n")
    summary = {"source": str(video), "n_frames": T, "fps": 10.0, "px_per_mm": scale,
               "frame_size": [96, 64], "tracker": {"max_gap_s": 1.0}}  # fmt: skip
    (out / "summary.json").write_text(json.dumps(summary))
    return {"out": out, "video": video, "body": body, "scale": scale}


@pytest.fixture
def track_output(tmp_path, rng) -> dict:
    return write_track_output(tmp_path, rng)


@pytest.fixture(scope="package")
def chromium():
    """Headless Chromium; missing, the browser tests FAIL unless THERMOSWARM_SKIP_BROWSER=1."""
    from thermoswarm.view.browser import Chromium

    if find_chromium() is None:
        if os.environ.get("THERMOSWARM_SKIP_BROWSER") == "1":
            pytest.skip("THERMOSWARM_SKIP_BROWSER=1 and no chromium")
        pytest.fail(
            "chromium is not installed: apt-get install -y chromium chromium-driver "
            "(or set THERMOSWARM_SKIP_BROWSER=1 to skip the browser tests locally)"
        )
    browser = Chromium(1200, 800)
    yield browser
    browser.close()
