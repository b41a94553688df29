"""Transport without connection versus swarm size (the paper's panels u and v).

The paper reports that the maximum distance the object is moved grows, and the time
to move it to the target shrinks, with the number of robots (PAPER_NOTES 5); its real
robots showed displacements "very high in variance and around 0" for few robots.  This
study runs ``transport-free`` (defaults: the mapping and heading law that move the
object toward the light) for a list of swarm sizes in a fixed arena -- so density
grows with ``n``, as when robots are added to one arena -- over several seeds, and
reports per size:

- the maximum displacement toward the target (mm): mean, sd, se, 95 % t interval,
  min and max over seeds;
- the time to target (s), a censored quantity (runs that never reach it): the fraction
  of runs that reached the target, the median time over all runs (unreached runs
  count as slower than any reached one, so the median is finite only when at least
  half reached), and the mean over the runs that reached it.

The target is ``target_distance`` mm toward the light from the object's start (the
top of the arena is too far for a 10-minute run at the drift speeds measured, see
``docs/scenarios_transport.md``).

Settings: ``quick`` (n = 50, 200, 600, 1200; 5 seeds; 300 s) and ``full`` (n = 50,
100, 200, 400, 800, 1200, 1600, 2000; 10 seeds; 600 s).  Run:
``thermoswarm study scaling --setting quick --out DIR`` writes
``DIR/scaling.json``, ``DIR/scaling.md`` and ``DIR/scaling.png``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from concurrent.futures import Executor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from thermoswarm.fsutil import atomic_path, atomic_write_json, atomic_write_text
from thermoswarm.studies._common import effect, run_grid

__all__ = [
    "SETTINGS",
    "ScalingResult",
    "run_scaling",
    "summarize",
    "censored_median",
    "plot_scaling",
]

SETTINGS: dict[str, dict[str, Any]] = {
    "quick": {"ns": [50, 200, 600, 1200], "seeds": 5, "duration": 300.0},
    "full": {"ns": [50, 100, 200, 400, 800, 1200, 1600, 2000], "seeds": 10, "duration": 600.0},
}


def censored_median(times: Sequence[float | None]) -> float | None:
    """Median of first-passage times where ``None`` (never reached) counts as longer
    than any reached time: ``None`` when fewer than half reached.

    With ``k`` values sorted (unreached last), the median is the middle value for odd
    ``k`` and the mean of the two middle values for even ``k``; ``None`` if either of
    those is unreached.
    """
    vals = sorted((math.inf if t is None else float(t)) for t in times)
    k = len(vals)
    if k == 0:
        return None
    mid = (vals[(k - 1) // 2] + vals[k // 2]) / 2
    return None if math.isinf(mid) else float(mid)


@dataclass
class ScalingResult:
    runs: pd.DataFrame
    summary: pd.DataFrame
    setting: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        return {
            "setting": self.setting,
            "summary": self.summary.to_dict(orient="records"),
            "runs": self.runs.to_dict(orient="records"),
        }

    def table(self) -> str:
        head = ["n", "seeds", "max displacement (mm) mean ± sd", "95 % CI", "min..max",
                "reached", "median time to target (s)", "mean time if reached (s)"]  # fmt: skip
        lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]

        def f(x: Any, fmt: str = ".1f") -> str:
            return (
                "-"
                if x is None or (isinstance(x, float) and not math.isfinite(x))
                else (format(x, fmt))
            )

        for _, r in self.summary.iterrows():
            lines.append(
                "| "
                + " | ".join(
                    [
                        str(int(r["n"])),
                        str(int(r["seeds"])),
                        f"{f(r['maxdisp_mean'])} ± {f(r['maxdisp_sd'])}",
                        f"[{f(r['maxdisp_ci_low'])}, {f(r['maxdisp_ci_high'])}]",
                        f"{f(r['maxdisp_min'])}..{f(r['maxdisp_max'])}",
                        f"{int(r['reached'])}/{int(r['seeds'])}",
                        f(r["time_median"]),
                        f(r["time_mean_reached"]),
                    ]
                )
                + " |"
            )
        return "\n".join(lines) + "\n"


def summarize(runs: pd.DataFrame) -> pd.DataFrame:
    """Per-``n`` statistics of a runs table with columns ``n``, ``max_displacement``
    (mm), ``displacement`` (mm) and ``time_to_target`` (s or None/NaN)."""
    rows = []
    for n, g in runs.groupby("n", sort=True):
        e = effect(g["max_displacement"].tolist())
        d = effect(g["displacement"].tolist())
        times = [None if t is None or (isinstance(t, float) and math.isnan(t)) else float(t)
                 for t in g["time_to_target"].tolist()]  # fmt: skip
        reached = [t for t in times if t is not None]
        rows.append(
            {
                "n": int(n),
                "seeds": e["n"],
                "maxdisp_mean": e["mean"],
                "maxdisp_sd": e["sd"],
                "maxdisp_se": e["se"],
                "maxdisp_ci_low": e["ci_low"],
                "maxdisp_ci_high": e["ci_high"],
                "maxdisp_min": float(g["max_displacement"].min()),
                "maxdisp_max": float(g["max_displacement"].max()),
                "disp_mean": d["mean"],
                "disp_se": d["se"],
                "reached": len(reached),
                "reached_fraction": len(reached) / max(len(times), 1),
                "time_median": censored_median(times),
                "time_mean_reached": float(np.mean(reached)) if reached else None,
                "time_min": float(min(reached)) if reached else None,
            }
        )
    return pd.DataFrame(rows)


def plot_scaling(result: ScalingResult | pd.DataFrame, axes: Sequence[Any] | None = None):
    """Panels (u) maximum displacement and (v) time to target versus ``n``.

    Error bars: sd over seeds (u); dots: individual runs.  In (v) the line is the
    censored median (missing where fewer than half reached the target) and each reached
    run is a dot; the fraction reached is written above each size.  Returns the figure.
    """
    import matplotlib.pyplot as plt

    if isinstance(result, ScalingResult):
        summary, runs = result.summary, result.runs
    else:
        summary, runs = result, None
    if axes is None:
        fig, axes = plt.subplots(1, 2, figsize=(9, 3.6), constrained_layout=True)
    else:
        fig = axes[0].figure
    ax_u, ax_v = axes
    ns = summary["n"].astype(float)
    xlim = (float(ns.min()) / 1.4, float(ns.max()) * 1.4)
    ax_u.errorbar(summary["n"], summary["maxdisp_mean"], yerr=summary["maxdisp_sd"],
                  fmt="o-", capsize=3, color="k", label="mean ± sd")  # fmt: skip
    if runs is not None:
        ax_u.plot(runs["n"], runs["max_displacement"], ".", color="tab:blue", alpha=0.5,
                  label="runs")  # fmt: skip
    ax_u.axhline(0, color="0.6", lw=0.8)
    ax_u.set_xscale("log")
    ax_u.set_xlim(xlim)
    ax_u.set_xlabel("number of robots")
    ax_u.set_ylabel("max displacement toward target (mm)")
    ax_u.set_title("(u) capacity")
    ax_u.legend(frameon=False, fontsize=8)
    med = summary["time_median"].astype(float)
    ax_v.plot(summary["n"], med, "o-", color="k", label="median")
    if runs is not None:
        rr = runs[runs["time_to_target"].notna()]
        ax_v.plot(rr["n"], rr["time_to_target"], ".", color="tab:red", alpha=0.6,
                  label="reached runs")  # fmt: skip
    ymax = ax_v.get_ylim()[1]
    for _, r in summary.iterrows():
        ax_v.annotate(f"{int(r['reached'])}/{int(r['seeds'])}", (r["n"], ymax),
                      ha="center", va="bottom", fontsize=7)  # fmt: skip
    ax_v.set_xscale("log")
    ax_v.set_xlim(xlim)
    ax_v.set_xlabel("number of robots")
    ax_v.set_ylabel("time to target (s)")
    ax_v.set_title("(v) speed", pad=14)
    ax_v.legend(frameon=False, fontsize=8)
    return fig


def run_scaling(
    out: str | Path,
    setting: str = "quick",
    *,
    ns: Sequence[int] | None = None,
    seeds: int | Sequence[int] | None = None,
    target_distance: float = 150.0,
    duration: float | None = None,
    variant: str = "free",
    executor: Executor | None = None,
    max_workers: int | None = None,
    overrides: dict[str, Any] | None = None,
    progress: bool | None = None,
    figure: bool = True,
) -> ScalingResult:
    """Run ``transport-free`` for each swarm size in ``ns`` over seeds into ``out``.

    ``target_distance`` (mm) sets ``target_y`` to the object's start plus this;
    ``overrides`` are further base parameters (dotted keys).  Writes
    ``out/scaling.json``, ``out/scaling.md`` and (``figure``) ``out/scaling.png``.
    """
    from thermoswarm.config import from_mapping
    from thermoswarm.errors import ConfigError
    from thermoswarm.scenarios.transport_free import TransportFreeParams, geometry

    if setting not in SETTINGS:
        raise ConfigError(f"setting must be one of {sorted(SETTINGS)}, got {setting!r}")
    cfg = SETTINGS[setting]
    ns = list(cfg["ns"] if ns is None else ns)
    seed_list = list(range(cfg["seeds"])) if seeds is None else seeds
    if isinstance(seed_list, int):
        seed_list = list(range(seed_list))
    base: dict[str, Any] = {"variant": variant, "duration": duration or cfg["duration"],
                            "record.interval": 10.0, "record.netcdf": False,
                            **(overrides or {})}  # fmt: skip
    if "target_y" not in base:
        probe = {k: v for k, v in base.items() if "." not in k and not isinstance(v, dict)}
        start_y = geometry(from_mapping(TransportFreeParams, probe)).start[1]
        base["target_y"] = start_y + float(target_distance)
    out = Path(out)
    records = run_grid("transport-free", out, base=base, grid={"n": ns},
                       seeds=seed_list, executor=executor, max_workers=max_workers,
                       progress=progress)  # fmt: skip
    runs = pd.DataFrame(
        [
            {
                "n": r.params["n"],
                "seed": r.seed,
                "max_displacement": r.metrics["max_displacement_toward_target"],
                "displacement": r.metrics["displacement_toward_target"],
                "time_to_target": r.metrics["time_to_target"],
                "run_dir": r.out,
            }
            for r in records
        ]
    )
    summary = summarize(runs)
    res = ScalingResult(runs=runs, summary=summary,
                        setting={"name": setting, "ns": ns, "seeds": list(seed_list),
                                 "base": base, "target_distance": target_distance})  # fmt: skip
    atomic_write_json(out / "scaling.json", res.to_dict())
    atomic_write_text(out / "scaling.md", res.table())
    if figure:
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        fig = plot_scaling(res)
        with atomic_path(out / "scaling.png", suffix=".png") as tmp:
            fig.savefig(tmp, dpi=120, format="png")
        plt.close(fig)
    return res
