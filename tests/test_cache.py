"""One Numba cache per machine, and speeds measured without the JIT."""

from __future__ import annotations

import os
import subprocess
import sys

import numba
import numpy as np

from thermoswarm.cache import jit_timer

PRINT_DIRS = (
    "import thermoswarm, os; from numba.core import config; "
    "print(os.environ['NUMBA_CACHE_DIR']); print(config.CACHE_DIR)"
)


def _env(**set_: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR",
                                                            "THERMOSWARM_CACHE_DIR")}  # fmt: skip
    env.update(set_)
    return env


def test_every_entry_point_shares_the_user_cache_unless_told_otherwise(tmp_path):
    out = subprocess.run([sys.executable, "-c", PRINT_DIRS], env=_env(
        THERMOSWARM_CACHE_DIR=str(tmp_path / "tc")), capture_output=True, text=True,
        check=True).stdout.split()  # fmt: skip
    assert out == [str(tmp_path / "tc" / "numba")] * 2
    # a NUMBA_CACHE_DIR the user set wins
    out = subprocess.run([sys.executable, "-c", PRINT_DIRS], env=_env(
        NUMBA_CACHE_DIR=str(tmp_path / "mine")), capture_output=True, text=True,
        check=True).stdout.split()  # fmt: skip
    assert out == [str(tmp_path / "mine")] * 2
    # Numba imported before thermoswarm still takes the default
    code = "import numba; " + PRINT_DIRS
    out = subprocess.run([sys.executable, "-c", code], env=_env(
        THERMOSWARM_CACHE_DIR=str(tmp_path / "tc")), capture_output=True, text=True,
        check=True).stdout.split()  # fmt: skip
    assert out == [str(tmp_path / "tc" / "numba")] * 2


def test_jit_timer_counts_compiling_and_nothing_else():
    @numba.njit  # a fresh function: compiled on its first call for each type
    def f(x):
        s = 0.0
        for v in x:
            s += v * v
        return s

    with jit_timer() as jit:
        f(np.ones(3))
    assert jit.compiled and jit.seconds >= jit.compile_seconds > 0
    with jit_timer() as again:  # the same types: nothing to compile or load
        for _ in range(100):
            f(np.ones(3))
    assert again.seconds == 0 and not again.compiled
    with jit_timer() as other:  # new types: compiled again
        f(np.ones(3, dtype=np.float32))
    assert other.compiled
