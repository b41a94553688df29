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


def _files(folder: Path, pattern: str) -> list[Path]:
    out = []
    for p in folder.iterdir():
        if not p.is_file() or not fnmatch.fnmatch(p.name.lower(), pattern.lower()):
            continue
        if any(tag in p.stem for tag in _SKIP):
            continue
        try:
            with zipfile.ZipFile(p) as zf:
                keys = {n.removesuffix(".npy") for n in zf.namelist()}
        except (OSError, zipfile.BadZipFile):
            continue
        if _looks_like_trex(keys):
            out.append(p)
    return sorted(out, key=lambda p: natural_key(p.stem))


def sniff(path: Path) -> bool:
    if path.is_dir():
        return bool(_files(path, "*.npz"))
    try:
        with zipfile.ZipFile(path) as zf:
            keys = {n.removesuffix(".npy") for n in zf.namelist()}
    except (OSError, zipfile.BadZipFile):
        return False
    return _looks_like_trex(keys)


def _name(path: Path) -> str:
    m = _NAME.search(path.stem)
    return m.group(1) if m else path.stem


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
    if path.is_dir():
        files = _files(path, pattern)
        if not files:
            raise InputError(f"{path}: no TRex .npz exports matching {pattern!r}")
    else:
        files = [path]
    xk, yk = _keys(source)
    rows: dict[str, list[np.ndarray]] = {"ind": [], "frame": [], "time": [], "x": [], "y": []}
    cpps: set[float] = set()
    rates: set[float] = set()
    have_time = True
    names = []
    for f in files:
        data = _load(f)
        for key in ("frame", xk, yk):
            if key not in data:
                avail = ", ".join(sorted(k for k in data if k.startswith(("X", "Y"))))
                raise InputError(
                    f"{f}: no {key!r} array (position fields here: {avail or 'none'}); "
                    'choose another with --read-option source="..."'
                )
        frame = np.asarray(data["frame"]).ravel()
        n = frame.size
        x = np.asarray(data[xk], dtype=np.float64).ravel()
        y = np.asarray(data[yk], dtype=np.float64).ravel()
        lengths = {"frame": n, xk: x.size, yk: y.size}
        if "time" in data:
            lengths["time"] = np.asarray(data["time"]).size
        if "missing" in data:
            lengths["missing"] = np.asarray(data["missing"]).size
        if len(set(lengths.values())) != 1:
            raise InputError(f"{f}: arrays of different lengths {lengths}")
        if frame.dtype.kind not in "fiu" or not np.all(np.isfinite(frame)):
            raise InputError(f"{f}: 'frame' must be finite numbers")
        bad = ~(np.isfinite(x) & np.isfinite(y))
        if "missing" in data:
            bad |= np.asarray(data["missing"]).ravel().astype(bool)
        x[bad] = np.nan
        y[bad] = np.nan
        if "time" in data:
            t = np.asarray(data["time"], dtype=np.float64).ravel()
            t = np.where(np.isfinite(t), t, np.nan)
            rows["time"].append(t)
        else:
            have_time = False
        name = _name(f)
        names.append(name)
        rows["ind"].append(np.full(n, name, dtype=object))
        rows["frame"].append(frame.astype(np.float64))
        rows["x"].append(x)
        rows["y"].append(y)
        cpp = _scalar(data.get("cm_per_pixel"))
        if cpp is not None:
            cpps.add(cpp)
        rate = _scalar(data.get("frame_rate"))
        if rate is not None:
            rates.add(rate)
    if len(set(names)) != len(names):
        # e.g. exports of two videos in one folder: fall back to the whole file stems
        full = [f.stem for f in files]
        for old_name, new_name, ind in zip(names, full, rows["ind"], strict=True):
            ind[ind == old_name] = new_name
        names = full
    if len(cpps) > 1:
        raise InputError(f"{path}: files disagree on cm_per_pixel ({sorted(cpps)})")
    if len(rates) > 1:
        raise InputError(f"{path}: files disagree on frame_rate ({sorted(rates)})")
    file_cpp = next(iter(cpps), None)
    file_rate = next(iter(rates), None)
    rate = resolve_fps(path, fps, file_rate, "TRex")
    attrs: dict[str, Any] = {"trex_source": source}
    if file_rate is not None:
        attrs["file_fps"] = file_rate
    cpp = cpp_opt if cpp_opt is not None else file_cpp
    if cpp is not None:
        attrs["trex_cm_per_pixel"] = cpp
    if px_per_mm is not None:
        if cpp is None:
            raise InputError(
                f"{path}: to apply --px-per-mm the cm/px factor TRex used is needed, and the "
                "file does not record it; pass --read-option cm_per_pixel=... (or drop "
                "--px-per-mm to keep TRex's cm)"
            )
        factor = 1.0 / (cpp * px_per_mm)
        attrs.update(
            px_per_mm=px_per_mm,
            source_space_unit="cm",
            unit_conversion="mm = cm / trex_cm_per_pixel / px_per_mm",
        )
    else:
        factor = 10.0
        attrs.update(source_space_unit="cm", unit_conversion="mm = cm * 10")
    frames = np.concatenate(rows["frame"])
    frame_rate = None
    if rate is not None and (fps is not None or not have_time):
        time, frame_rate = frames, rate
        attrs["time_from"] = "frame / fps"
    elif have_time:
        time = _time_from_pairs(path, frames, np.concatenate(rows["time"]))
    else:
        raise InputError(f"{path}: no 'time' array and no frame_rate in the file; pass --fps")
    parts = assemble_long(
        path,
        individual=np.concatenate(rows["ind"]),
        time=time,
        x=np.concatenate(rows["x"]) * factor,
        y=np.concatenate(rows["y"]) * factor,
        keypoint=None,
        individual_order=names,
        frame_rate=frame_rate,
        clock="shared",  # TRex's times are those of one video's frames
    )
    attrs.update(parts["attrs"])
    return make_tracks(
        parts["position"],
        time=parts["time"],
        fps=rate,
        individuals=parts["individuals"],
        keypoints=[source],
        source_software="TRex",
        source_file=str(path),
        attrs=attrs,
    )


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
