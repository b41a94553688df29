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

__all__ = ["compare_unified_law"]


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
        (REPRODUCED if ok else NOT_RESOLVED if _powerless(nb) else DIFFERS)
        if pref
        else NOT_MEASURED,
        (f"{_powerless(nb)}; " if pref and not ok and _powerless(nb) else "")
        + why
        + what
        + _command(ants),
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
        "test sample, its n in fits.json)" + _command(ants),
    )
    slope, p = st.get("slope"), st.get("p_value")
    falls = slope is not None and slope < 0 and p is not None and p < 0.05
    trend = _row(
        f"ants ({who}): the steering temperature falls with speed",
        "Fig. 3 (i): T_theta decreases with the ants' average speed (energy level)",
        f"slope {fmt(slope)} per energy unit, {_p(p)}; Spearman rho {fmt(st.get('spearman_rho'))}",
        (REPRODUCED if falls else DIFFERS) if slope is not None else NOT_MEASURED,
        "rule: weighted least-squares slope of T_theta against the bins' mean energy, "
        f"negative with t-test p < 0.05 over {fmt(k)} bins" + _command(ants),
    )
    return [law, trend]


def compare_unified_law(res: Mapping[str, Any]) -> list[dict[str, str]]:
    nb = next((s.get("n_bootstrap") for s in res.values() if isinstance(s, Mapping)), None)
    rows = [
        _ant_row(_get(res, "ants_real") or {}, nb, real=True),
        _ant_row(_get(res, "ants") or {}, nb, real=False),
    ]
    for key, who in (("ants_real", "real"), ("ants", "synthetic control")):
        if (_get(res, key) or {}).get("steering"):
            rows.extend(_steering_rows(_get(res, key), who))
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
            )
            + _command(gas),
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
    if ok and hot and kt2 and kt2 < 0.9 * hot:  # beyond the fit's noise
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
            (
                REPRODUCED
                if ok
                else PARTLY
                if pref == "two_phase"
                else NOT_RESOLVED
                if _powerless(nb)
                else DIFFERS
            )
            if pref
            else NOT_MEASURED,
            (f"{_powerless(nb)}; " if pref and not ok and _powerless(nb) else "")
            + why_robots
            + _command(rob),
        )
    )
    return rows
