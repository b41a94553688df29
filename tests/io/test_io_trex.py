"""TRex reader: per-individual .npz files written with numpy as TRex lays them out."""

from __future__ import annotations

import numpy as np
import pytest
from io_truth import SCALE, Truth, assert_tracks

from thermoswarm.errors import InputError
from thermoswarm.io import detect_format, read_tracks

CM_PER_PX = 0.0125
FRAME_RATE = 20.0


def _export(folder, truth: Truth, *, with_meta: bool = True, start: int = 3) -> list:
    """One npz per individual; frames start at ``start``; missing -> inf + missing=1."""
    c = truth.centroid_only()
    paths = []
    frames = np.arange(start, start + truth.n_t)
    for i in range(len(truth.individuals)):
        x = c.px[:, 0, 0, i] * CM_PER_PX
        y = c.px[:, 1, 0, i] * CM_PER_PX
        missing = np.isnan(x).astype(np.float32)
        data = {
            "X#wcentroid": np.where(missing == 1, np.inf, x),
            "Y#wcentroid": np.where(missing == 1, np.inf, y),
            "X": np.where(missing == 1, np.inf, x + 1.0),  # head, elsewhere
            "Y": np.where(missing == 1, np.inf, y + 1.0),
            "frame": frames.astype(np.int64),
            "time": frames / FRAME_RATE,
            "missing": missing,
            "SPEED#wcentroid": np.zeros(truth.n_t),
        }
        if with_meta:
            data["cm_per_pixel"] = np.array([CM_PER_PX])
            data["frame_rate"] = np.array([FRAME_RATE])
        path = folder / f"video_fish{i}.npz"
        np.savez(path, **data)
        paths.append(path)
    (folder / "video_posture_fish0.npz").write_bytes(b"not a trex export")
    return paths


def test_folder_in_cm(tmp_path, truth):
    _export(tmp_path, truth)
    assert detect_format(tmp_path) == "trex"
    ds = read_tracks(tmp_path)
    c = truth.centroid_only()
    times = np.arange(3, 3 + truth.n_t) / FRAME_RATE
    assert_tracks(ds, c.px * CM_PER_PX * 10.0, times, ["fish0", "fish1"], ["wcentroid"])
    assert ds.attrs["trex_cm_per_pixel"] == CM_PER_PX
    assert ds.attrs["fps"] == FRAME_RATE
    assert ds.attrs["unit_conversion"] == "mm = cm * 10"


def test_own_calibration_undoes_trex_scale(tmp_path, truth):
    _export(tmp_path, truth)
    ds = read_tracks(tmp_path, px_per_mm="paper")
    c = truth.centroid_only()
    times = np.arange(3, 3 + truth.n_t) / FRAME_RATE
    assert_tracks(ds, c.mm, times, ["fish0", "fish1"], ["wcentroid"])
    assert ds.attrs["px_per_mm"] == SCALE


def test_single_file_and_head_source(tmp_path, truth):
    paths = _export(tmp_path, truth)
    assert detect_format(paths[1]) == "trex"
    ds = read_tracks(paths[1], source="head")
    c = truth.centroid_only()
    expect = (c.px[..., 1:] * CM_PER_PX + 1.0) * 10.0
    times = np.arange(3, 3 + truth.n_t) / FRAME_RATE
    assert_tracks(ds, expect, times, ["fish1"], ["head"])


def test_px_per_mm_without_recorded_scale(tmp_path, truth):
    _export(tmp_path, truth, with_meta=False)
    with pytest.raises(InputError, match="cm_per_pixel"):
        read_tracks(tmp_path, px_per_mm=SCALE)
    ds = read_tracks(tmp_path, px_per_mm=SCALE, cm_per_pixel=CM_PER_PX)
    np.testing.assert_allclose(ds.position.values, truth.centroid_only().mm, rtol=1e-12)


def test_fps_overrides_time(tmp_path, truth):
    _export(tmp_path, truth, with_meta=False)
    ds = read_tracks(tmp_path, fps=10.0)
    np.testing.assert_allclose(ds.time.values, np.arange(3, 3 + truth.n_t) / 10.0)


def test_unknown_source_and_option(tmp_path, truth):
    _export(tmp_path, truth)
    with pytest.raises(InputError, match="source must be one of"):
        read_tracks(tmp_path, source="tail")
    with pytest.raises(InputError, match=r"unknown option\(s\) bogus.*accepts: cm_per_pixel"):
        read_tracks(tmp_path, bogus=1)


def test_missing_position_field(tmp_path):
    path = tmp_path / "v_id0.npz"
    np.savez(path, frame=np.arange(3), time=np.arange(3) / 10, X=np.zeros(3), Y=np.zeros(3))
    with pytest.raises(InputError, match=r"v_id0\.npz.*'X#wcentroid'.*source"):
        read_tracks(path)


def test_mismatched_lengths(tmp_path):
    path = tmp_path / "v_id0.npz"
    np.savez(
        path,
        frame=np.arange(3),
        time=np.arange(3) / 10.0,
        **{"X#wcentroid": np.zeros(4), "Y#wcentroid": np.zeros(3)},
    )
    with pytest.raises(InputError, match=r"v_id0\.npz.*different lengths"):
        read_tracks(path)


def test_pickled_npz_refused(tmp_path):
    path = tmp_path / "v_id0.npz"
    np.savez(
        path,
        frame=np.arange(2),
        time=np.arange(2.0),
        **{"X#wcentroid": np.array([{"a": 1}, None], dtype=object), "Y#wcentroid": np.zeros(2)},
    )
    with pytest.raises(InputError, match=r"v_id0\.npz.*pickled"):
        read_tracks(path)


def test_truncated_npz(tmp_path, truth):
    paths = _export(tmp_path, truth)
    bad = tmp_path / "one" / "v_id0.npz"
    bad.parent.mkdir()
    bad.write_bytes(paths[0].read_bytes()[:100])
    with pytest.raises(InputError, match=r"v_id0\.npz"):
        read_tracks(bad, format="trex")


def test_two_videos_in_one_folder_use_full_stems(tmp_path, truth):
    paths = _export(tmp_path, truth)
    paths[1].rename(tmp_path / "other_fish0.npz")
    ds = read_tracks(tmp_path)
    assert list(ds.individuals.values) == ["other_fish0", "video_fish0"]


def _eight(folder, rng) -> list:
    """Eight individuals' exports, frames 0..29."""
    paths = []
    for i in range(8):
        frames = np.arange(30)
        data = {"X#wcentroid": rng.normal(0, 5, 30), "Y#wcentroid": rng.normal(0, 5, 30),
                "frame": frames, "time": frames / FRAME_RATE, "missing": np.zeros(30)}  # fmt: skip
        np.savez(folder / f"video_fish{i}.npz", **data)
        paths.append(folder / f"video_fish{i}.npz")
    return paths


@pytest.mark.parametrize("damage", ["truncated", "empty", "garbage"])
def test_a_damaged_npz_among_eight_is_named(tmp_path, rng, damage):
    """The reader once skipped zip errors silently: 7 individuals, no word of the 8th."""
    paths = _eight(tmp_path, rng)
    whole = paths[5].read_bytes()
    paths[5].write_bytes({"truncated": whole[: len(whole) // 2], "empty": b"",
                          "garbage": b"PK\x03\x04" + bytes(200)}[damage])  # fmt: skip
    with pytest.raises(InputError, match=r"1 of 8 TRex \.npz files are damaged.*video_fish5\.npz"):
        read_tracks(tmp_path, format="trex")
    ds = read_tracks(tmp_path, format="trex", pattern="video_fish[0-4].npz")
    assert ds.sizes["individuals"] == 5


def test_a_mislabelled_npz_among_eight_is_a_warning(tmp_path, rng):
    paths = _eight(tmp_path, rng)
    np.savez(paths[2], weights=np.zeros(3))  # a readable .npz, not a TRex export
    with pytest.warns(UserWarning, match=r"1 \.npz file\(s\) without TRex's arrays.*video_fish2"):
        ds = read_tracks(tmp_path, format="trex")
    assert ds.sizes["individuals"] == 7


def test_read_is_at_most_80_lines():
    import inspect

    from thermoswarm.io import trex

    assert len(inspect.getsource(trex.read).splitlines()) <= 80
