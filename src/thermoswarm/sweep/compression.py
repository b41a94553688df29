"""The compression experiment's sweeps: isotherm, pressure against temperature, and the
temperature that holds the density fixed (``docs/scenarios_road_compression.md``).

Each runs the ``compression`` scenario over a grid through :func:`run_sweep` (any
executor) and returns a tidy :class:`pandas.DataFrame`;
:func:`thermoswarm.scenarios.compression.study_figure` draws the tables.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any, Literal

from thermoswarm.config import check
from thermoswarm.errors import ThermoswarmError
from thermoswarm.fsutil import prepare_output_dir
from thermoswarm.maxent import speed_law
from thermoswarm.scenarios.compression import CompressionParams
from thermoswarm.sweep.run import run_sweep
from thermoswarm.sweep.spec import SweepSpec

__all__ = [
    "isotherm",
    "temperature_series",
    "temperature_for_density",
    "sweep_table",
    "TABLE_COLUMNS",
]


def _run_sweep(
    base: dict[str, Any],
    grid: dict[str, list[Any]],
    seeds: Iterable[int],
    out: str | Path,
    executor: Any = None,
) -> list[dict[str, Any]]:
    """The :func:`run_sweep` of ``compression`` over ``grid`` x ``seeds``;
    the records as dicts (``run_id``, ``params``, ``seed``, ``out``, ``status``,
    ``metrics``, ``error``)."""
    spec = SweepSpec(
        scenario="compression", out=Path(out), base=base, grid=grid, seeds=[int(s) for s in seeds]
    )
    return [dataclasses.asdict(r) for r in run_sweep(spec, executor)]


#: Columns of the tidy tables the sweeps return.
TABLE_COLUMNS = (
    "walls", "force", "kT", "n", "width", "tau", "pressure", "pressure_se",
    "pressure_applied", "height", "area", "free_area", "packing_fraction", "density",
    "kT_eff", "kT_eff_se", "Z", "Z_se", "se_reliable", "at_limit_fraction",
)  # fmt: skip


def sweep_table(records: Iterable[dict[str, Any]]) -> Any:
    """A :class:`pandas.DataFrame` with one row per run: ``run_id``, ``seed``, ``status``,
    ``error`` and the metrics in :data:`TABLE_COLUMNS` (failed runs are kept, with NaN)."""
    import pandas as pd

    rows = []
    for r in records:
        m = r.get("metrics") or {}
        row = {"run_id": r.get("run_id"), "seed": r.get("seed"), "status": r.get("status"),
               "error": r.get("error")}  # fmt: skip
        row.update({c: m.get(c) for c in TABLE_COLUMNS})
        rows.append(row)
    return pd.DataFrame(rows, columns=["run_id", "seed", "status", "error", *TABLE_COLUMNS])


def _base(base: dict[str, Any] | None) -> dict[str, Any]:
    b = dict(base or {})
    rec = dict(b.get("record", {}))
    rec.setdefault("netcdf", False)  # sweeps need the metrics, not the trajectories
    rec.setdefault("interval", 50.0)
    b["record"] = rec
    return b


def isotherm(
    forces: Sequence[float],
    *,
    out: str | Path,
    kT: float | None = None,
    base: dict[str, Any] | None = None,
    seeds: Sequence[int] = (0,),
    executor: Any = None,
) -> Any:
    """Pressure versus area at fixed temperature: one run per force and seed.

    Returns the tidy table of :func:`sweep_table` (columns ``force``, ``pressure``,
    ``free_area``, ``kT_eff``, ``Z``...).  ``base`` holds further parameters (nested
    dicts as in a config file); ``kT`` overrides its temperature.
    """
    b = _base(base)
    if kT is not None:
        b["kT"] = float(kT)
    b["walls"] = "force"
    recs = _run_sweep(b, {"force": [float(f) for f in forces]}, seeds, out, executor)
    return sweep_table(recs)


def temperature_series(
    kTs: Sequence[float],
    *,
    out: str | Path,
    force: float | None = None,
    walls: Literal["held", "force"] = "held",
    base: dict[str, Any] | None = None,
    seeds: Sequence[int] = (0,),
    executor: Any = None,
) -> Any:
    """Pressure versus temperature: held walls (fixed density; the default) or walls
    pushed by a fixed ``force`` (then the area grows with T).  With held walls the
    height is that of ``base`` (or the ideal-gas height at ``force`` and the first
    temperature, so that all runs share one area)."""
    b = _base(base)
    if force is not None:
        b["force"] = float(force)
    b["walls"] = walls
    if walls == "held" and b.get("height") is None:
        first = {k: v for k, v in b.items() if k not in ("engine", "record", "walls")}
        first["kT"] = float(kTs[0])
        b["height"] = CompressionParams(**first).initial_height
    recs = _run_sweep(b, {"kT": [float(t) for t in kTs]}, seeds, out, executor)
    return sweep_table(recs)


def temperature_for_density(
    forces: Sequence[float],
    *,
    packing_fraction: float,
    out: str | Path,
    base: dict[str, Any] | None = None,
    seeds: Sequence[int] = (0,),
    iterations: int = 2,
    executor: Any = None,
) -> Any:
    """The temperature that holds the density fixed as the force varies (panel w).

    For each force the first guess is the ideal-gas temperature for the target area;
    each further iteration rescales ``kT`` by the ratio of the target free height to the
    measured one (exact for an ideal gas).  Returns the table of the last iteration
    with a column ``iteration``; the density reached is in ``packing_fraction``.
    """
    import pandas as pd

    b = _base(base)
    b["walls"] = "force"
    p0 = CompressionParams(**{k: v for k, v in b.items() if k not in ("engine", "record")})
    check(0 < packing_fraction < 0.8, "packing_fraction", "in (0, 0.8)", packing_fraction)
    check(iterations >= 1, "iterations", "a positive integer", iterations)
    area = p0.n * math.pi * p0.radius**2 / packing_fraction
    h_target = area / p0.width
    hf_target = h_target - p0.diameter
    ms_per_kT = speed_law(p0.speed_law, 1.0).mean_square()  # <v^2> per unit kT
    out = prepare_output_dir(out)
    kTs = {float(F): F * hf_target / p0.n / (ms_per_kT * p0.tau / 4) for F in forces}
    table = None
    for it in range(iterations):
        frames = []
        for F, kT in kTs.items():
            b_it = dict(b, force=F, kT=kT, height=h_target)
            recs = _run_sweep(b_it, {"force": [F]}, seeds, out / f"iter{it}", executor)
            frames.append(sweep_table(recs))
        table = pd.concat(frames, ignore_index=True)
        table["iteration"] = it
        failed = table[table["status"] == "failed"]
        if len(failed):
            row = failed.iloc[0]
            raise ThermoswarmError(
                f"temperature_for_density: run {row['run_id']} (force {row['force']}) "
                f"failed: {row['error']}"
            )
        means = table.groupby("force")[["height", "kT"]].mean()
        for F in kTs:
            hf = float(means.loc[F, "height"]) - p0.diameter
            kTs[F] = float(kTs[F] * hf_target / hf)
    return table
