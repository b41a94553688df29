"""The studies behind the transport: drift-speed maps, the mechanism, scaling with
swarm size; numbers and report sections."""

from __future__ import annotations

from concurrent.futures import Executor
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.reproduce.plans import Plan
from thermoswarm.reproduce.text import _fig, _notes_link, _num, _text


def _regime(out: Path, plan: Plan, rep: Any, workers: int | None,
            bars: bool | None = False, pool: Executor | None = None
            ) -> dict[str, Any]:  # fmt: skip
    from thermoswarm.studies import verdict
    from thermoswarm.studies.regime import MAPS, TITLES, default_cell, plot_maps, run_regime

    r = run_regime(
        out / "regime", plan.study, maps=list(plan.regime_maps) if plan.regime_maps else None,
        seeds=plan.study_seeds, max_workers=workers, executor=pool, progress=bars,
        overrides=dict(plan.study_overrides), figure=False,
    )  # fmt: skip
    rows = r.summary.replace({np.nan: None}).to_dict(orient="records")
    for row in rows:
        lo, hi = row["drift_ci_low"], row["drift_ci_high"]
        row["verdict"] = "no interval (one seed)" if lo is None or hi is None else verdict(lo, hi)
        row["default"] = default_cell(row["map"]) == (row["x"], row["y"])
        row.update(map_title=TITLES[row["map"]], x_name=MAPS[row["map"]]["x"][2],
                   y_name=MAPS[row["map"]]["y"][2])  # fmt: skip
    with rep.section("Where the object moves fastest: drift-speed maps"):
        rep.paragraph(
            "The object's drift toward the light (mm/s, mean ± standard error over seeds) "
            "over the parameters Algorithm 5 leaves open, around the default (outlined): "
            f"{', '.join(TITLES[k] for k in r.setting['maps'])} ({plan.study} setting: "
            f"{r.setting['base'].get('n'):,} robots, "
            f"{_text(r.setting['base'].get('duration'), 's')} runs, "
            f"{len(r.setting['seeds'])} seeds per cell). A cell's verdict: toward or "
            "away from the target when its whole 95 % interval is on one side of 0."
        )
        n_reached = sum(1 for row in rows if row["reached"])
        _fig(rep, plot_maps(r), "Drift speed toward the light (mm/s, mean ± standard error)"
             + (f"; in brackets, where any did, the runs that reached the target within the "
                f"run ({n_reached} of {len(rows)} cells)." if n_reached else
                f"; no run of any cell reached the target within its "
                f"{_text(r.setting['base'].get('duration'), 's')}."))  # fmt: skip
        for name in r.setting["maps"]:
            mp = MAPS[name]
            rep.table(
                [{mp["y"][2]: row["y"], mp["x"][2]: row["x"],
                  "drift (mm/s), mean": row["drift_mean"],
                  "standard error (mm/s)": row["drift_se"],
                  "reached the target": f"{row['reached']} of {row['seeds']}",
                  "verdict": row["verdict"] + (" (default)" if row["default"] else "")}
                 for row in rows if row["map"] == name],
                caption=f"{TITLES[name]}: drift toward the light per cell",
                floatfmt=".3g",
            )  # fmt: skip
    return {"setting": plan.study, "maps": list(r.setting["maps"]),
            "seeds": len(r.setting["seeds"]), "n": r.setting["base"].get("n"),
            "duration_s": r.setting["base"].get("duration"), "rows": rows}  # fmt: skip


def _mechanism(out: Path, plan: Plan, rep: Any, workers: int | None,
               bars: bool | None = False, pool: Executor | None = None
               ) -> dict[str, Any]:  # fmt: skip
    from thermoswarm.studies.mechanism import run_mechanism

    r = run_mechanism(
        out / "mechanism", plan.study, seeds=plan.mechanism_seeds or plan.study_seeds,
        max_workers=workers,
        overrides=dict(plan.study_overrides), progress=bars, executor=pool,
    )  # fmt: skip
    rows = r.summary.replace({np.nan: None}).to_dict(orient="records")
    with rep.section("The transport mechanism, measured"):
        rep.paragraph(
            "The paper's equation and its captions assign hot and cold to light and shadow in "
            "opposite ways. Every combination of mapping, heading law and sensing, "
            f"{len(r.setting['seeds'])} seeds each ({plan.study} setting): mean displacement "
            "of the object toward the light with its standard error and 95 % confidence "
            "interval, and the verdict (toward or away from the target when the whole "
            "interval is on one side of 0)."
        )
        _notes_link(rep, out, "How the contradiction is settled: ", ", section 6.3.")
        factors = [c for c in ("n", "mapping", "heading_law", "sensor.mode") if c in r.summary]
        names = {"n": "robots", "mapping": "mapping", "heading_law": "heading law",
                 "sensor.mode": "sensing"}  # fmt: skip
        rep.table(
            [{**{names[f]: row[f] for f in factors},
              "seeds": row["seeds"],
              "displacement (mm), mean": row["disp_mean"],
              "standard error (mm)": row["disp_se"],
              "95 % interval (mm)": f"{_text(row['disp_ci_low'])} to {_text(row['disp_ci_high'])}",
              "Cohen's d": row["disp_d"],
              "p (t-test against 0)": row["disp_p"],
              "force on the moving object (mm/s)": row["force_mean"],
              "force on the held object (mm/s)": row.get("held_mean"),
              "verdict": row["verdict"]} for row in rows],
            caption="Displacement toward the light per combination (forces in robot-drag "
            "units, mm/s)", floatfmt=".3g",
        )  # fmt: skip
    return {"setting": plan.study, "rows": rows, "default": r.setting["default"]}


def _scaling_trend(results: list[Any]) -> dict[str, Any]:
    """Per series: does each run's maximum displacement grow with N (Spearman)?"""
    from scipy import stats

    trend: dict[str, Any] = {}
    for r in results:
        runs = r.runs
        t: dict[str, Any] = {"test": "Spearman rank correlation of each run's maximum "
                             "displacement with N", "n_runs": len(runs)}  # fmt: skip
        # (undefined when every run moved the object the same distance, e.g. none at all)
        if len(runs) >= 3 and runs["n"].nunique() >= 2 and runs["max_displacement"].nunique() > 1:
            rho, pv = stats.spearmanr(runs["n"], runs["max_displacement"])
            t.update(spearman_rho=_num(float(rho)), spearman_p=_num(float(pv), 4))
        trend[r.setting["series"]] = t
    return trend


def _interval(lo: Any, hi: Any) -> str:
    """An interval of a median: unbounded above when its end is a run that never
    arrived; none with fewer than two runs."""
    if lo is None and hi is None:
        return "\u2013"
    return f"{_text(lo)} to {_text(hi) if hi is not None else 'unbounded'}"


def _scaling(out: Path, plan: Plan, rep: Any, workers: int | None,
             bars: bool | None = False, pool: Executor | None = None
             ) -> dict[str, Any]:  # fmt: skip
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FixedLocator, NullFormatter, NullLocator

    from thermoswarm.studies.scaling import plot_scaling, run_scaling

    over = {k: v for k, v in plan.study_overrides.items() if k != "n"}
    results = [run_scaling(out / f"scaling-{s}", s, ns=plan.scaling_ns, seeds=plan.study_seeds,
                           max_workers=workers, progress=bars, executor=pool, figure=False,
                           overrides=over) for s in plan.scaling_settings]  # fmt: skip
    rows = [row for r in results for row in r.summary.replace({np.nan: None}).to_dict("records")]
    trend = _scaling_trend(results)
    first = results[0].setting
    horizon, target = first["horizon"], first["target_distance"]
    window = min(horizon, float(first["base"].get("duration") or horizon))  # runs may be shorter

    reached = int(sum((row.get("reached") or 0) for row in rows))
    names = {"fixed": "fixed arena", "density": "arena grows with N"}
    with rep.section("Scaling with swarm size (panels u and v)"):
        rep.paragraph(
            "transport-free at its defaults for each swarm size over seeds: "
            + "; ".join(
                f"{names.get(r.setting['series'], r.setting['series'])} "
                f"({r.setting['name']} setting, {len(r.setting['seeds'])} seeds, "
                f"{_text(r.setting['base'].get('duration'), 's')} runs)"
                for r in results
            )
            + f". Capacity: the maximum displacement toward the target within the first "
            f"{_text(window, 's')} (later the object meets the target and the wall, which "
            f"cap it); time to the target line {_text(target, 'mm')} above the start. Medians "
            "with distribution-free 95 % intervals (order statistics; with fewer than 6 runs "
            "the range); a run that never arrived counts as slower than any that did."
        )
        rep.table(
            [{"series": names.get(row["series"], row["series"]), "robots": row["n"],
              "arena side (mm)": row["arena"], "seeds": row["seeds"],
              f"max displacement in {_text(window, 's')} (mm), median": row["maxdisp_median"],
              "95 % interval (mm)": _interval(row["maxdisp_ci_low"], row["maxdisp_ci_high"]),
              "mean ± sd (mm)": f"{_text(row['maxdisp_mean'])} ± {_text(row['maxdisp_sd'])}",
              "reached the target": f"{int(row['reached'])} of {int(row['seeds'])}",
              "time to target (s), median": row["time_median"],
              "95 % interval (s)": _interval(row["time_ci_low"], row["time_ci_high"]),
              "fastest run (s)": row["time_min"]} for row in rows],
            caption=f"Capacity and time to the target line {_text(target, 'mm')} above the "
            "start (median time \u2013: fewer than half the runs arrived; an interval "
            "unbounded: its end is a run that never arrived)",
            floatfmt=".4g",
        )  # fmt: skip
        fig, axes = plt.subplots(1, 2, figsize=(9, 3.6), constrained_layout=True)
        plot_scaling(results, axes=axes)
        ns = sorted({float(row["n"]) for row in rows})
        for ax in axes:  # the swarm sizes themselves as ticks (log minor labels overlap)
            ax.xaxis.set_major_locator(FixedLocator(ns))
            ax.xaxis.set_major_formatter(lambda x, _: f"{x:,.0f}")
            ax.xaxis.set_minor_locator(NullLocator())
            ax.xaxis.set_minor_formatter(NullFormatter())
            ax.tick_params(axis="x", labelsize=7)
        if reached == 0:  # panel (v) would be an empty plot
            fig.delaxes(axes[1])
            fig.set_size_inches(4.8, 3.6)
        _fig(rep, fig, f"(u) Maximum displacement toward the target within the first "
             f"{_text(window, 's')} against the number of robots"
             + (f"; (v) time to the target line {_text(target, 'mm')} above the start" if reached
                else "")
             + ": medians over seeds with 95 % intervals, dots the runs"
             + ("; a median time is drawn only where at least half the runs arrived." if reached
                else "."))  # fmt: skip
        if reached == 0:
            rep.empty(
                "(v) Time to target: no run at any swarm size reached the target line "
                f"within {_text(first['base'].get('duration'), 's')}, so there is no "
                "time to plot."
            )
    return {"setting": list(plan.scaling_settings), "horizon_s": horizon,
            "target_distance_mm": target, "rows": rows, "trend": trend}  # fmt: skip
