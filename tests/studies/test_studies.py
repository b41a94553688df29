"""Study statistics on constructed data with known answers, and tiny end-to-end runs."""

from __future__ import annotations

import json
import math
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from thermoswarm.errors import ConfigError, OutputError
from thermoswarm.studies import effect, verdict
from thermoswarm.studies.mechanism import markdown_table, run_mechanism, summarize
from thermoswarm.studies.regime import run_regime
from thermoswarm.studies.scaling import arena_side, censored_median, median_interval, run_scaling
from thermoswarm.studies.scaling import summarize as scaling_summary


@pytest.fixture
def ex():
    """An in-process executor for tiny study runs (no worker start-up per study)."""
    with ThreadPoolExecutor(1) as pool:
        yield pool


def test_effect_on_known_values():
    e = effect([1.0, 2.0, 3.0, 4.0, 5.0])
    assert e["n"] == 5 and e["mean"] == 3.0
    assert e["sd"] == pytest.approx(math.sqrt(2.5))
    assert e["se"] == pytest.approx(math.sqrt(2.5 / 5))
    q = 2.7764451051977987  # t(0.975, 4)
    assert e["ci_low"] == pytest.approx(3.0 - q * math.sqrt(0.5))
    assert e["ci_high"] == pytest.approx(3.0 + q * math.sqrt(0.5))
    assert e["t"] == pytest.approx(3.0 / math.sqrt(0.5))
    assert e["p"] == pytest.approx(stats.ttest_1samp([1, 2, 3, 4, 5], 0.0).pvalue)
    assert e["d"] == pytest.approx(3.0 / math.sqrt(2.5))
    # None and NaN are dropped; one value has no spread
    e1 = effect([None, float("nan"), 2.0])
    assert e1["n"] == 1 and e1["mean"] == 2.0 and math.isnan(e1["se"])
    assert effect([])["n"] == 0


def test_effect_interval_covers_the_truth_at_its_nominal_rate():
    rng = np.random.default_rng(5)
    hits = sum(
        (e := effect(rng.normal(1.0, 2.0, 10)))["ci_low"] < 1.0 < e["ci_high"] for _ in range(2000)
    )
    # 95 % coverage; binomial sd over 2000 trials is 0.0049
    assert abs(hits / 2000 - 0.95) < 4 * 0.0049


def test_verdict():
    assert verdict(0.1, 3.0) == "toward target"
    assert verdict(-3.0, -0.2) == "away from target"
    assert verdict(-1.0, 1.0) == "no detectable motion"


def test_mechanism_summary_of_constructed_runs():
    runs = pd.DataFrame(
        {
            "mapping": ["lit_hot"] * 4 + ["lit_cold"] * 4,
            "displacement": [-10.0, -12.0, -8.0, -10.0, 5.0, -5.0, 10.0, -10.0],
            "force": [-1.0, -1.0, -1.0, -1.0, 0.5, 0.5, 0.5, 0.5],
            "hot_fraction": [0.9] * 4 + [0.1] * 4,
        }
    )
    s = summarize(runs, ["mapping"]).set_index("mapping")
    assert s.loc["lit_hot", "disp_mean"] == -10.0
    assert s.loc["lit_hot", "disp_se"] == pytest.approx(np.std([-10, -12, -8, -10], ddof=1) / 2)
    assert s.loc["lit_hot", "verdict"] == "away from target"
    assert s.loc["lit_cold", "verdict"] == "no detectable motion"
    assert s.loc["lit_cold", "force_mean"] == 0.5 and s.loc["lit_cold", "force_se"] == 0.0
    table = markdown_table(s.reset_index())
    assert "away from target" in table and table.count("\n") == 4


def test_censored_median():
    assert censored_median([10.0, 30.0, 20.0]) == 20.0
    assert censored_median([10.0, None, 20.0]) == 20.0
    assert censored_median([10.0, None, None]) is None
    assert censored_median([10.0, 20.0, None, 40.0]) == 30.0
    assert censored_median([10.0, 20.0, None, None]) is None
    assert censored_median([]) is None


def test_scaling_summary_of_constructed_runs():
    runs = pd.DataFrame(
        {
            "n": [50, 50, 50, 200, 200, 200],
            "max_displacement": [1.0, 2.0, 3.0, 10.0, 20.0, 30.0],
            "displacement": [0.0, 1.0, 2.0, 5.0, 10.0, 15.0],
            "time_to_target": [None, None, 100.0, 50.0, 70.0, None],
        }
    )
    s = scaling_summary(runs).set_index("n")
    assert s.loc[50, "maxdisp_mean"] == 2.0 and s.loc[200, "maxdisp_sd"] == 10.0
    assert s.loc[50, "reached"] == 1 and pd.isna(s.loc[50, "time_median"])
    assert s.loc[200, "reached"] == 2 and s.loc[200, "time_median"] == 70.0
    assert s.loc[200, "time_mean_reached"] == 60.0


def test_run_mechanism_end_to_end_tiny(tmp_path):
    res = run_mechanism(
        tmp_path / "m",
        "quick",
        seeds=2,
        grid={"mapping": ["lit_hot", "lit_cold"]},
        overrides={"n": 40, "width": 500.0, "height": 500.0, "duration": 6.0, "warmup": 2.0},
        max_workers=1,
        progress=False,
    )
    assert len(res.runs) == 4 and len(res.summary) == 2
    assert res.runs["force_held"].notna().all()  # held during the warm-up, then measured
    data = json.loads((tmp_path / "m" / "mechanism.json").read_text())
    assert len(data["runs"]) == 4 and data["setting"]["seeds"] == [0, 1]
    assert (tmp_path / "m" / "mechanism.md").read_text().startswith("| mapping |")
    # restart: finished runs are reused, results identical
    res2 = run_mechanism(
        tmp_path / "m",
        "quick",
        seeds=2,
        grid={"mapping": ["lit_hot", "lit_cold"]},
        overrides={"n": 40, "width": 500.0, "height": 500.0, "duration": 6.0, "warmup": 2.0},
        max_workers=1,
        progress=False,
    )
    pd.testing.assert_frame_equal(res.summary, res2.summary)


def test_run_scaling_end_to_end_tiny(tmp_path, ex):
    # 20 mm in 20 s: within reach of some of these runs, not of all; the horizon (10 s)
    # holds three of the frames recorded every 5 s
    target, duration, horizon = 20.0, 20.0, 10.0
    res = run_scaling(
        tmp_path / "s",
        "quick",
        ns=[20, 60],
        seeds=2,
        duration=duration,
        target_distance=target,
        horizon=horizon,
        overrides={"width": 500.0, "height": 500.0},
        executor=ex,
        progress=False,
    )
    assert list(res.summary["n"]) == [20, 60]
    assert (res.runs["target_y"] == 270.0).all()  # the start (250 mm) + 20 mm
    runs = res.runs
    assert sorted(zip(runs["n"], runs["seed"], strict=True)) == [
        (20, 0),
        (20, 1),
        (60, 0),
        (60, 1),
    ]
    for _, r in runs.iterrows():
        # each row is what its own run wrote, for its own size and seed
        m = json.loads((Path(r["run_dir"]) / "metrics.json").read_text())
        assert m["n"] == r["n"] and m["target_y"] == r["target_y"] == 270.0
        assert r["max_displacement_run"] == m["max_displacement_toward_target"]
        assert r["displacement"] == m["displacement_toward_target"]
        # the horizon's maximum is taken over the recorded path up to 10 s after warm-up
        t, p = np.asarray(m["object_path"]["time"]), np.asarray(m["object_path"]["progress"])
        within = t <= m["warmup"] + horizon + 1e-9
        assert within.sum() >= 3 and r["max_displacement"] == p[within].max()
        assert r["max_displacement"] <= r["max_displacement_run"]
        # the whole run's maximum includes the start (0) and the end
        assert r["max_displacement_run"] >= max(0.0, r["displacement"]) - 1e-9
        # reached exactly when the whole run's maximum got to the target, within the run
        tt = r["time_to_target"]
        reached = tt is not None and not (isinstance(tt, float) and math.isnan(tt))
        assert reached == (m["time_to_target"] is not None)
        assert reached == (r["max_displacement_run"] >= target)
        assert not reached or (0.0 < tt <= duration and tt == m["time_to_target"])
    # (these seeds exercise both branches: some runs reach the target, some do not)
    assert 0 < res.summary["reached"].sum() < len(runs)
    # the summary, recomputed here from the runs
    for _, s in res.summary.iterrows():
        g = runs[runs["n"] == s["n"]]
        md = g["max_displacement"].to_numpy(float)
        assert s["seeds"] == 2
        assert s["maxdisp_mean"] == pytest.approx(md.mean())
        assert s["maxdisp_sd"] == pytest.approx(md.std(ddof=1))
        assert s["maxdisp_median"] == pytest.approx(np.median(md))
        assert (s["maxdisp_min"], s["maxdisp_max"]) == (md.min(), md.max())
        # two values: the interval of the median is their range
        assert (s["maxdisp_ci_low"], s["maxdisp_ci_high"]) == (md.min(), md.max())
        assert s["disp_mean"] == pytest.approx(g["displacement"].mean())
        times = sorted(float(x) for x in g["time_to_target"] if x is not None and x == x)
        assert s["reached"] == len(times)
        # two seeds: the median is the mean of both times, unknown if either is missing
        want = sum(times) / 2 if len(times) == 2 else None
        assert (s["time_median"] is None or pd.isna(s["time_median"])) == (want is None)
        assert want is None or s["time_median"] == pytest.approx(want)
    # the files say the same
    data = json.loads((tmp_path / "s" / "scaling.json").read_text())
    for row, (_, s) in zip(data["summary"], res.summary.iterrows(), strict=True):
        assert row["n"] == s["n"] and row["maxdisp_mean"] == pytest.approx(s["maxdisp_mean"])
        assert row["reached"] == s["reached"]
    assert (tmp_path / "s" / "scaling.png").stat().st_size > 1000
    md_rows = (tmp_path / "s" / "scaling.md").read_text().splitlines()[2:]
    for line, (_, s) in zip(md_rows, res.summary.iterrows(), strict=True):
        cells = [c.strip() for c in line.strip("|").split("|")]
        assert cells[:2] == ["fixed", str(s["n"])] and cells[7] == f"{s['reached']}/2"
        assert cells[5].startswith(f"{s['maxdisp_mean']:.0f} ± ")
    # a later call with other sizes and the same setting adds them to the study
    more = run_scaling(
        tmp_path / "s", "quick", ns=[40], seeds=2, duration=duration, target_distance=target,
        horizon=horizon, overrides={"width": 500.0, "height": 500.0}, executor=ex,
        progress=False,
    )  # fmt: skip
    assert list(more.summary["n"]) == [20, 40, 60]
    pd.testing.assert_frame_equal(
        more.summary.set_index("n").loc[[20, 60]].reset_index()[res.summary.columns],
        res.summary,
        check_dtype=False,
    )


def test_run_scaling_density_series_scales_the_arena(tmp_path, ex):
    res = run_scaling(
        tmp_path / "d", "density", ns=[30, 120], seeds=1, duration=2.0, target_distance=1.0,
        executor=ex, progress=False,
    )  # fmt: skip
    arenas = res.summary.set_index("n")["arena"]
    # side ~ sqrt(n): 4 times the robots, twice the side (to the rounding of 1 mm)
    assert abs(arenas[120] - 2 * arenas[30]) <= 2
    assert arenas[120] == arena_side(120)
    assert arena_side(1200) == 1800.0  # the default packing is that of 1,200 in 1800 mm


def test_median_interval_order_statistics():
    """Sign-test interval: for 10 values the 2nd and 9th order statistics (coverage
    1 - 2 P(B <= 1) = 97.9 % for B ~ Binomial(10, 1/2)); unreached runs (None) are
    longer than any reached and make an end unbounded."""
    vals = [float(v) for v in range(1, 11)]
    assert median_interval(vals) == (2.0, 9.0)
    assert median_interval([*vals[:8], None, None]) == (2.0, None)
    assert median_interval([None] * 9 + [1.0]) == (None, None)
    assert median_interval([5.0]) == (None, None)
    assert median_interval([3.0, 1.0, 2.0, 5.0, 4.0]) == (1.0, 5.0)  # 5 values: the range
    # coverage of the median of a continuous law at least 95 % (20,000 samples of 10)
    rng = np.random.default_rng(0)
    hits = 0
    for _ in range(2000):
        lo, hi = median_interval(list(rng.exponential(1.0, 10)))
        hits += lo <= math.log(2) <= hi
    assert hits / 2000 > 0.979 - 4 * math.sqrt(0.979 * 0.021 / 2000)


def test_run_regime_end_to_end_tiny(tmp_path, ex):
    """Two maps on a tiny swarm (the quick setting's 3 x 3 corners): every cell has its
    seeds, the drift is the run's displacement over its duration, the tables and the
    figure are written; a later call with another map adds it to the study."""
    over = {"n": 30, "width": 400.0, "height": 400.0, "duration": 2.0}
    res = run_regime(tmp_path / "r", "quick", maps=["cold"], seeds=2, overrides=over,
                     executor=ex, progress=False)  # fmt: skip
    res = run_regime(tmp_path / "r", "quick", maps=["light"], seeds=2, overrides=over,
                     executor=ex, progress=False)  # fmt: skip
    s = res.summary
    assert list(s["map"].unique()) == ["cold", "light"]
    assert len(s[s["map"] == "cold"]) == 9 and len(s[s["map"] == "light"]) == 9
    assert (s["seeds"] == 2).all()
    np.testing.assert_allclose(res.runs["drift"], res.runs["displacement"] / 2.0)
    assert set(res.runs[res.runs["map"] == "cold"]["y"]) == {15.0, 18.0, 20.0}  # mean speeds
    md = (tmp_path / "r" / "regime.md").read_text()
    assert "### cold" in md and "### light" in md
    assert (tmp_path / "r" / "regime.png").stat().st_size > 1000


def test_bad_setting_and_missing_parent(tmp_path):
    with pytest.raises(ConfigError, match="setting"):
        run_mechanism(tmp_path / "m", "medium")
    (tmp_path / "file").write_text("")
    with pytest.raises(OutputError, match="not a directory"):
        run_scaling(tmp_path / "file" / "such", "quick")


def test_set_overrides_become_the_dotted_keys_of_a_grid_base():
    from thermoswarm.studies._common import dotted_overrides

    got = dotted_overrides(["sensor.mode='ideal'", "n=300", "light.a.b=1.5"])
    assert got == {"sensor.mode": "ideal", "n": 300, "light.a.b": 1.5}


def test_study_cli_bad_value_is_one_line_exit_2_and_writes_nothing(tmp_path):
    from click.testing import CliRunner

    from thermoswarm.cli import cli

    for verb in ("mechanism", "scaling", "regime"):
        out = tmp_path / verb
        r = CliRunner().invoke(cli, ["study", verb, "--out", str(out), "--set", "nope=1"])
        assert r.exit_code == 2, r.output
        err = r.stderr.strip().splitlines()
        assert len(err) == 1 and "unknown key 'nope'" in err[0]
        assert not out.exists()
