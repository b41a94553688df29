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
import statistics
from collections.abc import Mapping, Sequence
from typing import Any

from thermoswarm.report.paper_common import (
    DIFFERS,
    NOT_MEASURED,
    NOT_RESOLVED,
    PARTLY,
    REPRODUCED,
    _get,
    _p,
    _row,
    fmt,
)
from thermoswarm.report.paper_power import (
    _arrival_power,
    _cells_power,
    _mean_power,
    _r2_power,
    _se_diff,
    _z_power,
)
from thermoswarm.report.paper_unified import compare_unified_law
from thermoswarm.report.power import mde, mde_spearman, power_note, rank_p_floor

__all__ = ["COMPARISONS", "compare", "fmt", "NOTES_PAGE"]

#: The page of the documentation that settles the paper's contradictions.
NOTES_PAGE = "docs/paper_notes.md"


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
            "rule: both directions cross and no gap without a crossing reaches 60 s; "
            + power_note(
                "none (a rule on one run's crossings, no rate estimated)",
                f"1 run of {fmt(dur, unit='s')}, {fmt(_get(res, 'n'))} robots",
                "none stated (one run gives no rate of deadlocks; seeds would)",
                level=False,
            ),
        )
    ]
    sec = _get(res, "section_energy") or {}
    wide, narrow = _get(sec, "wide", "mean"), _get(sec, "narrow", "mean")
    if wide is not None and narrow is not None:
        se = _se_diff(_get(sec, "wide", "se"), _get(sec, "narrow", "se"))
        resolved = se is None or abs(wide - narrow) > 1.96 * se
        rows.append(
            _row(
                "slower, colder motion in the narrow section",
                "Fig. 2 (i): fewer ants in the high-temperature phase on the narrow side "
                "(ants; the robots' sections are not reported)",
                f"mean energy {fmt(narrow)} (narrow) against {fmt(wide)} mm^2/s^2 (wide)",
                NOT_RESOLVED if not resolved else REPRODUCED if narrow < wide else DIFFERS,
                ("the same direction as the ants, for robots whose speed law does not depend "
                 "on the section: crowding alone cools them" if narrow < wide else
                 "warmer, not colder, in the narrow section")
                + ("" if resolved else ", but within 1.96 standard errors of no difference")
                + "; rule: the narrow section's mean energy below the wide one's; "
                + power_note("z-test of the difference of the two means",
                             "1 run: each section's steps, their standard errors from the run",
                             None if se is None else
                             f"energy difference {fmt(mde(se), 2)} mm^2/s^2"),
            )
        )  # fmt: skip
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
            "rule: the mean Z within 10 % of 1; " + _z_power(_get(res, "isotherm") or []),
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
            "rule: a straight line through the points with R^2 > 0.99; "
            + _r2_power(pt.get("n_points")),
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
            "rule: R^2 > 0.99 of the temperature against the force; "
            + _r2_power(td.get("n_points")),
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
            "rule: every run reaches the target room; " + _arrival_power(seeds),
        )
    ]


def compare_transport_free(res: Mapping[str, Any]) -> list[dict[str, str]]:
    rows = []
    d = _get(res, "default") or {}
    times = d.get("time_to_target") or []
    seeds = d.get("seeds")
    got = [t for t in times if t is not None]
    k = d.get("reached", len(got))
    med = d.get("time_to_target_median")
    if med is None and got:
        med = statistics.median(got)
    z = d.get("mean_over_se")
    if seeds is None:
        verdict, why = NOT_MEASURED, ""
    elif seeds and k == seeds:
        verdict, why = REPRODUCED, "every run reaches the target line"
    elif k:
        verdict = PARTLY
        why = f"{k} of {seeds} runs reached the target within the run"
    elif z is not None and z > 2:
        verdict = PARTLY
        why = (
            f"the object moves toward the light ({fmt(z, 2)} standard errors) but "
            f"0 of {seeds} runs reached the target in {fmt(d.get('duration_s'), unit='s')}"
        )
    else:
        verdict, why = DIFFERS, "no run arrived and no displacement toward the light beyond 2 se"
    dist = d.get("target_distance_mm")
    ours = (
        f"reached the target line{' ' + fmt(dist, unit='mm') + ' up' if dist else ''} in "
        f"{fmt(k)} of {fmt(seeds)} runs of {fmt(d.get('n'))} robots "
        f"({fmt(d.get('duration_s'), unit='s')} each)"
    )
    if got:
        ours += (
            f"; time to target median {fmt(med, unit='s')} (range "
            f"{fmt(d.get('time_to_target_min', min(got)), unit='s')} to "
            f"{fmt(d.get('time_to_target_max', max(got)), unit='s')})"
        )
    else:
        ours += (
            f"; displacement toward the target {fmt(d.get('displacement_toward_target_mean'))}"
            f" +- {fmt(d.get('displacement_toward_target_se'))} mm (mean +- se)"
        )
    rows.append(
        _row(
            "robots without connection push the object to the lit target (free space)",
            "Fig. 6 (a-h): 1,200 robots move the object 'without obstacle to the top'; "
            "Fig. 5 (real robots, 0-300 s): they 'move the green object toward the light'",
            ours,
            verdict,
            (why + "; rule: every run reaches the target line, or (partly) the mean "
             "displacement toward it is above 2 standard errors; " + _arrival_power(seeds)
             + "; " + _mean_power(d.get("displacement_toward_target_se"), seeds,
                                  "displacement (mm)")) if seeds is not None else why,
        )
    )  # fmt: skip
    rows.extend(_variant_row(_get(res, v) or {}, v, panel) for v, panel in (
        ("obstacle", "Fig. 6 (i-p): past an obstacle"),
        ("zigzag", "Fig. 6 (q-t): along a zig-zag curve"),
    ))  # fmt: skip
    return rows


def _variant_row(r: Mapping[str, Any], v: str, panel: str) -> dict[str, str]:
    """One run of a variant (obstacle, zig-zag): reached the target, or how far it got."""
    if not r:
        return _row(f"variant {v}", panel + " to the top", "n/a", NOT_MEASURED, "")
    disp = r.get("max_displacement_toward_target", r.get("displacement_toward_target"))
    t = r.get("time_to_target")
    verdict = REPRODUCED if t is not None else (PARTLY if (disp or 0) > 0 else DIFFERS)
    return _row(
        f"variant {v}",
        panel + " to the top",
        (
            f"reached the target line {fmt(r.get('target_distance_mm'), unit='mm')} up "
            f"at {fmt(t, unit='s')}"
            if t is not None
            else f"target not reached in {fmt(r.get('duration_s'), unit='s')}; "
            f"at most {fmt(disp, unit='mm')} toward it"
        ),
        verdict,
        ("one run: reached or not" if t is not None
         else "one run; moving toward the light is not arriving")
        + "; " + power_note("none (one run: reached or not)", "1 run",
                            "none stated (one run gives no rate)", level=False),
    )  # fmt: skip


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
                        verdict, why + "; rule: toward the light when the 95 % t interval "
                        "of the displacement over seeds is above 0; " + _cells_power(rs,
                        "disp_se", "displacement", "mm")))  # fmt: skip
    return out


_SERIES = {"fixed": "robots added to a fixed arena", "density": "the arena grows with N"}


def _by_series(rows: Sequence[Mapping[str, Any]]) -> dict[str, list[Mapping[str, Any]]]:
    out: dict[str, list[Mapping[str, Any]]] = {}
    for r in rows:
        out.setdefault(r.get("series") or "fixed", []).append(r)
    return {k: sorted(v, key=lambda r: r.get("n") or 0) for k, v in out.items()}


def _capacity_row(rows: Sequence[Mapping[str, Any]], trend: Mapping[str, Any], label: str
                  ) -> dict[str, str]:  # fmt: skip
    """Panel (u) for one series: the rank trend of the runs' maximum displacement with N,
    and where the median stops growing (reaches the 95 % interval of the largest)."""
    meds = [(r.get("n"), r.get("maxdisp_median", r.get("maxdisp_mean"))) for r in rows]
    meds = [(n, m) for n, m in meds if n is not None and m is not None]
    rho, p = trend.get("spearman_rho"), trend.get("spearman_p")
    claim = "(u) the maximum distance moved grows with the number of robots" + label
    paper = (
        "Fig. 6 (u): 'capacity ... quantified by maximum object moving distance, increase "
        "with number of robots'; real robots: high variance, near 0 for few"
    )
    if not meds:
        return _row(claim, paper, "n/a", NOT_MEASURED, "")
    top = max(range(len(meds)), key=lambda i: meds[i][1])
    n_top, m_top = meds[top]
    low = rows[[r.get("n") for r in rows].index(n_top)].get("maxdisp_ci_low")
    n_sat = next((n for n, m in meds if low is not None and m >= low), n_top)
    ours = "median max displacement " + ", ".join(
        f"{fmt(m, 3)} mm (N = {fmt(n)})" for n, m in meds
    )
    if rho is not None:
        ours += f"; Spearman rho = {fmt(rho, 2)}, {_p(p)}"
    peak = f"largest median at N = {fmt(n_top)}"
    if n_sat != n_top:
        peak += f", within its 95 % interval from N = {fmt(n_sat)} on"
    if rho is None:
        return _row(claim, paper, ours, NOT_MEASURED, "too few runs for a rank correlation")
    floor = rank_p_floor([r.get("seeds") or 0 for r in rows])
    if floor is not None and floor >= 0.05:  # no ordering of these runs is significant
        verdict = NOT_RESOLVED
        why = (f"not resolved at this scale: with {fmt(sum(r.get('seeds') or 0 for r in rows))}"
               f" runs over {fmt(len(rows))} swarm sizes the smallest p-value of an exact "
               f"rank test is {fmt(floor, 2)}, so none can reject at the 5 % level (more "
               f"seeds or sizes resolve it: reproduce --full); {peak}")  # fmt: skip
    elif rho > 0 and p is not None and p < 0.05:
        if n_top == meds[-1][0]:
            verdict, why = REPRODUCED, f"grows with N ({peak})"
        else:
            verdict = PARTLY
            why = f"grows, then saturates or falls: {peak}; smaller at N = {fmt(meds[-1][0])}"
    else:
        verdict, why = DIFFERS, f"no significant increase with N ({peak})"
    rule = "rule: Spearman correlation of the runs' maximum displacement with N, positive at "
    n_runs = trend.get("n_runs") or sum(r.get("seeds") or 0 for r in rows) or None
    m = mde_spearman(n_runs)
    power = power_note(
        "Spearman rank correlation",
        f"{fmt(n_runs)} runs over {fmt(len(rows))} swarm sizes",
        None if m is None else f"rank correlation {fmt(m, 2)}",
    )
    return _row(claim, paper, ours, verdict, f"{why}; {rule}the 5 % level, the largest median "
                f"at the largest N; {power}")  # fmt: skip


def _time_row(rows: Sequence[Mapping[str, Any]], label: str) -> dict[str, str]:
    """Panel (v) for one series: median times to target (a size where fewer than half the
    runs arrived is slower than any that has a median) and where they stop falling (reach
    the 95 % interval of the fastest median)."""
    claim = "(v) the time to the target falls with the number of robots" + label
    paper = (
        "Fig. 6 (v): 'the minimum time to move object to desired position, decreases with "
        "number of robots'"
    )
    meds = [(r.get("n"), r.get("time_median"), r) for r in rows]
    finite = [(n, t, r) for n, t, r in meds if t is not None]
    arrived = sum(1 for r in rows if (r.get("reached") or 0) > 0)
    if len(finite) < 2:
        return _row(
            claim,
            paper,
            f"{arrived} of {len(rows)} swarm sizes reached the target in any run; "
            f"{len(finite)} had a median time (at least half the runs arrived)",
            NOT_MEASURED,
            "no times to compare: the object did not reach the target line at enough sizes",
        )
    n_best, t_best, r_best = min(finite, key=lambda e: e[1])
    hi = r_best.get("time_ci_high")
    n_sat = next((n for n, t, _ in finite if hi is not None and t <= hi), n_best)
    first = meds[0][1]  # None: fewer than half arrived, slower than any median
    # a fall: the smallest swarm's median outside the fastest median's 95 % interval
    falls = first is None or first > (hi if hi is not None else t_best)
    ours = "median time " + ", ".join(
        f"{fmt(t, unit='s') if t is not None else 'none (under half arrived)'} (N = {fmt(n)})"
        for n, t, _ in meds
    )
    fastest = [(r.get("n"), r.get("time_min")) for r in rows if r.get("time_min") is not None]
    if fastest:
        ours += "; fastest run " + ", ".join(f"{fmt(t, unit='s')} (N = {fmt(n)})"
                                             for n, t in fastest)  # fmt: skip
    where = f"fastest median at N = {fmt(n_best)}"
    if n_sat != n_best:
        where += f", within its 95 % interval from N = {fmt(n_sat)} on"
    if hi is None:  # too few runs arrived for a bounded interval: no power to decide
        verdict = NOT_RESOLVED
        why = (f"the fastest median's 95 % interval is unbounded ({r_best.get('reached')} of "
               f"{r_best.get('seeds')} runs at N = {fmt(n_best)} reached the target): more "
               "seeds a size (reproduce --full) resolve it")  # fmt: skip
    elif falls and n_best == meds[-1][0]:
        verdict, why = REPRODUCED, f"falls with N ({where})"
    elif falls:
        verdict, why = PARTLY, f"falls, then saturates or rises: {where}"
    else:
        verdict = DIFFERS
        why = f"no faster than at the smallest N, to the 95 % interval ({where})"
    power = power_note(
        "order-statistic (distribution-free) 95 % interval of the fastest median",
        f"{'-'.join(fmt(x) for x in sorted({r.get('seeds') for r in rows if r.get('seeds')}))}"
        f" runs a size, {fmt(len(rows))} sizes",
        None
        if hi is None
        else f"fall {fmt(hi - t_best, 2, 's')} (the interval's upper "
        "half-width: a smaller swarm's median must lie above it)",
    )
    return _row(claim, paper, ours, verdict, f"{why}; rule: the fastest median at the largest "
                f"N, and the smallest N's median above its 95 % interval; {power}")  # fmt: skip


def compare_scaling(res: Mapping[str, Any]) -> list[dict[str, str]]:
    """Panels (u) and (v), one row each per series (robots added to a fixed arena; an
    arena grown with N at a fixed density)."""
    rows_in = _get(res, "rows") or []
    trend = _get(res, "trend") or {}
    if "spearman_rho" in trend or "test" in trend:  # one series, as older results hold it
        trend = {"fixed": trend}
    if not rows_in:
        return [_row("capacity grows with the swarm", "Fig. 6 (u)", "n/a", NOT_MEASURED, "")]
    groups = _by_series(rows_in)
    out = []
    for series, rows in groups.items():
        label = f" ({_SERIES.get(series, series)})" if len(groups) > 1 else ""
        out.append(_capacity_row(rows, trend.get(series) or {}, label))
        out.append(_time_row(rows, label))
    return out


def compare_regime(res: Mapping[str, Any]) -> list[dict[str, str]]:
    """The drift-speed maps: does the object move toward the light over the parameters
    the paper leaves open, and where fastest."""
    rows = _get(res, "rows") or []
    claim = "the object moves toward the light over the parameters the paper leaves open"
    paper = (
        "Algorithm 5 gives the law, not its numbers (temperatures, steering, control period, "
        "light); Figs. 5-6 show the object moved toward the light at the authors' settings"
    )
    if not rows:
        return [_row(claim, paper, "n/a", NOT_MEASURED, "")]
    toward = [r for r in rows if r.get("verdict") == "toward target"]
    away = [r for r in rows if r.get("verdict") == "away from target"]
    # the fastest cell among those whose own verdict is a detectable motion toward the
    # light: a larger mean whose interval holds 0 is no evidence of speed
    best = max(toward, key=lambda r: r.get("drift_mean") or -math.inf) if toward else None

    def cell(r: Mapping[str, Any]) -> str:
        return (
            f"{fmt(r.get('drift_mean'))} +- {fmt(r.get('drift_se'), 2)} mm/s at "
            f"{r.get('map_title', r.get('map'))}: {r.get('x_name', 'x')} {fmt(r.get('x'))}, "
            f"{r.get('y_name', 'y')} {fmt(r.get('y'))}"
        )

    ours = (
        f"toward the light in {len(toward)} of {len(rows)} cells, away in {len(away)} "
        f"({fmt(res.get('seeds'))} seeds, {fmt(res.get('n'))} robots, "
        f"{fmt(res.get('duration_s'), unit='s')}); "
        + (
            f"fastest detectable {cell(best)}"
            if best
            else "no cell with detectable motion toward the light"
        )  # fmt: skip
    )
    default = next((r for r in rows if r.get("default")), None)
    if default is not None:
        ours += (
            f"; the default cell {fmt(default.get('drift_mean'))} +- "
            + fmt(default.get("drift_se"), 2)
            + " mm/s"
        )
    if len(toward) == len(rows):
        verdict, why = REPRODUCED, "toward the light in every cell"
    elif toward:
        verdict = PARTLY
        why = "the transport depends on the numbers the paper leaves open"
    elif not away:  # every interval holds 0: the test had no power with these seeds
        verdict = NOT_RESOLVED
        why = (f"no cell's 95 % interval excludes 0 with {fmt(res.get('seeds'))} seeds: not "
               "resolved at this scale (reproduce --full runs more seeds, longer)")  # fmt: skip
    else:
        verdict, why = DIFFERS, "no cell moves the object toward the light"
    return [_row(claim, paper, ours, verdict, why + "; rule: a cell moves toward the light "
                 "when the 95 % interval of its drift is above 0; "
                 + _cells_power(rows, "drift_se", "drift", "mm/s"))]  # fmt: skip


COMPARISONS = {
    "unified_law": compare_unified_law,
    "narrow_road": compare_narrow_road,
    "compression": compare_compression,
    "transport_connected": compare_transport_connected,
    "transport_free": compare_transport_free,
    "regime": compare_regime,
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
    if all(v in (NOT_MEASURED, NOT_RESOLVED) for v in verdicts):
        return NOT_RESOLVED
    if any(v in (REPRODUCED, PARTLY) for v in verdicts):
        return PARTLY
    return DIFFERS
