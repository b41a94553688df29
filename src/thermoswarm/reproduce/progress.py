"""The estimate of what is left of a ``reproduce``: each step's cost in CPU seconds, and
this machine's speed and the cores this run gets, measured on the steps that finished.

A step's wall time is its CPU work divided by the cores it gets.  Its work is the
plan's reference CPU seconds (:attr:`~thermoswarm.reproduce.plans.Plan.cost`: in this
process, which runs on one core, and in the worker pool, which runs on ``workers``)
times this machine's *slowness* (CPU seconds per reference CPU second, measured).  The
cores it gets: ``k`` busy processes of this run get ``min(k, share)`` cores, where the
*share* is what the kernel gives this run on a busy machine.  Linux shares the cores
fairly between sessions (``/proc/sys/kernel/sched_autogroup_enabled``), not between
processes: on a machine that other sessions load, a one-process step and a two-process
step get about the same cores (measured: ``reproduce --quick`` at load 8-12 on 2 cores,
every step got 0.41-0.56 cores; docs/reproduce.md), so a pace measured on one-process
steps misjudges the two-process studies by up to 2x.

After each step both are measured: the slowness from the CPU seconds that the step and
its worker processes used (:mod:`psutil`), the share from the wall time the step took for
that CPU work (the share for which the model gives that wall time) or, where the step
got every core it asked for, from the cores the machine's other processes left
(:func:`psutil.cpu_times`); recent steps weigh most (a shared machine's load changes).
Where the system gives no machine-wide CPU times the share is taken as every core and
the slowness is the pace of the finished steps.  Where the load runs in this run's own
session (or autogroup is off), the kernel shares by process and the two-process
studies get more than a one-process step: the estimate of the studies is then up to
2x long.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import psutil


def cores_got(k: float, share: float) -> float:
    """Cores that ``k`` busy processes of this run get where the run's share of the
    machine is ``share`` cores."""
    return max(1e-3, min(k, share))


@dataclass
class Usage:
    """CPU seconds used by this process and by its descendants, and by the machine."""

    own: float
    children: float
    machine_busy: float | None  # every process's CPU seconds since boot

    def __sub__(self, other: Usage) -> Usage:
        busy = None
        if self.machine_busy is not None and other.machine_busy is not None:
            busy = self.machine_busy - other.machine_busy
        return Usage(self.own - other.own, self.children - other.children, busy)


def _descendants_cpu() -> float:
    """CPU seconds of the live descendants of this process (with the children they
    reaped)."""
    total = 0.0
    for child in psutil.Process().children(recursive=True):
        try:
            t = child.cpu_times()
        except psutil.Error:  # ended since it was listed: os.times() counts it once reaped
            continue
        total += t.user + t.system + t.children_user + t.children_system
    return total


def _machine_busy() -> float | None:
    """CPU seconds every process of the machine used since boot; None where the system
    does not say."""
    try:
        t = psutil.cpu_times()
    except (psutil.Error, OSError):
        return None
    return float(sum(getattr(t, k, 0.0) for k in ("user", "nice", "system", "irq", "softirq")))


def measure() -> Usage:
    """CPU seconds so far (s): this process (every thread), its descendants (live ones
    from :mod:`psutil`, reaped ones from :func:`os.times`), the whole machine since boot."""
    t = os.times()
    children = t.children_user + t.children_system + _descendants_cpu()
    return Usage(t.user + t.system, children, _machine_busy())


@dataclass
class _Done:
    wall: float
    used: float  # CPU seconds, this process and the workers
    slowness: float  # CPU seconds per reference CPU second
    share: float  # cores the run got when it asked for every core


class Estimate:
    """What is left of a run of steps, from their reference costs and the steps done.

    Parameters
    ----------
    cost : mapping
        Step name to its reference CPU seconds ``(in this process, in the workers)``.
    cores : int
        The machine's cores.
    workers : int
        Processes of the worker pool.
    share : float, optional
        Cores this run gets before any step has finished (default: every core; the
        start-up measures it).
    """

    def __init__(self, cost: Mapping[str, tuple[float, float]], cores: int, workers: int,
                 share: float | None = None) -> None:  # fmt: skip
        self.cost = {k: (float(a), float(b)) for k, (a, b) in cost.items()}
        self.cores, self.workers = max(1, cores), max(1, workers)
        self.start_share = float(self.cores if share is None else share)
        self.done: dict[str, _Done] = {}

    def _wall(self, own: float, pool: float, share: float) -> float:
        """Wall seconds for CPU work ``own`` (one process) and ``pool`` (the workers)."""
        return own / cores_got(1, share) + pool / cores_got(self.workers, share)

    def _share_of(self, wall: float, own: float, pool: float, left: float | None) -> float:
        """The share that gives a step of this CPU work this wall time; where the step
        took no longer than with every core it asked for, the cores the machine's other
        processes ``left`` (when known), at least what the step got."""
        top = float(max(1, self.workers) if pool > 0 else 1)
        if self._wall(own, pool, top) >= wall:  # got every core it asked for
            return max(top, left) if left is not None else float(self.cores)
        lo, hi = 1e-3, top
        for _ in range(60):  # the wall time falls as the share grows
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if self._wall(own, pool, mid) > wall else (lo, mid)
        return hi

    def finish(self, step: str, wall: float, used: Usage | None) -> None:
        """Record a finished ``step``: its ``wall`` seconds and the CPU it ``used``."""
        ref_own, ref_pool = self.cost.get(step, (1.0, 0.0))
        ref = ref_own + ref_pool
        if used is None or used.own + used.children <= 0:  # not measured: every core
            idle = self._wall(ref_own, ref_pool, self.cores)
            slow = wall / idle if idle > 0 else 1.0
            self.done[step] = _Done(wall, slow * ref, slow, float(self.cores))
            return
        left = None
        if used.machine_busy is not None and wall > 0:
            left = self.cores - max(0.0, used.machine_busy - used.own - used.children) / wall
        cpu = used.own + used.children
        share = self._share_of(wall, used.own, used.children, left)
        self.done[step] = _Done(wall, cpu, cpu / ref if ref > 0 else 1.0, share)

    def _weights(self) -> list[tuple[float, _Done]]:
        """The finished steps, each at half the weight of the next (the load changes)."""
        d = list(self.done.values())
        return [(0.5 ** (len(d) - 1 - i), x) for i, x in enumerate(d)]

    def slowness(self) -> float:
        """CPU seconds per reference CPU second on the finished steps (1 before any)."""
        w = self._weights()
        ref = sum(wi * x.used / x.slowness for wi, x in w if x.slowness > 0)
        used = sum(wi * x.used for wi, x in w if x.slowness > 0)
        return used / ref if ref > 0 else 1.0

    def share(self) -> float:
        """Cores this run gets: the finished steps' shares, weighted by their wall time
        and recency (the start-up's before any step finished)."""
        w = [(wi * x.wall, x.share) for wi, x in self._weights()]
        total = sum(wi for wi, _ in w)
        return sum(wi * v for wi, v in w) / total if total > 0 else self.start_share

    def left(self, steps: list[str] | None = None) -> float:
        """Wall seconds for ``steps`` (default: every step not finished) at the measured
        slowness and share."""
        todo = [s for s in (steps if steps is not None else self.cost) if s not in self.done]
        slow, share = self.slowness(), self.share()
        return sum(slow * self._wall(*self.cost.get(t, (1.0, 0.0)), share) for t in todo)


def meter(
    clock: Callable[[], float], usage: Callable[[], Usage | None]
) -> Callable[[], tuple[float, Usage | None]]:
    """Start a measurement: returns a function that gives the wall seconds (``clock``)
    and the CPU seconds (``usage``, None where not measured) since."""
    t0, u0 = clock(), usage()

    def since() -> tuple[float, Usage | None]:
        u1 = usage()
        return clock() - t0, (u1 - u0 if u0 is not None and u1 is not None else None)

    return since
