"""netCDF (ours and movement's) and MOTChallenge: round trips through the writers."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from io_truth import FPS, SCALE, assert_tracks

from thermoswarm.errors import InputError
from thermoswarm.io import read_tracks, write_tracks
from thermoswarm.tracks import make_tracks


def test_netcdf_round_trip_with_awkward_attrs(tmp_path, truth):
    ds0 = make_tracks(
        truth.mm,
        fps=FPS,
        individuals=truth.individuals,
        keypoints=truth.keypoints,
        confidence=truth.conf,
        attrs={"flag": True, "names": ["a", "b"], "meta": {"k": 1}},
    )
    write_tracks(ds0, tmp_path / "t.nc")
    ds = read_tracks(tmp_path / "t.nc")
    assert_tracks(ds, truth.mm, truth.times, truth.individuals, truth.keypoints, truth.conf)
    assert ds.attrs["flag"] == 1 and ds.attrs["names"] == "a, b"
    assert ds.attrs["meta"] == '{"k": 1}'


def _movement_file(path, truth, *, order=("time", "individuals", "keypoints", "space")):
    pos = xr.DataArray(
        truth.px,
        dims=("time", "space", "keypoints", "individuals"),
        coords={
            "time": truth.times,
            "space": ["x", "y"],
            "keypoints": truth.keypoints,
            "individuals": truth.individuals,
        },
    )
    conf = xr.DataArray(truth.conf, dims=("time", "keypoints", "individuals"))
    ds = xr.Dataset(
        {"position": pos.transpose(*order), "confidence": conf},
        attrs={
            "source_software": "DeepLabCut",
            "ds_type": "poses",
            "fps": FPS,
            "time_unit": "seconds",
        },
    )
    ds.to_netcdf(path, engine="h5netcdf")


def test_movement_file_in_pixels(tmp_path, truth):
    path = tmp_path / "movement.nc"
    _movement_file(path, truth)
    with pytest.raises(InputError, match=r"movement\.nc.*--px-per-mm"):
        read_tracks(path)
    ds = read_tracks(path, px_per_mm="paper")
    assert_tracks(ds, truth.mm, truth.times, truth.individuals, truth.keypoints, truth.conf)
    assert ds.attrs["px_per_mm"] == SCALE


def test_movement_file_already_in_mm(tmp_path, truth):
    path = tmp_path / "movement.nc"
    _movement_file(path, truth)
    ds = read_tracks(path, units="mm")
    np.testing.assert_array_equal(ds.position.values, truth.px)


def test_movement_bboxes_get_a_centroid_keypoint(tmp_path, truth):
    c = truth.centroid_only()
    ds = xr.Dataset(
        {
            "position": (("time", "space", "individuals"), c.px[:, :, 0, :]),
            "shape": (("time", "space", "individuals"), np.ones_like(c.px[:, :, 0, :])),
        },
        coords={"time": truth.times, "space": ["x", "y"], "individuals": truth.individuals},
        attrs={"ds_type": "bboxes", "time_unit": "seconds"},
    )
    ds.to_netcdf(tmp_path / "boxes.nc", engine="h5netcdf")
    out = read_tracks(tmp_path / "boxes.nc", px_per_mm=SCALE)
    assert_tracks(out, c.mm, truth.times, truth.individuals, ["centroid"])


def test_corrupt_netcdf(tmp_path, truth):
    ds0 = make_tracks(truth.mm, fps=FPS)
    write_tracks(ds0, tmp_path / "t.nc")
    data = (tmp_path / "t.nc").read_bytes()
    (tmp_path / "cut.nc").write_bytes(data[: len(data) // 3])
    with pytest.raises(InputError, match=r"cut\.nc: not a readable netCDF"):
        read_tracks(tmp_path / "cut.nc")


def test_mot_round_trip(tmp_path, truth):
    c = truth.centroid_only()
    ds0 = make_tracks(c.mm, fps=FPS, individuals=truth.individuals, confidence=c.conf)
    write_tracks(ds0, tmp_path / "gt.txt", px_per_mm=SCALE)
    ds = read_tracks(tmp_path / "gt.txt", fps=FPS, px_per_mm=SCALE)
    # MOT ids are integers: individuals come back as id_1, id_2
    np.testing.assert_allclose(ds.position.values, c.mm, rtol=1e-12)
    np.testing.assert_allclose(ds.time.values, truth.times, rtol=1e-12)
    assert list(ds.individuals.values) == ["id_1", "id_2"]
    np.testing.assert_allclose(ds.confidence.values, c.conf, atol=5e-4)


def test_write_to_missing_directory(tmp_path, truth):
    from thermoswarm.errors import OutputError

    with pytest.raises(OutputError, match="does not exist"):
        write_tracks(make_tracks(truth.mm, fps=FPS), tmp_path / "nope" / "t.nc")
    with pytest.raises(InputError, match="no writer for extension"):
        write_tracks(make_tracks(truth.mm, fps=FPS), tmp_path / "t.parquet")


def test_scale_given_for_a_file_in_mm_is_ignored_with_warning(tmp_path, truth):
    write_tracks(make_tracks(truth.mm, fps=FPS), tmp_path / "t.nc")
    with pytest.warns(UserWarning, match=r"t\.nc.*mm; --px-per-mm is ignored"):
        ds = read_tracks(tmp_path / "t.nc", px_per_mm="paper")
    np.testing.assert_array_equal(ds.position.values, make_tracks(truth.mm).position.values)
