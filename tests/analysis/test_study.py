"""The study on synthetic tracks from known laws: the paper's statistics are recovered."""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr
from analysis_helpers import MIXTURE, STEER_T

from thermoswarm.analysis.region_stats import high_T_fraction
from thermoswarm.analysis.regions import regions_from_mapping
from thermoswarm.analysis.study import analyze_tracks, run_study
from thermoswarm.analysis.synthetic import synthetic_tracks
from thermoswarm.errors import ConfigError
from thermoswarm.fsutil import dumps_json
from thermoswarm.io import write_tracks
from thermoswarm.maxent import EnergyLaw, EnergyMixture
from thermoswarm.report.analysis_run import analyze_file
from thermoswarm.tracks import make_tracks

HALVES = regions_from_mapping(
    {
        "region": [
            {"name": "west", "rect": [-1e6, -1e6, 0, 1e6]},
            {"name": "east", "rect": [0, -1e6, 1e6, 1e6]},
        ]
    }
)


def within(est, truth, se, k=3.0):
    return abs(est - truth) < k * se


def test_two_phase_tracks_recover_the_laws(two_phase_tracks):
    ds, truth = two_phase_tracks
    res = run_study(ds, n_bootstrap=49, seed=1)
    fits = res.fits
    e = fits["energy"]
    assert fits["n_tracks"] == 40 and fits["n_samples"] == 40 * 300
    two = e["two_phase"]
    assert within(two["phi"], MIXTURE.phi, two["phi_se"])
    assert within(two["kT1"], MIXTURE.kT1, two["kT1_se"])
    assert within(two["kT2"], MIXTURE.kT2, two["kT2_se"])
    assert e["preferred"] == "two_phase" and e["lr_p_value"] < 0.05
    assert e["one_phase"]["p_value"] < 0.05  # one exponential is rejected...
    assert e["two_phase"]["p_value"] > 0.05  # ...two are not
    assert e["test_sample"]["thinning_step"] == 1  # independent steps

    # steering: per bin, kT_theta is the bin's mean of T(v) (|w| has mean T(v))
    kin = res.kinematics
    speed = kin["speed"].values
    energy = kin["energy"].values
    mag = np.abs(kin["steering_rate"].values)
    ok = kin["steering_valid"].values
    st = fits["steering"]
    assert len(st["bins"]) == 8 and st["by"] == "energy"
    total = 0
    for k, b in enumerate(st["bins"]):
        last = k == len(st["bins"]) - 1
        m = ok & (energy >= b["low"]) & ((energy <= b["high"]) if last else (energy < b["high"]))
        total += m.sum()
        assert b["n_fit"] == m.sum()
        expected = STEER_T(speed[m]).mean()
        se = mag[m].std() / np.sqrt(m.sum())
        assert within(b["kT_theta"], expected, se), (k, b["kT_theta"], expected, se)
        assert b["energy_center"] == pytest.approx(energy[m].mean())
        assert b["sign_p_value"] > 0.001  # signs are fair coins
    assert total == ok.sum()
    centers = [b["energy_center"] for b in st["bins"]]
    assert centers == sorted(centers)
    tr = st["trend"]
    assert tr["direction"] == "decreasing" and tr["slope"] < 0 and tr["p_value"] < 0.05
    assert tr["spearman_rho"] == pytest.approx(-1.0)
    assert tr["spearman_p_value"] == pytest.approx(2 / 40320)  # exact, 8 bins


def test_one_phase_tracks_prefer_one_phase(one_phase_tracks):
    ds, _ = one_phase_tracks
    e = analyze_tracks(ds, n_bootstrap=49, seed=2)["energy"]
    assert e["preferred"] == "one_phase"
    assert e["lr_p_value"] > 0.05 and e["one_phase"]["p_value"] > 0.05
    assert within(e["one_phase"]["kT"], 35.0, e["one_phase"]["kT_se"])


def test_fits_json_has_the_documented_keys(two_phase_tracks):
    ds, _ = two_phase_tracks
    fits = json.loads(dumps_json(analyze_tracks(ds, n_bootstrap=9, test_size=2000)))
    for key in ("n_tracks", "n_samples", "energy", "steering", "groups", "regions",
                "data_quality", "settings", "units"):  # fmt: skip
        assert key in fits
    e = fits["energy"]
    assert {"kT", "ks", "p_value", "n"} <= set(e["one_phase"])
    assert {"phi", "kT1", "kT2", "ks", "p_value", "n"} <= set(e["two_phase"])
    assert e["preferred"] in ("one_phase", "two_phase")
    assert "lr_p_value" in e
    assert e["one_phase"]["n"] == 2000 == e["lr_n"]  # the test sample's size
    for b in fits["steering"]["bins"]:
        assert {"energy_center", "kT_theta", "ks", "p_value", "n"} <= set(b)
    assert {"slope", "p_value"} <= set(fits["steering"]["trend"])
    assert fits["units"]["energy"] == "mm^2/s^2"


def test_regions_hot_fraction_and_its_test():
    law_w = EnergyMixture(0.7, 20.0, 80.0)  # hot fraction 0.3
    law_e = EnergyMixture(0.4, 20.0, 80.0)  # hot fraction 0.6
    n = 25
    dw, _ = synthetic_tracks(n, 301, energy=law_w, fps=25.0, rng=21,
                             start=np.tile([-1e5, 0.0], (n, 1)))  # fmt: skip
    de, _ = synthetic_tracks(n, 301, energy=law_e, fps=25.0, rng=22,
                             start=np.tile([1e5, 0.0], (n, 1)))  # fmt: skip
    pos = np.concatenate([dw["position"].values, de["position"].values], axis=-1)
    ds = make_tracks(pos, fps=25.0)
    reg = run_study(ds, regions=HALVES, n_bootstrap=200, test_size=1000, seed=3).fits["regions"]
    west, east = reg["levels"]["west"], reg["levels"]["east"]
    assert west["n_tracks"] == n and east["n_tracks"] == n
    assert within(west["high_T_fraction"], 0.3, west["se"])
    assert within(east["high_T_fraction"], 0.6, east["se"])
    assert west["ci_low"] < west["high_T_fraction"] < west["ci_high"]
    (d,) = reg["differences"]
    assert (d["a"], d["b"]) == ("west", "east")
    assert d["difference"] < 0 and d["p_value"] < 0.05
    assert reg["bootstrap"]["clusters"] == "tracks"


def test_regions_with_equal_fractions_are_not_different(two_phase_tracks):
    ds, _ = two_phase_tracks
    reg = analyze_tracks(ds, regions=HALVES, n_bootstrap=200, test_size=1000, seed=4)["regions"]
    (d,) = reg["differences"]
    assert d["p_value"] > 0.05
    assert within(reg["levels"]["west"]["high_T_fraction"], 1 - MIXTURE.phi,
                  reg["levels"]["west"]["se"])  # fmt: skip


def test_groups_by_variable_and_time():
    da, _ = synthetic_tracks(10, 201, energy=EnergyLaw(20.0), fps=25.0, rng=31)
    db, _ = synthetic_tracks(10, 201, energy=EnergyLaw(60.0), fps=25.0, rng=32)
    pos = np.concatenate([da["position"].values, db["position"].values], axis=-1)
    ds = make_tracks(pos, fps=25.0)
    ds["condition"] = ("individuals", np.array(["cold"] * 10 + ["hot"] * 10))
    fits = analyze_tracks(ds, group_by=["condition", "time:3"], n_bootstrap=39, seed=5)
    g = fits["groups"]["condition"]
    assert g["kind"] == "variable" and list(g["levels"]) == ["cold", "hot"]
    for label, kT in (("cold", 20.0), ("hot", 60.0)):
        one = g["levels"][label]["one_phase"]
        assert within(one["kT"], kT, one["kT_se"])
        assert g["levels"][label]["n_tracks"] == 10
    assert fits["energy"]["preferred"] == "two_phase"  # the pooled energies
    kc = g["ks_comparison"]
    assert kc["labels"] == ["cold", "hot"] and kc["p_value"] is not None
    t = fits["groups"]["time:3"]
    assert list(t["levels"]) == ["0-3 s", "3-6 s", "6-9 s"]
    assert sum(lv["n"] for lv in t["levels"].values()) == fits["n_samples"]


def test_thinning_follows_the_autocorrelation_time():
    """Positions upsampled 5x repeat each step's velocity 5 times: rho(5) = 0, tau = 5."""
    coarse, _ = synthetic_tracks(20, 201, energy=EnergyLaw(30.0), fps=5.0, rng=41)
    t_c = coarse["time"].values
    t_f = np.arange(0, len(t_c) * 5 - 4) / 25.0
    pos = coarse["position"].values
    fine = np.empty((t_f.size, 2, 1, 20))
    for i in range(20):
        for d in range(2):
            fine[:, d, 0, i] = np.interp(t_f, t_c, pos[:, d, 0, i])
    ds = make_tracks(fine[:, :, 0, :], fps=25.0)
    e = analyze_tracks(ds, n_bootstrap=19, seed=6)["energy"]
    ts = e["test_sample"]
    assert ts["decorrelation_lag"] == 5 == ts["thinning_step"]
    assert 3.5 < ts["tau_int"] < 5.5  # biased low on short tracks (see sampling's docstring)
    assert ts["n"] == pytest.approx(ts["n_available"] / 5, abs=20)
    assert e["one_phase"]["n"] == ts["n"]


def test_mass_gives_joules_and_same_phases(two_phase_tracks):
    ds, _ = two_phase_tracks
    per_mass = analyze_tracks(ds, n_bootstrap=0)
    joules = analyze_tracks(ds, n_bootstrap=0, mass=1e-5)
    assert joules["units"]["energy"] == "J"
    for k in ("kT1", "kT2"):
        assert joules["energy"]["two_phase"][k] == pytest.approx(
            per_mass["energy"]["two_phase"][k] * 1e-5 * 1e-6, rel=1e-7
        )
    assert joules["energy"]["two_phase"]["phi"] == pytest.approx(
        per_mass["energy"]["two_phase"]["phi"], rel=1e-7
    )


def test_same_seed_same_output(two_phase_tracks):
    ds, _ = two_phase_tracks
    opts = {"n_bootstrap": 19, "test_size": 3000, "regions": HALVES, "group_by": ["time:6"]}
    a = dumps_json(analyze_tracks(ds, seed=7, **opts))
    b = dumps_json(analyze_tracks(ds, seed=7, **opts))
    assert a == b
    c = json.loads(dumps_json(analyze_tracks(ds, seed=8, **opts)))
    # estimates do not depend on the seed (only the tests' random draws do)
    assert c["energy"]["two_phase"]["kT2"] == pytest.approx(
        json.loads(a)["energy"]["two_phase"]["kT2"], rel=1e-6
    )


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"group_by": ["region"]}, "needs --regions"),
        ({"group_by": ["time:0"]}, "number of seconds from"),
        ({"group_by": ["nothing"]}, "no such data variable"),
        ({"energy_bins": "a,b"}, "edges must be numbers"),
        ({"energy_bins": 0}, "from 1 to"),
        ({"energy_bins": [3, 1]}, "must increase"),
        ({"n_bootstrap": -1}, "n_bootstrap"),
        ({"thin": 0}, "thin"),
        ({"alpha": 2}, "alpha"),
        ({"smoothing": 1}, "unknown analysis option 'smoothing'"),
        ({"steering_by": "heading"}, "steering_by"),
    ],
)
def test_bad_options_are_config_errors(kwargs, match):
    ds = make_tracks(np.random.default_rng(0).normal(size=(30, 2, 3)).cumsum(0), fps=10.0)
    with pytest.raises(ConfigError, match=match):
        analyze_tracks(ds, n_bootstrap=kwargs.pop("n_bootstrap", 0), **kwargs)


def test_group_variable_must_be_categorical():
    ds = make_tracks(np.random.default_rng(0).normal(size=(200, 2, 3)).cumsum(0), fps=10.0)
    ds["noise"] = (("time", "individuals"), np.random.default_rng(1).normal(size=(200, 3)))
    with pytest.raises(ConfigError, match="distinct values"):
        analyze_tracks(ds, group_by=["noise"], n_bootstrap=0)
    ds["bad"] = (("space",), np.array([1.0, 2.0]))
    with pytest.raises(ConfigError, match="dims"):
        analyze_tracks(ds, group_by=["bad"], n_bootstrap=0)


def test_too_few_samples_are_reported_not_fitted():
    ds = make_tracks(np.random.default_rng(0).normal(size=(6, 2, 2)).cumsum(0), fps=10.0)
    fits = analyze_tracks(ds, n_bootstrap=9)
    assert "skipped" in fits["energy"] and "skipped" in fits["steering"]


def test_analyze_file_writes_three_outputs(tmp_path, two_phase_tracks):
    ds, _ = two_phase_tracks
    src = tmp_path / "tracks.nc"
    write_tracks(ds, src)
    regions = tmp_path / "regions.toml"
    regions.write_text('[[region]]\nname = "all"\nrect = [-1e6, -1e6, 1e6, 1e6]\n')
    out = tmp_path / "out"
    res = analyze_file(src, out, regions=regions, n_bootstrap=9, test_size=2000)
    fits = json.loads((out / "fits.json").read_text())
    assert fits == json.loads(dumps_json(res.fits))
    assert fits["settings"]["regions"] == str(regions)
    with xr.open_dataset(out / "kinematics.nc", engine="h5netcdf") as kin:
        assert {"speed", "energy", "heading", "steering_rate", "valid", "region"} <= set(kin)
        assert kin.attrs["n_steps_used"] == fits["n_samples"]
        np.testing.assert_allclose(
            kin["energy"].values, res.kinematics["energy"].values.astype(np.float32)
        )
    html = (out / "report.html").read_text()
    assert html.startswith("<!DOCTYPE html>") and "data:image/png;base64," in html
    assert 'src="http' not in html and "<link" not in html  # self-contained
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no temporaries left


def test_high_T_fraction_with_fixed_temperatures():
    rng = np.random.default_rng(50)
    x = EnergyMixture(0.7, 20.0, 80.0).sample(rng, 5000)
    w, se = high_T_fraction(x, 20.0, 80.0)
    assert within(w, 0.3, se)
    assert se == pytest.approx(np.sqrt(0.3 * 0.7 / 5000), rel=1.0)  # same order as binomial
    assert high_T_fraction(np.full(100, 1e-3), 20.0, 80.0)[0] == 0.0  # all cold-looking
    assert high_T_fraction(np.full(100, 1e3), 20.0, 80.0)[0] == 1.0  # all hot-looking


def test_few_tracks_are_cut_into_time_blocks_for_the_bootstrap():
    ds, _ = synthetic_tracks(2, 2001, energy=MIXTURE, fps=25.0, rng=51)
    reg = analyze_tracks(ds, regions=HALVES, n_bootstrap=50, test_size=500, seed=1)["regions"]
    assert reg["bootstrap"]["clusters"].startswith("10 contiguous time blocks of each of 2")
    present = [lv for lv in reg["levels"].values() if lv.get("high_T_fraction") is not None]
    assert present and all(lv["se"] > 0 for lv in present)
