"""Reading and writing trajectories: one registry, one format out.

:func:`read_tracks` picks a reader by the ``format`` argument, else by sniffing the
file's content and extension, and returns the trajectory format of
:mod:`thermoswarm.tracks` with positions in mm and times in seconds.

Readers are registered with :func:`register_reader`; each is a module of this
package (one per family of formats) that is imported only when used, so that the
core stays light (``sleap-io`` is needed only for ``.slp``).

Scale and frame rate are never assumed: pixel-based formats need ``px_per_mm``
(``"paper"`` is the paper's 3.04 px/mm preset) and formats without timestamps need
``fps``; otherwise the reader raises :class:`~thermoswarm.errors.InputError`.
"""

from __future__ import annotations

import importlib
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import xarray as xr

from thermoswarm.errors import InputError

#: Named scale presets for ``px_per_mm``.
SCALE_PRESETS: dict[str, float] = {"paper": 3.04}


@dataclass(frozen=True)
class Format:
    """A registered trajectory format.

    ``module`` holds functions ``sniff(path) -> bool`` (optional), ``read(path, **opts)``
    and ``write(ds, path, **opts)`` (optional), imported lazily.
    """

    name: str
    module: str
    extensions: tuple[str, ...]
    description: str
    can_read: bool = True
    can_write: bool = False

    def load(self) -> Any:
        return importlib.import_module(self.module)


_FORMATS: dict[str, Format] = {}


def register_format(fmt: Format) -> None:
    """Add (or replace) a format in the registry."""
    _FORMATS[fmt.name] = fmt


def formats() -> dict[str, Format]:
    """The registered formats, by name."""
    return dict(_FORMATS)


def resolve_px_per_mm(value: float | str | None) -> float | None:
    """``None``, a positive number, or a preset name (``"paper"`` = 3.04 px/mm)."""
    if value is None:
        return None
    if isinstance(value, str):
        key = value.strip().lower()
        if key in SCALE_PRESETS:
            return SCALE_PRESETS[key]
        try:
            value = float(key)
        except ValueError:
            presets = ", ".join(SCALE_PRESETS)
            raise InputError(
                f"px_per_mm must be a positive number or a preset ({presets}), got {value!r}"
            ) from None
    value = float(value)
    if not (value > 0 and value < float("inf")):
        raise InputError(f"px_per_mm must be a positive number, got {value!r}")
    return value


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
        if sniff is not None and sniff(path):
            return fmt.name
    known = ", ".join(sorted(_FORMATS))
    if candidates:
        names = ", ".join(f.name for f in candidates)
        raise InputError(f"{path}: could not tell which of {names} this is; pass --format")
    raise InputError(f"{path}: unknown trajectory format {ext!r}; pass --format (one of {known})")


def read_tracks(
    path: str | os.PathLike,
    format: str | None = None,
    *,
    fps: float | None = None,
    px_per_mm: float | str | None = None,
    **options: Any,
) -> xr.Dataset:
    """Read trajectories from ``path`` into the trajectory format.

    Parameters
    ----------
    path
        File or directory.
    format
        A registered format name; detected from the file when omitted.
    fps
        Frame rate, for files that have frame numbers but no times.
    px_per_mm
        Pixels per millimetre for pixel-based files, or a preset name (``"paper"``).
    **options
        Format-specific options (column names, ``allow_pickle``, ...).
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such file or directory")
    name = format or detect_format(path)
    if name not in _FORMATS or not _FORMATS[name].can_read:
        known = ", ".join(sorted(n for n, f in _FORMATS.items() if f.can_read))
        raise InputError(f"unknown input format {name!r}; expected one of: {known}")
    reader = _FORMATS[name].load()
    return reader.read(path, fps=fps, px_per_mm=resolve_px_per_mm(px_per_mm), **options)


def write_tracks(ds: xr.Dataset, path: str | os.PathLike, format: str | None = None,
                 **options: Any) -> Path:
    """Write ``ds`` to ``path`` (atomically); the format follows the extension by default."""
    path = Path(path)
    if format is None:
        ext = _suffix(path)
        writers = [f for f in _FORMATS.values() if f.can_write and ext in f.extensions]
        if not writers:
            raise InputError(f"{path}: no writer for extension {ext!r}")
        format = writers[0].name
    fmt = _FORMATS.get(format)
    if fmt is None or not fmt.can_write:
        known = ", ".join(sorted(n for n, f in _FORMATS.items() if f.can_write))
        raise InputError(f"unknown output format {format!r}; expected one of: {known}")
    fmt.load().write(ds, path, **options)
    return path


register_format(Format("netcdf", "thermoswarm.io.netcdf", (".nc", ".nc4", ".netcdf"),
                       "thermoswarm / movement netCDF", can_write=True))
register_format(Format("zarr", "thermoswarm.io.zarrstore", (".zarr",),
                       "thermoswarm Zarr store (simulation recordings)"))
register_format(Format("mot", "thermoswarm.io.mot", (".txt",),
                       "MOTChallenge txt (box centres)", can_write=True))
