"""The analysis options: one frozen object, a strict TOML loader, ``analyze --config``,
and the stages of the kinematics each run alone."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from thermoswarm.analysis.kinematics import (
    DATA_QUALITY_KEYS,
    STEP_BUCKETS,
    classify_steps,
    clean_samples,
    compute_kinematics,
    fill_and_smooth,
    step_clock,
)
from thermoswarm.analysis.options import AnalysisOptions
from thermoswarm.analysis.synthetic import synthetic_tracks
from thermoswarm.cli import cli
from thermoswarm.errors import ConfigError
from thermoswarm.io import write_tracks
from thermoswarm.maxent import EnergyMixture
from thermoswarm.tracks import make_tracks

TOML = """\
[read]
fps = 25
[clean]
smooth = 0.2
max_gap = 0.1
[steps]
gap_factor = 2
[exclude]
body_length = 2.0
keep_resting = true
[fit]
group_by = ["colony", "time:3"]
energy_bins = [0, 10, 40]
[test]
n_bootstrap = 0
seed = 7
thin = 2
[report]
html = false
"""


@pytest.fixture(scope="module")
def tracks_file(tmp_path_factory):
    ds, _ = synthetic_tracks(8, 121, energy=EnergyMixture(0.6, 20.0, 80.0), fps=25.0, rng=2)
    ds["colony"] = ("individuals", np.array(["A", "B"] * 4))
    path = tmp_path_factory.mktemp("opts") / "tracks.nc"
    write_tracks(ds, path)
    return path


def _toml(tmp_path, text, name="analysis.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_toml_fills_every_section_with_typed_values(tmp_path):
    opts = AnalysisOptions.from_toml(_toml(tmp_path, TOML))
    assert opts.read.fps == 25.0 and isinstance(opts.read.fps, float)
    assert opts.steps.gap_factor == 2.0 and isinstance(opts.steps.gap_factor, float)
    assert opts.clean.smooth == 0.2 and opts.clean.max_gap == 0.1
    assert opts.exclude.body_length == 2.0 and opts.exclude.keep_resting is True
    assert opts.fit.group_by == ("colony", "time:3") and opts.fit.energy_bins == (0.0, 10.0, 40.0)
    assert (opts.test.n_bootstrap, opts.test.seed, opts.test.thin) == (0, 7, 2)
    assert opts.report.html is False
    # untouched options keep their defaults, and the object is frozen
    assert opts.steps.regular_tolerance == 0.1 and opts.exclude.implausible_factor == 5.0
    with pytest.raises(AttributeError):
        opts.test.seed = 1  # type: ignore[misc]


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("[clean]\nsmoth = 0.1\n",
         r"analysis.toml: unknown key 'clean.smoth' \(did you mean 'clean.smooth'"),
        ("[cleaning]\nsmooth = 0.1\n", "unknown key 'cleaning'"),
        ("smooth = 0.1\n", r"unknown key 'smooth' \(did you mean 'clean.smooth'"),
        ("[test]\nn_bootstrap = \"many\"\n", "test.n_bootstrap must be an integer, got 'many'"),
        ("[test]\nn_bootstrap = 2.5\n", "test.n_bootstrap must be an integer"),
        ("[clean]\nduplicates = \"last\"\n", "clean.duplicates must be one of"),
        ("[steps]\ngap_factor = 0.5\n", "steps.gap_factor must be at least 1, got 0.5"),
        ("[clean]\nsmooth = 0\n", "clean.smooth must be a positive number"),
        ("[test]\nalpha = 1.5\n", r"test.alpha must be in \(0, 1\)"),
        ("[fit]\nenergy_bins = [3, 1]\n", "must increase"),
        ("[read]\noptions = 3\n", "read.options"),
    ],
)  # fmt: skip
def test_toml_refuses_unknown_keys_and_bad_values_by_name(tmp_path, text, match):
    with pytest.raises(ConfigError, match=match):
        AnalysisOptions.from_toml(_toml(tmp_path, text))


def test_keyword_api_is_the_same_options_object():
    a = AnalysisOptions.from_keywords(smooth=0.2, n_bootstrap=9, fps=25, group_by="time:3")
    b = AnalysisOptions.from_mapping(
        {"clean": {"smooth": 0.2}, "test": {"n_bootstrap": 9}, "read": {"fps": 25.0},
         "fit": {"group_by": ["time:3"]}}
    )  # fmt: skip
    assert a == b
    with pytest.raises(ConfigError, match="unknown analysis option 'smoothing'"):
        AnalysisOptions.from_keywords(smoothing=1)


def test_compute_kinematics_takes_options_or_keywords(tracks_file):
    from thermoswarm.io import read_tracks

    ds = read_tracks(tracks_file)
    opts = AnalysisOptions.from_keywords(smooth=0.2, max_gap=0.1, min_track_extent=1.0)
    a = compute_kinematics(ds, opts)
    b = compute_kinematics(ds, smooth=0.2, max_gap=0.1, min_track_extent=1.0)
    c = compute_kinematics(ds)
    assert a.identical(b)
    assert not a["speed"].equals(c["speed"])  # the smoothing did change the speeds
    with pytest.raises(ConfigError, match="compute_kinematics takes no option 'n_bootstrap'"):
        compute_kinematics(ds, n_bootstrap=3)


def test_stages_run_alone_and_count_every_step():
    # one individual at 10 Hz with one missed sample (a gap) and a held position
    t = np.array([0.0, 0.1, 0.2, 0.3, 0.5, 0.6, 0.7])
    x = np.array([0.0, 1.0, 2.0, 2.0, 4.0, 5.0, 6.0])
    ds = make_tracks(np.stack([x, np.zeros_like(x)], axis=1)[:, :, None], time=t)
    opts = AnalysisOptions()
    counts = dict.fromkeys(DATA_QUALITY_KEYS, 0)
    s = clean_samples(ds, opts, counts)
    assert counts["n_samples"] == 7
    clock = step_clock(s, opts.steps, counts)
    assert clock.med[0] == pytest.approx(0.1)
    assert clock.gap[:, 0].tolist() == [False, False, False, True, False, False]
    X, Y, present = fill_and_smooth(s, clock, opts.clean, counts)
    assert present.all()
    c = classify_steps(s, clock, X, Y, present, opts, counts)
    # speeds 10, 10, 0 (resting), gap, 10, 10 mm/s
    assert counts["n_steps_time_gap"] == 1 and counts["n_steps_resting"] == 1
    assert counts["n_steps_used"] == 4 == int(c.used.sum())
    assert sum(counts[k] for k in STEP_BUCKETS) == counts["n_steps_total"] == 6


def _run(*args):
    return CliRunner().invoke(cli, ["analyze", *map(str, args)])


def test_config_file_and_flags_give_the_same_fits(tracks_file, tmp_path):
    cfg = _toml(tmp_path, TOML)
    res = _run(tracks_file, "--config", cfg, "--out", tmp_path / "a", "-q")
    assert res.exit_code == 0, res.output
    flags = ["--fps", 25, "--smooth", 0.2, "--max-gap", 0.1, "--gap-factor", 2,
             "--body-length", 2.0, "--keep-resting", "--group-by", "colony",
             "--group-by", "time:3", "--energy-bins", "0,10,40", "--bootstrap", 0,
             "--seed", 7, "--thin", 2, "--no-report"]  # fmt: skip
    res = _run(tracks_file, *flags, "--out", tmp_path / "b", "-q")
    assert res.exit_code == 0, res.output
    a = (tmp_path / "a" / "fits.json").read_bytes()
    assert a == (tmp_path / "b" / "fits.json").read_bytes()
    assert not (tmp_path / "a" / "report.html").exists()  # [report] html = false
    assert json.loads(a)["settings"]["smooth"] == 0.2


def test_flags_given_override_the_file(tracks_file, tmp_path):
    cfg = _toml(tmp_path, TOML)
    res = _run(tracks_file, "--config", cfg, "--seed", 3, "--group-by", "colony",
               "--out", tmp_path / "o", "-q")  # fmt: skip
    assert res.exit_code == 0, res.output
    s = json.loads((tmp_path / "o" / "fits.json").read_text())["settings"]
    assert s["seed"] == 3 and s["group_by"] == ["colony"]  # the flags
    assert s["n_bootstrap"] == 0 and s["smooth"] == 0.2  # the file; defaults did not override


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("[clean]\nsmoth = 0.1\n", "unknown key 'clean.smoth'"),
        ("[test]\nseed = \"x\"\n", "test.seed must be an integer"),
        ("[clean\n", "not valid TOML"),
    ],
)  # fmt: skip
def test_bad_config_is_one_line_naming_the_file_and_key(tracks_file, tmp_path, text, match):
    cfg = _toml(tmp_path, text)
    res = _run(tracks_file, "--config", cfg, "--out", tmp_path / "o", "-q")
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), res.output
    assert str(cfg) in lines[0] and match in lines[0]
    assert not (tmp_path / "o").exists()  # refused before anything is written
