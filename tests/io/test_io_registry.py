"""The registry: content sniffing per ambiguous extension, options, presets, the CLI."""

from __future__ import annotations

import warnings

import h5py
import numpy as np
import pandas as pd
import pytest
import tables  # noqa: F401  (pandas writes the DeepLabCut .h5 fixtures with it)
from click.testing import CliRunner
from io_truth import FPS, SCALE

from thermoswarm.cli import cli
from thermoswarm.errors import InputError
from thermoswarm.io import (
    describe_formats,
    parse_read_options,
    read_tracks,
    resolve_px_per_mm,
)
from thermoswarm.tracks import make_tracks

PX = {"px_per_mm": SCALE, "fps": FPS}


def _sleap_h5(path):
    with h5py.File(path, "w") as f:
        f["tracks"] = np.ones((1, 2, 1, 3))
        f["node_names"] = np.array([b"body"])
        f["track_names"] = np.array([b"t0"])


def _idtracker_h5(path):
    with h5py.File(path, "w") as f:
        f["trajectories"] = np.ones((3, 1, 2))
        f.attrs["frames_per_second"] = FPS


def _dlc_h5(path):
    cols = pd.MultiIndex.from_tuples(
        [("s", "body", c) for c in ("x", "y", "likelihood")],
        names=["scorer", "bodyparts", "coords"],
    )
    pd.DataFrame(np.ones((3, 3)), columns=cols).to_hdf(path, key="df_with_missing", format="table")


@pytest.mark.parametrize(
    ("make", "software"),
    [
        (_sleap_h5, "SLEAP"),
        (_idtracker_h5, "idtracker.ai"),
        (_dlc_h5, "DeepLabCut"),
    ],
)
def test_read_tracks_sniffs_h5(tmp_path, make, software):
    path = tmp_path / "data.h5"
    make(path)
    assert read_tracks(path, **PX).attrs["source_software"] == software


@pytest.mark.parametrize(
    ("text", "software"),
    [
        ("id,frame,x,y\na,0,1,2\n", "CSV (tidy)"),
        ("frame,x0,y0,x1,y1\n0,1,2,3,4\n", "CSV (wide)"),
        ("scorer,s,s,s\nbodyparts,b,b,b\ncoords,x,y,likelihood\n0,1,2,0.5\n", "DeepLabCut"),
    ],
)
def test_read_tracks_sniffs_csv(tmp_path, text, software):
    path = tmp_path / "data.csv"
    path.write_text(text)
    assert read_tracks(path, **PX).attrs["source_software"] == software


@pytest.mark.parametrize(
    ("text", "software"),
    [
        ("1,1,10,20,4,4,1,-1,-1,-1\n2,1,11,20,4,4,1,-1,-1,-1\n", "MOTChallenge"),
        ("t x y\n0 1 2\n0.1 2 3\n", "text (t x y)"),
    ],
)
def test_read_tracks_sniffs_txt(tmp_path, text, software):
    path = tmp_path / "data.txt"
    path.write_text(text)
    assert read_tracks(path, **PX).attrs["source_software"] == software


def _zarr_dir(d):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        make_tracks(np.ones((3, 2, 1))).to_zarr(d, zarr_format=3)


def _idtracker_dir(d):
    (d / "trajectories").mkdir()
    _idtracker_h5(d / "trajectories" / "trajectories.h5")


def _trex_dir(d):
    np.savez(
        d / "v_id0.npz",
        frame=np.arange(3),
        time=np.arange(3) / FPS,
        **{"X#wcentroid": np.ones(3), "Y#wcentroid": np.ones(3)},
    )


def _text_dir(d):
    (d / "a.txt").write_text("0 1 2\n1 2 3\n")


@pytest.mark.parametrize(
    ("make", "software"),
    [
        (_zarr_dir, "thermoswarm"),
        (_idtracker_dir, "idtracker.ai"),
        (_trex_dir, "TRex"),
        (_text_dir, "text (t x y)"),
    ],
)
def test_read_tracks_sniffs_directories(tmp_path, make, software):
    d = tmp_path / "data"
    d.mkdir()
    make(d)
    kwargs = {} if software in ("thermoswarm", "TRex") else PX
    assert read_tracks(d, **kwargs).attrs["source_software"] == software


def test_unknown_option_lists_accepted(tmp_path):
    path = tmp_path / "data.csv"
    path.write_text("id,frame,x,y\na,0,1,2\n")
    with pytest.raises(
        InputError,
        match=r"data\.csv: unknown option\(s\) colour .*tidy_csv"
        r".*accepts: confidence_col, delimiter",
    ):
        read_tracks(path, colour="red", **PX)


def test_allow_pickle_ignored_by_formats_that_never_unpickle(tmp_path):
    path = tmp_path / "data.csv"
    path.write_text("id,frame,x,y\na,0,1,2\n")
    assert read_tracks(path, allow_pickle=True, **PX).sizes["time"] == 1


def test_paper_preset_and_bad_scales():
    assert resolve_px_per_mm("paper") == 3.04
    assert resolve_px_per_mm(" Paper ") == 3.04
    assert resolve_px_per_mm("2.5") == 2.5
    for bad in ("fast", -1, 0, float("nan"), "inf"):
        with pytest.raises(InputError, match="px_per_mm"):
            resolve_px_per_mm(bad)


def test_parse_read_options():
    opts = parse_read_options(
        [
            "units=mm",
            'x_col="cx"',
            "video=2",
            "user_instances=false",
            'columns=["frame", "x", "y"]',
            "cm_per_pixel=0.5",
        ]
    )
    assert opts == {
        "units": "mm",
        "x_col": "cx",
        "video": 2,
        "user_instances": False,
        "columns": ["frame", "x", "y"],
        "cm_per_pixel": 0.5,
    }
    with pytest.raises(InputError, match="expected key=value"):
        parse_read_options(["novalue"])
    with pytest.raises(InputError, match="given twice"):
        parse_read_options(["a=1", "a=2"])


def test_missing_path_and_unknown_format(tmp_path):
    with pytest.raises(InputError, match=r"nothere\.csv: no such file"):
        read_tracks(tmp_path / "nothere.csv")
    (tmp_path / "x.bin").write_bytes(b"\0")
    with pytest.raises(InputError, match=r"x\.bin: unknown trajectory format '\.bin'"):
        read_tracks(tmp_path / "x.bin")
    with pytest.raises(InputError, match="unknown input format 'nope'"):
        read_tracks(tmp_path / "x.bin", format="nope")


def test_every_format_documents_needs_and_options():
    rows = describe_formats()
    assert {r["name"] for r in rows} >= {
        "netcdf",
        "zarr",
        "mot",
        "text",
        "dlc",
        "tidy_csv",
        "wide_csv",
        "sleap",
        "idtracker",
        "trex",
    }
    for r in rows:
        assert r["needs"], r["name"]
        assert all(isinstance(v, str) and v for v in r["options"].values())


# ----------------------------------------------------------------------------- CLI


def test_cli_convert_csv_to_netcdf(tmp_path):
    src = tmp_path / "in.csv"
    src.write_text("id,frame,x,y\na,0,3.04,6.08\na,1,6.08,6.08\n")
    out = tmp_path / "out.nc"
    res = CliRunner().invoke(
        cli, ["convert", str(src), str(out), "--fps", "10", "--px-per-mm", "paper"]
    )
    assert res.exit_code == 0, res.output
    assert "2 time steps, 1 individuals" in res.output
    ds = read_tracks(out)
    np.testing.assert_allclose(ds.position.values[:, :, 0, 0], [[1.0, 2.0], [2.0, 2.0]])


def test_cli_convert_read_option(tmp_path):
    src = tmp_path / "in.csv"
    src.write_text("ant,frame,cx,cy\na,0,1,2\n")
    res = CliRunner().invoke(
        cli,
        [
            "convert",
            str(src),
            str(tmp_path / "o.csv"),
            "--fps",
            "1",
            "--read-option",
            "units=mm",
            "--read-option",
            "individual_col=ant",
            "--read-option",
            "x_col=cx",
            "--read-option",
            'y_col="cy"',
            "--format",
            "tidy_csv",
        ],
    )
    assert res.exit_code == 0, res.output
    # the options reached the reader: the renamed columns give individual a at (1, 2) mm
    back = read_tracks(tmp_path / "o.csv")
    assert list(back.individuals.values) == ["a"]
    np.testing.assert_array_equal(back.position.values[0, :, 0, 0], [1.0, 2.0])
    assert back.attrs["space_unit"] == "mm" and back.time.values.tolist() == [0.0]


@pytest.mark.parametrize(
    ("name", "content", "args", "expect"),
    [
        (
            "bad.csv",
            "id,frame,x,y\na,0,abc,2\n",
            ["--fps", "1", "--read-option", "units=mm"],
            "non-numeric value 'abc'",
        ),
        (
            "bad.h5",
            "\x89HDF junk",
            ["--format", "sleap", "--fps", "1", "--px-per-mm", "2"],
            "not a readable HDF5",
        ),
        ("bad.txt", "1,1,10,20,4,4\n", ["--px-per-mm", "2"], "--fps"),
        ("bad.npy", None, ["--px-per-mm", "2"], "--allow-pickle"),
    ],
)
def test_cli_malformed_file_exit_2_one_line(tmp_path, name, content, args, expect):
    src = tmp_path / name
    if content is None:
        np.save(src, {"trajectories": np.ones((2, 1, 2))}, allow_pickle=True)
    else:
        src.write_text(content)
    res = CliRunner().invoke(cli, ["convert", str(src), str(tmp_path / "o.nc"), *args])
    assert res.exit_code == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith(f"error: {src}")
    assert expect in lines[0]
    assert not (tmp_path / "o.nc").exists()


def test_cli_formats_lists_everything():
    res = CliRunner().invoke(cli, ["formats"])
    assert res.exit_code == 0
    for name in ("idtracker", "trex", "sleap", "dlc", "tidy_csv", "wide_csv", "zarr"):
        assert name in res.output


def _bigger_sleap_h5(path):
    with h5py.File(path, "w") as f:
        f.create_dataset("tracks", data=np.random.default_rng(0).normal(size=(4, 2, 3, 500)))
        f["node_names"] = np.array([b"a", b"b", b"c"])
        f["track_names"] = np.array([b"t0", b"t1", b"t2", b"t3"])


def _bigger_idtracker_h5(path):
    with h5py.File(path, "w") as f:
        f["trajectories"] = np.random.default_rng(0).normal(size=(500, 4, 2))
        f.attrs["frames_per_second"] = FPS


def _bigger_dlc_h5(path):
    cols = pd.MultiIndex.from_tuples(
        [("s", f"b{k}", c) for k in range(5) for c in ("x", "y", "likelihood")],
        names=["scorer", "bodyparts", "coords"],
    )
    pd.DataFrame(np.random.default_rng(0).normal(size=(500, 15)), columns=cols).to_hdf(
        path, key="df_with_missing", format="table"
    )


def _bigger_nc(path):
    from thermoswarm.io import write_tracks

    write_tracks(make_tracks(np.random.default_rng(0).normal(size=(500, 2, 4)), fps=FPS), path)


def _bigger_npz(path):
    n = 500
    np.savez(
        path,
        frame=np.arange(n),
        time=np.arange(n) / FPS,
        **{"X#wcentroid": np.ones(n), "Y#wcentroid": np.ones(n)},
    )


@pytest.mark.parametrize(
    ("name", "make", "fmt"),
    [
        ("a.h5", _bigger_sleap_h5, "sleap"),
        ("b.h5", _bigger_idtracker_h5, "idtracker"),
        ("c.h5", _bigger_dlc_h5, "dlc"),
        ("d.nc", _bigger_nc, "netcdf"),
        ("e_id0.npz", _bigger_npz, "trex"),
    ],
)
@pytest.mark.parametrize("keep", [0.5, 0.9])
def test_truncated_files_are_one_line_errors(tmp_path, name, make, fmt, keep):
    path = tmp_path / name
    make(path)
    data = path.read_bytes()
    path.write_bytes(data[: int(len(data) * keep)])
    with pytest.raises(InputError) as err:
        read_tracks(path, fmt, **PX)
    msg = str(err.value)
    assert msg.startswith(str(path)) and "\n" not in msg
