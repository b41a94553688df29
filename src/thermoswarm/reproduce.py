"""``thermoswarm reproduce``: every robot experiment of the paper, into one report.

Runs, into ``OUT/``:

1. ``narrow-road`` for the paper's 5,600 s: flows per direction, zero-flow gaps,
   speed and energy per road section;
2. ``compression``: an isotherm (pressure against area with the ideal-gas curve), the
   pressure against temperature at fixed density, and the temperature that holds the
   density fixed as the force varies (the paper's panel w);
3. ``transport-connected``: the object carried into the target room, over seeds;
4. ``transport-free``: the default (the combination the mechanism study found to
   move the object toward the light) and the ``obstacle`` and ``zigzag`` variants;
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
    free_duration: float = 1200.0
    variant_duration: float = 600.0
    study: str = "full"  # mechanism and scaling settings
    unified_robots: int = 1200
    unified_duration: float = 120.0


QUICK = Plan("quick", compression_duration=1600.0, connected_seeds=3, free_seeds=3,
             free_duration=600.0, variant_duration=400.0, study="quick",
             unified_duration=60.0)  # fmt: skip
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


def _transport_free(out: Path, plan: Plan, rep: Any, seed: int) -> dict[str, Any]:
    import matplotlib.pyplot as plt

    from thermoswarm.report.animate import animate, snapshot_strip
    from thermoswarm.scenarios import transport_free as F

    base = {"duration": plan.free_duration}
    runs = [
        _run("transport-free", out / "transport-free" / f"seed{s}", base, seed + s)
        for s in range(plan.free_seeds)
    ]
    disp = np.array([m["displacement_toward_target"] for m, _, _ in runs])
    se = float(disp.std(ddof=1) / math.sqrt(disp.size)) if disp.size > 1 else float("nan")
    variants = {v: _run("transport-free", out / f"transport-free-{v}",
                        {"variant": v, "duration": plan.variant_duration}, seed)
                for v in ("obstacle", "zigzag")}  # fmt: skip
    m, tracks, info = runs[0]
    res = {
        "default": {"seeds": int(disp.size), "duration_s": plan.free_duration,
                    "displacement_toward_target_mean": _num(float(disp.mean())),
                    "displacement_toward_target_se": _num(se),
                    "mean_over_se": _num(float(disp.mean()) / se) if se > 0 else None,
                    "time_to_target": [mm["time_to_target"] for mm, _, _ in runs]},
        **{v: {"duration_s": plan.variant_duration,
               "displacement_toward_target": _num(mm["displacement_toward_target"]),
               "time_to_target": mm["time_to_target"]} for v, (mm, _, _) in variants.items()},
    }  # fmt: skip
    with rep.section("Transport without connection (Algorithm 5)"):
        rep.paragraph(
            "1,200 robots around the 100 mm object in the centre, light from the target side "
            "(top); the object's shadow darkens the area behind it and each robot's "
            "temperature switches with the light it sees: red robots are hot (gas-like), blue "
            "ones cold (liquid-like). The default is the combination that the mechanism "
            "study found to move the object toward the light (lit robots cold, persistent "
            "headings; see below)."
        )
        rep.table(
            {
                f"displacement toward the target over {disp.size} seeds (mm)": (
                    f"{disp.mean():.1f} +- {se:.1f} (mean +- se)"
                ),
                "obstacle variant (mm)": res["obstacle"]["displacement_toward_target"],
                "zig-zag variant (mm)": res["zigzag"]["displacement_toward_target"],
            }
        )
        _fig(
            rep,
            snapshot_strip(tracks, F.plot_frame, info),
            "Snapshots of the default run: "
            "gas-like (red) and liquid-like (blue) robots around the object.",
        )
        fig, ax = plt.subplots(figsize=(6, 3.5))
        for label, (_, tr, _) in [("free", runs[0]), *variants.items()]:
            y = tr["object_position"].sel(space="y")
            ax.plot(tr["time"], y - float(y[0]), label=label)
        ax.set_xlabel("time (s)")
        ax.set_ylabel("object displacement toward the light (mm)")
        ax.legend()
        _fig(rep, fig, "Object position over time (toward the light is up).")
        for v, (_, tr, inf) in variants.items():
            _fig(rep, snapshot_strip(tr, F.plot_frame, inf, panels=4), f"Variant {v}.")
        path = animate(
            tracks,
            F.plot_frame,
            info,
            out / "animations" / "transport-free",
            title="transport without connection",
        )
        rep.animation(path, caption="Transport without connection (default).")
    return res


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

    r = run_scaling(out / "scaling", plan.study, max_workers=workers, progress=False,
                    figure=False)  # fmt: skip
    rows = r.summary.replace({np.nan: None}).to_dict(orient="records")
    with rep.section("Scaling with swarm size (panels u and v)"):
        rep.raw("<pre>" + r.table() + "</pre>")
        _fig(
            rep,
            plot_scaling(r),
            "Maximum displacement toward the target and time to "
            "target against the number of robots (mean and spread over seeds).",
        )
    return {"setting": plan.study, "rows": rows}


# ------------------------------------------------------------------ one law, three systems
def _unified(out: Path, plan: Plan, rep: Any, seed: int) -> dict[str, Any]:
    import matplotlib.pyplot as plt
    import xarray as xr

    from thermoswarm.analysis.study import run_study
    from thermoswarm.report.analysis_figures import plot_density_fit
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
