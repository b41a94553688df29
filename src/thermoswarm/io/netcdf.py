"""netCDF in the trajectory format (also what ``movement`` saves).

Written with the ``h5netcdf`` engine (netCDF-4/HDF5), atomically.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import xarray as xr

from thermoswarm.errors import InputError
from thermoswarm.fsutil import atomic_path
from thermoswarm.tracks import validate_tracks


def sniff(path: Path) -> bool:
    with open(path, "rb") as fh:
        head = fh.read(8)
    return head.startswith(b"\x89HDF") or head.startswith(b"CDF")


def read(path: Path, *, fps: float | None = None, px_per_mm: float | None = None,
         **options: Any) -> xr.Dataset:
    if options:
        raise InputError(f"{path}: netcdf takes no options, got {sorted(options)}")
    try:
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            ds = ds.load()
    except Exception as exc:  # h5py/xarray raise many types for a bad file
        raise InputError(f"{path}: not a readable netCDF file ({type(exc).__name__})") from None
    if "position" not in ds:
        raise InputError(f"{path}: no 'position' variable; not a trajectory file")
    if fps is not None and "fps" not in ds.attrs:
        ds.attrs["fps"] = float(fps)
    if px_per_mm is not None and ds.attrs.get("space_unit", "mm") == "px":
        ds["position"] = ds["position"] / px_per_mm
        ds.attrs["space_unit"] = "mm"
    ds.attrs.setdefault("source_file", str(path))
    return validate_tracks(ds, source=str(path))


def write(ds: xr.Dataset, path: Path, **options: Any) -> None:
    if options:
        raise InputError(f"{path}: netcdf writer takes no options, got {sorted(options)}")
    path = Path(path)
    with atomic_path(path, suffix=".nc") as tmp:
        ds.to_netcdf(tmp, engine="h5netcdf")
