"""compression: the ideal-gas law of a swarm, its measurement, and the sweeps."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from thermoswarm.errors import ConfigError
from thermoswarm.maxent import kT_for_mean_speed
from thermoswarm.scenarios import compression as C
from thermoswarm.scenarios import runner

R = 16.5
D = 2 * R


def _dilute(n, phi, h_free, mean_speed, tau=0.1):
    """Overrides for a swarm of ``n`` robots at packing fraction ``phi`` between walls
    ``h_free + d`` apart, with the force that holds them there if the gas is ideal."""
    kT = kT_for_mean_speed(mean_speed)
    kT_eff = 2 * kT * tau / 4  # <v^2> = 2 kT for Rayleigh speeds
    width = n * math.pi * R * R / phi / (h_free + D)
    force = n * kT_eff / h_free
    return {
        "n": n,
        "width": width,
        "kT": kT,
        "tau": tau,
        "force": force,
        "record": {"interval": 100.0, "netcdf": False},
    }


def _run(tmp_path, name, seed=1, **params):
    sets = []
    for k, v in params.items():
        if isinstance(v, dict):
            sets += [f"{k}.{kk}={json.dumps(vv)}" for kk, vv in v.items()]
        else:
            sets.append(f"{k}={json.dumps(v)}")
    cfg = runner.resolve("compression", overrides=sets, seed=seed)
    return runner.run(cfg, tmp_path / name, progress=False)


# ------------------------------------------------------------------ the claims


def test_dilute_swarm_obeys_the_ideal_gas_law(tmp_path):
    """Packing fraction 0.01, walls pushed by F: P A_free / (n kT_eff) within 5 % of 1.

    Geometry chosen for a short relaxation time: heading re-drawn every step
    (tau = 0.1 s) at mean speed 20 mm/s, so the persistence length <v> tau = 2 mm is
    50 times below the free height (robots piling up at the walls lower Z by about
    that ratio), and t_relax = h^2 / (pi^2 D) ~ 80 s; the run holds 8 batches of
    5 t_relax after settling, so the batch-means error is trustworthy."""
    p = _dilute(n=700, phi=0.01, h_free=100.0, mean_speed=20.0)
    m = _run(tmp_path, "gas", duration=3600.0, **p)
    assert m["packing_fraction"] <= 0.02
    assert m["se_reliable"] and m["n_batches"] >= 8
    assert m["at_limit_fraction"] == 0.0
    # the walls are in force balance: measured pressure = applied F / (Lx - d)
    assert abs(m["pressure"] - m["pressure_applied"]) < 4 * m["pressure_se"]
    # the claim, with an error bar small enough for it to mean something
    assert abs(m["Z"] - 1) < 0.05
    assert 4 * m["Z_se"] < 0.05
    # kT_eff measured from the speeds actually drawn agrees with the law's <v^2> tau / 4
    assert abs(m["kT_eff"] - m["kT_eff_theory"]) < 4 * m["kT_eff_se"] + 1e-12
    assert m["height"] == pytest.approx(m["ideal_height"], rel=0.05)


def test_pressure_is_proportional_to_temperature_at_fixed_density(tmp_path):
    """Held walls (fixed area): P against kT_eff is a line through the origin with
    R^2 > 0.99 and slope n / A_free (the ideal gas)."""
    base = _dilute(n=300, phi=0.01, h_free=100.0, mean_speed=20.0)
    height = 100.0 + D
    rows = []
    for k, v in enumerate((16.0, 20.0, 24.0, 28.0)):
        m = _run(tmp_path, f"T{k}", seed=k, **{**base, "kT": kT_for_mean_speed(v)},
                 walls="held", height=height, duration=1600.0)  # fmt: skip
        assert m["height"] == pytest.approx(height, abs=1e-9)  # the walls did not move
        rows.append((m["kT_eff"], m["pressure"], m["free_area"]))
    kT_eff, P, A_free = (np.array(c) for c in zip(*rows, strict=True))
    fit = C.linear_fit(kT_eff, P)
    assert fit["r2"] > 0.99
    ideal = 300 / A_free[0]
    assert fit["slope0"] == pytest.approx(ideal, rel=0.05)
    # the temperatures span a factor (28/16)^2 ~ 3: a constant pressure would fail R^2
    assert kT_eff.max() / kT_eff.min() > 2.9


# ------------------------------------------------------------------ measurement helpers


def test_place_uniform_spreads_discs_evenly_without_overlap():
    rng = np.random.default_rng(0)
    pos = C.place_uniform((0.0, 100.0, 20_000.0, 233.0), 400, R, rng)
    assert pos[:, 0].min() >= R and pos[:, 0].max() <= 20_000 - R
    assert pos[:, 1].min() >= 100 + R and pos[:, 1].max() <= 233 - R
    from scipy import stats
    from scipy.spatial.distance import pdist

    assert pdist(pos).min() >= D
    # heights uniform between the walls (a lattice row would pile them at one wall)
    assert stats.kstest((pos[:, 1] - 100 - R) / (133 - D), "uniform").pvalue > 1e-3


def test_ideal_height():
    # n kT_eff / F + d: 100 robots at kT_eff 30 mm^2/s pushed by 20 -> 150 mm free height
    assert C.ideal_height(100, 30.0, 20.0, 33.0) == pytest.approx(183.0)


def test_batch_means_weights_and_never_splits_sub_batches():
    x = np.array([1.0, 3.0, 5.0, 7.0, 9.0, 11.0])
    w = np.array([1, 1, 1, 1, 2, 2])
    b = C.batch_means(x, w, 3)
    assert b.tolist() == pytest.approx([2.0, 6.0, 10.0])
    b = C.batch_means(x, np.array([1, 3, 1, 1, 1, 1]), 2)
    assert b.tolist() == pytest.approx([(1 + 9 + 5) / 5, 9.0])
    with pytest.raises(ValueError):
        C.batch_means(x, w, 7)


def test_linear_fit_recovers_a_known_line():
    x = np.array([1.0, 2.0, 3.0, 4.0])
    fit = C.linear_fit(x, 2.5 * x + 1.0)
    assert fit["slope"] == pytest.approx(2.5) and fit["intercept"] == pytest.approx(1.0)
    assert fit["r2"] == pytest.approx(1.0)
    assert fit["slope0"] == pytest.approx((2.5 * 30 + 10) / 30)
    noisy = C.linear_fit(x, np.array([1.0, 3.0, 2.0, 4.0]))
    assert noisy["r2"] == pytest.approx(0.64)  # corr(x, y) = 0.8


def _acc(k, steps, f_top, f_bot, height, v2):
    z = np.zeros(k)
    return {
        "f_top": z + f_top * steps,
        "f_bottom": z + f_bot * steps,
        "height": z + height * steps,
        "v2": z + v2 * steps,
        "steps": np.full(k, steps, np.int64),
        "at_limit": np.zeros(1, np.int64),
    }


def test_measure_on_constant_accumulators():
    """Known forces, height and speeds give the exact pressure, area, kT_eff and Z."""
    n, width, d, tau = 50, 1033.0, 33.0, 1.0
    acc = _acc(k=400, steps=10, f_top=6.0, f_bot=4.0, height=233.0, v2=120.0)
    m = C.measure(acc, sub_steps=10, dt=0.1, n=n, width=width, diameter=d, tau=tau, drag=1.0,
                  settle=0.0, duration=400.0, batch_relaxations=5.0, min_batches=8,
                  expected_D=30.0)  # fmt: skip
    assert m["pressure"] == pytest.approx(5.0 / 1000.0)
    assert m["pressure_top"] == pytest.approx(6.0 / 1000.0)
    assert m["pressure_bottom"] == pytest.approx(4.0 / 1000.0)
    assert m["area"] == pytest.approx(width * 233.0)
    assert m["free_area"] == pytest.approx(1000.0 * 200.0)
    assert m["kT_eff"] == pytest.approx(30.0)
    assert m["Z"] == pytest.approx(0.005 * 200_000 / (50 * 30.0))
    assert m["Z_se"] == pytest.approx(0.0, abs=1e-12)
    # t_relax = 200^2 / (pi^2 30) = 135 s: batches of 5 t_relax do not fit 8 times in
    # 400 s, so 8 shorter batches are used and the error is flagged unreliable
    assert m["t_relax"] == pytest.approx(200**2 / (math.pi**2 * 30.0))
    assert m["n_batches"] == 8 and not m["se_reliable"]
    assert m["window_s"] == pytest.approx(400.0)


def test_measure_leaves_out_the_settling_time_and_sizes_batches():
    acc = _acc(k=1000, steps=10, f_top=5.0, f_bot=5.0, height=63.0, v2=120.0)
    # the first 100 s had another pressure: left out by settle = 100
    acc["f_top"][:100] = 99.0 * 10
    m = C.measure(acc, sub_steps=10, dt=0.1, n=10, width=1033.0, diameter=33.0, tau=1.0,
                  drag=1.0, settle=100.0, duration=1000.0, batch_relaxations=5.0,
                  min_batches=8, expected_D=30.0)  # fmt: skip
    assert m["pressure"] == pytest.approx(5.0 / 1000.0)
    assert m["window_s"] == pytest.approx(900.0)
    # t_relax = 30^2 / (pi^2 30) = 3.04 s -> 900 / 15.2 = 59 batches
    assert m["n_batches"] == int(900 // (5 * 30**2 / (math.pi**2 * 30.0)))
    assert m["se_reliable"]


# ------------------------------------------------------------------ the scenario


def test_scenario_builds_runs_and_balances(tmp_path):
    m = _run(tmp_path, "run", duration=100.0, n=60, width=1500.0)
    for key in ("n", "pressure", "area", "free_area", "packing_fraction", "kT_eff", "Z"):
        assert key in m and m[key] is not None
    assert m["n"] == 60
    assert m["pressure_applied"] == pytest.approx(20.0 / (1500.0 - 33.0))
    assert m["free_area"] == pytest.approx((1500 - 33) * (m["height"] - 33))
    assert m["max_overlap_fraction"] < 0.02
    # both walls feel the robots: forces of the same sign convention (pushed outward)
    assert m["pressure_top"] > 0 and m["pressure_bottom"] > 0
    import xarray as xr

    tr = xr.open_dataset(tmp_path / "run" / "tracks.nc")
    walls = tr["walls"].values  # (time, wall): top above bottom, robots between
    y = tr["position"].isel(keypoints=0).sel(space="y").values
    assert np.all(walls[:, 0] > walls[:, 1])
    assert np.all(y <= walls[:, [0]] - R + 0.7) and np.all(y >= walls[:, [1]] + R - 0.7)


@pytest.mark.parametrize(
    ("key", "value", "named"),
    [
        ("force", -5.0, "force"),
        ("walls", "spring", "walls"),
        ("height", 10.0, "height"),
        ("n", 0, "n"),
        ("width", 40.0, "width"),
        ("min_batches", 1, "min_batches"),
        ("kT", 0.0, "kT"),
    ],
)
def test_bad_config_is_one_line_error_naming_the_key(key, value, named):
    with pytest.raises(ConfigError) as exc:
        runner.resolve("compression", overrides=[f"{key}={json.dumps(value)}"])
    msg = str(exc.value)
    assert named in msg and "\n" not in msg


def test_max_height_below_initial_height_is_rejected():
    with pytest.raises(ConfigError, match="max_height"):
        runner.resolve("compression", overrides=["height=300", "max_height=200"])


def test_too_many_robots_for_the_space_is_a_config_error(tmp_path):
    cfg = runner.resolve("compression", overrides=["n=400", "width=300", "height=60"])
    with pytest.raises(ConfigError, match="cannot place"):
        runner.run(cfg, tmp_path / "x", progress=False)
    assert not (tmp_path / "x").exists()


# ------------------------------------------------------------------ sweeps


def test_plots_draw(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import xarray as xr

    m = _run(tmp_path, "run", duration=30.0, n=30, width=1000.0)
    tr = xr.open_dataset(tmp_path / "run" / "tracks.nc")
    fig, ax = plt.subplots()
    coll = C.plot_frame(ax, tr, 20.0, m["geometry"])
    assert len(coll.get_offsets()) == 30
    plt.close(fig)
