"""Figures in the manner of the paper's panels, and the analysis report (``report.html``).

They draw what the fits expose (:meth:`~thermoswarm.analysis.fit.ExponentialFit.density_curves`)
and what the study computed; nothing in :mod:`thermoswarm.analysis` imports this module.

Every function draws on :class:`matplotlib.figure.Figure` objects (no pyplot, no
display: the Agg canvas renders them), so it runs headless and leaves no global state.

- :func:`energy_figure`: the energy density on a log scale with the one- and two-phase
  fits, and the survival function (paper figure 3a-h, and Fig. 1e).
- :func:`groups_figure`: one density panel per group, the fitted two-phase densities
  overlaid ("probability density curve at different energy level"), and the KS
  distances of the one- and two-phase fits per group (panel j).
- :func:`steering_figure`: ``|steering rate|`` per energy bin with exponential fits
  (figure 4a-h) and ``kT_theta`` against energy with the fitted trend (4i).
- :func:`regions_figure`: the regions with step midpoints coloured by the posterior
  probability of the hot phase, and the hot-phase fraction per region (panel i).
- :func:`build_report`: the self-contained ``report.html``.

The figures are drawn in :mod:`thermoswarm.report._analysis_plots` (re-exported here);
this module builds the report from them.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from thermoswarm.analysis.explain import explain_phases, format_p_value, trend_statement
from thermoswarm.analysis.study import StudyResult
from thermoswarm.report._analysis_plots import (
    energy_axis,
    energy_figure,
    fmt_value,
    groups_figure,
    plot_density_fit,
    regions_figure,
    steering_figure,
)

__all__ = [
    "energy_axis",
    "plot_density_fit",
    "energy_figure",
    "groups_figure",
    "steering_figure",
    "regions_figure",
    "build_report",
]

# --------------------------------------------------------------------------------------
# Report


#: What each step bucket of ``data_quality`` means, in the report.
BUCKET_HELP = {
    "missing_position": "an end's position missing (NaN, inf or low confidence)",
    "time_gap": "longer than --gap-factor times the individual's median step",
    "static_track": "the individual never leaves --min-track-extent (a static object)",
    "over_max_speed": "faster than --max-speed",
    "implausible": "faster than the implausible-motion threshold (glitch, identity swap)",
    "resting": "at or below --resting-speed: not moving",
    "stationary_dropped": "in a long stationary period (--drop-stationary)",
    "used": "used in the fits",
}

#: Row labels of the test-sample table.
TEST_SAMPLE_LABELS = {
    "n": "test-sample size n (what each bootstrap test uses)",
    "n_available": "steps available",
    "thinning_step": "thinning step (steps)",
    "max_n": "cap (--test-size)",
    "decorrelation_lag": "decorrelation lag (steps)",
    "tau_int": "integrated autocorrelation time (steps)",
    "note": "note",
}


def _labelled(d: dict[str, Any], labels: dict[str, str]) -> dict[str, Any]:
    return {labels.get(k, k): v for k, v in d.items()}


def _data_quality_rows(dq: dict[str, Any]) -> list[dict[str, Any]]:
    total = dq.get("n_steps_total") or 0
    return [
        {
            "bucket": name,
            "steps": n,
            "fraction": (n / total) if total else None,
            "meaning": BUCKET_HELP.get(name, ""),
        }
        for name, n in dq.get("step_buckets", {}).items()
    ] + [{"bucket": "total", "steps": total, "fraction": 1.0 if total else None, "meaning": ""}]


def _fit_rows(block: dict[str, Any]) -> list[dict[str, Any]]:
    one, two = block["one_phase"], block["two_phase"]
    nb = block.get("n_bootstrap")
    return [
        {
            "model": "one phase",
            "parameters": f"kT = {one['kT']:.5g} \u00b1 {one['kT_se']:.2g}",
            "ks (test)": one["ks"],
            "p (bootstrap)": format_p_value(one["p_value"], nb),
            "n (test)": one["n"],
            "ks (all, naive)": one["naive"]["ks"],
            "p (naive)": one["naive"]["p_value"],
            "BIC": one["bic"],
        },
        {
            "model": "two phases",
            "parameters": (
                f"phi = {two['phi']:.4g} \u00b1 {two['phi_se']:.2g}, "
                f"kT1 = {two['kT1']:.5g} \u00b1 {two['kT1_se']:.2g}, "
                f"kT2 = {two['kT2']:.5g} \u00b1 {two['kT2_se']:.2g}"
            ),
            "ks (test)": two["ks"],
            "p (bootstrap)": format_p_value(two["p_value"], nb),
            "n (test)": two["n"],
            "ks (all, naive)": two["naive"]["ks"],
            "p (naive)": two["naive"]["p_value"],
            "BIC": two["bic"],
        },
    ]


def build_report(result: StudyResult) -> str:
    """The self-contained HTML report of a study, one function per section."""
    from thermoswarm.report.html import HtmlReport

    fits = result.fits
    kin = result.kinematics
    unit = fits["units"]["energy"]
    energy = kin["energy"].values
    valid = kin["valid"].values & np.isfinite(energy)
    src = fits.get("source_file") or "trajectories"
    rep = HtmlReport("thermoswarm analysis", subtitle=str(src))
    _summary_section(rep, fits)
    _data_quality_section(rep, fits["data_quality"])
    if fits.get("excluded", {}):
        _excluded_section(rep, fits["excluded"])
    if fits.get("plausibility", {}).get("temperatures"):
        _plausibility_section(rep, fits["plausibility"])
    _energy_section(rep, result, energy[valid], unit)
    for spec, g in fits["groups"].items():
        _groups_section(rep, result, spec, g, energy, valid, unit)
    _steering_section(rep, result, unit)
    if fits["regions"]:
        _regions_section(rep, result)
    with rep.section("Settings"):
        rep.table(fits["settings"], header=("setting", "value"))
    return rep.render()


def _summary_section(rep: Any, fits: dict[str, Any]) -> None:
    """Counts, the preferred energy model and why, plausibility and the steering trend."""
    e = fits["energy"]
    excluded = fits.get("excluded", {})
    plaus = fits.get("plausibility", {})
    with rep.section("Summary"):
        summary = {
            "tracks with data": fits["n_tracks"],
            "energy samples (steps used)": fits["n_samples"],
            "energy unit": fits["units"]["energy"],
            "left out of the fits": excluded.get("statement"),
        }
        if "one_phase" in e:
            summary.update(
                {
                    "preferred model": e["preferred"],
                    "decided by": e["preferred_by"],
                    "LR test p-value (bootstrap)": format_p_value(
                        e["lr_p_value"], e.get("n_bootstrap")
                    ),
                    "LR test n": e["lr_n"],
                    "BIC prefers": e["bic_preferred"],
                }
            )
            why = explain_phases(e)
            if why:
                summary["why two phases"] = why
        if plaus.get("temperatures"):
            summary["temperatures plausible"] = (
                "yes"
                if plaus.get("all_plausible")
                else plaus.get("warning", "not checked (no bound)")
            )
        tr = fits["steering"].get("trend", {})
        summary["kT_theta against energy"] = trend_statement(tr)
        rep.table(summary)
        if plaus.get("warning"):
            rep.paragraph(f"Warning: {plaus['warning']}.")
        rep.paragraph(
            "p-values: 'bootstrap' p-values are parametric-bootstrap p-values valid for "
            "fitted parameters, computed on the test sample (thinned by the "
            "autocorrelation time, capped in size; its n is given); '< x' means no "
            "bootstrap replicate reached the observed statistic (x = 1/(B+1)). 'naive' "
            "p-values treat the fitted law as known and all steps as independent, as the "
            "paper does; they are shown for comparison only.",
            note=True,
        )


def _data_quality_section(rep: Any, dq: dict[str, Any]) -> None:
    """The step buckets (summing to the total) and the other counters."""
    with rep.section("Data quality"):
        rep.table(
            _data_quality_rows(dq),
            caption="every step in exactly one bucket; the buckets sum to the total",
        )
        rep.table(
            {k: v for k, v in dq.items() if k != "step_buckets" and not k.startswith("n_steps_")},
            header=("counter (docs/analysis.md)", "value"),
            caption="counters of the samples and of what was handled",
        )


def _excluded_section(rep: Any, excluded: dict[str, Any]) -> None:
    """The implausible-motion rule, the worst steps and the resting steps left out."""
    with rep.section("Left out of the fits"):
        imp, rest = excluded["implausible"], excluded["resting"]
        rep.paragraph(excluded["statement"] + ".")
        rule = {
            k: v
            for k, v in imp.items()
            if k not in ("worst", "individuals_all_implausible", "n", "excluded")
        }
        rep.table(rule, header=("implausible-motion rule", "value"))
        if imp.get("worst"):
            rep.table(imp["worst"], caption="the fastest implausible steps")
        if imp.get("individuals_all_implausible"):
            rep.paragraph(
                "Individuals whose every moving step is implausible (left out "
                "entirely): " + ", ".join(imp["individuals_all_implausible"])
            )
        rep.table(rest, header=("resting", "value"))


def _plausibility_section(rep: Any, plaus: dict[str, Any]) -> None:
    """The speed bound (mm/s) and each fitted temperature against it."""
    with rep.section("Plausibility of the fitted temperatures"):
        rep.paragraph(
            f"Bound: {fmt_value(plaus['bound_mm_s'], '.4g')} mm/s "
            f"({plaus['bound_source']}); {plaus['rule']}."
        )
        rep.table(
            [{"temperature": k, **v} for k, v in plaus["temperatures"].items()],
        )


def _energy_section(rep: Any, result: StudyResult, x: np.ndarray, unit: str) -> None:
    """One phase against two: the fit table, the test sample and the figure of ``x``
    (the valid energies, in ``unit``)."""
    e = result.fits["energy"]
    with rep.section("Energy: one phase or two"):
        if "one_phase" in e:
            rep.table(_fit_rows(e), caption=f"energy unit {unit}")
            rep.table(
                _labelled(e["test_sample"], TEST_SAMPLE_LABELS),
                caption="test sample",
                header=("quantity", "value"),
            )
            if result.energy is not None:
                rep.figure(
                    energy_figure(result.energy, x, unit),
                    caption="Energy density (log scale) and survival function with fits.",
                )
        else:
            rep.paragraph(e.get("skipped", "not fitted"))


def _group_row(lab: str, lv: dict[str, Any]) -> dict[str, Any]:
    """One level's row of a group table: its fits, or why it was skipped."""
    row: dict[str, Any] = {"group": lab, "n": lv["n"], "tracks": lv.get("n_tracks")}
    if "one_phase" not in lv:
        row["note"] = lv.get("skipped")
        return row
    row.update(
        {
            "mean E": lv["mean"],
            "kT (1 phase)": lv["one_phase"]["kT"],
            "phi": lv["two_phase"]["phi"],
            "kT1": lv["two_phase"]["kT1"],
            "kT2": lv["two_phase"]["kT2"],
            "KS 1 (naive)": lv["one_phase"]["naive"]["ks"],
            "KS 2 (naive)": lv["two_phase"]["naive"]["ks"],
            "p 1 (boot)": format_p_value(lv["one_phase"]["p_value"], lv.get("n_bootstrap")),
            "p 2 (boot)": format_p_value(lv["two_phase"]["p_value"], lv.get("n_bootstrap")),
            "LR p": format_p_value(lv["lr_p_value"], lv.get("n_bootstrap")),
            "preferred": lv["preferred"],
        }
    )
    return row


def _groups_section(
    rep: Any,
    result: StudyResult,
    spec: str,
    g: dict[str, Any],
    energy: np.ndarray,
    valid: np.ndarray,
    unit: str,
) -> None:
    """The fits per level of grouping ``spec``, the paired KS test and the figure."""
    with rep.section(f"Groups: {spec}"):
        rep.table([_group_row(lab, lv) for lab, lv in g["levels"].items()])
        kc = g["ks_comparison"]
        rep.paragraph(
            f"Paired t-test of KS (1 phase) vs KS (2 phases) across groups: "
            f"t = {fmt_value(kc['t_statistic'])}, p = {format_p_value(kc['p_value'])}. "
            f"{kc['method']}.",
            note=True,
        )
        gr = result.groups.get(spec)
        if gr and any(v is not None for v in gr["fits"].values()):
            rep.figure(groups_figure(spec, gr, g["levels"], energy, valid, unit))


def _steering_section(rep: Any, result: StudyResult, unit: str) -> None:
    """The steering-angle rate law, its fit per bin, the trend and the figure."""
    fits = result.fits
    st = fits["steering"]
    with rep.section("Steering-angle rate"):
        rep.paragraph(st["law"])
        rows = [
            {
                "bin": b["index"],
                f"{st['by']} range": f"{b['low']:.4g} - {b['high']:.4g}",
                "mean energy": b["energy_center"],
                "mean speed": b["speed_center"],
                "kT_theta (rad/s)": b.get("kT_theta"),
                "SE": b.get("kT_theta_se"),
                "KS (test)": b.get("ks"),
                "p (bootstrap)": format_p_value(b.get("p_value"), fits["settings"]["n_bootstrap"]),
                "n (test)": b.get("n"),
                "KS (naive)": (b.get("naive") or {}).get("ks"),
                "p (naive)": (b.get("naive") or {}).get("p_value"),
                "fraction turning left": b.get("fraction_positive"),
                "sign test p": b.get("sign_p_value"),
            }
            for b in st["bins"]
        ]
        rep.table(rows)
        if st.get("trend"):
            rep.paragraph(trend_statement(st["trend"]))
            rep.table(
                {k: v for k, v in st["trend"].items() if not isinstance(v, dict)},
                caption="kT_theta versus energy",
            )
        if result.steering.get("fits"):
            rep.figure(steering_figure(st, result.steering, result.kinematics, unit))


def _regions_section(rep: Any, result: StudyResult) -> None:
    """The hot-phase fraction per region, their differences and the figure."""
    reg = result.fits["regions"]
    with rep.section("Regions"):
        rows = [{"region": n, **lv} for n, lv in reg["levels"].items()]
        rep.table(rows, caption="hot-phase fraction per region (temperatures fixed)")
        if reg["differences"]:
            rep.table(reg["differences"], caption="differences between regions")
        if "bootstrap" in reg:
            rep.paragraph(
                f"Uncertainty: {reg['bootstrap']['method']}; clusters: "
                f"{reg['bootstrap']['clusters']}.",
                note=True,
            )
        if "high_T_fraction_note" in reg:
            rep.paragraph(reg["high_T_fraction_note"], note=True)
        rep.figure(regions_figure(result))
