"""``make run``'s estimate of what is left (issue 33): each step's reference CPU seconds
at this machine's measured speed and the cores the run gets.

The steps run on a fake machine (a fake clock and a fake CPU meter): ``cores`` cores
shared fairly between sessions, as Linux's autogroup scheduler does, this run being
one session that asks for one core in its own process and for ``workers`` cores while
its worker pool runs.  Each estimate printed after a step is compared with the time the
fake run then really took to finish.
"""

from __future__ import annotations

from collections.abc import Callable

import pytest

from thermoswarm.reproduce.plans import QUICK, Plan
from thermoswarm.reproduce.progress import Estimate, Usage
from thermoswarm.reproduce.runs import _Log


def _fair(demands: list[float], cores: float) -> list[float]:
    """Cores each session gets: the machine's cores shared fairly (water-filling)."""
    if sum(demands) <= cores:
        return list(demands)
    lo, hi = 0.0, max(demands)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if sum(min(d, mid) for d in demands) < cores else (lo, mid)
    return [min(d, hi) for d in demands]


class FakeMachine:
    """``cores`` cores; this run's CPU work costs ``slowness(t)`` times the reference;
    ``others(t)`` the other sessions' demands (busy processes each) at time ``t``."""

    def __init__(
        self,
        slowness: Callable[[float], float] = lambda t: 1.0,
        others: Callable[[float], list[float]] = lambda t: [],
        cores: int = 2,
        workers: int = 2,
    ) -> None:
        self.t, self.own, self.children, self.busy = 0.0, 0.0, 0.0, 0.0
        self.slowness, self.others, self.cores, self.workers = slowness, others, cores, workers

    def clock(self) -> float:
        return self.t

    def usage(self) -> Usage:
        return Usage(self.own, self.children, self.busy)

    def _work(self, cpu: float, k: int, pool: bool) -> None:
        """``cpu`` reference CPU seconds on ``k`` processes, in steps of 0.5 s or less."""
        while cpu > 1e-9:
            got = _fair([k, *self.others(self.t)], self.cores)
            slow = self.slowness(self.t)
            dt = min(0.5, cpu * slow / got[0])
            cpu -= got[0] * dt / slow
            self.t += dt
            self.busy += sum(got) * dt
            if pool:
                self.children += got[0] * dt
            else:
                self.own += got[0] * dt

    def run_step(self, own: float, pool: float) -> None:
        self._work(own, 1, False)
        self._work(pool, self.workers, True)


def _ratios(machine: FakeMachine, plan: Plan = QUICK) -> list[float]:
    """The estimate printed after each step (the last excepted) over the time the run
    then took to finish."""
    steps = list(plan.cost)
    log = _Log(False, plan, steps, workers=machine.workers, clock=machine.clock,
               usage=machine.usage, cores=machine.cores)  # fmt: skip
    said = []
    for s in steps:
        done = log.step(s)
        machine.run_step(*plan.cost[s])
        done()
        said.append((machine.t, log.left()))
    end = machine.t
    return [left / (end - t) for t, left in said[:-1]]


def _within(ratios: list[float], factor: float = 1.5) -> bool:
    return all(1 / factor <= r <= factor for r in ratios)


def test_a_machine_twice_as_slow_as_the_reference():
    r = _ratios(FakeMachine(slowness=lambda t: 2.0))
    assert r == pytest.approx([1.0] * len(r), rel=1e-6)


@pytest.mark.parametrize("others", [[2.0], [1.0], [1.0, 1.0], [0.5]])
def test_other_sessions_busy(others):
    # Beside another session busy on both cores, a one-process step still gets a core,
    # a two-process study only one of its two: one pace for every step, measured on the
    # first steps, says half the time the studies take.
    r = _ratios(FakeMachine(others=lambda t: others))
    assert _within(r, 1.05), r


def test_a_heavily_loaded_machine_that_is_also_slower():
    # Twenty other sessions with a busy process each, CPU work 1.3 times the reference.
    r = _ratios(FakeMachine(slowness=lambda t: 1.3, others=lambda t: [1.0] * 20))
    assert _within(r, 1.05), r


def test_a_machine_that_slows_down_midway():
    # From 60 s on (in the fifth step) each CPU second costs 1.4 (a slower clock, a busy
    # hyperthread sibling): every estimate within 1.5x, and within 1.1x once a step has
    # measured it.
    r = _ratios(FakeMachine(slowness=lambda t: 1.0 if t < 60 else 1.4))
    assert _within(r), r
    assert _within(r[4:], 1.1), r


def test_a_load_that_starts_midway():
    # Another session busy on both cores from 60 s on, in the fifth step (one process:
    # it still gets its core): no estimate can foresee it, and until a step has
    # measured it the estimate is off by no more than the slowdown of the studies (2x);
    # once the fifth step has seen the other session's CPU time, within 1.15x.
    r = _ratios(FakeMachine(others=lambda t: [2.0] if t > 60 else []))
    assert _within(r, 2.0), r
    assert _within(r[4:], 1.15), r


def test_without_a_cpu_meter_the_pace_of_the_finished_steps():
    e = Estimate({"a": (10.0, 0.0), "b": (0.0, 20.0), "c": (10.0, 0.0)}, cores=2, workers=2)
    assert e.left() == pytest.approx(10 + 10 + 10)  # the pool's 20 CPU s on 2 cores
    e.finish("a", 30.0, None)  # three times the reference, every core assumed
    assert e.slowness() == pytest.approx(3.0) and e.share() == 2.0
    assert e.left() == pytest.approx(3 * (10 + 10))


def test_the_share_from_the_cores_the_other_processes_left():
    e = Estimate({"a": (10.0, 0.0), "b": (0.0, 20.0)}, cores=2, workers=2)
    # a one-process step that got its core while the others used 0.6 of a core
    e.finish("a", 10.0, Usage(own=10.0, children=0.0, machine_busy=16.0))
    assert e.share() == pytest.approx(1.4)
    assert e.left() == pytest.approx(20 / 1.4)


def test_start_up_is_not_a_step():
    m = FakeMachine()
    log = _Log(False, QUICK, list(QUICK.cost), clock=m.clock, usage=m.usage, cores=2)
    log.start_up()
    assert log.start_up_s == 0 and log.times == {} and log.estimate.done == {}
