"""Analyse a trajectory file: read it, run the study, write the results and the report.

:func:`analyze_file` is what ``thermoswarm analyze`` calls: it writes ``fits.json``,
``kinematics.nc`` and ``report.html`` (atomically) into one directory.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.analysis.regions import load_regions
from thermoswarm.analysis.study import StudyResult, run_study
from thermoswarm.errors import InputError
from thermoswarm.tracks import combine_tracks

__all__ = ["analyze_file", "write_kinematics"]


def write_kinematics(kin: xr.Dataset, path: Path) -> None:
    from thermoswarm.fsutil import atomic_path

    enc = {
        v: {"dtype": "float32"} for v in kin.data_vars if kin[v].dtype.kind == "f" and v != "dt"
    }
    out = kin.copy()
    for v in ("valid", "steering_valid", "stationary"):
        out[v] = out[v].astype(np.int8)
        out[v].attrs["flag"] = "1 = true"
    with atomic_path(path, suffix=".nc") as tmp:
        out.to_netcdf(tmp, engine="h5netcdf", encoding=enc)


def analyze_file(
    path: str | os.PathLike | Sequence[str | os.PathLike],
    out: str | os.PathLike,
    *,
    format: str | None = None,
    px_per_mm: float | str | None = None,
    read_options: dict[str, Any] | None = None,
    allow_pickle: bool = False,
    fps: float | None = None,
    regions: str | os.PathLike | None = None,
    report: bool = True,
    **options: Any,
) -> StudyResult:
    """Read trajectories, run the study, write ``fits.json``, ``kinematics.nc`` and
    ``report.html`` into directory ``out`` (created with its parents; files are written
    atomically).  ``format``, ``px_per_mm``, ``allow_pickle`` and ``read_options`` go
    to :func:`thermoswarm.io.read_tracks`; the other options as :func:`run_study`.

    ``path`` may be several files (one per video or recording): each is read with the
    same options and their individuals are analysed together, named ``FILE:NAME``
    (:func:`thermoswarm.tracks.combine_tracks`)."""
    from thermoswarm.fsutil import atomic_write_json, atomic_write_text, prepare_output_dir
    from thermoswarm.io import detect_format, formats, read_tracks

    out = Path(out)
    paths = [Path(p) for p in path] if isinstance(path, list | tuple) else [Path(path)]
    if not paths:
        raise InputError("no input file given")
    read_options = dict(read_options or {})
    if options.get("duplicates") is not None and "duplicates" not in read_options:
        # one rule for the reader and the kinematics, where the reader takes it
        name = format or detect_format(paths[0])
        reader = formats().get(name)
        if reader is not None and "duplicates" in getattr(reader.load(), "OPTIONS", {}):
            read_options["duplicates"] = options["duplicates"]
    regions_list = load_regions(regions) if regions is not None else None
    prepare_output_dir(out)
    read = [
        read_tracks(
            p, format, fps=fps, px_per_mm=px_per_mm, allow_pickle=allow_pickle, **read_options
        )
        for p in paths
    ]
    if len(read) == 1:
        ds = read[0]
    else:
        stems = [p.stem for p in paths]
        parents = [p.parent.name for p in paths]  # a batch: OUT/<video>/tracks.nc
        prefixes = next(
            (n for n in (stems, parents) if len(set(n)) == len(n)), [str(p) for p in paths]
        )
        ds = combine_tracks(read, prefixes, fps=fps)
    if "position" not in ds:
        raise InputError(f"{paths[0]}: the reader returned no positions")
    result = run_study(ds, fps=fps, regions=regions_list, **options)
    if regions is not None:
        result.fits["settings"]["regions"] = str(regions)
        if result.fits["regions"]:
            result.fits["regions"]["source"] = str(regions)
    result.fits["settings"]["format"] = format
    result.fits["settings"]["px_per_mm"] = px_per_mm
    write_kinematics(result.kinematics, out / "kinematics.nc")
    atomic_write_json(out / "fits.json", result.fits)
    if report:
        from thermoswarm.report.analysis_figures import build_report

        atomic_write_text(out / "report.html", build_report(result))
    return result
