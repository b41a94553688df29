"""The paper beside our results for "one law, three systems": real and synthetic ants,
an elastic gas, light-switched robots (:func:`compare_unified_law`; the rules are in
each row's ``why``)."""

from __future__ import annotations

import math
from collections.abc import Mapping
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
from thermoswarm.report.power import mde, mde_ks, p_floor, power_note

__all__ = ["compare_unified_law", "walking_command"]


def _powerless(nb: Any) -> str | None:
    """Why a bootstrap of ``nb`` replicates cannot reject at the 5 % level, or ``None``:
    its smallest p-value, ``1 / (nb + 1)``, is not below 0.05."""
    if nb and 1 / (nb + 1) >= 0.05:
        return (f"not resolved at this scale: with {nb} bootstrap replicates the smallest "
                f"p-value is {fmt(1 / (nb + 1), 2)}, so no test here can reject at the 5 % "
                "level (the quick and full plans run 200)")  # fmt: skip
    return None


def _command(system: Mapping[str, Any]) -> str:
    """``; numbers from: COMMAND`` where the row's results name the command."""
    cmd = system.get("command")
    return f"; numbers from: {cmd}" if cmd else ""


def _sample(b: Mapping[str, Any], nb: Any) -> str:
    """The sample of a system's tests: steps fitted, the decorrelated test sample and
    the bootstrap replicates with their smallest p-value."""
    parts = [f"{fmt(b.get('n_steps'))} steps fitted", f"{fmt(b.get('n_test'))} in the "
             "decorrelated test sample (the tests run on it)"]  # fmt: skip
    if nb:
        parts.append(f"{fmt(nb)} bootstrap replicates (smallest p {fmt(p_floor(nb), 2)})")
    return ", ".join(parts)


def _kt_gap_mde(b: Mapping[str, Any]) -> float | None:
    """The smallest difference between two phases' temperatures (mm^2/s^2) that the
    test sample detects: :func:`~thermoswarm.report.power.mde` of the difference's
    standard error, the two-phase fit's (or, without it, two equal halves of the one
    phase: twice its kT's) scaled from the steps fitted to the test sample.  It is the
    power had each step's phase been known: a lower bound for the mixture's test."""
    tp = b.get("two_phase") or {}
    s1, s2 = tp.get("kT1_se"), tp.get("kT2_se")
    if s1 is not None and s2 is not None and math.isfinite(s1 + s2):
        se = math.hypot(s1, s2)
    elif b.get("one_phase_kT_se") is not None:
        se = 2 * b["one_phase_kT_se"]
    else:
        return None
    n, nt = b.get("n_steps"), b.get("n_test")
    return mde(se * math.sqrt(n / nt) if n and nt else se)


def _lr_power(b: Mapping[str, Any], nb: Any) -> str:
    """``test: ...; sample: ...; smallest detectable kT difference ...`` of a phase row."""
    m = _kt_gap_mde(b)
    return power_note(
        "bootstrap likelihood-ratio test of one exponential phase against two, then the "
        "bootstrap KS test of the preferred fit",
        _sample(b, nb),
        None
        if m is None
        else f"kT difference between the phases {fmt(m, 2)} mm^2/s^2 "
        "(as if each step's phase were known: a lower bound)",
    )


def _phases(ants: Mapping[str, Any]) -> tuple[str, bool]:
    """Which fitted phase of the real ants is which: the cold phase's mean speed
    (``sqrt(pi kT1 / 2)`` for an exponential energy law) against the measured speed of
    ants at rest (the tracking's jitter).  Within twice the jitter the cold phase is
    standing ants' jitter, and the walking steps alone (results' ``walking``) are
    stated; ``(text, standing)``."""
    tp, jit = ants.get("two_phase") or {}, ants.get("jitter") or {}
    kt1, kt2, j = tp.get("kT1"), tp.get("kT2"), jit.get("speed_mm_s")
    if not kt1 or not kt2:
        return "", False
    cold, hot = _mean_speed(kt1), _mean_speed(kt2)
    if not j:
        text = ("which phase of the two-phase fit is which: not measured (no jitter of ants "
                f"at rest; the cold phase's mean speed is {fmt(cold, 2)} mm/s); ")  # fmt: skip
        return text, False
    text = (
        "which phase of the two-phase fit is which: the cold phase's mean speed "
        f"{fmt(cold, 2)} mm/s against the jitter of ants at rest, {fmt(j, 2)} mm/s (the "
        f"mean speed of {fmt(jit.get('n_steps'))} nonzero steps of "
        f"{fmt(jit.get('n_individuals'))} ants whose positions stayed within "
        f"{fmt(jit.get('extent_mm'), 2)} mm for {fmt(jit.get('window_s'), 2)} s; one pixel "
        f"a frame is {fmt(jit.get('pixel_speed_mm_s'), 2)} mm/s): "
    )
    if cold > 2 * j:
        text += (f"above twice the jitter, so both phases walk: the cold phase is slow "
                 f"walking, the hot one (mean {fmt(hot, 2)} mm/s) fast walking; ")  # fmt: skip
        return text, False
    text += (
        "within twice the jitter, so the cold phase is standing ants' jitter, not a "
        f"walking phase, and the hot phase (mean {fmt(hot, 2)} mm/s) is the walking one; "
    )
    return text + _walking(ants, 2 * j), True


def _mean_speed(kt: float) -> float:
    """The mean speed (mm/s) of an exponential energy law of temperature ``kt``
    (mm^2/s^2, energy v^2/2): ``sqrt(pi kt / 2)``."""
    return math.sqrt(math.pi * kt / 2)


def _walking(ants: Mapping[str, Any], cut: float) -> str:
    """The walking steps alone: the fit with every step at or below ``cut`` (twice the
    jitter, mm/s) left out as standing, by the ant row's rule, and its command."""
    w = ants.get("walking") or {}
    cut = w.get("resting_speed_mm_s") or cut
    cmd = walking_command(ants.get("command"), cut)
    if not w.get("preferred"):
        return ("the walking steps alone are not fitted in this run"
                + (f" (their command: {cmd}); " if cmd else "; "))  # fmt: skip
    tp, nb = w.get("two_phase") or {}, w.get("n_bootstrap")
    speeds = ", ".join(fmt(_mean_speed(tp[k]), 2) for k in ("kT1", "kT2") if tp.get(k))
    speeds = speeds or fmt(None)
    return (
        f"the walking steps alone (steps at or below {fmt(cut, 2)} mm/s, twice the jitter, "
        f"left out as standing: {fmt(w.get('resting_left_out'))}; {fmt(w.get('n_steps'))} "
        f"fitted, {fmt(w.get('n_test'))} in the test sample): {w['preferred']} preferred "
        f"(LR {_p(w.get('lr_p_value'), nb)}), KS {_p(w.get('ks_p_value_preferred'), nb)}; "
        f"phi = {fmt(tp.get('phi'))}, kT1 = {fmt(tp.get('kT1'))}, kT2 = {fmt(tp.get('kT2'))} "
        f"mm^2/s^2 (mean speeds {speeds} mm/s; smallest detectable kT difference "
        f"{fmt(_kt_gap_mde(w), 2)} mm^2/s^2): "
        + _walking_outcome(w) + (f" (numbers from: {cmd}); " if cmd else "; ")
    )  # fmt: skip


def _walking_outcome(w: Mapping[str, Any]) -> str:
    """The walking fit by the ant row's rule: two walking phases, not, or not resolved
    (a bootstrap whose smallest p-value is not below 0.05 cannot prefer two)."""
    ok = w.get("preferred") == "two_phase" and (w.get("ks_p_value_preferred") or 0) > 0.05
    if ok:
        return "two walking phases by the row's rule"
    if _powerless(w.get("n_bootstrap")):
        return (f"not resolved at this scale ({fmt(w.get('n_bootstrap'))} bootstrap "
                "replicates cannot reject at the 5 % level)")  # fmt: skip
    return "not two walking phases by the row's rule"


def _walking_verdict(ants: Mapping[str, Any]) -> str:
    """The walking fit's outcome in a few words, with its p-values."""
    w = ants.get("walking") or {}
    if not w.get("preferred"):
        return "the walking steps alone are not fitted in this run"
    nb = w.get("n_bootstrap")
    return (f"the walking steps alone: {_walking_outcome(w)} (LR {_p(w.get('lr_p_value'), nb)}"
            f", KS {_p(w.get('ks_p_value_preferred'), nb)}; their fit: below)")  # fmt: skip


def walking_command(command: str | None, resting_speed: float) -> str | None:
    """The row's ``analyze`` command with ``--resting-speed`` (mm/s, two significant
    digits) before ``--out``: the fit of the steps faster than the jitter alone."""
    if not command or " --out " not in command:
        return None
    head, tail = command.split(" --out ", 1)
    return f"{head} --resting-speed {float(f'{resting_speed:.2g}'):g} --out {tail}"


def _ant_row(ants: Mapping[str, Any], nb: Any, real: bool) -> dict[str, str]:
    """The paper's two-phase claim checked on real ants, or on the synthetic control.

    Rule for both: two phases preferred by the LR test and the two-phase fit not
    rejected by its KS test (p > 0.05).  The real row says which phase is which (standing
    or walking) right after its rule, then its test and sample, then its data.
    """
    pref = ants.get("preferred")
    tp = ants.get("two_phase") or {}
    ok = pref == "two_phase" and (ants.get("ks_p_value_preferred") or 0) > 0.05
    sm = ants.get("samples") or {}
    phases, standing = _phases(ants) if real else ("", False)
    if real:
        data = (
            f"real ants: {ants.get('source') or 'source n/a'}; {fmt(sm.get('single'))} of "
            f"{fmt(sm.get('total'))} samples measured individually "
            f"({fmt(sm.get('cluster_shared'))} in clusters, left out), "
            f"{fmt(_get(ants, 'steps', 'resting'))} resting steps left out"
        )
        claim = "ants (real): energy is a two-phase exponential mixture"
    else:
        data = (
            "control: synthetic ants drawn from the paper's two-phase model, read back by "
            "the same analysis: this checks the analysis, not the biology"
        )
        claim = "ants (synthetic control): the analysis recovers the two-phase mixture"
    why = ("rule: two phases preferred (LR p < 0.05) and the two-phase fit not rejected "
           "(KS p > 0.05); ")  # fmt: skip
    if pref and not ok:
        why += ("here one phase was preferred; " if pref != "two_phase"
                else "here the KS test rejects the two-phase fit; ")  # fmt: skip
    weak = _powerless(nb) if pref and not ok else None
    if not pref:
        verdict = NOT_MEASURED
    elif ok:
        verdict = PARTLY if standing else REPRODUCED
    else:
        verdict = NOT_RESOLVED if weak else DIFFERS
    lead = (f"{weak}; " if weak else "") + (
        "partly: two phases preferred and not rejected, but one of them is standing, not "
        f"walking (which is which: below); {_walking_verdict(ants)}; " if ok and standing
        else "")  # fmt: skip
    return _row(
        claim,
        "Fig. 2 (a-h): p(v^2) = phi Exp(kT1) + (1 - phi) Exp(kT2) fits every energy level; "
        "KS 0.024-0.052, p 0.99-1.00",
        f"{pref or 'n/a'} preferred (LR {_p(ants.get('lr_p_value'), nb)}); "
        f"one phase kT = {fmt(ants.get('one_phase_kT'))}; phi = {fmt(tp.get('phi'))}, "
        f"kT1 = {fmt(tp.get('kT1'))}, kT2 = {fmt(tp.get('kT2'))} mm^2/s^2; KS "
        f"{_p(ants.get('ks_p_value_preferred'), nb)}",
        verdict,
        lead + why + phases + (_lr_power(ants, nb) + "; " if pref else "") + data
        + _command(ants),
    )  # fmt: skip


def _ks_power(st: Mapping[str, Any], k: Any) -> str:
    """The steering law's test, its per-bin sample and the KS distance it detects in
    the smallest bin (:func:`~thermoswarm.report.power.mde_ks`)."""
    ns = [n for n in st.get("bin_n") or [] if n]
    return power_note(
        f"bootstrap KS test of an exponential |steering rate| in each of {fmt(k)} bins",
        f"{fmt(min(ns))}-{fmt(max(ns))} decorrelated rates per bin" if ns else "n/a",
        f"KS distance {fmt(mde_ks(min(ns)), 2)} in the smallest bin (at most: "
        "whatever the departure's shape)"
        if ns
        else None,
    )


def _slope_power(st: Mapping[str, Any]) -> str:
    """The trend's test, its bins and the slope it detects (t quantiles, k - 2 df)."""
    k, se = st.get("k") or st.get("bins"), st.get("slope_se")
    m = mde(se, df=k - 2) if k and se is not None else None
    return power_note(
        f"t-test of the weighted least-squares slope ({fmt(k - 2 if k else None)} degrees "
        "of freedom)",
        f"{fmt(k)} bins",
        None if m is None else f"slope {fmt(m, 2)} rad/s per mm^2/s^2",
    )


def _steering_rows(ants: Mapping[str, Any], who: str) -> list[dict[str, str]]:
    """The paper's steering claims on one ant system: ``|steering rate|`` exponential in
    every speed bin, and its temperature falling with speed."""
    st = ants.get("steering") or {}
    k, ok_bins = st.get("bins"), st.get("bins_exponential")
    measured = bool(k)
    law = _row(
        f"ants ({who}): |steering rate| is exponential in each speed bin",
        "Fig. 3 (a-h): p(theta) = exp(-theta/kT_theta(v))/kT_theta(v) at each energy "
        "level (4.5-90): KS 0.060-0.10, p 0.3-1",
        f"exponential not rejected in {fmt(ok_bins)} of {fmt(k)} {st.get('by') or ''} bins",
        (REPRODUCED if ok_bins == k else PARTLY if ok_bins else DIFFERS)
        if measured
        else NOT_MEASURED,
        "rule: the bootstrap KS test of each bin's exponential fit at p > 0.05 (thinned "
        "test sample, its n in fits.json); " + _ks_power(st, k) + _command(ants),
    )
    slope, p = st.get("slope"), st.get("p_value")
    falls = slope is not None and slope < 0 and p is not None and p < 0.05
    trend = _row(
        f"ants ({who}): the steering temperature falls with speed",
        "Fig. 3 (i): T_theta decreases with the ants' average speed (energy level)",
        f"slope {fmt(slope)} per energy unit, {_p(p)}; Spearman rho {fmt(st.get('spearman_rho'))}",
        (REPRODUCED if falls else DIFFERS) if slope is not None else NOT_MEASURED,
        "rule: weighted least-squares slope of T_theta against the bins' mean energy, "
        f"negative with t-test p < 0.05 over {fmt(k)} bins; " + _slope_power(st) + _command(ants),
    )
    return [law, trend]


def _kt_power(gas: Mapping[str, Any]) -> str:
    """The smallest difference between kT and the mean energy the gas's sample detects:
    :func:`~thermoswarm.report.power.mde` of kT's standard error at the test sample."""
    se, kt = gas.get("one_phase_kT_se"), gas.get("one_phase_kT")
    n, nt = gas.get("n_steps"), gas.get("n_test")
    m = mde(se * math.sqrt(n / nt) if se is not None and n and nt else se)
    if m is None or not kt:
        return ""
    return (f"; kT against the mean energy: smallest detectable difference {fmt(m, 2)} "
            f"mm^2/s^2 ({fmt(100 * m / kt, 2)} % of kT; the rule allows 10 %)")  # fmt: skip


def _set_gap(rob: Mapping[str, Any]) -> tuple[float | None, float | None]:
    """The robots' set temperature difference and the smallest the sample detects."""
    hot, cold = rob.get("kT_hot"), rob.get("kT_cold")
    return (hot - cold if hot is not None and cold is not None else None), _kt_gap_mde(rob)


def _gas_row(gas: Mapping[str, Any], nb: Any) -> dict[str, str]:
    """The elastic gas: one exponential at its mean energy (Maxwell-Boltzmann)."""
    pref = gas.get("preferred")
    kt, mean = gas.get("one_phase_kT"), gas.get("mean_energy_per_particle")
    rel = abs(kt / mean - 1) if kt and mean else None
    ok = pref == "one_phase" and rel is not None and rel < 0.1
    return _row(
        "physical particles: one exponential at kT",
        "Discussion table: p(v^2) = exp(-v^2/E)/E with E = kT (the Boltzmann law)",
        f"{pref or 'n/a'} preferred (LR {_p(gas.get('lr_p_value'), nb)}); "
        f"kT = {fmt(kt)} mm^2/s^2 "
        f"against the mean energy per particle {fmt(mean)} mm^2/s^2",
        (REPRODUCED if ok else DIFFERS) if pref else NOT_MEASURED,
        "rule: one phase preferred and kT within 10 % of the mean energy; "
        + _lr_power(gas, nb)
        + _kt_power(gas)
        + (
            ""
            if ok or not pref
            else "; a short record of a small gas is correlated across particles, so the "
            "bootstrap p-values are too small (see the analysis docs)"
        )
        + _command(gas),
    )


def _robot_row(rob: Mapping[str, Any], nb: Any) -> dict[str, str]:
    """The robots of Algorithm 5: two phases at the temperatures their light sets."""
    pref = rob.get("preferred")
    tp = rob.get("two_phase") or {}
    ks = rob.get("ks_p_value_preferred")
    fits = ks is not None and ks > 0.05
    ok = pref == "two_phase" and fits
    reasons = []
    gap, m = _set_gap(rob)
    if pref != "two_phase":
        reasons.append("the test could not tell two phases from one in this sample"
                       + (f": the set temperatures differ by {fmt(gap, 2)} mm^2/s^2, less "
                          f"than the {fmt(m, 2)} it detects" if gap is not None and m is not
                          None and gap < m else ""))  # fmt: skip
    elif not fits:
        reasons.append(
            f"two phases preferred, but the KS test rejects two exponentials "
            f"({_p(ks, nb)}): collisions and walls reshape the hot phase's speeds"
        )
    hot, kt2 = rob.get("kT_hot"), tp.get("kT2")
    if ok and hot and kt2 and kt2 < 0.9 * hot:  # beyond the fit's noise
        reasons.append(
            "the fitted hot temperature sits below the set one: robots stalled by "
            "collisions and walls move slower than they command"
        )
    why_robots = "; ".join(reasons) or "two phases, as set"
    weak = _powerless(nb) or (gap is not None and m is not None and gap < m)
    if not pref:
        verdict = NOT_MEASURED
    elif ok or pref == "two_phase":
        verdict = REPRODUCED if ok else PARTLY
    else:  # one phase: no power to see the set gap, or it should have been seen
        verdict = NOT_RESOLVED if weak else DIFFERS
    return _row(
        "robots of Algorithm 5: two temperatures switched by light",
        "Discussion table: p(v^2) = exp(-v^2/E(x))/E(x), E(x) set by the light; Fig. 5: "
        "gas-like and liquid-like robots",
        f"{pref or 'n/a'} preferred (LR {_p(rob.get('lr_p_value'), nb)}); fitted kT1 = "
        f"{fmt(tp.get('kT1'))}, kT2 = {fmt(tp.get('kT2'))} mm^2/s^2; set "
        f"{fmt(rob.get('kT_cold'))} and {fmt(rob.get('kT_hot'))} mm^2/s^2; KS "
        f"{_p(ks, nb)}",
        verdict,
        (f"{_powerless(nb)}; " if pref and not ok and _powerless(nb) else "")
        + why_robots
        + (
            "; rule: two phases preferred and the two-phase fit not rejected (KS p > "
            "0.05); " + _lr_power(rob, nb)
            if pref
            else ""
        )
        + _command(rob),
    )


def compare_unified_law(res: Mapping[str, Any]) -> list[dict[str, str]]:
    nb = next((s.get("n_bootstrap") for s in res.values() if isinstance(s, Mapping)), None)
    rows = [
        _ant_row(_get(res, "ants_real") or {}, nb, real=True),
        _ant_row(_get(res, "ants") or {}, nb, real=False),
    ]
    for key, who in (("ants_real", "real"), ("ants", "synthetic control")):
        if (_get(res, key) or {}).get("steering"):
            rows.extend(_steering_rows(_get(res, key), who))
    rows.append(_gas_row(_get(res, "gas") or {}, nb))
    rows.append(_robot_row(_get(res, "robots") or {}, nb))
    return rows
