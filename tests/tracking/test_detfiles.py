"""Other detectors' boxes: MOT, YOLO and COCO files, scale-free association, frame
numbering kept, bad files refused in one line."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner
from tracking_fixtures import small_video

from thermoswarm.cli import cli
from thermoswarm.errors import InputError
from thermoswarm.io.mot import read_mot_table, write_mot_table
from thermoswarm.tracking.detect.classical import FrameDetections
from thermoswarm.tracking.detect.files import parse_image_size, read_detections
from thermoswarm.tracking.evaluate import evaluate_tables
from thermoswarm.tracking.pipeline import track_detection_file
from thermoswarm.tracking.track.tracker import track_detections

W, H = 480, 200


@pytest.fixture(scope="module")
def noisy_boxes():
    """MOT detection rows (1-based) from the ground truth of a small video: boxes
    jittered by 5 % of their size, 10 % dropped, one false box every other frame,
    scores in [0.3, 1]; seeded.  Returns (video, rows)."""
    v = small_video(seed=11, n_ants=10, n_frames=60)
    rng = np.random.default_rng(5)
    gt = v.mot_gt
    keep = rng.random(len(gt)) > 0.1
    rows = gt[keep].copy()
    rows[:, 1] = -1
    size = rows[:, 4:6].mean(1, keepdims=True)
    rows[:, 2:4] += 0.05 * size * rng.standard_normal((len(rows), 2))
    rows[:, 4:6] *= np.exp(0.05 * rng.standard_normal((len(rows), 2)))
    rows[:, 6] = rng.uniform(0.3, 1.0, len(rows))
    fp_frames = np.arange(1, v.n_frames + 1, 2)
    fp = np.full((fp_frames.size, rows.shape[1]), -1.0)
    fp[:, 0] = fp_frames
    fp[:, 2] = rng.uniform(0, W - 30, fp_frames.size)
    fp[:, 3] = rng.uniform(0, H - 15, fp_frames.size)
    fp[:, 4:6] = [30, 15]
    fp[:, 6] = rng.uniform(0.1, 0.4, fp_frames.size)
    return v, np.concatenate([rows, fp])


def _frames(rows: np.ndarray, scale: float) -> list[FrameDetections]:
    out = []
    for f in range(1, int(rows[:, 0].max()) + 1):
        r = rows[rows[:, 0] == f]
        b = r[:, 2:6] * scale
        pts = np.full((len(r), 3, 2), np.nan)
        pts[:, 1] = b[:, :2] + b[:, 2:] / 2
        out.append(FrameDetections(pts, r[:, 6], boxes=b))
    return out


def test_scaled_detections_give_the_same_identities(noisy_boxes):
    """Association is in units of the objects' size: the same boxes at 1/4 and 4x the
    pixel scale give exactly the same tracks (powers of two scale floats exactly)."""
    v, rows = noisy_boxes
    runs = {}
    for s in (0.25, 1.0, 4.0):
        runs[s] = track_detections(_frames(rows, s), fps=30, frame_size=(W * s, H * s))
    base = runs[1.0]
    m = evaluate_tables(v.mot_gt, base.mot_table())
    assert m["mota"] > 0.8 and base.n_tracks >= len(np.unique(v.mot_gt[:, 1]))
    for s in (0.25, 4.0):
        r = runs[s]
        np.testing.assert_array_equal(r.frames, base.frames)
        np.testing.assert_array_equal(r.ids, base.ids)
        np.testing.assert_array_equal(r.boxes, base.boxes * s)


def _source_boxes(result_table: np.ndarray, det_rows: np.ndarray) -> np.ndarray:
    """For each detected (score > 0) output row, the input box of the same frame that
    it was written from (NaN where none): the same size (sizes are written as
    detected; the tracker smooths only the centres) and a centre within half of
    the box's larger side."""
    out = []
    for r in result_table[result_table[:, 6] > 0]:
        same = det_rows[det_rows[:, 0] == r[0]]
        size = np.all(np.abs(same[:, 4:6] - r[4:6]) < 1e-3, axis=1)
        near = np.all(np.abs(same[:, 2:4] - r[2:4]) < r[4:6].max() / 2, axis=1)
        hit = same[size & near]
        out.append(hit[0, 2:6] if len(hit) else np.full(4, np.nan))
    return np.array(out)


def _own_boxes(result_table: np.ndarray, det_rows: np.ndarray) -> np.ndarray:
    """For each detected output row: was it written from an input box of its frame?"""
    return np.isfinite(_source_boxes(result_table, det_rows)[:, 0])


def test_mot_file_from_frame_0_keeps_its_numbering(noisy_boxes, tmp_path):
    v, rows = noisy_boxes
    write_mot_table(tmp_path / "one.txt", rows)
    zero = rows.copy()
    zero[:, 0] -= 1
    (tmp_path / "zero.txt").write_text(
        "".join(
            f"{int(r[0])},-1,{r[2]:.3f},{r[3]:.3f},{r[4]:.3f},{r[5]:.3f},{r[6]:.4g}\n"
            for r in zero
        )
    )
    s1 = track_detection_file(tmp_path / "one.txt", tmp_path / "o1", fps=30)
    s0 = track_detection_file(tmp_path / "zero.txt", tmp_path / "o0", fps=30)
    assert (s1["first_frame"], s0["first_frame"]) == (1, 0)
    t1 = read_mot_table(tmp_path / "o1" / "tracks_mot.txt")
    t0 = read_mot_table(tmp_path / "o0" / "tracks_mot.txt", min_frame=0)
    assert t0[:, 0].min() == 0 and t1[:, 0].min() == 1
    np.testing.assert_array_equal(t0[:, 0] + 1, t1[:, 0])
    np.testing.assert_array_equal(t0[:, 1:6], t1[:, 1:6])
    # The boxes written are the detections' own, in their own frames.
    assert _own_boxes(t1, read_mot_table(tmp_path / "one.txt")).all()
    # Without a scale tracks.nc is written in px, and says so.
    import xarray as xr

    with xr.open_dataset(tmp_path / "o1" / "tracks.nc") as ds:
        assert ds.attrs["space_unit"] == "px"
        body = ds["position"].sel(keypoints="body").values  # (time, space, individuals)
    first = _source_boxes(t1[t1[:, 0] == 1], read_mot_table(tmp_path / "one.txt"))
    centres = first[:, :2] + first[:, 2:] / 2  # the body points are the detections'
    got = body[0][:, np.isfinite(body[0, 0])].T
    assert len(got) == len(centres)
    np.testing.assert_allclose(np.sort(got[:, 0]), np.sort(centres[:, 0]), atol=2e-3)


def test_a_missing_frame_is_an_empty_frame_not_a_shift(noisy_boxes, tmp_path):
    v, rows = noisy_boxes
    gap = rows[rows[:, 0] != 30]
    write_mot_table(tmp_path / "gap.txt", gap)
    track_detection_file(tmp_path / "gap.txt", tmp_path / "o", fps=30)
    t = read_mot_table(tmp_path / "o" / "tracks_mot.txt")
    # Frame 30 holds only interpolated rows (score 0); every other row sits in the
    # frame of the detection it came from.
    assert np.all(t[t[:, 0] == 30, 6] == 0) and np.any(t[:, 0] == 30)
    assert _own_boxes(t, gap).all()
    m = evaluate_tables(v.mot_gt, t)
    assert m["mota"] > 0.8


@pytest.mark.parametrize(
    "line, message",
    [
        ("3,-1,10,10,-5,8,1", "gt.txt:2: negative box width or height (-5 x 8)"),
        ("-1,-1,10,10,5,8,1", "gt.txt:2: frame number -1 is not an integer >= 0"),
        ("2.5,-1,10,10,5,8,1", "gt.txt:2: frame number 2.5 is not an integer"),
        ("1e11,-1,10,10,5,8,1", "span 100,000,000,000 frames, more than the 10,000,000"),
        ("3,-1,10,10,0,8,1", "row 2: box width and height must be positive, got 0 x 8"),
        ("3,-1,10,nan,5,8,1", "gt.txt:2: non-finite frame, id or box value"),
    ],
)
def test_bad_mot_detections_are_refused_in_one_line(tmp_path, line, message):
    p = tmp_path / "gt.txt"
    p.write_text("1,-1,10,10,5,8,1\n" + line + "\n")
    with pytest.raises(InputError) as e:
        read_detections(p)
    assert message in str(e.value) and "\n" not in str(e.value)


def test_yolo_and_coco_files_track_like_mot(noisy_boxes, tmp_path):
    v, rows = noisy_boxes
    write_mot_table(tmp_path / "dets.txt", rows)
    rows = read_mot_table(tmp_path / "dets.txt")  # as written (3 decimals)
    track_detection_file(tmp_path / "dets.txt", tmp_path / "o_mot", fps=30, image_size=(W, H))
    want = read_mot_table(tmp_path / "o_mot" / "tracks_mot.txt")
    # YOLO: one file per frame (frames without a detection have no file), normalised.
    yolo = tmp_path / "labels"
    yolo.mkdir()
    for f in np.unique(rows[:, 0]).astype(int):
        r = rows[rows[:, 0] == f]
        lines = [
            f"0 {(b[2] + b[4] / 2) / W:.9f} {(b[3] + b[5] / 2) / H:.9f} "
            f"{b[4] / W:.9f} {b[5] / H:.9f} {b[6]:.6f}"
            for b in r
        ]
        (yolo / f"clip_{f:06d}.txt").write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match="pass --image-size"):
        read_detections(yolo)
    track_detection_file(yolo, tmp_path / "o_yolo", fps=30, image_size=(W, H))
    got = read_mot_table(tmp_path / "o_yolo" / "tracks_mot.txt")
    np.testing.assert_array_equal(got[:, :2], want[:, :2])
    np.testing.assert_allclose(got[:, 2:6], want[:, 2:6], atol=2e-3)
    # COCO results format (image_id = frame) and dataset format (frame from file names).
    res = [
        {"image_id": int(r[0]), "bbox": [float(x) for x in r[2:6]], "score": float(r[6])}
        for r in rows
    ]
    (tmp_path / "res.json").write_text(json.dumps(res))
    frames = np.unique(rows[:, 0]).astype(int)
    images = [
        {"id": 100 + int(f), "file_name": f"img{f:05d}.jpg", "width": W, "height": H}
        for f in frames
    ]
    anns = [dict(r, image_id=100 + r["image_id"]) for r in res]
    (tmp_path / "ds.json").write_text(json.dumps({"images": images, "annotations": anns}))
    for name in ("res.json", "ds.json"):  # the dataset gives its image size itself
        size = (W, H) if name == "res.json" else None
        track_detection_file(tmp_path / name, tmp_path / f"o_{name}", fps=30, image_size=size)
        got = read_mot_table(tmp_path / f"o_{name}" / "tracks_mot.txt")
        np.testing.assert_array_equal(got[:, :2], want[:, :2])
        np.testing.assert_allclose(got[:, 2:6], want[:, 2:6], atol=2e-3)
    assert read_detections(tmp_path / "ds.json").image_size == (W, H)


def test_bad_yolo_and_coco_files(tmp_path):
    d = tmp_path / "yolo"
    d.mkdir()
    (d / "frame_1.txt").write_text("0 320 100 40 20\n")
    with pytest.raises(InputError, match=r"frame_1.txt:1: cx cy w h must be normalised"):
        read_detections(d, image_size=(W, H))
    (d / "frame_1.txt").write_text("0 0.5 0.5 0.1\n")
    with pytest.raises(InputError, match=r"frame_1.txt:1: expected 'class cx cy w h \[conf\]'"):
        read_detections(d, image_size=(W, H))
    (d / "frame_1.txt").write_text("0 0.5 0.5 0.1 0.1\n")
    (d / "notes.txt").write_text("")
    with pytest.raises(InputError, match="no frame number in the file name 'notes.txt'"):
        read_detections(d, image_size=(W, H))
    j = tmp_path / "d.json"
    j.write_text(json.dumps([{"image_id": 1.5, "bbox": [0, 0, 1, 1]}]))
    with pytest.raises(InputError, match="image_id must be an integer frame number, got 1.5"):
        read_detections(j)
    j.write_text(
        json.dumps({"images": [{"id": 1}], "annotations": [{"image_id": 2, "bbox": [0, 0, 1, 1]}]})
    )
    with pytest.raises(InputError, match="image_id 2 is not in 'images'"):
        read_detections(j)
    j.write_text("{")
    with pytest.raises(InputError, match="not a JSON file"):
        read_detections(j)


def test_image_size_from_text_or_a_frame(tmp_path):
    from PIL import Image

    assert parse_image_size("640x480") == (640, 480)
    Image.new("RGB", (33, 21)).save(tmp_path / "f.png")
    assert parse_image_size(str(tmp_path / "f.png")) == (33, 21)
    with pytest.raises(InputError, match="expected WIDTHxHEIGHT or an image/video file"):
        parse_image_size("big")


def test_cli_tracks_boxes_without_a_scale(noisy_boxes, tmp_path):
    v, rows = noisy_boxes
    write_mot_table(tmp_path / "dets.txt", rows)
    out = tmp_path / "out"
    r = CliRunner().invoke(
        cli,
        ["track", "--detections", str(tmp_path / "dets.txt"), "--fps", "30", "--out", str(out)],
    )
    assert r.exit_code == 0, r.output
    assert "tracks.nc" in r.output and (out / "tracks_mot.txt").exists()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["px_per_mm"] is None and summary["detections_format"] == "mot"
    assert summary["space_unit"] == "px"
    m = evaluate_tables(v.mot_gt, read_mot_table(out / "tracks_mot.txt"))
    assert m["mota"] > 0.8
    # With a scale, tracks.nc is in mm.
    r = CliRunner().invoke(
        cli,
        ["track", "--detections", str(tmp_path / "dets.txt"), "--fps", "30", "--out",
         str(tmp_path / "o2"), "--px-per-mm", "paper"],
    )  # fmt: skip
    assert r.exit_code == 0 and (tmp_path / "o2" / "tracks.nc").exists()
    r = CliRunner().invoke(
        cli, ["track", "--detections", str(tmp_path / "dets.txt"), "--out", str(tmp_path / "o3")]
    )
    assert r.exit_code == 2 and "pass --fps" in r.output
