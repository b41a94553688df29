"""One law, three systems: real ants (with synthetic ants as the control of the
analysis), an elastic gas and light-switched robots, each analysed by the same study.

The real ants are an excerpt of anTraX's JS16 demo (16 tagged *Ooceraea biroi*,
``tests/data/antrax_js16/``, GPL-3.0).  anTraX gives every ant of a multi-ant blob the
blob's position, so two or more ants at exactly the same point in one frame are not
measured individually: those samples are made missing (and counted) before the study,
and no step is computed into or out of them.  Static ants' zero-length steps are left
out by the study's resting rule, also counted.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.analysis.recording import mask_shared_positions
from thermoswarm.reproduce.plans import Plan
from thermoswarm.reproduce.runs import _run
from thermoswarm.reproduce.text import _fig, _num

__all__ = ["ANTRAX_JS16", "REAL_ANTS_COMMAND", "mask_shared_positions", "real_ants", "rest_jitter"]

#: The real ant excerpt: in a source checkout only (tests/data is not package data).
ANTRAX_JS16 = (
    Path(__file__).resolve().parents[3] / "tests" / "data" / "antrax_js16" / "js16_xy_1_1_mm.csv"
)
#: The systems' names in the fits table.
_SYSTEM_NAMES = {"ants_real": "ants, real (anTraX JS16)", "ants": "ants, synthetic (control)"}
#: The ``analyze`` command that gives the real-ant row's numbers (``{path}``, ``{seed}``,
#: ``{n_bootstrap}`` filled in; OUT is any new directory).
REAL_ANTS_COMMAND = ("thermoswarm analyze {path} --mask-shared-positions --seed {seed} "
                     "--bootstrap {n_bootstrap} --out OUT")  # fmt: skip
#: The ``analyze`` command of a simulated (or synthetic) system's row.
SYSTEM_COMMAND = "thermoswarm analyze {path} --seed {seed} --bootstrap {n_bootstrap} --out OUT"
#: The excerpt's pixel (mm): anTraX's scale tool, a 65 mm arena drawn 704 px across
#: (tests/data/antrax_js16/README.md); positions are blob centroids, finer than a pixel.
ANTRAX_PIXEL_MM = 65.0 / 704
#: The resting rule of :func:`rest_jitter`: an ant is at rest over a window of
#: ``REST_WINDOW_S`` seconds when all its positions in it lie within a box whose
#: diagonal is under ``REST_EXTENT_MM`` (about 5 pixels, a fifth of an O. biroi's
#: 2.5 mm body): it may jitter, it does not walk.
REST_WINDOW_S, REST_EXTENT_MM = 1.0, 0.5
#: Where the excerpt comes from (tests/data/antrax_js16/README.md has the details).
ANTRAX_SOURCE = (
    "anTraX-data (github.com/Social-Evolution-and-Behavior/anTraX-data, commit 37ed5e9a, "
    "GPL-3.0), JS16/antrax_demo/antdata/xy_1_1.csv: 16 tagged Ooceraea biroi tracked by "
    "anTraX, first 2,400 frames (240 s at 10 frames/s), in mm"
)


def rest_jitter(
    ds: Any, *, window_s: float = REST_WINDOW_S, extent_mm: float = REST_EXTENT_MM
) -> dict[str, Any]:
    """The speed of positions of individuals at rest: the tracking's jitter, measured.

    Parameters
    ----------
    ds : xarray.Dataset
        Trajectories in mm with ``attrs["fps"]`` (frames/s); shared positions already
        masked (missing samples break a window).
    window_s, extent_mm
        The resting rule: every position of a window of ``window_s`` seconds within a
        box of diagonal below ``extent_mm`` (mm); each step inside such a window is a
        step at rest.

    Returns
    -------
    dict
        ``speed_mm_s``: the mean speed (mm/s) of the nonzero steps at rest (zero steps
        are left out, as the fit leaves them out), ``None`` when there are none;
        ``n_steps`` (steps at rest, nonzero), ``n_individuals`` (with any),
        ``window_s``, ``extent_mm`` and ``pixel_speed_mm_s`` (one pixel a frame).
    """
    fps = float(ds.attrs["fps"])
    w = max(1, round(window_s * fps))  # steps in a window
    xy = ds["position"].transpose("time", "space", "keypoints", "individuals").values[:, :2, 0, :]
    speeds, who = [], 0
    for i in range(xy.shape[2]):
        p = xy[:, :, i]
        if p.shape[0] <= w:
            continue
        win = np.lib.stride_tricks.sliding_window_view(p, w + 1, axis=0)  # (T-w, 2, w+1)
        with np.errstate(invalid="ignore"):
            ext = np.hypot(*(win.max(axis=2) - win.min(axis=2)).T)
        rest = np.isfinite(win).all(axis=(1, 2)) & (ext < extent_mm)
        # step j (frames j to j+1) is at rest when a resting window starts in [j-w+1, j]
        at_rest = np.convolve(rest.astype(int), np.ones(w, dtype=int))[: p.shape[0] - 1] > 0
        step = np.hypot(*np.diff(p, axis=0).T) * fps
        v = step[at_rest & np.isfinite(step) & (step > 0)]
        who += bool(v.size)
        speeds.append(v)
    v = np.concatenate(speeds) if speeds else np.array([])
    return {"speed_mm_s": float(v.mean()) if v.size else None, "n_steps": int(v.size),
            "n_individuals": who, "window_s": float(window_s), "extent_mm": float(extent_mm),
            "pixel_speed_mm_s": ANTRAX_PIXEL_MM * fps}  # fmt: skip


def real_ants(path: Path = ANTRAX_JS16, *, seed: int = 0, n_bootstrap: int = 200
              ) -> tuple[Any, dict[str, Any]]:  # fmt: skip
    """Read the real ant excerpt, mask blob-shared positions, run the study.

    Parameters
    ----------
    path
        The wide CSV (mm, 10 frames/s in its header).
    seed, n_bootstrap
        As :func:`thermoswarm.analysis.study.run_study`.

    Returns
    -------
    study : StudyResult
        The study of the masked trajectories.
    counts : dict
        ``samples``: ``total`` (frames x ants), ``missing`` (no position in the source),
        ``cluster_shared`` (masked here), ``single`` (the rest, measured individually);
        ``steps``: the study's step buckets (they sum to ``total``), and the resting and
        implausible steps it left out; ``jitter``: :func:`rest_jitter` of the masked
        trajectories (the speed of ants at rest, to tell standing from walking).
    """
    from thermoswarm.analysis.kinematics import data_quality
    from thermoswarm.analysis.study import run_study
    from thermoswarm.io import read_tracks

    ds = read_tracks(path)
    jitter = rest_jitter(mask_shared_positions(ds)[0])
    xy = ds["position"].values[:, :2, 0, :]
    total = int(xy.shape[0] * xy.shape[2])
    missing = int((~np.isfinite(xy).all(axis=1)).sum())
    # the analysis's own option (``analyze --mask-shared-positions``), not a step of ours
    study = run_study(ds, seed=seed, n_bootstrap=n_bootstrap, mask_shared_positions=True)
    n_shared = int(study.fits["data_quality"]["n_shared_positions_masked"])
    dq = data_quality(study.kinematics)
    ex = study.fits["excluded"]
    rel = path.relative_to(ANTRAX_JS16.parents[3]) if path.is_relative_to(
        ANTRAX_JS16.parents[3]) else path  # fmt: skip
    counts = {
        "command": REAL_ANTS_COMMAND.format(path=rel, seed=seed, n_bootstrap=n_bootstrap),
        "fps": float(ds.attrs["fps"]),
        "n_individuals": int(xy.shape[2]),
        "n_frames": int(xy.shape[0]),
        "samples": {"total": total, "missing": missing, "cluster_shared": n_shared,
                    "single": total - missing - n_shared},
        "steps": {"total": dq["n_steps_total"], **dq["step_buckets"],
                  "resting_left_out": ex["resting"]["n"],
                  "implausible_left_out": ex["implausible"]["n"]},
        "jitter": jitter,
    }  # fmt: skip
    if jitter.get("speed_mm_s"):
        counts["walking"] = _walking_fit(ds, jitter["speed_mm_s"], seed, n_bootstrap)
    return study, counts


def _walking_fit(ds: Any, jitter: float, seed: int, n_bootstrap: int) -> dict[str, Any]:
    """The study of the walking steps alone: every step at or below twice the jitter of
    ants at rest (mm/s, two significant digits, as the row's walking command prints it)
    left out as resting; the fit's numbers as :func:`_fit_summary` gives them."""
    from thermoswarm.analysis.study import run_study

    cut = float(f"{2 * jitter:.2g}")
    walk = run_study(ds, seed=seed, n_bootstrap=n_bootstrap, mask_shared_positions=True,
                     resting_speed=cut)  # fmt: skip
    return {"resting_speed_mm_s": cut, "resting_left_out": walk.fits["excluded"]["resting"]["n"],
            **_fit_summary(walk, n_bootstrap)}  # fmt: skip


def _simulate(
    out: Path, plan: Plan, seed: int, bars: bool | None
) -> tuple[list[tuple[str, str, Any]], dict[str, Any], dict[str, float]]:
    """The synthetic ants, the elastic gas and the light-switched robots: ``(key, label,
    tracks)`` per system, the gas's metrics and the robots' two temperatures."""
    from thermoswarm.io import read_tracks, write_tracks
    from thermoswarm.maxent import kT_for_mean_speed
    from thermoswarm.tracking.synth.clip import SynthConfig, generate

    work = out / "unified"
    (work / "ants").mkdir(parents=True, exist_ok=True)
    ants = generate(SynthConfig(n_frames=plan.ant_frames), np.random.default_rng(seed)).tracks
    write_tracks(ants, work / "ants" / "tracks.nc")
    gas_m, _, _ = _run("box", work / "gas", {"mode": "inertial", "n": 300,
                                            "packing_fraction": 0.1,
                                            "duration": plan.gas_duration,
                                            "engine": {"dt": 0.05},
                                            "record": {"interval": 0.05}}, seed, bars)  # fmt: skip
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
    labels = {
        "ants": "ants, synthetic (the paper's two-phase model): the control",
        "gas": "elastic gas (physical particles)",
        "robots": "robots, Algorithm 5 (temperature switched by light)",
    }
    # each system is analysed as read from its file, exactly as `analyze FILE` reads it
    systems = [(k, label, read_tracks(work / k / "tracks.nc")) for k, label in labels.items()]
    return systems, gas_m, robot_kT


def _panel(ax: Any, study: Any, label: str, n_bootstrap: int) -> dict[str, Any]:
    """Draw one system's energy density with the preferred fit; its row of the table."""
    from thermoswarm.report.analysis_figures import plot_density_fit

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
    return {**_fit_summary(study, n_bootstrap), "steering": _steering(study.fits["steering"])}


def _fit_summary(study: Any, n_bootstrap: int) -> dict[str, Any]:
    """A study's energy fits for results.json: the preferred model, the LR and KS
    p-values, the one- and two-phase temperatures (mm^2/s^2) and the tests' sample."""
    en = study.fits["energy"]
    return {
        "preferred": en["preferred"],
        "lr_p_value": _num(en["lr_p_value"], 4),
        "one_phase_kT": _num(en["one_phase"]["kT"]),
        "one_phase_kT_se": _num(en["one_phase"].get("kT_se"), 4),
        "two_phase": {
            k: _num(en["two_phase"].get(k), 4 if k.endswith("_se") else 3)
            for k in ("phi", "kT1", "kT2", "kT1_se", "kT2_se")
        },  # fmt: skip
        # the sample of the tests: steps fitted and the decorrelated test sample
        "n_steps": en.get("n"),
        "n_test": (en.get("test_sample") or {}).get("n"),
        "ks_p_value_preferred": _num(en[en["preferred"]]["p_value"], 4),
        "n_bootstrap": n_bootstrap,
    }


def _steering(st: dict[str, Any]) -> dict[str, Any]:
    """The steering-rate law per bin and the temperature's trend, for the paper's rows."""
    tr = st.get("trend") or {}
    bins = [b for b in st.get("bins", []) if b.get("p_value") is not None]
    return {
        "by": st.get("by"),
        "bins": len(bins),
        "bins_exponential": sum(1 for b in bins if b["p_value"] > 0.05),
        "slope": _num(tr.get("slope"), 6),
        "p_value": _num(tr.get("p_value"), 4),
        "spearman_rho": _num(tr.get("spearman_rho"), 3),
        "slope_se": _num(tr.get("slope_se"), 6),
        "k": tr.get("k"),
        "bin_n": [b.get("n") for b in bins],
        "direction": tr.get("direction"),
    }


def _unified(out: Path, plan: Plan, rep: Any, seed: int, bars: bool | None = False
             ) -> dict[str, Any]:  # fmt: skip
    import matplotlib.pyplot as plt

    from thermoswarm.analysis.study import run_study

    systems, gas_m, robot_kT = _simulate(out, plan, seed, bars)
    real = None
    if ANTRAX_JS16.is_file():  # a source checkout: the excerpt is test data, not packaged
        real = real_ants(ANTRAX_JS16, seed=seed, n_bootstrap=plan.n_bootstrap)
        systems.insert(0, ("ants_real", "ants, real (anTraX JS16, 16 O. biroi, 240 s)", None))
    fig, axes = plt.subplots(2, 2, figsize=(12, 8), layout="constrained")
    res: dict[str, Any] = {}
    for ax, (key, label, ds) in zip(axes.flat, systems, strict=False):
        study = real[0] if key == "ants_real" else run_study(
            ds, seed=seed, n_bootstrap=plan.n_bootstrap)  # fmt: skip
        res[key] = _panel(ax, study, label, plan.n_bootstrap)
        if key != "ants_real":
            res[key]["command"] = SYSTEM_COMMAND.format(
                path=out / "unified" / key / "tracks.nc", seed=seed, n_bootstrap=plan.n_bootstrap
            )
    if real is not None:
        res["ants_real"].update(source=ANTRAX_SOURCE, **real[1])
    else:
        axes.flat[-1].set_axis_off()
    res["gas"]["mean_energy_per_particle"] = _num(gas_m["energy_final"] / 300)
    res["robots"]["kT_hot"] = _num(robot_kT["kT_hot"])
    res["robots"]["kT_cold"] = _num(robot_kT["kT_cold"])
    _section(rep, plan, fig, res, real)
    return res


def _p_cell(p: float | None, floor: float) -> Any:
    return f"< {floor:.2g} (the bootstrap's floor)" if p is not None and p <= 1.02 * floor else p


def _section(rep: Any, plan: Plan, fig: Any, res: dict[str, Any], real: Any) -> None:
    """The report's section "One law, three systems"."""
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
            "two phases at the 5 % level); the other model is not drawn. Two ant rows: real "
            "ants (16 tagged Ooceraea biroi tracked by anTraX, an excerpt of its GPL-3.0 "
            "JS16 demo shipped in tests/data/antrax_js16) and synthetic ants drawn from "
            "the paper's model, the control of the analysis. In the real colony most "
            "samples are of ants inside a cluster, where anTraX gives every ant the "
            "cluster's position: those samples are left out (no step into or out of "
            "them), and so are the zero-length steps of resting ants; the counts are "
            "below. Verdict rule for both ant rows (paper comparison): two phases "
            "preferred and the two-phase fit not rejected by its KS test (p > 0.05). "
            "The simulated systems' energies are their recorded speeds (analyze's default "
            "for a thermoswarm recording: the robots' commanded speeds, the particles' "
            "instantaneous ones; --speed-source)."
        )
        _fig(rep, fig, "Energy distributions (log density) with the preferred fit.")
        floor = 1 / (plan.n_bootstrap + 1)
        rep.table(
            [{"system": _SYSTEM_NAMES.get(k, k), "preferred": v["preferred"].replace("_", " "),
              "LR p-value": _p_cell(v["lr_p_value"], floor),
              "one phase: kT (mm^2/s^2)": v["one_phase_kT"],
              "two phases: phi": v["two_phase"]["phi"],
              "kT1 (mm^2/s^2)": v["two_phase"]["kT1"], "kT2 (mm^2/s^2)": v["two_phase"]["kT2"],
              "KS p-value of the preferred fit": _p_cell(v["ks_p_value_preferred"], floor)}
             for k, v in res.items()],
            caption=f"Fits ({plan.n_bootstrap} bootstrap replicates per test)",
        )  # fmt: skip
        if real is not None:
            rep.paragraph(f"The real-ant row from the command line: {real[1]['command']} "
                          "(OUT/fits.json holds the same numbers).")  # fmt: skip
            rep.table(_real_counts(real[1]), header=("real ants", "count"), caption=(
                "Real ants: what the fit uses and what it leaves out (samples = frames x "
                "ants; steps between consecutive frames of one ant)"))  # fmt: skip
        else:
            rep.paragraph("Real ants: not measured (tests/data/antrax_js16 is in the source "
                          "checkout only, not in the installed package).", note=True)  # fmt: skip


def _real_counts(c: dict[str, Any]) -> dict[str, int]:
    """The real ants' sample and step counts, for the report (each block adds up)."""
    sm, st = c["samples"], c["steps"]
    other = st["total"] - st["used"] - st["resting"] - st["implausible"] - st["missing_position"]
    return {
        "samples (frames x ants)": sm["total"],
        "... measured individually": sm["single"],
        "... in a cluster (position shared with another ant), left out": sm["cluster_shared"],
        "... no position in the source": sm["missing"],
        "steps (consecutive frames of one ant)": st["total"],
        "... fitted": st["used"],
        "... an end in a cluster or missing": st["missing_position"],
        "... resting (zero length), left out": st["resting"],
        "... implausibly fast, left out": st["implausible"],
        "... other exclusions (gaps, static tracks, speed cut)": other,
    }
