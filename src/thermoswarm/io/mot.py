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
from thermoswarm.tracks import centroid, make_tracks

OPTIONS: dict[str, str] = {}
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


#: The longest frame range a MOT file may span (10 million frames: 3.9 days at 30 fps);
#: a larger one is refused before anything is allocated for it.
MAX_FRAMES = 10_000_000


def read_mot_table(
    path: str | Path, *, allow_empty: bool = False, min_frame: int = 1
) -> np.ndarray:
    """Rows of a MOT file as a float array ``(n, 10)``; missing trailing columns are -1.

    Frame numbers must be integers ``>= min_frame`` (MOTChallenge counts from 1; pass
    0 to accept 0-based files) spanning at most :data:`MAX_FRAMES` frames; box widths
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
    span = f.max() - f.min() + 1
    if span > MAX_FRAMES:
        raise InputError(
            f"{path}: frames {f.min():.0f} to {f.max():.0f} span {span:,.0f} frames, "
            f"more than the {MAX_FRAMES:,} accepted"
        )
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
    table: np.ndarray, *, fps: float, px_per_mm: float, source_file: str | None = None
) -> xr.Dataset:
    """Box centres of a MOT table as trajectories (frame ``f`` -> time ``(f - 1) / fps``)."""
    frames = table[:, 0].astype(np.int64)
    ids = table[:, 1].astype(np.int64)
    f0, f1 = frames.min(), frames.max()
    uid, col = np.unique(ids, return_inverse=True)
    pos = np.full((f1 - f0 + 1, 2, 1, uid.size), np.nan)
    conf = np.full((f1 - f0 + 1, 1, uid.size), np.nan, dtype=np.float32)
    row = frames - f0
    pos[row, 0, 0, col] = (table[:, 2] + table[:, 4] / 2) / px_per_mm
    pos[row, 1, 0, col] = (table[:, 3] + table[:, 5] / 2) / px_per_mm
    conf[row, 0, col] = np.clip(table[:, 6], 0, 1)
    t = (np.arange(f0, f1 + 1) - 1) / fps
    return make_tracks(
        pos,
        time=t,
        fps=fps,
        individuals=[f"id_{i}" for i in uid],
        confidence=conf,
        source_software="MOTChallenge",
        source_file=source_file,
        attrs={"px_per_mm": px_per_mm},
    )


def read(
    path: Path, *, fps: float | None = None, px_per_mm: float | None = None, **options: Any
) -> xr.Dataset:
    if options:
        raise InputError(f"{path}: mot reader takes no options, got {sorted(options)}")
    if fps is None:
        raise InputError(f"{path}: MOTChallenge files have frame numbers only; pass --fps")
    if px_per_mm is None:
        raise InputError(
            f"{path}: MOTChallenge boxes are in pixels; pass --px-per-mm "
            "(the paper's scale is --px-per-mm paper = 3.04)"
        )
    table = read_mot_table(path)
    if np.any(table[:, 1] < 0):
        raise InputError(f"{path}: rows with id -1 are detections, not tracks")
    return tracks_from_table(table, fps=fps, px_per_mm=px_per_mm, source_file=str(path))


def table_from_tracks(
    ds: xr.Dataset, *, px_per_mm: float | None = None, box_size_px: float = 20.0
) -> np.ndarray:
    """Rows of a MOT table with a square box of ``box_size_px`` around each centroid."""
    scale = px_per_mm if px_per_mm is not None else ds.attrs.get("px_per_mm")
    if scale is None:
        raise InputError("writing MOTChallenge needs px_per_mm (boxes are in pixels)")
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
