"""Statistics that explain themselves: p-values at their resolution, trends only when
their test rejects, one-line reasons for departures from theory."""

from __future__ import annotations

import pytest

from thermoswarm.analysis.explain import (
    explain_diffusion,
    explain_phases,
    format_p_value,
    trend_statement,
)


def test_p_value_at_the_bootstrap_floor_is_an_upper_bound():
    assert format_p_value(1 / 200, 199) == "< 0.005"
    assert format_p_value(2 / 200, 199) == "0.01"
    assert format_p_value(None, 199) == "n/a"
    assert format_p_value(float("nan")) == "n/a"
    assert format_p_value(0.0312) == "0.031"


@pytest.mark.parametrize(("p", "said"), [(0.39, "no significant trend"), (0.004, "decreasing")])
def test_a_direction_only_when_the_test_rejects(p, said):
    trend = {"slope": -0.01, "p_value": p, "alpha": 0.05, "k": 8,
             "direction": "decreasing" if p < 0.05 else None}  # fmt: skip
    text = trend_statement(trend)
    assert said in text
    if p >= 0.05:
        assert "decreasing" not in text


def test_two_phases_in_a_one_temperature_box_are_explained_by_collisions():
    block = {"preferred": "two_phase", "two_phase": {"kT1": 2.0, "kT2": 40.0}}
    assert "collisions stall robots" in explain_phases(block, one_temperature=True)
    assert "resting" in explain_phases(block, rest_speed=3.0)  # rms sqrt(4) = 2 mm/s
    assert explain_phases({"preferred": "one_phase"}) is None
    # a cold phase 17 times slower (kT 300 times lower): pausing or jitter, not walking
    far = {"preferred": "two_phase", "two_phase": {"kT1": 0.03, "kT2": 9.0}}
    assert "far slower" in explain_phases(far)
    near = {"preferred": "two_phase", "two_phase": {"kT1": 20.0, "kT2": 80.0}}
    assert "two modes of motion" in explain_phases(near)


def test_diffusion_below_theory_names_collisions_and_walls():
    assert "collisions and walls" in explain_diffusion(25.0, 31.8)
    assert "agrees" in explain_diffusion(31.0, 31.8)
    assert "persist" in explain_diffusion(40.0, 31.8)
