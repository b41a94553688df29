"""``movement`` datasets both ways: poses and bounding boxes, in memory and on disk.

`movement <https://movement.neuroinformatics.dev>`_ holds trajectories in an
:class:`xarray.Dataset` of one of two types (``attrs["ds_type"]``):

``poses``   ``position(time, space, keypoints, individuals)``,
            ``confidence(time, keypoints, individuals)``
``bboxes``  ``position(time, space, individuals)`` (box centres),
            ``shape(time, space, individuals)`` (width, height),
            ``confidence(time, individuals)``

Positions are pixels unless ``movement.transforms.scale`` recorded a
``space_unit`` on the ``position`` variable; the ``time`` coordinate is in frames
(``time_unit = "frames"``) unless the loader was given an ``fps`` (``"seconds"``);
``confidence`` is NaN where the source had no scores.

:func:`from_movement` turns any such dataset (either type, any dimension order,
pixel or calibrated units) into the trajectory format of :mod:`thermoswarm.tracks`
(mm, seconds): a box becomes one keypoint, ``centroid``, and its ``shape`` is kept
(in mm) as a variable of that name; an all-NaN ``confidence`` is dropped.
:func:`to_movement` goes back: a dataset that ``movement`` validates
(``ValidPosesInputs.validate`` / ``ValidBboxesInputs.validate``), with the lengths
in mm recorded as ``position.attrs["space_unit"]``, as ``scale`` does.  Data read
from boxes are written back as boxes.

As a registered format (``--format movement`` / ``--to movement``) this module reads
and writes such datasets as netCDF, as ``movement`` saves them; the ``netcdf``
reader hands ``movement``'s own files here too.  With the read option
``source_software`` it reads any file that ``movement`` itself loads (SLEAP,
DeepLabCut, LightningPose, Anipose, VIA-tracks, NWB) through ``movement``'s loader;
that needs the ``movement`` package, which the core does not install.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.errors import InputError
from thermoswarm.fsutil import atomic_path
from thermoswarm.io._common import attr_value, check_options, length_scale, option_str
from thermoswarm.io._common import resolve_fps as _resolve_fps
from thermoswarm.tracks import CONF_DIMS, DIMS, per_individual, validate_tracks

__all__ = ["from_movement", "to_movement", "is_movement_dataset", "read", "write"]

OPTIONS = {
    "units": 'length unit when the dataset records none: "px" (default when --px-per-mm '
    'is given), "mm", "cm", "m", "um"',
    "source_software": "read a third-party file with movement's own loader: SLEAP, "
    "DeepLabCut, LightningPose, Anipose, VIA-tracks or NWB (needs the movement package)",
}
NEEDS = "--px-per-mm for pixel positions; --fps when the time axis is in frames"

#: movement's dataset types and the dimensions of their variables.
BBOX_DIMS = ("time", "space", "individuals")
BBOX_CONF_DIMS = ("time", "individuals")
#: Variables with a length unit that are converted with ``position``.
_LENGTH_VARS = ("position", "shape")


def is_movement_dataset(ds: xr.Dataset) -> bool:
    """Whether ``ds`` needs :func:`from_movement` (it was not written by our netCDF writer).

    Our own files record ``space_unit = "mm"`` on the dataset; ``movement``'s record
    no unit (pixels) or one on ``position`` (after ``scale``), and boxes have no
    ``keypoints`` dimension.
    """
    if "position" not in ds:
        return False
    return (
        ds.attrs.get("ds_type") == "bboxes"
        or "keypoints" not in ds["position"].dims
        or "space_unit" not in ds.attrs
        or "space_unit" in ds["position"].attrs
    )


def _where(source: Any) -> str:
    return str(source) if source is not None else "the movement dataset"


def _ds_type(ds: xr.Dataset, where: str) -> str:
    kind = ds.attrs.get("ds_type")
    if kind is None:  # older files: the dimensions say which
        kind = "poses" if "keypoints" in ds["position"].dims else "bboxes"
    if kind not in ("poses", "bboxes"):
        raise InputError(f"{where}: ds_type {kind!r} is neither 'poses' nor 'bboxes'")
    want = set(DIMS) if kind == "poses" else set(BBOX_DIMS)
    extra = sorted(set(ds["position"].dims) - want)
    if extra and ds["position"].ndim == len(want) + len(extra):
        raise InputError(
            f"{where}: 'position' has the further dimension(s) {extra} (several camera "
            f"views?); select one first, e.g. ds.sel({extra[0]}=...)"
        )
    if set(ds["position"].dims) != want:
        raise InputError(
            f"{where}: a movement {kind} 'position' needs dims {sorted(want)}, "
            f"got {list(ds['position'].dims)}"
        )
    return kind


def _as_poses(ds: xr.Dataset) -> xr.Dataset:
    """Boxes as poses with one keypoint, ``centroid``; every variable in our order."""
    if "keypoints" not in ds["position"].dims:
        ds = ds.copy()
        ds["position"] = ds["position"].expand_dims(keypoints=["centroid"])
        if "confidence" in ds and "keypoints" not in ds["confidence"].dims:
            ds["confidence"] = ds["confidence"].expand_dims(keypoints=["centroid"])
    ds = ds.transpose(*DIMS, ...)
    ds["position"] = ds["position"].transpose(*DIMS)
    if "confidence" in ds:
        ds["confidence"] = ds["confidence"].transpose(*CONF_DIMS)
    if "shape" in ds:
        ds["shape"] = ds["shape"].transpose(*BBOX_DIMS)
    return ds


def _file_unit(ds: xr.Dataset, units: str | None, where: str) -> tuple[str | None, bool]:
    """The length unit: the option, else the one recorded (``position``, then dataset)."""
    recorded = ds["position"].attrs.get("space_unit", ds.attrs.get("space_unit"))
    recorded = None if recorded in (None, "") else str(recorded)
    if units is None:
        return recorded, recorded is not None
    if recorded is not None and recorded.strip().lower() != units.strip().lower():
        raise InputError(
            f"{where}: option units={units!r} contradicts the dataset's space_unit={recorded!r}"
        )
    return units, False


def _convert_time(
    ds: xr.Dataset, fps: float | None, where: str
) -> tuple[xr.Dataset, dict[str, Any]]:
    """Frame numbers to seconds where a frame rate is known; the fps and time unit."""
    in_file = ds.attrs.get("fps")
    try:
        in_file = None if in_file in (None, "") else float(in_file)
    except (TypeError, ValueError):
        raise InputError(f"{where}: attribute fps={in_file!r} is not a number") from None
    rate = _resolve_fps(Path(where), fps, in_file, "the movement dataset")
    unit = ds.attrs.get("time_unit")
    if unit is None:
        unit = "frames" if np.issubdtype(ds["time"].dtype, np.integer) else "seconds"
    if unit not in ("frames", "seconds"):
        raise InputError(f"{where}: time_unit {unit!r} is neither 'frames' nor 'seconds'")
    t = np.asarray(ds["time"].values, dtype=np.float64)
    if unit == "frames" and rate is not None:
        ds = ds.assign_coords(time=t / rate)
        unit = "seconds"
    elif unit == "seconds" and rate is not None and in_file is not None and rate != in_file:
        # the seconds were computed with the file's rate: recompute them with the given one
        ds = ds.assign_coords(time=t * in_file / rate)
    else:
        ds = ds.assign_coords(time=t)
    attrs: dict[str, Any] = {"time_unit": unit}
    if rate is not None and math.isfinite(rate):
        attrs["fps"] = float(rate)
    return ds, attrs


def _storable(attrs: dict[str, Any]) -> dict[str, Any]:
    """Attributes without ``None`` and with ``movement``'s logs as JSON text."""
    out = {}
    for key, value in attrs.items():
        if value is None:
            continue
        if isinstance(value, list | dict):
            value = json.dumps(value, default=str)
        out[key] = value
    return out


def from_movement(
    ds: xr.Dataset,
    *,
    fps: float | None = None,
    px_per_mm: float | None = None,
    units: str | None = None,
    source: str | Path | None = None,
) -> xr.Dataset:
    """Turn a ``movement`` poses or bboxes dataset into the trajectory format.

    Parameters
    ----------
    ds
        A ``movement`` dataset (in memory, or opened from a netCDF file).
    fps
        Frame rate (frames/s).  Needed to turn a ``time`` axis in frames into seconds
        (else the result keeps frame numbers and the analysis asks for it); overrides
        the dataset's own ``fps`` (with a warning when they differ).
    px_per_mm
        Pixels per millimetre, for positions in pixels (no ``space_unit`` recorded).
    units
        The length unit when the dataset records none (``"px"``, ``"mm"``, ``"cm"``,
        ``"m"``, ``"um"``).
    source
        The file it came from, for messages and ``attrs["source_file"]``.

    Returns
    -------
    xarray.Dataset
        ``position`` in mm, ``confidence`` in [0, 1] (absent when the source had no
        scores), box ``shape`` in mm for boxes, ``time`` in seconds where a frame rate
        is known; ``attrs["movement_ds_type"]`` records the source's type.
    """
    where = _where(source)
    if units is not None:
        units = option_str(Path(where), "units", units)
    if not isinstance(ds, xr.Dataset) or "position" not in ds:
        raise InputError(f"{where}: not a movement dataset (no 'position' variable)")
    kind = _ds_type(ds, where)
    if ds.sizes["space"] != 2:
        raise InputError(
            f"{where}: {ds.sizes['space']}-D positions (space {list(ds['space'].values)}); "
            "thermoswarm analyses 2-D tracks: select x and y first (ds.sel(space=['x', 'y']))"
        )
    if not np.issubdtype(ds["position"].dtype, np.number):
        raise InputError(f"{where}: 'position' is not numeric ({ds['position'].dtype})")
    unit, from_file = _file_unit(ds, units, where)
    scale, unit_attrs = length_scale(
        Path(where), unit, px_per_mm, "this movement dataset", from_file=from_file
    )
    ds, dropped = _lengths_in_mm(_as_poses(ds), scale, unit_attrs.get("px_per_mm"))
    if "confidence" in ds:
        conf = ds["confidence"].astype(np.float32)
        if np.isfinite(conf.values).any():
            ds["confidence"] = conf
        else:  # movement fills NaN where the source had no scores
            ds = ds.drop_vars("confidence")
    ds, time_attrs = _convert_time(ds, fps, where)
    ds = ds.assign_coords(
        individuals=[str(x) for x in ds["individuals"].values],
        keypoints=[str(x) for x in ds["keypoints"].values],
    )
    attrs = _storable(dict(ds.attrs))
    attrs.pop("fps", None)
    attrs.update(unit_attrs)
    attrs.update(time_attrs)
    attrs.update({"ds_type": "poses", "space_unit": "mm", "movement_ds_type": kind})
    attrs.setdefault("source_software", "movement")
    if source is not None:
        attrs.setdefault("source_file", str(source))
    if dropped:
        attrs["dropped_variables"] = ", ".join(dropped)
    ds.attrs = attrs
    return validate_tracks(ds, source=where)


def _lengths_in_mm(
    ds: xr.Dataset, scale: float, px_per: float | None
) -> tuple[xr.Dataset, list[str]]:
    """``ds`` with ``position`` and ``shape`` in mm (pixels divided by ``px_per``, other
    units times ``scale``) and the other variables with a ``space`` axis dropped, and
    the names dropped."""
    # lengths other than position and shape (say, velocities) are in the file's unit
    # and were derived by the user: dropped rather than mixed with mm
    dropped = [str(v) for v in ds.data_vars if v not in _LENGTH_VARS and "space" in ds[v].dims]
    ds = ds.drop_vars(dropped)
    for name in _LENGTH_VARS:
        if name in ds:
            var = ds[name].astype(np.float64)
            # pixels are divided by the scale, as every pixel reader does (same floats)
            var = var / px_per if px_per is not None else var * scale
            var.attrs = _storable({**ds[name].attrs, "space_unit": "mm"})
            ds[name] = var
    return ds, dropped


def to_movement(tracks: xr.Dataset, *, ds_type: str | None = None) -> xr.Dataset:
    """The trajectory format as a dataset that ``movement`` validates.

    Parameters
    ----------
    tracks
        Trajectories in our format (mm, one shared time axis).
    ds_type
        ``"poses"`` or ``"bboxes"``; default: ``"bboxes"`` for data read from boxes
        (``attrs["movement_ds_type"]``, a ``shape`` variable, one keypoint), else
        ``"poses"``.  Boxes need exactly one keypoint and a ``shape`` variable.

    Returns
    -------
    xarray.Dataset
        ``position`` (mm, ``attrs["space_unit"] = "mm"``) and ``confidence`` (NaN
        where we have none), ``time`` in seconds (or frames, as in ``tracks``),
        attributes ``ds_type``, ``source_software``, ``time_unit``, ``fps`` when known.
    """
    tracks = validate_tracks(tracks)
    if per_individual(tracks):
        raise InputError(
            "movement needs one time axis shared by the individuals; these are on their "
            "own clocks (write netcdf or tidy_csv instead)"
        )
    boxes_fit = "shape" in tracks and tracks.sizes["keypoints"] == 1
    if ds_type is None:
        ds_type = (
            "bboxes" if boxes_fit and tracks.attrs.get("movement_ds_type") == "bboxes" else "poses"
        )
    if ds_type not in ("poses", "bboxes"):
        raise InputError(f"ds_type must be 'poses' or 'bboxes', got {ds_type!r}")
    if ds_type == "bboxes" and not boxes_fit:
        raise InputError(
            "bboxes need one keypoint and a 'shape' variable (box width and height, mm)"
        )
    out = tracks.copy()
    if "confidence" not in out:
        out["confidence"] = xr.full_like(out["position"].isel(space=0, drop=True), np.nan)
    out["confidence"] = out["confidence"].astype(np.float64)
    if ds_type == "bboxes":
        out = out.squeeze("keypoints", drop=True)
        out = out.drop_vars([v for v in out.data_vars if "keypoints" in out[v].dims])
        out["shape"] = out["shape"].transpose(*BBOX_DIMS)
    out["position"] = out["position"].astype(np.float64)
    out["position"].attrs = {**tracks["position"].attrs, "space_unit": "mm"}
    attrs = {k: attr_value(v) for k, v in tracks.attrs.items() if v is not None}
    attrs.update({"ds_type": ds_type, "time_unit": tracks.attrs.get("time_unit", "seconds")})
    attrs.setdefault("source_software", "thermoswarm")
    attrs.pop("movement_ds_type", None)
    out.attrs = attrs
    return out


def _open_netcdf(path: Path) -> xr.Dataset:
    """Load a netCDF-4 file; any failure is one InputError naming the file.

    h5py opens it first: a file it cannot open never reaches h5netcdf, whose ``File``
    leaves a half-built object behind when its constructor fails (see
    :func:`thermoswarm.io.netcdf._open`, which this module must not import: the
    netcdf reader imports this one).
    """
    import h5py

    try:
        with h5py.File(path, "r"):
            pass
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            return ds.load()
    except Exception as exc:  # h5py/xarray raise many types for a bad file
        raise InputError(f"{path}: not a readable netCDF file ({type(exc).__name__})") from None


def _load_with_movement(path: Path, software: str, fps: float | None) -> xr.Dataset:
    """A third-party file read by ``movement``'s own loader."""
    try:
        from movement.io import load_dataset
    except ImportError:
        raise InputError(
            f"{path}: source_software={software!r} reads through the movement package, "
            "which is not installed: pip install movement"
        ) from None
    return load_dataset(path, source_software=software, fps=fps)


def read(
    path: Path, *, fps: float | None = None, px_per_mm: float | None = None, **options: Any
) -> xr.Dataset:
    """Read a ``movement`` netCDF file, or any file through ``movement``'s loader."""
    check_options(path, "movement", options, OPTIONS)
    units = options.get("units")
    if "source_software" in options:
        software = option_str(path, "source_software", options["source_software"])
        ds = _load_with_movement(path, software, fps)
    else:
        ds = _open_netcdf(path)
    return from_movement(ds, fps=fps, px_per_mm=px_per_mm, units=units, source=path)


def write(ds: xr.Dataset, path: Path, *, ds_type: str | None = None) -> None:
    """Write ``ds`` as a ``movement`` netCDF file (h5netcdf), atomically."""
    out = to_movement(ds, ds_type=ds_type)
    with atomic_path(Path(path), suffix=".nc") as tmp:
        out.to_netcdf(tmp, engine="h5netcdf")
