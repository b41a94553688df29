"""Helpers shared by the tracking tests (imported by name; pytest puts this folder on
sys.path).  Small synthetic videos made in code with fixed seeds."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import numpy as np

from thermoswarm.tracking.synth.clip import SynthConfig, SynthVideo, generate

#: A small frame that still holds the paper's 40 mm road at 3.04 px/mm (122 px).
SMALL = dict(width=480, height=200, fps=30.0)


def small_video(seed: int = 7, **kw) -> SynthVideo:
    args = dict(SMALL, n_ants=8, n_frames=60)
    args.update(kw)
    return generate(SynthConfig(**args), np.random.default_rng(seed))


def bench_module(name: str) -> ModuleType:
    """``benchmarks/NAME.py`` imported as module ``NAME`` (registered in
    ``sys.modules``: a dataclass in it looks its module up)."""
    path = Path(__file__).resolve().parents[2] / "benchmarks" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod
