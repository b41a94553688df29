"""Real trajectories from other labs' trackers (excerpts in tests/data, sources and
licences in their READMEs), and a real dataset's pathologies reproduced in code."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from thermoswarm.analysis.kinematics import STEP_BUCKETS, compute_kinematics, data_quality
from thermoswarm.analysis.study import run_study
from thermoswarm.io import read_tracks

DATA = Path(__file__).resolve().parents[1] / "data"

#: Upper bounds on the rms speed sqrt(2 kT) of a fitted phase (mm/s), from each
#: animal's known walking speeds with room to spare: marching desert-locust hoppers
#: walk at 1-4 cm/s (adults a little faster), Drosophila walks at most about 3 cm/s.
LOCUST_BOUND = 100.0
FLY_BOUND = 50.0


def _accounted(kin) -> None:
    dq = data_quality(kin)
    assert sum(dq[k] for k in STEP_BUCKETS) == dq["n_steps_total"] > 0


def test_trex_locusts_every_step_accounted_and_temperatures_plausible():
    with pytest.warns(UserWarning, match="--fps 5 overrides the frame rate 30"):
        ds = read_tracks(DATA / "trex_locusts", fps=5)
    assert ds.sizes["individuals"] == 5 and ds.attrs["time_unit"] == "seconds"
    res = run_study(ds, n_bootstrap=0, max_plausible_speed=LOCUST_BOUND)
    kin = res.kinematics
    _accounted(kin)
    np.testing.assert_allclose(kin["median_dt"].values, 0.2)  # 5 frames/s
    plaus = res.fits["plausibility"]
    assert plaus["all_plausible"] is True, plaus


def test_trex_locusts_at_the_stored_frame_rate_are_flagged_implausible():
    # TRex stored the playback rate (30/s): speeds 6x, energies 36x too high
    ds = read_tracks(DATA / "trex_locusts")
    res = run_study(ds, n_bootstrap=0, max_plausible_speed=LOCUST_BOUND)
    plaus = res.fits["plausibility"]
    assert plaus["all_plausible"] is False
    assert "frame rate" in plaus["warning"]


def test_sleap_flies_every_step_accounted_and_temperatures_plausible():
    ds = read_tracks(DATA / "sleap_flies" / "flies.analysis.h5", fps=25, px_per_mm=30)
    assert list(ds.keypoints.values) == ["head", "thorax", "abdomen"]
    res = run_study(ds, n_bootstrap=0, max_plausible_speed=FLY_BOUND)
    _accounted(res.kinematics)
    assert res.fits["plausibility"]["all_plausible"] is True
    # the few steps faster than 5x the flies' 0.9-quantile speed are named, fastest first
    worst = res.fits["excluded"]["implausible"]["worst"]
    assert worst and all(w["speed_mm_s"] > w["threshold_mm_s"] for w in worst)
    assert [w["speed_mm_s"] for w in worst] == sorted(
        (w["speed_mm_s"] for w in worst), reverse=True
    )


def _colony_csv(path: Path, rng: np.random.Generator) -> None:
    """The shape of a YetAnotherTracker CSV of one ant (McLean and Herberstein's lab
    videos): comment lines after the header, 30 static specks tracked beside the ant,
    rows out of frame order, and 'held' rows (``ValueChanged`` false) that repeat a
    speck's last position where the tracker did not update it."""
    fps, n = 50.0, 400
    lines = ['"Frame","Time","TrackId","x","y","ValueChanged"', "#1234.mp4", "#--csv-units m"]
    rows = []
    walk = np.cumsum(rng.normal(0, 0.0012, (n, 2)), axis=0) + 0.3  # m; ~60 mm/s
    for f in range(n):
        rows.append((f, 0, walk[f, 0], walk[f, 1], "true"))
    for s in range(1, 31):  # specks: fixed points with 0.05 mm of jitter
        last = None
        for f in range(n):
            if rng.random() < 0.3:
                continue  # not detected in this frame
            if last is not None and rng.random() < 0.1:
                rows.append((f, s, *last, "false"))  # held: the last position again
                continue
            last = (0.01 * s + rng.normal(0, 5e-5), 0.5 + rng.normal(0, 5e-5))
            rows.append((f, s, *last, "true"))
    for j in rng.permutation(len(rows)):
        f, tid, x, y, changed = rows[j]
        lines.append(f"{f},{f / fps:.2f},{tid},{float(x)!r},{float(y)!r},{changed}")
    path.write_text("\n".join(lines) + "\n")


def test_colony_tracker_pathologies(tmp_path):
    rng = np.random.default_rng(2)
    path = tmp_path / "1234.csv"
    _colony_csv(path, rng)
    ds = read_tracks(path, units="m")
    assert ds.sizes["individuals"] == 31
    assert ds.attrs["n_decreasing_timestamps"] > 0  # rows were sorted
    kin = compute_kinematics(ds)
    dq = data_quality(kin)
    # held rows are zero-length steps: resting, left out and counted
    assert dq["n_steps_resting"] > 0 and dq["resting_fraction"] > 0
    kin = compute_kinematics(ds, min_track_extent=30.0)
    _accounted(kin)
    dq = data_quality(kin)
    assert dq["n_static_tracks"] == 30  # the specks never move 30 mm
    ant = kin.sel(individuals="0")
    assert int(kin["valid"].sum()) == int(ant["valid"].sum()) > 0  # only the ant is fitted
    speed = ant["speed"].values[ant["valid"].values]
    assert 30 < np.median(speed) < 150  # the ant's walk, in mm/s
    held = compute_kinematics(ds, held_positions="missing")
    assert held.attrs["n_held_positions"] > 0 and held.attrs["n_steps_resting"] == 0
    fits = run_study(ds, n_bootstrap=0, min_track_extent=30.0).fits
    assert fits["n_tracks"] == 1 and json.dumps(fits["excluded"])
