"""idtracker.ai readers: trajectories.h5 (h5py), trajectories.npy (pickled dict), folders."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from io_truth import SCALE, Truth, assert_tracks

from thermoswarm.errors import InputError
from thermoswarm.io import detect_format, read_tracks

FPS_FILE = 30.0


def _dict(truth: Truth) -> dict:
    c = truth.centroid_only()
    return {
        "trajectories": np.transpose(c.px[:, :, 0, :], (0, 2, 1)),  # (frames, animals, 2)
        "id_probabilities": c.conf[:, 0, :, None].astype(np.float64),  # (frames, animals, 1)
        "frames_per_second": FPS_FILE,
        "body_length": 42.5,
        "version": "5.2.7",
        "video_paths": ["/data/ants.mp4"],
        "length_unit": None,
        "setup_points": {},
        "identities_groups": {},
        "areas": {"mean": np.array([10.0, 11.0])},
    }


def _write_h5(path, data: dict) -> None:
    """As idtracker.ai does: arrays as datasets, scalars and string lists as attributes."""
    with h5py.File(path, "w") as f:
        for key, value in data.items():
            if isinstance(value, dict):
                grp = f.create_group(key)
                for k, v in value.items():
                    grp.create_dataset(k, data=v)
            elif value is None:
                f.attrs[key] = -1
            elif isinstance(value, int | float | str) or isinstance(value, list):
                f.attrs[key] = value
            else:
                f.create_dataset(key, data=value)


def _expected(truth: Truth):
    c = truth.centroid_only()
    return c.mm, np.arange(truth.n_t) / FPS_FILE, c.conf


def test_h5(tmp_path, truth):
    path = tmp_path / "trajectories.h5"
    _write_h5(path, _dict(truth))
    assert detect_format(path) == "idtracker"
    ds = read_tracks(path, px_per_mm="paper")
    mm, times, conf = _expected(truth)
    assert_tracks(ds, mm, times, ["id_1", "id_2"], ["centroid"], conf)
    assert ds.attrs["fps"] == FPS_FILE
    assert ds.attrs["body_length_px"] == 42.5
    assert ds.attrs["body_length_mm"] == pytest.approx(42.5 / SCALE)
    assert ds.attrs["idtracker_version"] == "5.2.7"


def test_h5_identity_labels(tmp_path, truth):
    data = _dict(truth) | {"identities_labels": ["queen", "worker"]}
    path = tmp_path / "trajectories.h5"
    _write_h5(path, data)
    ds = read_tracks(path, px_per_mm=SCALE)
    assert list(ds.individuals.values) == ["queen", "worker"]


def test_npy_needs_allow_pickle(tmp_path, truth):
    path = tmp_path / "trajectories.npy"
    np.save(path, _dict(truth), allow_pickle=True)
    with pytest.raises(InputError, match=r"trajectories\.npy.*pickle.*--allow-pickle"):
        read_tracks(path, px_per_mm=SCALE)
    ds = read_tracks(path, px_per_mm=SCALE, allow_pickle=True)
    mm, times, conf = _expected(truth)
    assert_tracks(ds, mm, times, ["id_1", "id_2"], ["centroid"], conf)


def test_npy_option_spelling_also_works(tmp_path, truth):
    path = tmp_path / "trajectories.npy"
    np.save(path, _dict(truth), allow_pickle=True)
    ds = read_tracks(path, "idtracker", px_per_mm=SCALE, allow_pickle=True)
    assert ds.sizes["individuals"] == 2


def test_plain_array_npy_needs_fps(tmp_path, truth):
    path = tmp_path / "positions.npy"
    np.save(path, _dict(truth)["trajectories"])
    with pytest.raises(InputError, match=r"positions\.npy.*--fps"):
        read_tracks(path, px_per_mm=SCALE)
    ds = read_tracks(path, px_per_mm=SCALE, fps=10.0)
    c = truth.centroid_only()
    assert_tracks(ds, c.mm, np.arange(truth.n_t) / 10.0, ["id_1", "id_2"], ["centroid"])


def test_explicit_fps_overrides_file_with_warning(tmp_path, truth):
    path = tmp_path / "trajectories.h5"
    _write_h5(path, _dict(truth))
    with pytest.warns(UserWarning, match="overrides"):
        ds = read_tracks(path, px_per_mm=SCALE, fps=50.0)
    np.testing.assert_allclose(ds.time.values, np.arange(truth.n_t) / 50.0)
    assert ds.attrs["file_fps"] == FPS_FILE


def test_session_folder(tmp_path, truth):
    session = tmp_path / "session_test"
    (session / "trajectories").mkdir(parents=True)
    _write_h5(session / "trajectories" / "without_gaps.h5", _dict(truth))
    assert detect_format(session) == "idtracker"
    ds = read_tracks(session, px_per_mm=SCALE)
    assert ds.attrs["source_file"].endswith("without_gaps.h5")


def test_needs_scale(tmp_path, truth):
    path = tmp_path / "trajectories.h5"
    _write_h5(path, _dict(truth))
    with pytest.raises(InputError, match=r"trajectories\.h5.*--px-per-mm.*paper"):
        read_tracks(path)


def test_wrong_shape(tmp_path):
    path = tmp_path / "trajectories.h5"
    _write_h5(path, {"trajectories": np.zeros((5, 3, 3)), "frames_per_second": 30.0})
    with pytest.raises(InputError, match=r"trajectories\.h5"):
        read_tracks(path, format="idtracker", px_per_mm=SCALE)


def test_damaged_pickle(tmp_path, truth):
    path = tmp_path / "trajectories.npy"
    np.save(path, _dict(truth), allow_pickle=True)
    path.write_bytes(path.read_bytes()[:200])
    with pytest.raises(InputError, match=r"trajectories\.npy.*damaged"):
        read_tracks(path, px_per_mm=SCALE, allow_pickle=True)


def test_nan_only(tmp_path):
    path = tmp_path / "trajectories.h5"
    _write_h5(path, {"trajectories": np.full((4, 2, 2), np.nan), "frames_per_second": 30.0})
    with pytest.raises(InputError, match=r"trajectories\.h5.*NaN"):
        read_tracks(path, px_per_mm=SCALE)
