"""The built robot (MicroPython's unix port, fake machine module) in closed loop with
the simulator: same decisions as CPython's controller, the periods on the fixed tick,
the turns where the controller asked, the safe stop, and (slow) the paper's tasks."""

from __future__ import annotations

import json
import math

import numpy as np

from thermoswarm.robot.controller import Config, Controller, wrap
from thermoswarm.robot.host.build import build
from thermoswarm.robot.host.loop import ClosedLoop
from thermoswarm.scenarios.runner import resolve


def _replay(settings, seed, decisions, mapping="lit_cold"):
    """CPython's controller, same seed, fed the light level each logged phase implies."""
    ctrl = Controller(Config(**settings), seed=seed)
    out = []
    for d in decisions:
        hot = d.phase == 1
        lit = hot if mapping == "lit_hot" else not hot
        out.append(ctrl.decide(0.9 if lit else 0.1, d.previous))
    return out


def _settings(tmp_path, i):
    return json.loads((tmp_path / "work" / f"robot{i}" / "config.json").read_text())


def test_boards_make_cpython_decisions_on_the_tick_and_turn_where_asked(tmp_path):
    """Three boards among the narrow road's simulated robots for 20 s."""
    build("rp2040-zero", "narrow-road", tmp_path / "build")
    run = resolve("narrow-road", overrides=["duration=20"], seed=1)
    ids = [0, 1, 5]  # two of group 0, one of group 1
    with ClosedLoop(run, tmp_path / "build", ids, tmp_path / "work") as cl:
        st = cl.state
        groups = {i: int(st.by_id(st.group)[i]) for i in ids}
        assert sorted(groups.values()) == [0, 0, 1]
        cl.run(20.0)
        assert cl.close() == {i: "" for i in ids}  # no MicroPython error
        tau = run.params.tau
        for b in cl.boards:
            dec = b.decisions()
            assert [d.period for d in dec] == list(range(len(dec)))
            # the fixed-rate tick: a period lasts tau, unless its turns took longer
            # (then the next starts at once, on a new tick)
            # (group 1 turns about a full turn each period: to the light, then back)
            length = np.diff([0.0] + [d.t for d in dec])
            assert np.all(length > tau - 1e-6) and len(dec) <= 20
            if groups[b.id] == 0:
                assert len(dec) >= 15 and np.mean(np.abs(length - tau) < 1e-6) > 0.7
            else:
                assert len(dec) >= 5
            ctl = _settings(tmp_path, b.id)["controller"]
            assert ctl["group"] == groups[b.id]
            replay = _replay(ctl, _settings(tmp_path, b.id)["seed"], dec)
            for d, (theta, v) in zip(dec, replay, strict=True):
                assert (d.theta, d.speed) == (theta, v)  # bit for bit
            assert all(d.converged for d in dec)  # Algorithm 1 found the light each time
            # at each period's end the body points where the controller asked (heading
            # 0 = the light, at +x): within Algorithm 1's window, a step and the timing
            err = np.array([abs(wrap(d.phi - d.theta)) for d in dec])
            assert err.max() < math.radians(4.0), np.degrees(err.max())
            goal = 0.0 if groups[b.id] == 0 else math.pi
            assert np.mean([abs(wrap(d.theta - goal)) for d in dec]) < 1.0  # sigma 45 deg
