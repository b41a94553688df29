"""TRex exports: one ``.npz`` per individual (``<video>_<prefix><N>.npz``).

Layout (TRex documentation, "File formats"; fields depend on ``output_fields``):

``X#wcentroid``, ``Y#wcentroid``  body centre; ``#centroid``, ``#pcentroid`` other
                                  centres; bare ``X``, ``Y`` the head (posture only)
``time``                          seconds from the start of the video
``frame``                         frame number (not necessarily from 0, may skip)
``missing``                       1 where the individual was not tracked
``cm_per_pixel``, ``frame_rate``  the scale TRex applied and the video's frame rate
                                  (recent versions; one-element arrays)

Positions are in **cm**: TRex multiplies pixels by ``cm_per_pixel`` (a guess from
an assumed 30 cm arena width when the user did not calibrate).  This reader
converts cm to mm (x10) and records ``trex_cm_per_pixel``.  If you pass
``--px-per-mm`` (your own calibration), TRex's scaling is undone first
(``px = cm / cm_per_pixel``, then ``mm = px / px_per_mm``); that needs
``cm_per_pixel`` from the file or the ``cm_per_pixel`` option.

Missing samples (``missing == 1`` or non-finite values; TRex writes ``inf``) become
NaN.  A folder is read as one group: every ``.npz`` in it whose arrays include
``frame`` and the chosen position source (posture, visual-field, tracklet-image
and heatmap files are skipped), aligned on frame numbers.
"""

from __future__ import annotations

import fnmatch
import math
import re
import warnings
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.errors import InputError
from thermoswarm.io._common import (
    assemble_long,
    check_npy_sizes,
    check_options,
    natural_key,
    option_positive,
    option_str,
    resolve_fps,
)
from thermoswarm.tracks import make_tracks

SOURCES = ("wcentroid", "centroid", "pcentroid", "head")
OPTIONS = {
    "source": 'position source: "wcentroid" (default, body centre weighted by pixel values), '
    '"centroid", "pcentroid" (midline centre) or "head"',
    "cm_per_pixel": "the cm/px factor TRex applied, when the file does not record it "
    "(only needed with --px-per-mm)",
    "pattern": 'file name pattern in a folder (default "*.npz")',
}
NEEDS = "nothing (positions in cm, times in s); --px-per-mm to replace TRex's own scale"

_NAME = re.compile(r"_([A-Za-z]*\d+)$")
_SKIP = ("_posture", "_visual_field", "_tracklet_images", "_heatmap")


def _keys(source: str) -> tuple[str, str]:
    return ("X", "Y") if source == "head" else (f"X#{source}", f"Y#{source}")


def _load(path: Path) -> dict[str, np.ndarray]:
    """Arrays of an npz, without unpickling (object arrays are refused)."""
    check_npy_sizes(path)
    try:
        with np.load(path, allow_pickle=False) as npz:
            return {k: npz[k] for k in npz.files}
    except ValueError as exc:
        if "allow_pickle" in str(exc):
            raise InputError(
                f"{path}: holds pickled Python objects; a TRex export has only numeric arrays"
            ) from None
        raise InputError(f"{path}: not a readable .npz file ({exc})") from None
    except (OSError, EOFError, zipfile.BadZipFile) as exc:
        raise InputError(f"{path}: not a readable .npz file ({type(exc).__name__})") from None


def _scalar(arr: np.ndarray | None) -> float | None:
    if arr is None:
        return None
    flat = np.asarray(arr, dtype=np.float64).ravel()
    flat = flat[np.isfinite(flat)]
    return float(flat[0]) if flat.size else None


def _looks_like_trex(keys: set[str]) -> bool:
    return (
        "frame" in keys
        and any(k.startswith(("X#", "X")) for k in keys)
        and ("time" in keys or "missing" in keys)
    )


def _zip_keys(path: Path) -> set[str] | None:
    """The array names of an ``.npz`` (a zip), or None when it is not a readable zip."""
    try:
        with zipfile.ZipFile(path) as zf:
            return {n.removesuffix(".npy") for n in zf.namelist()}
    except (OSError, zipfile.BadZipFile, ValueError, EOFError):
        return None


def _scan(folder: Path, pattern: str) -> tuple[list[Path], list[Path], list[Path]]:
    """The folder's ``.npz`` files matching ``pattern`` (TRex's posture, visual-field,
    tracklet-image and heatmap files left out): TRex exports, damaged files (not a
    readable zip: empty, truncated) and readable ones without TRex's arrays."""
    good, damaged, foreign = [], [], []
    for p in folder.iterdir():
        if not p.is_file() or not fnmatch.fnmatch(p.name.lower(), pattern.lower()):
            continue
        if any(tag in p.stem for tag in _SKIP):
            continue
        keys = _zip_keys(p)
        (damaged if keys is None else good if _looks_like_trex(keys) else foreign).append(p)
    return tuple(sorted(x, key=lambda p: natural_key(p.stem)) for x in (good, damaged, foreign))


def _files(folder: Path, pattern: str) -> list[Path]:
    """The TRex exports of a folder; a damaged one is an error and a ``.npz`` without
    TRex's arrays a warning, each naming the files (never dropped in silence)."""
    good, damaged, foreign = _scan(folder, pattern)
    if not good:
        raise InputError(f"{folder}: no TRex .npz exports matching {pattern!r}")
    if damaged:
        names = ", ".join(p.name for p in damaged[:5]) + (" ..." if len(damaged) > 5 else "")
        raise InputError(
            f"{folder}: {len(damaged)} of {len(good) + len(damaged)} TRex .npz files are "
            f"damaged (not a readable .npz): {names}; repair or move them, or pass "
            '--read-option pattern="..." to read the others'
        )
    if foreign:
        names = ", ".join(p.name for p in foreign[:5]) + (" ..." if len(foreign) > 5 else "")
        warnings.warn(
            f"{folder}: {len(foreign)} .npz file(s) without TRex's arrays (frame, X#..., "
            f"time or missing) left out: {names}",
            stacklevel=3,
        )
    return good


def sniff(path: Path) -> bool:
    if path.is_dir():
        return bool(_scan(path, "*.npz")[0])
    keys = _zip_keys(path)
    return keys is not None and _looks_like_trex(keys)


def _name(path: Path) -> str:
    m = _NAME.search(path.stem)
    return m.group(1) if m else path.stem


def _one(f: Path, xk: str, yk: str) -> dict[str, Any]:
    """One export's arrays: frame, x, y (NaN where missing), time or None, scale, rate."""
    data = _load(f)
    for key in ("frame", xk, yk):
        if key not in data:
            avail = ", ".join(sorted(k for k in data if k.startswith(("X", "Y"))))
            raise InputError(
                f"{f}: no {key!r} array (position fields here: {avail or 'none'}); "
                'choose another with --read-option source="..."'
            )
    frame = np.asarray(data["frame"]).ravel()
    x = np.asarray(data[xk], dtype=np.float64).ravel()
    y = np.asarray(data[yk], dtype=np.float64).ravel()
    lengths = {"frame": frame.size, xk: x.size, yk: y.size}
    for key in ("time", "missing"):
        if key in data:
            lengths[key] = np.asarray(data[key]).size
    if len(set(lengths.values())) != 1:
        raise InputError(f"{f}: arrays of different lengths {lengths}")
    if frame.dtype.kind not in "fiu" or not np.all(np.isfinite(frame)):
        raise InputError(f"{f}: 'frame' must be finite numbers")
    bad = ~(np.isfinite(x) & np.isfinite(y))
    if "missing" in data:
        bad |= np.asarray(data["missing"]).ravel().astype(bool)
    x[bad] = np.nan
    y[bad] = np.nan
    time = None
    if "time" in data:
        t = np.asarray(data["time"], dtype=np.float64).ravel()
        time = np.where(np.isfinite(t), t, np.nan)
    return {"frame": frame.astype(np.float64), "x": x, "y": y, "time": time,
            "cpp": _scalar(data.get("cm_per_pixel")),
            "rate": _scalar(data.get("frame_rate"))}  # fmt: skip


def _names(files: list[Path]) -> list[str]:
    """Individual names (``fish3``); the whole file stems when two files share one."""
    names = [_name(f) for f in files]
    return names if len(set(names)) == len(names) else [f.stem for f in files]


def _one_value(path: Path, values: list[float | None], what: str) -> float | None:
    found = {v for v in values if v is not None}
    if len(found) > 1:
        raise InputError(f"{path}: files disagree on {what} ({sorted(found)})")
    return next(iter(found), None)


def _scale(path: Path, cpp: float | None, px_per_mm: float | None) -> tuple[float, dict]:
    """Factor from TRex's cm to mm, and the attrs recording it."""
    if px_per_mm is None:
        return 10.0, {"source_space_unit": "cm", "unit_conversion": "mm = cm * 10"}
    if cpp is None:
        raise InputError(
            f"{path}: to apply --px-per-mm the cm/px factor TRex used is needed, and the "
            "file does not record it; pass --read-option cm_per_pixel=... (or drop "
            "--px-per-mm to keep TRex's cm)"
        )
    return 1.0 / (cpp * px_per_mm), {
        "px_per_mm": px_per_mm,
        "source_space_unit": "cm",
        "unit_conversion": "mm = cm / trex_cm_per_pixel / px_per_mm",
    }


def read(
    path: Path, *, fps: float | None = None, px_per_mm: float | None = None, **options: Any
) -> xr.Dataset:
    """Read one TRex ``.npz`` or a folder of them (see the module docstring)."""
    check_options(path, "trex", options, OPTIONS)
    source = option_str(path, "source", options.get("source", "wcentroid"), SOURCES)
    pattern = option_str(path, "pattern", options.get("pattern", "*.npz"))
    cpp_opt = (
        option_positive(path, "cm_per_pixel", options["cm_per_pixel"])
        if "cm_per_pixel" in options
        else None
    )
    files = _files(path, pattern) if path.is_dir() else [path]
    parts = [_one(f, *_keys(source)) for f in files]
    names = _names(files)
    file_cpp = _one_value(path, [p["cpp"] for p in parts], "cm_per_pixel")
    file_rate = _one_value(path, [p["rate"] for p in parts], "frame_rate")
    rate = resolve_fps(path, fps, file_rate, "TRex")
    attrs: dict[str, Any] = {"trex_source": source}
    if file_rate is not None:
        attrs["file_fps"] = file_rate
    cpp = cpp_opt if cpp_opt is not None else file_cpp
    if cpp is not None:
        attrs["trex_cm_per_pixel"] = cpp
    factor, unit_attrs = _scale(path, cpp, px_per_mm)
    attrs.update(unit_attrs)
    frames = np.concatenate([p["frame"] for p in parts])
    have_time = all(p["time"] is not None for p in parts)
    frame_rate = None
    if rate is not None and (fps is not None or not have_time):
        time, frame_rate = frames, rate
        attrs["time_from"] = "frame / fps"
    elif have_time:
        time = _time_from_pairs(path, frames, np.concatenate([p["time"] for p in parts]))
    else:
        raise InputError(f"{path}: no 'time' array and no frame_rate in the file; pass --fps")
    long = assemble_long(
        path,
        individual=np.concatenate(
            [np.full(p["frame"].size, n, dtype=object) for p, n in zip(parts, names, strict=True)]
        ),
        time=time,
        x=np.concatenate([p["x"] for p in parts]) * factor,
        y=np.concatenate([p["y"] for p in parts]) * factor,
        keypoint=None,
        individual_order=names,
        frame_rate=frame_rate,
        clock="shared",  # TRex's times are those of one video's frames
    )
    attrs.update(long["attrs"])
    return make_tracks(long["position"], time=long["time"], fps=rate,
                       individuals=long["individuals"], keypoints=[source],
                       source_software="TRex", source_file=str(path), attrs=attrs)  # fmt: skip


def _time_from_pairs(path: Path, frames: np.ndarray, times: np.ndarray) -> np.ndarray:
    """One time per frame number: TRex's ``time`` is consistent across individuals.

    Frames whose time is non-finite (TRex writes ``inf`` where nothing is known)
    take the time another individual recorded for the same frame; a frame with no
    finite time anywhere is an error.
    """
    ok = np.isfinite(times)
    uniq, inv = np.unique(frames, return_inverse=True)
    table = np.full(uniq.size, np.nan)
    table[inv[ok]] = times[ok]
    if np.isnan(table).any():
        f = uniq[np.flatnonzero(np.isnan(table))[0]]
        raise InputError(f"{path}: no finite time for frame {f:g}; pass --fps to use frame / fps")
    spread = np.zeros(uniq.size)
    np.maximum.at(spread, inv[ok], np.abs(times[ok] - table[inv[ok]]))
    if spread.max(initial=0.0) > 1e-6 * max(1.0, float(np.nanmax(np.abs(table)))):
        f = uniq[int(np.argmax(spread))]
        raise InputError(f"{path}: files give different times for frame {f:g}")
    if not math.isfinite(float(table.max())):
        raise InputError(f"{path}: non-finite times")
    return table[inv]
