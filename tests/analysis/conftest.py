"""Fixtures of the analysis tests: small synthetic tracks from known laws, fixed seeds."""

from __future__ import annotations

import pytest
from analysis_helpers import MIXTURE, STEER_T

from thermoswarm.analysis.synthetic import synthetic_tracks
from thermoswarm.maxent import EnergyLaw, SteeringLaw


@pytest.fixture
def two_phase_tracks():
    return synthetic_tracks(
        40, 301, energy=MIXTURE, steering=SteeringLaw(STEER_T), fps=25.0, rng=11
    )


@pytest.fixture
def one_phase_tracks():
    return synthetic_tracks(
        30, 301, energy=EnergyLaw(35.0), steering=SteeringLaw(STEER_T), fps=25.0, rng=12
    )
