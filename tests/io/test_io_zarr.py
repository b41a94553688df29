"""The simulation recorder's Zarr store: only committed frames are returned."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import xarray as xr
import zarr

from thermoswarm.errors import InputError
from thermoswarm.io import detect_format, read_tracks
from thermoswarm.tracks import make_tracks

N_ALLOC, N_COMMITTED = 10, 6


def _store(path, rng, committed: int | None = N_COMMITTED) -> np.ndarray:
    """A store preallocated for 10 frames; frames >= committed hold garbage."""
    pos = rng.normal(size=(N_ALLOC, 2, 1, 3)) * 100.0
    good = pos.copy()
    pos[N_COMMITTED:] = 1e30  # half-written block: must never be returned
    ds = make_tracks(pos, fps=5.0, individuals=["r0", "r1", "r2"], source_software="sim")
    ds["temperature"] = (("time", "individuals"), rng.uniform(1, 2, size=(N_ALLOC, 3)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds.to_zarr(path, zarr_format=3, consolidated=False)
    if committed is not None:
        zarr.open_group(path, mode="r+").attrs["committed_frames"] = committed
    return good


def test_only_committed_frames(tmp_path, rng):
    path = tmp_path / "run.zarr"
    good = _store(path, rng)
    assert detect_format(path) == "zarr"
    ds = read_tracks(path)
    assert ds.sizes["time"] == N_COMMITTED
    np.testing.assert_array_equal(ds.position.values, good[:N_COMMITTED])
    np.testing.assert_allclose(ds.time.values, np.arange(N_COMMITTED) / 5.0)
    assert ds["temperature"].sizes["time"] == N_COMMITTED
    assert ds.attrs["committed_frames"] == N_COMMITTED
    assert ds.attrs["fps"] == 5.0


def test_plain_directory_name_is_sniffed(tmp_path, rng):
    path = tmp_path / "recording"
    _store(path, rng)
    assert detect_format(path) == "zarr"


def test_marker_updated_after_open_is_seen_by_a_new_read(tmp_path, rng):
    path = tmp_path / "run.zarr"
    _store(path, rng, committed=2)
    assert read_tracks(path).sizes["time"] == 2
    zarr.open_group(path, mode="r+").attrs["committed_frames"] = 5
    assert read_tracks(path).sizes["time"] == 5


def test_store_without_marker_is_complete(tmp_path, rng):
    path = tmp_path / "whole.zarr"
    _store(path, rng, committed=None)
    assert read_tracks(path).sizes["time"] == N_ALLOC


@pytest.mark.parametrize(
    ("value", "pattern"),
    [
        (0, "no committed frames yet"),
        (11, "committed_frames = 11 but the store holds 10"),
        (-1, "committed_frames must be an integer >= 0, got -1"),
        ("6", "committed_frames must be an integer >= 0, got .6."),
    ],
)
def test_bad_marker(tmp_path, rng, value, pattern):
    path = tmp_path / "run.zarr"
    _store(path, rng)
    zarr.open_group(path, mode="r+").attrs["committed_frames"] = value
    with pytest.raises(InputError, match=r"run\.zarr: " + pattern):
        read_tracks(path)


def test_corrupt_metadata(tmp_path, rng):
    path = tmp_path / "run.zarr"
    _store(path, rng)
    (path / "zarr.json").write_text("{not json")
    with pytest.raises(InputError, match=r"run\.zarr: unreadable Zarr root metadata"):
        read_tracks(path)


def test_missing_chunk_in_committed_range(tmp_path, rng):
    path = tmp_path / "run.zarr"
    _store(path, rng)
    meta = path / "position" / "zarr.json"
    meta.write_text(meta.read_text().replace('"float64"', '"complex_garbage"'))
    with pytest.raises(InputError, match=r"run\.zarr"):
        read_tracks(path)


def test_not_trajectories(tmp_path):
    path = tmp_path / "other.zarr"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        xr.Dataset({"a": ("t", np.arange(3.0))}).to_zarr(path, zarr_format=3)
    with pytest.raises(InputError, match=r"other\.zarr: no 'position'"):
        read_tracks(path)
