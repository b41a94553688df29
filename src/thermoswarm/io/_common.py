"""Helpers shared by the readers: long tables, clocks, size guards, HDF5, names.

Every reader converts to the one trajectory format (mm, seconds) and reports bad
input as a one-line :class:`~thermoswarm.errors.InputError` that names the file.
:func:`assemble_long` scatters a long table (one row per sample) onto that format;
the size guards (:data:`MAX_CELLS`, :data:`MAX_FRAMES`) refuse a file before it is
allocated.  The options, units and frame rates are in :mod:`thermoswarm.io._options`
and are re-exported here, so a reader imports its helpers from this one module.
"""

from __future__ import annotations

import contextlib
import json
import math
import re
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from thermoswarm.errors import InputError
from thermoswarm.io._options import (  # noqa: F401 (re-exported: the readers import them from here)
    DUPLICATES_HELP,
    FPS_HINT,
    FPS_RANGE,
    MM_PER_UNIT,
    PIXEL_UNITS,
    PX_HINT,
    SECONDS_PER_UNIT,
    as_float_column,
    check_fps,
    check_options,
    length_scale,
    option_bool,
    option_duplicates,
    option_int,
    option_positive,
    option_str,
    option_str_list,
    require_fps,
    require_px_per_mm,
    resolve_fps,
)
from thermoswarm.tracks import resolve_duplicates


def attr_value(value: Any) -> Any:
    """A value that netCDF can store as an attribute (str, int, float, or arrays of them)."""
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, bool | np.bool_):
        return int(value)
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, list | tuple):
        items = [attr_value(v) for v in value]
        if items and all(isinstance(v, str) for v in items):
            return ", ".join(items)
        return str(items)
    if value is None:
        return ""
    if isinstance(value, dict):
        return json.dumps(value, default=str)
    return value


def time_key(t: np.ndarray) -> np.ndarray:
    """Times rounded to 1 ns so that float noise does not split one instant in two."""
    return np.round(np.asarray(t, dtype=np.float64), 9)


def assemble_long(
    path: Path,
    *,
    individual: np.ndarray,
    time: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    keypoint: np.ndarray | None = None,
    confidence: np.ndarray | None = None,
    individual_order: Sequence[str] | None = None,
    keypoint_order: Sequence[str] | None = None,
    frame_rate: float | None = None,
    duplicates: str = "error",
    clock: str = "auto",
    individual_sources: Sequence[Any] | None = None,
) -> dict[str, Any]:
    """Scatter a long table (one row per sample) onto the trajectory layout.

    ``time`` holds seconds, or frame numbers when ``frame_rate`` is given.  Rows are
    sorted by time within each individual (and keypoint); rows of one individual and
    keypoint at the same time are resolved by ``duplicates`` (see
    :func:`thermoswarm.tracks.resolve_duplicates`: exact duplicates dropped, conflicts
    an error, or the first, or the mean), and counted.

    The clock.  Frame numbers are a shared clock (the frames of one video): the axis
    is every frame from the first to the last (frames nobody was seen in are NaN, so
    the sampling stays regular), in seconds ``frame / frame_rate``.  Seconds share one
    axis when ``clock="shared"`` (times that come from one video's frames), when every
    individual has the same set of times, or when the times are those of one regular
    clock with some samples missing (:func:`one_regular_clock`); otherwise each
    individual keeps its own times (per-individual clocks, :mod:`thermoswarm.tracks`):
    row ``k`` of an individual is its ``k``-th sample, and no filler rows are
    invented.

    Returns a dict with ``position``, ``confidence`` (or None), ``time`` (``(time,)``
    or ``(time, individuals)`` seconds), ``individuals``, ``keypoints`` and ``attrs``
    (the duplicate counts and ``n_decreasing_timestamps``, the backward steps in the
    input order of each individual and keypoint).  ``individual_sources`` (one file
    per individual, in ``individual_order``) names the file in error messages instead
    of ``path``.
    """
    n = len(time)
    if n == 0:
        raise InputError(f"{path}: no data rows")
    if clock not in ("auto", "shared"):
        raise ValueError(f"clock must be 'auto' or 'shared', got {clock!r}")
    time = np.asarray(time, dtype=np.float64)
    if not np.all(np.isfinite(time)):
        bad = int(np.flatnonzero(~np.isfinite(time))[0])
        raise InputError(f"{path}: missing or non-finite time/frame in data row {bad + 1}")
    ind_names, ind_idx = _codes(path, individual, individual_order)
    if keypoint is None:
        kp_names, kp_idx = ["centroid"], np.zeros(n, dtype=np.int64)
    else:
        kp_names, kp_idx = _codes(path, keypoint, keypoint_order)
    n_k, n_i = len(kp_names), len(ind_names)
    key = _sort_key(path, time, frame_rate, n_k, n_i)
    values = np.column_stack(
        [np.asarray(x, np.float64), np.asarray(y, np.float64)]
        + ([] if confidence is None else [np.asarray(confidence, np.float64)])
    )
    describe = _describer(path, ind_names, None if keypoint is None else kp_names,
                          frame_rate, individual_sources)  # fmt: skip
    rows, vals, attrs = _resolve_rows(key, values, ind_idx * n_k + kp_idx, n_k * n_i,
                                      frame_rate, duplicates, describe)  # fmt: skip
    key, ind_idx, kp_idx = key[rows], ind_idx[rows], kp_idx[rows]
    times, n_t, t_idx = _time_axis(path, key, ind_idx, n_k, n_i, frame_rate, clock)
    check_dense_size(path, n_t, n_k, n_i)
    pos, conf = _scatter(vals, (t_idx, kp_idx, ind_idx), (n_t, n_k, n_i), confidence is not None)
    return {
        "position": pos,
        "confidence": conf,
        "time": times,
        "individuals": ind_names,
        "keypoints": kp_names,
        "attrs": attrs,
    }


def _scatter(
    vals: np.ndarray,
    at: tuple[np.ndarray, np.ndarray, np.ndarray],
    shape: tuple[int, int, int],
    with_confidence: bool,
) -> tuple[np.ndarray, np.ndarray | None]:
    """Rows ``vals`` (x, y[, confidence]) at ``(time, keypoint, individual)`` indices
    ``at`` scattered onto NaN-filled ``position (time, 2, keypoints, individuals)`` and
    ``confidence (time, keypoints, individuals)`` float32 arrays (None without one)."""
    t_idx, kp_idx, ind_idx = at
    n_t, n_k, n_i = shape
    pos = np.full((n_t, 2, n_k, n_i), np.nan)
    pos[t_idx, 0, kp_idx, ind_idx] = vals[:, 0]
    pos[t_idx, 1, kp_idx, ind_idx] = vals[:, 1]
    conf = None
    if with_confidence:
        conf = np.full((n_t, n_k, n_i), np.nan, dtype=np.float32)
        conf[t_idx, kp_idx, ind_idx] = vals[:, 2]
    return pos, conf


def _sort_key(
    path: Path, time: np.ndarray, frame_rate: float | None, n_k: int, n_i: int
) -> np.ndarray:
    """The rows' time key: frame numbers (checked whole, their span and dense size
    refused when too large) when ``frame_rate`` is given, else :func:`time_key`."""
    if frame_rate is None:
        return time_key(time)
    frames = np.rint(time)
    if np.any(frames != time):
        bad = int(np.flatnonzero(frames != time)[0])
        raise InputError(f"{path}: frame number {time[bad]!r} is not an integer")
    f0, f1 = float(frames.min()), float(frames.max())
    check_frame_span(path, [f0, f1])
    check_dense_size(path, int(f1 - f0) + 1, n_k, n_i)
    return time


def _describer(
    path: Path,
    ind_names: Sequence[str],
    kp_names: Sequence[str] | None,
    frame_rate: float | None,
    individual_sources: Sequence[Any] | None,
) -> Callable[[int, float], str]:
    """``describe(group, when)``: where a duplicate is, for the error message (the
    file, the individual, the keypoint unless ``kp_names`` is None, the frame or time)."""
    n_k = 1 if kp_names is None else len(kp_names)

    def describe(group: int, when: float) -> str:
        ii, ki = divmod(group, n_k)
        what = f"individual {ind_names[ii]!r}"
        if kp_names is not None:
            what += f", keypoint {kp_names[ki]!r}"
        at = f"frame {when:.10g}" if frame_rate is not None else f"time {when:.10g} s"
        where = path if individual_sources is None else individual_sources[ii]
        return f"{where}: {what} at {at}"

    return describe


def _resolve_rows(
    key: np.ndarray,
    values: np.ndarray,
    group: np.ndarray,
    n_groups: int,
    frame_rate: float | None,
    duplicates: str,
    describe: Callable[[int, float], str],
) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    """The rows kept (sorted by time within each group: individual x keypoint), their
    values, and the counts: duplicates (exact and conflicting, resolved by
    ``duplicates``) and backward time steps in each group's input order."""
    n = key.size
    if n == 1 or bool(np.all(key[1:] >= key[:-1])):
        n_back = 0  # time-major tables (every frame's rows together) are sorted already
    else:
        by_group = np.argsort(group, kind="stable")  # each group's rows in input order
        same_group = group[by_group][1:] == group[by_group][:-1]
        n_back = int((same_group & (np.diff(key[by_group]) < 0)).sum())
    if frame_rate is not None and _one_row_per_cell(key, group, n_groups):
        # the usual frame table: no two rows in one cell, nothing to sort or resolve
        rows, vals, n_exact, n_conflict = np.arange(n), values, 0, 0
    else:
        rows, vals, n_exact, n_conflict = resolve_duplicates(
            key, values, duplicates, group=group, describe=describe
        )
    attrs = {
        "n_duplicate_rows": n_exact,
        "n_conflicting_duplicates": n_conflict,
        "n_decreasing_timestamps": n_back,
    }
    if n_exact or n_conflict:
        attrs["duplicates_rule"] = duplicates
    return rows, vals, attrs


def _time_axis(
    path: Path,
    key: np.ndarray,
    ind_idx: np.ndarray,
    n_k: int,
    n_i: int,
    frame_rate: float | None,
    clock: str,
) -> tuple[np.ndarray, int, np.ndarray]:
    """``(times, n_t, t_idx)``: the time axis (s; ``(n_t,)`` shared, ``(n_t, n_i)`` one
    clock per individual) and each row's index on it (see :func:`assemble_long`)."""
    if frame_rate is not None:
        f0 = int(key.min())
        t_idx = key.astype(np.int64) - f0
        times: np.ndarray = np.arange(f0, int(key.max()) + 1, dtype=np.float64) / frame_rate
        return times, times.size, t_idx
    # unique (individual, time) pairs: each individual's own sample times
    pair = np.lexsort((key, ind_idx))
    ks, iis = key[pair], ind_idx[pair]
    first = np.ones(ks.size, dtype=bool)
    first[1:] = (ks[1:] != ks[:-1]) | (iis[1:] != iis[:-1])
    u_t, u_i = ks[first], iis[first]
    shared_t = np.unique(u_t)
    per_ind = np.bincount(u_i, minlength=n_i)
    same = bool(np.all(per_ind == shared_t.size))
    if clock == "shared" or same or one_regular_clock(shared_t, u_t, u_i, n_i):
        return shared_t, shared_t.size, np.searchsorted(shared_t, key)
    start = np.concatenate([[0], np.cumsum(per_ind)[:-1]])
    rank = np.arange(u_t.size) - start[u_i]
    n_t = int(per_ind.max())
    check_dense_size(path, n_t, n_k, n_i)
    times = np.full((n_t, n_i), np.nan)
    times[rank, u_i] = u_t
    # each row's rank: its pair's rank (rows of other keypoints share the pair)
    pair_id = np.cumsum(first) - 1
    row_rank = np.empty(key.size, dtype=np.int64)
    row_rank[pair] = rank[pair_id]
    return times, n_t, row_rank


def _one_row_per_cell(frames: np.ndarray, group: np.ndarray, n_groups: int) -> bool:
    """Whether no (frame, group) cell holds two rows (a bincount, no sort).

    False (let the sort decide) when the table is too sparse for a count per cell.
    """
    f = frames.astype(np.int64)
    f0 = int(f.min())
    n_cells = (int(f.max()) - f0 + 1) * n_groups
    if n_cells > 8 * f.size + 1024:
        return False
    cell = (f - f0) * n_groups + group
    return int(np.bincount(cell, minlength=n_cells).max(initial=0)) <= 1


def one_regular_clock(
    union: np.ndarray, t: np.ndarray, ind: np.ndarray, n_i: int, tol: float = 0.1
) -> bool:
    """Whether samples ``t`` of individuals ``ind`` are ticks of one regular clock.

    ``union`` is the sorted union of all times, ``t``/``ind`` each individual's own
    sorted times.  True when every step of the union is (within ``tol``) a whole
    number of its median step ``D`` and every individual's own median step is ``D``
    (within ``tol``): the individuals were sampled at the same instants, some samples
    missing, and the rows one lacks are honest gaps.  Offset, jittered or differently
    paced clocks fail (their union has steps that are fractions of ``D``, or an
    individual steps by a multiple of it).
    """
    if union.size < 3:
        return False
    du = np.diff(union)
    d = float(np.median(du))
    if not d > 0:
        return False
    ratio = du / d
    if np.any(ratio < 1 - tol) or np.any(np.abs(ratio - np.rint(ratio)) > tol):
        return False
    own = np.diff(t)
    same = ind[1:] == ind[:-1]
    own, who = own[same], ind[1:][same]
    if own.size == 0:
        return False
    for i in np.unique(who):
        m = float(np.median(own[who == i]))
        if abs(m - d) > tol * d:
            return False
    return True


#: Largest dense position array a reader will allocate (float64 values; 8 GB).
MAX_CELLS = 1_000_000_000


def check_dense_size(path: Path, n_t: int, n_k: int, n_i: int) -> None:
    """Refuse a dense ``(time, 2, keypoints, individuals)`` array that cannot fit.

    Long tables from trackers that fragment identities (thousands of short tracks)
    would otherwise ask for tens of GB of mostly-NaN positions.
    """
    cells = n_t * 2 * n_k * n_i
    if cells > MAX_CELLS:
        raise InputError(
            f"{path}: {n_i} individuals x {n_k} keypoints x {n_t} time steps would need "
            f"{cells * 8 / 1e9:.0f} GB as a dense array; merge fragmented track ids or "
            "split the file in time"
        )


#: The longest frame range a file may span (10 million frames: 3.9 days at 30 fps);
#: a larger one is refused before anything is allocated for it.
MAX_FRAMES = 10_000_000


def check_frame_span(path: Path, frames: Any, what: str = "frames") -> None:
    """Refuse frame numbers spanning more than :data:`MAX_FRAMES` (one stray 1e11 would
    ask for a dense array of 1e11 rows)."""
    f = np.asarray(frames, dtype=np.float64)
    if f.size == 0:
        return
    lo, hi = float(np.nanmin(f)), float(np.nanmax(f))
    span = hi - lo + 1
    if span > MAX_FRAMES:
        raise InputError(
            f"{path}: {what} {lo:.0f} to {hi:.0f} span {span:,.0f} frames, "
            f"more than the {MAX_FRAMES:,} accepted"
        )


def check_integers(path: Path, values: Any, what: str, lines: Any = None) -> np.ndarray:
    """``values`` as int64, refusing one that is not a whole number (1.5 would be
    truncated to 1 and merged with it); ``lines`` (file line of each value) names the
    line in the error."""
    v = np.asarray(values, dtype=np.float64)
    bad = ~np.isfinite(v) | (v != np.round(v)) | (np.abs(v) > 2.0**53)
    if bad.any():
        i = int(np.argmax(bad))
        where = f"{path}:{int(np.asarray(lines)[i])}" if lines is not None else f"{path}"
        raise InputError(f"{where}: {what} {v[i]!r} is not an integer")
    return v.astype(np.int64)


def check_unique_frames(path: Path, frames: Any, what: str) -> None:
    """Refuse a frame number that appears twice where a file holds one entry per frame."""
    u, count = np.unique(np.asarray(frames), return_counts=True)
    if (count > 1).any():
        k = int(np.argmax(count > 1))
        raise InputError(
            f"{path}: {what} {float(u[k]):g} appears {int(count[k])} times; "
            "expected one entry per frame"
        )


def check_declared_size(path: Path, name: str, shape: Sequence[int]) -> None:
    """Refuse a dataset whose declared shape holds more than :data:`MAX_CELLS` values,
    before any of it is read (an HDF5 header can declare 2e10 values in a few bytes)."""
    size = math.prod(int(n) for n in shape)
    if size > MAX_CELLS:
        raise InputError(
            f"{path}: dataset {name!r} declares shape {tuple(int(n) for n in shape)}, "
            f"{size:,} values, more than the {MAX_CELLS:,} a reader loads"
        )


#: Largest |position| (mm) a reader keeps: a million km.  Beyond it a value is not a
#: position (1e308 overflows every float32 output and every squared speed) and counts
#: as non-finite.
MAX_ABS_MM = 1e12


def npy_declared_shape(fh: Any) -> tuple[int, ...] | None:
    """The shape an ``.npy`` stream declares in its header (``fh`` at its start), or
    None for a header this cannot parse (the read that follows reports it)."""
    try:
        version = np.lib.format.read_magic(fh)
        if version == (1, 0):
            return tuple(np.lib.format.read_array_header_1_0(fh)[0])
        if version == (2, 0):
            return tuple(np.lib.format.read_array_header_2_0(fh)[0])
    except (ValueError, OSError, EOFError):
        return None
    return None


def check_npy_sizes(path: Path) -> None:
    """Refuse an ``.npy`` file, or an ``.npz`` member, whose header declares more than
    :data:`MAX_CELLS` values, before NumPy allocates them."""
    import zipfile

    if zipfile.is_zipfile(path):
        try:
            with zipfile.ZipFile(path) as zf:
                for name in zf.namelist():
                    with zf.open(name) as fh:
                        shape = npy_declared_shape(fh)
                    if shape is not None:
                        check_declared_size(path, name.removesuffix(".npy"), shape)
        except (zipfile.BadZipFile, OSError, EOFError, RuntimeError):
            return  # the reader's own load reports a damaged archive
        return
    try:
        with open(path, "rb") as fh:
            shape = npy_declared_shape(fh)
    except OSError:
        return
    if shape is not None:
        check_declared_size(path, path.name, shape)


def check_h5_sizes(path: Path, fh: Any) -> None:
    """Refuse an HDF5 file (netCDF-4) with a dataset declaring more than
    :data:`MAX_CELLS` values, before a library reads it whole."""
    import h5py

    def visit(name: str, obj: Any) -> None:
        if isinstance(obj, h5py.Dataset) and obj.shape:
            check_declared_size(path, name, obj.shape)

    fh.visititems(visit)


def check_tracks(ds: Any, path: Path) -> Any:
    """Checks of every reader's result; returns ``ds`` with non-finite positions counted.

    Individual and keypoint names must be unique (they label the tracks: 8 individuals
    of one name would be analysed as 8 tracks) and the frame rate within
    :data:`FPS_RANGE`.  Positions that are infinite or beyond :data:`MAX_ABS_MM` (x or
    y) become NaN and are counted in ``attrs["n_nonfinite_positions"]`` (samples), which
    the analysis reports with its own count.
    """
    for dim in ("individuals", "keypoints"):
        if dim not in ds.coords:
            continue
        counts: dict[str, int] = {}
        for n in (str(v) for v in ds[dim].values):
            counts[n] = counts.get(n, 0) + 1
        dup = {n: c for n, c in counts.items() if c > 1}
        if dup:
            shown = ", ".join(f"{n!r} x{c}" for n, c in list(dup.items())[:5])
            raise InputError(
                f"{path}: {dim} names must be unique, got {shown}"
                f"{' ...' if len(dup) > 5 else ''}; rename them"
            )
    fps = ds.attrs.get("fps")
    if fps is not None:
        check_fps(path, fps, "the frame rate (attribute fps)")
    pos = ds["position"]
    if pos.dtype.kind != "f":
        return ds
    values = pos.values
    with np.errstate(invalid="ignore"):
        bad = (np.abs(values) > MAX_ABS_MM).any(axis=pos.dims.index("space"))
    n_bad = int(bad.sum())
    if n_bad:
        import xarray as xr

        keep = xr.DataArray(~bad, dims=[d for d in pos.dims if d != "space"])
        ds = ds.copy()
        ds["position"] = pos.where(keep)
    ds.attrs["n_nonfinite_positions"] = int(ds.attrs.get("n_nonfinite_positions", 0)) + n_bad
    return ds


def _codes(
    path: Path, values: np.ndarray, order: Sequence[str] | None
) -> tuple[list[str], np.ndarray]:
    """Names (in first-seen order, or ``order``) and each row's index into them."""
    codes, uniques = pd.factorize(np.asarray(values), sort=False)
    if (codes < 0).any():
        raise InputError(f"{path}: missing individual or keypoint name")
    names = [str(u) for u in uniques]
    if len(set(names)) != len(names):  # e.g. 1 and "1": same name, two codes
        names_arr = np.asarray(names, dtype=object)
        codes, uniques = pd.factorize(names_arr[codes], sort=False)
        names = [str(u) for u in uniques]
    if order is None:
        return names, codes.astype(np.int64)
    order = [str(o) for o in order]
    lookup = {name: i for i, name in enumerate(order)}
    remap = np.array([lookup[name] for name in names], dtype=np.int64)
    return order, remap[codes]


def natural_key(text: str) -> list[Any]:
    """Sort key that puts ``id2`` before ``id10``."""
    return [int(p) if p.isdigit() else p.lower() for p in re.split(r"(\d+)", text)]


@contextlib.contextmanager
def h5_file(path: Path, what: str) -> Iterator[Any]:
    """Open an HDF5 file read-only; an unreadable file is an InputError naming it."""
    import h5py

    try:
        fh = h5py.File(path, "r")
    except Exception as exc:  # h5py raises OSError subclasses with long messages
        raise InputError(
            f"{path}: not a readable HDF5 {what} file ({type(exc).__name__})"
        ) from None
    try:
        yield fh
    finally:
        fh.close()


def h5_read(path: Path, fh: Any, name: str) -> np.ndarray:
    """Read a whole HDF5 dataset; a missing or corrupt one is an InputError."""
    if name not in fh:
        raise InputError(f"{path}: no {name!r} dataset")
    shape = getattr(fh[name], "shape", None)
    if shape:
        check_declared_size(path, name, shape)
    try:
        return fh[name][()]
    except Exception as exc:  # truncated chunks raise OSError/RuntimeError
        raise InputError(f"{path}: cannot read dataset {name!r} ({type(exc).__name__})") from None


def decode_names(values: Any) -> list[str]:
    """HDF5 string arrays (bytes or str) as a list of str."""
    out = []
    for v in np.asarray(values).ravel():
        out.append(v.decode("utf-8", "replace") if isinstance(v, bytes) else str(v))
    return out


def unique_names(path: Path, names: Sequence[str], what: str) -> list[str]:
    """Names must be unique (they become coordinate labels)."""
    names = [str(n) for n in names]
    seen: set[str] = set()
    for n in names:
        if n in seen:
            raise InputError(f"{path}: {what} name {n!r} appears twice")
        seen.add(n)
    return names
