"""The paper beside our results: what each experiment of the paper shows, what we
measured, and whether it is reproduced.

Each ``compare_<experiment>(res)`` takes the experiment's block of ``results.json``
(plain data) and returns rows ``{"claim", "paper", "ours", "verdict", "why"}``.  The
paper's column quotes the paper (arXiv 2511.05785: its figure, panel and caption
values; the figures themselves are not in its source, so only captions and text can be
quoted); the verdict is computed from our numbers with the rule stated in ``why``.
Verdicts: ``reproduced``, ``partly`` (the direction, not the size or not every part),
``differs`` (with the reason), ``not measured``.

Missing keys (an older or smaller ``results.json``) give ``not measured``, never an
error: a report is written whatever the experiment returned.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

__all__ = ["COMPARISONS", "compare", "fmt", "NOTES_PAGE"]

#: The page of the documentation that settles the paper's contradictions.
NOTES_PAGE = "docs/paper_notes.md"

REPRODUCED, PARTLY, DIFFERS, NOT_MEASURED = "reproduced", "partly", "differs", "not measured"


def fmt(x: Any, nd: int = 3, unit: str = "") -> str:
    """A number for a table cell: ``nd`` significant digits, its unit, or an en dash."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "\u2013"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, int):
        text = f"{x:,}"
    elif abs(float(x)) >= 10**nd:  # 5,600 s, never 5.6e+03 s
        text = f"{float(x):,.0f}"
    else:
        text = format(float(x), f",.{nd}g")
    return f"{text} {unit}".strip()


def _get(d: Any, *keys: str, default: Any = None) -> Any:
    for k in keys:
        if not isinstance(d, Mapping) or k not in d:
            return default
        d = d[k]
    return d


def _row(claim: str, paper: str, ours: str, verdict: str, why: str) -> dict[str, str]:
    return {"claim": claim, "paper": paper, "ours": ours, "verdict": verdict, "why": why}


def _p(p: Any, n_bootstrap: Any = None) -> str:
    """``p = 0.03``, or ``p < 1/(B+1)`` at the resolution of a bootstrap of B replicates."""
    if p is None:
        return "p n/a"
    if n_bootstrap and p <= 1.02 / (n_bootstrap + 1):  # results.json rounds p
        floor = fmt(1 / (n_bootstrap + 1), 2)
        return f"p <= {floor} (the smallest p of {n_bootstrap} bootstrap replicates)"
    return f"p = {fmt(p, 2)}"


# ----------------------------------------------------------------------- one law
def compare_unified_law(res: Mapping[str, Any]) -> list[dict[str, str]]:
    rows = []
    nb = next((s.get("n_bootstrap") for s in res.values() if isinstance(s, Mapping)), None)
    ants = _get(res, "ants") or {}
    pref = ants.get("preferred")
    tp = ants.get("two_phase") or {}
    ok = pref == "two_phase" and (ants.get("ks_p_value_preferred") or 0) > 0.05
    rows.append(
        _row(
            "ants: energy is a two-phase exponential mixture",
            "Fig. 2 (a-h): p(v^2) = phi Exp(kT1) + (1 - phi) Exp(kT2) fits every energy level; "
            "KS 0.024-0.052, p 0.99-1.00",
            f"{pref or 'n/a'} preferred (LR {_p(ants.get('lr_p_value'), nb)}); "
            f"phi = {fmt(tp.get('phi'))}, "
            f"kT1 = {fmt(tp.get('kT1'))}, kT2 = {fmt(tp.get('kT2'))} mm^2/s^2; KS "
            f"{_p(ants.get('ks_p_value_preferred'), nb)}",
            (REPRODUCED if ok else DIFFERS) if pref else NOT_MEASURED,
            "synthetic ants drawn from the paper's two-phase model (no real footage ships), "
            "read back by the same analysis: this checks the analysis, not the biology"
            + ("" if ok or not pref else "; the two-phase fit was not preferred or was rejected"),
        )
    )
    gas = _get(res, "gas") or {}
    pref = gas.get("preferred")
    kt, mean = gas.get("one_phase_kT"), gas.get("mean_energy_per_particle")
    rel = abs(kt / mean - 1) if kt and mean else None
    ok = pref == "one_phase" and rel is not None and rel < 0.1
    rows.append(
        _row(
            "physical particles: one exponential at kT",
            "Discussion table: p(v^2) = exp(-v^2/E)/E with E = kT (the Boltzmann law)",
            f"{pref or 'n/a'} preferred (LR {_p(gas.get('lr_p_value'), nb)}); "
            f"kT = {fmt(kt)} mm^2/s^2 "
            f"against the mean energy per particle {fmt(mean)} mm^2/s^2",
            (REPRODUCED if ok else DIFFERS) if pref else NOT_MEASURED,
            "rule: one phase preferred and kT within 10 % of the mean energy"
            + (
                ""
                if ok or not pref
                else "; a short record of a small gas is correlated across particles, so the "
                "bootstrap p-values are too small (see the analysis docs)"
            ),
        )
    )
    rob = _get(res, "robots") or {}
    pref = rob.get("preferred")
    tp = rob.get("two_phase") or {}
    ks = rob.get("ks_p_value_preferred")
    fits = ks is not None and ks > 0.05
    ok = pref == "two_phase" and fits
    reasons = []
    if pref != "two_phase":
        reasons.append("the test could not tell two phases from one in this sample")
    elif not fits:
        reasons.append(
            f"two phases preferred, but the KS test rejects two exponentials "
            f"({_p(ks, nb)}): collisions and walls reshape the hot phase's speeds"
        )
    hot, kt2 = rob.get("kT_hot"), tp.get("kT2")
    if ok and hot and kt2 and kt2 < hot:
        reasons.append(
            "the fitted hot temperature sits below the set one: robots stalled by "
            "collisions and walls move slower than they command"
        )
    why_robots = "; ".join(reasons) or "two phases, as set"
    rows.append(
        _row(
            "robots of Algorithm 5: two temperatures switched by light",
            "Discussion table: p(v^2) = exp(-v^2/E(x))/E(x), E(x) set by the light; Fig. 5: "
            "gas-like and liquid-like robots",
            f"{pref or 'n/a'} preferred (LR {_p(rob.get('lr_p_value'), nb)}); fitted kT1 = "
            f"{fmt(tp.get('kT1'))}, kT2 = {fmt(tp.get('kT2'))} mm^2/s^2; set "
            f"{fmt(rob.get('kT_cold'))} and {fmt(rob.get('kT_hot'))} mm^2/s^2; KS "
            f"{_p(ks, nb)}",
            (REPRODUCED if ok else PARTLY if pref == "two_phase" else DIFFERS)
            if pref
            else NOT_MEASURED,
            why_robots,
        )
    )
    return rows


# ----------------------------------------------------------------------- road
def compare_narrow_road(res: Mapping[str, Any]) -> list[dict[str, str]]:
    cross = _get(res, "crossings") or {}
    gap = _get(res, "longest_zero_flow_s", "overall")
    dur = _get(res, "duration_s")
    both = bool(cross) and min(cross.get("+x", 0), cross.get("-x", 0)) > 0
    ok = both and gap is not None and gap < 60
    rows = [
        _row(
            "robots pass each other on the narrow road without deadlock",
            "Fig. 4: snapshots 0-5600 s; the robots 'pass each other and achieve effective "
            "collective navigation' (no numbers given)",
            f"{fmt(cross.get('+x'))} crossings toward +x and {fmt(cross.get('-x'))} toward -x "
            f"in {fmt(dur, unit='s')}; longest period with no crossing {fmt(gap, unit='s')}",
            (REPRODUCED if ok else DIFFERS) if cross else NOT_MEASURED,
            "rule: both directions cross and no gap without a crossing reaches 60 s",
        )
    ]
    sec = _get(res, "section_energy") or {}
    wide, narrow = _get(sec, "wide", "mean"), _get(sec, "narrow", "mean")
    if wide is not None and narrow is not None:
        rows.append(
            _row(
                "slower, colder motion in the narrow section",
                "Fig. 2 (i): fewer ants in the high-temperature phase on the narrow side "
                "(ants; the robots' sections are not reported)",
                f"mean energy {fmt(narrow)} (narrow) against {fmt(wide)} mm^2/s^2 (wide)",
                REPRODUCED if narrow < wide else DIFFERS,
                "the same direction as the ants, for robots whose speed law does not depend "
                "on the section: crowding alone cools them",
            )
        )
    return rows


# ----------------------------------------------------------------------- compression
def compare_compression(res: Mapping[str, Any]) -> list[dict[str, str]]:
    rows = []
    z = _get(res, "dilute_Z_mean")
    rows.append(
        _row(
            "the pressure-volume relation is that of an ideal gas",
            "Results text (Fig. 6 w): 'the observed pressure-volume relationship is analogous "
            "to that of an ideal gas'",
            f"Z = P A_free / (n kT_eff) = {fmt(z)} on the isotherm (ideal gas: 1)",
            (REPRODUCED if abs(z - 1) < 0.1 else DIFFERS) if z is not None else NOT_MEASURED,
            "rule: the mean Z within 10 % of 1",
        )
    )
    pt = _get(res, "pressure_vs_temperature") or {}
    r2, slope, ideal = pt.get("r2"), pt.get("slope"), pt.get("ideal_slope")
    rows.append(
        _row(
            "P proportional to T at fixed density",
            "Section 5 (compression): 'temperature increases to keep density the same' "
            "(P ~ T at fixed density)",
            f"R^2 = {fmt(r2, 5)}; slope {fmt(slope)} against the ideal-gas n / A_free = "
            f"{fmt(ideal)} per mm^2",
            (REPRODUCED if r2 is not None and r2 > 0.99 else DIFFERS)
            if r2 is not None
            else NOT_MEASURED,
            "rule: a straight line through the points with R^2 > 0.99",
        )
    )
    td = _get(res, "temperature_for_density") or {}
    r2 = td.get("r2")
    pf = td.get("packing_fraction") or []
    rows.append(
        _row(
            "the temperature that holds the density rises with the force",
            "Fig. 6 (w): 'temperature increases to keep density the same'",
            f"linear in the force, R^2 = {fmt(r2, 5)}; packing fraction held at "
            f"{', '.join(fmt(x, 3) for x in pf) or 'n/a'}",
            (REPRODUCED if r2 > 0.99 else DIFFERS) if r2 is not None else NOT_MEASURED,
            "rule: R^2 > 0.99 of the temperature against the force",
        )
    )
    return rows


# ----------------------------------------------------------------------- transport
def compare_transport_connected(res: Mapping[str, Any]) -> list[dict[str, str]]:
    seeds, reached = _get(res, "seeds"), _get(res, "reached")
    t, sd = _get(res, "time_to_target_mean"), _get(res, "time_to_target_sd")
    if seeds is None:
        return [
            _row(
                "robots attached to the object carry it to the target",
                "Results text: the connected robots 'successfully moved the object "
                "toward the goal'",
                "n/a",
                NOT_MEASURED,
                "",
            )
        ]
    ok = reached == seeds
    return [
        _row(
            "robots attached to the object carry it to the target",
            "Results text (Algorithm 4): the connected robots 'successfully moved the object "
            "toward the goal' (no time given)",
            f"reached in {reached} of {seeds} runs; time to target {fmt(t, unit='s')} "
            f"(sd {fmt(sd, unit='s')})",
            REPRODUCED if ok else (PARTLY if reached else DIFFERS),
            "rule: every run reaches the target room",
        )
    ]


def compare_transport_free(res: Mapping[str, Any]) -> list[dict[str, str]]:
    rows = []
    d = _get(res, "default") or {}
    times = [t for t in (d.get("time_to_target") or []) if t is not None]
    seeds = d.get("seeds")
    mean, se = d.get("displacement_toward_target_mean"), d.get("displacement_toward_target_se")
    z = d.get("mean_over_se")
    if seeds is None:
        verdict, why = NOT_MEASURED, ""
    elif times and len(times) == seeds:
        verdict, why = REPRODUCED, "every run reached the target"
    elif z is not None and z > 2:
        verdict = PARTLY
        why = (
            f"the object moves toward the light ({fmt(z, 2)} standard errors) but "
            f"{len(times)} of {seeds} runs reached the target in "
            f"{fmt(d.get('duration_s'), unit='s')}"
        )
    else:
        verdict, why = DIFFERS, "no displacement toward the light beyond 2 standard errors"
    tt = f"; time to target {', '.join(fmt(t, unit='s') for t in times)}" if times else ""
    rows.append(
        _row(
            "robots without connection push the object to the lit target (free space)",
            "Fig. 6 (a-h): 1,200 robots move the object 'without obstacle to the top'; "
            "Fig. 5 (real robots, 0-300 s): they 'move the green object toward the light'",
            f"displacement toward the target {fmt(mean)} +- {fmt(se)} mm (mean +- se, "
            f"{fmt(seeds)} runs of {fmt(d.get('n'))} robots, "
            f"{fmt(d.get('duration_s'), unit='s')}){tt}",
            verdict,
            why,
        )
    )
    for v, panel in (
        ("obstacle", "Fig. 6 (i-p): past an obstacle"),
        ("zigzag", "Fig. 6 (q-t): along a zig-zag curve"),
    ):
        r = _get(res, v) or {}
        disp, t = r.get("displacement_toward_target"), r.get("time_to_target")
        if not r:
            rows.append(_row(f"variant {v}", panel + " to the top", "n/a", NOT_MEASURED, ""))
            continue
        verdict = REPRODUCED if t is not None else (PARTLY if (disp or 0) > 0 else DIFFERS)
        rows.append(
            _row(
                f"variant {v}",
                panel + " to the top",
                f"displacement {fmt(disp, unit='mm')} in {fmt(r.get('duration_s'), unit='s')}; "
                + (
                    f"reached the target at {fmt(t, unit='s')}"
                    if t is not None
                    else "target not reached"
                ),
                verdict,
                "one run: reached or not"
                if t is not None
                else "one run; moving toward the light is not arriving",
            )
        )
    return rows


_MECHANISMS = [
    ("lit_cold", "uniform", "Algorithm 5 as written: lit robots cold (its equation), a fresh "
     "uniform heading every period"),
    ("lit_hot", "uniform", "Algorithm 5 as captioned: lit robots hot, gas-like (Figs. 5-6), "
     "fresh uniform headings"),
    ("lit_cold", "persistent", "the equation's mapping with persistent headings (our default)"),
    ("lit_hot", "persistent", "the captions' mapping with persistent headings"),
]  # fmt: skip


def compare_mechanism(res: Mapping[str, Any]) -> list[dict[str, str]]:
    """One row per reading of Algorithm 5 (mapping x heading law), over the sensing modes:
    the paper's result is that the object moves toward the light."""
    rows_in = _get(res, "rows") or []
    if not rows_in:
        return [_row("which robots are hot", "", "n/a", NOT_MEASURED, "")]
    out = []
    for mapping, law, label in _MECHANISMS:
        rs = [r for r in rows_in if r.get("mapping") == mapping and r.get("heading_law") == law]
        if not rs:
            continue
        toward = [r for r in rs if r.get("verdict") == "toward target"]
        away = [r for r in rs if r.get("verdict") == "away from target"]
        ours = "; ".join(
            f"{r.get('sensor.mode', '?')} sensing: {fmt(r.get('disp_mean'), 3)} +- "
            f"{fmt(r.get('disp_se'), 2)} mm ({r.get('verdict')})"
            for r in rs
        )
        if len(toward) == len(rs):
            verdict, why = REPRODUCED, "toward the light with every sensing model"
        elif toward:
            verdict = PARTLY
            why = f"toward the light with {len(toward)} of {len(rs)} sensing models"
        else:
            verdict = DIFFERS
            why = ("the object moves away from the light" if away else
                   "no motion toward the light beyond the 95 % interval")  # fmt: skip
        out.append(_row(label, "the swarm moves the object to the light (Figs. 5-6)", ours,
                        verdict, why))  # fmt: skip
    return out


def compare_scaling(res: Mapping[str, Any]) -> list[dict[str, str]]:
    rows_in = _get(res, "rows") or []
    trend = _get(res, "trend") or {}
    if not rows_in:
        return [_row("capacity grows with the swarm", "Fig. 6 (u)", "n/a", NOT_MEASURED, "")]
    ns = [r.get("n") for r in rows_in]
    rho, p = trend.get("spearman_rho"), trend.get("spearman_p")
    if rho is None:
        verdict, why = NOT_MEASURED, "too few runs for a rank correlation"
    elif rho > 0 and p is not None and p < 0.05:
        verdict, why = (
            REPRODUCED,
            "rule: Spearman correlation of runs' maximum "
            "displacement with N, positive at the 5 % level",
        )
    else:
        verdict = DIFFERS
        why = (
            "no significant increase of the maximum displacement with N (Spearman "
            "test at the 5 % level)"
        )
    out = [
        _row(
            "(u) the maximum distance moved grows with the number of robots",
            "Fig. 6 (u): 'capacity ... quantified by maximum object moving distance, "
            "increase with number of robots'; real robots: high variance, near 0 for few",
            "mean max displacement "
            + ", ".join(f"{fmt(r.get('maxdisp_mean'), 3)} mm (N = {r.get('n')})" for r in rows_in)
            + (f"; Spearman rho = {fmt(rho, 2)}, {_p(p)}" if rho is not None else ""),
            verdict,
            why,
        )
    ]
    reached = [r for r in rows_in if (r.get("reached") or 0) > 0]
    if len(reached) >= 2:
        times = [(r.get("n"), r.get("time_median") or r.get("time_mean_reached")) for r in reached]
        falls = all(
            b[1] is not None and a[1] is not None and b[1] <= a[1]
            for a, b in zip(times, times[1:], strict=False)
        )
        out.append(
            _row(
                "(v) the time to the target falls with the number of robots",
                "Fig. 6 (v): 'the minimum time to move object to desired position, decreases "
                "with number of robots'",
                ", ".join(f"{fmt(t, unit='s')} (N = {n})" for n, t in times),
                REPRODUCED if falls else PARTLY,
                "rule: the median time falls at every larger N that reached the target",
            )
        )
    else:
        out.append(
            _row(
                "(v) the time to the target falls with the number of robots",
                "Fig. 6 (v): 'the minimum time ... decreases with number of robots'",
                f"{len(reached)} of {len(ns)} swarm sizes reached the target in any run",
                NOT_MEASURED,
                "no time to compare: the object did not reach the target line at enough sizes",
            )
        )
    return out


COMPARISONS = {
    "unified_law": compare_unified_law,
    "narrow_road": compare_narrow_road,
    "compression": compare_compression,
    "transport_connected": compare_transport_connected,
    "transport_free": compare_transport_free,
    "mechanism": compare_mechanism,
    "scaling": compare_scaling,
}


def compare(name: str, res: Mapping[str, Any]) -> list[dict[str, str]]:
    """The comparison rows of experiment ``name`` (a key of ``results.json``)."""
    fn = COMPARISONS.get(name)
    return fn(res) if fn is not None else []


def summary_verdict(rows: Sequence[Mapping[str, str]]) -> str:
    """One word for an experiment: reproduced only if every row is (a claim not measured
    makes it partly)."""
    verdicts = [r["verdict"] for r in rows]
    if not verdicts or all(v == NOT_MEASURED for v in verdicts):
        return NOT_MEASURED
    if all(v == REPRODUCED for v in verdicts):
        return REPRODUCED
    if any(v in (REPRODUCED, PARTLY) for v in verdicts):
        return PARTLY
    return DIFFERS
