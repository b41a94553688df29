"""The fuzz findings of issue 22, each as a property the readers keep.

Every bad input found by fuzzing is either one line (an :class:`InputError`, CLI exit
status 2) or a counted exclusion in ``attrs``; none allocates what the file merely
declares, and none gives a silently wrong result.  Hypothesis draws the bad values
(``derandomize``: the same examples every run).  Sizes are tested against a lowered
:data:`thermoswarm.io._common.MAX_CELLS` so that no example allocates much either way.
"""

from __future__ import annotations

import itertools
import warnings
from pathlib import Path

import h5py
import numpy as np
import pandas as pd
import pytest
import sleap_io as sio  # part of the [io] extra: a missing one must fail, not skip
from click.testing import CliRunner
from hypothesis import HealthCheck, Phase, assume, given, settings
from hypothesis import strategies as st

from thermoswarm.analysis.kinematics import compute_kinematics, data_quality
from thermoswarm.cli import cli
from thermoswarm.errors import InputError
from thermoswarm.io import _common, read_tracks
from thermoswarm.tracks import make_tracks

# the limits, named so that this module also imports (and fails) on code without them
FPS_RANGE = getattr(_common, "FPS_RANGE", (1e-6, 1e7))
MAX_ABS_MM = getattr(_common, "MAX_ABS_MM", 1e12)

SETTINGS = dict(
    deadline=None,
    derandomize=True,
    database=None,
    max_examples=25,
    # no shrinking: on code without the checks a failing example must not lead the
    # shrinker to sizes that allocate
    phases=[Phase.explicit, Phase.generate],
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)


_EXAMPLE = itertools.count()


def _fresh(tmp_path: Path, tag: object) -> Path:
    """A new folder for each example (hypothesis may draw one example twice)."""
    d = tmp_path / f"ex{next(_EXAMPLE)}"
    d.mkdir()
    return d


# --------------------------------------------------------------------------- SLEAP .slp


def _slp(path: Path, frame_idxs, values=None) -> Path:
    skeleton = sio.Skeleton(nodes=["head", "tail"])
    video = sio.Video(filename="ants.mp4", open_backend=False)
    track = sio.Track(name="ant")
    frames = []
    for j, f in enumerate(frame_idxs):
        pts = np.array([[10.0 + j, 20.0], [30.0, 40.0]]) if values is None else values[j]
        inst = sio.PredictedInstance.from_numpy(
            points_data=pts, skeleton=skeleton, point_scores=np.ones(2), score=0.9, track=track
        )
        frames.append(sio.LabeledFrame(video=video, frame_idx=int(f), instances=[inst]))
    labels = sio.Labels(
        labeled_frames=frames, videos=[video], skeletons=[skeleton], tracks=[track]
    )
    sio.save_slp(labels, str(path))
    return path


@settings(**SETTINGS)
@given(
    far=st.one_of(st.integers(1001, 10**5), st.integers(10**11, 10**12)),
    n_near=st.integers(1, 4),
)
def test_slp_frame_idx_spanning_too_many_frames_is_one_line(tmp_path, monkeypatch, far, n_near):
    # one frame_idx of 1e11 made sleap-io allocate 8.7 TiB; with the limit lowered to
    # 1,000 frames no example allocates much, whatever the code does
    monkeypatch.setattr(_common, "MAX_FRAMES", 1000, raising=False)
    path = _slp(_fresh(tmp_path, (far, n_near)) / "far.slp", [*range(n_near), far])
    with pytest.raises(InputError, match=r"far\.slp: frame_idx 0 to \d+ span .* accepted"):
        read_tracks(path, fps=1.0, px_per_mm="paper")


@settings(**SETTINGS)
@given(
    frames=st.lists(st.integers(0, 50), min_size=2, max_size=8, unique=True),
    which=st.integers(0, 7),
)
def test_slp_two_frames_with_one_frame_idx_are_refused(tmp_path, frames, which):
    again = frames[which % len(frames)]
    path = _slp(_fresh(tmp_path, (tuple(frames), which)) / "dup.slp", [*frames, again])
    with pytest.raises(InputError, match=rf"dup\.slp: frame_idx {again} appears 2 times"):
        read_tracks(path, fps=1.0, px_per_mm=1.0)


@settings(**SETTINGS)
@given(start=st.integers(0, 1000), n=st.integers(2, 6))
def test_slp_times_count_from_frame_zero_of_the_video(tmp_path, start, n):
    path = _slp(_fresh(tmp_path, (start, n)) / "late.slp", range(start, start + n))
    ds = read_tracks(path, fps=4.0, px_per_mm=1.0)
    np.testing.assert_allclose(ds["time"].values, np.arange(start, start + n) / 4.0)


@settings(**SETTINGS)
@given(
    big=st.lists(
        st.one_of(st.floats(MAX_ABS_MM * 1.01, 1.7e308), st.floats(-1.7e308, -MAX_ABS_MM * 1.01)),
        min_size=1,
        max_size=3,
    )
)
def test_slp_positions_beyond_float32_are_counted_non_finite(tmp_path, big):
    # sleap-io's float32 array overflowed to inf with a RuntimeWarning, uncounted
    n = 5
    values = [np.array([[10.0 + j, 20.0], [30.0, 40.0]]) for j in range(n)]
    for j, v in enumerate(big):
        values[j][0, 1] = v  # the head's y in frame j
    path = _slp(_fresh(tmp_path, tuple(big)) / "huge.slp", range(n), values)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no overflow warning reaches the user
        ds = read_tracks(path, fps=1.0, px_per_mm=1.0)
    assert ds.attrs["n_nonfinite_positions"] == len(big)
    head = ds["position"].sel(keypoints="head", individuals="ant").values
    assert np.isnan(head[: len(big)]).all() and np.isfinite(head[len(big) :]).all()


def test_cli_slp_far_frame_is_exit_2_one_line(tmp_path):
    src = _slp(tmp_path / "far.slp", [0, 1, 10**11])
    res = CliRunner().invoke(
        cli, ["convert", str(src), str(tmp_path / "o.nc"), "--fps", "1", "--px-per-mm", "paper"]
    )
    assert res.exit_code == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {src}: frame_idx"), res.stderr
    assert not (tmp_path / "o.nc").exists()


# --------------------------------------------------------------------------- HDF5 sizes


@settings(**SETTINGS)
@given(
    n_tracks=st.integers(1, 40),
    n_nodes=st.integers(1, 5),
    n_frames=st.integers(1, 400),
)
def test_hdf5_datasets_are_refused_by_declared_size_before_reading(
    tmp_path, monkeypatch, n_tracks, n_nodes, n_frames
):
    # a SLEAP analysis .h5 declaring 2e10 values was read before its size was checked;
    # here the limit is lowered to 1,000 values so no example allocates much
    monkeypatch.setattr(_common, "MAX_CELLS", 1000)
    shape = (n_tracks, 2, n_nodes, n_frames)
    path = _fresh(tmp_path, shape) / "big.analysis.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("tracks", shape=shape, dtype="f4", fillvalue=1.0, chunks=True)
        f["node_names"] = np.array([f"n{k}".encode() for k in range(n_nodes)])
    size = int(np.prod(shape))
    if size > 1000:
        with pytest.raises(InputError, match=rf"'tracks' declares shape .*{size:,} values"):
            read_tracks(path, fps=1.0, px_per_mm=1.0, format="sleap")
    else:
        ds = read_tracks(path, fps=1.0, px_per_mm=1.0, format="sleap")
        assert ds.sizes["time"] == n_frames and ds.sizes["individuals"] == n_tracks


# --------------------------------------------------------------------------- MOT


def _mot_rows(n_frames: int, n_ids: int) -> list[list[float]]:
    return [[f, i, 10.0 * i, 5.0 * f, 4.0, 6.0, 1.0] for f in range(1, n_frames + 1)
            for i in range(1, n_ids + 1)]  # fmt: skip


def _write_mot(path: Path, rows) -> Path:
    path.write_text("".join(",".join(f"{v:g}" for v in r) + "\n" for r in rows))
    return path


@settings(**SETTINGS)
@given(
    n_frames=st.integers(2, 8),
    n_ids=st.integers(1, 4),
    pick=st.integers(0, 10**6),
    shift=st.integers(1, 50),
)
def test_mot_conflicting_rows_are_refused_and_exact_ones_counted(
    tmp_path, n_frames, n_ids, pick, shift
):
    rows = _mot_rows(n_frames, n_ids)
    row = rows[pick % len(rows)]
    d = _fresh(tmp_path, (n_frames, n_ids, pick, shift))
    other = [*row[:2], row[2] + shift, *row[3:]]  # same frame and id, another box
    bad = _write_mot(d / "conflict.txt", [*rows, other])
    with pytest.raises(InputError, match=rf"individual 'id_{row[1]:g}' at frame {row[0]:g}"):
        read_tracks(bad, fps=10.0, px_per_mm=1.0, format="mot")
    # the first box, or the mean, when asked; the conflict counted either way
    ds = read_tracks(bad, fps=10.0, px_per_mm=1.0, format="mot", duplicates="first")
    assert ds.attrs["n_conflicting_duplicates"] == 1
    x = ds["position"].sel(individuals=f"id_{row[1]:g}", space="x").values[:, 0]
    assert x[int(row[0]) - 1] == pytest.approx(row[2] + 2.0)  # box centre, the first box
    same = read_tracks(
        _write_mot(d / "exact.txt", [*rows, row]), fps=10.0, px_per_mm=1.0, format="mot"
    )
    assert same.attrs["n_duplicate_rows"] == 1
    np.testing.assert_allclose(same["time"].values, np.arange(n_frames) / 10.0)


@settings(**SETTINGS)
@given(n_frames=st.integers(2, 6), frac=st.floats(0.01, 0.99), where=st.integers(0, 10**6))
def test_mot_fractional_ids_are_refused_naming_the_line(tmp_path, n_frames, frac, where):
    rows = _mot_rows(n_frames, 2)
    k = where % len(rows)
    rows[k] = [rows[k][0], rows[k][1] + frac, *rows[k][2:]]
    path = _write_mot(_fresh(tmp_path, (n_frames, frac, where)) / "frac.txt", rows)
    with pytest.raises(InputError, match=rf"frac\.txt:{k + 1}: id .* is not an integer"):
        read_tracks(path, fps=10.0, px_per_mm=1.0, format="mot")


# --------------------------------------------------------------------------- frame rates

#: Positive frame rates no recording has: tiny to subnormal, and huge.
TINY_OR_HUGE_FPS = st.one_of(
    st.sampled_from([1e-300, 5e-324, 1e300]),
    st.floats(1e-300, FPS_RANGE[0] / 1.01),
    st.floats(FPS_RANGE[1] * 1.01, 1e300),
)
#: And zero, negative, infinite.
BAD_FPS = st.one_of(TINY_OR_HUGE_FPS, st.sampled_from([0.0, -1.0, float("inf")]))


def _idtracker_h5(d: Path, fps: float) -> tuple[Path, dict]:
    with h5py.File(d / "trajectories.h5", "w") as f:
        f["trajectories"] = np.arange(24, dtype=float).reshape(6, 2, 2)
        f.attrs["frames_per_second"] = fps
    return d / "trajectories.h5", {"format": "idtracker", "px_per_mm": 1.0}


def _trex_npz(d: Path, fps: float) -> tuple[Path, dict]:
    frames = np.arange(6)
    np.savez(d / "video_fish0.npz", frame=frames, time=frames / 10.0, frame_rate=fps,
             **{"X#wcentroid": frames * 1.0, "Y#wcentroid": frames * 2.0})  # fmt: skip
    return d / "video_fish0.npz", {"format": "trex"}


def _csv_header(d: Path, fps: float) -> tuple[Path, dict]:
    rows = "".join(f"a,{t},{t * 1.5},{t * 2.0}\n" for t in range(6))
    (d / "t.csv").write_text(f"# fps: {fps!r}\n# space_unit: mm\nid,frame,x,y\n{rows}")
    return d / "t.csv", {"format": "tidy_csv"}


def _text_header(d: Path, fps: float) -> tuple[Path, dict]:
    rows = "".join(f"{t} {t * 1.5} {t * 2.0}\n" for t in range(6))
    (d / "ant.txt").write_text(f"# fps: {fps!r}\n# space_unit: mm\n{rows}")
    return d / "ant.txt", {"format": "text"}


@pytest.mark.parametrize("writer", [_idtracker_h5, _trex_npz, _csv_header, _text_header])
@settings(**SETTINGS)
@given(fps=BAD_FPS)
def test_non_physical_frame_rate_in_a_file_is_one_line(tmp_path, writer, fps):
    # an idtracker.ai .h5 with frames_per_second = 1e-300 ran and skipped the fit
    assume(writer is not _trex_npz or np.isfinite(fps))  # TRex writes inf for "unknown"
    path, kw = writer(_fresh(tmp_path, (writer.__name__, fps)), fps)
    with pytest.raises(InputError, match=r"frame rate|fps"):
        read_tracks(path, **kw)


@settings(**SETTINGS)
@given(fps=TINY_OR_HUGE_FPS)
def test_non_physical_fps_option_is_one_line(tmp_path, fps):
    path, kw = _idtracker_h5(_fresh(tmp_path, fps), 25.0)
    with pytest.raises(InputError, match=r"--fps .* not a recording's frame rate"):
        read_tracks(path, fps=fps, **kw)


@settings(**SETTINGS)
@given(fps=st.floats(*FPS_RANGE))
def test_physical_frame_rates_are_read(tmp_path, fps):
    path, kw = _idtracker_h5(_fresh(tmp_path, fps), fps)
    ds = read_tracks(path, **kw)
    assert ds.attrs["fps"] == fps
    np.testing.assert_allclose(ds["time"].values, np.arange(6) / fps)


# --------------------------------------------------------------------------- big positions


@settings(**SETTINGS)
@given(
    big=st.lists(
        st.one_of(
            st.floats(MAX_ABS_MM * 1.01, 1.7e308),
            st.floats(-1.7e308, -MAX_ABS_MM * 1.01),
            st.just(float("inf")),
        ),
        min_size=1,
        max_size=4,
    )
)
def test_csv_positions_beyond_any_arena_are_counted_non_finite(tmp_path, big):
    # 1e308 mm overflowed the float32 kinematics output with a warning, not counted
    n = 12
    x = np.linspace(0.0, 50.0, n)
    x[1 : 1 + len(big)] = big
    d = _fresh(tmp_path, tuple(big))
    pd.DataFrame({"id": "a", "time": np.arange(n) / 2.0, "x": x, "y": 1.0}).to_csv(
        d / "t.csv", index=False
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ds = read_tracks(d / "t.csv", units="mm")
        kin = compute_kinematics(ds)
    assert ds.attrs["n_nonfinite_positions"] == len(big)
    assert data_quality(kin)["n_nonfinite_positions"] == len(big)
    assert np.isfinite(kin["speed"].values[np.isfinite(kin["speed"].values)]).all()
    assert float(np.nanmax(kin["speed"].values)) < 1e6


# --------------------------------------------------------------------------- names


@settings(**SETTINGS)
@given(
    names=st.lists(st.sampled_from(["ant", "a", "b", "c", "d"]), min_size=2, max_size=8).filter(
        lambda v: len(set(v)) < len(v)
    )
)
def test_netcdf_with_duplicate_individual_names_is_refused(tmp_path, names):
    # a netCDF whose 8 individuals share one name was analysed as 8 tracks
    n = len(names)
    ds = make_tracks(np.ones((4, 2, n)), fps=5.0)
    ds = ds.assign_coords(individuals=names)
    path = _fresh(tmp_path, tuple(names)) / "same.nc"
    ds.to_netcdf(path, engine="h5netcdf")
    dup = next(v for v in names if names.count(v) > 1)
    with pytest.raises(InputError, match=rf"same\.nc: individuals names must be unique.*'{dup}'"):
        read_tracks(path)


# --------------------------------------------------------------------------- DeepLabCut


@settings(**SETTINGS)
@given(n=st.integers(2, 10), again=st.integers(0, 10**6))
def test_dlc_rows_of_one_frame_are_refused(tmp_path, n, again):
    frames = list(range(n))
    frames.append(frames[again % n])
    cols = pd.MultiIndex.from_tuples(
        [("s", "head", c) for c in ("x", "y", "likelihood")],
        names=["scorer", "bodyparts", "coords"],
    )
    df = pd.DataFrame(np.ones((n + 1, 3)), index=frames, columns=cols)
    path = _fresh(tmp_path, (n, again)) / "predsDLC.csv"
    df.to_csv(path)
    with pytest.raises(InputError, match=rf"frame {again % n} appears 2 times"):
        read_tracks(path, fps=1.0, px_per_mm=1.0, format="dlc")


# --------------------------------------------------------------------------- siblings
# The same sizes declared by the other readers' containers: netCDF (HDF5), Zarr, the
# .npy/.npz of idtracker.ai and TRex, and TRex frame numbers spanning too many frames.


def _declared(d: Path, kind: str, n_frames: int) -> tuple[Path, dict]:
    if kind == "netcdf":
        ds = make_tracks(np.ones((n_frames, 2, 3)), fps=5.0)
        ds.to_netcdf(d / "t.nc", engine="h5netcdf")
        return d / "t.nc", {}
    if kind == "zarr":
        ds = make_tracks(np.ones((n_frames, 2, 3)), fps=5.0)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ds.to_zarr(d / "r.zarr", zarr_format=3, consolidated=False)
        return d / "r.zarr", {}
    if kind == "idtracker_npy":
        np.save(d / "trajectories.npy", np.ones((n_frames, 3, 2)))
        return d / "trajectories.npy", {"format": "idtracker", "px_per_mm": 1.0, "fps": 5.0}
    frames = np.arange(n_frames)
    # an array the reader does not use is loaded with the rest: its size counts too
    np.savez(d / "video_fish0.npz", frame=frames, time=frames / 10.0, frame_rate=10.0,
             midline=np.ones((n_frames, 6)),
             **{"X#wcentroid": frames * 1.0, "Y#wcentroid": frames * 1.0})  # fmt: skip
    return d / "video_fish0.npz", {"format": "trex"}


@pytest.mark.parametrize("kind", ["netcdf", "zarr", "idtracker_npy", "trex_npz"])
@settings(**SETTINGS)
@given(n_frames=st.integers(2, 400))
def test_declared_sizes_are_checked_by_every_container(tmp_path, monkeypatch, kind, n_frames):
    monkeypatch.setattr(_common, "MAX_CELLS", 600)
    path, kw = _declared(_fresh(tmp_path, (kind, n_frames)), kind, n_frames)
    if n_frames * 6 > 600:  # the largest array: 6 values a frame
        with pytest.raises(InputError, match=r"declares shape .* more than the 600"):
            read_tracks(path, **kw)
    else:
        assert read_tracks(path, **kw).sizes["time"] == n_frames


@settings(**SETTINGS)
@given(far=st.one_of(st.integers(1001, 10**5), st.integers(10**11, 10**12)))
def test_trex_frames_spanning_too_many_frames_are_refused(tmp_path, monkeypatch, far):
    monkeypatch.setattr(_common, "MAX_FRAMES", 1000, raising=False)
    frames = np.array([0, 1, 2, far])
    d = _fresh(tmp_path, far)
    np.savez(d / "video_fish0.npz", frame=frames, frame_rate=10.0, missing=np.zeros(4),
             **{"X#wcentroid": np.ones(4), "Y#wcentroid": np.ones(4)})  # fmt: skip
    with pytest.raises(InputError, match=r"frames 0 to \d+ span .* accepted"):
        read_tracks(d / "video_fish0.npz", format="trex")
