"""thermoswarm Zarr stores: simulation recordings, read up to the committed frame.

The simulation engine streams the trajectory format into a Zarr (v3) store and,
after each block of frames is fully written, sets the root attribute
``committed_frames`` (an int).  Frames at or after it may be half-written (a run
killed mid-block), so this reader returns only ``time[:committed_frames]``.  A
store without the attribute is taken as complete (e.g. written in one go by
``xarray.Dataset.to_zarr``).

The store is opened without consolidated metadata: a store that grows while being
written may carry a stale consolidated copy, whereas each array's own metadata is
current.  The marker is read before the data, so every frame returned had been
written before it was committed.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.errors import InputError
from thermoswarm.io._common import check_declared_size, check_options, length_scale
from thermoswarm.tracks import validate_tracks

OPTIONS: dict[str, str] = {}
NEEDS = "nothing (mm and seconds are recorded in the store)"


def sniff(path: Path) -> bool:
    return path.is_dir() and ((path / "zarr.json").is_file() or (path / ".zgroup").is_file())


def _committed(path: Path) -> int | None:
    """The ``committed_frames`` root attribute, read straight from the metadata file."""
    meta = path / "zarr.json"
    try:
        if meta.is_file():
            attrs = json.loads(meta.read_text(encoding="utf-8")).get("attributes", {})
        elif (path / ".zattrs").is_file():
            attrs = json.loads((path / ".zattrs").read_text(encoding="utf-8"))
        else:
            attrs = {}
    except (OSError, ValueError, AttributeError):
        raise InputError(f"{path}: unreadable Zarr root metadata") from None
    if not isinstance(attrs, dict) or "committed_frames" not in attrs:
        return None
    value = attrs["committed_frames"]
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise InputError(f"{path}: committed_frames must be an integer >= 0, got {value!r}")
    return value


def read(
    path: Path, *, fps: float | None = None, px_per_mm: float | None = None, **options: Any
) -> xr.Dataset:
    """Read a thermoswarm Zarr store, only its committed frames, into memory."""
    check_options(path, "zarr", options, OPTIONS)
    if not sniff(path):
        raise InputError(f"{path}: not a Zarr store (no zarr.json)")
    committed = _committed(path)
    if committed == 0:
        raise InputError(f"{path}: no committed frames yet (committed_frames = 0)")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            store = xr.open_zarr(path, consolidated=False)
    except Exception as exc:  # zarr raises many types for damaged metadata
        raise InputError(f"{path}: not a readable Zarr store ({type(exc).__name__})") from None
    if "position" not in store or "time" not in store.dims:
        raise InputError(f"{path}: no 'position' variable with a time dimension")
    n = store.sizes["time"]
    if committed is not None:
        if committed > n:
            raise InputError(
                f"{path}: committed_frames = {committed} but the store holds {n} time steps"
            )
        store = store.isel(time=slice(0, committed))
    try:
        for name, var in store.variables.items():
            if var.shape:
                check_declared_size(path, str(name), var.shape)  # before loading it whole
    except InputError:
        store.close()
        raise
    try:
        ds = store.load()
    except Exception as exc:  # a damaged chunk in the committed range
        raise InputError(
            f"{path}: cannot read the committed frames ({type(exc).__name__})"
        ) from None
    finally:
        store.close()
    ds.attrs["committed_frames"] = int(ds.sizes["time"])
    unit = ds.attrs.get("space_unit", "mm")
    if unit != "mm":
        scale, attrs = length_scale(path, str(unit), px_per_mm, "this store", from_file=True)
        ds["position"] = ds["position"] * scale
        ds.attrs.update(attrs, space_unit="mm")
    if fps is not None and "fps" not in ds.attrs:
        ds.attrs["fps"] = float(fps)
    ds.attrs.setdefault("source_file", str(path))
    if not np.issubdtype(ds["position"].dtype, np.floating):
        raise InputError(f"{path}: 'position' is not floating point")
    return validate_tracks(ds, source=str(path))
