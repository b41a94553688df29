"""Property-based tests of every reader: random valid files round-trip, random
corruptions give a one-line error -- never a traceback, a hang or a wrong result.

Hypothesis draws the trajectories (sizes, values on a 1/8 px grid that text keeps
exactly, missing samples) and the corruptions (truncation, overwritten bytes, inserted
garbage).  ``derandomize`` makes every run draw the same examples, so a failure is
reproducible from the log.
"""

from __future__ import annotations

import contextlib
import gc
import io
import shutil
import signal
import sys
import tempfile
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pandas as pd
import pytest
import tables  # noqa: F401  (pandas writes the DeepLabCut .h5 with it)
import zarr
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from thermoswarm.errors import ThermoswarmError
from thermoswarm.io import read_tracks, write_tracks
from thermoswarm.tracks import DIMS, individual_times, make_tracks

SCALE, FPS, CM_PER_PX = 4.0, 10.0, 0.05
#: Seconds any one read may take before the example counts as a hang.
HANG = 30

SETTINGS = dict(
    deadline=None,
    derandomize=True,
    database=None,
    # no shrinking: the fixed draws already make a failure reproducible, and shrinking
    # a failing read can take minutes
    phases=[Phase.explicit, Phase.generate],
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


# --------------------------------------------------------------------------- truth


@st.composite
def truths(draw, *, max_keypoints: int = 2) -> dict[str, Any]:
    """Positions in px ``(time, 2, keypoints, individuals)`` on a 1/8 grid, some NaN;
    every individual has at least two present samples."""
    n_t = draw(st.integers(3, 24))
    n_i = draw(st.integers(1, 3))
    n_k = draw(st.integers(1, max_keypoints))
    px = draw(
        hnp.arrays(
            np.float64, (n_t, 2, n_k, n_i), elements=st.integers(0, 8000).map(lambda v: v / 8)
        )
    )
    # the AND of two draws: about a quarter of the samples missing
    missing = draw(hnp.arrays(np.bool_, (n_t, n_k, n_i))) & draw(
        hnp.arrays(np.bool_, (n_t, n_k, n_i))
    )
    missing[:2] = False  # two present samples of everyone
    px = np.where(missing[:, None], np.nan, px)
    return {"px": px, "individuals": [f"ant{i}" for i in range(n_i)], "keypoints":
            [f"kp{k}" for k in range(n_k)]}  # fmt: skip


def _samples(ds) -> dict[tuple[str, str], tuple[np.ndarray, np.ndarray]]:
    """Each (individual, keypoint)'s present samples: times (s) and positions (mm)."""
    t = individual_times(ds)
    pos = ds["position"].transpose(*DIMS).values
    out = {}
    for i, name in enumerate(str(v) for v in ds["individuals"].values):
        for k, kp in enumerate(str(v) for v in ds["keypoints"].values):
            ok = np.isfinite(t[:, i]) & np.isfinite(pos[:, 0, k, i])
            out[(name, kp)] = (t[ok, i], pos[ok, :, k, i])
    return out


def _expected(truth, *, scale: float = SCALE, t0: float = 0.0):
    mm = truth["px"] / scale
    times = t0 + np.arange(mm.shape[0]) / FPS
    out = {}
    for i, name in enumerate(truth["individuals"]):
        for k, kp in enumerate(truth["keypoints"]):
            ok = np.isfinite(mm[:, 0, k, i])
            out[(name, kp)] = (times[ok], mm[ok, :, k, i])
    return out


def _assert_same(got, want, *, rtol: float = 1e-9) -> None:
    assert set(got) == set(want)
    for key, (t, p) in want.items():
        tg, pg = got[key]
        np.testing.assert_allclose(tg, t, rtol=1e-9, atol=1e-9, err_msg=str(key))
        np.testing.assert_allclose(pg, p, rtol=rtol, atol=1e-9, err_msg=str(key))


# --------------------------------------------------------------------------- writers
# Each writes ``truth`` in one format under ``d`` and returns (path, read kwargs,
# expected samples).


def _netcdf(d: Path, truth):
    ds = make_tracks(truth["px"] / SCALE, fps=FPS, individuals=truth["individuals"],
                     keypoints=truth["keypoints"])  # fmt: skip
    return write_tracks(ds, d / "t.nc"), {}, _expected(truth)


def _tidy(d: Path, truth):
    ds = make_tracks(truth["px"] / SCALE, fps=FPS, individuals=truth["individuals"],
                     keypoints=truth["keypoints"])  # fmt: skip
    return write_tracks(ds, d / "t.csv"), {}, _expected(truth)


def _wide(d: Path, truth):
    single = {**truth, "px": truth["px"][:, :, :1], "keypoints": ["centroid"]}
    cols = {"frame": np.arange(truth["px"].shape[0])}
    for i in range(len(truth["individuals"])):
        cols[f"x{i}"] = single["px"][:, 0, 0, i] / SCALE
        cols[f"y{i}"] = single["px"][:, 1, 0, i] / SCALE
    pd.DataFrame(cols).to_csv(d / "w.csv", index=False)
    want = _expected(
        {**single, "individuals": [f"id_{i}" for i in range(len(truth["individuals"]))]}
    )
    return d / "w.csv", {"fps": FPS, "units": "mm"}, want


def _text(d: Path, truth):
    folder = d / "text"
    folder.mkdir()
    single = {**truth, "px": truth["px"][:, :, :1], "keypoints": ["centroid"]}
    mm = single["px"][:, :, 0] / SCALE
    t = np.arange(mm.shape[0]) / FPS
    for i, name in enumerate(truth["individuals"]):
        ok = np.isfinite(mm[:, 0, i])
        np.savetxt(folder / f"{name}.txt", np.column_stack([t, mm[:, :, i]])[ok], fmt="%.17g")
    return folder, {"units": "mm"}, _expected(single)


def _dlc_frame(truth) -> pd.DataFrame:
    cols, data = [], []
    for i, ind in enumerate(truth["individuals"]):
        for k, kp in enumerate(truth["keypoints"]):
            for c, values in (("x", truth["px"][:, 0, k, i]), ("y", truth["px"][:, 1, k, i]),
                              ("likelihood", np.full(truth["px"].shape[0], 0.5))):  # fmt: skip
                cols.append(("DLC_scorer", ind, kp, c))
                data.append(values)
    names = ["scorer", "individuals", "bodyparts", "coords"]
    return pd.DataFrame(
        np.column_stack(data), columns=pd.MultiIndex.from_tuples(cols, names=names)
    )


def _dlc_csv(d: Path, truth):
    _dlc_frame(truth).to_csv(d / "p.csv")
    return d / "p.csv", {"fps": FPS, "px_per_mm": SCALE}, _expected(truth)


def _dlc_h5(d: Path, truth):
    _dlc_frame(truth).to_hdf(d / "p.h5", key="df_with_missing", format="table")
    return d / "p.h5", {"fps": FPS, "px_per_mm": SCALE, "format": "dlc"}, _expected(truth)


def _sleap(d: Path, truth):
    with h5py.File(d / "s.analysis.h5", "w") as f:
        f["tracks"] = np.transpose(truth["px"], (3, 1, 2, 0))  # (tracks, 2, nodes, frames)
        f["node_names"] = np.array([k.encode() for k in truth["keypoints"]])
        f["track_names"] = np.array([n.encode() for n in truth["individuals"]])
    return (
        d / "s.analysis.h5",
        {"fps": FPS, "px_per_mm": SCALE, "format": "sleap"},
        _expected(truth),
    )


def _idtracker(d: Path, truth):
    single = {**truth, "px": truth["px"][:, :, :1], "keypoints": ["centroid"]}
    with h5py.File(d / "trajectories.h5", "w") as f:
        f["trajectories"] = np.transpose(single["px"][:, :, 0, :], (0, 2, 1))
        f.attrs["frames_per_second"] = FPS
    want = _expected(
        {**single, "individuals": [f"id_{i + 1}" for i in range(len(truth["individuals"]))]}
    )
    return d / "trajectories.h5", {"px_per_mm": SCALE, "format": "idtracker"}, want


def _trex(d: Path, truth):
    folder = d / "trex"
    folder.mkdir()
    single = {**truth, "px": truth["px"][:, :, :1], "keypoints": ["centroid"]}
    frames = np.arange(truth["px"].shape[0])
    for i, name in enumerate(truth["individuals"]):
        x = single["px"][:, 0, 0, i] * CM_PER_PX
        y = single["px"][:, 1, 0, i] * CM_PER_PX
        miss = np.isnan(x)
        xy = {"X#wcentroid": np.where(miss, np.inf, x), "Y#wcentroid": np.where(miss, np.inf, y)}
        np.savez(folder / f"video_{name}.npz", frame=frames, time=frames / FPS,
                 missing=miss.astype(np.float32), **xy)  # fmt: skip
    # TRex's cm -> mm: x10, from px at 1 / CM_PER_PX px per cm; the keypoint is the source
    single["keypoints"] = ["wcentroid"]
    return folder, {}, _expected(single, scale=1.0 / (10 * CM_PER_PX))


def _zarr(d: Path, truth):
    ds = make_tracks(truth["px"] / SCALE, fps=FPS, individuals=truth["individuals"],
                     keypoints=truth["keypoints"])  # fmt: skip
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds.to_zarr(d / "r.zarr", zarr_format=3, consolidated=False)
    zarr.open_group(d / "r.zarr", mode="r+").attrs["committed_frames"] = ds.sizes["time"]
    return d / "r.zarr", {}, _expected(truth)


WRITERS: dict[str, Callable] = {
    "netcdf": _netcdf, "tidy_csv": _tidy, "wide_csv": _wide, "text": _text,
    "dlc_csv": _dlc_csv, "dlc_h5": _dlc_h5, "sleap": _sleap, "idtracker": _idtracker,
    "trex": _trex, "zarr": _zarr,
}  # fmt: skip


@contextlib.contextmanager
def _workdir() -> Iterator[Path]:
    d = Path(tempfile.mkdtemp(prefix="thermoswarm-prop-"))
    try:
        yield d
    finally:
        shutil.rmtree(d, ignore_errors=True)


@contextlib.contextmanager
def _no_hang(seconds: int = HANG) -> Iterator[None]:
    def fail(*_):
        raise TimeoutError(f"a read took more than {seconds} s")

    old = signal.signal(signal.SIGALRM, fail)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def _read(path: Path, kwargs: dict[str, Any]):
    kwargs = dict(kwargs)
    return read_tracks(path, kwargs.pop("format", None), **kwargs)


# --------------------------------------------------------------------------- properties


@pytest.mark.parametrize("fmt", sorted(WRITERS))
def test_random_valid_files_round_trip(fmt):
    @settings(max_examples=8, **SETTINGS)
    @given(truth=truths())
    def check(truth):
        with _workdir() as d:
            path, kwargs, want = WRITERS[fmt](d, truth)
            with _no_hang(), warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ds = _read(path, kwargs)
            _assert_same(_samples(ds), want)

    check()


def _corrupt(data: bytes, how: str, at: float, length: int, junk: bytes) -> bytes:
    j = int(at * len(data))
    if how == "truncate":
        return data[:j]
    if how == "overwrite":
        return data[:j] + junk[:length] + data[j + length :]
    return data[:j] + junk[:length] + data[j:]  # insert


def _target(path: Path) -> Path:
    """The file to corrupt: the file itself, or a folder's first data file."""
    if path.is_file():
        return path
    files = sorted(p for p in path.rglob("*") if p.is_file() and p.stat().st_size > 0)
    for name in ("zarr.json", ".npz", ".txt"):
        for p in files:
            if p.name == name or p.name.endswith(name):
                return p
    return files[0]


@pytest.mark.parametrize("fmt", sorted(WRITERS))
def test_random_corruptions_give_one_line_errors(fmt):
    @settings(max_examples=16, **SETTINGS)
    @given(
        truth=truths(),
        how=st.sampled_from(["truncate", "overwrite", "insert"]),
        at=st.floats(0.0, 1.0),
        length=st.integers(1, 64),
        junk=st.binary(min_size=64, max_size=64),
    )
    def check(truth, how, at, length, junk):
        with _workdir() as d:
            path, kwargs, _ = WRITERS[fmt](d, truth)
            target = _target(path)
            target.write_bytes(_corrupt(target.read_bytes(), how, at, length, junk))
            err = io.StringIO()
            ignored: list[Any] = []  # exceptions raised in destructors ("Exception ignored")
            hook = sys.unraisablehook
            sys.unraisablehook = ignored.append
            try:
                with _no_hang(), contextlib.redirect_stderr(err), warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    try:
                        ds = _read(path, kwargs)
                    except ThermoswarmError as exc:
                        msg = str(exc)
                        assert msg and "\n" not in msg and "Traceback" not in msg
                    else:  # a corruption the format cannot see: the result is still valid
                        assert np.isfinite(ds["position"].values).any()
                    gc.collect()
            finally:
                sys.unraisablehook = hook
            assert "Traceback" not in err.getvalue(), err.getvalue()
            assert not ignored, [f"{u.exc_type.__name__}: {u.exc_value}" for u in ignored]

    check()
