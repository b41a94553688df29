"""Which combination moves the object of ``transport-free`` toward the target?

PAPER_NOTES 6.3: the paper's equation makes lit robots cold (``T_liquid`` where ``l >
l_threshold``) while its captions and text make them hot (gas-like).  Simple physics
says more.  A robot that redraws a uniform heading every period and holds a speed drawn
at the local temperature is a random walker with diffusivity ``D(x) = kT(x) tau / 2``;
its steady density obeys ``rho D = const`` (Ito convention: the speed is set where the
period starts), and the dilute swarm's pressure on a wall is ``P = rho D`` (drag 1) --
the same everywhere, so the net force on an obstacle vanishes whatever the temperature
field.  With a persistent heading the speed adapts within a run, ``rho ~ 1 / v`` and
``P ~ rho v^2 tau_p ~ v``: the hot side pushes toward the cold side.  Crowding breaks
the uniform-heading balance too: where the cold region is small (the shadow strip
behind the object, when lit robots are hot) it cannot hold the density ``rho_cold =
rho_hot D_hot / D_cold`` that balance requires, and the hot side wins.

This study measures it: ``mapping`` x ``heading_law`` x ``sensor.mode`` (x ``n``, the
density, in the full setting) over at least 10 seeds each, and reports per combination
the mean displacement of the object toward the target with its standard error, a 95 %
Student-t confidence interval, Cohen's d and a verdict, and the time-averaged net force
on the object along the target direction (robot drag units, mm/s), also with a t
interval over seeds.

Settings (``SETTINGS``); every run holds the object for a 100 s warm-up (its stall
force is ``force_held``), then releases it:

- ``quick``: 600 robots in a 1270 mm square arena (the packing fraction 0.32 of the
  default 1,200 robots in 1800 mm), 300 s free, 10 seeds, 8 combinations: 80 runs, about
  2 minutes on two cores.  It reduces the swarm size, the arena and the duration.
- ``full``: 1,200 robots in 1800 mm, 600 s free, plus the density factor ``n`` in {300,
  1200} in the same arena (packing 0.08 and 0.32), 10 seeds: 160 runs, the numbers in
  ``docs/scenarios_transport.md``.

Run: ``thermoswarm study mechanism --setting quick --out DIR`` writes
``DIR/mechanism.json`` and ``DIR/mechanism.md`` (runs in ``DIR/runs/``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from concurrent.futures import Executor
from pathlib import Path
from typing import Any

import pandas as pd

from thermoswarm.fsutil import atomic_write_json, atomic_write_text
from thermoswarm.studies._common import StudyResult, effect, run_grid, verdict

__all__ = ["SETTINGS", "MechanismResult", "run_mechanism", "summarize", "markdown_table"]

_COMMON = {"record.interval": 10.0, "record.netcdf": False}

#: Named settings: ``base`` parameters, ``grid`` and number of seeds.
SETTINGS: dict[str, dict[str, Any]] = {
    "quick": {
        "base": {
            **_COMMON,
            "n": 600,
            "width": 1270.0,
            "height": 1270.0,
            "duration": 400.0,
            "warmup": 100.0,
        },  # fmt: skip
        "grid": {
            "mapping": ["lit_hot", "lit_cold"],
            "heading_law": ["uniform", "persistent"],
            "sensor.mode": ["ideal", "photoresistor"],
        },
        "seeds": 10,
    },
    "full": {
        "base": {**_COMMON, "duration": 700.0, "warmup": 100.0},
        "grid": {
            "mapping": ["lit_hot", "lit_cold"],
            "heading_law": ["uniform", "persistent"],
            "sensor.mode": ["ideal", "photoresistor"],
            "n": [300, 1200],
        },
        "seeds": 10,
    },
}

#: The combination that ``transport-free`` uses by default.
DEFAULT = {"mapping": "lit_cold", "heading_law": "persistent", "sensor.mode": "ideal"}


class MechanismResult(StudyResult):
    """Per-run rows (``runs``), per-combination statistics (``summary``), the setting."""

    def table(self) -> str:
        return markdown_table(self.summary)


def _rows(records: Sequence[Any], factors: Sequence[str]) -> pd.DataFrame:
    rows = []
    for r in records:
        m = r.metrics
        row = {f: r.params.get(f) for f in factors}
        row.update(
            seed=r.seed,
            displacement=m["displacement_toward_target"],
            max_displacement=m["max_displacement_toward_target"],
            time_to_target=m["time_to_target"],
            force=m["force_toward_target"]["mean"],
            force_held=(m.get("force_held") or {}).get("mean"),
            force_se_within_run=m["force_toward_target"]["se"],
            lateral_displacement=m["lateral_displacement"],
            hot_fraction=m["hot_fraction_mean"],
            run_dir=r.out,
        )
        rows.append(row)
    return pd.DataFrame(rows)


def summarize(runs: pd.DataFrame, factors: Sequence[str]) -> pd.DataFrame:
    """Per-combination statistics of a runs table (one row per run, columns
    ``factors``, ``displacement`` mm and ``force`` mm/s).

    Columns: the factors, ``seeds``, ``disp_mean``, ``disp_sd``, ``disp_se``,
    ``disp_ci_low``, ``disp_ci_high`` (95 % t interval, mm), ``disp_d`` (Cohen's d),
    ``disp_p`` (two-sided t-test against 0), ``force_mean``, ``force_se``,
    ``force_ci_low``, ``force_ci_high`` (time-averaged net force on the moving object
    along the target direction, robot drag units = mm/s), ``held_mean``, ``held_se``,
    ``held_ci_low``, ``held_ci_high`` and ``held_verdict`` (the same for the force on the
    object held during the warm-up's second half: the stall force of the mechanism),
    ``hot_fraction`` (mean fraction of robots hot) and ``verdict`` (from the
    displacement interval).
    """
    out = []
    for key, g in runs.groupby(list(factors), sort=True, dropna=False):
        key = key if isinstance(key, tuple) else (key,)
        d = effect(g["displacement"].tolist())
        f = effect(g["force"].tolist())
        h = effect(g["force_held"].tolist()) if "force_held" in g else effect([])
        row = dict(zip(factors, key, strict=True))
        row.update(
            seeds=d["n"],
            disp_mean=d["mean"],
            disp_sd=d["sd"],
            disp_se=d["se"],
            disp_ci_low=d["ci_low"],
            disp_ci_high=d["ci_high"],
            disp_d=d["d"],
            disp_p=d["p"],
            force_mean=f["mean"],
            force_se=f["se"],
            force_ci_low=f["ci_low"],
            force_ci_high=f["ci_high"],
            held_mean=h["mean"],
            held_se=h["se"],
            held_ci_low=h["ci_low"],
            held_ci_high=h["ci_high"],
            held_verdict=verdict(h["ci_low"], h["ci_high"]) if h["n"] >= 2 else None,
            hot_fraction=float(g["hot_fraction"].mean()),
            verdict=verdict(d["ci_low"], d["ci_high"]),
        )
        out.append(row)
    return pd.DataFrame(out)


def markdown_table(summary: pd.DataFrame) -> str:
    """The summary as a Markdown table (displacement mm, force mm/s)."""
    factors = [c for c in summary.columns if c in ("n", "mapping", "heading_law", "sensor.mode")]
    head = [*factors, "seeds", "displacement (mm) mean ± se", "95 % CI", "d", "p",
            "force, free (mm/s)", "force, held (mm/s)", "verdict"]  # fmt: skip
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]

    def num(x: float, fmt: str) -> str:
        return "nan" if x is None or not math.isfinite(x) else format(x, fmt)

    for _, r in summary.iterrows():
        cells = [str(r[f]) for f in factors]
        cells += [
            str(int(r["seeds"])),
            f"{num(r['disp_mean'], '.1f')} ± {num(r['disp_se'], '.1f')}",
            f"[{num(r['disp_ci_low'], '.1f')}, {num(r['disp_ci_high'], '.1f')}]",
            num(r["disp_d"], ".2f"),
            num(r["disp_p"], ".2g"),
            f"{num(r['force_mean'], '.3f')} ± {num(r['force_se'], '.3f')}",
            f"{num(r.get('held_mean'), '.3f')} ± {num(r.get('held_se'), '.3f')}",
            str(r["verdict"]),
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def run_mechanism(
    out: str | Path,
    setting: str = "quick",
    *,
    seeds: int | Sequence[int] | None = None,
    variant: str = "free",
    executor: Executor | None = None,
    max_workers: int | None = None,
    overrides: dict[str, Any] | None = None,
    grid: dict[str, list[Any]] | None = None,
    progress: bool | None = None,
) -> MechanismResult:
    """Run the mechanism grid into ``out`` and summarise it.

    Parameters
    ----------
    out : path
        Study directory (created with its parents); runs go to ``out/runs/<run_id>/``,
        results to ``out/mechanism.json`` and ``out/mechanism.md``.
    setting : {"quick", "full"}
    seeds : int or list of int, optional
        Number of seeds (0..k-1) or the seeds; default the setting's (10).
    variant : str
        ``transport-free`` variant.
    overrides : dict, optional
        Further base parameters (dotted keys), e.g. ``{"duration": 100}``.
    grid : dict, optional
        Replaces the setting's grid (dotted key -> values).
    """
    from thermoswarm.errors import ConfigError

    if setting not in SETTINGS:
        raise ConfigError(f"setting must be one of {sorted(SETTINGS)}, got {setting!r}")
    cfg = SETTINGS[setting]
    seed_list = list(range(cfg["seeds"])) if seeds is None else seeds
    if isinstance(seed_list, int):
        seed_list = list(range(seed_list))
    base = {**cfg["base"], "variant": variant, **(overrides or {})}
    grid = dict(cfg["grid"] if grid is None else grid)
    out = Path(out)
    records = run_grid("transport-free", out, base=base, grid=grid, seeds=seed_list,
                       executor=executor, max_workers=max_workers, progress=progress)  # fmt: skip
    factors = list(grid)
    runs = _rows(records, factors)
    summary = summarize(runs, factors)
    result = MechanismResult(
        runs=runs,
        summary=summary,
        setting={
            "name": setting,
            "base": base,
            "grid": grid,
            "seeds": list(seed_list),
            "default": DEFAULT,
        },  # fmt: skip
    )
    atomic_write_json(out / "mechanism.json", result.to_dict())
    atomic_write_text(out / "mechanism.md", result.table())
    return result
