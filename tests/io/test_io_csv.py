"""Tidy and wide CSV: readers (fixtures written with pandas) and the tidy writer."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from io_truth import FPS, SCALE, Truth, assert_tracks

from thermoswarm.errors import InputError
from thermoswarm.io import detect_format, read_tracks, write_tracks
from thermoswarm.tracks import make_tracks


def _tidy_frame(truth: Truth, *, time: bool = False) -> pd.DataFrame:
    rows = []
    for t in range(truth.n_t):
        for i, ind in enumerate(truth.individuals):
            for k, kp in enumerate(truth.keypoints):
                x, y = truth.px[t, :, k, i]
                if np.isnan(x):
                    continue
                row = {
                    "track_id": ind,
                    "bodypart": kp,
                    "x": x,
                    "y": y,
                    "likelihood": float(truth.conf[t, k, i]),
                }
                row["time" if time else "frame"] = t / truth.fps if time else t
                rows.append(row)
    return pd.DataFrame(rows)


def test_tidy_pixels_frames_aliases(tmp_path, truth):
    path = tmp_path / "tracks.csv"
    _tidy_frame(truth).to_csv(path, index=False)
    assert detect_format(path) == "tidy_csv"
    ds = read_tracks(path, fps=FPS, px_per_mm="paper")
    assert_tracks(ds, truth.mm, truth.times, truth.individuals, truth.keypoints, truth.conf)
    assert ds.attrs["px_per_mm"] == SCALE


def test_tidy_time_in_ms_and_mm_units(tmp_path, truth):
    df = _tidy_frame(truth, time=True)
    df["time"] = df["time"] * 1000
    path = tmp_path / "t.csv"
    df.to_csv(path, index=False)
    ds = read_tracks(path, units="mm", time_unit="ms")
    assert_tracks(ds, truth.px, truth.times, truth.individuals, truth.keypoints, truth.conf)
    assert "fps" not in ds.attrs


def test_tidy_custom_columns_semicolon(tmp_path, truth):
    df = _tidy_frame(truth).rename(
        columns={"track_id": "ant", "x": "cx", "y": "cy", "frame": "img"}
    )
    path = tmp_path / "c.csv"
    df.to_csv(path, index=False, sep=";")
    ds = read_tracks(
        path,
        "tidy_csv",
        fps=FPS,
        px_per_mm=SCALE,
        individual_col="ant",
        x_col="cx",
        y_col="cy",
        frame_col="img",
    )
    assert_tracks(ds, truth.mm, truth.times, truth.individuals, truth.keypoints, truth.conf)


def test_tidy_unit_suffix_columns(tmp_path):
    pd.DataFrame(
        {
            "id": ["a", "a", "b"],
            "frame": [0, 1, 0],
            "x_cm": [1.5, 2.0, 3.0],
            "y_cm": [0.0, 0.5, 1.0],
        }
    ).to_csv(tmp_path / "u.csv", index=False)
    ds = read_tracks(tmp_path / "u.csv", fps=2.0)
    np.testing.assert_allclose(ds.position.sel(individuals="a", space="x").squeeze(), [15.0, 20.0])
    assert ds.attrs["source_space_unit"] == "cm"


def test_writer_round_trip_is_exact(tmp_path, truth):
    ds0 = make_tracks(
        truth.mm,
        fps=FPS,
        individuals=truth.individuals,
        keypoints=truth.keypoints,
        confidence=truth.conf,
        source_software="test",
    )
    path = tmp_path / "out.csv"
    write_tracks(ds0, path)
    text = path.read_text()
    assert text.startswith("# thermoswarm tidy CSV\n# space_unit: mm\n")
    header = [ln for ln in text.splitlines() if not ln.startswith("#")][0]
    assert header == "individual,keypoint,time,frame,x,y,confidence"
    ds = read_tracks(path)  # units and fps come from the metadata lines
    assert_tracks(ds, truth.mm, truth.times, truth.individuals, truth.keypoints, truth.conf)
    assert ds.attrs["fps"] == FPS
    np.testing.assert_array_equal(ds.position.values, ds0.position.values)  # bit-exact
    df = pd.read_csv(path, comment="#")  # plain pandas reads it too
    assert int(df.frame.max()) == truth.n_t - 1


def test_writer_keeps_all_nan_rows_on_request(tmp_path, truth):
    ds0 = make_tracks(truth.mm, fps=FPS, individuals=truth.individuals, keypoints=truth.keypoints)
    write_tracks(ds0, tmp_path / "a.csv", dropna=False)
    df = pd.read_csv(tmp_path / "a.csv", comment="#")
    assert len(df) == truth.mm[:, 0].size
    with pytest.raises(InputError, match="unknown write option"):
        write_tracks(ds0, tmp_path / "b.csv", nope=True)


def test_wide_idtracker_style(tmp_path, truth):
    c = truth.centroid_only()
    df = pd.DataFrame({"time": truth.times})
    for i in range(2):
        df[f"x{i + 1}"] = c.px[:, 0, 0, i]
        df[f"y{i + 1}"] = c.px[:, 1, 0, i]
    path = tmp_path / "trajectories.csv"
    df.to_csv(path, index=False)
    assert detect_format(path) == "wide_csv"
    ds = read_tracks(path, px_per_mm=SCALE)
    assert_tracks(ds, c.mm, truth.times, ["id_1", "id_2"], ["centroid"])


def test_wide_sorts_rows_and_resolves_duplicates_by_rule(tmp_path):
    df = pd.DataFrame(
        {
            "frame": [0, 2, 1, 1, 2],
            "ant_x": [1.0, 2.0, 3.0, 4.0, 2.0],
            "ant_y": [5.0, 6.0, 7.0, 8.0, 6.0],
        }
    )
    df.to_csv(tmp_path / "w.csv", index=False)
    # frame 2 twice with the same position: dropped; frame 1 twice, different: a conflict
    with pytest.raises(InputError, match=r"w\.csv: individual 'ant' at frame 1: two different"):
        read_tracks(tmp_path / "w.csv", fps=1.0, units="mm")
    first = read_tracks(tmp_path / "w.csv", fps=1.0, units="mm", duplicates="first")
    np.testing.assert_array_equal(first.time.values, [0.0, 1.0, 2.0])
    np.testing.assert_array_equal(first.position.values[:, 0, 0, 0], [1.0, 3.0, 2.0])
    assert first.attrs["n_duplicate_rows"] == 1
    assert first.attrs["n_conflicting_duplicates"] == 1
    mean = read_tracks(tmp_path / "w.csv", fps=1.0, units="mm", duplicates="mean")
    np.testing.assert_array_equal(mean.position.values[:, 1, 0, 0], [5.0, 7.5, 6.0])
    assert list(mean.individuals.values) == ["ant"]


def test_wide_frame_like_first_column_is_recognised(tmp_path):
    # a colony tracker's layout: the frame number in a column named "position"
    text = "position,x0,y0,x1,y1\n0,1,2,3,4\n1,1.5,2,3,4.5\n2,2,2,3,5\n"
    (tmp_path / "colony.csv").write_text(text)
    assert detect_format(tmp_path / "colony.csv") == "wide_csv"
    ds = read_tracks(tmp_path / "colony.csv", fps=29.97, units="mm")
    np.testing.assert_allclose(ds.time.values, np.arange(3) / 29.97)
    np.testing.assert_array_equal(ds.position.values[:, 0, 0, 1], [3.0, 3.0, 3.0])
    assert "position" in ds.attrs["time_from"]
    # a first column of non-integers is not a frame number: not recognised
    (tmp_path / "other.csv").write_text("speed,x0,y0\n0.5,1,2\n")
    with pytest.raises(InputError, match="--format"):
        detect_format(tmp_path / "other.csv")


def test_sniff_tells_tidy_wide_and_dlc_apart(tmp_path):
    (tmp_path / "tidy.csv").write_text("id,time,x,y\na,0,1,2\n")
    (tmp_path / "wide.csv").write_text("frame,x0,y0,x1,y1\n0,1,2,3,4\n")
    (tmp_path / "dlc.csv").write_text("scorer,s,s\nbodyparts,a,a\ncoords,x,y\n0,1,2\n")
    (tmp_path / "other.csv").write_text("a,b,c\n1,2,3\n")
    assert detect_format(tmp_path / "tidy.csv") == "tidy_csv"
    assert detect_format(tmp_path / "wide.csv") == "wide_csv"
    assert detect_format(tmp_path / "dlc.csv") == "dlc"
    with pytest.raises(InputError, match=r"other\.csv.*--format"):
        detect_format(tmp_path / "other.csv")


@pytest.mark.parametrize(
    ("text", "kwargs", "pattern"),
    [
        ("id,frame,x,y\na,0,1,2\n", {"fps": 1.0}, r"length unit.*--px-per-mm.*units"),
        ("id,frame,x,y\na,0,1,2\n", {"px_per_mm": 2.0}, r"frame numbers.*--fps"),
        (
            "id,frame,x,y\na,0,abc,2\n",
            {"fps": 1, "units": "mm"},
            r"non-numeric value 'abc' in column 'x' \(data row 1\)",
        ),
        (
            "id,frame,x,y\na,0,1,2\na,0,3,4\n",
            {"fps": 1, "units": "mm"},
            r"individual 'a' at frame 0: two different samples",
        ),
        ("id,frame,x,y\n", {"fps": 1, "units": "mm"}, r"no data rows"),
        ("id,frame,x\na,0,1\n", {"fps": 1, "units": "mm"}, r"no x/y columns"),
        ("id,frame,x,y\na,0,1,2,9,9\n", {"fps": 1, "units": "mm"}, r"malformed CSV"),
        ("id,frame,x,y\na,,1,2\n", {"fps": 1, "units": "mm"}, r"non-finite time/frame"),
        ("id,frame,x,y\na,0,,\n", {"fps": 1, "units": "mm"}, r"NaN"),
        ("id,frame,x,y\na,0,1,2\n", {"fps": 1, "units": "furlong"}, r"unknown length unit"),
        (
            "id,frame,x,y\na,0,1,2\n",
            {"fps": 1, "units": "mm", "px_per_mm": 2},
            r"not pixels; drop --px-per-mm",
        ),
    ],
)
def test_malformed_tidy(tmp_path, text, kwargs, pattern):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=r"bad\.csv: .*" + pattern) as err:
        read_tracks(path, "tidy_csv", **kwargs)
    assert "\n" not in str(err.value)


def test_not_utf8(tmp_path):
    path = tmp_path / "bin.csv"
    path.write_bytes(b"\xff\xfe\x00\x81" * 20)
    with pytest.raises(InputError, match=r"bin\.csv"):
        read_tracks(path, "tidy_csv", fps=1, units="mm")


def test_dense_size_guard(tmp_path, monkeypatch):
    import thermoswarm.io._common as common

    monkeypatch.setattr(common, "MAX_CELLS", 10)
    pd.DataFrame(
        {"id": [f"t{i}" for i in range(4)], "frame": [0, 1, 2, 3], "x": 1.0, "y": 1.0}
    ).to_csv(tmp_path / "frag.csv", index=False)
    with pytest.raises(InputError, match=r"frag\.csv: 4 individuals .* merge fragmented"):
        read_tracks(tmp_path / "frag.csv", fps=1, units="mm")


def test_tsv_written_with_tabs_and_read_back(tmp_path, truth):
    ds0 = make_tracks(truth.mm, fps=FPS, individuals=truth.individuals, keypoints=truth.keypoints)
    write_tracks(ds0, tmp_path / "t.tsv")
    header = [
        ln for ln in (tmp_path / "t.tsv").read_text().splitlines() if not ln.startswith("#")
    ][0]
    assert header.split("\t") == ["individual", "keypoint", "time", "frame", "x", "y"]
    ds = read_tracks(tmp_path / "t.tsv")
    np.testing.assert_array_equal(ds.position.values, ds0.position.values)
