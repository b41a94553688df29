"""Fuzz fixtures: small inputs made in code, and the per-verb counts at the end."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest
from harness import COUNTS, table


@pytest.fixture(scope="session")
def tracks_nc(tmp_path_factory) -> Path:
    """A 60-step, 4-individual trajectory file (mm, 10 frames/s)."""
    from thermoswarm.io.netcdf import write
    from thermoswarm.tracks import make_tracks

    pos = np.cumsum(np.random.default_rng(36).normal(0, 1, (60, 2, 4)), axis=0)
    path = tmp_path_factory.mktemp("fuzz") / "tracks.nc"
    write(make_tracks(pos, fps=10.0), path)
    return path


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    """Print the fuzz counts per verb (without xdist: its workers print nothing)."""
    if COUNTS:
        terminalreporter.write_line("\nfuzz runs per verb (this process):")
        terminalreporter.write_line(table())


def pytest_sessionfinish(session, exitstatus):
    """With THERMOSWARM_FUZZ_COUNTS=FILE, write the counts as JSON to FILE.PID (each
    xdist worker its own)."""
    target = os.environ.get("THERMOSWARM_FUZZ_COUNTS")
    if target and COUNTS:
        data = {v: dict(c) for v, c in COUNTS.items()}
        Path(f"{target}.{os.getpid()}").write_text(json.dumps(data, indent=1))
