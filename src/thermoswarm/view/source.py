"""``thermoswarm view PATH``: which kind of source PATH is, opened as a :class:`ViewData`.

A ``track --out`` folder (``summary.json``), a run folder or Zarr store (read lazily,
committed frames only), else any file :func:`thermoswarm.io.read_tracks` reads.
"""

from __future__ import annotations

from pathlib import Path

from thermoswarm.errors import InputError
from thermoswarm.view.data import ViewData, from_dataset, open_zarr, with_geometry
from thermoswarm.view.track_output import open_track_output

__all__ = ["open_source"]


def open_source(
    path: str | Path,
    *,
    video: str | Path | None = None,
    format: str | None = None,
    fps: float | None = None,
    px_per_mm: float | str | None = None,
    regions: str | Path | None = None,
) -> ViewData:
    """Open what ``thermoswarm view PATH`` shows (see the module docstring).

    ``format``, ``fps`` and ``px_per_mm`` are passed to
    :func:`thermoswarm.io.read_tracks` for files other than run stores.  ``regions``
    is a regions TOML file (mm, as ``analyze --regions``): a ``region`` variable to
    colour by, and the regions' outlines.
    """
    data = _open(Path(path), video=video, format=format, fps=fps, px_per_mm=px_per_mm)
    if regions is not None:
        from thermoswarm.analysis.regions import load_regions

        data.regions = load_regions(regions)
    return data


def _open(
    path: Path,
    *,
    video: str | Path | None,
    format: str | None,
    fps: float | None,
    px_per_mm: float | str | None,
) -> ViewData:
    if not path.exists():
        raise InputError(f"{path}: no such file or directory")
    if path.is_dir() and (path / "summary.json").is_file() and format is None:
        return open_track_output(path, video=video)
    if video is not None:
        raise InputError("--video applies to `thermoswarm track` output folders only")
    store = None
    if path.is_dir() and (path / "tracks.zarr").is_dir():
        store = path / "tracks.zarr"
    elif path.is_dir() and (path / "zarr.json").is_file():
        store = path
    if store is not None and format in (None, "zarr"):
        ds, committed, complete = open_zarr(store)
        data = ViewData(ds=ds, kind="run", title=str(path), store=store)
        data.committed, data.complete = committed, complete
        return with_geometry(data, ds.attrs.get("config"), str(store))
    if path.is_dir() and (path / "tracks.nc").is_file():
        path = path / "tracks.nc"
    from thermoswarm.io import read_tracks

    ds = read_tracks(path, format, fps=fps, px_per_mm=px_per_mm)
    from thermoswarm.tracks import per_individual

    if per_individual(ds):
        raise InputError(
            f"{path}: the individuals are on their own clocks; convert to one frame axis "
            "first (thermoswarm convert)"
        )
    data = from_dataset(ds, title=str(path))
    return data
