"""netCDF in the trajectory format (also what ``movement`` saves).

Written with the ``h5netcdf`` engine (netCDF-4/HDF5), atomically.

Reading accepts our own files (``space_unit = "mm"``) and ``movement``'s: those
have no ``space_unit`` and are in pixels (pass ``--px-per-mm``, or the ``units``
option when they were already scaled); older ``movement`` files with dimensions in
another order are transposed, and ``bboxes`` datasets (no ``keypoints`` dimension)
get one keypoint, ``centroid``.
"""

from __future__ import annotations

import gc
import sys
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.errors import InputError
from thermoswarm.fsutil import atomic_path
from thermoswarm.io._common import (
    attr_value,
    check_h5_sizes,
    check_options,
    length_scale,
    option_str,
)
from thermoswarm.tracks import DIMS, validate_tracks

OPTIONS = {
    "units": 'length unit of a file without a space_unit attribute: "px" (default when '
    '--px-per-mm is given), "mm", "cm", "m", "um"',
}
NEEDS = "nothing for thermoswarm files; --px-per-mm for movement files (pixels)"


def sniff(path: Path) -> bool:
    with open(path, "rb") as fh:
        head = fh.read(8)
    return head.startswith(b"\x89HDF") or head.startswith(b"CDF")


def _open(path: Path) -> xr.Dataset:
    """Load a netCDF-4 file; any failure is one InputError naming the file.

    The file is opened with h5py first: when h5netcdf's ``File`` fails inside its own
    constructor (a truncated or corrupted file), its destructor later raises
    ``AttributeError: 'File' object has no attribute '_writable'``, which Python prints
    as "Exception ignored in ..." with a traceback.  A file h5py cannot open never
    reaches h5netcdf; whatever a destructor still raises while the failed objects are
    collected here is dropped (it concerns a file already reported as unreadable).
    """
    import h5py

    try:
        fh = h5py.File(path, "r")
    except Exception as exc:  # OSError subclasses with long messages
        raise InputError(f"{path}: not a readable netCDF file ({type(exc).__name__})") from None
    try:
        check_h5_sizes(path, fh)  # xarray loads every variable whole
    finally:
        fh.close()
    hook = sys.unraisablehook
    sys.unraisablehook = lambda unraisable: None
    failed = None
    try:
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            return ds.load()
    except Exception as exc:  # h5py/xarray raise many types for a bad file
        failed = type(exc).__name__  # not the exception: its frames hold the broken File
    finally:
        gc.collect()  # finalise what failed while the quiet hook is in place
        sys.unraisablehook = hook
    raise InputError(f"{path}: not a readable netCDF file ({failed})")


def read(
    path: Path, *, fps: float | None = None, px_per_mm: float | None = None, **options: Any
) -> xr.Dataset:
    check_options(path, "netcdf", options, OPTIONS)
    ds = _open(path)
    if "position" not in ds:
        raise InputError(f"{path}: no 'position' variable; not a trajectory file")
    from thermoswarm.io import movement

    if movement.is_movement_dataset(ds):  # movement's units, boxes and clocks: one reader
        return movement.from_movement(ds, fps=fps, px_per_mm=px_per_mm, source=path, **options)
    dims = set(ds["position"].dims)
    if dims == {"time", "space", "individuals"}:
        ds = ds.expand_dims(keypoints=["centroid"])
        if "confidence" in ds and "keypoints" not in ds["confidence"].dims:
            ds["confidence"] = ds["confidence"].expand_dims(keypoints=["centroid"])
    if set(ds["position"].dims) == set(DIMS) and ds["position"].dims != DIMS:
        ds = ds.transpose(*DIMS, ...)
    if "confidence" in ds and set(ds["confidence"].dims) == {"time", "keypoints", "individuals"}:
        ds["confidence"] = ds["confidence"].transpose("time", "keypoints", "individuals")
    if not np.issubdtype(ds["position"].dtype, np.number):
        raise InputError(f"{path}: 'position' is not numeric ({ds['position'].dtype})")
    if "units" in options:
        units, from_file = option_str(path, "units", options["units"]), False
        if "space_unit" in ds.attrs and str(ds.attrs["space_unit"]) != units:
            raise InputError(
                f"{path}: option units={units!r} contradicts the file's "
                f"space_unit={ds.attrs['space_unit']!r}"
            )
    elif "space_unit" in ds.attrs:
        units, from_file = str(ds.attrs["space_unit"]), True
    else:
        units, from_file = None, False
    scale, attrs = length_scale(path, units, px_per_mm, "this netCDF file", from_file=from_file)
    if scale != 1.0:
        ds["position"] = ds["position"].astype(np.float64) * scale
    ds.attrs.update(attrs)
    ds.attrs["space_unit"] = "mm"
    if fps is not None and "fps" not in ds.attrs:
        ds.attrs["fps"] = float(fps)
    ds.attrs.setdefault("source_file", str(path))
    return validate_tracks(ds, source=str(path))


def write(ds: xr.Dataset, path: Path, **options: Any) -> None:
    """Write ``ds`` as netCDF-4 (h5netcdf), atomically; attributes made storable."""
    if options:
        raise InputError(f"{path}: netcdf writer takes no options, got {sorted(options)}")
    path = Path(path)
    out = ds.copy(deep=False)
    out.attrs = {k: attr_value(v) for k, v in ds.attrs.items() if v is not None}
    with atomic_path(path, suffix=".nc") as tmp:
        out.to_netcdf(tmp, engine="h5netcdf")
