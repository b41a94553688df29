"""How many Numba threads the engine's kernels run on.

An explicit count -- :func:`set_threads`, ``numba.set_num_threads`` before the first
step, ``thermoswarm bench --threads`` -- is always respected; only when none was given
does the engine choose (one thread below :data:`SERIAL_BELOW` robots).
:mod:`thermoswarm.sim.engine` re-exports these names.
"""

from __future__ import annotations

import numba
import numpy as np

from thermoswarm.errors import ConfigError

__all__ = ["SERIAL_BELOW", "set_threads", "threads_for", "auto_threads"]


#: When no thread count was given, swarms smaller than this are stepped on one thread:
#: below it, waking a second thread for each of a step's parallel loops costs more than
#: it saves.  Measured on an idle 2-core machine (``benchmarks/bench_engine.py --tools
#: ours1,ours2 --settle 5``, packing 0.18 and 0.5): two threads over one 0.51-0.60x at
#: 10,000 robots, 0.86-0.77x at 20,000, 0.97-0.94x at 40,000, 1.05-1.17x at 70,000.
SERIAL_BELOW = 60_000

_EXPLICIT_THREADS: int | None = None


def set_threads(n: int | None) -> None:
    """Numba threads for the engine: ``n`` (1 to ``numba.config.NUMBA_NUM_THREADS``), or
    ``None`` for the automatic choice.

    An explicit count is never changed by the engine.  The automatic choice applies only
    when no count was given here and Numba's count is still the process default (a count
    set with ``numba.set_num_threads`` is respected too): then swarms below
    :data:`SERIAL_BELOW` robots run on one thread, larger ones on all.
    """
    global _EXPLICIT_THREADS
    if n is None:
        _EXPLICIT_THREADS = None
        return
    top = numba.config.NUMBA_NUM_THREADS
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or not 1 <= n <= top:
        raise ConfigError(
            f"threads must be an integer in [1, {top}] (NUMBA_NUM_THREADS), got {n!r}"
        )
    numba.set_num_threads(int(n))
    _EXPLICIT_THREADS = int(n)


def threads_for(n: int) -> int:
    """The number of Numba threads a step of ``n`` robots runs on now."""
    if _EXPLICIT_THREADS is not None:
        return _EXPLICIT_THREADS
    current = numba.get_num_threads()
    if current == numba.config.NUMBA_NUM_THREADS and n < SERIAL_BELOW:
        return 1
    return current


def auto_threads(n: int) -> tuple[int | None, bool]:
    """Lower Numba to one thread for a small swarm when no count was given.  Returns the
    count to restore after the step (None: nothing changed) and whether the step runs on
    one thread (then the kernels call their loops' serial twins).  Costs ~1 us; with an
    explicit count, nothing."""
    if _EXPLICIT_THREADS is not None:
        return None, _EXPLICIT_THREADS == 1
    current = numba.get_num_threads()
    if n >= SERIAL_BELOW or current == 1 or current != numba.config.NUMBA_NUM_THREADS:
        return None, current == 1  # all threads, one already, or a count the caller chose
    numba.set_num_threads(1)
    return current, True
