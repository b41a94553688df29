"""Shared fixtures: small data made in code, fixed seeds."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20251107)


#: The slow tests that take over a minute each on a 2-core machine (measured with
#: ``make test-slow``'s ``--durations``).  ``make test-slow`` runs them; CI runs the
#: rest of the slow suite (``make test-slow-ci``), to stay inside its 90 minutes.
HEAVY = (
    "tests/analysis/test_calibration.py::test_two_phase_gof_is_calibrated_under_two_phases",
    "tests/analysis/test_calibration.py::test_lr_and_one_phase_gof_are_calibrated_under_one_phase",
    "tests/robot/test_closed_loop.py::test_transport_free_boards_push_the_object_as_simulated_robots_do",
    "tests/docs/test_examples.py::test_every_example_runs_as_written[reproduce.md]",
    "tests/docs/test_examples.py::test_python_examples_run[tracking.md:308]",
    "tests/scenarios/test_transport_free.py::test_default_reaches_the_target_in_ten_of_ten_seeds",
    "tests/docs/test_examples.py::test_every_example_runs_as_written[scenarios_transport.md]",
    "tests/tracking/test_unet.py::test_briefly_trained_model_finds_the_ants",
    "tests/tracking/test_self_trained.py::test_self_trained_finds_a_fly_that_never_moves",
    "tests/fuzz/test_fuzz_verbs.py::test_fuzz_sweep_options_slow",
    "tests/tracking/test_track_analyze.py::test_benchmark_video_recovers_the_ant_model",
    "tests/sim/test_gpu_backend.py::test_wall_pressure_matches_the_cpu_engine_large",
)


def pytest_collection_modifyitems(config, items):
    """Mark the :data:`HEAVY` tests ``heavy`` (they are ``slow`` too).  When the whole
    suite is collected, every HEAVY id must name a test: an id that no longer matches
    (a docs example moved to another line) would send that test to CI's share."""
    ids = {item.nodeid for item in items}
    for item in items:
        if item.nodeid in HEAVY:
            item.add_marker(pytest.mark.heavy)
    files = {i.split("::")[0] for i in ids}
    gone = [h for h in HEAVY if h.split("::")[0] in files and h not in ids]
    whole = all(h.split("::")[0] in files for h in HEAVY) and not config.option.keyword
    if gone and whole:
        raise pytest.UsageError(f"tests/conftest.py HEAVY names no test: {gone}")
