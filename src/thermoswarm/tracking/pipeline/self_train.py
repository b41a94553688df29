"""``track --detector self-trained``: a U-Net trained on the video's own animals.

The classical detector finds what differs from a still background, so an animal that
stands still for most of a clip becomes background and is not found (SLEAP's flies,
still for their first 40 s).  The U-Net finds animals by their look, wherever they
are and whether they move or not, but it needs training, and no weights ship with
thermoswarm.  This mode trains one on the video itself, from what the classical
detector does see:

1. the classical pass: :func:`~.video.track_video` as usual, into ``OUT/classical``
   (all its outputs, to compare);
2. labels: the frames where the most animals are tracked at once (detected there,
   not interpolated; the largest count reached in at least :data:`MIN_LABEL_FRAMES`
   frames), up to :data:`LABEL_FRAMES` of them spread evenly over the clip, with each
   of those tracks' head, body and tail (head and tail as the tracker oriented them,
   from the animal's motion);
3. a U-Net trained from random weights on those frames for :data:`STEPS` steps, at the
   scale that makes the animals as long as the paper's ants at 3.04 px/mm (the
   training data's scale), written to ``OUT/self_trained.pt`` with its report
   ``OUT/self_trained.json``;
4. :func:`~.video.track_video` again with that model, into ``OUT``; ``summary.json``
   gets a ``self_training`` record (the labels, the training, the classical pass).

A re-run into the same ``OUT`` whose classical pass gives the same labels (frames,
animals, length) with the same steps and seed uses the model there (``reused``).

Animals the classical pass never tracks are unlabelled in the label frames: the label
frames are those with the most animals found, so that in a clip where every animal
moves at some time they hold every animal, and blobs that stand out of their own
surroundings as the labelled animals do but hold no label (an animal that never moves)
are left out of training's "no animal" (:func:`_unlabelled_spots`).
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.errors import InputError
from thermoswarm.fsutil import atomic_write_json, prepare_output_dir
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.pipeline.flood import most_at_once

__all__ = ["SELF_TRAINED", "LABEL_FRAMES", "STEPS", "label_frames", "track_self_trained"]

#: The detector name that selects this mode.
SELF_TRAINED = "self-trained"
#: Most frames labelled from the classical pass.
LABEL_FRAMES = 60
#: Fewest frames at the labelled count (fewer: the count is not reached often enough
#: to be the animals' number).
MIN_LABEL_FRAMES = 5
#: Training steps (about 60 s on 2 cores at 60 frames: SLEAP's fly clip, 1,100 frames,
#: MOTA 0.073 with the classical detector, 0.955 with the model of 600 steps).
STEPS = 600
#: The training data's scale: the paper's, where an ant is 21.7 px long.
MODEL_PX_PER_MM = 3.04


def _tracked(first: Path) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    """``(points, found, attrs)`` of the classical pass's ``tracks.nc``: points ``(T, I,
    3, 2)`` in the tracks' px, ``found`` ``(T, I)``: detected there (not interpolated)."""
    import xarray as xr

    with xr.open_dataset(first / "tracks.nc") as ds:
        attrs = dict(ds.attrs)
        pos = ds["position"].transpose("time", "individuals", "keypoints", "space").values
        conf = ds["confidence"].transpose("time", "individuals", "keypoints").values
    if attrs.get("space_unit") == "mm":
        pos = pos * float(attrs["px_per_mm"])
    found = np.isfinite(pos[..., 1, 0]) & (np.nan_to_num(conf[..., 1]) > 0)
    return pos, found, attrs


def _pick(found: np.ndarray, n_max: int) -> tuple[np.ndarray, int]:
    """Frames to label and the count of animals found in each: the largest count
    reached in :data:`MIN_LABEL_FRAMES` frames or more, at most ``n_max`` of those
    frames, evenly spread."""
    count = found.sum(1)
    top = most_at_once(count, MIN_LABEL_FRAMES)
    if top == 0:
        return np.zeros(0, np.int64), 0
    cand = np.flatnonzero(count >= top)
    take = np.unique(np.linspace(0, cand.size - 1, min(n_max, cand.size)).round().astype(int))
    return cand[take], top


def _unlabelled_spots(frame: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Centres ``(m, 2)`` px of the blobs of ``frame`` (at :data:`MODEL_PX_PER_MM`) that
    stand out from their surroundings as the labelled animals do (``points``: their
    head, body, tail) but hold no label: animals the classical pass never found, as
    one that never moves, or specks.  Training teaches no "no animal" there; without
    this an animal that never moves is taught as floor in every label frame (SLEAP's
    fly excerpt with one fly frozen in place: that fly in no frame, MOTA 0.452; with
    it 0.939, ``benchmarks/bench_self_trained.py frozen``).

    The surroundings are the frame's own (a grey opening or closing over 1.5 body
    lengths: a spatial background, which holds no animal whether it moves or not), so
    that a still animal stands out as a moving one does; the side (light or dark
    animals) is the one on which the labelled body points stand out more."""
    import cv2

    from thermoswarm.tracking.detect.blobs import parts_at, spatial_response

    length = anatomy.ANT_LENGTH_MM * MODEL_PX_PER_MM
    grey = frame.astype(np.float32).mean(-1)
    light, dark = (spatial_response(grey, 1.5 * length, side) for side in (True, False))
    body = np.clip(points[:, 1].round().astype(int), 0, np.array(grey.shape[::-1]) - 1)
    at = [r[body[:, 1], body[:, 0]] for r in (light, dark)]
    resp = light if np.median(at[0]) >= np.median(at[1]) else dark
    n, lab, stats, cents = parts_at(resp, body)
    labelled = np.unique(lab[body[:, 1], body[:, 0]])
    area = np.median(stats[labelled[labelled > 0], cv2.CC_STAT_AREA]) if labelled.any() else 0
    keep = [
        c for c in range(1, n)
        if c not in labelled and 0.3 * area <= stats[c, cv2.CC_STAT_AREA] <= 3 * area
    ]  # fmt: skip
    spots = cents[keep].reshape(-1, 2)
    if len(spots) and len(points):
        d = np.linalg.norm(spots[:, None] - points[None, :, 1], axis=-1).min(1)
        spots = spots[d > 0.5 * length]
    return spots


def label_frames(
    first: str | os.PathLike,
    video: str | os.PathLike,
    *,
    max_frames: int | None = None,
    n_max: int = LABEL_FRAMES,
) -> tuple[Any, dict[str, Any]]:
    """The training frames of :func:`track_self_trained` from the classical pass in
    folder ``first`` (its ``tracks.nc`` and ``summary.json``) on ``video``: a
    :class:`~thermoswarm.tracking.train.data.LabeledFrames` at
    :data:`MODEL_PX_PER_MM`, and a record of them.  A registered camera's frames are
    registered again (the same path) and labelled in the canvas's px, as the second
    pass's detector sees them.  :class:`InputError` when too few frames have animals."""
    from thermoswarm.tracking.detect.register import register_source
    from thermoswarm.tracking.train.data import LabeledFrames
    from thermoswarm.tracking.video import open_video

    first = Path(first)
    pos, found, attrs = _tracked(first)
    pick, top = _pick(found, n_max)
    if pick.size == 0:
        raise InputError(
            f"{video}: nothing to learn the animals' look from: the classical pass "
            f"({first}) tracked animals in fewer than {MIN_LABEL_FRAMES} frames; "
            "--detector self-trained needs animals that move in part of the clip"
        )
    summary = json.loads((first / "summary.json").read_text())
    src = open_video(video)
    offset = np.zeros(2)
    if summary["camera"].get("registered"):
        src, path = register_source(src, "moving", max_frames=max_frames)
        offset = np.asarray(path.offset, float)
    want = {int(k): i for i, k in enumerate(pick)}
    frames: list[np.ndarray] = [np.zeros(0)] * pick.size
    for k, frame in enumerate(src.frames(int(pick[-1]) + 1, prefetch=4)):
        if k in want:
            frames[want[k]] = frame
    points = [pos[k][found[k]] + offset for k in pick]
    length = float(attrs["body_length_px"])
    data = LabeledFrames(
        frames, points, px_per_mm=length / anatomy.ANT_LENGTH_MM,
        source=f"self-training labels of {Path(video).name}",
    ).rescaled(MODEL_PX_PER_MM)  # fmt: skip
    data.ignore = [_unlabelled_spots(f, p) for f, p in zip(data.frames, data.points, strict=True)]
    record = {
        "label_frames": [int(k) + 1 for k in pick],
        "n_ignored": data.n_ignored,
        "animals_per_frame": top,
        "n_labels": data.n_instances,
        "length_px": length,
    }
    return data, record


def _trained(path: Path, data: Any, cfg: Any, labels: dict[str, Any]) -> dict[str, Any]:
    """The training report of ``path``: the model trained on ``data`` with ``cfg``, or,
    when ``path`` is there from an earlier run on the same labels (frames, animals,
    length, steps, seed), that run's (a re-run, e.g. with other tracker options, does
    not train again)."""
    from thermoswarm.tracking.train.fit import train

    labels = {**labels, "seed": cfg.seed}
    report_path = path.with_suffix(".json")
    if path.is_file() and report_path.is_file():
        old = json.loads(report_path.read_text())
        if old.get("self_training_labels") == labels:
            return old | {"reused": True}
    report = train(data, path, cfg)
    atomic_write_json(report_path, report | {"self_training_labels": labels})
    return report | {"reused": False}


def track_self_trained(
    video: str | os.PathLike,
    out_dir: str | os.PathLike,
    track_video: Callable[..., dict[str, Any]],
    *,
    steps: int = STEPS,
    seed: int = 0,
    threads: int | None = None,
    **options: Any,
) -> dict[str, Any]:
    """:func:`~.video.track_video` with a U-Net trained on the video's own animals (the
    module's docstring): ``track_video`` is that function (passed in: it calls this one),
    ``options`` its options (``model`` not among them).  Returns the second pass's
    summary with its ``self_training`` record."""
    from thermoswarm.tracking.train.fit import TrainConfig

    if options.get("model") is not None:
        raise InputError("--detector self-trained trains its own model; leave out --model")
    if not (isinstance(steps, int) and steps >= 1):
        raise InputError(f"self-training steps must be a positive integer, got {steps!r}")
    out = prepare_output_dir(out_dir)
    first = out / "classical"
    classical = {**options, "detector": None, "overlay": False}
    t0 = time.perf_counter()
    s1 = track_video(video, first, **classical)
    if s1.get("photo_series") is not None:
        raise InputError(f"{video}: a photo series; --detector self-trained is for videos")
    data, record = label_frames(first, video, max_frames=options.get("max_frames"))
    cfg = TrainConfig(
        seed=seed, max_steps=steps, eval_every=steps + 1, val_fraction=0.0, threads=threads
    )
    report = _trained(out / "self_trained.pt", data, cfg, {**record, "steps": steps})
    t_train = time.perf_counter() - t0
    # The detector options were the classical pass's; without a scale, the body length
    # is the one that pass measured (the U-Net's own pass would measure it again with
    # the classical detector's defaults, not the user's options).
    length = None if options.get("px_per_mm") is not None else record["length_px"]
    second = {**options, "detector": "unet", "model": out / "self_trained.pt"}
    summary = track_video(video, out, **{**second, "detector_options": None}, length_px=length)
    record.update(
        model="self_trained.pt",
        steps=report["steps"],
        seed=seed,
        train_seconds=round(report["train_seconds"], 1),
        reused=report["reused"],
        seconds_before_tracking=round(t_train, 1),
        classical={k: s1[k] for k in ("n_tracks", "detections_per_frame")}
        | {"folder": "classical"},
    )
    summary["self_training"] = record
    summary["outputs"] += ["self_trained.pt", "self_trained.json", "classical/"]
    atomic_write_json(out / "summary.json", summary)
    return summary
