"""Reading and writing trajectories: one registry, one format out.

:func:`read_tracks` picks a reader by the ``format`` argument, else by sniffing the
file's content and extension, and returns the trajectory format of
:mod:`thermoswarm.tracks` with positions in mm and times in seconds.

Formats are registered with :func:`register_format`; each lives in a module of
this package (one per family of formats) that is imported only when used, so that
the core stays light (``sleap-io`` is needed only for ``.slp``).  A module declares
``OPTIONS`` (option name -> help) and ``NEEDS``; :func:`read_tracks` rejects options
a format does not know, and turns any library failure on a malformed file into a
one-line :class:`~thermoswarm.errors.InputError` naming the file.

Scale and frame rate are never assumed: pixel-based formats need ``px_per_mm``
(``"paper"`` is the paper's 3.04 px/mm preset) and formats without timestamps need
``fps``; otherwise the reader raises :class:`~thermoswarm.errors.InputError`.
Nothing is unpickled unless ``allow_pickle=True`` (``--allow-pickle``).  See
``docs/io.md`` for every format, its options and the attributes it records.
"""

from __future__ import annotations

import importlib
import inspect
import os
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.config import loads_value
from thermoswarm.errors import InputError, OutputError, ThermoswarmError
from thermoswarm.fsutil import check_replaceable
from thermoswarm.io._common import MAX_ABS_MM, check_fps, check_tracks
from thermoswarm.io._scale import (  # noqa: F401 (the scale parser, re-exported)
    MAX_PX_PER_MM,
    MIN_PX_PER_MM,
    SCALE_PRESETS,
    resolve_px_per_mm,
)
from thermoswarm.tracks import per_individual, validate_tracks


@dataclass(frozen=True)
class Format:
    """A registered trajectory format.

    ``module`` holds functions ``sniff(path) -> bool`` (optional), ``read(path, **opts)``
    and ``write(ds, path, **opts)`` (optional), a dict ``OPTIONS`` (option name -> one
    line of help) and a string ``NEEDS`` (what the user must supply), imported lazily.
    ``"package.module:NAME"`` names an object of the module that has those attributes
    (one module can hold a family of formats, e.g. tidy and wide CSV).
    """

    name: str
    module: str
    extensions: tuple[str, ...]
    description: str
    can_read: bool = True
    can_write: bool = False

    def load(self) -> Any:
        module, _, attr = self.module.partition(":")
        mod = importlib.import_module(module)
        return getattr(mod, attr) if attr else mod


_FORMATS: dict[str, Format] = {}


def register_format(fmt: Format) -> None:
    """Add (or replace) a format in the registry."""
    _FORMATS[fmt.name] = fmt


def formats() -> dict[str, Format]:
    """The registered formats, by name."""
    return dict(_FORMATS)


def _suffix(path: Path) -> str:
    name = path.name.lower()
    for ext in sorted({e for f in _FORMATS.values() for e in f.extensions}, key=len, reverse=True):
        if name.endswith(ext):
            return ext
    return path.suffix.lower()


def detect_format(path: str | os.PathLike) -> str:
    """Name of the format of ``path``, by content where the extension is ambiguous."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file or directory")
    ext = "/" if path.is_dir() and not path.name.lower().endswith(".zarr") else _suffix(path)
    candidates = [f for f in _FORMATS.values() if f.can_read and ext in f.extensions]
    if len(candidates) == 1:
        return candidates[0].name
    for fmt in candidates:
        sniff: Callable[[Path], bool] | None = getattr(fmt.load(), "sniff", None)
        try:
            found = sniff is not None and sniff(path)
        except Exception:  # a sniffer must never turn a bad file into a traceback
            found = False
        if found:
            return fmt.name
    known = ", ".join(sorted(_FORMATS))
    if candidates:
        names = ", ".join(f.name for f in candidates)
        what = "directory" if ext == "/" else f"{ext} file"
        raise InputError(
            f"{path}: this {what} looks like none of {names} (unreadable, empty or another "
            "layout); pass --format NAME to get that reader's own error"
        )
    raise InputError(f"{path}: unknown trajectory format {ext!r}; pass --format (one of {known})")


def read_tracks(
    path: str | os.PathLike,
    format: str | None = None,
    *,
    fps: float | None = None,
    px_per_mm: float | str | None = None,
    allow_pickle: bool = False,
    **options: Any,
) -> xr.Dataset:
    """Read trajectories from ``path`` into the trajectory format (mm, seconds).

    Parameters
    ----------
    path
        File or directory.
    format
        A registered format name (see :func:`formats`); detected from the file's
        extension and content when omitted.
    fps
        Frame rate (frames/s) for files that have frame numbers but no times.  Where
        a file records its own frame rate, an explicit ``fps`` overrides it (with a
        warning when they differ) and the file's value is kept in ``attrs``.
    px_per_mm
        Pixels per millimetre for pixel-based files, or a preset name (``"paper"`` =
        3.04 px/mm).  Never assumed: a pixel-based file without it is an error.
    allow_pickle
        Allow formats that store Python pickles (idtracker.ai ``trajectories.npy``)
        to be unpickled.  Unpickling runs code from the file: only for files you trust.
        Ignored by formats that never unpickle.
    **options
        Format-specific options (see ``docs/io.md``); an option the format does not
        know is an error that lists the ones it accepts.

    Returns
    -------
    xarray.Dataset
        ``position(time, space, keypoints, individuals)`` in mm, ``confidence`` where
        the source has scores, attributes recording the source and any conversion.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file or directory")
    fps = check_fps(path, fps, "--fps")
    name = format or detect_format(path)
    if name not in _FORMATS or not _FORMATS[name].can_read:
        known = ", ".join(sorted(n for n, f in _FORMATS.items() if f.can_read))
        raise InputError(f"unknown input format {name!r}; expected one of: {known}")
    reader = _FORMATS[name].load()
    accepted: dict[str, str] = getattr(reader, "OPTIONS", {})
    if "allow_pickle" in accepted:
        options["allow_pickle"] = bool(allow_pickle)
    unknown = sorted(set(options) - set(accepted))
    if unknown:
        known = ", ".join(sorted(k for k in accepted if k != "allow_pickle")) or "none"
        raise InputError(
            f"{path}: unknown option(s) {', '.join(unknown)} for format {name!r}; "
            f"it accepts: {known}"
        )
    try:
        ds = reader.read(path, fps=fps, px_per_mm=resolve_px_per_mm(px_per_mm), **options)
    except ThermoswarmError:
        raise
    except MemoryError:
        raise
    except Exception as exc:  # a library failed on a malformed file: one line, naming it
        detail = str(exc).strip().splitlines()[0][:200] if str(exc).strip() else ""
        raise InputError(
            f"{path}: cannot read as {name} ({type(exc).__name__}{': ' if detail else ''}{detail})"
        ) from exc
    return _check_result(ds, path)


def _check_result(ds: xr.Dataset, path: Path) -> xr.Dataset:
    """Final checks common to every reader: schema, unique names, a recording's frame
    rate, non-finite positions counted (:func:`~thermoswarm.io._common.check_tracks`),
    at least one finite position."""
    ds = validate_tracks(ds, source=str(path))
    if ds.sizes["time"] == 0:
        raise InputError(f"{path}: no time steps")
    if ds.sizes["individuals"] == 0 or ds.sizes["keypoints"] == 0:
        raise InputError(f"{path}: no individuals or keypoints")
    ds = check_tracks(ds, path)
    if not np.isfinite(ds["position"].values).any():
        n_bad = ds.attrs.get("n_nonfinite_positions", 0)
        why = f" ({n_bad} infinite or beyond {MAX_ABS_MM:g} mm)" if n_bad else ""
        raise InputError(f"{path}: every position is missing (NaN){why}; nothing to analyse")
    ds.attrs.setdefault("source_file", str(path))
    return ds


def parse_read_options(items: Iterable[str], *, flag: str = "--read-option") -> dict[str, Any]:
    """Turn repeated ``--read-option key=value`` strings into keyword options.

    Values are parsed as TOML (``3``, ``2.5``, ``true``, ``"text"``, ``["a", "b"]``);
    a value that is not valid TOML is taken as a bare string (``units=mm``).
    """
    out: dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition("=")
        key = key.strip()
        if not sep or not key or not key.replace("_", "").isalnum():
            raise InputError(f"{flag} {item!r}: expected key=value")
        if key in out:
            raise InputError(f"{flag} {key!r} is given twice")
        out[key] = loads_value(text.strip(), f"{flag} {key}")
    return out


def describe_formats() -> list[dict[str, Any]]:
    """One row per registered format: name, extensions, read/write, needs, options."""
    rows = []
    for fmt in sorted(_FORMATS.values(), key=lambda f: f.name):
        mod = fmt.load() if fmt.can_read else None
        rows.append(
            {
                "name": fmt.name,
                "extensions": [("(directory)" if e == "/" else e) for e in fmt.extensions],
                "description": fmt.description,
                "read": fmt.can_read,
                "write": fmt.can_write,
                "needs": getattr(mod, "NEEDS", ""),
                "options": dict(getattr(mod, "OPTIONS", {})),
            }
        )
    return rows


def write_tracks(
    ds: xr.Dataset, path: str | os.PathLike, format: str | None = None, **options: Any
) -> Path:
    """Write ``ds`` to ``path`` atomically; the format follows the extension by default.

    ``.nc`` -> netCDF, ``.csv`` -> tidy CSV, ``.txt`` -> MOTChallenge (needs
    ``px_per_mm`` unless ``ds.attrs`` has it).  The parent directory must exist.
    """
    path = Path(path)
    if format is None:
        ext = _suffix(path)
        writers = [f for f in _FORMATS.values() if f.can_write and ext in f.extensions]
        if not writers:
            known = ", ".join(e for f in _FORMATS.values() if f.can_write for e in f.extensions)
            raise InputError(f"{path}: no writer for extension {ext!r} (writers: {known})")
        format = writers[0].name
    fmt = _FORMATS.get(format)
    if fmt is None or not fmt.can_write:
        known = ", ".join(sorted(n for n, f in _FORMATS.items() if f.can_write))
        raise InputError(f"unknown output format {format!r}; expected one of: {known}")
    parent = path.absolute().parent
    if not parent.is_dir():
        raise OutputError(f"{path}: parent directory {str(parent)!r} does not exist")
    if path.is_dir():
        raise OutputError(f"{path}: is a directory")
    writer = fmt.load().write
    params = inspect.signature(writer).parameters
    accepted = [n for n, p in params.items() if p.kind is inspect.Parameter.KEYWORD_ONLY]
    takes_any = any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values())
    unknown = sorted(set(options) - set(accepted))
    if unknown and not takes_any:
        raise InputError(
            f"{path}: unknown write option(s) {', '.join(unknown)} for {format!r}; "
            f"it accepts: {', '.join(accepted) or 'none'}"
        )
    if "px_per_mm" in options:
        options = {**options, "px_per_mm": resolve_px_per_mm(options["px_per_mm"])}
    check_replaceable(path)
    validate_tracks(ds)
    if per_individual(ds) and format not in _OWN_CLOCK_WRITERS:
        raise InputError(
            f"{path}: the individuals are on their own clocks and {format!r} needs one "
            f"shared frame axis; write one of: {', '.join(_OWN_CLOCK_WRITERS)}"
        )
    writer(ds, path, **options)
    return path


#: Writers that keep per-individual clocks (the others need a shared frame axis).
_OWN_CLOCK_WRITERS = ("netcdf", "tidy_csv")


def convert_tracks(
    source: str | os.PathLike,
    dest: str | os.PathLike,
    *,
    format: str | None = None,
    to: str | None = None,
    fps: float | None = None,
    px_per_mm: float | str | None = None,
    allow_pickle: bool = False,
    read_options: dict[str, Any] | None = None,
    write_options: dict[str, Any] | None = None,
) -> xr.Dataset:
    """Read ``source`` (any registered format) and write it to ``dest``; return the data."""
    ds = read_tracks(
        source,
        format,
        fps=fps,
        px_per_mm=px_per_mm,
        allow_pickle=allow_pickle,
        **(read_options or {}),
    )
    write_tracks(ds, dest, to, **(write_options or {}))
    return ds


# Registration order matters where formats share an extension: detect_format asks
# each candidate's ``sniff`` in this order, so the strictest sniffers come first.
register_format(
    Format(
        "netcdf",
        "thermoswarm.io.netcdf",
        (".nc", ".nc4", ".netcdf"),
        "thermoswarm / movement netCDF",
        can_write=True,
    )
)
# After netcdf, so that .nc files are written as netcdf by default; the netcdf reader
# hands movement's own files to this module.
register_format(
    Format(
        "movement",
        "thermoswarm.io.movement",
        (".nc", ".nc4", ".netcdf"),
        "movement dataset (poses or boxes) as netCDF; any movement-loadable file "
        "with --read-option source_software=NAME",
        can_write=True,
    )
)
register_format(
    Format(
        "zarr",
        "thermoswarm.io.zarrstore",
        (".zarr", "/"),
        "thermoswarm Zarr store (simulation recordings)",
    )
)
register_format(
    Format(
        "mot", "thermoswarm.io.mot", (".txt",), "MOTChallenge txt (box centres)", can_write=True
    )
)
register_format(
    Format(
        "dlc",
        "thermoswarm.io.dlc",
        (".h5", ".hdf5", ".csv"),
        "DeepLabCut predictions (.h5 / .csv)",
    )
)
register_format(
    Format(
        "tidy_csv",
        "thermoswarm.io.csv:TIDY",
        (".csv", ".tsv"),
        "tidy CSV: one row per individual and time",
        can_write=True,
    )
)
register_format(
    Format(
        "wide_csv",
        "thermoswarm.io.csv:WIDE",
        (".csv", ".tsv"),
        "wide CSV: one row per frame, x/y columns per individual",
    )
)
register_format(
    Format(
        "sleap",
        "thermoswarm.io.sleap",
        (".slp", ".h5", ".hdf5"),
        "SLEAP labels (.slp) and analysis HDF5 (.h5)",
    )
)
register_format(
    Format(
        "idtracker",
        "thermoswarm.io.idtracker",
        (".npy", ".h5", ".hdf5", "/"),
        "idtracker.ai trajectories (.h5, .npy, session folder)",
    )
)
register_format(
    Format(
        "trex",
        "thermoswarm.io.trex",
        (".npz", "/"),
        "TRex per-individual .npz exports (a file or a folder)",
    )
)
register_format(
    Format(
        "text",
        "thermoswarm.io.textdir",
        (".txt", ".dat", ".xy", "/"),
        "one `t x y` text file per individual (a file or a folder of them)",
    )
)
