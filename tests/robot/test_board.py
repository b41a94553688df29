"""The board's files: MicroPython only, the HAL's wheel commands against the motor
model, the safe stop, and the paper_robot model's limits and their report."""

from __future__ import annotations

import json
import math
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest
from test_controller import MICROPYTHON_MODULES, _imports

import thermoswarm.robot.boards as boards
from thermoswarm.robot.host.build import build
from thermoswarm.robot.host.loop import FAKE, ClosedLoop, micropython, robot_folder
from thermoswarm.scenarios.runner import resolve
from thermoswarm.sim.robot_model import (
    RobotLimitWarning,
    RobotModel,
    drive_arc,
    limit_report,
    paper_robot,
    warn_limits,
)

BOARD_DIR = Path(boards.__file__).parent


def test_board_files_import_only_what_micropython_has():
    files = sorted(BOARD_DIR.glob("*.py")) + sorted(FAKE.glob("*.py"))
    assert {f.name for f in files} >= {"hal.py", "main.py", "calibrate.py", "machine.py"}
    ours = {"controller", "hal", "main", "calibrate", "machine", "time"}
    for f in files:
        _, imported = _imports(f)
        outside = {m for m in imported if m.split(".")[0] not in MICROPYTHON_MODULES | ours}
        assert not outside, f"{f.name} imports {sorted(outside)}, which MicroPython lacks"


def test_paper_robot_limits():
    m = paper_robot
    assert m.top_speed == pytest.approx(math.pi * 12 * 52 / 60)  # 32.67 mm/s
    assert m.max_turn_rate == pytest.approx(2 * m.top_speed / 29.0)
    assert m.mean_current_ma == pytest.approx(250 / 1.55)  # 161 mA
    assert m.sensing_params().turn_rate_deg == pytest.approx(math.degrees(m.max_turn_rate))
    # the motor model: stall below the dead band, static friction at rest, top speed at
    # the rated voltage
    assert m.wheel_speed(1.0, 3.0, 0, moving=False) == pytest.approx(m.top_speed)
    assert m.wheel_speed(-0.2, 3.0, 1, moving=True) == pytest.approx(-m.top_speed * 0.05 / 0.85)
    assert m.wheel_speed(0.2, 3.0, 1, moving=False) == 0.0
    assert m.wheel_speed(0.1, 3.0, 1, moving=True) == 0.0
    with pytest.raises(ValueError, match="track"):
        RobotModel(track=40.0)


def test_drive_arc_is_exact():
    # a quarter circle: wheels 10 and 20 mm/s on a 29 mm track, radius 43.5 mm
    w = 10.0 / 29.0
    t = (math.pi / 2) / w
    x, y, phi = drive_arc(0.0, 0.0, 0.0, 10.0, 20.0, 29.0, t)
    r = 15.0 / w
    assert (x, y, phi) == pytest.approx((r, r, math.pi / 2))
    # in small pieces the same
    p = (0.0, 0.0, 0.0)
    for _ in range(100):
        p = drive_arc(*p, 10.0, 20.0, 29.0, t / 100)
    assert p == pytest.approx((x, y, phi))


def test_limit_report_counts_what_the_robot_cannot_do():
    speed = np.array([[10.0, 40.0], [20.0, 30.0], [33.0, 5.0]])
    heading = np.array([[0.0, 0.0], [3.0, 0.1], [3.0, -3.0]])  # turns of 3 rad in 1 s
    rep = limit_report(speed, heading, interval=1.0, tau=1.0, model=paper_robot, chunk=2)
    assert rep["speed_over_fraction"] == pytest.approx(2 / 6)  # 40 and 33 > 32.67
    assert rep["max_speed"] == 40.0
    assert rep["turn_over_fraction"] == pytest.approx(2 / 4)  # 3 and 3.1 rad > 2.25 rad/s
    with pytest.warns(RobotLimitWarning, match="top speed 32.7 mm/s in 33%"):
        warn_limits(rep)
    slow = limit_report(speed / 2, heading / 2, 1.0, 1.0, paper_robot)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warn_limits(slow)  # nothing beyond the limits: no warning


def test_the_runner_reports_the_paper_robots_limits(tmp_path):
    from thermoswarm.scenarios.runner import run

    cfg = resolve("narrow-road", overrides=["duration=5", "record.netcdf=false"], seed=2)
    with pytest.warns(RobotLimitWarning, match="paper_robot"):
        metrics = run(cfg, tmp_path / "run", progress=False)
    lim = metrics["robot_limits"]
    # mean speed 20 mm/s (Rayleigh): P(v > 32.67) = exp(-32.67^2 / (2 kT)) = 0.123
    kT = cfg.params.kT
    p = math.exp(-(paper_robot.top_speed**2) / (2 * kT))
    frames = 51 * 9  # robot-frames: correlated within a period, so a loose band
    assert abs(lim["speed_over_fraction"] - p) < 6 * math.sqrt(p * (1 - p) / (frames / 10))


def _hal_duties(folder, cases):
    """The HAL's duty() on MicroPython for (side, u, volts) cases."""
    code = (
        "import json\nfrom hal import BoardHAL, load_config\nh = BoardHAL(load_config())\n"
        f"out = []\nfor side, u, v in {cases!r}:\n    h.vbat = v\n"
        "    out.append(h.duty(side, u))\nprint(json.dumps(out))\n"
    )
    env = {"MICROPYPATH": f"{FAKE}:{folder}", "PATH": "/usr/bin:/bin"}
    res = subprocess.run([micropython(), "-c", code], cwd=folder, env=env,
                         capture_output=True, text=True, timeout=60)  # fmt: skip
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout)


def test_hal_wheel_commands_invert_the_motor_model(tmp_path):
    """u (fraction of the top speed) -> the HAL's PWM duty -> the motor model's speed is
    u * top speed, for motors that differ (trim = their gains) and any battery voltage."""
    build("rp2040-zero", "compression", tmp_path / "build")
    gains = (0.92, 1.07)
    folder = robot_folder(tmp_path / "build", tmp_path / "b", motor={"trim": list(gains)})
    model = RobotModel(gains=gains)
    cases = [(s, u, v) for s in (0, 1) for u in (-1.0, -0.3, 0.05, 0.5, 0.9)
             for v in (3.4, 3.9, 4.2)]  # fmt: skip
    duties = _hal_duties(folder, cases)
    for (side, u, v), d in zip(cases, duties, strict=True):
        assert -1.0 <= d <= 1.0
        expect = u * model.top_speed
        if abs(u) / gains[side] * 0.85 + 0.15 > v / 3.0:  # beyond what the battery gives
            continue
        assert model.wheel_speed(d, v, side, moving=True) == pytest.approx(expect, rel=1e-9)


def test_low_battery_and_driver_fault_stop_the_robot(tmp_path):
    build("esp32c3-supermini", "narrow-road", tmp_path / "build")
    run = resolve("narrow-road", overrides=["duration=10"], seed=3)
    with ClosedLoop(run, tmp_path / "build", [0, 1], tmp_path / "work") as cl:
        cl.run(3.0)
        low, fault = cl.boards
        assert not low.ended and not fault.ended
        low.battery_volts = 3.2  # below low_volts = 3.3
        fault.fault = True
        cl.run(0.5)  # checked at least every 100 ms
        for b in cl.boards:
            assert b.ended and b.wheel == [0.0, 0.0]
            assert all(b.duties[p] == 0 for p in b.duties)  # the PWM is off
        assert low.proc.log[-1].startswith("safe stop: low battery: 3.2")
        assert fault.proc.log[-1] == "safe stop: motor driver fault (nFAULT low)"
        x = [(b.x, b.y) for b in cl.boards]
        cl.run(2.0)
        assert [(b.x, b.y) for b in cl.boards] == x
        assert cl.close() == {0: "", 1: ""}


def test_turn_held_charges_long_turns_in_full():
    """A robot whose turns take 2.5 periods stands for 2.5 periods (TurnTimeCharged
    would charge one), then its next decision is charged only what is left."""
    from thermoswarm.policy import Action, Observation
    from thermoswarm.robot.host.loop import TurnHeld

    class Fixed:  # the heading it asks at each time (held robots' draws are dropped)
        plan = {0.0: math.pi, 1.0: 2.0, 2.0: 2.0, 4.0: 0.5 * math.pi, 8.0: 0.4 * math.pi}

        def act(self, obs, rng):
            return Action(heading=np.array([self.plan[obs.time]]), speed=np.array([10.0]))

    pol = TurnHeld(Fixed(), turn_rate=1.0)  # rad/s; tau = 1 s
    h = 0.0

    def decide(t, heading, light=1.0):
        obs = Observation(time=t, index=np.array([0]), tau=1.0, ids=np.array([7]),
                          heading=np.array([heading]), zero_heading=np.array([0.0]),
                          light=np.array([light]))  # fmt: skip
        a = pol.act(obs, np.random.default_rng(0))
        return float(a.heading[0]), float(a.speed[0])

    h, v = decide(0.0, h)  # to the light (0) then to pi: 3.14 s of turning
    assert (h, v) == (math.pi, 0.0) and pol.busy[7] == pytest.approx(math.pi)
    assert decide(1.0, h) == (math.pi, 0.0) and decide(2.0, h) == (math.pi, 0.0)  # held
    h2, v2 = decide(4.0, h)  # 0.86 s past the turn's end: pi + pi/2 = 4.71 s, less 0.86
    assert h2 == 0.5 * math.pi and v2 == 0.0 and pol.busy[7] == pytest.approx(4.0 + 3.855, 1e-3)
    h3, v3 = decide(8.0, h2, light=0.0)  # dark: 0.1 pi from the last heading, less the wait
    assert h3 == pytest.approx(0.4 * math.pi)
    late = 8.0 - (4.0 + 1.5 * math.pi - (4.0 - math.pi))
    assert v3 == pytest.approx(10.0 * (1.0 - (0.1 * math.pi - late)))
