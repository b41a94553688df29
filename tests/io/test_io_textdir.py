"""One `t x y` text file per individual: single files and folders."""

from __future__ import annotations

import numpy as np
import pytest
from io_truth import SCALE, Truth, assert_tracks

from thermoswarm.errors import InputError
from thermoswarm.io import detect_format, read_tracks


def _write_folder(folder, truth: Truth, *, header: str | None = "t x y") -> None:
    c = truth.centroid_only()
    for i, name in enumerate(truth.individuals):
        rows = np.column_stack([truth.times, c.px[:, 0, 0, i], c.px[:, 1, 0, i]])
        keep = ~np.isnan(rows[:, 1])
        np.savetxt(
            folder / f"{name}.txt", rows[keep], header=header or "", comments="", fmt="%.17g"
        )


def test_folder_in_pixels(tmp_path, truth):
    _write_folder(tmp_path, truth)
    assert detect_format(tmp_path) == "text"
    ds = read_tracks(tmp_path, px_per_mm="paper")
    c = truth.centroid_only()
    assert_tracks(ds, c.mm, truth.times, truth.individuals, ["centroid"])


def test_natural_order_and_frames(tmp_path):
    for name, off in (("ant10", 10.0), ("ant2", 2.0)):
        np.savetxt(tmp_path / f"{name}.dat", [[0, off, 0], [1, off + 1, 1], [3, off, 2]], fmt="%g")
    ds = read_tracks(tmp_path, fps=10.0, units="mm", columns=["frame", "x", "y"])
    assert list(ds.individuals.values) == ["ant2", "ant10"]
    # frame numbers give a regular axis: frame 2, seen in no file, is a NaN row
    np.testing.assert_allclose(ds.time.values, [0.0, 0.1, 0.2, 0.3])
    np.testing.assert_allclose(ds.position.values[:, 0, 0, 1], [10.0, 11.0, np.nan, 10.0])


def test_single_file_sorted_exact_duplicates_dropped(tmp_path):
    path = tmp_path / "ant.txt"
    path.write_text("# space_unit: cm\n0.0 1 1\n0.2 2 2\n0.1 3 3\n0.1 3 3\n")
    assert detect_format(path) == "text"
    ds = read_tracks(path)
    np.testing.assert_array_equal(ds.time.values, [0.0, 0.1, 0.2])
    np.testing.assert_allclose(ds.position.values[:, 0, 0, 0], [10.0, 30.0, 20.0])
    assert ds.attrs["n_duplicate_rows"] == 1
    assert ds.attrs["n_conflicting_duplicates"] == 0


def test_folder_on_own_clocks_keeps_every_sample(tmp_path):
    # two 10 Hz tracks offset by 50 ms: no union axis, each keeps its own times
    for name, off in (("a", 0.0), ("b", 0.05)):
        t = off + np.arange(5) * 0.1
        np.savetxt(tmp_path / f"{name}.txt", np.column_stack([t, t * 10, t]), fmt="%.6f")
    ds = read_tracks(tmp_path, units="mm")
    assert ds.attrs["time_unit"] == "per_individual"
    assert ds.sizes["time"] == 5
    np.testing.assert_allclose(ds["individual_time"].values[:, 1], 0.05 + np.arange(5) * 0.1)
    assert np.isfinite(ds.position.values).all()


def test_txt_sniff_mot_versus_text(tmp_path):
    (tmp_path / "mot.txt").write_text("1,1,10,20,5,5,1,-1,-1,-1\n")
    (tmp_path / "xyt.txt").write_text("0.0 1.5 2.5\n")
    assert detect_format(tmp_path / "mot.txt") == "mot"
    assert detect_format(tmp_path / "xyt.txt") == "text"


def test_folder_duplicate_time_is_error(tmp_path):
    (tmp_path / "a.txt").write_text("t x y\n0 1 1\n0 2 2\n")
    (tmp_path / "b.txt").write_text("t x y\n0 1 1\n")
    with pytest.raises(InputError, match=r"a\.txt: individual 'a' at time 0 s: two different"):
        read_tracks(tmp_path, units="mm")
    ds = read_tracks(tmp_path, units="mm", duplicates="mean")
    np.testing.assert_allclose(ds.position.values[0, 0, 0], [1.5, 1.0])


@pytest.mark.parametrize(
    ("text", "pattern"),
    [
        ("0 1\n", r"first data row has 2 columns, expected at least 3"),
        ("a b c\n1 2 3\n", r"cannot find t .*x and y"),
        ("t x y\n0 1 zz\n", r"non-numeric value 'zz' in column 'y'"),
        ("", r"empty file"),
    ],
)
def test_malformed(tmp_path, text, pattern):
    path = tmp_path / "bad.txt"
    path.write_text(text)
    with pytest.raises(InputError, match=r"bad\.txt: " + pattern):
        read_tracks(path, "text", units="mm")


def test_empty_folder(tmp_path):
    with pytest.raises(InputError, match="looks like none of"):
        read_tracks(tmp_path)
    with pytest.raises(InputError, match=r"no files matching"):
        read_tracks(tmp_path, "text", units="mm")


def test_scale_required(tmp_path, truth):
    _write_folder(tmp_path, truth)
    with pytest.raises(InputError, match=r"--px-per-mm.*paper.*units"):
        read_tracks(tmp_path)
    ds = read_tracks(tmp_path, px_per_mm=SCALE)
    assert ds.attrs["px_per_mm"] == SCALE
