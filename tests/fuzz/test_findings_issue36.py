"""Each finding of issue 36 (hostile input to the verbs), as run by its reporter: a
one-line error (exit 2) naming the file, field or value, nothing half-written, or the
right result.  Every case here failed on e33dc8e (a traceback, a hang, a memory
blow-up, a silently wrong result or a file left behind)."""

from __future__ import annotations

import json
import os
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
from harness import assert_clean, outcome


def _error(argv, match: str, verb: str) -> str:
    import re

    res = outcome(argv)
    assert_clean(verb, res)
    assert res.kind == "error", str(res)
    assert re.search(match, res.err), res.err
    return res.err


# ------------------------------------------------------------------ analyze --config
@pytest.mark.parametrize(
    ("toml", "match"),
    [
        ("[test]\nn_bootstrap = 9223372036854775808", r"test\.n_bootstrap must be a 64-bit"),
        ("[test]\nn_bootstrap = 1000000000000", r"n_bootstrap must be an integer from 0 to"),
        ("[test]\nseed = -1", r"test\.seed must be an integer from 0 to 2\*\*63 - 1, got -1"),
        ("[clean]\nsmooth = 1e308", r"clean\.smooth must be at most 1e\+09 s"),
        ("[fit]\nenergy_bins = 1000000000", r"energy_bins must be from 1 to 10000"),
        ("[fit]\nenergy_bins = 1e29", r"energy_bins must be an integer or a list"),
        ('[fit]\ngroup_by = ["time:1e-300"]', r"'time:1e-300': the window must be"),
        ("[steps]\nmass = 1e308", r"steps\.mass must be at most 1e\+06 kg"),
        ("a = " + "[" * 3000 + "]" * 3000, r"nested too deeply"),
        ("[test]\nseed = " + "7" * 5000, r"a number too long to read"),
    ],
)
def test_analyze_config_limits(tmp_path, tracks_nc, toml, match):
    cfg = tmp_path / "c.toml"
    cfg.write_text(toml + "\n")
    _error(["analyze", tracks_nc, "--config", cfg, "--out", tmp_path / "res"], match, "analyze")
    assert not (tmp_path / "res").exists()


# ------------------------------------------------------------------ simulate --set
@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--set", "engine.dt=1e-300"], r"engine\.dt = 1e-300 is outside"),
        (["--set", "record.interval=1e308"], r"record\.interval = 1e\+308 is outside"),
        (["--set", "kT=1e308"], r"kT = 1e\+308 is outside"),
        (["--set", "diameter=1e308"], r"diameter = 1e\+308 is outside"),
        (["--seed", str(2**70)], r"seed must be an integer from 0 to 2\*\*63 - 1"),
        (["--set", "n=20"], r"--set 'n' is given twice"),
        (["--set", "kT=" + "[" * 3000], r"nested too deeply"),
    ],
)
def test_simulate_refuses_before_writing(tmp_path, args, match):
    out = tmp_path / "run"
    _error(["simulate", "box", "--out", out, "--set", "n=20", *args], match, "simulate")
    assert not out.exists()  # no checkpoint, config, metrics or store half-written


# ------------------------------------------------------------------ sweep
@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--seeds", "0-999999999999"], r"more than 100,000 seeds"),
        (["--seeds", str(2**64)], r"integers from 0 to 2\*\*63 - 1"),
        (["--grid", "kT=50", "--grid", "kT=60"], r"--grid 'kT' is given twice"),
    ],
)
def test_sweep_options(tmp_path, args, match):
    out = tmp_path / "sw"
    _error(["sweep", "box", "--out", out, "--set", "n=20", *args], match, "sweep")
    assert not out.exists()


# ------------------------------------------------------------------ convert
@pytest.mark.parametrize("value", ["0", "nan", "1e308", "-3", "inf", '"miles"'])
def test_convert_write_scale_is_strict(tmp_path, tracks_nc, value):
    dest = tmp_path / "out.txt"
    _error(["convert", tracks_nc, dest, "--to", "mot", "--write-option", f"px_per_mm={value}"],
           r"px_per_mm must be a (number from 1e-06 to 1e\+06|positive number or a preset)",
           "convert")  # fmt: skip
    assert not dest.exists()


def test_convert_write_scale_paper(tmp_path, tracks_nc):
    dest = tmp_path / "out.txt"
    res = outcome(["convert", tracks_nc, dest, "--to", "mot", "--write-option", "px_per_mm=paper"])
    rows = np.loadtxt(dest, delimiter=",") if res.kind == "ok" else None
    from thermoswarm.io import read_tracks

    ds = read_tracks(tracks_nc)
    want = ds["position"].values[0, :, 0, 0] * 3.04 - 10.0  # box corner of frame 1, id 1
    ok = rows is not None and np.allclose(rows[0, 2:4], want, atol=1e-3)
    assert_clean("convert", res, correct=bool(ok))


def test_convert_never_replaces_a_fifo(tmp_path, tracks_nc):
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    _error(["convert", tracks_nc, fifo, "--to", "tidy_csv"], r"pipe\.csv is a FIFO", "convert")
    assert fifo.is_fifo()
    from thermoswarm.errors import OutputError
    from thermoswarm.fsutil import atomic_write_text

    with pytest.raises(OutputError, match="FIFO"):
        atomic_write_text(fifo, "x")
    assert fifo.is_fifo()


# ------------------------------------------------------------------ TRex folder
def test_trex_damaged_npz_among_eight_is_named(tmp_path, tracks_nc):
    rng = np.random.default_rng(8)
    folder = tmp_path / "trex"
    folder.mkdir()
    for i in range(8):
        f = np.arange(40)
        np.savez(folder / f"v_fish{i}.npz", **{"X#wcentroid": rng.random(40),
                 "Y#wcentroid": rng.random(40), "frame": f, "time": f / 20.0,
                 "missing": np.zeros(40)})  # fmt: skip
    (folder / "v_fish4.npz").write_bytes(b"")
    _error(["analyze", folder, "--out", tmp_path / "r"], r"v_fish4\.npz", "analyze")


# ------------------------------------------------------------------ evaluate
def test_evaluate_ids_do_not_collide(tmp_path):
    """frame 1 id 2**31+1 and frame 2 id 1 were 'id 1 appears twice in frame 2'."""
    gt = tmp_path / "gt.txt"
    gt.write_text(f"1,{2**31 + 1},10,10,5,5,1,1,1\n2,1,10,10,5,5,1,1,1\n")
    res = outcome(["evaluate", gt, gt])
    metrics = json.loads(res.out) if res.kind == "ok" else {}
    assert_clean("evaluate", res, correct=metrics.get("mota") == 1.0)


@pytest.mark.parametrize("start", [10_000_000, 10**11])
def test_evaluate_late_frames_are_quick(tmp_path, start):
    gt = tmp_path / "gt.txt"
    gt.write_text("".join(f"{start + k},1,{10 + k},10,5,5,1,1,1\n" for k in range(5)))
    res = outcome(["evaluate", gt, gt], limit_s=30)
    metrics = json.loads(res.out) if res.kind == "ok" else {}
    assert_clean("evaluate", res, correct=metrics.get("idf1") == 1.0)


# ------------------------------------------------------------------ track --detections
def _late_files(folder: Path, start: int) -> dict[str, list[str]]:
    """The same five boxes as MOT, COCO and YOLO, frames numbered from ``start``."""
    mot = folder / "dets.txt"
    mot.write_text("".join(f"{start + k},-1,{20 + 3 * k},30,12,8,0.9,-1,-1,-1\n"
                           for k in range(5)))  # fmt: skip
    coco = folder / "dets.json"
    coco.write_text(json.dumps({"annotations": [
        {"image_id": start + k, "bbox": [20 + 3 * k, 30, 12, 8], "score": 0.9}
        for k in range(5)]}))  # fmt: skip
    yolo = folder / "yolo"
    yolo.mkdir()
    for k in range(5):
        cx, cy = (26 + 3 * k) / 200, 34 / 100
        (yolo / f"frame_{start + k}.txt").write_text(f"0 {cx} {cy} 0.06 0.08 0.9\n")
    return {"mot": [mot], "coco": [coco], "yolo": [yolo, "--image-size", "200x100"]}


@pytest.mark.parametrize("start", [1_000_000, 10_000_000, 10**11])
@pytest.mark.parametrize("fmt", ["mot", "coco", "yolo"])
def test_track_detections_numbered_late(tmp_path, fmt, start):
    """Frames near 1e7 hung past 60 s; near 1e11 asked for 745 GiB."""
    args = _late_files(tmp_path, start)[fmt]
    out = tmp_path / "o"
    res = outcome(["track", "--detections", args[0], *args[1:], "--fps", "30", "--out", out,
                   "--set", "tracker.confirm_s=0"], limit_s=60)  # fmt: skip
    ok = False
    if res.kind == "ok":
        rows = np.loadtxt(out / "tracks_mot.txt", delimiter=",", ndmin=2)
        ok = rows.shape[0] == 5 and rows[0, 0] == start and rows[-1, 0] == start + 4
    assert_clean("track --detections", res, correct=ok)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("[" * 3000 + "]" * 3000, r"JSON nested too deeply"),
        ('{"annotations": [{"image_id": ' + "9" * 5000 + ', "bbox": [1,2,5,5]}]}',
         r"a number too long to read"),
        ('{"annotations": [{"image_id": [1], "bbox": [1,2,5,5]}]}', r"image_id must be"),
        ('{"annotations": [{"image_id": NaN, "bbox": [1,2,5,5]}]}', r"got nan"),
        ('{"annotations": [{"image_id": Infinity, "bbox": [1,2,5,5]}]}', r"got inf"),
        ('{"annotations": [{"image_id": 1e300, "bbox": [1,2,5,5]}]}', r"got 1e\+300"),
        ('{"annotations": [{"image_id": ' + str(2**70) + ', "bbox": [1,2,5,5]}]}',
         r"image_id must"),
        ('{"images": [{"id": 1, "width": "wide", "height": 5}], "annotations": '
         '[{"image_id": 1, "bbox": [1,2,5,5]}]}', r"width and height must be integers"),
        ('{"images": [{"id": 1, "width": Infinity, "height": 5}], "annotations": '
         '[{"image_id": 1, "bbox": [1,2,5,5]}]}', r"width and height must be integers"),
        ('{"categories": 5, "annotations": [{"image_id": 1, "bbox": [1,2,5,5]}]}',
         r"'categories' must be a list"),
        ('{"images": {"id": 1}, "annotations": []}', r"'images' must be a list"),
        ('{"annotations": [{"image_id": 1, "bbox": [1e300,2,5,5]}]}', r"beyond 1e\+07 px"),
    ],
)  # fmt: skip
def test_coco_reader_trusts_no_value(tmp_path, text, match):
    dets = tmp_path / "d.json"
    dets.write_text(text)
    _error(["track", "--detections", dets, "--fps", "30", "--out", tmp_path / "o"], match,
           "track --detections")  # fmt: skip
    assert not (tmp_path / "o").exists()


def test_coco_info_of_any_type(tmp_path):
    dets = tmp_path / "d.json"
    cats = [{"keypoints": ["head", "body", "tail"]}]
    anns = [{"image_id": 1, "bbox": [1, 2, 5, 5]}]
    dets.write_text(json.dumps({"info": [1], "categories": cats, "annotations": anns}))
    res = outcome(["track", "--detections", dets, "--fps", "30", "--out", tmp_path / "o"])
    assert_clean("track --detections", res, correct=(tmp_path / "o" / "tracks.nc").is_file())


def test_yolo_folder_named_like_a_frame(tmp_path):
    yolo = tmp_path / "yolo"
    (yolo / "frame_9999.txt").mkdir(parents=True)
    (yolo / "frame_1.txt").write_text("0 0.5 0.5 0.1 0.1\n")
    out = tmp_path / "o"
    res = outcome(["track", "--detections", yolo, "--image-size", "64x48", "--fps", "30",
                   "--out", out])  # fmt: skip
    assert_clean("track --detections", res, correct=(out / "summary.json").is_file())
    assert json.loads((out / "summary.json").read_text())["n_frames"] == 1


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--object-size-px", "1e308"], r"--object-size-px must be a number from 2 to"),
        (["--fps", "0"], r"--fps = 0\.0 is not a recording's frame rate"),
        (["--fps", "1e308"], r"--fps = 1e\+308 is not"),
        (["--set", "tracker.confirm_s=1e9"], r"confirm_s must be at most 60"),
    ],
)
def test_track_detections_options(tmp_path, args, match):
    dets = tmp_path / "d.txt"
    dets.write_text("1,-1,20,30,12,8,0.9,-1,-1,-1\n")
    fps = [] if "--fps" in args else ["--fps", "30"]
    _error(["track", "--detections", dets, *fps, *args, "--out", tmp_path / "o"], match,
           "track --detections")  # fmt: skip


def _png(path: Path, width: int, height: int) -> None:
    """A PNG whose header declares ``width`` x ``height`` (data for a few rows only)."""

    def chunk(tag: bytes, data: bytes) -> bytes:
        return (
            struct.pack(">I", len(data))
            + tag
            + data
            + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)
        )

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    raw = zlib.compress(b"\x00" * (1 + 3 * min(width, 64)) * min(height, 4))
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", raw)
                     + chunk(b"IEND", b""))  # fmt: skip


@pytest.mark.parametrize(
    ("size", "match"), [((1, 1), r"a 1x1 px frame"), ((60000, 60000), r"cannot read image frame")]
)
@pytest.mark.parametrize("verb", ["track", "detect"])
def test_images_too_small_or_too_large(tmp_path, verb, size, match):
    pytest.importorskip("cv2")
    frames = tmp_path / "frames"
    frames.mkdir()
    for k in (1, 2):
        _png(frames / f"{k:06d}.png", *size)
    extra = ["--fps", "5"] if verb == "track" else []
    _error([verb, frames, "--out", tmp_path / "o", *extra], match, verb)
    assert not (tmp_path / "o").exists()


def test_detect_scale_giving_a_zero_pixel_ant(tmp_path):
    pytest.importorskip("cv2")
    frames = tmp_path / "frames"
    frames.mkdir()
    for k in (1, 2):
        _png(frames / f"{k:06d}.png", 32, 32)
    _error(["detect", frames, "--out", tmp_path / "o", "--px-per-mm", "1e-300"],
           r"px_per_mm must be a number from 1e-06", "detect")  # fmt: skip
    _error(["detect", frames, "--out", tmp_path / "o", "--px-per-mm", "1e-5"],
           r"an ant .* would be 7\.14e-05 px long", "detect")  # fmt: skip


# ------------------------------------------------------------------ messages
def test_no_numpy_scalar_reprs_in_messages():
    from thermoswarm.config import shown

    assert shown(np.float64(1.5)) == "1.5"
    assert shown(np.int64(3)) == "3"
    assert shown(10**5000).startswith("an integer of about 5000 digits")
