"""What thermoswarm computes once per machine: compiled Numba kernels, parameter lists.

One place for every entry point (the ``thermoswarm`` command, ``make``, the Python API,
the tests): ``NUMBA_CACHE_DIR`` defaults to ``<user cache>/thermoswarm/numba`` (on Linux
``~/.cache/thermoswarm/numba``; ``THERMOSWARM_CACHE_DIR`` moves the whole cache, and a
``NUMBA_CACHE_DIR`` set by the user is kept).  The default is set when ``thermoswarm`` is
imported, before Numba is.  Numba keys its files by the source's path and time stamp, so
several checkouts share the directory without mixing their kernels.

:func:`warm` compiles every kernel the scenarios and the analysis use (``make install``
runs it through ``thermoswarm cache --warm``) and the scenarios' parameter listing
(:mod:`thermoswarm.scenarios.schema`); :func:`jit_timer` measures the time a
block spends compiling or loading kernels, so that speeds can be reported without it.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

__all__ = ["cache_dir", "numba_cache_dir", "default_numba_cache_dir", "jit_timer", "warm",
           "clear", "JitTime"]  # fmt: skip


def cache_dir() -> Path:
    """``THERMOSWARM_CACHE_DIR``, or the per-user cache directory of the platform."""
    env = os.environ.get("THERMOSWARM_CACHE_DIR")
    if env:
        return Path(env).expanduser()
    import platformdirs

    return Path(platformdirs.user_cache_dir("thermoswarm", appauthor=False))


def default_numba_cache_dir() -> Path:
    """Where Numba's cache goes unless ``NUMBA_CACHE_DIR`` says otherwise."""
    return cache_dir() / "numba"


def numba_cache_dir() -> Path:
    """Where Numba's cache goes in this process."""
    return Path(os.environ.get("NUMBA_CACHE_DIR") or default_numba_cache_dir())


@dataclass
class JitTime:
    """Seconds spent in Numba's JIT inside a :func:`jit_timer` block.

    ``seconds``: compiling plus loading compiled kernels from the cache (the time to
    leave out of a speed); ``compile_seconds``: compiling only (cache misses; 0 when
    every kernel came from the cache).
    """

    seconds: float = 0.0
    compile_seconds: float = 0.0

    @property
    def compiled(self) -> bool:
        return self.compile_seconds > 0


@contextlib.contextmanager
def jit_timer() -> Iterator[JitTime]:
    """``with jit_timer() as jit:`` measures the block's Numba compile and load time.

    Read ``jit.seconds`` after the block (or inside it, for the time so far): it uses
    Numba's event API (``numba:compiler_lock`` is held while a kernel is compiled or
    loaded from the cache, ``numba:compile`` only while it is compiled).
    """
    from numba.core import event

    res = JitTime()
    with (
        event.install_timer("numba:compiler_lock", lambda d: None) as lock,
        event.install_timer("numba:compile", lambda d: None) as comp,
    ):
        try:
            yield res
        finally:
            res.seconds = lock.duration if lock.done else 0.0
            res.compile_seconds = comp.duration if comp.done else 0.0


# Configurations whose kernels differ (engine modes, light and sensing kinds, walls,
# bodies); each is run for a few control periods at a small size.
_WARM: list[tuple[str, dict]] = [
    ("box", {"n": 50, "duration": 2.0}),
    ("box", {"n": 50, "duration": 0.5, "mode": "inertial", "engine": {"dt": 0.05},
             "record": {"interval": 0.05}}),
    ("narrow-road", {"duration": 2.0}),
    ("narrow-road", {"duration": 2.0, "steering": "exponential", "ends": "walls"}),
    ("compression", {"n": 50, "duration": 2.0}),
    ("compression", {"n": 50, "duration": 2.0, "walls": "held"}),
    ("transport-connected", {"duration": 2.0}),
    ("transport-connected", {"duration": 2.0, "sensor": {"mode": "photoresistor"}}),
    ("transport-free", {"n": 100, "duration": 2.0}),
    ("transport-free", {"n": 100, "duration": 2.0, "heading_law": "uniform",
                        "mapping": "lit_hot", "sensor": {"mode": "photoresistor"}}),
    ("transport-free", {"n": 100, "duration": 2.0, "variant": "obstacle", "light": "point"}),
    ("transport-free", {"n": 100, "duration": 2.0, "variant": "zigzag"}),
]  # fmt: skip


def warm(*, verbose: bool = False) -> JitTime:
    """Compile (or load) every kernel that the scenarios and the analysis use.

    Runs each configuration of a short list for a few control periods in a temporary
    directory, then fits a small sample with the analysis.  A configuration that a
    newer parameter set no longer accepts is skipped with a note (warming is a
    convenience, never an error).  Returns the time spent in the JIT.
    """
    import numpy as np

    from thermoswarm.errors import ThermoswarmError
    from thermoswarm.scenarios import get
    from thermoswarm.scenarios.runner import RunConfig, run
    from thermoswarm.sweep import _flatten_base

    total = JitTime()
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="thermoswarm-warm-") as tmp, jit_timer() as jit:
        for i, (name, over) in enumerate(_WARM):
            t = time.perf_counter()
            try:
                from thermoswarm.config import from_mapping

                params = from_mapping(get(name).Params, _flatten_base(over))
                run(RunConfig(name, params, 0), Path(tmp) / f"{i}", progress=False)
            except ThermoswarmError as exc:
                if verbose:
                    print(f"  {name} {over}: skipped ({exc})", flush=True)
                continue
            if verbose:
                print(f"  {name:20s} {time.perf_counter() - t:6.1f} s", flush=True)
        t = time.perf_counter()
        from thermoswarm.analysis.fit import compare_phases

        rng = np.random.default_rng(0)
        x = np.concatenate([rng.exponential(1.0, 300), rng.exponential(5.0, 300)])
        compare_phases(x, n_bootstrap=19, random_state=0)
        if verbose:
            print(f"  {'analysis':20s} {time.perf_counter() - t:6.1f} s", flush=True)
    total.seconds, total.compile_seconds = jit.seconds, jit.compile_seconds
    from thermoswarm.scenarios.schema import all_params

    all_params()  # the parameter listing that `--set` is checked against
    if verbose:
        what = "compiled" if total.compiled else "loaded from the cache"
        print(
            f"kernels {what} in {numba_cache_dir()} "
            f"({time.perf_counter() - t0:.0f} s; {total.compile_seconds:.0f} s compiling)",
            flush=True,
        )
    return total


def clear() -> Path:
    """Delete thermoswarm's Numba cache directory; returns its path."""
    path = numba_cache_dir()
    shutil.rmtree(path, ignore_errors=True)
    return path
