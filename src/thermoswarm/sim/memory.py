"""The memory a run will need, checked against the memory there is before allocating.

A config can ask for any number of robots (``--set n=1e12``) or frames; NumPy then
fails deep inside the engine with a traceback about terabytes.  :func:`check_run_memory`
estimates the bytes from the sizes alone and refuses, in one line naming the key, a
run that cannot fit.  The estimate is an upper bound measured on the engine, not a
promise: a run it lets through may still be tight.
"""

from __future__ import annotations

from thermoswarm.errors import ConfigError
from thermoswarm.system import available_memory

__all__ = ["BYTES_PER_ROBOT", "BYTES_PER_ROBOT_FRAME", "available_memory", "check_run_memory"]

#: Bytes per robot of the swarm's state, cell grid and one step's work arrays: the box
#: scenario peaks at 662 (tracemalloc over build, init and two steps, 1e5 and 4e5
#: robots); rounded up for the scenarios with sensing and bodies.
BYTES_PER_ROBOT = 1024
#: Bytes per robot and recorded frame: position (2 x 8) and the per-frame extras
#: (heading, speed, phase ...), in the recorder's buffer and in the tracks read back.
BYTES_PER_ROBOT_FRAME = 32


def _bytes(n: float) -> str:
    for unit, size in (("PiB", 2**50), ("TiB", 2**40), ("GiB", 2**30), ("MiB", 2**20)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n / 2**10:.3g} KiB"


def check_run_memory(n_robots: int, n_frames: int, block: int, *, key: str = "n") -> int:
    """Refuse a run whose arrays cannot fit in the memory available; return the bytes.

    Parameters
    ----------
    n_robots
        Robots in the run (``key`` names the config key that sets it).
    n_frames
        Recorded frames (``duration / record.interval + 1``): the tracks are read back
        whole at the end.
    block
        Frames the recorder buffers (``record.block``).

    Raises
    ------
    ConfigError
        One line naming the key that makes the run too large (``key`` when the robots
        alone do not fit, else ``duration``: the recorded frames), the bytes needed and
        the bytes available.
    """
    per_robot = BYTES_PER_ROBOT + BYTES_PER_ROBOT_FRAME * float(block)
    need = float(n_robots) * (per_robot + BYTES_PER_ROBOT_FRAME * float(n_frames))
    have = available_memory()
    if have is None or need <= have:
        return int(need)
    if float(n_robots) * per_robot > have:  # too many robots even without the frames
        what = f"{key} = {n_robots}: {n_robots:,} robots"
    else:
        what = f"duration: {n_frames:,} recorded frames of {n_robots:,} robots"
    raise ConfigError(
        f"{what} need about {_bytes(need)} ({BYTES_PER_ROBOT} bytes per robot, "
        f"{BYTES_PER_ROBOT_FRAME} per robot and frame), more than the {_bytes(have)} of "
        "memory available here"
    )
