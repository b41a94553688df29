"""The engine's elastic gas, analysed like ants: one-phase exponential at its kT."""

from __future__ import annotations

import math

import xarray as xr

from thermoswarm.analysis.study import analyze_tracks
from thermoswarm.scenarios import runner


def test_inertial_gas_energy_is_one_phase_exponential_at_the_mean_energy(tmp_path):
    # frames at every step keep the finite-difference speeds exact between collisions
    # (a frame that contains a collision averages two velocities: ~0.5 % of frames here)
    sets = [
        "mode='inertial'",
        "n=300",
        "packing_fraction=0.1",
        "duration=60",
        "engine.dt=0.05",
        "record.interval=0.05",
    ]
    metrics = runner.run(
        runner.resolve("box", overrides=sets, seed=1), tmp_path / "gas", progress=False
    )
    assert metrics["collisions_per_particle"] > 5  # a gas, not free flight
    mean_energy = metrics["energy_final"] / 300  # per particle, per unit mass: kT in 2D
    # from positions, like ants (the default fits a simulation's recorded speeds)
    fits = analyze_tracks(xr.open_dataset(tmp_path / "gas" / "tracks.nc"), seed=0,
                          speed_source="positions")  # fmt: skip
    energy = fits["energy"]
    assert energy["preferred"] == "one_phase"
    one = energy["one_phase"]
    assert one["p_value"] > 0.01  # the exponential law is not rejected (bootstrap KS)
    # frames are correlated: the error bar comes from the effective sample of the tests
    se = one["kT"] / math.sqrt(one["n"])
    assert abs(one["kT"] - mean_energy) < 4 * se, (one["kT"], mean_energy, se)
    assert 4 * se < 0.1 * mean_energy  # the check means something
