"""MOTChallenge text files: ``frame, id, bb_left, bb_top, bb_width, bb_height, conf, x, y, z``.

Frames are 1-based; ground-truth files use ``conf`` as the "consider" flag and may
carry class and visibility in columns 8-9; detection files have ``id = -1``.

The table functions (:func:`read_mot_table`, :func:`write_mot_table`) keep the raw
rows for tracking and evaluation; :func:`read` and :func:`write` convert between
box centres and the trajectory format.
"""

from __future__ import annotations

import io as _io
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.errors import InputError
from thermoswarm.fsutil import atomic_write_text
from thermoswarm.io._common import (
    DUPLICATES_HELP,
    MAX_FRAMES,
    assemble_long,
    check_frame_span,
    check_integers,
    check_options,
    option_duplicates,
    require_fps,
)
from thermoswarm.tracks import centroid, make_tracks

__all__ = ["MAX_FRAMES", "read", "read_mot_table", "tracks_from_table", "write", "write_mot_table"]

OPTIONS: dict[str, str] = {"duplicates": DUPLICATES_HELP}
NEEDS = "--fps and --px-per-mm (frame numbers and pixel boxes)"

#: Column names of a MOT row.
COLUMNS = ("frame", "id", "bb_left", "bb_top", "bb_width", "bb_height", "conf", "x", "y", "z")


def sniff(path: Path) -> bool:
    try:
        with open(path, encoding="utf-8") as fh:
            line = fh.readline()
    except (UnicodeDecodeError, OSError):
        return False
    parts = [p for p in line.replace(",", " ").split() if p]
    if len(parts) < 6:
        return False
    try:
        [float(p) for p in parts]
    except ValueError:
        return False
    return True


def read_mot_table(
    path: str | Path, *, allow_empty: bool = False, min_frame: int = 1
) -> np.ndarray:
    """Rows of a MOT file as a float array ``(n, 10)``; missing trailing columns are -1.

    Frame numbers must be integers ``>= min_frame`` (MOTChallenge counts from 1; pass
    0 to accept 0-based files) spanning at most :data:`MAX_FRAMES` frames, ids must be
    integers (1.5 is an error naming the line, not track 1); box widths
    and heights must not be negative.  Raises :class:`InputError` naming the file and
    line for a malformed row, and for an empty file unless ``allow_empty``.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except (UnicodeDecodeError, IsADirectoryError):
        raise InputError(f"{path}: not a MOTChallenge text file") from None
    rows = []
    lines = []
    for lineno, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        parts = [p for p in line.replace(",", " ").split() if p]
        if len(parts) < 6 or len(parts) > 10:
            raise InputError(
                f"{path}:{lineno}: expected 6 to 10 comma-separated numbers "
                f"(frame, id, left, top, width, height, ...), got {len(parts)}"
            )
        try:
            vals = [float(p) for p in parts]
        except ValueError:
            raise InputError(f"{path}:{lineno}: non-numeric value in {line[:60]!r}") from None
        vals += [-1.0] * (10 - len(vals))
        if len(parts) == 6:
            vals[6] = 1.0
        rows.append(vals)
        lines.append(lineno)
    if not rows:
        if allow_empty:
            return np.zeros((0, 10))
        raise InputError(f"{path}: empty MOTChallenge file (no rows)")
    table = np.asarray(rows, dtype=np.float64)
    at = np.asarray(lines)

    def first(bad: np.ndarray) -> int:
        return int(at[int(np.argmax(bad))])

    bad = ~np.all(np.isfinite(table[:, :6]), axis=1)
    if bad.any():
        raise InputError(f"{path}:{first(bad)}: non-finite frame, id or box value")
    f = table[:, 0]
    bad = (f < min_frame) | (f != np.round(f))
    if bad.any():
        base = "1-based" if min_frame == 1 else f"counted from {min_frame}"
        raise InputError(
            f"{path}:{first(bad)}: frame number {f[np.argmax(bad)]:g} is not an integer "
            f">= {min_frame} (MOT frames are {base})"
        )
    check_frame_span(path, f)
    # an id of 1.5 would be truncated to 1 and overwrite track 1
    check_integers(path, table[:, 1], "id", at)
    bad = (table[:, 4] < 0) | (table[:, 5] < 0)
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(
            f"{path}:{first(bad)}: negative box width or height "
            f"({table[i, 4]:g} x {table[i, 5]:g})"
        )
    return table


def write_mot_table(path: str | Path, table: np.ndarray) -> None:
    """Write rows ``(n, >=6)`` as a MOT file, atomically (frame and id as integers)."""
    table = np.asarray(table, dtype=np.float64)
    if table.ndim != 2 or table.shape[1] < 6:
        raise ValueError(f"MOT table must have shape (n, >=6), got {table.shape}")
    if table.shape[1] < 10:
        pad = np.full((table.shape[0], 10 - table.shape[1]), -1.0)
        if table.shape[1] <= 6:
            pad[:, 0] = 1.0
        table = np.hstack([table, pad])
    order = np.lexsort((table[:, 1], table[:, 0]))
    buf = _io.StringIO()
    for r in table[order]:
        buf.write(
            f"{int(r[0])},{int(r[1])},{r[2]:.3f},{r[3]:.3f},{r[4]:.3f},{r[5]:.3f},"
            f"{r[6]:.4g},{r[7]:.4g},{r[8]:.4g},{r[9]:.4g}\n"
        )
    atomic_write_text(path, buf.getvalue())


def tracks_from_table(
    table: np.ndarray,
    *,
    fps: float,
    px_per_mm: float,
    source_file: str | None = None,
    duplicates: str = "error",
) -> xr.Dataset:
    """Box centres of a MOT table as trajectories (frame ``f`` -> time ``(f - 1) / fps``).

    Rows of one id in one frame are resolved as in every long-table reader
    (:func:`~thermoswarm.io._common.assemble_long`): exact duplicates are dropped, other
    boxes are an error (or ``duplicates="first"``/``"mean"``), and both are counted in
    ``attrs``.
    """
    path = Path(source_file) if source_file is not None else Path("MOT table")
    ids = table[:, 1].astype(np.int64)
    uid = np.unique(ids)
    parts = assemble_long(
        path,
        individual=np.asarray([f"id_{i}" for i in ids], dtype=object),
        time=table[:, 0],
        x=(table[:, 2] + table[:, 4] / 2) / px_per_mm,
        y=(table[:, 3] + table[:, 5] / 2) / px_per_mm,
        confidence=np.clip(table[:, 6], 0, 1),
        individual_order=[f"id_{i}" for i in uid],
        frame_rate=fps,
        duplicates=duplicates,
    )
    frames = np.rint(parts["time"] * fps)  # MOT's frame numbers, 1-based
    return make_tracks(
        parts["position"],
        time=(frames - 1) / fps,
        fps=fps,
        individuals=parts["individuals"],
        confidence=parts["confidence"],
        source_software="MOTChallenge",
        source_file=source_file,
        attrs={"px_per_mm": px_per_mm, **parts["attrs"]},
    )


def read(
    path: Path, *, fps: float | None = None, px_per_mm: float | None = None, **options: Any
) -> xr.Dataset:
    check_options(path, "mot", options, OPTIONS)
    rule = option_duplicates(path, options)
    rate = require_fps(path, fps, "a MOTChallenge file")
    if px_per_mm is None:
        raise InputError(
            f"{path}: MOTChallenge boxes are in pixels; pass --px-per-mm "
            "(the paper's scale is --px-per-mm paper = 3.04)"
        )
    table = read_mot_table(path)
    if np.any(table[:, 1] < 0):
        raise InputError(f"{path}: rows with id -1 are detections, not tracks")
    return tracks_from_table(
        table, fps=rate, px_per_mm=px_per_mm, source_file=str(path), duplicates=rule
    )


def table_from_tracks(
    ds: xr.Dataset, *, px_per_mm: float | None = None, box_size_px: float = 20.0
) -> np.ndarray:
    """Rows of a MOT table with a square box of ``box_size_px`` around each centroid."""
    from thermoswarm.io._scale import resolve_px_per_mm

    scale = px_per_mm if px_per_mm is not None else ds.attrs.get("px_per_mm")
    if scale is None:
        raise InputError("writing MOTChallenge needs px_per_mm (boxes are in pixels)")
    scale = resolve_px_per_mm(scale)
    size = box_size_px
    if isinstance(size, bool) or not isinstance(size, int | float) or not 0 < size <= 1e6:
        raise InputError(f"box_size_px must be a number above 0 and at most 1e6, got {size!r}")
    c = centroid(ds).transpose("time", "space", "individuals").values * float(scale)
    fps = ds.attrs.get("fps")
    if fps is not None and ds.attrs.get("time_unit") == "seconds":
        frames = np.rint(ds["time"].values * fps).astype(np.int64) + 1
    else:
        frames = np.arange(ds.sizes["time"]) + 1
    t_idx, i_idx = np.nonzero(np.all(np.isfinite(c), axis=1))
    half = box_size_px / 2
    rows = np.empty((t_idx.size, 10))
    rows[:, 0] = frames[t_idx]
    rows[:, 1] = i_idx + 1
    rows[:, 2] = c[t_idx, 0, i_idx] - half
    rows[:, 3] = c[t_idx, 1, i_idx] - half
    rows[:, 4] = box_size_px
    rows[:, 5] = box_size_px
    if "confidence" in ds:
        conf = ds["confidence"].mean("keypoints").transpose("time", "individuals").values
        rows[:, 6] = np.nan_to_num(conf[t_idx, i_idx], nan=1.0)
    else:
        rows[:, 6] = 1.0
    rows[:, 7:] = -1
    return rows


def write(
    ds: xr.Dataset, path: Path, *, px_per_mm: float | None = None, box_size_px: float = 20.0
) -> None:
    write_mot_table(path, table_from_tracks(ds, px_per_mm=px_per_mm, box_size_px=box_size_px))
