"""The viewer's data layer: frames, variables, geometry, growing stores, bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

from thermoswarm import scenarios
from thermoswarm.cli import main
from thermoswarm.errors import InputError
from thermoswarm.tracks import make_tracks
from thermoswarm.view.data import from_dataset
from thermoswarm.view.page import write_html
from thermoswarm.view.source import open_source
from thermoswarm.view.track_output import track_events


def _decode(data, k, var):
    raw = np.frombuffer(data.frame_bytes(k, var), dtype="<f4")
    K, n = len(data.keypoints), data.n
    return raw[: K * 2 * n].reshape(K, 2, n), raw[K * 2 * n :]


def test_run_folder_frames_match_the_file(small_run):
    data = open_source(small_run)
    nc = xr.open_dataset(small_run / "tracks.nc", engine="h5netcdf")
    assert data.kind == "run" and data.complete
    assert (data.n, data.n_frames) == (nc.sizes["individuals"], nc.sizes["time"])
    for k in (0, 7, data.n_frames - 1):
        pos, speed = _decode(data, k, "speed")
        want = nc["position"].isel(time=k).transpose("keypoints", "space", "individuals")
        np.testing.assert_allclose(pos, want.values.astype("f4"), rtol=0, atol=0)
        np.testing.assert_allclose(speed, nc["speed"].isel(time=k).values, rtol=1e-6)
        _, energy = _decode(data, k, "energy")
        np.testing.assert_allclose(energy, 0.5 * speed.astype(float) ** 2, rtol=1e-5)
    nc.close()


def test_run_geometry_and_variables(small_run):
    meta = open_source(small_run).meta()
    geo = meta["geometry"]
    assert geo["scenario"] == "transport-free"
    assert len(geo["walls"]) == 4 and len(geo["bodies"]) == 1
    assert geo["light"]["kind"] == "directional"
    assert len(meta["per_frame"]["object_position"]) == meta["n_frames"]
    by_name = {v["name"]: v for v in meta["variables"]}
    assert by_name["speed"]["units"] == "mm/s"
    assert by_name["energy"]["units"] == "mm^2/s^2"
    assert by_name["phase"]["kind"] == "categorical"
    temps = {c["value"] for c in by_name["temperature"]["categories"]}
    assert temps <= {geo["kT"]["hot"], geo["kT"]["cold"]} and temps
    json.dumps(meta)  # JSON-able


def test_speed_derived_from_positions_when_not_recorded(rng):
    T, n, fps = 6, 3, 4.0
    steps = rng.normal(0, 2.0, (T, 2, n))
    ds = make_tracks(np.cumsum(steps, axis=0), fps=fps)
    data = from_dataset(ds, "synthetic")
    assert data.kind == "tracks" and "speed" in data.variables()
    for k in range(T):
        j = k if k + 1 < T else k - 1
        want = np.hypot(*steps[j + 1]) * fps
        np.testing.assert_allclose(data.values(k, "speed"), want, rtol=1e-12)
    series = data.series(1)
    np.testing.assert_allclose(series["speed"][:-1], np.hypot(*steps[1:, :, 1].T) * fps)
    np.testing.assert_allclose(series["energy"], 0.5 * np.asarray(series["speed"]) ** 2)


def _growing_store(path, *, n=5, frames=10, block=2, commit=2):
    from thermoswarm.sim.recorder import ZarrRecorder

    rec = ZarrRecorder(path, n=n, n_frames=frames, block=block, attrs={"fps": 2.0})
    for f in range(commit * block):
        pos = np.c_[np.arange(n) + f, np.arange(n) * 2.0]
        if rec.add(f * 0.5, pos, {"heading": np.zeros(n), "speed": np.full(n, 2.0)}):
            rec.flush()
    return rec


def test_zarr_being_written_shows_committed_frames_and_grows(tmp_path):
    store = tmp_path / "tracks.zarr"
    rec = _growing_store(store)
    data = open_source(store)
    assert data.n_frames == 4 and not data.complete
    notes = " ".join(data.meta()["notes"])
    assert "still being written" in notes and "4 committed" in notes
    for f in range(4, 6):
        rec.add(f * 0.5, np.c_[np.arange(5.0) + f, np.zeros(5)], {"heading": np.zeros(5),
                "speed": np.full(5, 2.0)})  # fmt: skip
    rec.flush()
    assert data.meta()["n_frames"] == 6
    pos, _ = _decode(data, 5, None)
    np.testing.assert_array_equal(pos[0, 0], np.arange(5.0) + 5)


def test_zarr_with_nothing_committed_is_one_line_error(tmp_path):
    _growing_store(tmp_path / "tracks.zarr", commit=0)
    with pytest.raises(InputError, match="no committed frames yet"):
        open_source(tmp_path / "tracks.zarr")


@pytest.mark.parametrize("content", ["hello, not a trajectory\n1,2\n", ""])
def test_not_a_trajectory_is_one_line_error(tmp_path, capsys, content):
    bad = tmp_path / "notes.csv"
    bad.write_text(content)
    with pytest.raises(SystemExit) as exc:
        main(["view", str(bad), "--no-browser"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1 and "notes.csv" in err


def test_missing_path_is_one_line_error(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["view", str(tmp_path / "nothing.nc"), "--no-browser"])
    assert exc.value.code == 2
    assert capsys.readouterr().err.strip().endswith("no such file or directory")


def test_track_events_lost_new_and_switch():
    T = 10
    centre = np.full((T, 2, 3), np.nan)
    centre[:, :, 0] = [5.0, 5.0]  # whole video
    centre[:4, :, 1] = [50.0, 50.0]  # lost at 3
    centre[5:, :, 2] = [52.0, 50.0]  # new at 5, 2 px away: a possible switch
    ev = track_events(centre, max_gap=3, near=10.0, ids=["a", "b", "c"])
    got = [(e["frame"], e["kind"], e["id"]) for e in ev]
    assert got == [(3, "lost", "b"), (5, "switch?", "c")]
    far = track_events(centre, max_gap=3, near=1.0, ids=["a", "b", "c"])
    assert far[1]["kind"] == "new"


def test_track_output_in_video_pixels(track_output):
    data = open_source(track_output["out"])
    assert data.kind == "track" and data.video is not None
    assert data.video.size == (96, 64)
    pos, _ = _decode(data, 3, "speed")
    np.testing.assert_allclose(pos[1], track_output["body"][3], atol=1e-4)  # body, px
    kinds = [(e["frame"], e["kind"], e["id"]) for e in data.events]
    assert kinds == [(5, "lost", "track_2"), (7, "switch?", "track_3")]
    assert data.boxes_at(0)[0] == [0.0, 35.0, 37.0, 10.0, 6.0]
    jpeg = data.video.jpeg(4)
    assert jpeg[:2] == b"\xff\xd8"


def test_track_output_without_its_video_says_so(track_output, tmp_path):
    import shutil

    shutil.rmtree(track_output["video"])
    meta = open_source(track_output["out"]).meta()
    assert meta["video"] is None
    assert any("source video" in n and "not found" in n for n in meta["notes"])


def test_self_contained_html(small_run, tmp_path):
    out = write_html(open_source(small_run), tmp_path / "run.html")
    text = out.read_text()
    assert "window.__EMBED__" in text and "__SCRIPT__" not in text
    assert "<script src" not in text and "https://" not in text and "http://" not in text
    head = text.index("window.__EMBED__ = ") + len("window.__EMBED__ = ")
    embed = json.loads(text[head : text.index(";</script>", head)])
    assert len(embed["pos"]) == embed["meta"]["n_frames"]
    with pytest.raises(InputError, match="too many for one HTML"):
        write_html(open_source(small_run), tmp_path / "big.html", max_bytes=1000)


@pytest.mark.parametrize("name", scenarios.names())
def test_every_scenario_geometry_is_drawable(name):
    """The world of each scenario, rebuilt from a run's config, as the page draws it."""
    from thermoswarm.scenarios import runner
    from thermoswarm.view.data import scenario_geometry

    cfg = runner.resolve(name, seed=3)
    _, setup, _, _ = runner.build(cfg)
    geo = scenario_geometry(cfg.to_toml(), "config.toml")
    assert geo["scenario"] == name
    assert geo["bounds"] == list(setup.world.bounds)
    np.testing.assert_array_equal(np.reshape(geo["walls"], (-1, 4)), setup.world.segments)
    assert len(geo["bodies"]) == len(setup.world.bodies)
    assert len(geo["pistons"]) == len(setup.world.pistons)
    json.dumps(geo, allow_nan=False)


def test_regions_file_gives_a_region_variable(tmp_path):
    pos = np.zeros((2, 2, 3))
    pos[:, 0] = [[10.0, 70.0, 500.0], [15.0, 80.0, 500.0]]  # x: wide, narrow, outside
    pos[:, 1] = 20.0
    from thermoswarm.io.netcdf import write as write_nc

    write_nc(make_tracks(pos, fps=1.0), tmp_path / "t.nc")
    (tmp_path / "road.toml").write_text(
        '[[region]]\nname = "wide"\nrect = [0, 0, 60, 40]\n'
        '[[region]]\nname = "narrow"\nrect = [60, 10, 100, 30]\n'
    )
    data = open_source(tmp_path / "t.nc", regions=tmp_path / "road.toml")
    np.testing.assert_array_equal(data.values(0, "region"), [0, 1, -1])
    info = data.var_info("region")
    assert info["kind"] == "categorical"
    assert [c["label"] for c in info["categories"]] == ["outside", "wide", "narrow"]
    assert [r["name"] for r in data.meta()["regions"]] == ["wide", "narrow"]
