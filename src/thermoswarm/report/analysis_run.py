"""Analyse a trajectory file: read it, run the study, write the results and the report.

:func:`analyze_file` is what ``thermoswarm analyze`` calls: it writes ``fits.json``,
``kinematics.nc`` and ``report.html`` (atomically) into one directory.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.analysis.options import AnalysisOptions
from thermoswarm.analysis.regions import load_regions
from thermoswarm.analysis.study import StudyResult, run_study
from thermoswarm.errors import InputError
from thermoswarm.tracks import combine_tracks

__all__ = ["analyze_file", "read_inputs", "write_results", "write_kinematics"]


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


def read_inputs(paths: Sequence[Path], opts: AnalysisOptions) -> xr.Dataset:
    """The read stage: each file read with ``opts.read`` (the reader also resolves
    duplicate samples by ``opts.clean.duplicates`` where it takes that option); several
    files are combined, their individuals named ``FILE:NAME``
    (:func:`thermoswarm.tracks.combine_tracks`)."""
    from thermoswarm.io import detect_format, formats, read_tracks

    rd = opts.read
    read_options = dict(rd.options)
    if "duplicates" not in read_options:
        # one rule for the reader and the kinematics, where the reader takes it
        reader = formats().get(rd.format or detect_format(paths[0]))
        if reader is not None and "duplicates" in getattr(reader.load(), "OPTIONS", {}):
            read_options["duplicates"] = opts.clean.duplicates
    read = [
        read_tracks(p, rd.format, fps=rd.fps, px_per_mm=rd.px_per_mm,
                    allow_pickle=rd.allow_pickle, **read_options)
        for p in paths
    ]  # fmt: skip
    if len(read) == 1:
        ds = read[0]
    else:
        stems = [p.stem for p in paths]
        parents = [p.parent.name for p in paths]  # a batch: OUT/<video>/tracks.nc
        prefixes = next(
            (n for n in (stems, parents) if len(set(n)) == len(n)), [str(p) for p in paths]
        )
        ds = combine_tracks(read, prefixes, fps=rd.fps)
    if "position" not in ds:
        raise InputError(f"{paths[0]}: the reader returned no positions")
    return ds


def write_results(out: Path, result: StudyResult, opts: AnalysisOptions) -> None:
    """The report stage: ``kinematics.nc``, ``fits.json`` and (with ``opts.report.html``)
    ``report.html`` into directory ``out`` (created with its parents), each written
    atomically."""
    from thermoswarm.fsutil import atomic_write_json, atomic_write_text

    out.mkdir(parents=True, exist_ok=True)
    write_kinematics(result.kinematics, out / "kinematics.nc")
    atomic_write_json(out / "fits.json", result.fits)
    if opts.report.html:
        from thermoswarm.report.analysis_figures import build_report

        atomic_write_text(out / "report.html", build_report(result))


def analyze_file(
    path: str | os.PathLike | Sequence[str | os.PathLike],
    out: str | os.PathLike,
    options: AnalysisOptions | None = None,
    *,
    progress: Callable[[str], None] | None = None,
    **keywords: Any,
) -> StudyResult:
    """Read trajectories, run the study, write ``fits.json``, ``kinematics.nc`` and
    ``report.html`` into directory ``out`` (created with its parents; files are written
    atomically): the stages of :mod:`thermoswarm.analysis` in order.

    ``options`` holds every option (:class:`AnalysisOptions`); ``keywords`` give
    options by their flat names over it (``format``, ``px_per_mm``, ``read_options``,
    ``fps``, ``regions``, ``report``, and those of :func:`run_study`).  ``path`` may be
    several files (one per video or recording), analysed together."""
    from thermoswarm.fsutil import prepare_output_dir

    opts = AnalysisOptions.from_keywords(options, **keywords)
    out = Path(out)
    paths = [Path(p) for p in path] if isinstance(path, list | tuple) else [Path(path)]
    if not paths:
        raise InputError("no input file given")
    regions = opts.fit.regions
    regions_list = load_regions(regions) if regions is not None else None
    prepare_output_dir(out)
    ds = read_inputs(paths, opts)
    result = run_study(ds, opts, regions=regions_list, progress=progress)
    settings = result.fits["settings"]
    if regions is not None:
        settings["regions"] = regions
        if result.fits["regions"]:
            result.fits["regions"]["source"] = regions
    settings["format"] = opts.read.format
    settings["px_per_mm"] = opts.read.px_per_mm
    write_results(out, result, opts)
    return result
