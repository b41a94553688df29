"""Simulate, then analyse with the defaults: the law the robots draw from comes back.

Issue 33: ``simulate box`` then ``analyze`` reported two phases for robots that all draw
their speed from one exponential law, because the recording sampled at the control
period (each displacement mixed two commanded velocities) and, in a crowd, contacts
slow the robots.  Now the box records every engine step, a simulation's recorded speeds
are what ``analyze`` fits by default (``--speed-source auto``), and ``analyze`` warns
when the sampling does not resolve the control period.

Every case runs the scenario's defaults except size (robots, seconds) and packing,
then :func:`analyze_file` with the defaults (200 bootstrap replicates, alpha 0.05).
Each case has its own seed.  The verdicts are tests at the 5 % level, so a correct
pipeline misses in about 1 case of 20: over K cases at most ``_allowed(K)`` misses are
accepted, the count a correct pipeline exceeds with probability under 1 %.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy import stats

from thermoswarm.io import read_tracks
from thermoswarm.report.analysis_run import analyze_file
from thermoswarm.scenarios.runner import resolve, run

#: (packing fraction, seed) of the overdamped robots, fast and slow grids.
FAST = [(0.02, 11), (0.1, 12), (0.3, 13), (0.5, 14)]
SLOW = [(p, 20 + i) for i, p in enumerate((0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5))]
#: Robots and simulated seconds of a case: 100 x 40 s is 4,000 speed draws (one per
#: robot per 1 s control period): the kT interval's half width is about 3 %.
SMALL = ("n=100", "duration=40")
LARGE = ("n=300", "duration=60")


def _allowed(k: int, level: float = 0.05) -> int:
    """Most misses of K tests at ``level`` that a correct pipeline exceeds with
    probability below 1 %."""
    return int(stats.binom.ppf(0.99, k, level))


def _case(root: Path, scenario: str, over: tuple[str, ...], seed: int) -> dict[str, Any]:
    """Simulate, analyse with defaults; the fits, the params and the recording."""
    out = root / f"{scenario}-{seed}"
    cfg = resolve(scenario, overrides=list(over), seed=seed)
    run(cfg, out / "run", progress=False)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = analyze_file(out / "run" / "tracks.nc", out / "res", report=False)
    ds = read_tracks(out / "run" / "tracks.nc")
    return {"fits": result.fits, "params": cfg.params, "tracks": ds,
            "warnings": [str(w.message) for w in caught]}  # fmt: skip


def _robots(root: Path, grid: list[tuple[float, int]], size: tuple[str, ...]) -> list[dict]:
    return [_case(root, "box", (*size, f"packing_fraction={p}"), s) for p, s in grid]


@pytest.fixture(scope="module")
def robots(tmp_path_factory: pytest.TempPathFactory) -> list[dict[str, Any]]:
    return _robots(tmp_path_factory.mktemp("robots"), FAST, SMALL)


def _check_one_phase_law(cases: list[dict[str, Any]]) -> None:
    n = len(cases)
    wrong_phase = [c for c in cases if c["fits"]["energy"]["preferred"] != "one_phase"]
    missed = []
    for c in cases:
        one = c["fits"]["energy"]["one_phase"]
        lo, hi = one["kT_ci"]
        # the interval has power: narrower than 10 % of the law's kT either side
        assert hi - lo < 0.2 * c["params"].kT
        if not lo <= c["params"].kT <= hi:
            missed.append(c)
        rec = c["fits"]["recording"]
        assert rec["speed_source"] == "recorded" and rec["speed_kind"] == "commanded"
        assert rec["mixed_step_fraction"] == pytest.approx(0.1) and rec["warning"] is None
    assert len(wrong_phase) <= _allowed(n), [c["fits"]["energy"]["lr_p_value"] for c in cases]
    # the commanded heading is uniform and independent of the speed: no steering trend
    trend = [c["fits"]["steering"]["trend"].get("p_value") for c in cases]
    assert sum(p is not None and p < 0.05 for p in trend) <= _allowed(n), trend
    assert len(missed) <= _allowed(n), [c["fits"]["energy"]["one_phase"] for c in missed]


def test_box_robots_one_phase_and_their_kT_at_packings_002_to_05(robots):
    _check_one_phase_law(robots)


def test_crowding_shows_in_the_realized_speeds_not_in_the_law(robots):
    """From positions, contacts slow the robots more the denser the box: the recording
    block says by how much, while the fitted law stays the commanded one."""
    ratio = [c["fits"]["recording"]["realized_to_recorded_energy"] for c in robots]
    slowed = [c["fits"]["recording"]["slowed_fraction"] for c in robots]
    assert ratio[0] > 0.9 and ratio[-1] < 0.85  # packing 0.02 vs 0.5
    assert slowed == sorted(slowed)


def test_sampling_at_the_control_period_is_warned_and_would_mislabel(tmp_path):
    """The issue's recording (interval = control period): analyze warns, and the speeds
    from positions (the old default) give two phases for a one-phase law."""
    over = (*SMALL, "packing_fraction=0.3", "record.interval=1.0")
    c = _case(tmp_path, "box", over, 7)
    rec = c["fits"]["recording"]
    assert rec["mixed_step_fraction"] == 1.0 and rec["control_period_s"] == 1.0
    assert any("control period" in w and "record.interval=0.1" in w for w in c["warnings"])
    assert c["fits"]["energy"]["preferred"] == "one_phase"  # recorded speeds: the law
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the same warning, checked above
        res = analyze_file(tmp_path / "box-7" / "run" / "tracks.nc", tmp_path / "pos",
                           speed_source="positions", report=False)  # fmt: skip
    assert res.fits["energy"]["preferred"] == "two_phase"
    assert res.fits["energy"]["lr_p_value"] < 0.05


def test_a_gas_keeps_one_phase_at_its_energy_per_particle(tmp_path):
    """Elastic particles: the recorded speeds are instantaneous; the law is one
    exponential at the energy per particle (conserved: the fit's kT is that energy)."""
    c = _case(tmp_path, "box", ("mode=\"inertial\"", "n=100", "duration=20",
                                "packing_fraction=0.3"), 5)  # fmt: skip
    e = c["fits"]["energy"]
    speed0 = c["tracks"]["speed"].values[0].astype(np.float64)
    assert c["fits"]["recording"]["speed_kind"] == "instantaneous"
    assert c["fits"]["recording"]["control_period_s"] is None
    assert e["preferred"] == "one_phase"
    assert e["one_phase"]["kT"] == pytest.approx(0.5 * np.mean(speed0**2), rel=2e-3)


@pytest.mark.slow
def test_two_phase_robots_recover_both_temperatures(tmp_path):
    """Algorithm 5 with two well-separated temperatures and no speed cut: two phases,
    each kT within 4 standard errors of its law (draws per phase from the fitted phi)."""
    kT_cold, kT_hot = 5.73, 143.239
    over = ("n=300", "duration=120", f"kT_hot={kT_hot}", f"kT_cold={kT_cold}", "v_max=1e6")
    c = _case(tmp_path, "transport-free", over, 3)
    two = c["fits"]["energy"]["two_phase"]
    assert c["fits"]["energy"]["preferred"] == "two_phase"
    draws = 300 * 120  # one per robot per 1 s control period
    for kT, w in ((kT_cold, two["phi"]), (kT_hot, 1 - two["phi"])):
        got = two["kT1"] if kT == kT_cold else two["kT2"]
        assert abs(got - kT) < 4 * kT / math.sqrt(max(w * draws, 1))


@pytest.mark.slow
def test_box_robots_larger_grid(tmp_path):
    _check_one_phase_law(_robots(tmp_path, SLOW, LARGE))
