"""The report's real ant row: the anTraX JS16 excerpt (tests/data/antrax_js16) read,
its cluster-shared positions masked, and fitted by the study; the paper comparison's
rule for the row."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest
import xarray as xr

from thermoswarm.io import read_tracks
from thermoswarm.report.paper import compare, fmt
from thermoswarm.report.paper_unified import walking_command
from thermoswarm.reproduce.unified import (
    ANTRAX_JS16,
    mask_shared_positions,
    real_ants,
    rest_jitter,
)

TAGS = 16
FRAMES = 2400


def test_the_excerpt_reads_as_16_ants_at_10_fps_in_mm():
    ds = read_tracks(ANTRAX_JS16)
    assert ds.sizes["individuals"] == TAGS and ds.sizes["time"] == FRAMES
    assert float(ds.attrs["fps"]) == 10.0
    xy = ds["position"].values[:, :2, 0, :]
    ok = np.isfinite(xy)
    # a 65 mm arena: metres converted to mm, not left in metres or in pixels
    assert 0 < np.nanmin(xy) and 60 < np.nanmax(xy) < 90
    assert ok.all(axis=1).sum() == TAGS * FRAMES - 100  # 100 samples without a position


def test_shared_positions_are_masked_and_counted():
    pos = np.arange(4 * 2 * 1 * 3, dtype=float).reshape(4, 2, 1, 3)
    pos[1, :, 0, 2] = pos[1, :, 0, 0]  # ants 0 and 2 share frame 1
    pos[3, :, 0, 1] = np.nan  # a missing sample is never "shared"
    pos[3, :, 0, 0] = np.nan
    ds = xr.Dataset({"position": (("time", "space", "keypoints", "individuals"), pos)})
    out, n = mask_shared_positions(ds)
    assert n == 2
    got = out["position"].values
    assert np.isnan(got[1, :, 0, [0, 2]]).all() and np.isfinite(got[1, :, 0, 1]).all()
    assert np.array_equal(got[[0, 2]], pos[[0, 2]])  # other frames untouched
    assert np.isfinite(ds["position"].values[1]).all()  # the input is not modified


def _shared_in_csv() -> int:
    """Cluster-shared samples counted straight from the CSV text (independent code)."""
    n = 0
    with open(ANTRAX_JS16, newline="") as f:
        rows = csv.reader(line for line in f if not line.startswith("#"))
        next(rows)
        for row in rows:
            pts = [p for p in zip(row[1::2], row[2::2], strict=True) if p[0]]
            n += sum(pts.count(p) for p in set(pts) if pts.count(p) > 1)
    return n


@pytest.fixture(scope="module")
def fitted():
    return real_ants(ANTRAX_JS16, seed=0, n_bootstrap=9)


def test_real_ants_counts_add_up(fitted):
    study, c = fitted
    sm, st = c["samples"], c["steps"]
    assert sm["total"] == TAGS * FRAMES == sm["single"] + sm["cluster_shared"] + sm["missing"]
    assert sm["cluster_shared"] == _shared_in_csv()
    # every step lands in one bucket; the fit uses exactly the "used" ones
    buckets = [v for k, v in st.items() if k not in ("total", "resting_left_out",
                                                     "implausible_left_out")]  # fmt: skip
    assert sum(buckets) == st["total"] == TAGS * (FRAMES - 1)
    assert st["resting_left_out"] == st["resting"] > 0
    assert study.fits["energy"]["n"] == st["used"]
    # a fitted step joins two individually measured samples of one ant
    assert st["used"] <= sm["single"] - TAGS


def test_real_ants_one_phase_kT_is_the_mean_energy(fitted):
    study, _ = fitted
    en = study.fits["energy"]
    kt = en["one_phase"]["kT"]
    assert math.isfinite(kt) and kt > 0
    assert kt == pytest.approx(en["mean"], rel=1e-9)  # the exponential's MLE
    # O. biroi walk a few mm/s: the mean speed implied lies between 1 and 20 mm/s
    assert 1.0 < math.sqrt(2 * kt) < 20.0
    tp = en["two_phase"]
    assert 0 < tp["phi"] < 1 and tp["kT1"] < tp["kT2"]


def test_the_real_row_states_its_rule_and_source():
    real = {"preferred": "one_phase", "lr_p_value": 0.2, "ks_p_value_preferred": 0.01,
            "one_phase_kT": 12.0, "two_phase": {"phi": 0.3, "kT1": 0.3, "kT2": 16.0},
            "source": "anTraX-data JS16", "samples": {"total": 10, "single": 4,
            "cluster_shared": 5, "missing": 1}, "steps": {"resting": 3},
            "n_bootstrap": 9}  # fmt: skip
    # 9 replicates: the smallest p-value is 0.1, so the LR test cannot prefer two phases
    weak = compare("unified_law", {"ants_real": real})[0]
    assert weak["verdict"] == "not resolved at this scale" and "smallest p-value is 0.1" in (
        weak["why"])  # fmt: skip
    real = dict(real, n_bootstrap=200)
    rows = compare("unified_law", {"ants_real": real})
    assert rows[0]["claim"].startswith("ants (real)") and rows[0]["verdict"] == "differs"
    assert "rule: two phases preferred" in rows[0]["why"] and "anTraX-data JS16" in rows[0]["why"]
    assert "5 in clusters" in rows[0]["why"] and "3 resting steps" in rows[0]["why"]
    good = dict(real, preferred="two_phase", lr_p_value=0.01, ks_p_value_preferred=0.4)
    row = compare("unified_law", {"ants_real": good})[0]
    # no jitter measured (an older results.json): the verdict by the rule, and it says so
    assert row["verdict"] == "reproduced"
    assert "which phase of the two-phase fit is which: not measured" in row["why"]
    assert compare("unified_law", {})[0]["verdict"] == "not measured"
    assert rows[1]["claim"].startswith("ants (synthetic control)")


def test_the_real_row_is_the_analyze_command_it_prints(fitted, tmp_path, monkeypatch):
    """Issue 33: the report's real-ant row prints the ``analyze`` command that gives its
    numbers; run that command (from the checkout's root) and compare every number."""
    import json
    import shlex

    from click.testing import CliRunner

    from thermoswarm.cli import cli

    study, counts = fitted
    words = shlex.split(counts["command"])
    assert words[:2] == ["thermoswarm", "analyze"] and "--mask-shared-positions" in words
    words[words.index("OUT")] = str(tmp_path / "res")
    monkeypatch.chdir(ANTRAX_JS16.parents[3])
    got = CliRunner().invoke(cli, words[1:])
    assert got.exit_code == 0, got.output
    fits = json.loads((tmp_path / "res" / "fits.json").read_text())
    want = study.fits["energy"]
    e = fits["energy"]
    assert e["preferred"] == want["preferred"] and e["n"] == want["n"] == counts["steps"]["used"]
    assert e["lr_p_value"] == want["lr_p_value"]
    assert e["one_phase"]["kT"] == want["one_phase"]["kT"]
    for k in ("phi", "kT1", "kT2", "p_value"):
        assert e["two_phase"][k] == want["two_phase"][k]
    shared = fits["data_quality"]["n_shared_positions_masked"]
    assert shared == counts["samples"]["cluster_shared"] == _shared_in_csv()


def _still_and_walking(sigma: float, fps: float, frames: int, seed: int) -> xr.Dataset:
    """Ant 0 stands at (10, 10) with Gaussian jitter ``sigma`` mm per axis; ant 1 walks
    at 5 mm/s along x with the same jitter (never at rest by the rule)."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames) / fps
    pos = np.full((frames, 2, 1, 2), 10.0) + rng.normal(0, sigma, (frames, 2, 1, 2))
    pos[:, 0, 0, 1] += 5.0 * t
    ds = xr.Dataset({"position": (("time", "space", "keypoints", "individuals"), pos)})
    ds.attrs["fps"] = fps
    return ds


def test_rest_jitter_measures_the_speed_of_a_standing_ant():
    """A standing ant's step is the difference of two N(0, sigma^2) positions per axis:
    its length is Rayleigh with scale sigma sqrt(2), mean sigma sqrt(pi); the speed is
    that times the frame rate.  The walking ant's steps are not counted."""
    sigma, fps, frames = 0.03, 10.0, 4000
    got = rest_jitter(_still_and_walking(sigma, fps, frames, seed=3))
    want = sigma * math.sqrt(math.pi) * fps
    # the Rayleigh length's sd is sigma sqrt(2) sqrt(2 - pi/2); steps overlap in pairs
    tol = 4 * sigma * math.sqrt(2) * math.sqrt(2 - math.pi / 2) * fps * math.sqrt(2 / frames)
    assert got["n_individuals"] == 1 and got["n_steps"] == frames - 1
    assert got["speed_mm_s"] == pytest.approx(want, abs=tol)
    # a jitter wider than the rule's box is never at rest: nothing measured
    assert rest_jitter(_still_and_walking(1.0, fps, 200, seed=3))["speed_mm_s"] is None


def _two_phase_row(kT1, jitter, command="thermoswarm analyze X --seed 0 --out OUT",
                   walking=None):  # fmt: skip
    real = {"preferred": "two_phase", "lr_p_value": 0.005, "ks_p_value_preferred": 0.4,
            "two_phase": {"phi": 0.3, "kT1": kT1, "kT2": 16.0}, "n_bootstrap": 200,
            "command": command, "walking": walking,
            "jitter": {"speed_mm_s": jitter, "n_steps": 500, "n_individuals": 8,
                       "window_s": 1.0, "extent_mm": 0.5, "pixel_speed_mm_s": 0.92}}  # fmt: skip
    return compare("unified_law", {"ants_real": real})[0]


def test_the_real_row_says_which_phase_is_standing():
    """Issue 33: the cold phase's mean speed (sqrt(pi kT1 / 2)) within twice the jitter
    of ants at rest is standing, not walking: partly, with the walking-only command."""
    # kT1 0.256: mean speed 0.63 mm/s, within twice a 0.5 mm/s jitter
    row = _two_phase_row(0.256, 0.5)
    assert row["verdict"] == "partly"
    assert "the cold phase's mean speed 0.63 mm/s against the jitter of ants at rest, 0.5" in (
        row["why"])  # fmt: skip
    assert "standing ants' jitter, not a walking phase" in row["why"]
    # no walking fit in these results: the row says so and prints the command for it
    assert ("the walking steps alone are not fitted in this run (their command: thermoswarm "
            "analyze X --seed 0 --resting-speed 1 --out OUT)") in row["why"]  # fmt: skip
    assert row["why"].index("which phase") < row["why"].index("test: ")  # after the rule
    walked = _two_phase_row(0.256, 0.5, walking={
        "resting_speed_mm_s": 1.0, "resting_left_out": 300, "n_steps": 900, "n_test": 60,
        "preferred": "one_phase", "lr_p_value": 0.4, "ks_p_value_preferred": 0.2,
        "n_bootstrap": 200, "two_phase": {"phi": 0.5, "kT1": 4.0, "kT2": 5.0}})  # fmt: skip
    assert walked["verdict"] == "partly"
    assert ("the walking steps alone: not two walking phases by the row's rule (LR p = 0.4, "
            "KS p = 0.2; their fit: below)") in walked["why"]  # fmt: skip
    assert ("left out as standing: 300; 900 fitted, 60 in the test sample): one_phase "
            "preferred") in walked["why"]  # fmt: skip
    assert "not two walking phases by the row's rule (numbers from: thermoswarm analyze X " in (
        walked["why"])  # fmt: skip
    # a bootstrap too small to reject: the walking fit is not resolved, not "one phase"
    few = _two_phase_row(0.256, 0.5, walking={
        "resting_speed_mm_s": 1.0, "n_steps": 900, "n_test": 60, "preferred": "one_phase",
        "lr_p_value": 0.05, "ks_p_value_preferred": 0.05, "n_bootstrap": 19})  # fmt: skip
    assert ("mm/s; smallest detectable kT difference – mm^2/s^2): not resolved at this scale "
            "(19 bootstrap replicates cannot reject") in few["why"]  # fmt: skip
    # kT1 4: mean speed 2.5 mm/s, over twice the jitter: two walking phases
    fast = _two_phase_row(4.0, 0.5)
    assert fast["verdict"] == "reproduced" and "both phases walk" in fast["why"]
    assert walking_command("thermoswarm analyze P --out OUT", 1.234) == (
        "thermoswarm analyze P --resting-speed 1.2 --out OUT")  # fmt: skip


def test_the_real_data_cold_phase_is_standing_and_the_walking_command_runs(
        fitted, tmp_path, monkeypatch):  # fmt: skip
    """On the JS16 excerpt: the jitter is measured (ants at rest exist), the row built
    from the fit says which phase is which, and its walking-only command runs and
    leaves out the steps at or below the stated speed."""
    import json
    import shlex

    from click.testing import CliRunner

    from thermoswarm.cli import cli

    study, counts = fitted
    jit = counts["jitter"]
    assert jit["n_steps"] > 100 and 0 < jit["speed_mm_s"] < jit["pixel_speed_mm_s"]
    en = study.fits["energy"]
    # the fixture's 9 replicates cannot prefer two phases (200 do: docs/real_data.md);
    # which phase is which depends on the two-phase fit alone, not on the bootstrap
    res = {"preferred": "two_phase", "lr_p_value": 0.005, "ks_p_value_preferred": 0.4,
           "n_bootstrap": 200,
           "two_phase": {k: en["two_phase"][k] for k in ("phi", "kT1", "kT2")},
           **counts}  # fmt: skip
    why = compare("unified_law", {"ants_real": res})[0]["why"]
    assert "which phase of the two-phase fit is which" in why
    cold = math.sqrt(math.pi * en["two_phase"]["kT1"] / 2)
    standing = cold <= 2 * jit["speed_mm_s"]
    assert ("standing ants' jitter" in why) == standing
    if not standing:
        return
    walk = why.split("the walking steps alone (")[1].split("(numbers from: ")[1].split(")")[0]
    words = shlex.split(walk)
    words[words.index("OUT")] = str(tmp_path / "walk")
    monkeypatch.chdir(ANTRAX_JS16.parents[3])
    got = CliRunner().invoke(cli, words[1:])
    assert got.exit_code == 0, got.output
    fits = json.loads((tmp_path / "walk" / "fits.json").read_text())
    cut = float(words[words.index("--resting-speed") + 1])
    assert fits["excluded"]["resting"]["resting_speed_mm_s"] == cut
    assert fits["energy"]["n"] < en["n"]  # the standing steps left out
    # the row's walking numbers are the command's (issue 33: each row's numbers from its
    # printed command), rounded as results.json rounds them
    w, e = counts["walking"], fits["energy"]
    assert w["resting_speed_mm_s"] == cut and w["preferred"] == e["preferred"]
    assert w["n_steps"] == e["n"] and w["resting_left_out"] == fits["excluded"]["resting"]["n"]
    assert w["lr_p_value"] == round(e["lr_p_value"], 4)
    assert w["ks_p_value_preferred"] == round(e[e["preferred"]]["p_value"], 4)
    for k in ("phi", "kT1", "kT2"):
        assert w["two_phase"][k] == round(e["two_phase"][k], 3)
        assert f"{k} = {fmt(w['two_phase'][k])}" in why
