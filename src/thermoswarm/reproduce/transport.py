"""Transport with connection (Algorithm 4) and without (Algorithm 5): runs, numbers
and report sections."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.reproduce.plans import Plan
from thermoswarm.reproduce.runs import _run
from thermoswarm.reproduce.text import _fig, _num, _text


def _transport_connected(out: Path, plan: Plan, rep: Any, seed: int, bars: bool | None = False
                         ) -> dict[str, Any]:  # fmt: skip
    from thermoswarm.report.animate import animate, snapshot_strip
    from thermoswarm.scenarios import transport_connected as T

    over = None if plan.connected_duration is None else {"duration": plan.connected_duration}
    runs = [_run("transport-connected", out / "transport-connected" / f"seed{s}", over,
                 seed + s, bars) for s in range(plan.connected_seeds)]  # fmt: skip
    times = [m["time_to_target"] for m, _, _ in runs]
    reached = [t for t in times if t is not None]
    m, tracks, info = runs[0]
    res = {"seeds": plan.connected_seeds, "reached": len(reached),
           "time_to_target_mean": _num(float(np.mean(reached))) if reached else None,
           "time_to_target_sd": _num(float(np.std(reached, ddof=1)))
           if len(reached) > 1 else None,
           "displacement_toward_target": [_num(m2["displacement_toward_target"])
                                          for m2, _, _ in runs]}  # fmt: skip
    with rep.section("Transport with connection (Algorithm 4)"):
        rep.paragraph(
            "Robots attached around the 100 mm object draw headings U(-90, 90) deg "
            "relative to the light (the target side); the object and its robots move "
            "as one rigid body into the target room."
        )
        rep.table(
            [{"seed": seed + s, "reached the target": m2["time_to_target"] is not None,
              "time to target (s)": m2["time_to_target"],
              "displacement toward the target (mm)": m2["displacement_toward_target"]}
             for s, (m2, _, _) in enumerate(runs)],
            caption=f"{len(reached)} of {plan.connected_seeds} runs reached the target room; "
            f"time to target {_text(res['time_to_target_mean'], 's')} on average "
            f"(sd {_text(res['time_to_target_sd'], 's')})",
        )  # fmt: skip
        _fig(rep, snapshot_strip(tracks, T.plot_frame, info), "Snapshots (seed 0).")
        path = animate(
            tracks,
            T.plot_frame,
            info,
            out / "animations" / "transport-connected",
            title="transport with connection",
        )
        rep.animation(path, caption="Transport with connection.")
    return res


def _phase_figure(metrics: dict[str, Any]) -> Any:
    """Phase separation over time (one run): the share of hot robots in the lit region
    and in the shadow, and the density of each phase in its own region."""
    import matplotlib.pyplot as plt

    reg = metrics["phase_by_region"]
    t = np.asarray(reg["time"], dtype=float)

    def arr(key: str) -> np.ndarray:
        return np.array([np.nan if v is None else v for v in reg[key]], dtype=float)

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 3.4), constrained_layout=True)
    a1.plot(t, arr("hot_fraction_shadow"), color="tab:red", label="in the shadow")
    a1.plot(t, arr("hot_fraction_lit"), color="tab:blue", label="in the light")
    a1.set_ylim(-0.02, 1.02)
    a1.set_xlabel("time (s)")
    a1.set_ylabel("fraction of robots that are hot")
    a1.legend(frameon=False, fontsize=8)
    hot_region = "shadow" if metrics["mapping"] == "lit_cold" else "lit"
    cold_region = "lit" if hot_region == "shadow" else "shadow"
    a2.plot(t, arr(f"density_hot_{hot_region}"), color="tab:red",
            label=f"hot (gas-like) robots in the {hot_region}")  # fmt: skip
    a2.plot(t, arr(f"density_cold_{cold_region}"), color="tab:blue",
            label=f"cold (liquid-like) robots in the {cold_region}")  # fmt: skip
    a2.set_xlabel("time (s)")
    a2.set_ylabel("density (robots per m²)")
    a2.legend(frameon=False, fontsize=8)
    return fig


#: Phase-by-region means reported (the second half of each run).
PHASE_KEYS = {
    "hot_fraction_lit": "share of the lit region's robots that are hot",
    "hot_fraction_shadow": "share of the shadow's robots that are hot",
    "density_cold_lit": "cold robots in the light (per m²)",
    "density_hot_shadow": "hot robots in the shadow (per m²)",
}


def _free_runs(out: Path, plan: Plan, seed: int, bars: bool | None) -> tuple[list, dict]:
    """The default runs over seeds and one run of each variant (obstacle, zig-zag)."""
    base: dict[str, Any] = {} if plan.free_duration is None else {"duration": plan.free_duration}
    if plan.free_n is not None:
        base["n"] = plan.free_n
    runs = [
        _run("transport-free", out / "transport-free" / f"seed{s}", base, seed + s, bars)
        for s in range(plan.free_seeds)
    ]
    vbase = {k: v for k, v in base.items() if k != "duration"}
    if plan.variant_duration is not None:
        vbase["duration"] = plan.variant_duration
    variants = {v: _run("transport-free", out / f"transport-free-{v}",
                        {**vbase, "variant": v}, seed, bars)
                for v in ("obstacle", "zigzag")}  # fmt: skip
    return runs, variants


def _free_results(runs: list, variants: dict) -> dict[str, Any]:
    """The numbers of ``results.json``: arrivals, times to target, displacement (mean and
    standard error over seeds), phase-by-region means; each variant's own."""
    m = runs[0][0]
    disp = np.array([mm["displacement_toward_target"] for mm, _, _ in runs])
    se = float(disp.std(ddof=1) / math.sqrt(disp.size)) if disp.size > 1 else float("nan")
    times = [mm["time_to_target"] for mm, _, _ in runs]
    reached = [t for t in times if t is not None]
    phase = [mm["phase_by_region_mean"] for mm, _, _ in runs]

    def mean_of(key: str) -> float | None:
        v = [p[key] for p in phase if p.get(key) is not None]
        return _num(float(np.mean(v))) if v else None

    return {
        "default": {
            "seeds": len(runs),
            "n": m.get("n"),
            "duration_s": m["duration"],
            "target_distance_mm": m["target_distance"],
            "reached": len(reached),
            "time_to_target": times,
            "time_to_target_median": _num(float(np.median(reached))) if reached else None,
            "time_to_target_min": _num(min(reached)) if reached else None,
            "time_to_target_max": _num(max(reached)) if reached else None,
            "displacement_toward_target_mean": _num(float(disp.mean())),
            "displacement_toward_target_se": _num(se),
            "mean_over_se": _num(float(disp.mean()) / se) if se > 0 else None,
            "phase_by_region_mean": {k: mean_of(k) for k in PHASE_KEYS},
        },
        **{v: {"duration_s": mm["duration"],
               "target_distance_mm": mm["target_distance"],
               "displacement_toward_target": _num(mm["displacement_toward_target"]),
               "max_displacement_toward_target": _num(mm["max_displacement_toward_target"]),
               "time_to_target": mm["time_to_target"]} for v, (mm, _, _) in variants.items()},
    }  # fmt: skip


def _free_table(rep: Any, seed: int, runs: list, variants: dict, d: dict[str, Any]) -> None:
    """One row per run (default seeds, then the variants), arrivals in the caption."""
    rep.table(
        [{"run": f"free, seed {seed + s}", "duration (s)": mm["duration"],
          "time to target (s)": mm["time_to_target"],
          "max displacement toward the target (mm)": mm["max_displacement_toward_target"],
          "final displacement (mm)": mm["displacement_toward_target"]}
         for s, (mm, _, _) in enumerate(runs)]
        + [{"run": f"{v}, seed {seed}", "duration (s)": mm["duration"],
            "time to target (s)": mm["time_to_target"],
            "max displacement toward the target (mm)": mm["max_displacement_toward_target"],
            "final displacement (mm)": mm["displacement_toward_target"]}
           for v, (mm, _, _) in variants.items()],
        caption=f"Free space: the target reached in {d['reached']} of {d['seeds']} runs"
        + (f"; time to target median {_text(d['time_to_target_median'], 's')} (range "
           f"{_text(d['time_to_target_min'], 's')} to "
           f"{_text(d['time_to_target_max'], 's')})" if d["reached"] else "")
        + "; time to target \u2013 = not reached within the run",
        floatfmt=".4g",
    )  # fmt: skip


def _object_path_figure(runs: list, variants: dict) -> Any:
    """The object's displacement toward the light over time, every run."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.5))
    for s, (mm, _, _) in enumerate(runs):
        path_ = mm["object_path"]
        ax.plot(path_["time"], path_["progress"], color="tab:green", alpha=0.7,
                label="free" if s == 0 else None)  # fmt: skip
    for v, (mm, _, _) in variants.items():
        ax.plot(mm["object_path"]["time"], mm["object_path"]["progress"], label=v)
    ax.axhline(runs[0][0]["target_distance"], color="tab:green", ls="--", lw=0.8)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("object displacement toward the light (mm)")
    ax.legend(frameon=False)
    return fig


def _transport_free(out: Path, plan: Plan, rep: Any, seed: int, bars: bool | None = False
                    ) -> dict[str, Any]:  # fmt: skip
    from thermoswarm.report.animate import animate, snapshot_strip
    from thermoswarm.scenarios import transport_free as F

    runs, variants = _free_runs(out, plan, seed, bars)
    m, tracks, info = runs[0]
    phase = [mm["phase_by_region_mean"] for mm, _, _ in runs]
    res = _free_results(runs, variants)
    d = res["default"]
    with rep.section("Transport without connection (Algorithm 5)"):
        rep.paragraph(
            f"{m['n']:,} robots around the 100 mm object in the centre of the arena, light "
            "from the target side (top); the object's shadow darkens the strip behind it and "
            "each robot's temperature switches with the light it sees: red robots are hot "
            "(gas-like), blue ones cold (liquid-like). Defaults found by the drift-speed "
            "search (below): the paper's equation (lit robots cold), hot robots 22 mm/s mean "
            "and keeping their heading, cold robots 18 mm/s and turning fast, speeds cut at "
            f"the robot's 33 mm/s. The object must travel {_text(d['target_distance_mm'], 'mm')}"
            " to the dashed line."
        )
        _free_table(rep, seed, runs, variants, d)
        path = animate(
            tracks,
            F.plot_frame,
            info,
            out / "animations" / "transport-free",
            title="transport without connection",
        )
        rep.animation(path, caption=f"The object carried toward the target line (default, "
                                    f"seed {seed}).")  # fmt: skip
        _fig(
            rep,
            snapshot_strip(tracks, F.plot_frame, info),
            "Snapshots of the default run: "
            "gas-like (red) and liquid-like (blue) robots around the object.",
        )
        fig = _object_path_figure(runs, variants)
        zz = res["zigzag"]["target_distance_mm"]
        _fig(rep, fig, "Object position over time (toward the light is up; dashed: the "
                       f"free arena's target; the zig-zag's target is {_text(zz, 'mm')} up)."
             )  # fmt: skip
        _fig(rep, _phase_figure(m),
             f"Phase separation (default, seed {seed}): left, the share of hot robots in the "
             "shadow and in the light; right, the density of each phase in its own "
             "region.")  # fmt: skip
        since = phase[0].get("since") if phase else None
        rep.table(
            [{"quantity": label, "mean over runs": d["phase_by_region_mean"][k]}
             for k, label in PHASE_KEYS.items()],
            caption=f"Phase separation by region: time means from {_text(since, 's')} to the "
            f"end of each run, averaged over {d['seeds']} runs",
            floatfmt=".3g",
        )  # fmt: skip
        for v, (_, tr, inf) in variants.items():
            _fig(rep, snapshot_strip(tr, F.plot_frame, inf, panels=4), f"Variant {v}.")
    return res
