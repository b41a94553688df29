"""DeepLabCut readers: CSV and HDF5 written with pandas, as DeepLabCut writes them."""

from __future__ import annotations

import pickle

import h5py
import numpy as np
import pandas as pd
import pytest
import tables  # noqa: F401  (pandas writes the DeepLabCut .h5 fixtures with it)
from io_truth import FPS, SCALE, Truth, assert_tracks

from thermoswarm.errors import InputError
from thermoswarm.io import detect_format, read_tracks


def _frame(truth: Truth, *, multi: bool = True) -> pd.DataFrame:
    """A DeepLabCut predictions DataFrame (columns scorer/[individuals/]bodyparts/coords)."""
    inds = truth.individuals if multi else truth.individuals[:1]
    cols, data = [], []
    for i, ind in enumerate(inds):
        for k, kp in enumerate(truth.keypoints):
            for c, values in (
                ("x", truth.px[:, 0, k, i]),
                ("y", truth.px[:, 1, k, i]),
                ("likelihood", truth.conf[:, k, i].astype(np.float64)),
            ):
                cols.append(
                    ("DLC_resnet50_antsMar1shuffle1_1000",) + ((ind,) if multi else ()) + (kp, c)
                )
                data.append(values)
    names = (
        ["scorer", "individuals", "bodyparts", "coords"]
        if multi
        else ["scorer", "bodyparts", "coords"]
    )
    return pd.DataFrame(
        np.column_stack(data), columns=pd.MultiIndex.from_tuples(cols, names=names)
    )


def test_csv_multi_animal(tmp_path, truth):
    path = tmp_path / "videoDLC_resnet50.csv"
    _frame(truth).to_csv(path)
    assert detect_format(path) == "dlc"
    ds = read_tracks(path, fps=FPS, px_per_mm="paper")
    assert_tracks(ds, truth.mm, truth.times, truth.individuals, truth.keypoints, truth.conf)
    assert ds.attrs["dlc_scorer"] == "DLC_resnet50_antsMar1shuffle1_1000"
    assert ds.attrs["px_per_mm"] == SCALE


def test_csv_single_animal(tmp_path, truth):
    path = tmp_path / "single.csv"
    _frame(truth, multi=False).to_csv(path)
    ds = read_tracks(path, fps=FPS, px_per_mm=SCALE)
    assert_tracks(
        ds, truth.mm[..., :1], truth.times, ["id_0"], truth.keypoints, truth.conf[..., :1]
    )


def test_csv_unique_bodyparts_become_union_of_keypoints(tmp_path, truth):
    df = _frame(truth)
    extra = pd.DataFrame(
        {
            ("DLC_resnet50_antsMar1shuffle1_1000", "single", "food", c): v
            for c, v in (
                ("x", np.arange(7.0)),
                ("y", np.arange(7.0) * 2),
                ("likelihood", np.full(7, 0.5)),
            )
        }
    )
    extra.columns.names = df.columns.names
    path = tmp_path / "ma.csv"
    pd.concat([df, extra], axis=1).to_csv(path)
    ds = read_tracks(path, fps=FPS, px_per_mm=SCALE)
    assert list(ds.individuals.values) == ["ant_a", "ant_b", "single"]
    assert list(ds.keypoints.values) == ["head", "thorax", "tail", "food"]
    food = ds.position.sel(keypoints="food")
    np.testing.assert_allclose(food.sel(individuals="single", space="y"), np.arange(7) * 2 / SCALE)
    assert np.isnan(food.sel(individuals="ant_a").values).all()
    assert np.isnan(ds.position.sel(keypoints="head", individuals="single").values).all()


@pytest.mark.parametrize("fmt", ["table", "fixed"])
def test_h5_written_by_pandas(tmp_path, truth, fmt):
    path = tmp_path / f"videoDLC_{fmt}.h5"
    _frame(truth).to_hdf(path, key="df_with_missing", format=fmt, mode="w")
    assert detect_format(path) == "dlc"
    ds = read_tracks(path, fps=FPS, px_per_mm=SCALE)
    assert_tracks(ds, truth.mm, truth.times, truth.individuals, truth.keypoints, truth.conf)


def test_h5_single_animal_table(tmp_path, truth):
    path = tmp_path / "single.h5"
    _frame(truth, multi=False).to_hdf(path, key="df_with_missing", format="table", mode="w")
    ds = read_tracks(path, fps=FPS, px_per_mm=SCALE)
    assert_tracks(
        ds, truth.mm[..., :1], truth.times, ["id_0"], truth.keypoints, truth.conf[..., :1]
    )


class _Boom:
    """Unpickling this would create a file: the reader must never do it."""

    def __init__(self, target: str) -> None:
        self.target = target

    def __reduce__(self):
        return (open, (self.target, "w"))


def test_h5_with_code_in_pickled_attribute_is_refused(tmp_path, truth):
    path = tmp_path / "evil.h5"
    _frame(truth).to_hdf(path, key="df_with_missing", format="table", mode="w")
    marker = tmp_path / "pwned"
    with h5py.File(path, "r+") as f:
        f["df_with_missing/table"].attrs["values_block_0_kind"] = np.bytes_(
            pickle.dumps(_Boom(str(marker)), protocol=0)
        )
    with pytest.raises(InputError, match=r"evil\.h5.*safely"):
        read_tracks(path, fps=FPS, px_per_mm=SCALE)
    assert not marker.exists()


def test_needs_fps_and_scale(tmp_path, truth):
    path = tmp_path / "d.csv"
    _frame(truth).to_csv(path)
    with pytest.raises(InputError, match=r"d\.csv.*--fps"):
        read_tracks(path, px_per_mm=SCALE)
    with pytest.raises(InputError, match=r"d\.csv.*--px-per-mm"):
        read_tracks(path, fps=FPS)


def test_non_numeric_value(tmp_path, truth):
    path = tmp_path / "bad.csv"
    _frame(truth).to_csv(path)
    lines = path.read_text().splitlines()
    parts = lines[6].split(",")
    parts[3] = "oops"
    lines[6] = ",".join(parts)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"bad\.csv.*non-numeric.*'oops'"):
        read_tracks(path, fps=FPS, px_per_mm=SCALE)


def test_wrong_header_rows(tmp_path):
    path = tmp_path / "hdr.csv"
    path.write_text("scorer,a,a\nfoo,b,b\ncoords,x,y\n0,1,2\n")
    with pytest.raises(InputError, match=r"hdr\.csv.*header rows"):
        read_tracks(path, fps=FPS, px_per_mm=SCALE)


def test_3d_rejected(tmp_path):
    cols = pd.MultiIndex.from_tuples(
        [("s", "nose", c) for c in "xyz"], names=["scorer", "bodyparts", "coords"]
    )
    path = tmp_path / "threed.csv"
    pd.DataFrame(np.ones((3, 3)), columns=cols).to_csv(path)
    with pytest.raises(InputError, match=r"threed\.csv.*3-D"):
        read_tracks(path, fps=FPS, px_per_mm=SCALE)


def test_corrupt_h5(tmp_path):
    path = tmp_path / "junk.h5"
    path.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\x00" * 64)
    with pytest.raises(InputError, match=r"junk\.h5"):
        read_tracks(path, format="dlc", fps=FPS, px_per_mm=SCALE)
