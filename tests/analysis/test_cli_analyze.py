"""``thermoswarm analyze`` end to end through click, and its one-line errors."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from thermoswarm.analysis.synthetic import synthetic_tracks
from thermoswarm.cli import cli
from thermoswarm.io import write_tracks
from thermoswarm.maxent import EnergyMixture


@pytest.fixture(scope="module")
def tracks_file(tmp_path_factory):
    ds, _ = synthetic_tracks(12, 151, energy=EnergyMixture(0.6, 20.0, 80.0), fps=25.0, rng=5)
    ds["colony"] = ("individuals", np.array(["A", "B"] * 6))
    path = tmp_path_factory.mktemp("cli") / "tracks.nc"
    write_tracks(ds, path)
    return path


def run(*args):
    return CliRunner().invoke(cli, ["analyze", *map(str, args)])


def test_analyze_writes_outputs_and_prints_a_summary(tracks_file, tmp_path):
    regions = tmp_path / "regions.toml"
    regions.write_text('[[region]]\nname = "all"\nrect = [-1e5, -1e5, 1e5, 1e5]\n')
    out = tmp_path / "out"
    res = run(tracks_file, "--out", out, "--bootstrap", 19, "--seed", 3, "--regions", regions,
              "--group-by", "colony", "--group-by", "time:3", "--energy-bins", "4",
              "--test-size", 1000, "-q")  # fmt: skip
    assert res.exit_code == 0, res.output
    assert "12 tracks, 1800 energy samples (mm^2/s^2)" in res.output
    assert "wrote" in res.output
    fits = json.loads((out / "fits.json").read_text())
    assert list(fits["groups"]) == ["colony", "time:3"]
    assert list(fits["groups"]["colony"]["levels"]) == ["A", "B"]
    assert len(fits["steering"]["bins"]) == 4
    assert fits["settings"]["seed"] == 3 and fits["settings"]["n_bootstrap"] == 19
    assert (out / "kinematics.nc").stat().st_size > 0
    assert (out / "report.html").read_text().count("data:image/png;base64,") >= 4


def test_no_report_and_mass(tracks_file, tmp_path):
    out = tmp_path / "o"
    res = run(tracks_file, "--out", out, "--bootstrap", 0, "--mass", 1e-5, "--no-report", "-q")
    assert res.exit_code == 0, res.output
    assert not (out / "report.html").exists()
    assert json.loads((out / "fits.json").read_text())["units"]["energy"] == "J"


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--group-by", "nothing"], "no such data variable"),
        (["--energy-bins", "x,y"], "edges must be numbers"),
        (["--thin", "zero"], "--thin"),
        (["--read-option", "novalue"], "expected key=value"),
        (["--read-option", "columns=3"], "unknown option(s) columns"),
        (["--read-option", "units=cm"], "contradicts the file's space_unit"),
        (["--fps", "-1"], "--fps"),
        (["--smooth", "0"], "smooth"),
        (["--regions", "missing.toml"], "does not exist"),
        (["--format", "nosuch"], "unknown input format"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(tracks_file, tmp_path, args, match):
    res = run(tracks_file, "--out", tmp_path / "o", "--bootstrap", 0, "-q", *args)
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), res.output
    assert match in lines[0]
    assert "Traceback" not in res.output


def test_missing_input_and_an_output_under_a_file(tmp_path, tracks_file):
    res = run(tmp_path / "none.nc", "--out", tmp_path / "o")
    assert res.exit_code == 2 and "no such file" in res.output
    (tmp_path / "a").write_text("")
    res = run(tracks_file, "--out", tmp_path / "a" / "b")
    assert res.exit_code == 2 and "is a file, not a directory" in res.output


def test_messy_pixel_csv_end_to_end(tmp_path):
    """A wide CSV in pixels with a repeated row, a backward step and a hole."""
    t = np.arange(60) / 10.0
    cols = {"time": t}
    for i in range(3):  # 10 mm/s straight lines, in pixels at the paper's 3.04 px/mm
        cols[f"x{i}"] = 3.04 * 10 * t * np.cos(i)
        cols[f"y{i}"] = 3.04 * 10 * t * np.sin(i)
    rows = np.array([cols[k] for k in cols]).T
    order = np.r_[0:10, 12, 11, 10, 13:60, 30]  # 12-11-10 and 59-30: 3 steps back; 30 twice
    rows = rows[order]
    rows[20, 1] = np.nan
    path = tmp_path / "messy.csv"
    header = ",".join(cols)
    path.write_text(header + "\n" + "\n".join(",".join(f"{v:.10g}" for v in r) for r in rows))
    out = tmp_path / "o"
    res = run(path, "--px-per-mm", "paper", "--out", out, "--bootstrap", 0, "-q")
    assert res.exit_code == 0, res.output
    # counted per individual: 3 backward steps and one exact duplicate row each
    assert "9 backward time steps" in res.output
    assert "3 exact duplicate rows dropped" in res.output
    fits = json.loads((out / "fits.json").read_text())
    dq = fits["data_quality"]
    assert dq["n_duplicate_rows"] == 3 and dq["n_samples"] == 3 * 60
    assert dq["n_missing_positions"] == 1 and dq["n_gaps"] == 1
    assert fits["n_samples"] == 3 * 59 - 2
    assert fits["energy"]["one_phase"]["kT"] == pytest.approx(50.0, rel=1e-9)  # v^2/2


def test_read_options_and_allow_pickle_reach_the_reader(tracks_file, tmp_path):
    # units="mm" agrees with the file; --allow-pickle is ignored by netCDF (never pickled)
    res = run(tracks_file, "--out", tmp_path / "o", "--bootstrap", 0, "--no-report", "-q",
              "--read-option", 'units="mm"', "--allow-pickle")  # fmt: skip
    assert res.exit_code == 0, res.output
    # the reader got the option: units="cm" contradicts the file, and it says so
    res = run(tracks_file, "--out", tmp_path / "o2", "--bootstrap", 0, "--no-report", "-q",
              "--read-option", 'units="cm"')  # fmt: skip
    assert res.exit_code == 2
    assert "units='cm' contradicts" in res.output and "Traceback" not in res.output
    assert not (tmp_path / "o2" / "fits.json").exists()


def _ant_folder(folder, n_ants=6, glitch=False, seed=4):
    """``t x y`` files of ants walking at about 15 mm/s; with ``glitch`` one more track
    that jumps 400 mm every frame (a tracker following nothing)."""
    rng = np.random.default_rng(seed)
    t = np.arange(120) / 10.0
    for i in range(n_ants):
        xy = np.cumsum(rng.normal(0.0, 1.0, (120, 2)), axis=0)
        np.savetxt(folder / f"ant{i}.txt", np.column_stack([t, xy]), fmt="%.5f")
    if glitch:
        xy = 400.0 * (np.arange(120) % 2)[:, None] * np.ones(2)
        np.savetxt(folder / "ghost.txt", np.column_stack([t, xy]), fmt="%.5f")


def _one_line_error(res, *needles):
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), res.output
    for n in needles:
        assert n in lines[0], lines[0]


def test_bad_real_world_input_is_one_line_or_a_counted_exclusion(tmp_path):
    (tmp_path / "dup").mkdir()
    (tmp_path / "dup" / "a.txt").write_text("0 0 0\n0.1 1 0\n0.1 1.5 0\n0.2 2 0\n")
    common = ("--read-option", "units=mm", "--bootstrap", 0, "--no-report", "-q")
    # two different samples at one time under the default rule
    _one_line_error(run(tmp_path / "dup", "--out", tmp_path / "o1", *common),
                    "a.txt", "individual 'a'", "--duplicates")  # fmt: skip
    # a file with one sample
    (tmp_path / "one.txt").write_text("0 1 2\n")
    _one_line_error(run(tmp_path / "one.txt", "--out", tmp_path / "o2", *common),
                    "at least 2 samples")  # fmt: skip
    # an individual whose every step is implausible, among ants: left out and counted
    (tmp_path / "ants").mkdir()
    _ant_folder(tmp_path / "ants", glitch=True)
    res = run(tmp_path / "ants", "--out", tmp_path / "o3", *common)
    assert res.exit_code == 0, res.output
    assert "1 individuals whose every moving step is implausible" in res.output
    fits = json.loads((tmp_path / "o3" / "fits.json").read_text())
    assert fits["excluded"]["implausible"]["individuals_all_implausible"] == ["ghost"]
    assert fits["n_tracks"] == 6
    # alone, with the animal's body length: nothing is left to fit -- one line, no files
    (tmp_path / "ghost").mkdir()
    (tmp_path / "ants" / "ghost.txt").rename(tmp_path / "ghost" / "ghost.txt")
    res = run(tmp_path / "ghost", "--out", tmp_path / "o4", *common, "--body-length", 5)
    _one_line_error(res, "no step left to fit", "implausible")
    assert not (tmp_path / "o4" / "fits.json").exists()
