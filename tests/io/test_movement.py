"""``movement`` both ways, against the real package.

Files are made with ``movement``'s own savers (SLEAP analysis .h5, DeepLabCut .h5 and
.csv, VIA-tracks .csv), loaded with its own loaders and saved as it saves datasets
(``Dataset.to_netcdf``); we read them and compare with the known pixels.  Going
back, what we write is opened as ``movement``'s napari loader opens a netCDF file
(``xarray.open_dataset`` with its default engine, then the validator of its
``ds_type``), rebuilt through the validating constructor, and exported with
``movement``'s savers, whose files we read again.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr
from click.testing import CliRunner
from io_truth import FPS, SCALE, Truth, assert_tracks

from thermoswarm.errors import InputError
from thermoswarm.io import read_tracks, write_tracks
from thermoswarm.io.movement import from_movement, to_movement
from thermoswarm.tracks import make_tracks

movement = pytest.importorskip("movement")  # the dev extra; test_install checks it is there
from movement.io import load_bboxes, load_dataset, load_poses, save_bboxes, save_poses  # noqa: E402
from movement.transforms import scale  # noqa: E402
from movement.validators.datasets import ValidBboxesInputs, ValidPosesInputs  # noqa: E402


def poses(truth: Truth, fps: float | None = None) -> xr.Dataset:
    """The truth as a movement poses dataset (pixels)."""
    return load_poses.from_numpy(
        truth.px,
        truth.conf,
        individual_names=truth.individuals,
        keypoint_names=truth.keypoints,
        fps=fps,
        source_software="test",
    )


@pytest.fixture
def boxes(rng: np.random.Generator) -> dict:
    """Box centres and sizes in pixels, two tracks over 9 frames, one box missing."""
    n_t = 9
    centre = np.round(rng.uniform(50.0, 1500.0, size=(n_t, 2, 2)) * 4) / 4
    size = np.round(rng.uniform(8.0, 40.0, size=(n_t, 2, 2)) * 4) / 4
    conf = np.round(rng.uniform(0.2, 1.0, size=(n_t, 2)) * 256) / 256
    centre[3, :, 1] = size[3, :, 1] = conf[3, 1] = np.nan
    return {"centre": centre, "size": size, "conf": conf, "names": ["id_1", "id_2"]}


def boxes_dataset(b: dict, fps: float | None = None) -> xr.Dataset:
    return load_bboxes.from_numpy(
        b["centre"],
        b["size"],
        b["conf"],
        individual_names=b["names"],
        frame_array=np.arange(b["centre"].shape[0])[:, None],
        fps=fps,
        source_software="VIA-tracks",
    )


def assert_movement_accepts(path, ds_type: str) -> xr.Dataset:
    """Open ``path`` as movement's netCDF loader does, validate it, rebuild it."""
    ds = xr.open_dataset(path).load()
    assert ds.attrs["ds_type"] == ds_type
    if ds_type == "poses":
        ValidPosesInputs.validate(ds)
        ValidPosesInputs(
            position_array=ds["position"].values,
            confidence_array=ds["confidence"].values,
            individual_names=[str(x) for x in ds["individuals"].values],
            keypoint_names=[str(x) for x in ds["keypoints"].values],
            fps=ds.attrs.get("fps"),
            source_software=ds.attrs["source_software"],
        )
        assert ds["position"].dims == ValidPosesInputs.DIM_NAMES
    else:
        ValidBboxesInputs.validate(ds)
        ValidBboxesInputs(
            position_array=ds["position"].values,
            shape_array=ds["shape"].values,
            confidence_array=ds["confidence"].values,
            individual_names=[str(x) for x in ds["individuals"].values],
            frame_array=np.arange(ds.sizes["time"])[:, None],
            fps=ds.attrs.get("fps"),
        )
        assert ds["position"].dims == ValidBboxesInputs.DIM_NAMES
    assert ds["position"].attrs["space_unit"] == "mm"
    return ds


# --- reading what movement wrote -----------------------------------------------------


def test_reads_movement_poses_loaded_from_its_sleap_file(truth, tmp_path):
    h5 = tmp_path / "ants.analysis.h5"
    save_poses.to_sleap_analysis_file(poses(truth), h5)
    nc = tmp_path / "ants.nc"
    load_dataset(h5, "SLEAP", fps=FPS).to_netcdf(nc)
    ds = read_tracks(nc, px_per_mm=SCALE)
    assert_tracks(ds, truth.mm, truth.times, truth.individuals, truth.keypoints, truth.conf)
    assert ds.attrs["movement_ds_type"] == "poses" and ds.attrs["fps"] == FPS
    # our own SLEAP reader reads movement's SLEAP file to the same numbers
    ours = read_tracks(h5, fps=FPS, px_per_mm=SCALE)
    np.testing.assert_array_equal(ours["position"].values, ds["position"].values)


@pytest.mark.parametrize("suffix", [".h5", ".csv"])
def test_reads_movement_poses_loaded_from_its_dlc_file(truth, tmp_path, suffix):
    dlc = tmp_path / f"ants{suffix}"
    save_poses.to_dlc_file(poses(truth), dlc, split_individuals=False)
    nc = tmp_path / "ants.nc"
    load_dataset(dlc, "DeepLabCut").to_netcdf(nc)  # frames: the fps comes with the read
    ds = read_tracks(nc, fps=FPS, px_per_mm=SCALE)
    assert_tracks(ds, truth.mm, truth.times, truth.individuals, truth.keypoints, truth.conf)
    ours = read_tracks(dlc, fps=FPS, px_per_mm=SCALE)
    np.testing.assert_allclose(ours["position"].values, ds["position"].values, rtol=1e-12)


def test_reads_movement_boxes_loaded_from_its_via_tracks_file(boxes, tmp_path):
    via = tmp_path / "boxes.csv"
    save_bboxes.to_via_tracks_file(boxes_dataset(boxes), via)
    nc = tmp_path / "boxes.nc"
    load_dataset(via, "VIA-tracks", fps=FPS).to_netcdf(nc)
    n_t = boxes["centre"].shape[0]
    for ds in (
        read_tracks(nc, px_per_mm=SCALE),
        read_tracks(via, "movement", px_per_mm=SCALE, fps=FPS, source_software="VIA-tracks"),
    ):
        assert_tracks(
            ds,
            boxes["centre"][:, :, None, :] / SCALE,
            np.arange(n_t) / FPS,
            boxes["names"],
            ["centroid"],
            boxes["conf"][:, None, :],
        )
        assert ds.attrs["movement_ds_type"] == "bboxes"
        np.testing.assert_allclose(ds["shape"].values, boxes["size"] / SCALE, rtol=1e-12)
        assert ds["shape"].dims == ("time", "space", "individuals")


def test_calibrated_units_any_dimension_order_and_frames(truth, tmp_path):
    ds = poses(truth)
    ds["position"] = scale(ds["position"], factor=0.1 / SCALE, space_unit="cm")
    nc = tmp_path / "cm.nc"
    ds.transpose("individuals", "keypoints", "space", "time").to_netcdf(nc)
    got = read_tracks(nc, fps=FPS)  # the unit is recorded: no --px-per-mm needed
    assert_tracks(got, truth.mm, truth.times, truth.individuals, truth.keypoints, truth.conf)
    with pytest.warns(UserWarning, match="--px-per-mm is ignored"):
        read_tracks(nc, fps=FPS, px_per_mm=2.0)
    # without a frame rate the time axis stays in frames, as movement keeps it
    frames = read_tracks(nc)
    assert frames.attrs["time_unit"] == "frames" and "fps" not in frames.attrs
    np.testing.assert_array_equal(frames["time"].values, np.arange(truth.n_t))


def test_movement_in_memory_without_scores_and_bad_datasets(truth):
    ds = load_poses.from_numpy(truth.px, fps=FPS)  # no scores: movement fills NaN
    got = from_movement(ds, px_per_mm=SCALE)
    assert "confidence" not in got
    np.testing.assert_allclose(got["position"].values, truth.mm, rtol=1e-12)
    with pytest.raises(InputError, match="is not recorded"):
        from_movement(ds)
    with pytest.raises(InputError, match="3-D positions"):
        from_movement(load_poses.from_numpy(np.zeros((3, 3, 1, 1))), units="mm")
    with pytest.raises(InputError, match=r"further dimension\(s\) \['view'\]"):
        from_movement(ds.expand_dims(view=["top", "side"]), px_per_mm=SCALE)
    with pytest.raises(InputError, match="contradicts"):
        from_movement(ds.assign_attrs(space_unit="cm"), units="mm")


# --- writing what movement loads -----------------------------------------------------


def test_movement_loads_validates_and_exports_what_we_write(truth, tmp_path):
    ours = make_tracks(
        truth.mm, fps=FPS, individuals=truth.individuals, keypoints=truth.keypoints,
        confidence=truth.conf,
    )  # fmt: skip
    nc = tmp_path / "ours.nc"
    write_tracks(ours, nc, "movement")
    ds = assert_movement_accepts(nc, "poses")
    assert ds.attrs["fps"] == FPS and ds.attrs["time_unit"] == "seconds"
    # movement's savers take it, and what they write reads back to the same tracks
    save_poses.to_dlc_file(ds, tmp_path / "back.h5", split_individuals=False)
    save_poses.to_sleap_analysis_file(ds, tmp_path / "back.analysis.h5")
    for back in (tmp_path / "back.h5", tmp_path / "back.analysis.h5"):
        got = read_tracks(back, fps=FPS, px_per_mm=1.0)  # the files hold mm as "pixels"
        np.testing.assert_allclose(got["position"].values, truth.mm, rtol=1e-12)
        np.testing.assert_allclose(got["confidence"].values, truth.conf, rtol=1e-6)
    # and our reader reads our movement file back exactly
    again = read_tracks(nc)
    assert_tracks(again, truth.mm, truth.times, truth.individuals, truth.keypoints, truth.conf)
    # the same through the CLI, from our own netCDF
    from thermoswarm.cli import cli

    write_tracks(ours, tmp_path / "plain.nc")
    res = CliRunner().invoke(
        cli, ["convert", str(tmp_path / "plain.nc"), str(tmp_path / "cli.nc"), "--to", "movement"]
    )
    assert res.exit_code == 0, res.output
    cli_ds = assert_movement_accepts(tmp_path / "cli.nc", "poses")
    np.testing.assert_array_equal(cli_ds["position"].values, ds["position"].values)


def test_boxes_round_trip_back_to_movement(boxes, tmp_path):
    read = from_movement(boxes_dataset(boxes, fps=FPS), px_per_mm=SCALE)
    nc = tmp_path / "boxes.nc"
    write_tracks(read, nc, "movement")
    ds = assert_movement_accepts(nc, "bboxes")
    np.testing.assert_allclose(ds["shape"].values, boxes["size"] / SCALE, rtol=1e-12)
    via = tmp_path / "again.csv"
    save_bboxes.to_via_tracks_file(ds, via)
    again = load_dataset(via, "VIA-tracks", fps=FPS)
    np.testing.assert_allclose(again["position"].values, boxes["centre"] / SCALE, rtol=1e-9)
    # poses written without scores get NaN scores, as movement expects
    no_conf = to_movement(read.drop_vars("confidence"), ds_type="poses")
    assert no_conf["confidence"].dims == ("time", "keypoints", "individuals")
    assert np.isnan(no_conf["confidence"].values).all()


def test_writing_refuses_what_movement_cannot_hold(truth, tmp_path):
    clocks = make_tracks(truth.mm[:, :, :1], time=np.tile(truth.times[:, None], (1, 2)))
    with pytest.raises(InputError, match="own clocks"):
        to_movement(clocks)
    poses_only = make_tracks(truth.mm, fps=FPS)
    with pytest.raises(InputError, match="bboxes need one keypoint"):
        to_movement(poses_only, ds_type="bboxes")


# --- thermoswarm analyze on movement's files -----------------------------------------


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):
    from thermoswarm.analysis.synthetic import synthetic_tracks
    from thermoswarm.maxent import EnergyMixture

    ds, _ = synthetic_tracks(6, 121, energy=EnergyMixture(0.6, 20.0, 80.0), fps=FPS, rng=7)
    where = tmp_path_factory.mktemp("movement_cli")
    write_tracks(ds, where / "ours.nc")
    return ds, where


def analyze(path, out, *args) -> dict:
    from thermoswarm.cli import cli

    res = CliRunner().invoke(
        cli, ["analyze", str(path), "--out", str(out), "--bootstrap", "0", "--no-report",
              "-q", "--seed", "1", *map(str, args)],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    return json.loads((out / "fits.json").read_text())


def _leaves(tree: object, path: str = "") -> dict[str, object]:
    """Every leaf of the fits (numbers and text) by its path, without the provenance."""
    if isinstance(tree, dict):
        out: dict[str, object] = {}
        for key, value in tree.items():
            if key not in ("source_file", "settings"):
                out.update(_leaves(value, f"{path}/{key}"))
        return out
    if isinstance(tree, list):
        return {k: v for i, x in enumerate(tree) for k, v in _leaves(x, f"{path}[{i}]").items()}
    return {path: tree}


def assert_same_fits(got: dict, want: dict, name: str) -> None:
    """The same fits up to float rounding: mm -> px -> mm changes the last bits."""
    got, want = _leaves(got), _leaves(want)
    assert got.keys() == want.keys(), name
    for key, value in want.items():
        if isinstance(value, float):
            assert got[key] == pytest.approx(value, rel=1e-9, abs=1e-12), f"{name} {key}"
        else:
            assert got[key] == value, f"{name} {key}"


def test_analyze_accepts_movement_poses_and_boxes(synthetic, tmp_path):
    ds, where = synthetic
    px = ds["position"].values * SCALE
    mv = load_poses.from_numpy(px, fps=FPS, source_software="test")
    mv.to_netcdf(tmp_path / "poses.nc")
    names = [f"id_{i}" for i in range(ds.sizes["individuals"])]

    def box(fps: float | None) -> xr.Dataset:
        return load_bboxes.from_numpy(
            px[:, :, 0, :], np.full_like(px[:, :, 0, :], 12.0), individual_names=names,
            frame_array=np.arange(px.shape[0])[:, None], fps=fps, source_software="test",
        )  # fmt: skip

    box(FPS).to_netcdf(tmp_path / "boxes.nc")
    # saved in frames: movement 0.15's VIA saver truncates time * fps to a frame number
    # (57 / 25 * 25 -> 56), which makes two frames one
    save_bboxes.to_via_tracks_file(box(None), tmp_path / "boxes.csv")
    reference = analyze(where / "ours.nc", tmp_path / "ref")
    assert reference["n_samples"] > 500
    for name, extra in (
        ("poses.nc", ()),
        ("boxes.nc", ()),
        ("boxes.csv", ("--format", "movement", "--fps", FPS,
                       "--read-option", "source_software=VIA-tracks")),
    ):  # fmt: skip
        fits = analyze(tmp_path / name, tmp_path / f"out_{name}", "--px-per-mm", SCALE, *extra)
        assert_same_fits(fits, reference, name)


def test_a_bad_file_is_one_error_naming_it(tmp_path):
    bad = tmp_path / "bad.nc"
    bad.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 64)  # an HDF5 signature, then nothing
    with pytest.raises(InputError, match="bad.nc: not a readable netCDF file"):
        read_tracks(bad, "movement", px_per_mm=SCALE)
    with pytest.raises(InputError, match="unknown option"):
        read_tracks(bad, "movement", source="SLEAP")
