"""Never a silent flood: detections that are not animals are named, not written quietly.

A detector that subtracts a still background turns a moving ground, flickering
texture or the lines of a plot into thousands of "animals".  :func:`flood_reasons`
checks a run's output against what animals can be:

* **crowding** -- the median frame holds more detections than the image can hold at
  the measured size: their bodies (``length x 0.35 length``, the paper's ant's
  proportions) would cover over ``max_cover`` of the frame;
* **flicker** (for detectors that subtract a background; ``dets`` given) -- of at
  least ``min_dets`` detections, more than ``max_in_place`` lie where a detection lay
  one second before, and more than ``min_gone`` of those were gone from that place
  halfway between (specks that flicker in place come and go at their places; an
  animal that stands still, found because it moves some other time of the clip, stays
  found: SLEAP's fly clip, 90 % in place, 0 % gone; glitter shown in half the frames,
  86 % and 13 %).  Measured on the detections, not on tracks: the tracker's gate, made
  for an ant's real speed, links neighbouring specks into tracks that seem to walk.

:func:`refuse_flood` then raises :class:`~thermoswarm.errors.InputError` with the
reasons and what to try, after the outputs are written with ``WARNING.txt`` beside
them (so the user can look), and the CLI exits with status 2.

Nor a silent empty result: when detections were found but no track was confirmed,
:func:`no_track_warning` says why (detections, frames, the confirmation needed) and
what to try; the outputs are written with it in ``WARNING.txt`` and
``summary.json``'s ``warnings``, and the CLI prints it on stderr (exit status 0).

Nor animals quietly lost in the background: where a background-subtracting detector's
tracks hold, on average over the frames, under ``FEW_FOUND`` of the most animals
tracked at once (:func:`few_found_warning`), and the tracks begin and end inside the
picture (not animals walking through it), the animals may have stood still part of the time;
the warning names ``--set detector.background=picture`` (each frame against its own
surroundings) and ``--detector self-trained``, which find them moving or not.
Where they stood nearly still in the very frames the background was learned from (they
look much longer in the picture than what moved), the pipeline compares each frame with
its own spatial background instead, and :func:`still_look_warning` says so; the
flicker check is then skipped (such a detector finds what stands still).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.errors import InputError
from thermoswarm.fsutil import atomic_write_text
from thermoswarm.tracking import anatomy
from thermoswarm.tracking.detect.size import looks_still

__all__ = [
    "flood_reasons",
    "refuse_flood",
    "no_track_warning",
    "warn_no_track",
    "few_found_warning",
    "inner_ends",
    "most_at_once",
    "FLOOD_HINT",
]

#: Animals tracked per frame, as a share of the most tracked at once (in 5 frames or
#: more), under which :func:`few_found_warning` speaks (SLEAP's fly clip: 0.09 over
#: its first 1,100 frames, where the flies stand still until frame 1,000; 1.00 over
#: all 1,500; a beelab trail clip, ants passing through: 0.03, but its tracks begin and
#: end at the picture's edges).
FEW_FOUND = 0.5

#: What to try when the output is not animals.
FLOOD_HINT = (
    "what to try: look at the overlay or detections; a camera that moves is registered "
    "by default (camera='auto'; see camera_path.csv), a video with no animals has "
    "nothing to find, a measured size far from the animals' calls for --px-per-mm"
)


def _in_place_share(dets: np.ndarray, length_px: float, fps: float) -> tuple[float, float, int]:
    """``(share, gone, n)``: of the ``n`` detections that have a frame one second before
    them, the ``share`` that lie within ``0.3`` body length (px) of a detection there
    (or a frame either side); of those, the share ``gone`` from that place in the frame
    halfway between (no detection within ``0.3`` body length there or a frame either
    side).

    Measured on the detections, not on tracks: a tracker that allows an ant's real
    speed will link specks that flicker in place into tracks that seem to walk.  An
    animal that stands still is found in place in every frame (``gone`` near 0, the
    detector's misses); a speck that flickers comes and goes (glitter shown in half the
    frames: ``gone`` about 0.1, three frames all dark).
    ``dets`` are MOT rows (frame, id, left, top, width, height, ...).
    """
    from scipy.spatial import cKDTree

    frame = dets[:, 0].astype(np.int64)
    centre = dets[:, 2:4] + 0.5 * dets[:, 4:6]
    lag = max(1, int(round(fps)))
    first, last = (int(frame.min()), int(frame.max())) if frame.size else (0, -1)
    starts = np.searchsorted(frame, np.arange(first, last + 2))  # rows are in frame order
    reach = 0.3 * length_px

    def near(f: int) -> np.ndarray:  # the centres of frames f - 1 .. f + 1
        return centre[starts[max(f - 1 - first, 0)] : starts[min(f + 2 - first, last + 1 - first)]]

    hits = gone = n = 0
    for f in range(first + lag + 1, last + 1, max(1, (last - first) // 200)):
        here = centre[starts[f - first] : starts[f - first + 1]]
        before = near(f - lag)
        if len(here) and len(before):
            d, _ = cKDTree(before).query(here, distance_upper_bound=reach)
            kept = here[np.isfinite(d)]
            hits += len(kept)
            mid = near(f - lag // 2) if lag >= 2 else kept
            if len(kept) and len(mid):
                d, _ = cKDTree(mid).query(kept, distance_upper_bound=reach)
                gone += int(np.isinf(d).sum())
            else:
                gone += len(kept)
        n += len(here)
    return (hits / n if n else 0.0), (gone / hits if hits else 0.0), n


def flood_reasons(
    per_frame: np.ndarray,
    frame_size: tuple[int, int],
    length_px: float,
    dets: np.ndarray | None = None,
    *,
    fps: float = 10.0,
    max_cover: float = 0.5,
    min_dets: int = 200,
    max_in_place: float = 0.8,
    min_gone: float = 0.05,
) -> list[str]:
    """Why the detections (``per_frame``: counts per frame; ``dets``: their MOT rows in
    frame order, px, or ``None`` to skip the flicker check) are not animals of body
    length ``length_px`` in a ``frame_size`` (w, h px) image at ``fps`` frames/s; empty
    when they may be."""
    reasons = []
    w, h = frame_size
    body = length_px * length_px * anatomy.ANT_WIDTH_MM / anatomy.ANT_LENGTH_MM
    n = float(np.median(per_frame)) if len(per_frame) else 0.0
    cover = n * body / (w * h)
    if cover > max_cover:
        reasons.append(
            f"{n:.0f} detections a frame at a body length of {length_px:.1f} px would cover "
            f"{100 * cover:.0f} % of the image (more than {100 * max_cover:.0f} % cannot "
            "be animals)"
        )
    if dets is not None:
        share, gone, nd = _in_place_share(dets, length_px, fps)
        if nd >= min_dets and share > max_in_place and gone > min_gone:
            reasons.append(
                f"{100 * share:.1f} % of {nd} detections lie where a detection lay one "
                f"second before (within 0.3 body length, {0.3 * length_px:.1f} px) and "
                f"{100 * gone:.0f} % of those were gone from there halfway between: they "
                "flicker in place, they do not move like animals"
            )
    return reasons


def refuse_flood(source: str, out: Path, reasons: list[str]) -> None:
    """Write ``WARNING.txt`` in ``out`` and raise :class:`InputError` naming ``reasons``."""
    text = f"{source}: the detections are not animals: " + "; ".join(reasons)
    atomic_write_text(out / "WARNING.txt", text + "\n" + FLOOD_HINT + "\n")
    raise InputError(f"{text}; outputs kept in {out} for a look (WARNING.txt); {FLOOD_HINT}")


def no_track_warning(
    per_frame: np.ndarray,
    fps: float,
    confirm_s: float,
    n_init: int,
    tentative_gap: int,
    *,
    video: bool = True,
) -> str:
    """One paragraph: why no track was confirmed from the detections counted per frame
    in ``per_frame`` at ``fps`` frames/s, when a track needs ``n_init`` detections
    (``confirm_s`` s) with at most ``tentative_gap`` missed frames between them; and
    what to try (for a video, or for a detections file when ``video`` is false)."""
    per_frame = np.asarray(per_frame)
    n_frames, n_det = len(per_frame), int(per_frame.sum())
    seen = int(np.count_nonzero(per_frame))
    gap = f"at most {tentative_gap} missed frame" + "s" * (tentative_gap > 1)
    gap = gap if tentative_gap else "no missed frame"
    text = (
        f"no track was confirmed, so tracks.nc holds no individuals: {n_det} detections in "
        f"{n_frames} frames ({seen} frames with any) at {fps:g} frames/s, and a track is "
        f"confirmed once one animal is detected {n_init} times (tracker.confirm_s = "
        f"{confirm_s:g} s = {n_init} detections at {fps:g} frames/s, with {gap} between "
        "them)"
    )
    if n_frames < n_init:
        text += f"; the run has fewer frames ({n_frames}) than that"
    more = f"more frames (at least {n_init}{'; --max-frames' if video else ''})"
    look = (
        "if the animals are missed or scattered (look at detections.txt and overlay.mp4), "
        "the detector's options (--set detector.threshold=..., detector.polarity, "
        "detector.channel) or --px-per-mm"
        if video
        else "if the boxes are few or scattered, the detector that made them, or "
        "--object-size-px (the tracker's body length)"
    )
    return (
        f"{text}. What to try: {more}, --set tracker.confirm_s=0 (confirm a track at its "
        "first detection), --set tracker.tentative_gap_s=0.2 (let a new track miss "
        f"frames); {look}."
    )


def warn_no_track(
    n_tracks: int, per_frame: np.ndarray, fps: float, cfg: Any, out: Path, *, video: bool = True
) -> list[str]:
    """``[]``, or where no track was confirmed (``n_tracks`` 0), :func:`no_track_warning`'s
    paragraph for the tracker's config ``cfg`` at ``fps`` frames/s, also written to
    ``out/WARNING.txt`` (removed when tracks were found: an earlier run's)."""
    if n_tracks:
        (out / "WARNING.txt").unlink(missing_ok=True)  # an earlier run's
        return []
    text = no_track_warning(
        per_frame, fps, cfg.confirm_s, cfg.n_init(fps), cfg.tentative_max_misses(fps), video=video
    )
    atomic_write_text(out / "WARNING.txt", text + "\n")
    return [text]


def add_warning(out: Path, text: str | None) -> list[str]:
    """``[text]`` appended to ``out/WARNING.txt`` (``[]`` for None)."""
    if text is None:
        return []
    old = (out / "WARNING.txt").read_text() if (out / "WARNING.txt").is_file() else ""
    atomic_write_text(out / "WARNING.txt", old + text + "\n")
    return [text]


def still_look_warning(scale: dict[str, Any]) -> str | None:
    """The warning for a classical detector's run whose animals look more than
    :data:`~thermoswarm.tracking.detect.size.STILL_LOOK` times longer in the picture
    (``scale["picture_length_px"]``) than what moved in the frames its background was
    learned from (``scale["moved_length_px"]``, ``scale["prepare_frames"]``): what was
    done about it (``scale["background"]``, ``"picture"`` when the pipeline compared
    each frame with its own surroundings instead), or what to do; ``None`` otherwise."""
    moved, look = scale.get("moved_length_px"), scale.get("picture_length_px")
    if not looks_still(look, moved):
        return None
    first, last = scale.get("prepare_frames") or ("?", "?")
    said = (
        f"the animals look {look:.0f} px long in the picture, {look / moved:.1f} times the "
        f"{moved:.1f} px of what moved in frames {first}-{last}, where the background was "
        "learned: they stood nearly still there, so only their moving parts (legs, "
        "wings, antennae) differ from it"
    )
    if scale.get("background") == "picture":
        return (
            f"{said}. Each frame was compared with its own surroundings "
            f"(detector.background=picture, body length {scale['length_px']:.0f} px): "
            "animals are found whether they move or not, and so is any still thing of "
            "their size that stands out of its surroundings (specks, small objects); "
            "check the overlay. --set detector.background=time keeps the background "
            "learned over time"
        )
    return (
        f"{said}, and the body length, the detections and the tracks may be pieces of "
        "animals. --set detector.background=picture compares each frame with its own "
        "surroundings instead (animals found whether they move or not); or track a "
        "stretch where they walk"
    )


def most_at_once(counts: np.ndarray, min_frames: int = 5) -> int:
    """The largest of the per-frame ``counts`` reached in ``min_frames`` frames or more
    (0 when none is): the animals' number, not a moment's extra blobs."""
    reached = np.bincount(np.asarray(counts, np.int64))
    often = np.flatnonzero(reached[1:] >= min_frames) + 1 if reached.size > 1 else []
    return int(often[-1]) if len(often) else 0


def inner_ends(
    ids: np.ndarray, frames: np.ndarray, body: np.ndarray, size: tuple[int, int], length: float
) -> float:
    """Share of the tracks' first and last detected body points ``body`` ``(n, 2)`` (rows
    of track ``ids`` at ``frames``) more than a body ``length`` from the edges of a frame
    of ``size`` (w, h): where animals appear and vanish inside the picture rather than
    walk in and out of it."""
    order = np.lexsort((frames, ids))
    ids, body = ids[order], body[order]
    new = np.r_[True, ids[1:] != ids[:-1]]
    ends = np.concatenate([body[new], body[np.r_[new[1:], True]]])
    w, h = size
    margin = np.minimum.reduce([ends[:, 0], ends[:, 1], w - ends[:, 0], h - ends[:, 1]])
    return float(np.mean(margin > length)) if ends.size else 0.0


def few_found_warning(per_frame: np.ndarray, inner: float = 1.0) -> str | None:
    """The warning for a background-subtracting detector's run whose ``per_frame``
    counts of tracked animals (detected there, not interpolated) average under
    :data:`FEW_FOUND` of the most tracked at once (the largest count reached in 5
    frames or more), where at least half of the tracks begin and end inside the picture
    (``inner``: :func:`inner_ends`; animals that walk in and out of it, as on a trail,
    are not lost); ``None`` otherwise."""
    top, mean = most_at_once(per_frame), float(np.mean(per_frame))
    if inner < 0.5 or top == 0 or mean >= FEW_FOUND * top:
        return None
    return (
        f"the tracks hold {mean:.2f} animals a frame on average, while up to {top} "
        f"were tracked at once ({mean / top:.0%}): the detector finds what moves, so "
        "animals that stood still part of the time became the background then (the "
        "tracks begin and end inside the picture). If they were there, `--set "
        "detector.background=picture` compares each frame with its own surroundings "
        "instead and finds them moving or not, in about the same time (and any still "
        "thing of their size that stands out of its surroundings: check the overlay); "
        "`--detector self-trained` learns their look from the frames where they moved "
        "(a U-Net trained on this video; about a minute of training on 2 cores)"
    )
