"""thermoswarm: ants, particles and robot swarms under one maximum-entropy law.

``p(x) = exp(-x / kT) / kT`` -- simulate swarms that follow it, analyse trajectories
for it, track ants in video, and run the same controller on a robot.
"""

import os as _os
import sys as _sys

__version__ = "0.1.0"

# Numba's OpenMP threads spin while they wait at the end of each parallel loop.  On a
# machine whose cores are shared (a laptop, a cluster node with other jobs) a spinning
# thread starves the one doing work: measured here, a 10,000-robot step ran 0.2-9
# M robot-steps/s with spinning waits and 4.6-8.7 M with passive ones.  Set before any
# OpenMP runtime starts; a value the user set is kept.
_os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

# One Numba cache per machine, whatever the entry point (command, make, Python, tests):
# the user's cache directory unless NUMBA_CACHE_DIR is set (see thermoswarm.cache).
if not _os.environ.get("NUMBA_CACHE_DIR"):
    from thermoswarm.cache import default_numba_cache_dir as _numba_dir

    _os.environ["NUMBA_CACHE_DIR"] = str(_numba_dir())
    if "numba.core.config" in _sys.modules:  # Numba was imported first: let it re-read
        _sys.modules["numba.core.config"].reload_config()

__all__ = ["__version__"]
