"""``thermoswarm reproduce``: every robot experiment of the paper, into one report.

Runs, into ``OUT/``:

1. ``narrow-road`` for the paper's 5,600 s: flows per direction, zero-flow gaps,
   speed and energy per road section;
2. ``compression``: an isotherm (pressure against area with the ideal-gas curve), the
   pressure against temperature at fixed density, and the temperature that holds the
   density fixed as the force varies (the paper's panel w);
3. ``transport-connected``: the object carried into the target room, over seeds;
4. ``transport-free``: the default (the regime of the drift-speed search in which the
   object reaches the target fastest) and the ``obstacle`` and ``zigzag`` variants,
   with the phase separation over time, and the drift-speed maps of that search;
5. the transport mechanism study (both light-to-phase mappings x fresh or persistent
   headings x ideal or photoresistor sensing, 10 seeds each);
6. scaling with swarm size (the paper's panels u and v);
7. one law for three systems: synthetic ants, an elastic gas and light-switched
   robots, each analysed by the same :func:`~thermoswarm.analysis.study.run_study`.

and writes ``OUT/report.html`` (self-contained), ``OUT/results.json`` (the headline
numbers; keys documented in the README) and an animation per scenario
(``OUT/animations/<scenario>.mp4``, or ``.gif`` without the video extra).

``quick`` keeps every experiment but shortens runs and studies (stated in the report) so
that the whole finishes in minutes on 2 cores; ``make run`` uses it.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm import __version__
from thermoswarm.fsutil import atomic_write_json, prepare_output_dir

__all__ = ["Plan", "reproduce"]


@dataclass(frozen=True)
class Plan:
    """How big each experiment is."""

    name: str
    road_duration: float = 5600.0
    compression_duration: float = 3600.0
    connected_seeds: int = 10
    free_seeds: int = 10
    free_duration: float | None = None  # None: the scenario's (every seed arrives)
    variant_duration: float | None = None
    study: str = "full"  # mechanism and scaling settings
    unified_robots: int = 1200
    unified_duration: float = 120.0


QUICK = Plan("quick", compression_duration=1600.0, connected_seeds=3, free_seeds=3,
             study="quick", unified_duration=60.0)  # fmt: skip
FULL = Plan("full")


class _Log:
    def __init__(self, verbose: bool) -> None:
        self.verbose = verbose
        self.t0 = time.perf_counter()
        self.times: dict[str, float] = {}

    def step(self, name: str) -> Callable[[], None]:
        start = time.perf_counter()
        if self.verbose:
            print(f"[{start - self.t0:6.0f} s] {name} ...", flush=True)

        def done() -> None:
            self.times[name] = round(time.perf_counter() - start, 1)

        return done


def _run(name: str, out: Path, overrides: dict[str, Any] | None = None, seed: int = 0):
    """Run (or reuse the finished run in) ``out``; returns (metrics, tracks, setup info)."""
    import xarray as xr

    from thermoswarm.config import from_mapping
    from thermoswarm.scenarios import get
    from thermoswarm.scenarios.runner import RunConfig, build, open_run_tracks, resume, run
    from thermoswarm.sweep import _flatten_base

    cls = get(name)
    cfg = RunConfig(name, from_mapping(cls.Params, _flatten_base(overrides or {})), seed)
    out.parent.mkdir(parents=True, exist_ok=True)
    if (out / "metrics.json").is_file() and (out / "config.toml").read_text() == cfg.to_toml():
        metrics = json.loads((out / "metrics.json").read_text())
    elif (out / "tracks.zarr").is_dir() and (out / "config.toml").read_text() == cfg.to_toml():
        metrics = resume(out, progress=False)
    else:
        if out.exists():
            import shutil

            shutil.rmtree(out)
        metrics = run(cfg, out, progress=False)
    nc = out / "tracks.nc"
    tracks = xr.open_dataset(nc).load() if nc.is_file() else open_run_tracks(out / "tracks.zarr")
    _, setup, _, _ = build(cfg)
    return metrics, tracks, setup.info


def _fig(report: Any, fig: Any, caption: str) -> None:
    import matplotlib.pyplot as plt

    report.figure(fig, caption=caption)
    plt.close(fig)


def _num(x: Any, nd: int = 3) -> Any:
    if x is None:
        return None
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return round(float(x), nd) if isinstance(x, float | np.floating) else x


# ----------------------------------------------------------------------------- road
def _narrow_road(out: Path, plan: Plan, rep: Any, seed: int) -> dict[str, Any]:
    import matplotlib.pyplot as plt

    from thermoswarm.report.animate import animate, snapshot_strip
    from thermoswarm.scenarios import narrow_road as R

    m, tracks, _ = _run("narrow-road", out / "narrow-road", {"duration": plan.road_duration},
                        seed)  # fmt: skip
    geo = m["road"]["geometry"]
    res = {
        "duration_s": plan.road_duration,
        "n": m["n"],
        "crossings": m["crossings"],
        "flow_per_direction": m["flow_per_direction"],
        "longest_zero_flow_s": m["longest_zero_flow_s"],
        # measured energy v^2/2 per road section (mm^2/s^2): colder in the narrow part
        "section_energy": {
            k: {"mean": _num(v["measured"]["energy_mean"]), "se": _num(v["measured"]["energy_se"])}
            for k, v in m["sections"].items()
        },  # fmt: skip
    }
    with rep.section("Narrow road (Algorithm 2)"):
        rep.paragraph(
            f"{m['n']} robots of 33 mm (occupation ratio 0.17857) cross a 381 mm road with a "
            f"wide and a narrow section in two directions for {plan.road_duration:.0f} s; "
            "robots that arrive re-enter at their start."
        )
        rep.table(
            {
                "crossings": json.dumps(m["crossings"]),
                "flow per direction (per min)": json.dumps(
                    {k: round(v, 2) for k, v in m["flow_per_direction"].items()}
                ),
                "longest zero-flow period (s)": json.dumps(
                    {k: round(v, 1) for k, v in m["longest_zero_flow_s"].items()}
                ),
                "measured energy per section (mm^2/s^2)": json.dumps(
                    {k: v["mean"] for k, v in res["section_energy"].items()}
                ),
            }
        )
        fig, ax = plt.subplots(figsize=(7, 3))
        R.plot_flow(ax, m)
        _fig(rep, fig, "Flow per direction over time (crossings per minute).")
        early = tracks.sel(time=slice(0, 300))
        _fig(
            rep,
            snapshot_strip(early, R.plot_frame, geo),
            "Snapshots of the first 300 s (blue: toward +x, orange: toward -x).",
        )
        path = animate(
            early,
            R.plot_frame,
            geo,
            out / "animations" / "narrow-road",
            size=(7.0, 3.0),
            title="narrow road",
        )
        rep.animation(path, caption="The first 300 s.")
    return res


# ------------------------------------------------------------------------ compression
def _compression(out: Path, plan: Plan, rep: Any, seed: int) -> dict[str, Any]:

    from thermoswarm.maxent import kT_for_mean_speed
    from thermoswarm.report.animate import animate, snapshot_strip
    from thermoswarm.scenarios import compression as C

    d = 33.0
    r = d / 2
    n, phi, h_free, tau = 300, 0.01, 100.0, 0.1
    kT = kT_for_mean_speed(20.0)
    kT_eff = 2 * kT * tau / 4
    width = n * math.pi * r * r / phi / (h_free + d)
    F0 = n * kT_eff / h_free
    base = {"n": n, "width": width, "kT": kT, "tau": tau, "duration": plan.compression_duration}
    work = out / "compression"
    iso = C.isotherm([F0 * s for s in (0.5, 0.75, 1.0, 1.5, 2.0)], out=work / "isotherm",
                     base=base, seeds=[seed])  # fmt: skip
    temp = C.temperature_series([kT_for_mean_speed(v) for v in (16.0, 20.0, 24.0, 28.0)],
                                out=work / "temperature", base={**base, "force": F0},
                                seeds=[seed])  # fmt: skip
    dens = C.temperature_for_density([F0 * s for s in (0.5, 1.0, 2.0, 4.0)],
                                     packing_fraction=phi, out=work / "density", base=base,
                                     seeds=[seed])  # fmt: skip
    # pictures from a squarer run (the dilute geometry above is 20 m wide and 13 cm tall):
    # 150 robots, 1 m wide, the force that holds an ideal gas about 0.6 m high
    kT10 = kT_for_mean_speed(10.0)
    pic = {"n": 150, "width": 1000.0, "kT": kT10, "tau": 1.0,
           "force": round(150 * (2 * kT10 * 1.0 / 4) / 600.0, 4),  # n kT_eff / h_free
           "duration": 600.0, "record": {"interval": 5.0}}  # fmt: skip
    m, tracks, _ = _run("compression", work / "run", pic, seed)
    geo = m["geometry"]
    pt_fit = C.linear_fit(temp["kT_eff"], temp["pressure"])
    dens_fit = C.linear_fit(dens["force"], dens["kT"])
    res = {
        "isotherm": [{"force": _num(a), "free_area": _num(b, 0), "pressure": _num(c, 8),
                      "Z": _num(z), "Z_se": _num(s)} for a, b, c, z, s in
                     zip(iso["force"], iso["free_area"], iso["pressure"], iso["Z"], iso["Z_se"],
                         strict=True)],  # fmt: skip
        "dilute_Z_mean": _num(float(np.mean(iso["Z"]))),
        "pressure_vs_temperature": {"r2": _num(pt_fit["r2"], 6), "slope": _num(pt_fit["slope"], 9),
                                    "ideal_slope": _num(n / float(temp["free_area"].iloc[0]), 9)},
        "temperature_for_density": {"r2": _num(dens_fit["r2"], 6),
                                    "packing_fraction": [_num(x, 4) for x in
                                                         dens["packing_fraction"]]},
    }  # fmt: skip
    with rep.section("Compression between force-driven walls (Algorithm 3)"):
        rep.paragraph(
            f"{n} robots at packing fraction {phi} between an upper and a lower wall pushed "
            f"by a constant force; heading re-drawn every {tau} s at mean speed 20 mm/s. "
            "Pressure from the walls' contact forces; kT_eff = D = <v^2> tau / 4 from the "
            "speeds drawn; Z = P A_free / (n kT_eff) with A_free = (Lx - d)(Ly - d)."
        )
        rep.table(
            {
                "mean Z on the isotherm": res["dilute_Z_mean"],
                "P vs T at fixed density: R^2": res["pressure_vs_temperature"]["r2"],
                "T for fixed density vs F: R^2": res["temperature_for_density"]["r2"],
            }
        )
        _fig(
            rep,
            C.study_figure(iso, temp, dens),
            "Left: isotherm, P against free area, "
            "with the ideal-gas curve n kT_eff / A_free. Middle: P against kT_eff at fixed "
            "area (held walls). Right: the temperature that holds the density fixed "
            "rises with the force (the paper's panel w).",
        )
        _fig(
            rep,
            snapshot_strip(tracks, C.plot_frame, geo),
            "Snapshots of a compression run (robots coloured by speed).",
        )
        path = animate(
            tracks, C.plot_frame, geo, out / "animations" / "compression", title="compression"
        )
        rep.animation(path, caption="Compression: walls pushed by a constant force.")
    return res


# ------------------------------------------------------------------------- transport
def _transport_connected(out: Path, plan: Plan, rep: Any, seed: int) -> dict[str, Any]:
    from thermoswarm.report.animate import animate, snapshot_strip
    from thermoswarm.scenarios import transport_connected as T

    runs = [_run("transport-connected", out / "transport-connected" / f"seed{s}", None,
                 seed + s) for s in range(plan.connected_seeds)]  # fmt: skip
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
            {
                "runs": plan.connected_seeds,
                "reached the target": len(reached),
                "time to target, mean (s)": res["time_to_target_mean"],
                "time to target, sd (s)": res["time_to_target_sd"],
            }
        )
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


def _transport_free(out: Path, plan: Plan, rep: Any, seed: int) -> dict[str, Any]:
    import matplotlib.pyplot as plt

    from thermoswarm.report.animate import animate, snapshot_strip
    from thermoswarm.scenarios import transport_free as F

    base = {} if plan.free_duration is None else {"duration": plan.free_duration}
    runs = [
        _run("transport-free", out / "transport-free" / f"seed{s}", base, seed + s)
        for s in range(plan.free_seeds)
    ]
    vdur = {} if plan.variant_duration is None else {"duration": plan.variant_duration}
    variants = {v: _run("transport-free", out / f"transport-free-{v}", {"variant": v, **vdur},
                        seed)
                for v in ("obstacle", "zigzag")}  # fmt: skip
    m, tracks, info = runs[0]
    times = [mm["time_to_target"] for mm, _, _ in runs]
    reached = [t for t in times if t is not None]
    phase = [mm["phase_by_region_mean"] for mm, _, _ in runs]

    def mean_of(key: str) -> float | None:
        v = [p[key] for p in phase if p.get(key) is not None]
        return _num(float(np.mean(v))) if v else None

    res = {
        "default": {
            "seeds": len(runs),
            "duration_s": m["duration"],
            "target_distance_mm": m["target_distance"],
            "reached": len(reached),
            "time_to_target": times,
            "time_to_target_median": _num(float(np.median(reached))) if reached else None,
            "time_to_target_min": _num(min(reached)) if reached else None,
            "time_to_target_max": _num(max(reached)) if reached else None,
            "phase_by_region_mean": {k: mean_of(k) for k in (
                "hot_fraction_lit", "hot_fraction_shadow", "density_hot_shadow",
                "density_cold_lit")},
        },
        **{v: {"duration_s": mm["duration"],
               "target_distance_mm": mm["target_distance"],
               "max_displacement_toward_target": _num(mm["max_displacement_toward_target"]),
               "time_to_target": mm["time_to_target"]} for v, (mm, _, _) in variants.items()},
    }  # fmt: skip
    with rep.section("Transport without connection (Algorithm 5)"):
        rep.paragraph(
            "1,200 robots around the 100 mm object in the centre of an 1800 mm arena, light "
            "from the target side (top); the object's shadow darkens the strip behind it and "
            "each robot's temperature switches with the light it sees: red robots are hot "
            "(gas-like), blue ones cold (liquid-like). Defaults found by the drift-speed "
            "search (below): the paper's equation (lit robots cold), hot robots 22 mm/s mean "
            "and keeping their heading, cold robots 18 mm/s and turning fast, speeds cut at "
            "the robot's 33 mm/s. The object must travel 750 mm to the dashed line."
        )
        rep.table(
            [
                {"run": f"seed {seed + s}", "time to target (s)": t,
                 "max displacement (mm)": mm["max_displacement_toward_target"]}
                for s, ((mm, _, _), t) in enumerate(zip(runs, times, strict=True))
            ]
            + [
                {"run": f"variant {v}", "time to target (s)": mm["time_to_target"],
                 "max displacement (mm)": mm["max_displacement_toward_target"]}
                for v, (mm, _, _) in variants.items()
            ],
            caption="Time to the target line (empty: not reached within the run).",
        )  # fmt: skip
        path = animate(
            tracks,
            F.plot_frame,
            info,
            out / "animations" / "transport-free",
            title="transport without connection",
        )
        rep.animation(path, caption="The object carried to the target line (default, seed 0).")
        _fig(
            rep,
            snapshot_strip(tracks, F.plot_frame, info),
            "Snapshots of the default run: "
            "gas-like (red) and liquid-like (blue) robots around the object.",
        )
        fig, ax = plt.subplots(figsize=(6, 3.5))
        for s, (mm, _, _) in enumerate(runs):
            path_ = mm["object_path"]
            ax.plot(path_["time"], path_["progress"], color="tab:green", alpha=0.7,
                    label="free" if s == 0 else None)  # fmt: skip
        for v, (mm, _, _) in variants.items():
            ax.plot(mm["object_path"]["time"], mm["object_path"]["progress"], label=v)
        ax.axhline(m["target_distance"], color="tab:green", ls="--", lw=0.8)
        ax.set_xlabel("time (s)")
        ax.set_ylabel("object displacement toward the light (mm)")
        ax.legend(frameon=False)
        _fig(rep, fig, "Object position over time (toward the light is up; dashed: the "
                       "free arena's target; the zig-zag's target is 1050 mm up).")  # fmt: skip
        _fig(rep, _phase_figure(m),
             "Phase separation (default, seed 0): left, the share of hot robots in the shadow "
             "and in the light; right, the density of each phase in its own region.")  # fmt: skip
        for v, (_, tr, inf) in variants.items():
            _fig(rep, snapshot_strip(tr, F.plot_frame, inf, panels=4), f"Variant {v}.")
    return res


def _regime(out: Path, plan: Plan, rep: Any, workers: int | None) -> dict[str, Any]:
    from thermoswarm.studies.regime import plot_maps, run_regime

    setting = "quick" if plan.study == "quick" else "full"
    maps = ["cold", "hot"] if setting == "quick" else None
    r = run_regime(out / "regime", setting, maps=maps, max_workers=workers, progress=False,
                   figure=False)  # fmt: skip
    with rep.section("Where the object moves fastest: drift-speed maps"):
        rep.paragraph(
            "The object's drift toward the light (mm/s, mean ± se over seeds) over the "
            "parameters Algorithm 5 leaves open, around the default (outlined): the cold "
            "phase's speed and steering temperature, the hot phase's, and more in the full "
            f"setting ({setting} setting here: {len(r.setting['seeds'])} seeds per cell)."
        )
        _fig(rep, plot_maps(r), "Drift speed toward the light (mm/s).")
    rows = r.summary.replace({np.nan: None}).to_dict(orient="records")
    return {"setting": setting, "rows": rows}


def _mechanism(out: Path, plan: Plan, rep: Any, workers: int | None) -> dict[str, Any]:
    from thermoswarm.studies.mechanism import run_mechanism

    r = run_mechanism(out / "mechanism", plan.study, max_workers=workers, progress=False)
    rows = r.summary.replace({np.nan: None}).to_dict(orient="records")
    with rep.section("The transport mechanism, measured"):
        rep.paragraph(
            "The paper's equation and its captions assign hot and cold to light and shadow in "
            "opposite ways (PAPER_NOTES 6.3). Every combination of mapping, heading law and "
            f"sensing, {len(r.setting['seeds'])} seeds each ({plan.study} setting): mean "
            "displacement of the object toward the light with its standard error and 95 % "
            "confidence interval, and the verdict."
        )
        rep.raw("<pre>" + r.table() + "</pre>")
    return {"setting": plan.study, "rows": rows, "default": r.setting["default"]}


def _scaling(out: Path, plan: Plan, rep: Any, workers: int | None) -> dict[str, Any]:
    from thermoswarm.studies.scaling import plot_scaling, run_scaling

    settings = ["quick"] if plan.study == "quick" else ["fixed", "density"]
    results = [run_scaling(out / f"scaling-{s}", s, max_workers=workers, progress=False,
                           figure=False) for s in settings]  # fmt: skip
    with rep.section("Scaling with swarm size (panels u and v)"):
        for r in results:
            rep.raw("<pre>" + r.table() + "</pre>")
        _fig(
            rep,
            plot_scaling(results),
            "(u) Maximum displacement toward the target within the first "
            f"{results[0].setting['horizon']:g} s and (v) time to the target "
            f"({results[0].setting['target_distance']:g} mm above the start) against the "
            "number of robots: medians over seeds with distribution-free 95 % intervals, "
            "dots the runs; a median is drawn only where at least half the runs arrived.",
        )
    rows = [row for r in results for row in r.summary.replace({np.nan: None}).to_dict("records")]
    return {"setting": settings, "rows": rows}


# ------------------------------------------------------------------ one law, three systems
def _unified(out: Path, plan: Plan, rep: Any, seed: int) -> dict[str, Any]:
    import matplotlib.pyplot as plt
    import xarray as xr

    from thermoswarm.analysis.figures import plot_density_fit
    from thermoswarm.analysis.study import run_study
    from thermoswarm.tracking.synth import SynthConfig, generate

    ants = generate(SynthConfig(n_frames=600), np.random.default_rng(seed)).tracks
    work = out / "unified"
    gas_m, _, _ = _run("box", work / "gas", {"mode": "inertial", "n": 300,
                                            "packing_fraction": 0.1, "duration": 400.0,
                                            "engine": {"dt": 0.05},
                                            "record": {"interval": 0.05}}, seed)  # fmt: skip
    gas = xr.open_dataset(work / "gas" / "tracks.nc").load()
    _run("transport-free", work / "robots",
                       {"n": plan.unified_robots, "duration": plan.unified_duration,
                        "record": {"interval": 0.1}}, seed)  # fmt: skip
    robots = xr.open_dataset(work / "robots" / "tracks.nc").load()
    systems = [
        ("ants", "ants (synthetic, the paper's two-phase model)", ants),
        ("gas", "elastic gas (physical particles)", gas),
        ("robots", "robots, Algorithm 5 (temperature switched by light)", robots),
    ]
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    res: dict[str, Any] = {}
    for ax, (key, label, ds) in zip(axes, systems, strict=True):
        study = run_study(ds, seed=seed)
        kin = study.kinematics
        e = kin["energy"].values[kin["valid"].values.astype(bool)]
        e = e[np.isfinite(e) & (e > 0)]
        plot_density_fit(ax, study.energy, e)
        ax.set_xlabel("energy v^2/2 (mm^2/s^2)")
        ax.set_title(label, fontsize=9)
        ax.legend(fontsize=7)
        en = study.fits["energy"]
        res[key] = {
            "preferred": en["preferred"],
            "lr_p_value": _num(en["lr_p_value"], 4),
            "one_phase_kT": _num(en["one_phase"]["kT"]),
            "two_phase": {k: _num(en["two_phase"][k]) for k in ("phi", "kT1", "kT2")},
            "ks_p_value_preferred": _num(en[en["preferred"]]["p_value"], 4),
        }
    res["gas"]["mean_energy_per_particle"] = _num(gas_m["energy_final"] / 300)
    from thermoswarm.scenarios.transport_free import TransportFreeParams

    defaults = TransportFreeParams()
    res["robots"]["kT_hot"] = _num(defaults.kT_hot)
    res["robots"]["kT_cold"] = _num(defaults.kT_cold)
    with rep.section("One law, three systems"):
        rep.paragraph(
            "The paper's thesis in one panel: the same analysis (thermoswarm analyze) reads "
            "trajectories of ants, of particles and of robots. Ants: two exponential phases "
            "(liquid and gas); the elastic gas: one exponential at its mean energy "
            "(Maxwell-Boltzmann); robots of Algorithm 5: two phases, the hot and the cold "
            "temperature their light switches between. Lines: maximum-likelihood fits (dashed: "
            "one phase, solid: two phases)."
        )
        _fig(rep, fig, "Energy distributions (log density) with one- and two-phase fits.")
        rep.table({k: f"{v['preferred']} (LR p = {v['lr_p_value']})" for k, v in res.items()})
    return res


# --------------------------------------------------------------------------- driver
def reproduce(
    out: str | Path,
    *,
    quick: bool = True,
    seed: int = 0,
    workers: int | None = None,
    verbose: bool = True,
) -> dict[str, Any]:
    """Run every experiment into ``out`` and write the report; returns ``results.json``.

    Finished runs in ``out`` are reused (a rerun after an interruption continues).
    """
    from thermoswarm.report.html import HtmlReport

    out = prepare_output_dir(out)
    for sub in ("animations", "unified", "compression", "transport-connected", "transport-free"):
        (out / sub).mkdir(exist_ok=True)
    plan = QUICK if quick else FULL
    log = _Log(verbose)
    rep = HtmlReport(
        "thermoswarm: the paper's robot experiments",
        subtitle=f"thermoswarm {__version__}, {plan.name} setting, seed {seed}",
    )
    rep.paragraph(
        "Ants, physical particles and robot swarms move by one maximum-entropy law, "
        "p(x) = exp(-x / kT) / kT (Yin, Yu, Spino, Rus, arXiv 2511.05785). Every experiment "
        "below was run by `thermoswarm reproduce`; results.json holds the numbers."
    )
    results: dict[str, Any] = {"version": __version__, "setting": plan.name, "seed": seed}
    steps: list[tuple[str, Callable[[], dict[str, Any]]]] = [
        ("unified_law", lambda: _unified(out, plan, rep, seed)),
        ("narrow_road", lambda: _narrow_road(out, plan, rep, seed)),
        ("compression", lambda: _compression(out, plan, rep, seed)),
        ("transport_connected", lambda: _transport_connected(out, plan, rep, seed)),
        ("transport_free", lambda: _transport_free(out, plan, rep, seed)),
        ("regime", lambda: _regime(out, plan, rep, workers)),
        ("mechanism", lambda: _mechanism(out, plan, rep, workers)),
        ("scaling", lambda: _scaling(out, plan, rep, workers)),
    ]
    for name, fn in steps:
        done = log.step(name)
        results[name] = fn()
        done()
    results["seconds"] = log.times
    with rep.section("Run"):
        rep.table({k: f"{v:.0f} s" for k, v in log.times.items()})
    rep.write(out / "report.html")
    atomic_write_json(out / "results.json", results)
    if verbose:
        print(
            f"wrote {out / 'report.html'} and {out / 'results.json'} "
            f"in {time.perf_counter() - log.t0:.0f} s",
            flush=True,
        )
    return results
