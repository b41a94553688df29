"""One law, three systems: synthetic ants, an elastic gas and light-switched robots,
each analysed by the same study."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.reproduce.plans import Plan
from thermoswarm.reproduce.runs import _run
from thermoswarm.reproduce.text import _fig, _num


def _unified(out: Path, plan: Plan, rep: Any, seed: int, bars: bool | None = False
             ) -> dict[str, Any]:  # fmt: skip
    import matplotlib.pyplot as plt
    import xarray as xr

    from thermoswarm.analysis.study import run_study
    from thermoswarm.maxent import kT_for_mean_speed
    from thermoswarm.report.analysis_figures import plot_density_fit
    from thermoswarm.tracking.synth import SynthConfig, generate

    ants = generate(SynthConfig(n_frames=plan.ant_frames), np.random.default_rng(seed)).tracks
    work = out / "unified"
    gas_m, _, _ = _run("box", work / "gas", {"mode": "inertial", "n": 300,
                                            "packing_fraction": 0.1,
                                            "duration": plan.gas_duration,
                                            "engine": {"dt": 0.05},
                                            "record": {"interval": 0.05}}, seed, bars)  # fmt: skip
    gas = xr.open_dataset(work / "gas" / "tracks.nc").load()
    # The scenario's defaults (hot 22, cold 18 mm/s mean, speeds cut at 33 mm/s) move the
    # object fastest, but their two speed laws are close and the cut truncates both, so
    # the energy histogram would hardly show two phases.  This panel is about the law
    # itself: two well-separated temperatures (15 and 3 mm/s mean) and no cut, so each
    # phase is an exact exponential in energy.
    robot_kT = {"kT_hot": round(kT_for_mean_speed(15.0), 3),
                "kT_cold": round(kT_for_mean_speed(3.0), 3)}  # fmt: skip
    _run("transport-free", work / "robots",
         {"n": plan.unified_robots, "duration": plan.unified_duration, **robot_kT,
          "v_max": None, "record": {"interval": 0.1}}, seed, bars)  # fmt: skip
    robots = xr.open_dataset(work / "robots" / "tracks.nc").load()
    systems = [
        ("ants", "ants (synthetic, the paper's two-phase model)", ants),
        ("gas", "elastic gas (physical particles)", gas),
        ("robots", "robots, Algorithm 5 (temperature switched by light)", robots),
    ]
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    res: dict[str, Any] = {}
    for ax, (key, label, ds) in zip(axes, systems, strict=True):
        study = run_study(ds, seed=seed, n_bootstrap=plan.n_bootstrap)
        kin = study.kinematics
        e = kin["energy"].values[kin["valid"].values.astype(bool)]
        e = e[np.isfinite(e) & (e > 0)]
        en = study.fits["energy"]
        # only the model the analysis kept: a rejected (or degenerate) fit is not drawn
        kept = study.energy.two if en["preferred"] == "two_phase" else study.energy.one
        plot_density_fit(ax, kept, e)
        ax.set_xlabel("energy v^2/2 (mm^2/s^2)")
        ax.set_ylabel("probability density")
        ax.set_title(label, fontsize=9)
        ax.legend(fontsize=7)
        res[key] = {
            "preferred": en["preferred"],
            "lr_p_value": _num(en["lr_p_value"], 4),
            "one_phase_kT": _num(en["one_phase"]["kT"]),
            "two_phase": {k: _num(en["two_phase"][k]) for k in ("phi", "kT1", "kT2")},
            "ks_p_value_preferred": _num(en[en["preferred"]]["p_value"], 4),
            "n_bootstrap": plan.n_bootstrap,
        }
    res["gas"]["mean_energy_per_particle"] = _num(gas_m["energy_final"] / 300)
    res["robots"]["kT_hot"] = _num(robot_kT["kT_hot"])
    res["robots"]["kT_cold"] = _num(robot_kT["kT_cold"])
    with rep.section("One law, three systems"):
        rep.paragraph(
            "The paper's thesis in one panel: the same analysis (thermoswarm analyze) reads "
            "trajectories of ants, of particles and of robots. Ants: two exponential phases "
            "(liquid and gas); the elastic gas: one exponential at its mean energy "
            "(Maxwell-Boltzmann); robots of Algorithm 5: two phases, the hot and the cold "
            "temperature their light switches between (here 15 and 3 mm/s mean, no speed "
            "cut: the transport's defaults are closer and cut, see below). Line: the "
            "maximum-likelihood fit of "
            "the model the analysis prefers (bootstrap likelihood-ratio test of one against "
            "two phases at the 5 % level); the other model is not drawn. The ant row is "
            "synthetic, the control of the analysis: no real ant trajectories whose licence "
            "allows shipping them have been found (licences checked in docs/real_data.md, "
            "which also fits real ants, locusts and flies with thermoswarm analyze)."
        )
        _fig(rep, fig, "Energy distributions (log density) with the preferred fit.")
        floor = 1 / (plan.n_bootstrap + 1)
        rep.table(
            [{"system": k, "preferred": v["preferred"].replace("_", " "),
              "LR p-value": (f"< {floor:.2g} (the bootstrap's floor)"
                             if v["lr_p_value"] is not None and v["lr_p_value"] <= 1.02 * floor
                             else v["lr_p_value"]),
              "one phase: kT (mm^2/s^2)": v["one_phase_kT"],
              "two phases: phi": v["two_phase"]["phi"],
              "kT1 (mm^2/s^2)": v["two_phase"]["kT1"], "kT2 (mm^2/s^2)": v["two_phase"]["kT2"],
              "KS p-value of the preferred fit": (
                  f"< {floor:.2g} (the bootstrap's floor)"
                  if v["ks_p_value_preferred"] is not None
                  and v["ks_p_value_preferred"] <= 1.02 * floor
                  else v["ks_p_value_preferred"])}
             for k, v in res.items()],
            caption=f"Fits ({plan.n_bootstrap} bootstrap replicates per test)",
        )  # fmt: skip
    return res
