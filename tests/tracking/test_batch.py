"""``thermoswarm track`` over many videos (a lab's batch) and ``analyze`` of the batch
folder: three tiny generated videos, one corrupt, on a 2-worker local pool and on a Dask
LocalCluster; a re-run does no work; a changed video or changed options re-track."""

from __future__ import annotations

import json
import os
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from click.testing import CliRunner
from tracking_fixtures import small_video

from thermoswarm.cli import cli
from thermoswarm.errors import InputError
from thermoswarm.tracking.batch import expand_batch_dirs, find_videos, track_batch
from thermoswarm.tracking.synth.clip import write_video

#: Options of every batch run here: the paper's scale, no overlay (fast, small).
TRACK = ["--px-per-mm", "paper", "--no-overlay", "--quiet"]
OPTIONS = {"px_per_mm": 3.04, "overlay": False}


@pytest.fixture(scope="module")
def videos(tmp_path_factory) -> Path:
    """ants_a.mp4 and ants_b.mp4 (8 ants, 40 frames, 480x200) and broken.mp4 (not a video)."""
    folder = tmp_path_factory.mktemp("videos")
    for name, seed in (("ants_a", 1), ("ants_b", 2)):
        v = small_video(seed, n_frames=40)
        write_video(v.frames(), folder / f"{name}.mp4", v.config.fps)
    (folder / "broken.mp4").write_bytes(b"\x00\x00\x00\x18ftypmp42 this is not a video" * 8)
    return folder


def _markers(out: Path) -> dict[str, int]:
    return {p.parent.name + "/" + p.name: p.stat().st_mtime_ns for p in out.glob("*/*.json")}


def _batch_twice(videos: Path, out: Path, *where: str) -> None:
    """Track the folder twice with ``where`` (executor options); check both runs."""
    runner = CliRunner()
    res = runner.invoke(cli, ["track", str(videos), "--out", str(out), *TRACK, *where])
    assert res.exit_code == 1, res.output
    errors = res.stderr.splitlines()
    broken = str(videos / "broken.mp4")
    assert len(errors) == 1 and errors[0].startswith(f"error: {broken}: ")
    assert errors[0].count(broken) == 1  # the video named once
    summary = json.loads((out / "batch.json").read_text())
    assert summary["counts"] == {
        "videos": 3, "done": 2, "skipped": 0, "failed": 1, "tracked": 2
    }  # fmt: skip
    by_name = {Path(r["out"]).name: r for r in summary["videos"]}
    assert by_name["broken"]["status"] == "failed"
    assert errors[0] == f"error: {by_name['broken']['error']}"
    assert "cannot open as a video" in errors[0]
    for name in ("ants_a", "ants_b"):
        rec = by_name[name]
        assert rec["status"] == "done" and rec["n_frames"] == 40 and rec["n_tracks"] >= 8
        assert (out / name / "tracks.nc").is_file() and (out / name / "done.json").is_file()
    assert not (out / "broken" / "done.json").exists()
    before = _markers(out)
    assert set(before) == {"ants_a/done.json", "ants_b/done.json", "ants_a/summary.json",
                           "ants_b/summary.json", "broken/failed.json"}  # fmt: skip

    # the re-run does no work: nothing tracked, no file rewritten, the error repeated
    res = runner.invoke(cli, ["track", str(videos), "--out", str(out), *TRACK, *where])
    assert res.exit_code == 1, res.output
    assert res.stderr.splitlines() == errors
    again = json.loads((out / "batch.json").read_text())
    assert again["counts"] == {
        "videos": 3, "done": 0, "skipped": 2, "failed": 1, "tracked": 0
    }  # fmt: skip
    assert _markers(out) == before


def test_batch_on_a_two_worker_local_pool(videos, tmp_path):
    _batch_twice(videos, tmp_path / "batch", "--workers", "2")


def test_batch_on_a_dask_local_cluster(videos, tmp_path):
    pytest.importorskip("distributed")
    _batch_twice(videos, tmp_path / "batch", "--cluster", "local:2")


def test_analyze_reads_the_batch_folder_as_one_study(videos, tmp_path):
    out = tmp_path / "batch"
    track_batch([videos], out, OPTIONS, ThreadPoolExecutor(2))
    assert expand_batch_dirs([out]) == [out / "ants_a" / "tracks.nc", out / "ants_b" / "tracks.nc"]
    res = CliRunner().invoke(
        cli, ["analyze", str(out), "--out", str(tmp_path / "an"), "--bootstrap", "0", "-q"]
    )
    assert res.exit_code == 0, res.output
    import xarray as xr

    with xr.open_dataset(tmp_path / "an" / "kinematics.nc") as kin:
        recordings = {str(n).split(":")[0] for n in kin["individuals"].values}
    assert recordings == {"ants_a", "ants_b"}  # each video's ants, named after it
    fits = json.loads((tmp_path / "an" / "fits.json").read_text())
    per_video = [json.loads((out / n / "done.json").read_text()) for n in ("ants_a", "ants_b")]
    assert fits["n_tracks"] <= sum(v["n_tracks"] for v in per_video)


def test_a_changed_video_or_changed_options_are_tracked_again(videos, tmp_path):
    src = tmp_path / "videos"
    src.mkdir()
    for name in ("ants_a.mp4", "ants_b.mp4"):
        (src / name).write_bytes((videos / name).read_bytes())
    out = tmp_path / "batch"
    with ThreadPoolExecutor(2) as ex:
        first = track_batch([src], out, OPTIONS, ex)
        assert [r.status for r in first] == ["done", "done"]
        st = (src / "ants_b.mp4").stat()
        os.utime(src / "ants_b.mp4", ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
        assert [r.status for r in track_batch([src], out, OPTIONS, ex)] == ["skipped", "done"]
        changed = {**OPTIONS, "tracker": {"max_gap_s": 0.25}}
        assert [r.status for r in track_batch([src], out, changed, ex)] == ["done", "done"]
        assert [r.status for r in track_batch([src], out, changed, ex)] == ["skipped"] * 2


def test_a_recorded_input_error_is_retried_on_request(videos, tmp_path):
    out = tmp_path / "batch"
    with ThreadPoolExecutor(1) as ex:
        track_batch([videos / "broken.mp4", videos / "ants_a.mp4"], out, OPTIONS, ex)
        seen = []
        again = track_batch([videos / "broken.mp4"], out, OPTIONS, ex, on_failure=seen.append)
        assert again[0].attempts == 0 and again[0].status == "failed" and seen == again
        retried = track_batch([videos / "broken.mp4"], out, OPTIONS, ex, retry_failed=True)
        assert retried[0].attempts == 1 and retried[0].error == again[0].error


def test_find_videos_reads_list_files_and_folders(videos, tmp_path):
    lst = tmp_path / "videos.txt"
    rel = os.path.relpath(videos / "ants_b.mp4", tmp_path)
    lst.write_text(f"# the lab's list\n{rel}\n\n{videos / 'ants_a.mp4'}\n")
    assert find_videos([lst, videos / "ants_b.mp4"]) == [
        videos / "ants_b.mp4",
        videos / "ants_a.mp4",
    ]
    assert find_videos([videos]) == sorted(videos.glob("*.mp4"))
    lst.write_text("ants_a.mp4\nmissing.mp4\n")
    with pytest.raises(InputError, match=r"videos.txt: entry 1 .*ants_a.mp4.*no such file"):
        find_videos([lst])


def test_same_stems_get_distinct_folders(videos, tmp_path):
    other = tmp_path / "other"
    other.mkdir()
    (other / "ants_a.mp4").write_bytes((videos / "ants_a.mp4").read_bytes())
    recs = track_batch([videos / "ants_a.mp4", other / "ants_a.mp4"], tmp_path / "b",
                       OPTIONS, ThreadPoolExecutor(2))  # fmt: skip
    names = [Path(r.out).name for r in recs]
    assert len(set(names)) == 2 and all(n.startswith("ants_a-") for n in names)
    assert [r.status for r in recs] == ["done", "done"]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--workers", "2"], "--workers, --scheduler, --cluster and --retry-failed apply to "
         "many videos (several paths, a folder of videos or a list file)"),
        (["--cluster", "local:0", "MORE"], "--cluster 'local:0': expected local:N with N >= 1 "
         "workers"),
        (["--cluster", "local:2", "--workers", "2", "MORE"],
         "--workers is for local processes; Dask brings its own workers"),
    ],
)  # fmt: skip
def test_batch_usage_errors_are_one_line(videos, tmp_path, args, message):
    paths = [str(videos / "ants_a.mp4")]
    if "MORE" in args:
        args = [a for a in args if a != "MORE"]
        paths.append(str(videos / "ants_b.mp4"))
    res = CliRunner().invoke(cli, ["track", *paths, "--out", str(tmp_path / "o"), *args])
    assert res.exit_code == 2
    assert res.stderr == f"error: {message}\n"
    assert not (tmp_path / "o").exists()
