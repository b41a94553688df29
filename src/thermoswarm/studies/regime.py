"""Where does ``transport-free`` move the object fastest?  Maps of the drift speed.

The paper fixes the law of Algorithm 5 (Boltzmann speeds whose temperature the light
switches) but leaves open its numbers: the two temperatures, the steering temperature
of a persistent heading, the control period, the light's geometry, the object's
friction, the arena and the density.  This study maps the object's drift speed toward
the light (displacement toward the target over the run, mm/s; mean and standard error
over seeds) over pairs of them, around a base regime, each map a grid x seeds run
through :func:`thermoswarm.studies._common.run_grid`:

- ``cold``: the cold phase's mean speed x its steering temperature;
- ``hot``: the hot phase's mean speed x its steering temperature;
- ``friction``: the object's drag x the arena's side (the density of 1,200 robots);
- ``light``: the lamp's angular radius (a penumbra) x the light threshold (the two
  together shape the hot region behind the object);
- ``period``: the control period x the cold steering temperature (a cold robot's
  heading changes by ``kT_theta_cold * tau`` per period).

Temperatures are set as mean speeds ``v`` (``kT = 2 v^2 / pi``, the Rayleigh law's
mean); every run caps speeds at the robot's top speed ``v_max`` = 33 mm/s.

Settings: ``quick`` (600 robots in the 1270 mm arena of the same packing 0.32, 150 s,
3 seeds, a 3 x 3 corner of each map: a smoke test, about 2 minutes on two cores) and
``full`` (1,200 robots, 300 s, 5 seeds; the maps in ``docs/scenarios_transport.md``).
Run ``thermoswarm study regime --setting full --out DIR``: writes ``DIR/regime.json``,
``DIR/regime.md`` and ``DIR/regime.png``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from concurrent.futures import Executor
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from thermoswarm.fsutil import atomic_path, atomic_write_json, atomic_write_text
from thermoswarm.maxent import kT_for_mean_speed
from thermoswarm.studies._common import StudyResult, effect, run_grid, study_pool

__all__ = [
    "SETTINGS",
    "MAPS",
    "RegimeResult",
    "run_regime",
    "load_regime",
    "summarize",
    "plot_maps",
]


def kT(v: float) -> float:
    """Temperature (mm^2/s^2) whose Rayleigh speed law has mean ``v`` (mm/s), rounded."""
    return round(float(kT_for_mean_speed(v)), 3)


#: The regime the maps are centred on (the defaults of ``transport-free``).
CENTRE: dict[str, Any] = {
    "kT_hot": kT(22.0),
    "kT_cold": kT(18.0),
    "kT_theta": 0.1,
    "kT_theta_cold": 2.0,
    "v_max": 33.0,
}

#: Each map: its two axes (a parameter and its values; ``speed`` axes are mean speeds in
#: mm/s set through the temperature) and fixed parameters beside the centre's.
MAPS: dict[str, dict[str, Any]] = {
    "cold": {
        "x": ("kT_theta_cold", [0.1, 0.8, 2.0, 5.0], "cold steering temperature (rad/s)"),
        "y": ("kT_cold", [3.0, 10.0, 15.0, 18.0, 20.0], "cold mean speed (mm/s)"),
    },
    "hot": {
        "x": ("kT_theta", [0.03, 0.1, 0.3, 0.8], "hot steering temperature (rad/s)"),
        "y": ("kT_hot", [20.0, 22.0, 25.0], "hot mean speed (mm/s)"),
    },
    "friction": {
        "x": ("object_drag", [0.5, 1.0, 2.0, 4.0, 8.0], "object drag (robot drags)"),
        "y": ("arena", [1500.0, 1800.0, 2100.0], "arena side (mm)"),
    },
    "light": {
        "x": ("light_spread_deg", [0.0, 5.0, 10.0], "lamp angular radius (deg)"),
        "y": ("threshold", [0.2, 0.5, 0.9], "light threshold"),
    },
    "period": {
        "x": ("kT_theta_cold", [0.8, 2.0, 5.0], "cold steering temperature (rad/s)"),
        "y": ("tau", [0.5, 1.0, 2.0], "control period (s)"),
    },
}

#: Axes given as mean speeds (mm/s) but set as temperatures.
SPEED_AXES = ("kT_cold", "kT_hot")

SETTINGS: dict[str, dict[str, Any]] = {
    "quick": {"n": 600, "arena": 1270.0, "duration": 150.0, "seeds": 3, "cells": 3},
    "full": {"n": 1200, "arena": None, "duration": 300.0, "seeds": 5, "cells": None},
}


class RegimeResult(StudyResult):
    def table(self) -> str:
        """One Markdown table per map: drift speed mean ± se (mm/s), rows y, columns x."""
        parts = []
        for name, h in self.summary.groupby("map", sort=False):
            m = MAPS[name]
            xs = sorted(h["x"].unique())
            ys = sorted(h["y"].unique())
            head = [f"{m['y'][2]} \\ {m['x'][2]}", *[f"{x:g}" for x in xs]]
            lines = [f"### {name}", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
            for y in ys:
                row = [f"{y:g}"]
                for x in xs:
                    c = h[(h["x"] == x) & (h["y"] == y)]
                    if c.empty:
                        row.append("")
                        continue
                    c = c.iloc[0]
                    row.append(
                        f"{c['drift_mean']:.2f} ± {c['drift_se']:.2f}"
                        + (f" ({int(c['reached'])}/{int(c['seeds'])})" if c["reached"] else "")
                    )
                lines.append("| " + " | ".join(row) + " |")
            parts.append("\n".join(lines))
        return "\n\n".join(parts) + "\n"


def _values(axis: tuple[str, list[float], str], cells: int | None) -> list[float]:
    key, vals, _ = axis
    return list(vals if cells is None else vals[-cells:] if key in SPEED_AXES else vals[:cells])


def _set(key: str, value: float, arena_default: float | None) -> dict[str, Any]:
    if key in SPEED_AXES:
        return {key: kT(value)}
    if key == "arena":
        return {"width": value, "height": value}
    return {key: value}


def summarize(runs: pd.DataFrame) -> pd.DataFrame:
    """Per map cell: seeds, drift speed (mm/s) mean/sd/se/95 % t interval, runs that
    reached the target, and the median time to target over those that did (s)."""
    rows = []
    keys = ["map", "x", "y"]
    for key, g in runs.groupby(keys, sort=False, dropna=False):
        e = effect(g["drift"].tolist())
        t = [v for v in g["time_to_target"].tolist() if v is not None and np.isfinite(v)]
        rows.append(
            {
                **dict(zip(keys, key, strict=True)),
                "seeds": e["n"],
                "drift_mean": e["mean"],
                "drift_sd": e["sd"],
                "drift_se": e["se"],
                "drift_ci_low": e["ci_low"],
                "drift_ci_high": e["ci_high"],
                "reached": len(t),
                "time_median_reached": float(np.median(t)) if t else None,
            }
        )
    return pd.DataFrame(rows)


def default_cell(name: str) -> tuple[float | None, float | None]:
    """The cell ``(x, y)`` of map ``name`` at the defaults of ``transport-free``, as the
    study records it (speed axes as mean speeds in mm/s); ``None`` for an axis whose
    values miss the default."""
    centre = {**CENTRE, "object_drag": 2.0, "arena": 1800.0, "tau": 1.0,
              "light_spread_deg": 0.0, "threshold": 0.5}  # fmt: skip
    out: list[float | None] = []
    for axis, (key, vals, _) in zip("xy", (MAPS[name]["x"], MAPS[name]["y"]), strict=True):
        c = float(centre[key])
        if key in SPEED_AXES:
            c = math.sqrt(math.pi * c / 2)  # the mean speed of the default temperature
        hit = next((float(v) for v in vals if abs(v - c) < 1e-3), None)
        if hit is not None and axis == "x" and key in SPEED_AXES:  # recorded from kT
            hit = round(math.sqrt(math.pi * kT(hit) / 2), 6)
        out.append(hit)
    return out[0], out[1]


#: Titles of the maps in figures.
TITLES = {
    "cold": "cold phase",
    "hot": "hot phase",
    "friction": "object friction and density",
    "light": "light: penumbra and threshold",
    "period": "control period",
}


def plot_maps(result: RegimeResult | pd.DataFrame, fig: Any = None) -> Any:
    """One heat map per map (three per row): colour = mean drift speed toward the
    light (mm/s), each cell annotated ``mean ± se`` and, where runs reached the target
    within the run, their count; the default regime's cell is outlined."""
    import matplotlib.pyplot as plt

    summary = result.summary if isinstance(result, RegimeResult) else result
    panels = list(summary.groupby("map", sort=False))
    cols = min(3, len(panels))
    rows = math.ceil(len(panels) / cols)
    if fig is None:
        fig = plt.figure(figsize=(4.8 * cols + 1.0, 3.9 * rows), constrained_layout=True)
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    vmax = float(np.nanmax(np.abs(summary["drift_mean"]))) or 1.0
    for ax, (name, h) in zip(axes, panels, strict=False):
        m = MAPS[name]
        xs = sorted(h["x"].unique())
        ys = sorted(h["y"].unique())
        grid = np.full((len(ys), len(xs)), np.nan)
        for _, c in h.iterrows():
            grid[ys.index(c["y"]), xs.index(c["x"])] = c["drift_mean"]
        im = ax.imshow(grid, origin="lower", cmap="RdBu_r", vmin=-vmax, vmax=vmax,
                       aspect="auto")  # fmt: skip
        for _, c in h.iterrows():
            i, j = ys.index(c["y"]), xs.index(c["x"])
            text = f"{c['drift_mean']:.2f}\n±{c['drift_se']:.2f}"
            if c["reached"]:
                text += f"\n({int(c['reached'])}/{int(c['seeds'])})"
            dark = abs(c["drift_mean"]) > 0.6 * vmax
            ax.text(j, i, text, ha="center", va="center", fontsize=7,
                    color="white" if dark else "black")  # fmt: skip
        cx, cy = default_cell(name)
        if cx in xs and cy in ys:  # the default regime's cell
            ax.add_patch(plt.Rectangle((xs.index(cx) - 0.5, ys.index(cy) - 0.5), 1, 1,
                                       fill=False, lw=2.5, ec="k"))  # fmt: skip
        ax.set_xticks(range(len(xs)), [f"{x:g}" for x in xs])
        ax.set_yticks(range(len(ys)), [f"{y:g}" for y in ys])
        ax.set_xlabel(m["x"][2])
        ax.set_ylabel(m["y"][2])
        ax.set_title(TITLES.get(name, name))
    for ax in axes[len(panels) :]:
        ax.set_visible(False)
    fig.colorbar(im, ax=list(axes[: len(panels)]), label="drift toward the light (mm/s)",
                 shrink=0.8)  # fmt: skip
    return fig


def load_regime(path: str | Path) -> RegimeResult:
    """A :class:`RegimeResult` from a study directory's ``regime.json``."""
    data = json.loads((Path(path) / "regime.json").read_text())
    return RegimeResult(runs=pd.DataFrame(data["runs"]), summary=pd.DataFrame(data["summary"]),
                        setting=data["setting"])  # fmt: skip


def _map_rows(
    out: Path,
    name: str,
    base: dict[str, Any],
    cfg: dict[str, Any],
    seed_list: Sequence[int],
    executor: Executor | None,
    max_workers: int | None,
    progress: bool | None,
) -> list[dict[str, Any]]:
    """One row per run of map ``name`` (one grid over its x axis per value of its y
    axis, into ``out/<name>/``): the drift (mm/s), displacement (mm) and time to target
    (s); speed axes in mean speed (mm/s)."""
    rows: list[dict[str, Any]] = []
    m = MAPS[name]
    xs = _values(m["x"], cfg["cells"])
    ys = _values(m["y"], cfg["cells"])
    for y in ys:
        b = {**base, **_set(m["y"][0], y, cfg["arena"])}
        if m["x"][0] in SPEED_AXES:
            grid = {m["x"][0]: [kT(x) for x in xs]}
        else:
            grid = {m["x"][0]: xs}
        sub = out / name
        sub.mkdir(exist_ok=True)
        records = run_grid("transport-free", sub, base=b, grid=grid, seeds=seed_list,
                           executor=executor, max_workers=max_workers,
                           progress=progress)  # fmt: skip
        for r in records:
            xv = r.params[m["x"][0]]
            if m["x"][0] in SPEED_AXES:
                xv = round(math.sqrt(math.pi * xv / 2), 6)
            met = r.metrics
            rows.append(
                {
                    "map": name,
                    "x": float(xv),
                    "y": float(y),
                    "seed": r.seed,
                    "drift": met["mean_velocity_toward_target"],
                    "displacement": met["displacement_toward_target"],
                    "time_to_target": met["time_to_target"],
                    "run_dir": r.out,
                }
            )
    return rows


def _with_earlier_maps(
    out: Path, runs: pd.DataFrame, info: dict[str, Any], names: list[str]
) -> tuple[pd.DataFrame, list[str]]:
    """``runs`` and map ``names`` with the other maps that an earlier study of the same
    setting left in ``out/regime.json`` (first)."""
    if (out / "regime.json").is_file():  # maps run earlier into this directory stay
        prev = json.loads((out / "regime.json").read_text())
        same = {k: prev["setting"].get(k) for k in info} == json.loads(json.dumps(info))
        if same and prev["runs"]:
            old = pd.DataFrame(prev["runs"])
            old = old[~old["map"].isin(names)]
            runs = pd.concat([old, runs], ignore_index=True)
            names = [*old["map"].drop_duplicates().tolist(), *names]
    return runs, names


def run_regime(
    out: str | Path,
    setting: str = "quick",
    *,
    maps: Sequence[str] | None = None,
    seeds: int | Sequence[int] | None = None,
    executor: Executor | None = None,
    max_workers: int | None = None,
    overrides: dict[str, Any] | None = None,
    progress: bool | None = None,
    figure: bool = True,
) -> RegimeResult:
    """Run the drift-speed maps ``maps`` (default all of :data:`MAPS`) into ``out``.

    Each map's runs go to ``out/<map>/runs/``; ``overrides`` (dotted keys) change the
    base of every map.  Writes ``out/regime.json``, ``out/regime.md`` and (``figure``)
    ``out/regime.png``.
    """
    from thermoswarm.errors import ConfigError

    if setting not in SETTINGS:
        raise ConfigError(f"setting must be one of {sorted(SETTINGS)}, got {setting!r}")
    cfg = SETTINGS[setting]
    names = list(MAPS if maps is None else maps)
    for name in names:
        if name not in MAPS:
            raise ConfigError(f"map must be one of {sorted(MAPS)}, got {name!r}")
    seed_list = list(range(cfg["seeds"])) if seeds is None else seeds
    if isinstance(seed_list, int):
        seed_list = list(range(seed_list))
    base: dict[str, Any] = {**CENTRE, "n": cfg["n"], "duration": cfg["duration"],
                            "record.interval": 10.0, "record.netcdf": False}  # fmt: skip
    if cfg["arena"] is not None:
        base.update(width=cfg["arena"], height=cfg["arena"])
    base.update(overrides or {})
    from thermoswarm.fsutil import check_output_dir

    out = check_output_dir(out)  # missing parents are created with it
    from thermoswarm.sweep import SweepSpec, expand

    expand(SweepSpec("transport-free", out, base, {}, seed_list))  # bad values: nothing written
    out.mkdir(parents=True, exist_ok=True)

    with study_pool(executor, max_workers) as executor:
        rows = [
            row
            for name in names
            for row in _map_rows(out, name, base, cfg, seed_list, executor, max_workers, progress)
        ]
    runs = pd.DataFrame(rows)
    info = {"name": setting, "seeds": list(seed_list), "base": base}
    runs, names = _with_earlier_maps(out, runs, info, names)
    summary = summarize(runs)
    res = RegimeResult(runs=runs, summary=summary, setting={**info, "maps": names})
    atomic_write_json(out / "regime.json", res.to_dict())
    atomic_write_text(out / "regime.md", res.table())
    if figure:
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        fig = plot_maps(res)
        with atomic_path(out / "regime.png", suffix=".png") as tmp:
            fig.savefig(tmp, dpi=110, format="png")
        plt.close(fig)
    return res
