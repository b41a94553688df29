"""``track --detector self-trained``: a U-Net trained on the video's own animals.

Real pixels: SLEAP's two-fly clip, shrunk (``tests/data/sleap_fly_clip``: 500 frames;
the flies stand still, then walk from frame 334), with one fly frozen: frame 1's
pixels where it stood then and where it is now pasted into every frame, so that it
stands where it stood in frame 1 and never moves.
The classical detector, which finds what differs from a still background, never finds
that fly; the self-trained U-Net learns the flies' look from the other one and finds
it too."""

from __future__ import annotations

import gzip
import json
import os
from pathlib import Path

import numpy as np
import pytest

# Before torch starts its OpenMP runtime (see thermoswarm.tracking.detect.unet).
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
from click.testing import CliRunner  # noqa: E402

from thermoswarm.cli import cli
from thermoswarm.io.mot import read_mot_table
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.pipeline import track_video
from thermoswarm.tracking.pipeline.flood import few_found_warning, inner_ends
from thermoswarm.tracking.pipeline.self_train import (
    MODEL_PX_PER_MM,
    _pick,
    _unlabelled_spots,
    label_frames,
)

DATA = Path(__file__).resolve().parents[1] / "data" / "sleap_fly_clip"
PX_PER_MM = 14.94 / 4  # the shrunk clip's scale: flies 26.7 px long
N_FRAMES = 500
#: Half a body length at the model's scale (px): the reach of "at this fly".
HALF_L = 0.5 * anatomy.ANT_LENGTH_MM * MODEL_PX_PER_MM


def frozen_fly_clip(out: Path) -> tuple[Path, np.ndarray, np.ndarray]:
    """The clip with fly 1 frozen as in frame 1, written to ``out``; its truth (MOT rows,
    fly 1's box the same in every frame; fly 2's where it is not under the patch) and
    fly 1's box."""
    import cv2

    cap = cv2.VideoCapture(str(DATA / "clip.mp4"))
    frames = []
    while len(frames) < N_FRAMES:
        ok, f = cap.read()
        assert ok
        frames.append(f)
    with gzip.open(DATA / "gt.txt.gz", "rt") as f:
        gt = np.loadtxt(f, delimiter=",", ndmin=2)
    gt = gt[gt[:, 0] <= N_FRAMES]
    box = gt[(gt[:, 1] == 1) & (gt[:, 0] == 1)][0, 2:6]

    def rect(b: np.ndarray, pad: int) -> tuple[slice, slice]:
        x0, y0 = (np.floor(b[:2]) - pad).astype(int).clip(0)
        x1, y1 = (np.ceil(b[:2] + b[2:]) + pad).astype(int)
        return slice(y0, y1), slice(x0, x1)

    first = {int(i): gt[(gt[:, 1] == i) & (gt[:, 0] == 1)][0, 2:6] for i in (1, 2)}
    path = out / "frozen.mp4"
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 10, (256, 256))
    for k, f in enumerate(frames, start=1):
        # Frame 1's pixels where fly 1 stood then and where it is now (the floor it
        # walks on, seen in frame 1); fly 2's pixels, now and in frame 1, are left live.
        paste = np.zeros(f.shape[:2], bool)
        now = {int(r[1]): r[2:6] for r in gt[gt[:, 0] == k]}
        paste[rect(first[1], 6)] = True
        if 1 in now:
            paste[rect(now[1], 6)] = True
        paste[rect(first[2], 0)] = False
        if 2 in now:
            paste[rect(now[2], 0)] = False
        g = f.copy()
        g[paste] = frames[0][paste]
        w.write(g)
    w.release()
    gt[gt[:, 1] == 1, 2:6] = box
    # Where fly 2 walks over fly 1's place it is hidden in part: those boxes are no
    # longer the truth, and are left out.
    (ys, xs), c = rect(box, 6), gt[:, 2:4] + gt[:, 4:6] / 2
    inside = (
        (c[:, 0] > xs.start) & (c[:, 0] < xs.stop) & (c[:, 1] > ys.start) & (c[:, 1] < ys.stop)
    )
    return path, gt[(gt[:, 1] == 1) | ~inside], box


@pytest.fixture(scope="module")
def frozen(tmp_path_factory):
    return frozen_fly_clip(tmp_path_factory.mktemp("frozen"))


def _found(rows: np.ndarray, box: np.ndarray, reach: float) -> float:
    """Share of the frames with a track box centred within ``reach`` px of ``box``'s."""
    c = box[:2] + box[2:] / 2
    d = np.linalg.norm(rows[:, 2:4] + rows[:, 4:6] / 2 - c, axis=1)
    return np.unique(rows[d <= reach, 0]).size / N_FRAMES


def _near(rows: np.ndarray, truth: np.ndarray, reach: float) -> float:
    """Share of the ``truth`` boxes with a track box centred within ``reach`` px in
    their frame."""
    hit = 0
    for t in truth:
        at = rows[rows[:, 0] == t[0]]
        c = t[2:4] + t[4:6] / 2
        hit += (
            bool(at.size)
            and np.linalg.norm(at[:, 2:4] + at[:, 4:6] / 2 - c, axis=1).min() <= reach
        )
    return hit / len(truth)


# ------------------------------------------------------------------ the parts


def test_few_found_warning_names_the_picture_background_and_the_self_trained_detector():
    # Two animals in 10 frames of 100, none elsewhere: 0.2 a frame, 10 % of two.
    text = few_found_warning(np.r_[np.zeros(90, int), np.full(10, 2)])
    assert text is not None and "10%" in text and "--detector self-trained" in text
    assert "--set detector.background=picture" in text
    assert few_found_warning(np.full(100, 2)) is None  # every animal in every frame
    assert few_found_warning(np.r_[np.full(60, 2), np.full(40, 1)]) is None  # 0.8 of 2
    assert few_found_warning(np.zeros(100, int)) is None  # nothing found: no_track's
    # Three at once in 4 frames only is not the animals' number: the count is 1.
    assert few_found_warning(np.r_[np.full(4, 3), np.zeros(96, int)]) is None
    # Animals that walk in and out of the picture (a trail) are not lost animals.
    assert few_found_warning(np.r_[np.zeros(90, int), np.full(10, 2)], inner=0.25) is None


def test_inner_ends_are_where_tracks_begin_and_end_inside_the_picture():
    # Track 1 walks in from the left edge and out at the right; track 2 appears and
    # vanishes in the middle (an animal that stood still before and after).
    ids = np.array([1, 1, 1, 2, 2])
    frames = np.array([2, 0, 1, 5, 6])
    body = np.array([[50.0, 50], [2.0, 50], [98.0, 50], [40.0, 40], [60.0, 60]])
    assert inner_ends(ids, frames, body, (100, 100), 10.0) == pytest.approx(0.75)
    assert inner_ends(ids[:3], frames[:3], body[:3], (100, 100), 10.0) == pytest.approx(0.5)


def test_pick_takes_the_frames_with_the_most_animals_spread_over_the_clip():
    found = np.zeros((100, 3), bool)
    found[:, 0] = True
    found[20:80, 1] = True  # two animals in 60 frames
    found[50:53, 2] = True  # three in 3 frames: fewer than MIN_LABEL_FRAMES
    pick, top = _pick(found, 10)
    assert top == 2 and pick.size == 10
    assert pick.min() == 20 and pick.max() == 79 and np.all(np.diff(pick) >= 6)
    assert _pick(np.zeros((50, 2), bool), 10)[0].size == 0


@pytest.mark.parametrize("light", [True, False])
def test_unlabelled_spots_are_the_animals_without_a_label(light):
    import cv2

    rng = np.random.default_rng(4)
    floor, body = (40, 200) if light else (200, 40)
    img = np.clip(floor + rng.normal(0, 3, (160, 240)), 0, 255).astype(np.uint8)
    centres = np.array([[40.0, 40.0], [120.0, 90.0], [200.0, 130.0]])
    for c in centres:  # animals 22 x 8 px, the model's scale
        cv2.ellipse(img, tuple(int(v) for v in c), (11, 4), 30, 0, 360, body, -1)
    frame = np.repeat(img[..., None], 3, axis=2)
    ht = np.array([[-9.5, -5.5], [0.0, 0.0], [9.5, 5.5]])
    points = centres[:2, None, :] + ht[None]  # the first two labelled
    spots = _unlabelled_spots(frame, points)
    assert spots.shape == (1, 2)
    assert np.linalg.norm(spots[0] - centres[2]) < 1.0


def test_a_fly_that_never_moves_is_left_out_of_the_negatives(frozen, tmp_path):
    """The classical pass tracks the walking fly only; its label frames hold that fly,
    and the frozen one as a spot left out of the training's "no animal"."""
    path, gt, box = frozen
    track_video(path, tmp_path / "c", px_per_mm=PX_PER_MM, overlay=False,
                detector_options={"polarity": "light"})  # fmt: skip
    data, record = label_frames(tmp_path / "c", path)
    assert record["animals_per_frame"] == 1 and len(data) >= 20
    r = MODEL_PX_PER_MM / PX_PER_MM
    frozen_at = (box[:2] + box[2:] / 2) * r
    checked = 0
    for k, pts, ign in zip(record["label_frames"], data.points, data.ignore, strict=True):
        walker = gt[(gt[:, 0] == k) & (gt[:, 1] == 2)][:, 2:6].reshape(-1)
        if walker.size == 0:
            continue  # fly 2 over fly 1's place: no truth there
        checked += 1
        assert np.linalg.norm(pts[0, 1] - (walker[:2] + walker[2:] / 2) * r) < HALF_L
        assert np.linalg.norm(ign - frozen_at, axis=1).min() < HALF_L, (k, ign)
    assert checked >= 50


def test_a_rerun_on_the_same_labels_reuses_the_model(tmp_path):
    from thermoswarm.tracking.pipeline.self_train import _trained
    from thermoswarm.tracking.train import fit as tr

    data = tr.synthetic_data(
        tr.SynthDataConfig(n_videos=1, frames_per_video=2, width=200, height=120, codec=False),
        np.random.default_rng(1),
    )
    cfg = tr.TrainConfig(max_steps=2, eval_every=10, centroid_batch=2, patch_size=32,
                         pose_batch=4, val_fraction=0.0, threads=1)  # fmt: skip
    labels = {"label_frames": [1, 2], "animals_per_frame": 3, "length_px": 21.7, "steps": 2}
    path = tmp_path / "self_trained.pt"
    first = _trained(path, data, cfg, labels)
    stamp = path.stat().st_mtime_ns
    again = _trained(path, data, cfg, labels)
    assert not first["reused"] and again["reused"] and path.stat().st_mtime_ns == stamp
    assert again["train_seconds"] == first["train_seconds"]
    # Other labels (the classical pass found other frames): trained again.
    other = _trained(path, data, cfg, {**labels, "label_frames": [1, 3]})
    assert not other["reused"]


def test_self_trained_is_a_track_mode(tmp_path):
    runner = CliRunner()
    video = str(DATA / "clip.mp4")
    model = tmp_path / "m.pt"
    model.write_bytes(b"x")
    r = runner.invoke(cli, ["track", video, "--out", str(tmp_path / "o"),
                             "--detector", "self-trained", "--model", str(model)])  # fmt: skip
    assert r.exit_code == 2 and "leave out --model" in r.output
    r = runner.invoke(cli, ["detect", video, "--out", str(tmp_path / "d"),
                             "--detector", "self-trained"])  # fmt: skip
    assert r.exit_code == 2 and "mode of `thermoswarm track`" in r.output


# ------------------------------------------------------------------ end to end


def test_the_picture_background_finds_a_fly_that_never_moves(frozen, tmp_path):
    """Real pixels, fly 1 frozen in every frame: the background learned over time holds
    it (found in no frame); each frame against its own surroundings
    (``detector.background=picture``) finds it in nearly every frame, and the walking
    fly too (``bench_self_trained.py frozen``: MOTA 0.450 -> 0.960, 501 misses -> 4)."""
    path, gt, box = frozen
    reach = 0.5 * anatomy.ANT_LENGTH_MM * PX_PER_MM
    rows = {}
    for bg in ("time", "picture"):
        s = track_video(path, tmp_path / bg, px_per_mm=PX_PER_MM, overlay=False,
                        detector_options={"polarity": "light", "background": bg})  # fmt: skip
        assert s["background"] == bg
        rows[bg] = read_mot_table(tmp_path / bg / "tracks_mot.txt")
    assert _found(rows["time"], box, reach) < 0.1
    assert _found(rows["picture"], box, reach) >= 0.95
    assert _near(rows["picture"], gt[gt[:, 1] == 2], reach) >= 0.95
    assert len(np.unique(rows["picture"][:, 1])) == 2


@pytest.mark.slow
def test_self_trained_finds_a_fly_that_never_moves(frozen, tmp_path):
    """Classical: the frozen fly in no frame.  Self-trained (600 steps, about 1.5 CPU
    minutes): in at least 0.9 of the frames (measured 0.92 MOTA over both flies), the
    walking fly as well."""
    path, gt, box = frozen
    common = ["--px-per-mm", str(PX_PER_MM), "--set", "detector.polarity=light",
              "--no-overlay", "--quiet"]  # fmt: skip
    runner = CliRunner()
    r = runner.invoke(cli, ["track", str(path), "--out", str(tmp_path / "s"),
                             "--detector", "self-trained", *common])  # fmt: skip
    assert r.exit_code == 0, r.output
    assert "self-trained on 60 frames" in r.output
    reach = 0.5 * anatomy.ANT_LENGTH_MM * PX_PER_MM
    classical = read_mot_table(tmp_path / "s" / "classical" / "tracks_mot.txt")
    ours = read_mot_table(tmp_path / "s" / "tracks_mot.txt")
    assert _found(classical, box, reach) < 0.1
    assert _found(ours, box, reach) >= 0.9
    walker = gt[gt[:, 1] == 2]
    assert _near(classical, walker, reach) >= 0.9 and _near(ours, walker, reach) >= 0.9
    s = json.loads((tmp_path / "s" / "summary.json").read_text())
    assert s["detector"] == "unet" and s["self_training"]["steps"] == 600
    assert not s["self_training"]["reused"]
    assert s["self_training"]["n_ignored"] >= 50  # the frozen fly, in most label frames
    # Again into the same folder with another tracker option: the same labels, so the
    # model is reused, not trained again.
    r = runner.invoke(cli, ["track", str(path), "--out", str(tmp_path / "s"),
                            "--detector", "self-trained", *common,
                            "--set", "tracker.max_gap_s=1"])  # fmt: skip
    assert r.exit_code == 0, r.output
    assert json.loads((tmp_path / "s" / "summary.json").read_text())["self_training"]["reused"]
