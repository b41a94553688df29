"""The robot controller: MicroPython-compatible, same laws as the simulator's policies."""

from __future__ import annotations

import ast
import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

import thermoswarm.robot.controller as ctl
from thermoswarm.maxent import EnergyLaw, NormalHeading
from thermoswarm.robot.controller import Config, Controller, Rng
from thermoswarm.sim.robot import ControllerPolicy, SimulatedHAL

SRC = Path(ctl.__file__)
BOARD_SCRIPT = Path(__file__).with_name("board_script.py")
N = 40_000


def _tool(name):
    """A program the dev extra installs next to the interpreter; missing is a failure
    (a broken install), never a skip."""
    path = shutil.which(name, path=str(Path(sys.executable).parent)) or shutil.which(name)
    assert path, f"{name} is not installed: it comes with the dev extra (make install)"
    return path


# what MicroPython's standard library offers (docs.micropython.org, "Python standard
# libraries and micro-libraries"), plus the board's own modules
MICROPYTHON_MODULES = {
    "array", "binascii", "collections", "errno", "gc", "hashlib", "heapq", "io", "json",
    "machine", "math", "micropython", "os", "random", "re", "select", "struct", "sys", "time",
}  # fmt: skip


def _imports(path):
    """Every module a file imports, at any depth (function-level imports included)."""
    tree = ast.parse(path.read_text())
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            found.add("." * node.level + (node.module or ""))
    return tree, found


def test_robot_package_imports_only_what_micropython_has():
    files = sorted(SRC.parent.glob("*.py"))
    assert {f.name for f in files} >= {"__init__.py", "controller.py"}
    for f in files:
        tree, imported = _imports(f)
        outside = {
            m
            for m in imported
            if m.split(".")[0] not in MICROPYTHON_MODULES
            and not m.startswith(("thermoswarm.robot", "."))
        }
        assert not outside, f"{f.name} imports {sorted(outside)}, which MicroPython lacks"
        for node in ast.walk(tree):
            # MicroPython has no dataclasses, typing or annotations at run time
            assert not isinstance(node, ast.AnnAssign), f"{f.name}:{node.lineno}"
            if isinstance(node, ast.FunctionDef):
                args = node.args.args + node.args.kwonlyargs
                assert node.returns is None and all(a.annotation is None for a in args), (
                    f"{f.name}:{node.lineno} has annotations"
                )
    # the controller, the one file a board needs, stands alone
    assert _imports(SRC)[1] == {"math"}


def test_the_import_check_has_teeth(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("def f():\n    import numpy\n")
    assert _imports(bad)[1] == {"numpy"}


def test_micropython_compiler_accepts_the_controller(tmp_path):
    mpy_cross = _tool("mpy-cross")
    out = tmp_path / "controller.mpy"
    res = subprocess.run([mpy_cross, "-o", str(out), str(SRC)], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    assert out.stat().st_size > 1000
    # and it rejects what MicroPython lacks (the check has teeth)
    bad = tmp_path / "bad.py"
    bad.write_text("match 1:\n    case 1:\n        pass\n")
    assert subprocess.run([mpy_cross, str(bad)], capture_output=True).returncode != 0


def _run(argv):
    res = subprocess.run(argv, capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    return res.stdout.splitlines()


def test_micropython_makes_the_same_decisions_as_cpython(tmp_path):
    """The controller on MicroPython's unix port, as a board holds it (compiled to .mpy
    by mpy-cross, alone, in a 64 KiB heap -- less than an ESP32 or RP2040 offers),
    driven by a scripted HAL: every decision (heading, speed, Algorithm 1's outcome,
    phase) is bit for bit the one CPython makes for the same seed."""
    micropython = _tool("micropython")
    impl = _run([micropython, "-c", "import sys; print(sys.implementation.name)"])
    assert impl == ["micropython"]
    board = tmp_path / "board"
    board.mkdir()
    subprocess.run([_tool("mpy-cross"), "-o", str(board / "controller.mpy"), str(SRC)], check=True)
    host = tmp_path / "host"
    host.mkdir()
    shutil.copy(SRC, host / "controller.py")
    on_board = _run([micropython, "-X", "heapsize=64K", str(BOARD_SCRIPT), str(board)])
    on_host = _run([sys.executable, str(BOARD_SCRIPT), str(host)])
    # the script exercises what it should: 6 runs x (24 periods + 3 decisions), with
    # converged and given-up turns, both phases, distinct headings
    assert len(on_host) == 1 + 6 * 27
    periods = [line.split() for line in on_host if line.split()[1] in ("0", "1")]
    assert {p[4] for p in periods} == {"True", "False"} and {p[1] for p in periods} == {"0", "1"}
    assert all(len({p[2] for p in periods[k : k + 24]}) == 24 for k in range(0, 144, 24))
    for k, (b, h) in enumerate(zip(on_board, on_host, strict=True)):
        assert b == h, f"line {k}: MicroPython {b!r} != CPython {h!r}"


def test_portable_generator_is_deterministic_and_uniform():
    a, b = Rng(7), Rng(7)
    seq = [a.u32() for _ in range(1000)]
    assert seq == [b.u32() for _ in range(1000)]
    assert all(0 <= x < 2**32 for x in seq) and len(set(seq)) == 1000
    u = np.array([Rng(11).random() for _ in range(1)] + [0.0])  # seeds differ
    assert u[0] != Rng(12).random()
    r = Rng(3)
    x = np.array([r.random() for _ in range(N)])
    assert x.min() > 0 and x.max() < 1
    assert stats.kstest(x, "uniform").pvalue > 1e-3
    z = np.array([r.normal() for _ in range(N)])
    assert stats.kstest(z, "norm").pvalue > 1e-3


@pytest.mark.parametrize(
    "alg, lo, hi",
    [
        ("compression", -math.pi, math.pi),
        ("transport-connected", -math.pi / 2, math.pi / 2),
        ("transport-free", -math.pi, math.pi),
    ],
)
def test_decisions_follow_the_algorithms_laws(alg, lo, hi):
    c = Controller(Config(algorithm=alg, kT=40.0, kT_hot=40.0, kT_cold=40.0, v_max=None), seed=5)
    th, v = np.array([c.decide(0.9) for _ in range(N)]).T
    # energy v^2/2 is the maximum-entropy law Exp(kT)
    assert stats.kstest(v**2 / 2, EnergyLaw(40.0).cdf).pvalue > 1e-3
    assert th.min() >= lo and th.max() <= hi
    assert stats.kstest(th, stats.uniform(lo, hi - lo).cdf).pvalue > 1e-3


def test_narrow_road_headings_point_to_each_groups_goal():
    for group, goal in ((0, 0.0), (1, math.pi)):
        c = Controller(Config(algorithm="narrow-road", group=group, sigma=0.4), seed=2)
        th = np.array([c.decide()[0] for _ in range(N)])
        assert stats.kstest(th, NormalHeading(goal, 0.4).cdf).pvalue > 1e-3


def test_light_switches_the_temperature_and_the_mapping_flips_it():
    cfg = dict(algorithm="transport-free", v_max=None)
    lit_hot = Controller(Config(mapping="lit_hot", **cfg), seed=1)
    lit_cold = Controller(Config(mapping="lit_cold", **cfg), seed=1)
    c = Config()
    se = c.kT_hot / math.sqrt(N)
    for ctrl, lit_T, dark_T in ((lit_hot, c.kT_hot, c.kT_cold), (lit_cold, c.kT_cold, c.kT_hot)):
        e_lit = np.mean([ctrl.decide(0.9)[1] ** 2 / 2 for _ in range(N)])
        e_dark = np.mean([ctrl.decide(0.1)[1] ** 2 / 2 for _ in range(N)])
        assert abs(e_lit - lit_T) < 4 * se and abs(e_dark - dark_T) < 4 * se
    lit_cold.decide(0.9)
    assert lit_cold.phase == 0
    lit_hot.decide(0.9)
    assert lit_hot.phase == 1


def test_persistent_heading_turns_by_the_exponential_steering_law():
    # scale kT_theta * tau = 0.5 rad: turns beyond pi (wrapped) have probability e^-6.3
    c = Controller(Config(algorithm="transport-free", kT_theta=0.25, tau=2.0), seed=8)
    prev = c.theta
    turns = []
    for _ in range(N):
        th, _ = c.decide(0.2)
        turns.append(ctl.wrap(th - prev))
        prev = th
    turns = np.array(turns)
    # |turn| ~ Exponential(kT_theta * tau) with a random sign (PAPER_NOTES 6.4)
    assert stats.kstest(np.abs(turns), stats.expon(scale=0.5).cdf).pvalue > 1e-3
    assert abs(np.mean(turns > 0) - 0.5) < 4 * 0.5 / math.sqrt(N)


def test_v_max_clips_to_the_motors_limit():
    c = Controller(Config(kT=1000.0, v_max=33.0), seed=4)
    v = np.array([c.decide()[1] for _ in range(5000)])
    assert v.max() == 33.0 and np.mean(v == 33.0) > 0.5  # most draws exceed 33 mm/s


def test_bad_settings_name_the_setting():
    with pytest.raises(ValueError, match="unknown setting 'speed'"):
        Config(speed=3)
    with pytest.raises(ValueError, match="algorithm must be one of"):
        Config(algorithm="flocking")
    with pytest.raises(ValueError, match="kT must be positive"):
        Config(kT=-1)


def test_turn_to_light_finds_heading_zero_and_stops_at_once_in_the_dark():
    from thermoswarm.sim.geometry import Disc
    from thermoswarm.sim.light import DirectionalLight

    light = DirectionalLight(direction=(0.0, -1.0))  # light from +y: heading 0 is +y
    rng = np.random.default_rng(0)
    cfg = Config()
    errors = []
    for h0 in rng.uniform(-np.pi, np.pi, 40):
        hal = SimulatedHAL((0.0, 0.0), h0, light)
        ok, steps = Controller(cfg, hal, seed=1).turn_to_light()
        assert ok and steps <= 181
        errors.append(ctl.wrap(hal.heading - math.pi / 2))
    assert np.max(np.abs(errors)) <= cfg.step  # within one turning step
    # in the shadow of an object nothing is seen: Algorithm 1 ends at once
    hal = SimulatedHAL((0.0, 0.0), 1.0, light, occluders=[Disc((0.0, 100.0), 50.0)])
    assert Controller(cfg, hal).turn_to_light() == (False, 0)
    assert hal.turned == 0.0


def test_a_whole_period_turns_then_drives():
    from thermoswarm.sim.light import DirectionalLight

    hal = SimulatedHAL((0.0, 0.0), 0.3, DirectionalLight(direction=(0.0, -1.0)))
    theta, v, ok = Controller(Config(tau=2.0), hal, seed=9).period()
    assert ok and hal.driven == pytest.approx(2.0 * v)
    assert ctl.wrap(hal.heading - math.pi / 2 - theta) == pytest.approx(0.0, abs=0.04)


def test_the_simulator_runs_the_robots_controller():
    """The engine driven by the robot's own code: its commanded speeds follow the law."""
    from thermoswarm.sim import EngineParams, Simulator, box_world, place_lattice

    world = box_world(3000.0, 3000.0)
    policy = ControllerPolicy(algorithm="compression", kT=50.0, v_max=None)
    sim = Simulator(world, EngineParams(dt=0.1, tau=1.0), policy)
    rng = np.random.default_rng(1)
    state = sim.init(place_lattice(world.bounds, 100, 16.5, rng), rng)
    speeds = []
    for k in range(300):
        sim.step(state)
        if k % 10 == 0:
            speeds.append(state.speed.copy())
    v = np.concatenate(speeds)
    assert stats.kstest(v**2 / 2, EnergyLaw(50.0).cdf).pvalue > 1e-3
    assert sim.max_overlap(state) < 0.02 * 33
    # reproducible: the same seed gives the same swarm
    rng2 = np.random.default_rng(1)
    s2 = sim.init(place_lattice(world.bounds, 100, 16.5, rng2), rng2)
    for _ in range(300):
        sim.step(s2)
    assert np.array_equal(state.by_id(state.pos), s2.by_id(s2.pos))
