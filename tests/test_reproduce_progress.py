"""``make run``'s estimate of what is left (issue 33): the pace of the finished steps,
the most recent weighted most, times the expected seconds of the steps to run."""

from __future__ import annotations

import pytest

from thermoswarm.reproduce.plans import Plan
from thermoswarm.reproduce.runs import _Log


def _log(expected: dict[str, float]) -> _Log:
    return _Log(False, Plan("t", expected=expected), list(expected))


def test_the_estimate_follows_a_load_that_changes():
    log = _log({"a": 10.0, "b": 10.0, "c": 10.0, "d": 10.0})
    assert log.left() == pytest.approx(40.0)  # no step finished: the plan's seconds
    log.times["a"] = 10.0  # idle: one wall second per expected second
    assert log.left() == pytest.approx(30.0)
    log.times["b"] = 40.0  # the machine got four times slower
    # pace (0.5 * 10 + 40) / (0.5 * 10 + 10) = 3: nearer the new load than the mean 2.5
    assert log.speed() == pytest.approx(3.0)
    assert log.left() == pytest.approx(60.0)
    log.times["c"] = 40.0
    assert log.speed() == pytest.approx((0.25 * 10 + 0.5 * 40 + 40) / (0.25 * 10 + 0.5 * 10 + 10))


def test_the_proportions_of_the_steps_come_from_the_plan():
    log = _log({"small": 1.0, "big": 100.0})
    log.times["small"] = 3.0
    assert log.left() == pytest.approx(300.0)


def test_start_up_is_not_a_step():
    log = _log({"a": 1.0})
    log.start_up()
    assert log.start_up_s >= 0 and log.times == {}
