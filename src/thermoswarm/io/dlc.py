"""DeepLabCut predictions: ``.csv`` (3- or 4-row header) and ``.h5`` (pandas HDFStore).

Both hold one table: rows are frames (the first column / the index is the frame
number), columns a MultiIndex ``scorer / [individuals /] bodyparts / coords`` with
``coords`` in ``x, y, likelihood``.  Single-animal files have no ``individuals``
level (one individual, ``id_0``).  Multi-animal files may give some individuals
only some body parts (DeepLabCut's ``single`` individual for unique body parts):
the keypoints are the union, NaN where an individual has no such part.
``likelihood`` becomes ``confidence``.  Positions are pixels (``--px-per-mm``) and
there are no times (``--fps``).

Why the ``.h5`` reader does not call ``pandas.read_hdf``: DeepLabCut writes the
table with ``format="table"``, and PyTables stores that table's column names as
*pickled* attributes, which ``read_hdf`` unpickles -- running code from the file.
This module reads the same file with h5py and decodes those attributes with an
unpickler that refuses every global (:class:`_NamesOnly`), so only strings, numbers,
lists and tuples can come out.  No pickle in such a file needs more; one that does
is refused.  (``format="fixed"`` files store plain arrays and are read directly.)
"""

from __future__ import annotations

import io as _io
import pickle
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from thermoswarm.errors import InputError
from thermoswarm.io._common import (
    as_float_column,
    check_dense_size,
    check_options,
    check_unique_frames,
    decode_names,
    h5_file,
    h5_read,
    require_fps,
    require_px_per_mm,
)
from thermoswarm.tracks import make_tracks

OPTIONS = {
    "key": 'HDF5 key of the table in a .h5 (default: "df_with_missing", else the only table)',
}
NEEDS = "--fps and --px-per-mm (DeepLabCut stores neither)"


# --------------------------------------------------------------------------- sniffing


def sniff(path: Path) -> bool:
    if path.suffix.lower() == ".csv":
        try:
            with open(path, encoding="utf-8-sig") as fh:
                first = fh.readline()
        except (UnicodeDecodeError, OSError):
            return False
        return first.split(",", 1)[0].strip().lower() == "scorer"
    import h5py

    try:
        with h5py.File(path, "r") as fh:
            return any(isinstance(fh[k], h5py.Group) and "pandas_type" in fh[k].attrs for k in fh)
    except Exception:
        return False


# --------------------------------------------------------------------------- table -> tracks


def _tracks_from_columns(
    path: Path,
    columns: list[tuple[str, ...]],
    values: np.ndarray,
    frames: np.ndarray,
    scale: float,
    fps: float,
) -> xr.Dataset:
    """Turn DLC columns (``(scorer, [individual,] bodypart, coord)``) into tracks."""
    if not columns:
        raise InputError(f"{path}: no data columns")
    nlev = {len(c) for c in columns}
    if nlev not in ({3}, {4}):
        raise InputError(
            f"{path}: expected a 3-row (scorer, bodyparts, coords) or 4-row (scorer, "
            f"individuals, bodyparts, coords) header, got {sorted(nlev)} levels"
        )
    multi = nlev == {4}
    scorers = sorted({c[0] for c in columns})
    inds: list[str] = []
    kps: list[str] = []
    for c in columns:
        ind = c[1] if multi else "id_0"
        kp = c[-2]
        if ind not in inds:
            inds.append(ind)
        if kp not in kps:
            kps.append(kp)
    coords = {c[-1] for c in columns}
    if "z" in coords:
        raise InputError(f"{path}: 3-D (x, y, z) data; only 2-D positions are supported")
    if not {"x", "y"} <= coords:
        raise InputError(f"{path}: coords level must hold x and y, got {sorted(coords)}")
    unknown = coords - {"x", "y", "likelihood"}
    if unknown:
        raise InputError(f"{path}: unexpected coords {sorted(unknown)} (want x, y, likelihood)")
    n = values.shape[0]
    check_dense_size(path, n, len(kps), len(inds))
    has_conf = "likelihood" in coords
    kp_of = {kp: k for k, kp in enumerate(kps)}
    ind_of = {ind: i for i, ind in enumerate(inds)}
    coord_of = {"x": 0, "y": 1, "likelihood": 2}
    # column of each (coord, keypoint, individual); a missing pair points at a NaN column
    missing = values.shape[1]
    idx = np.full((3, len(kps), len(inds)), missing, dtype=np.int64)
    for j, c in enumerate(columns):
        cell = (coord_of[c[-1]], kp_of[c[-2]], ind_of[c[1] if multi else "id_0"])
        if idx[cell] != missing:
            raise InputError(f"{path}: column {c} appears twice")
        idx[cell] = j
    n_c, n_k, n_i = 3 if has_conf else 2, len(kps), len(inds)
    idx = idx[:n_c]
    regular = np.arange(n_i * n_k * n_c).reshape(n_i, n_k, n_c).transpose(2, 1, 0)
    if values.shape[1] == idx.size and np.array_equal(idx, regular):
        # DeepLabCut's own column order (individual, bodypart, coord): a reshaped view
        gathered = values.reshape(n, n_i, n_k, n_c).transpose(0, 3, 2, 1)
    else:
        if (idx == missing).any():
            values = np.hstack([values, np.full((n, 1), np.nan)])
        gathered = np.take(values, idx.reshape(-1), axis=1).reshape(n, n_c, n_k, n_i)
    pos = gathered[:, :2] / scale
    conf = gathered[:, 2].astype(np.float32) if has_conf else None
    return make_tracks(
        pos,
        time=frames / fps,
        fps=fps,
        individuals=inds,
        keypoints=kps,
        confidence=conf,
        source_software="DeepLabCut",
        source_file=str(path),
        attrs={"px_per_mm": scale, "source_space_unit": "px", "dlc_scorer": ", ".join(scorers)},
    )


def _frame_numbers(path: Path, index: np.ndarray) -> np.ndarray:
    """The index column as frame numbers (DeepLabCut predictions: 0, 1, 2, ...)."""
    try:
        frames = np.asarray(index, dtype=np.float64)
    except (TypeError, ValueError):
        first = str(index[0])[:60] if len(index) else ""
        raise InputError(
            f"{path}: the first column is not frame numbers (e.g. {first!r}); this looks "
            "like a DeepLabCut labelled-data file, not predictions on a video"
        ) from None
    if not np.all(np.isfinite(frames)):
        raise InputError(f"{path}: missing frame number in the first column")
    check_unique_frames(path, frames, "frame")  # two rows of one frame: which is it?
    return frames


# --------------------------------------------------------------------------- CSV


def _read_csv(path: Path, scale: float, fps: float) -> xr.Dataset:
    try:
        with open(path, encoding="utf-8-sig") as fh:
            head = [fh.readline() for _ in range(4)]
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a UTF-8 text file") from None
    labels = [h.split(",", 1)[0].strip().lower() for h in head]
    if labels[:1] != ["scorer"]:
        raise InputError(f"{path}: not a DeepLabCut CSV (first cell is not 'scorer')")
    if labels[1:4] == ["individuals", "bodyparts", "coords"]:
        nrows = 4
    elif labels[1:3] == ["bodyparts", "coords"]:
        nrows = 3
    else:
        raise InputError(
            f"{path}: DeepLabCut header rows must be scorer, [individuals,] bodyparts, "
            f"coords; got {', '.join(labels[:4])}"
        )
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", pd.errors.ParserWarning)
            df = pd.read_csv(path, header=list(range(nrows)), encoding="utf-8-sig")
    except (pd.errors.ParserError, pd.errors.ParserWarning) as exc:
        detail = str(exc).strip().splitlines()[-1][:160]
        raise InputError(f"{path}: malformed CSV ({detail})") from None
    except pd.errors.EmptyDataError:
        raise InputError(f"{path}: empty file") from None
    if len(df) == 0:
        raise InputError(f"{path}: no data rows after the {nrows}-row header")
    index = df.iloc[:, 0].to_numpy()
    frames = _frame_numbers(path, index)
    data = df.iloc[:, 1:]
    columns = [tuple(str(v).strip() for v in c) for c in data.columns]
    values = (
        np.column_stack(
            [
                as_float_column(path, data.iloc[:, j].to_numpy(), "/".join(columns[j]))
                for j in range(data.shape[1])
            ]
        )
        if data.shape[1]
        else np.zeros((len(df), 0))
    )
    return _tracks_from_columns(path, columns, values, frames, scale, fps)


# --------------------------------------------------------------------------- HDF5


class _NamesOnly(pickle.Unpickler):
    """An unpickler that builds only plain data: any class or function is refused.

    Hand-written because no library decodes PyTables' pickled attributes safely;
    the pattern is the one the Python documentation gives ("Restricting Globals").
    """

    def find_class(self, module: str, name: str) -> Any:  # noqa: D401
        raise pickle.UnpicklingError(f"refusing to load {module}.{name}")


def _unpickle_plain(path: Path, raw: Any, what: str) -> Any:
    if isinstance(raw, np.ndarray) and raw.dtype.kind in "SV":
        raw = raw.tobytes()
    if isinstance(raw, np.bytes_ | bytes):
        data = bytes(raw)
    else:
        return raw
    try:
        return _NamesOnly(_io.BytesIO(data)).load()
    except Exception as exc:
        raise InputError(
            f"{path}: cannot decode {what} safely ({exc}); the file holds objects other than names"
        ) from None


def _table_key(path: Path, fh: Any, key: Any) -> str:
    import h5py

    if key is not None:
        if not isinstance(key, str) or key not in fh or not isinstance(fh[key], h5py.Group):
            raise InputError(f"{path}: no table {key!r} in this HDF5 file")
        return key
    if "df_with_missing" in fh:
        return "df_with_missing"
    tables = [k for k in fh if isinstance(fh[k], h5py.Group) and "pandas_type" in fh[k].attrs]
    if len(tables) != 1:
        raise InputError(
            f"{path}: {'no' if not tables else len(tables)} pandas tables; expected "
            "DeepLabCut's 'df_with_missing' (choose one with --read-option key=...)"
        )
    return tables[0]


def _read_fixed(path: Path, grp: Any) -> tuple[list[tuple[str, ...]], np.ndarray, np.ndarray]:
    """pandas ``format="fixed"`` frame: plain arrays, one value block per dtype."""
    nblocks = int(grp.attrs.get("nblocks", 0))
    nlev = int(grp.attrs.get("axis0_nlevels", 1))

    def level_names(prefix: str) -> list[tuple[str, ...]]:
        if nlev == 1:
            return [(n,) for n in decode_names(h5_read(path, grp, prefix))]
        levels = [decode_names(h5_read(path, grp, f"{prefix}_level{i}")) for i in range(nlev)]
        codes = [np.asarray(h5_read(path, grp, f"{prefix}_label{i}")) for i in range(nlev)]
        return [tuple(levels[i][codes[i][j]] for i in range(nlev)) for j in range(len(codes[0]))]

    index = np.asarray(h5_read(path, grp, "axis1"))
    cols: list[tuple[str, ...]] = []
    blocks = []
    for b in range(nblocks):
        cols += level_names(f"block{b}_items")
        vals = np.asarray(h5_read(path, grp, f"block{b}_values"))
        if vals.ndim != 2 or vals.dtype.kind not in "fiu":
            raise InputError(f"{path}: value block {b} is not a numeric table")
        blocks.append(vals.astype(np.float64))
    if not blocks:
        raise InputError(f"{path}: no value blocks in the table")
    return cols, np.hstack(blocks), index


def _read_table(path: Path, grp: Any) -> tuple[list[tuple[str, ...]], np.ndarray, np.ndarray]:
    """pandas ``format="table"`` frame: a compound dataset, names in pickled attrs."""
    if "table" not in grp:
        raise InputError(f"{path}: pandas table group has no 'table' dataset")
    table = h5_read(path, grp, "table")
    if table.dtype.names is None or "index" not in table.dtype.names:
        raise InputError(f"{path}: the pandas table has no index column")
    attrs = grp["table"].attrs
    cols: list[tuple[str, ...]] = []
    blocks = []
    for name in table.dtype.names:
        if name == "index":
            continue
        kind = _unpickle_plain(path, attrs.get(f"{name}_kind"), f"{name}_kind")
        if not isinstance(kind, list):
            raise InputError(f"{path}: no column names for block {name!r}")
        vals = np.ascontiguousarray(table[name])  # a field view strides over records
        if vals.ndim == 1:
            vals = vals[:, None]
        if vals.dtype.kind not in "fiu":
            raise InputError(f"{path}: block {name!r} is not numeric")
        if vals.shape[1] != len(kind):
            raise InputError(
                f"{path}: block {name!r} has {vals.shape[1]} columns, {len(kind)} names"
            )
        for k in kind:
            cols.append(tuple(str(v) for v in (k if isinstance(k, tuple) else (k,))))
        blocks.append(vals.astype(np.float64, copy=False))
    if not blocks:
        raise InputError(f"{path}: no value blocks in the table")
    values = blocks[0] if len(blocks) == 1 else np.hstack(blocks)
    return cols, values, np.asarray(table["index"])


def _read_h5(path: Path, scale: float, fps: float, key: Any) -> xr.Dataset:
    with h5_file(path, "DeepLabCut") as fh:
        name = _table_key(path, fh, key)
        grp = fh[name]
        ptype = grp.attrs.get("pandas_type", b"")
        ptype = ptype.decode() if isinstance(ptype, bytes) else str(ptype)
        if ptype == "frame_table":
            cols, values, index = _read_table(path, grp)
        elif ptype == "frame":
            cols, values, index = _read_fixed(path, grp)
        else:
            raise InputError(f"{path}: pandas object {name!r} is a {ptype!r}, not a DataFrame")
    frames = _frame_numbers(path, index)
    return _tracks_from_columns(path, cols, values, frames, scale, fps)


def read(
    path: Path, *, fps: float | None = None, px_per_mm: float | None = None, **options: Any
) -> xr.Dataset:
    """Read DeepLabCut predictions (see the module docstring) in mm and seconds."""
    check_options(path, "dlc", options, OPTIONS)
    rate = require_fps(path, fps, "DeepLabCut")
    scale = require_px_per_mm(path, px_per_mm, "DeepLabCut")
    if path.suffix.lower() == ".csv":
        if "key" in options:
            raise InputError(f"{path}: option key applies to .h5 files only")
        return _read_csv(path, scale, rate)
    return _read_h5(path, scale, rate, options.get("key"))
