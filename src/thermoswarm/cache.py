"""What thermoswarm computes once per machine: compiled Numba kernels, parameter lists.

One place for every entry point (the ``thermoswarm`` command, ``make``, the Python API,
the tests): ``NUMBA_CACHE_DIR`` defaults to ``<user cache>/thermoswarm/numba`` (on Linux
``~/.cache/thermoswarm/numba``; ``THERMOSWARM_CACHE_DIR`` moves the whole cache, and a
``NUMBA_CACHE_DIR`` set by the user is kept).  The default is set when ``thermoswarm`` is
imported, before Numba is.  Numba keys its files by the source's path and time stamp, so
several checkouts share the directory without mixing their kernels.

:func:`jit_timer` measures the time a block spends compiling or loading kernels, so that
speeds can be reported without it.  Warming every kernel (``thermoswarm cache --warm``,
which ``make install`` runs) lives with that command (:mod:`thermoswarm.cli.cache`): it
runs the scenarios and the analysis, which this module, imported by the package itself,
must not import.
"""

from __future__ import annotations

import contextlib
import os
import shutil
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

__all__ = ["cache_dir", "numba_cache_dir", "default_numba_cache_dir", "jit_timer",
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


def clear() -> Path:
    """Delete thermoswarm's Numba cache directory; returns its path."""
    path = numba_cache_dir()
    shutil.rmtree(path, ignore_errors=True)
    return path
