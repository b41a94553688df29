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

from thermoswarm.report._paper_rows import (
    DIFFERS,
    NOT_MEASURED,
    NOTES_PAGE,
    PARTLY,
    REPRODUCED,
    _get,
    _p,
    _row,
    fmt,
)
from thermoswarm.report._paper_transport import (
    compare_mechanism,
    compare_regime,
    compare_scaling,
    compare_transport_connected,
    compare_transport_free,
)

__all__ = ["COMPARISONS", "compare", "fmt", "NOTES_PAGE"]


# ----------------------------------------------------------------------- one law
def _ant_row(ants: Mapping[str, Any], nb: Any, real: bool) -> dict[str, str]:
    """The paper's two-phase claim checked on real ants, or on the synthetic control.

    Rule for both: two phases preferred by the LR test and the two-phase fit not
    rejected by its KS test (p > 0.05).
    """
    pref = ants.get("preferred")
    tp = ants.get("two_phase") or {}
    ok = pref == "two_phase" and (ants.get("ks_p_value_preferred") or 0) > 0.05
    sm = ants.get("samples") or {}
    if real:
        what = (
            f"real ants: {ants.get('source') or 'source n/a'}; {fmt(sm.get('single'))} of "
            f"{fmt(sm.get('total'))} samples measured individually "
            f"({fmt(sm.get('cluster_shared'))} in clusters, left out), "
            f"{fmt(_get(ants, 'steps', 'resting'))} resting steps left out"
        )
        kt1 = tp.get("kT1")
        if ok and kt1:  # a cold phase near zero may be standing ants' centroid jitter
            what += (
                f"; the cold phase's rms speed is {fmt(math.sqrt(2 * kt1), 2)} mm/s: at "
                "this camera's 0.094 mm pixels and 10 frames/s, about one pixel per frame, "
                "so it may be standing ants' jitter rather than a second gait"
            )
        claim = "ants (real): energy is a two-phase exponential mixture"
    else:
        what = (
            "control: synthetic ants drawn from the paper's two-phase model, read back by "
            "the same analysis: this checks the analysis, not the biology"
        )
        claim = "ants (synthetic control): the analysis recovers the two-phase mixture"
    why = (
        "rule: two phases preferred (LR p < 0.05) and the two-phase fit not rejected "
        "(KS p > 0.05); "
    )
    if pref and not ok:
        why += (
            "here one phase was preferred; "
            if pref != "two_phase"
            else "here the KS test rejects the two-phase fit; "
        )
    return _row(
        claim,
        "Fig. 2 (a-h): p(v^2) = phi Exp(kT1) + (1 - phi) Exp(kT2) fits every energy level; "
        "KS 0.024-0.052, p 0.99-1.00",
        f"{pref or 'n/a'} preferred (LR {_p(ants.get('lr_p_value'), nb)}); "
        f"one phase kT = {fmt(ants.get('one_phase_kT'))}; phi = {fmt(tp.get('phi'))}, "
        f"kT1 = {fmt(tp.get('kT1'))}, kT2 = {fmt(tp.get('kT2'))} mm^2/s^2; KS "
        f"{_p(ants.get('ks_p_value_preferred'), nb)}",
        (REPRODUCED if ok else DIFFERS) if pref else NOT_MEASURED,
        why + what,
    )


def compare_unified_law(res: Mapping[str, Any]) -> list[dict[str, str]]:
    nb = next((s.get("n_bootstrap") for s in res.values() if isinstance(s, Mapping)), None)
    rows = [
        _ant_row(_get(res, "ants_real") or {}, nb, real=True),
        _ant_row(_get(res, "ants") or {}, nb, real=False),
    ]
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
    if any(v in (REPRODUCED, PARTLY) for v in verdicts):
        return PARTLY
    return DIFFERS
