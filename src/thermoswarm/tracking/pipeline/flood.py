"""Never a silent flood: detections that are not animals are named, not written quietly.

A detector that subtracts a still background turns a moving ground, flickering
texture or the lines of a plot into thousands of "animals".  :func:`flood_reasons`
checks a run's output against what animals can be:

* **crowding** -- the median frame holds more detections than the image can hold at
  the measured size: their bodies (``length x 0.35 length``, the paper's ant's
  proportions) would cover over ``max_cover`` of the frame;
* **stillness** (for detectors that subtract a background; ``result`` given) --
  among at least ``min_tracks`` confirmed tracks, fewer than ``min_moving`` of them
  ever get one body length from where they began (animals that a background
  subtraction finds are the ones that move: 70 % of the tracks of the rendered test
  clip; glitter that flickers in place: 6-8 %).

:func:`refuse_flood` then raises :class:`~thermoswarm.errors.InputError` with the
reasons and what to try, after the outputs are written with ``WARNING.txt`` beside
them (so the user can look), and the CLI exits with status 2.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.errors import InputError
from thermoswarm.fsutil import atomic_write_text
from thermoswarm.tracking import anatomy

__all__ = ["flood_reasons", "refuse_flood", "FLOOD_HINT"]

#: What to try when the output is not animals.
FLOOD_HINT = (
    "what to try: look at the overlay or detections; a camera that moves is registered "
    "by default (camera='auto'; see camera_path.csv), a video with no animals has "
    "nothing to find, a measured size far from the animals' calls for --px-per-mm"
)


def _moving_share(result: Any, length_px: float) -> tuple[float, int]:
    """``(share, n)``: of the ``n`` tracks, the share that get one body length (px)
    from where they began."""
    ids, body = result.ids, result.points[:, 1, :]
    if ids.size == 0:
        return 1.0, 0
    order = np.argsort(ids, kind="stable")
    ids, body = ids[order], body[order]
    uniq, start = np.unique(ids, return_index=True)
    first = body[start]
    runs = np.diff(np.append(start, ids.size))
    d = np.linalg.norm(body - np.repeat(first, runs, axis=0), axis=1)
    reach = np.zeros(uniq.size)
    np.maximum.at(reach, np.searchsorted(uniq, ids), np.nan_to_num(d))
    return float(np.mean(reach >= length_px)), int(uniq.size)


def flood_reasons(
    per_frame: np.ndarray,
    frame_size: tuple[int, int],
    length_px: float,
    result: Any | None = None,
    *,
    max_cover: float = 0.5,
    min_tracks: int = 20,
    min_moving: float = 0.2,
) -> list[str]:
    """Why the detections (``per_frame``: counts per frame) and tracks (``result``, a
    :class:`~thermoswarm.tracking.track.result.TrackResult` in px, or ``None``) are not
    animals of body length ``length_px`` in a ``frame_size`` (w, h px) image; empty
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
    if result is not None:
        share, nt = _moving_share(result, length_px)
        if nt >= min_tracks and share < min_moving:
            reasons.append(
                f"only {100 * share:.1f} % of {nt} tracks ever move one body length "
                f"({length_px:.1f} px) from where they began: they do not move like animals"
            )
    return reasons


def refuse_flood(source: str, out: Path, reasons: list[str]) -> None:
    """Write ``WARNING.txt`` in ``out`` and raise :class:`InputError` naming ``reasons``."""
    text = f"{source}: the detections are not animals: " + "; ".join(reasons)
    atomic_write_text(out / "WARNING.txt", text + "\n" + FLOOD_HINT + "\n")
    raise InputError(f"{text}; outputs kept in {out} for a look (WARNING.txt); {FLOOD_HINT}")
