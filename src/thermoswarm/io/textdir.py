"""Plain text trajectories: one file per individual with columns ``t x y``.

A single file is one individual; a folder of such files is a group, each file one
individual named after its stem (``ant07.txt`` -> ``ant07``), in natural order.
Columns are separated by spaces, tabs or commas; lines starting with ``#`` are
comments (``# space_unit: mm`` and ``# fps: 30`` are read as metadata).  An optional
header line names the columns (``t x y``, ``time x y``, ``frame x y``, ...); without
one the columns are ``t x y`` (change with the ``columns`` option, e.g.
``["frame", "x", "y"]``).

Each file's rows are sorted by time; an exact duplicate row is dropped and counted,
two different rows at one time are resolved by the ``duplicates`` option (an error by
default, or ``"first"`` / ``"mean"``) and counted.  Files whose times are all the same
share one time axis; otherwise every individual keeps its own clock (no union of all
files' times: see :mod:`thermoswarm.tracks`).  Frame numbers with ``--fps`` are one
shared clock.
"""

from __future__ import annotations

import fnmatch
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from thermoswarm.errors import InputError
from thermoswarm.io._common import (
    DUPLICATES_HELP,
    SECONDS_PER_UNIT,
    as_float_column,
    assemble_long,
    check_fps,
    check_options,
    length_scale,
    natural_key,
    option_duplicates,
    option_str,
    option_str_list,
    require_fps,
    resolve_fps,
)
from thermoswarm.io.csv import ALIASES
from thermoswarm.tracks import make_tracks

OPTIONS = {
    "columns": 'column names for files without a header (default ["t", "x", "y"]; '
    'use "frame" for frame numbers, "_" to skip a column)',
    "pattern": 'file name pattern(s) in a folder (default ["*.txt", "*.dat", "*.xy"])',
    "units": 'length unit when no --px-per-mm: "mm", "cm", "m", "um" or "px"',
    "time_unit": 'unit of the t column: "s" (default), "ms", "us", "min", "h"',
    "duplicates": DUPLICATES_HELP,
}
NEEDS = "--px-per-mm or units=...; --fps when the files have frame numbers"

DEFAULT_PATTERNS = ["*.txt", "*.dat", "*.xy"]


def _head(path: Path) -> tuple[dict[str, str], int, str | None]:
    """Metadata from ``#`` lines, how many lines precede the first row, that row."""
    meta: dict[str, str] = {}
    n = 0
    with open(path, encoding="utf-8-sig") as fh:
        for line in fh:
            s = line.strip()
            if not s or s.startswith("#"):
                if s.startswith("#"):
                    key, sep, value = s[1:].partition(":")
                    if sep:
                        meta[key.strip().lower()] = value.strip()
                n += 1
                continue
            return meta, n, s
    return meta, n, None


def _tokens(line: str) -> list[str]:
    return [p for p in line.replace(",", " ").replace(";", " ").split() if p]


def _is_number(tok: str) -> bool:
    try:
        float(tok)
    except ValueError:
        return False
    return True


def _role(name: str) -> str | None:
    low = name.lower()
    for role in ("time", "frame", "x", "y"):
        if low in ALIASES[role]:
            return role
    return None


def _sniff_file(path: Path) -> bool:
    try:
        _, _, first = _head(path)
    except (UnicodeDecodeError, OSError):
        return False
    if first is None:
        return False
    toks = _tokens(first)
    if all(_is_number(t) for t in toks):
        return 3 <= len(toks) <= 5
    roles = {_role(t) for t in toks}
    return {"x", "y"} <= roles and bool(roles & {"time", "frame"})


def _files(folder: Path, patterns: list[str]) -> list[Path]:
    found = [
        p
        for p in folder.iterdir()
        if p.is_file()
        and not p.name.startswith(".")
        and any(fnmatch.fnmatch(p.name.lower(), pat.lower()) for pat in patterns)
    ]
    return sorted(found, key=lambda p: natural_key(p.stem))


def sniff(path: Path) -> bool:
    if path.is_dir():
        files = _files(path, DEFAULT_PATTERNS)
        return bool(files) and _sniff_file(files[0])
    return _sniff_file(path)


def _read_one(
    path: Path, columns: list[str] | None
) -> tuple[dict[str, str], dict[str, np.ndarray]]:
    """Columns of one file by role (``time``/``frame``/``x``/``y``) as float arrays."""
    try:
        meta, n_skip, first = _head(path)
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a UTF-8 text file") from None
    if first is None:
        raise InputError(f"{path}: empty file (no data rows)")
    toks = _tokens(first)
    has_header = not all(_is_number(t) for t in toks)
    if has_header:
        names = toks
        n_skip += 1
    else:
        names = columns or ["t", "x", "y"]
        if len(toks) < len(names):
            raise InputError(
                f"{path}: first data row has {len(toks)} columns, expected at least "
                f"{len(names)} ({' '.join(names)})"
            )
    roles: dict[str, int] = {}
    for i, name in enumerate(names):
        role = _role(name)
        if role is not None and role not in roles:
            roles[role] = i
    missing = [r for r in ("x", "y") if r not in roles]
    if missing or not ({"time", "frame"} & set(roles)):
        raise InputError(
            f"{path}: cannot find t (or frame), x and y among the columns {names}; "
            'set them with --read-option columns=["t", "x", "y"]'
        )
    sep = "," if "," in first else r"\s+"
    try:
        df = pd.read_csv(
            path,
            sep=sep,
            header=None,
            skiprows=n_skip,
            comment="#",
            usecols=sorted(roles.values()),
            skipinitialspace=True,
            encoding="utf-8-sig",
        )
    except pd.errors.EmptyDataError:
        raise InputError(f"{path}: no data rows") from None
    except (pd.errors.ParserError, ValueError) as exc:
        detail = str(exc).strip().splitlines()[-1][:160]
        raise InputError(f"{path}: malformed text table ({detail})") from None
    if len(df) == 0:
        raise InputError(f"{path}: no data rows")
    out = {
        role: as_float_column(path, df[idx].to_numpy(), names[idx]) for role, idx in roles.items()
    }
    return meta, out


def read(
    path: Path, *, fps: float | None = None, px_per_mm: float | None = None, **options: Any
) -> xr.Dataset:
    """Read one ``t x y`` file or a folder of them (see the module docstring)."""
    check_options(path, "text", options, OPTIONS)
    columns = (
        option_str_list(path, "columns", options["columns"]) if "columns" in options else None
    )
    patterns = (
        option_str_list(path, "pattern", options["pattern"])
        if "pattern" in options
        else DEFAULT_PATTERNS
    )
    unit_t = option_str(path, "time_unit", options.get("time_unit", "s"), tuple(SECONDS_PER_UNIT))
    if path.is_dir():
        files = _files(path, patterns)
        if not files:
            raise InputError(
                f"{path}: no files matching {', '.join(patterns)}; "
                'set --read-option pattern="*.csv" for other names'
            )
    else:
        files = [path]
    metas, tables = [], []
    for f in files:
        meta, cols = _read_one(f, columns)
        metas.append(meta)
        tables.append(cols)
    meta = metas[0]
    file_fps = check_fps(path, meta.get("fps"))
    fps = resolve_fps(path, fps, file_fps, "the file's header")
    attrs: dict[str, Any] = {}
    times = []
    for f, cols in zip(files, tables, strict=True):
        if "time" in cols:
            times.append(cols["time"] * SECONDS_PER_UNIT[unit_t])
        else:
            rate = require_fps(f, fps, "this text file")
            attrs["time_from"] = "frame / fps"
            times.append(cols["frame"] / rate)
    units = options.get("units")
    from_file = False
    if units is None and "space_unit" in meta:
        units, from_file = meta["space_unit"], True
    elif units is not None:
        units = option_str(path, "units", units)
    scale, u_attrs = length_scale(path, units, px_per_mm, "these text files", from_file=from_file)
    attrs.update(u_attrs)
    names = [f.stem for f in files]
    common = dict(fps=fps, source_software="text (t x y)", source_file=str(path))
    for f, t in zip(files, times, strict=True):
        if not np.all(np.isfinite(t)):
            row = int(np.flatnonzero(~np.isfinite(t))[0])
            raise InputError(f"{f}: missing or non-finite time in data row {row + 1}")
    individual = np.concatenate(
        [np.full(t.size, n, dtype=object) for n, t in zip(names, times, strict=True)]
    )
    all_frames = fps is not None and all("time" not in c for c in tables)
    parts = assemble_long(
        path,
        individual=individual,
        time=np.concatenate([c["frame"] for c in tables] if all_frames else times),
        frame_rate=fps if all_frames else None,
        x=np.concatenate([c["x"] for c in tables]) * scale,
        y=np.concatenate([c["y"] for c in tables]) * scale,
        individual_order=names,
        duplicates=option_duplicates(path, options),
        individual_sources=files,
    )
    return make_tracks(
        parts["position"],
        time=parts["time"],
        individuals=parts["individuals"],
        attrs={**attrs, **parts["attrs"]},
        **common,
    )
