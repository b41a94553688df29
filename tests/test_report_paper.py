"""The verdicts beside the paper follow their stated rules, and never fail on a gap."""

from __future__ import annotations

import pytest

from thermoswarm.report.paper import COMPARISONS, compare, fmt, summary_verdict


def _verdicts(name, res):
    return [r["verdict"] for r in compare(name, res)]


@pytest.mark.parametrize("name", sorted(COMPARISONS))
def test_missing_results_are_not_measured_never_an_error(name):
    rows = compare(name, {})
    assert rows and all(set(r) == {"claim", "paper", "ours", "verdict", "why"} for r in rows)
    assert summary_verdict(rows) in ("not measured", "differs")


def test_transport_free_reached_partly_and_differs():
    base = {"seeds": 3, "duration_s": 600, "n": 1200, "displacement_toward_target_mean": 90.0,
            "displacement_toward_target_se": 20.0}  # fmt: skip
    reached = {"default": {**base, "time_to_target": [100.0, 200.0, 300.0], "mean_over_se": 4.5}}
    moving = {"default": {**base, "time_to_target": [None, 250.0, None], "mean_over_se": 4.5}}
    still = {"default": {**base, "time_to_target": [None] * 3, "mean_over_se": 1.2}}
    assert _verdicts("transport_free", reached)[0] == "reproduced"
    assert _verdicts("transport_free", moving)[0] == "partly"
    assert "1 of 3 runs reached" in compare("transport_free", moving)[0]["why"]
    assert _verdicts("transport_free", still)[0] == "differs"


def test_mechanism_rows_per_reading_of_algorithm_5():
    rows = [
        {"mapping": m, "heading_law": h, "sensor.mode": s, "disp_mean": d, "disp_se": 5.0,
         "verdict": v}
        for m, h, s, d, v in [
            ("lit_cold", "persistent", "ideal", 30.0, "toward target"),
            ("lit_cold", "persistent", "photoresistor", 10.0, "no detectable motion"),
            ("lit_cold", "uniform", "ideal", 1.0, "no detectable motion"),
            ("lit_cold", "uniform", "photoresistor", 0.0, "no detectable motion"),
            ("lit_hot", "uniform", "ideal", -40.0, "away from target"),
            ("lit_hot", "uniform", "photoresistor", -30.0, "away from target"),
            ("lit_hot", "persistent", "ideal", 20.0, "toward target"),
            ("lit_hot", "persistent", "photoresistor", 25.0, "toward target"),
        ]
    ]  # fmt: skip
    out = {r["claim"]: r for r in compare("mechanism", {"rows": rows})}
    as_written = next(r for c, r in out.items() if c.startswith("Algorithm 5 as written"))
    captioned = next(r for c, r in out.items() if c.startswith("Algorithm 5 as captioned"))
    default = next(r for c, r in out.items() if "our default" in c)
    other = next(r for c, r in out.items() if "captions' mapping with persistent" in c)
    assert as_written["verdict"] == "differs" and "no motion" in as_written["why"]
    assert captioned["verdict"] == "differs" and "away" in captioned["why"]
    assert default["verdict"] == "partly" and other["verdict"] == "reproduced"


def test_scaling_trend_and_the_empty_panel_v():
    rows = [{"n": n, "maxdisp_mean": m, "reached": 0, "seeds": 5} for n, m in
            [(50, 10.0), (200, 20.0), (1200, 80.0)]]  # fmt: skip
    up = {"rows": rows, "trend": {"spearman_rho": 0.7, "spearman_p": 0.001}}
    flat = {"rows": rows, "trend": {"spearman_rho": 0.2, "spearman_p": 0.39}}
    assert _verdicts("scaling", up) == ["reproduced", "not measured"]
    assert summary_verdict(compare("scaling", up)) == "partly"
    assert _verdicts("scaling", flat)[0] == "differs"
    timed = [dict(r, reached=5, time_median=t) for r, t in zip(rows, [900, 500, 200],
                                                                  strict=True)]  # fmt: skip
    assert _verdicts("scaling", {"rows": timed, "trend": up["trend"]})[1] == "reproduced"


def test_unified_law_rules_and_the_bootstrap_floor():
    ants = {
        "preferred": "two_phase",
        "lr_p_value": 0.005,
        "ks_p_value_preferred": 0.4,
        "two_phase": {"phi": 0.4, "kT1": 30.0, "kT2": 300.0},
        "n_bootstrap": 200,
    }
    gas = {
        "preferred": "one_phase",
        "lr_p_value": 0.3,
        "one_phase_kT": 64.6,
        "mean_energy_per_particle": 64.8,
        "n_bootstrap": 200,
    }
    robots = {"preferred": "two_phase", "lr_p_value": 0.005, "ks_p_value_preferred": 0.005,
              "two_phase": {"kT1": 5.0, "kT2": 110.0}, "kT_hot": 143.0, "kT_cold": 5.7,
              "n_bootstrap": 200}  # fmt: skip
    rows = compare("unified_law", {"ants": ants, "gas": gas, "robots": robots})
    assert [r["verdict"] for r in rows] == ["reproduced", "reproduced", "partly"]
    assert "p <= 0.005" in rows[0]["ours"] and "KS test rejects" in rows[2]["why"]
    hot_gas = dict(gas, one_phase_kT=90.0)
    assert compare("unified_law", {"gas": hot_gas})[1]["verdict"] == "differs"


def test_numbers_read_as_numbers():
    assert fmt(5600.0, unit="s") == "5,600 s" and fmt(0.012345) == "0.0123"
    assert fmt(None) == "\u2013" and fmt(float("nan")) == "\u2013" and fmt(1200) == "1,200"
