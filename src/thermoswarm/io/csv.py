"""CSV tables: tidy (one row per individual and time) and wide (one row per frame).

Tidy CSV
    Columns ``individual`` (optional: one individual when absent), ``keypoint``
    (optional), ``time`` (s) and/or ``frame``, ``x``, ``y``, ``confidence``
    (optional).  Column names are matched case-insensitively against common aliases
    (``id``, ``track``, ``t``, ``frame_idx``, ``likelihood``, ...) and can be set
    with the ``*_col`` options.
Wide CSV
    Columns ``time`` or ``frame`` and one ``x``/``y`` pair per individual:
    ``x0, y0, x1, y1`` or ``x_ant3, y_ant3`` or ``ant3_x, ant3_y`` (idtracker.ai's
    ``trajectories.csv`` -- ``time, x1, y1, x2, y2`` -- is one).  When no column has
    a time or frame name, a first column of integers followed only by x/y pairs is
    taken as the frame number whatever its name (a colony tracker writes
    ``position, x0, y0, ...``); ``attrs["time_from"]`` says so.

Both layouts sort each individual's rows by time; rows of one individual at one time
are exact duplicates (dropped, counted) or conflicts, resolved by the ``duplicates``
option (``"error"`` by default, ``"first"`` or ``"mean"``) and counted
(``attrs["n_duplicate_rows"]``, ``attrs["n_conflicting_duplicates"]``).

Lines starting with ``#`` among the rows are comments and skipped.

Units.  Lengths are in pixels when ``px_per_mm`` is given; otherwise the unit must
be stated: by the ``units`` option, by unit-suffixed columns (``x_mm``, ``y_px``), or
by a ``# space_unit: mm`` line at the top of the file (what :func:`write` puts
there).  Leading lines starting with ``#`` are ``key: value`` metadata (``fps``,
``space_unit``, ``time_unit``, ``source_software``); they are skipped by
``pandas.read_csv(..., comment="#")`` and R's ``read.csv(comment.char = "#")``.
"""

from __future__ import annotations

import io as _io
import mmap
import re
import warnings
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from thermoswarm.errors import InputError
from thermoswarm.fsutil import atomic_write_text
from thermoswarm.io._common import (
    DUPLICATES_HELP,
    SECONDS_PER_UNIT,
    as_float_column,
    assemble_long,
    check_fps,
    check_options,
    length_scale,
    option_duplicates,
    option_str,
    require_fps,
    resolve_fps,
    unique_names,
)
from thermoswarm.tracks import make_tracks, per_individual

ALIASES: dict[str, tuple[str, ...]] = {
    "individual": (
        "individual",
        "individuals",
        "id",
        "track",
        "track_id",
        "trackid",
        "ind",
        "animal",
        "identity",
        "object",
        "object_id",
    ),
    "keypoint": ("keypoint", "keypoints", "bodypart", "bodyparts", "node", "part"),
    "time": ("time", "t", "time_s", "seconds", "sec"),
    "frame": ("frame", "frames", "frame_idx", "frame_index", "frame_number", "frame_no"),
    "x": ("x", "x_px", "x_mm", "x_cm", "x_m", "pos_x", "position_x"),
    "y": ("y", "y_px", "y_mm", "y_cm", "y_m", "pos_y", "position_y"),
    "confidence": ("confidence", "likelihood", "score", "conf", "probability"),
}

_COMMON_OPTIONS = {
    "units": 'length unit of x and y when no --px-per-mm: "mm", "cm", "m", "um" or "px"',
    "time_unit": 'unit of the time column: "s" (default), "ms", "us", "min", "h"',
    "delimiter": "field separator (default: guessed from the header: , tab ; or spaces)",
    "time_col": "name of the time column (seconds unless time_unit says otherwise)",
    "frame_col": "name of the frame-number column (needs --fps when there is no time)",
    "duplicates": DUPLICATES_HELP,
}

TIDY_OPTIONS = {
    **_COMMON_OPTIONS,
    "individual_col": "name of the individual column (absent: one individual)",
    "keypoint_col": "name of the keypoint column (absent: one keypoint, 'centroid')",
    "x_col": "name of the x column",
    "y_col": "name of the y column",
    "confidence_col": "name of the confidence/likelihood column (optional)",
}
WIDE_OPTIONS = dict(_COMMON_OPTIONS)

NEEDS = "--px-per-mm, or lengths in a stated unit; --fps when there are frames but no times"

_WIDE_PATTERNS = (
    re.compile(r"^(?P<axis>[xy])[_\s.-]?(?P<name>.+)$", re.IGNORECASE),
    re.compile(r"^(?P<name>.+?)[_\s.-]?(?P<axis>[xy])$", re.IGNORECASE),
)


# --------------------------------------------------------------------------- parsing


def _read_head(path: Path) -> tuple[dict[str, str], int, str]:
    """``# key: value`` metadata, number of such lines, and the header line."""
    meta: dict[str, str] = {}
    n = 0
    try:
        with open(path, encoding="utf-8-sig") as fh:
            for line in fh:
                stripped = line.strip()
                if stripped.startswith("#"):
                    key, sep, value = stripped[1:].partition(":")
                    if sep:
                        meta[key.strip().lower()] = value.strip()
                    n += 1
                    continue
                if not stripped:
                    n += 1
                    continue
                return meta, n, stripped
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a UTF-8 text file") from None
    except IsADirectoryError:
        raise InputError(f"{path}: is a directory, not a CSV file") from None
    raise InputError(f"{path}: empty CSV file (no header line)")


def _guess_sep(path: Path, header: str, delimiter: Any) -> str:
    if delimiter is not None:
        return option_str(path, "delimiter", delimiter)
    if path.suffix.lower() == ".tsv" or "\t" in header:
        return "\t"
    if "," in header:
        return ","
    if ";" in header:
        return ";"
    return r"\s+"


def _split_header(header: str, sep: str) -> list[str]:
    parts = re.split(r"\s+", header) if sep == r"\s+" else header.split(sep)
    return [p.strip().strip('"').strip("'") for p in parts]


def _find(columns: list[str], role: str, given: Any, path: Path) -> str | None:
    """The column playing ``role``: the given name, else the first alias present."""
    if given is not None:
        name = option_str(path, f"{role}_col", given)
        if name not in columns:
            raise InputError(
                f"{path}: no column {name!r} (for {role}); columns are: {', '.join(columns)}"
            )
        return name
    lower = {c.lower(): c for c in columns}
    for alias in ALIASES[role]:
        if alias in lower:
            return lower[alias]
    return None


def _comment_lines(path: Path, n_meta: int) -> list[int]:
    """Line numbers (0-based) of lines starting with ``#`` after the header.

    Some trackers write comments among the rows (YetAnotherTracker puts the video name
    and its command line after the header); ``comment="#"`` would also cut names like
    TRex's ``X#wcentroid``, so only whole lines are skipped.
    """
    try:
        data = path.read_bytes()
    except OSError:
        return []
    if b"\n#" not in data:
        return []
    arr = np.frombuffer(data, dtype=np.uint8)
    starts = np.flatnonzero(arr[:-1] == 10) + 1  # the character after each newline
    lines = np.flatnonzero(arr[starts] == ord("#")) + 1
    return [int(v) for v in lines if v > n_meta]


def _has_comment_lines(path: Path) -> bool:
    """Whether some line after the first starts with ``#`` (a C-speed scan of the file)."""
    try:
        with open(path, "rb") as fh, mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as mm:
            return mm.find(b"\n#") >= 0
    except (OSError, ValueError):  # empty files cannot be mapped
        return False


def _read_table(path: Path, n_meta: int, sep: str, text_cols: list[str]) -> pd.DataFrame:
    skip: int | list[int] = n_meta
    if _has_comment_lines(path):  # rare: comment lines among the rows
        comments = _comment_lines(path, n_meta)
        if comments:
            skip = [*range(n_meta), *comments]
    return _parse_table(path, skip, sep, text_cols)


def _parse_table(
    path: Path, skip: int | list[int], sep: str, text_cols: list[str]
) -> pd.DataFrame:
    try:
        with warnings.catch_warnings():
            # pandas only warns when a row has more fields than the header, and drops them
            warnings.simplefilter("error", pd.errors.ParserWarning)
            df = pd.read_csv(
                path,
                sep=sep,
                skiprows=skip,
                index_col=False,
                dtype={c: object for c in text_cols},
                skipinitialspace=True,
                encoding="utf-8-sig",
                engine="c" if sep != r"\s+" else "python",
            )
    except pd.errors.EmptyDataError:
        raise InputError(f"{path}: empty CSV file") from None
    except (pd.errors.ParserError, pd.errors.ParserWarning) as exc:
        detail = str(exc).strip().splitlines()[-1]
        raise InputError(f"{path}: malformed CSV ({detail})") from None
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a UTF-8 text file") from None
    df.columns = [str(c).strip() for c in df.columns]
    if len(df) == 0:
        raise InputError(f"{path}: no data rows after the header")
    return df


def _units_from(path: Path, options: dict[str, Any], meta: dict[str, str], x_col: str | None):
    """Length unit: option, else a unit suffix on the x column, else the metadata line."""
    if options.get("units") is not None:
        return option_str(path, "units", options["units"]), False
    if x_col is not None:
        m = re.search(r"_(px|mm|cm|m)$", x_col.lower())
        if m:
            return m.group(1), True
    if "space_unit" in meta:
        return meta["space_unit"], True
    return None, False


def _times(
    path: Path,
    df: pd.DataFrame,
    time_col: str | None,
    frame_col: str | None,
    options: dict[str, Any],
    fps: float | None,
) -> tuple[np.ndarray, float | None, dict[str, Any]]:
    """Time key of each row: ``(seconds, None, attrs)`` from a time column, or
    ``(frame numbers, fps, attrs)`` from a frame column and the frame rate."""
    if time_col is not None:
        unit = option_str(
            path, "time_unit", options.get("time_unit", "s"), tuple(SECONDS_PER_UNIT)
        )
        t = as_float_column(path, df[time_col].to_numpy(), time_col) * SECONDS_PER_UNIT[unit]
        return t, None, {}
    if frame_col is None:
        raise InputError(
            f"{path}: no time or frame column (columns: {', '.join(map(str, df.columns))}); "
            "name it with --read-option time_col=... or frame_col=..."
        )
    frames = as_float_column(path, df[frame_col].to_numpy(), frame_col)
    rate = require_fps(path, fps, "this CSV")
    return frames, rate, {"time_from": "frame / fps"}


# --------------------------------------------------------------------------- tidy


def _names(path: Path, df: pd.DataFrame, col: str) -> np.ndarray:
    """A name column as strings; an empty cell is an error naming the row."""
    values = df[col]
    missing = values.isna().to_numpy()
    if missing.any():
        row = int(np.flatnonzero(missing)[0])
        raise InputError(f"{path}: empty {col!r} in data row {row + 1}")
    return values.to_numpy(dtype=object)


def sniff_tidy(path: Path) -> bool:
    try:
        meta, _, header = _read_head(path)
    except InputError:
        return False
    cols = _split_header(header, _guess_sep(path, header, None))
    if "scorer" in (c.lower() for c in cols[:1]):
        return False
    lower = {c.lower() for c in cols}
    has_xy = bool(lower & set(ALIASES["x"])) and bool(lower & set(ALIASES["y"]))
    has_t = bool(lower & (set(ALIASES["time"]) | set(ALIASES["frame"])))
    return has_xy and has_t


def read_tidy(
    path: Path, *, fps: float | None = None, px_per_mm: float | None = None, **options: Any
) -> xr.Dataset:
    """Read a tidy CSV (see the module docstring) into the trajectory format."""
    check_options(path, "tidy_csv", options, TIDY_OPTIONS)
    meta, n_meta, header = _read_head(path)
    sep = _guess_sep(path, header, options.get("delimiter"))
    cols = _split_header(header, sep)
    ind_col = _find(cols, "individual", options.get("individual_col"), path)
    kp_col = _find(cols, "keypoint", options.get("keypoint_col"), path)
    df = _read_table(path, n_meta, sep, [c for c in (ind_col, kp_col) if c])
    cols = list(df.columns)
    x_col = _find(cols, "x", options.get("x_col"), path)
    y_col = _find(cols, "y", options.get("y_col"), path)
    if x_col is None or y_col is None:
        raise InputError(
            f"{path}: no x/y columns (columns: {', '.join(cols)}); "
            "name them with --read-option x_col=... y_col=..."
        )
    time_col = _find(cols, "time", options.get("time_col"), path)
    frame_col = _find(cols, "frame", options.get("frame_col"), path)
    conf_col = _find(cols, "confidence", options.get("confidence_col"), path)
    fps = resolve_fps(path, fps, check_fps(path, meta.get("fps")), "the file's header")
    key, rate, t_attrs = _times(path, df, time_col, frame_col, options, fps)
    units, from_file = _units_from(path, options, meta, x_col)
    scale, u_attrs = length_scale(path, units, px_per_mm, "this CSV", from_file=from_file)
    x = as_float_column(path, df[x_col].to_numpy(), x_col) * scale
    y = as_float_column(path, df[y_col].to_numpy(), y_col) * scale
    conf = as_float_column(path, df[conf_col].to_numpy(), conf_col) if conf_col else None
    if ind_col is None:
        individual = np.full(len(df), "id_0", dtype=object)
    else:
        individual = _names(path, df, ind_col)
    keypoint = None if kp_col is None else _names(path, df, kp_col)
    parts = assemble_long(
        path,
        individual=individual,
        time=key,
        x=x,
        y=y,
        keypoint=keypoint,
        confidence=conf,
        frame_rate=rate,
        duplicates=option_duplicates(path, options),
    )
    attrs = {**t_attrs, **u_attrs, **parts["attrs"]}
    return make_tracks(
        parts["position"],
        time=parts["time"],
        fps=fps,
        individuals=parts["individuals"],
        keypoints=parts["keypoints"],
        confidence=parts["confidence"],
        source_software=meta.get("source_software", "CSV (tidy)"),
        source_file=str(path),
        attrs=attrs,
    )


def write(
    ds: xr.Dataset,
    path: Path,
    *,
    dropna: bool = True,
    metadata: bool = True,
) -> None:
    """Write ``ds`` as a tidy CSV, atomically.

    Columns: ``individual, keypoint, time, frame, x, y, confidence`` -- ``time`` in
    seconds (each individual's own with per-individual clocks; absent when the
    dataset has frame numbers only), ``frame`` when the frame
    rate is known (``round(time * fps)``), ``x``/``y`` in mm, ``confidence`` when the
    dataset has one.  Rows where both x and y are missing are left out unless
    ``dropna=False``.  With ``metadata`` (default) the file starts with ``# key: value``
    lines (``space_unit``, ``time_unit``, ``fps``, ``source_software``).  Floats are
    written with the shortest repr that round-trips exactly.
    """
    path = Path(path)
    pos = ds["position"].transpose("time", "space", "keypoints", "individuals").values
    n_t, _, n_k, n_i = pos.shape
    t_idx, k_idx, i_idx = (
        a.ravel()
        for a in np.meshgrid(np.arange(n_t), np.arange(n_k), np.arange(n_i), indexing="ij")
    )
    x = pos[:, 0].ravel()
    y = pos[:, 1].ravel()
    keep = ~(np.isnan(x) & np.isnan(y)) if dropna else np.ones(x.size, dtype=bool)
    own = per_individual(ds)
    if own:  # rows past an individual's last sample are padding, not samples
        clock = ds["individual_time"].transpose("time", "individuals").values
        keep &= np.isfinite(clock[t_idx, i_idx])
    t_idx, k_idx, i_idx, x, y = t_idx[keep], k_idx[keep], i_idx[keep], x[keep], y[keep]
    ind_names = np.asarray([str(v) for v in ds["individuals"].values], dtype=object)
    kp_names = np.asarray([str(v) for v in ds["keypoints"].values], dtype=object)
    tvals = np.asarray(ds["time"].values, dtype=np.float64)
    fps = ds.attrs.get("fps")
    seconds = ds.attrs.get("time_unit", "seconds") == "seconds"
    cols: dict[str, Any] = {"individual": ind_names[i_idx], "keypoint": kp_names[k_idx]}
    if own:
        cols["time"] = clock[t_idx, i_idx]
        seconds = True
        if fps is not None:
            cols["frame"] = np.rint(cols["time"] * float(fps)).astype(np.int64)
    elif seconds:
        cols["time"] = tvals[t_idx]
        if fps is not None:
            cols["frame"] = np.rint(tvals[t_idx] * float(fps)).astype(np.int64)
    else:
        cols["frame"] = np.rint(tvals[t_idx]).astype(np.int64)
        if fps is not None:
            cols["time"] = tvals[t_idx] / float(fps)
    cols["x"] = x
    cols["y"] = y
    if "confidence" in ds:
        conf = ds["confidence"].transpose("time", "keypoints", "individuals").values
        cols["confidence"] = conf[t_idx, k_idx, i_idx]
    order = [
        c for c in ("individual", "keypoint", "time", "frame", "x", "y", "confidence") if c in cols
    ]
    frame = pd.DataFrame({c: cols[c] for c in order})
    buf = _io.StringIO()
    if metadata:
        buf.write("# thermoswarm tidy CSV\n")
        buf.write(f"# space_unit: {ds.attrs.get('space_unit', 'mm')}\n")
        buf.write(f"# time_unit: {'s' if seconds or fps is not None else 'frames'}\n")
        if fps is not None:
            buf.write(f"# fps: {float(fps)!r}\n")
        src = str(ds.attrs.get("source_software", "")).replace("\n", " ")
        if src:
            buf.write(f"# source_software: {src}\n")
    sep = "\t" if path.suffix.lower() == ".tsv" else ","
    frame.to_csv(buf, index=False, sep=sep, lineterminator="\n")
    atomic_write_text(path, buf.getvalue())


# --------------------------------------------------------------------------- wide


def _wide_pairs(columns: list[str], skip: set[str]) -> list[tuple[str, str, str]]:
    """``(name, x column, y column)`` for each individual, in column order."""
    for pattern in _WIDE_PATTERNS:
        xs: dict[str, str] = {}
        ys: dict[str, str] = {}
        for c in columns:
            if c in skip:
                continue
            m = pattern.match(c)
            if not m:
                continue
            (xs if m.group("axis").lower() == "x" else ys)[m.group("name")] = c
        names = [n for n in xs if n in ys]
        if names:
            return [(n, xs[n], ys[n]) for n in names]
    return []


def _wide_name(name: str) -> str:
    return f"id_{name}" if name.isdigit() else name


def _frame_like_first(path: Path, cols: list[str], sep: str, n_meta: int) -> str | None:
    """The first column, when it is not an x/y column, every other column is one of
    x/y pairs, and its first values are integers: a frame number by another name."""
    if len(cols) < 3 or len(cols) % 2 == 0:
        return None
    pairs = _wide_pairs(cols, {cols[0]})
    if 2 * len(pairs) != len(cols) - 1 or any(cols[0] in (xc, yc) for _, xc, yc in pairs):
        return None
    try:
        head = pd.read_csv(
            path,
            sep=sep,
            skiprows=n_meta,
            nrows=20,
            usecols=[0],
            encoding="utf-8-sig",
            engine="c" if sep != r"\s+" else "python",
        )
    except Exception:  # a sniffer never raises; the reader reports the real problem
        return None
    v = pd.to_numeric(head.iloc[:, 0], errors="coerce").to_numpy(dtype=np.float64)
    if v.size == 0 or not np.all(np.isfinite(v)) or np.any(v != np.rint(v)):
        return None
    return cols[0]


def sniff_wide(path: Path) -> bool:
    try:
        _, n_meta, header = _read_head(path)
    except InputError:
        return False
    sep = _guess_sep(path, header, None)
    cols = _split_header(header, sep)
    lower = {c.lower() for c in cols}
    if lower & set(ALIASES["individual"]):
        return False
    has_t = bool(lower & (set(ALIASES["time"]) | set(ALIASES["frame"])))
    if has_t:
        return bool(_wide_pairs(cols, set()))
    return _frame_like_first(path, cols, sep, n_meta) is not None


def read_wide(
    path: Path, *, fps: float | None = None, px_per_mm: float | None = None, **options: Any
) -> xr.Dataset:
    """Read a wide CSV (see the module docstring) into the trajectory format."""
    check_options(path, "wide_csv", options, WIDE_OPTIONS)
    duplicates = option_duplicates(path, options)
    meta, n_meta, header = _read_head(path)
    sep = _guess_sep(path, header, options.get("delimiter"))
    df = _read_table(path, n_meta, sep, [])
    cols = list(df.columns)
    time_col = _find(cols, "time", options.get("time_col"), path)
    frame_col = _find(cols, "frame", options.get("frame_col"), path)
    t_attrs: dict[str, Any] = {}
    if time_col is None and frame_col is None:
        frame_col = _frame_like_first(path, cols, sep, n_meta)
        if frame_col is not None:
            t_attrs["time_from"] = f"first column {frame_col!r} read as frame numbers"
    pairs = _wide_pairs(cols, {c for c in (time_col, frame_col) if c})
    if not pairs:
        raise InputError(
            f"{path}: no x/y column pairs (expected x0, y0, x1, y1 ... or name_x, name_y); "
            f"columns are: {', '.join(cols)}"
        )
    fps = resolve_fps(path, fps, check_fps(path, meta.get("fps")), "the file's header")
    key, rate, more = _times(path, df, time_col, frame_col, options, fps)
    t_attrs = {**more, **t_attrs}
    if not np.all(np.isfinite(key)):
        row = int(np.flatnonzero(~np.isfinite(key))[0])
        raise InputError(f"{path}: missing or non-finite time/frame in data row {row + 1}")
    units, from_file = _units_from(path, options, meta, None)
    scale, u_attrs = length_scale(path, units, px_per_mm, "this CSV", from_file=from_file)
    n_rows, n_ind = len(df), len(pairs)
    x = np.empty((n_rows, n_ind))
    y = np.empty((n_rows, n_ind))
    for i, (_, xc, yc) in enumerate(pairs):
        x[:, i] = as_float_column(path, df[xc].to_numpy(), xc) * scale
        y[:, i] = as_float_column(path, df[yc].to_numpy(), yc) * scale
    names = unique_names(path, [_wide_name(n) for n, _, _ in pairs], "individual")
    # one long table (row-major: every individual of a row together); the frames or
    # times of a row are one instant for every individual: a shared clock
    parts = assemble_long(
        path,
        individual=np.tile(np.asarray(names, dtype=object), n_rows),
        time=np.repeat(key, n_ind),
        x=x.ravel(),
        y=y.ravel(),
        individual_order=names,
        frame_rate=rate,
        duplicates=duplicates,
        clock="shared",
    )
    return make_tracks(
        parts["position"],
        time=parts["time"],
        fps=fps,
        individuals=names,
        source_software=meta.get("source_software", "CSV (wide)"),
        source_file=str(path),
        attrs={**t_attrs, **u_attrs, **parts["attrs"]},
    )


TIDY = SimpleNamespace(
    sniff=sniff_tidy, read=read_tidy, write=write, OPTIONS=TIDY_OPTIONS, NEEDS=NEEDS
)
WIDE = SimpleNamespace(sniff=sniff_wide, read=read_wide, OPTIONS=WIDE_OPTIONS, NEEDS=NEEDS)
