"""Fixtures of the I/O tests: small data made in code with a fixed seed."""

from __future__ import annotations

import numpy as np
import pytest
from io_truth import Truth


@pytest.fixture
def truth(rng: np.random.Generator) -> Truth:
    """7 frames, 3 keypoints, 2 individuals; values exactly representable in text."""
    n_t, n_k, n_i = 7, 3, 2
    px = np.round(rng.uniform(0.0, 1900.0, size=(n_t, 2, n_k, n_i)) * 8) / 8
    conf = (np.round(rng.uniform(0.0, 1.0, size=(n_t, n_k, n_i)) * 1024) / 1024).astype(np.float32)
    px[2, :, 1, 0] = np.nan  # one missing keypoint
    conf[2, 1, 0] = np.nan
    px[4, :, :, 1] = np.nan  # one missing individual
    conf[4, :, 1] = np.nan
    return Truth(px, conf, ["ant_a", "ant_b"], ["head", "thorax", "tail"])
