"""Fixtures of the tracking tests: small synthetic videos (made in code, fixed seeds)."""

from __future__ import annotations

import numpy as np
import pytest
from tracking_fixtures import small_video

from thermoswarm.tracking.synth.clip import SynthVideo


@pytest.fixture(scope="session")
def video_small() -> SynthVideo:
    """8 ants, 60 frames, 480x200 px."""
    return small_video()


@pytest.fixture(scope="session")
def frames_small(video_small: SynthVideo) -> list[np.ndarray]:
    return list(video_small.frames())
