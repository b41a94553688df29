"""What the pipeline's verbs share: the detector built and prepared on a source's first
frames (measuring the animals' size when no scale is given), the run's summary, and the
trajectory Dataset in px."""

from __future__ import annotations

import contextlib
import dataclasses
import os
from typing import Any

import numpy as np

from thermoswarm.config import to_dict
from thermoswarm.errors import InputError, NoBlobsError
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.detect.classical import (
    NOTHING_FOUND_HINT,
    make_detector,
)
from thermoswarm.tracking.detect.register import RegisteredSource
from thermoswarm.tracking.detect.size import estimate_length_px
from thermoswarm.tracking.track.tracker import TrackerConfig, TrackResult

#: Smallest share of its length squared that a single animal's blob fills (lines below).
MIN_FILL = 0.1
#: Smallest typical peak contrast, over the noise threshold, of blobs taken for animals
#: when a sample whose blobs stand out more is found (:attr:`SizeEstimate.clear`: real
#: animals 6.6-8.9; the compression specks of SLEAP's fly clip, whose flies stand still
#: for 40 s, 1.7-2.2, measured as 12-px "animals" in 41 tracks before).
MIN_CLEAR = 3.0
#: With a scale, the moving blobs' length as a share of the paper's ant's at that scale
#: for a sample to show the animals (a quarter to four times: ant species of 2-28 mm).
#: SLEAP's fly clip, first 1,100 frames (flies still until frame 1,000): its first 3 s
#: show specks of 0.11 times it; the background from them gave MOTA 0.073, from frames
#: 1026-1100, where the flies walk, 1.000.
EXPECT_RANGE = (0.25, 4.0)


def pixel_dataset(result: TrackResult, *, fps: float, source: str, attrs: dict[str, Any]) -> Any:
    """The trajectory Dataset of ``result`` with positions in px (no scale known).

    ``attrs["space_unit"]`` is ``"px"``; readers (:func:`thermoswarm.io.read_tracks`)
    then need ``--px-per-mm`` to convert to mm, or the ``units`` option to keep px.
    """
    ds = result.dataset(px_per_mm=1.0, fps=fps, source_file=source, attrs=attrs)
    del ds.attrs["px_per_mm"]
    ds.attrs["space_unit"] = "px"
    return ds


def _prep_frames(prepare_s: float, rate: float, max_frames: int | None) -> int:
    """How many first frames the detector's ``prepare`` step sees (at least one)."""
    n_prep = max(1, int(round(prepare_s * rate)))
    if max_frames is not None:
        n_prep = min(n_prep, max_frames)
    return n_prep


#: Windows of the detector's preparation frames tried first over a clip, the first
#: included, when its first frames show no moving animal (an arena still empty when
#: it starts); then every window in turn, up to :data:`SCAN_BUDGET_PX`.
SIZE_WINDOWS = 9
#: Most pixels decoded looking for moving animals (about 1,000 full-HD frames, or
#: every frame of a 10-min clip of 84 x 72 px, in a few seconds).
SCAN_BUDGET_PX = 2e9


#: Most windows' length the sample spread over a clip covers (a minute at the default 3 s
#: window): over longer spans the floor itself changes (beelab's 10-min ROI_7 clip, its
#: light changing: the sample spread over all of it found 25-px "animals" filling 0.08
#: of their length squared, where its ants are 8 px; over its first minute, none).
SPREAD_WINDOWS = 20

#: A sample of frames: ``(start, stop, step)``, 0-based, as ``frames`` takes it.
Sample = tuple[int, int, int]


def _samples(
    src: Any, n_prep: int, step: int, max_frames: int | None, spread: int | None, at: int = 0
) -> tuple[list[Sample], int]:
    """The frame samples where the animals' size is looked for, in order: with
    ``spread`` (a frame count) and a clip of two windows or more, as many frames as
    one window holds spread evenly over the clip's first ``spread`` frames (and below
    ``max_frames`` and :data:`SPREAD_WINDOWS` windows); then windows of ``n_prep``
    frames: the first, windows evenly spread over the clip, then the windows that tile
    it, within :data:`SCAN_BUDGET_PX`; and the clip's frames."""
    total = getattr(src, "n_frames", None)
    if max_frames is not None:
        total = max_frames if total is None else min(total, max_frames)
    if not total or total < 2 * n_prep:
        return [(0, n_prep, step)], n_prep
    spread_at = np.linspace(0, total - n_prep, SIZE_WINDOWS).round().astype(int).tolist()
    tiles = [min(k, total - n_prep) for k in range(0, total, n_prep)]
    seen = np.zeros(total, bool)
    starts = []
    for k in spread_at + tiles:  # the spread first; then the tiles that see a new frame
        if not seen[k : k + n_prep].all():
            starts.append(k)
            seen[k : k + n_prep] = True
    w, h = src.size
    most = max(SIZE_WINDOWS, int(SCAN_BUDGET_PX // (w * h * n_prep)))
    out = [(k, k + n_prep, step) for k in starts[:most]]
    # A clip two windows long or more is first sampled evenly over its whole length, so
    # that animals standing still in its first seconds are not learned as floor and
    # their twitching legs taken for animals (SLEAP's fly clip: a 12 px "fly" measured
    # from the first 3 s, 72 px from the spread sample; labelled head to abdomen 70 px).
    span = min(spread or 0, total, SPREAD_WINDOWS * n_prep)
    if span >= 2 * n_prep:
        n = -(-n_prep // step)  # as many frames as a window gives
        every = span // n
        out.insert(at, (0, every * (n - 1) + 1, every))
    return out, total


def _measure_size(
    src: Any,
    samples: list[Sample],
    total: int,
    n_prep: int,
    options: dict[str, Any] | None,
    keep: dict | None = None,
    expect: float | None = None,
) -> tuple[Any, Sample]:
    """The animals' size (:class:`SizeEstimate`) and the frame sample it was measured
    on: the first of ``samples`` (:func:`_samples`, over a clip of ``total`` frames)
    where animals move: moving blobs that stand out of the noise (:data:`MIN_CLEAR`)
    and, with a body length ``expect`` known from the scale, within
    :data:`EXPECT_RANGE` of it; else (with ``expect``) the first whose blobs fit it,
    faint or not; else the first where anything moves.  A one-line error says how much
    of the clip was looked at when nothing moves."""
    windows = [s for s in samples if s[1] - s[0] == n_prep]
    lo, hi = EXPECT_RANGE
    fallback = faint = None  # the first where anything moves; the first that fits
    for sample in samples:
        try:
            est = estimate_length_px(_read(src, sample, keep), options, source=str(src.path))
        except NoBlobsError as exc:
            if len(samples) == 1:
                raise
            first = exc
            continue
        if est.fill >= MIN_FILL or sample in windows:  # a spread sample's lines: the floor
            fits = expect is None or lo * expect <= est.length_px <= hi * expect
            if fits and not est.clear < MIN_CLEAR:  # NaN (a user's threshold): clear
                return est, sample
            fallback = fallback or (est, sample)
            if fits and expect is not None:  # faint animals the scale says are animals
                faint = faint or (est, sample)
    if faint is not None or fallback is not None:
        return faint or fallback
    seen = np.zeros(total, bool)
    for start, stop, _ in windows:
        seen[start:stop] = True
    more = "" if seen.all() else f" (the look stops at {SCAN_BUDGET_PX:.0e} px decoded)"
    spread_note = " and a sample spread over it" if len(windows) < len(samples) else ""
    raise InputError(
        f"{src.path}: cannot measure the animals' size: no moving animal in "
        f"{len(windows)} windows of {n_prep} frames covering {seen.mean():.0%} of the "
        f"clip{spread_note}{more}; cut the clip where animals move, or {NOTHING_FOUND_HINT}"
    ) from first


def first_cut(path: Any) -> int | None:
    """The first frame (0-based) after a scene cut of a camera ``path``, if any."""
    return min(path.cuts, default=None) if path is not None else None


#: Most bytes of decoded frames kept for a second pass over the same sample (the size,
#: then the background): 45 frames of 1024 x 1024 RGB are 142 MB; 4K frames are read twice.
KEEP_BYTES = 2**29


def _read(src: Any, sample: Sample, keep: dict | None = None) -> Any:
    """The frames of ``sample`` (sources without ``start`` are only asked for samples
    from frame 0); with ``keep``, the last sample's frames are kept there as a list
    when under :data:`KEEP_BYTES`, and given again from it."""
    if keep is not None and sample in keep:
        return keep[sample]
    start, stop, every = sample
    frames = src.frames(stop, step=every, prefetch=4, **({"start": start} if start else {}))
    w, h = src.size
    if keep is None or len(range(start, stop, every)) * w * h * 3 > KEEP_BYTES:
        return frames
    keep.clear()
    keep[sample] = list(frames)
    return keep[sample]


#: Working px by which a registered frame may sit off the background (the registration's
#: residual; ECC runs on a copy at most 400 px wide): a background edge within it is not
#: foreground (``ClassicalConfig.shift_px``).  Without it the moved fly clip's hole grid
#: gave 110-262 speck tracks; with it, the same frames are refused (no animal moves).
REGISTERED_SHIFT_PX = 1


#: Why thin lines may be found on a registered source (appended to the refusal).
_EDGES_NOTE = (
    " (the camera moved: edges that its registration leaves look like this, "
    "and animals that do not move are not found)"
)


def _not_lines(src: Any, est: Any, registered: bool) -> None:
    """:class:`InputError` when the measured blobs (``est``) are thin lines, not animals."""
    if est.fill < MIN_FILL:
        raise InputError(
            f"{src.path}: the moving things are thin lines, not animals: their blobs "
            f"fill {est.fill:.2f} of their length squared (an animal's 0.25-0.5); a "
            f"plot or a drawing has nothing to track{_EDGES_NOTE if registered else ''}; give "
            "--px-per-mm to track anyway"
        )


def build_detector(
    src: Any,
    n_prep: int,
    *,
    px_per_mm: float | None,
    detector: str | None,
    model: str | os.PathLike | None,
    options: dict[str, Any] | None,
    step: int | None = None,
    max_frames: int | None = None,
    spread: bool = True,
    scene_end: int | None = None,
) -> tuple[Any, dict[str, Any]]:
    """The detector for video ``src``, prepared on as many frames as ``n_prep`` of its
    first frames taken every ``step``-th (default every other from 32 frames, else
    all): with ``spread``, on a clip at least twice that long, those frames spread
    evenly over the clip (below ``max_frames``, and over its first scene: below
    ``scene_end``, the first frame after a scene cut; a registered clip only where
    its first frames show no moving animal); else its first frames, or, when those
    show no moving animal, the first window of as many frames further into the clip
    that does (:func:`_samples`).

    Without a scale the animals' body length is measured first from the same frames
    (:func:`~thermoswarm.tracking.detect.size.estimate_length_px`, with the classical
    detector's options when the detector is the classical one) and the detector is
    built at the scale that makes the paper's ant that long.  Returns the detector
    and ``{"px_per_mm", "length_px", "scale_source", "n_blobs", "prepare_frames"}``
    (``px_per_mm`` the scale used, ``length_px`` the body length in px,
    ``prepare_frames`` the 1-based first and last frame the detector learned from and
    ``prepare_step`` the frames between them; for the classical detector, where the
    size was measured, ``moved_length_px`` and ``picture_length_px``: what moved, and
    the same blobs in the picture, :class:`SizeEstimate`'s ``length_px`` and
    ``look_px``; and ``background``: :func:`_choose_background`).
    """
    step = step or (2 if n_prep >= 32 else 1)
    info: dict[str, Any] = {"scale_source": "user", "n_blobs": None}
    classical = (detector or ("classical" if model is None else "")) == "classical"
    registered = isinstance(src, RegisteredSource)
    if classical and registered and "shift_px" not in (options or {}):
        options = {**(options or {}), "shift_px": REGISTERED_SHIFT_PX}
    reach = (scene_end or np.iinfo(np.int64).max) if spread else None
    # A registered clip tries its first window first: frames close in time share the
    # registration's small errors; frames spread over it carry different ones into one
    # background (SLEAP's flies walking, moved: 0.936 of the still clip's points found
    # again from the first window, 0.648 from the spread sample).  Its spread sample
    # comes next, where the first window shows no moving animal (the whole moved fly
    # clip, its flies still for 33 s, at its scale: MOTA 0.315 from a later window in a
    # scratch run, 0.999 from the spread sample: benchmarks/bench_registration.py whole).
    at = int(registered)
    samples, total = _samples(src, n_prep, step, max_frames, reach, at)
    sample, keep = samples[0], {}  # keep: the measured sample's frames, decoded once
    est = None
    if px_per_mm is None:
        opts = options if classical else None
        est, sample = _measure_size(src, samples, total, n_prep, opts, keep)
        _not_lines(src, est, registered)
        info.update(scale_source="measured", n_blobs=est.n_blobs)
    elif not (px_per_mm > 0 and np.isfinite(px_per_mm)):
        raise InputError(f"px_per_mm must be a positive number, got {px_per_mm!r}")
    elif classical and len(samples) > 1 and (options or {}).get("background") != "picture":
        # With a scale too, the background comes from the first sample where animals
        # move: from frames without one the threshold comes from the floor's noise
        # alone (beelab ROI_1 at 0.94 px/mm, its first ant after 11 s: 64 tracks from
        # the first 3 s, 1 from the spread sample, 4 from the window where ants walk).
        # ... and moving specks are not animals where the scale says how long they are.
        # Not for a picture background, which needs no moving animal (19 s of 22 here).
        expect = anatomy.ANT_LENGTH_MM * px_per_mm
        with contextlib.suppress(InputError):  # nothing moves anywhere: detect says so
            est, sample = _measure_size(src, samples, total, n_prep, options, keep, expect)
    if classical:
        options, px_per_mm = _choose_background(est, options, px_per_mm, info)
    elif est is not None and px_per_mm is None:
        px_per_mm = est.length_px / anatomy.ANT_LENGTH_MM
    det = make_detector(detector, px_per_mm=px_per_mm, model=model, options=options)
    if hasattr(det, "prepare"):
        det.prepare(_read(src, sample, keep))
    info.update(px_per_mm=float(px_per_mm), length_px=float(anatomy.ANT_LENGTH_MM * px_per_mm))
    start, stop, every = sample
    info.update(prepare_frames=[start + 1, stop], prepare_step=every)
    return det, info


def _choose_background(
    est: Any, options: dict[str, Any] | None, px_per_mm: float | None, info: dict[str, Any]
) -> tuple[dict[str, Any], float]:
    """The classical detector's options and scale after the size measurement ``est``
    (None where none was made; then ``px_per_mm`` is the user's): ``background``
    ``"picture"`` where the animals stood nearly still in the measured frames
    (:attr:`~thermoswarm.tracking.detect.size.SizeEstimate.stood_still`) and the user
    did not choose; without a scale, the body length for that background
    (:meth:`~thermoswarm.tracking.detect.size.SizeEstimate.length_for`).  ``info``
    gets ``background``, ``moved_length_px`` and ``picture_length_px``."""
    opts = dict(options or {})
    if est is not None:  # what moved, and the same blobs in the picture
        info.update(moved_length_px=est.length_px, picture_length_px=est.look_px)
        if est.stood_still and "background" not in opts:
            # Only the still animals' moving parts differ from a background learned
            # over time; each frame's own surroundings hold none of them (SLEAP's
            # flies nearly still for 6 s: 2 tracks, every fly point found, against 6
            # tracks of pieces).
            opts["background"] = "picture"
        if px_per_mm is None:
            px_per_mm = est.length_for(opts.get("background", "time")) / anatomy.ANT_LENGTH_MM
    info["background"] = opts.get("background", "time")
    assert px_per_mm is not None
    return opts, px_per_mm


def _detector_info(det: Any, options: dict[str, Any] | None) -> dict[str, Any]:
    info: dict[str, Any] = {"options": dict(options or {})}
    for attr in ("threshold", "single_area", "length_px", "widening_px"):
        if hasattr(det, attr):
            info[attr] = getattr(det, attr)
    if dataclasses.is_dataclass(getattr(det, "config", None)):
        info["config"] = to_dict(det.config)
    return info


def _summary(
    result: TrackResult,
    *,
    source: str,
    fps: float,
    fps_source: str,
    px_per_mm: float | None,
    tracker: TrackerConfig,
    detector: str | None,
    model: Any,
    n_det: int,
    elapsed: float,
    prepare: float,
    size: tuple[int, int] | None,
    outputs: list[str],
    detector_options: dict[str, Any] | None,
) -> dict[str, Any]:
    n = max(result.n_frames, 1)
    return {
        "source": source,
        "n_frames": result.n_frames,
        "fps": fps,
        "fps_source": fps_source,
        "px_per_mm": px_per_mm,
        "frame_size": list(size) if size else None,
        "detector": detector,
        "model": None if model is None else str(model),
        "n_detections": n_det,
        "detections_per_frame": n_det / n,
        "n_tracks": result.n_tracks,
        "n_rows": int(result.frames.size),
        "n_interpolated": int(result.interpolated.sum()),
        "seconds": elapsed,
        "prepare_seconds": prepare,
        "frames_per_second": result.n_frames / elapsed if elapsed > 0 else None,
        "tracker": to_dict(tracker),
        "detector_info": detector_options,
        "outputs": outputs,
    }
