"""``robot build`` for each board, and ``robot deploy`` / ``robot calibrate`` against a
fake serial device: MicroPython's unix port on a pseudo-terminal, whose current folder
is the board's filesystem (mpremote talks to its raw REPL as to a board's)."""

from __future__ import annotations

import json
import os
import select
import subprocess
import threading
import tty
from pathlib import Path

import pytest
from click.testing import CliRunner

from thermoswarm.cli import cli as main
from thermoswarm.robot.host.build import BOARDS, board_pins
from thermoswarm.robot.host.deploy import trim_from_drift
from thermoswarm.robot.host.loop import FAKE, micropython


def test_build_writes_each_boards_files(tmp_path):
    runner = CliRunner()
    for board in BOARDS:
        out = tmp_path / board
        res = runner.invoke(main, ["robot", "build", "--board", board, "--scenario",
                                   "transport-free", "--out", str(out), "--seed", "4",
                                   "--set", "kT_hot=200.0"])  # fmt: skip
        assert res.exit_code == 0, res.output
        names = sorted(p.name for p in out.iterdir())
        assert names == ["calibrate.py", "config.json", "controller.py", "hal.py", "main.py"]
        cfg = json.loads((out / "config.json").read_text())
        assert cfg["board"] == board_pins(board)
        pins = cfg["board"]["pins"]
        used = pins["ldr"] + [pins[k] for k in ("battery", "ain1", "ain2", "bin1", "bin2",
                                                 "nsleep", "nfault")]  # fmt: skip
        assert len(set(used)) == len(used)  # no pin used twice
        c = cfg["controller"]
        assert c["algorithm"] == "transport-free" and c["kT_hot"] == 200.0
        assert cfg["seed"] == 4 and c["v_max"] == pytest.approx(32.67, abs=0.01)
    # the ADC pins are ADC-capable on each board: RP2040 GP26-29, ESP32-C3 ADC1 GPIO0-4
    assert set(board_pins("rp2040-zero")["pins"]["ldr"]) <= {26, 27, 28, 29}
    assert set(board_pins("esp32c3-supermini")["pins"]["ldr"]) <= {0, 1, 2, 3, 4}


def test_build_rejects_what_the_controller_cannot_run(tmp_path):
    runner = CliRunner()
    res = runner.invoke(main, ["robot", "build", "--board", "rp2040-zero", "--scenario",
                               "narrow-road", "--out", str(tmp_path / "o"), "--set",
                               "steering=exponential"])  # fmt: skip
    assert res.exit_code == 2 and "normal heading law only" in res.output
    assert not (tmp_path / "o").exists()
    res = runner.invoke(main, ["robot", "deploy", str(tmp_path), "--port", "/dev/null"])
    assert res.exit_code == 2 and "not a built robot folder" in res.output


class FakeBoard:
    """MicroPython's unix port on one pseudo-terminal, bridged to a second whose slave
    end is the "serial port" mpremote opens (both ends raw, as a USB CDC port is)."""

    def __init__(self, fs: Path) -> None:
        self.fs = fs
        ma, sa = os.openpty()
        mb, sb = os.openpty()
        tty.setraw(sa)
        tty.setraw(sb)
        env = dict(os.environ, MICROPYPATH=f"{FAKE}:.")
        self.proc = subprocess.Popen([micropython()], stdin=sa, stdout=sa, stderr=sa,
                                     cwd=fs, env=env)  # fmt: skip
        os.close(sa)
        self.fds = (ma, mb, sb)
        self.port = os.ttyname(sb)
        self.alive = True
        self.thread = threading.Thread(target=self._pump, daemon=True)
        self.thread.start()

    def _pump(self) -> None:
        ma, mb, _ = self.fds
        while self.alive:
            r, _, _ = select.select([ma, mb], [], [], 0.05)
            for fd in r:
                try:
                    data = os.read(fd, 4096)
                except OSError:
                    return
                os.write(mb if fd == ma else ma, data)

    def close(self) -> None:
        self.alive = False
        self.thread.join()
        self.proc.kill()
        self.proc.wait()
        for fd in self.fds:
            os.close(fd)


@pytest.fixture
def board(tmp_path):
    fs = tmp_path / "board_fs"
    fs.mkdir()
    b = FakeBoard(fs)
    yield b
    b.close()


def _mpremote_installed():
    try:
        import mpremote  # noqa: F401
    except ModuleNotFoundError:
        pytest.fail("mpremote is not installed: it comes with the robot extra (make install)")


def test_deploy_copies_the_build_to_the_board_and_it_runs(tmp_path, board):
    _mpremote_installed()
    build = tmp_path / "build"
    runner = CliRunner()
    res = runner.invoke(main, ["robot", "build", "--board", "rp2040-zero", "--scenario",
                               "narrow-road", "--out", str(build), "--seed", "9"])  # fmt: skip
    assert res.exit_code == 0, res.output
    (board.fs / "calib.json").write_text('{"light": {"dark": [1, 2, 3]}}')
    res = runner.invoke(main, ["robot", "deploy", str(build), "--port", board.port])
    assert res.exit_code == 0, res.output
    for f in build.iterdir():
        assert (board.fs / f.name).read_bytes() == f.read_bytes()
    # the board's own calibration survives a deploy
    assert json.loads((board.fs / "calib.json").read_text()) == {"light": {"dark": [1, 2, 3]}}
    # and the deployed files run there: three periods of the controller on the board
    from mpremote.transport_serial import SerialTransport

    t = SerialTransport(board.port)
    t.enter_raw_repl(soft_reset=False)
    cfg = "from hal import load_config\ncfg = load_config()\ncfg['periods'] = 3\n"
    out = t.exec(cfg + "cfg['log'] = True\nimport main\nprint(main.run(cfg))").decode()
    t.exit_raw_repl()
    t.close()
    lines = out.strip().splitlines()
    assert lines[-1] == "3" and [ln.split()[:2] for ln in lines[:3]] == [
        ["period", "0"], ["period", "1"], ["period", "2"]]  # fmt: skip


def test_calibrate_stores_light_and_motor_calibration_on_the_board(tmp_path, board):
    _mpremote_installed()
    from thermoswarm.robot.host.deploy import calibrate, deploy

    build = tmp_path / "build"
    CliRunner().invoke(main, ["robot", "build", "--board", "rp2040-zero", "--scenario",
                              "compression", "--out", str(build)])  # fmt: skip
    deploy(build, board.port)
    scene = {"dark": {26: 900, 27: 1100, 28: 1000}, "bright": {26: 50000, 27: 52000, 28: 47000}}
    answers = iter([("dark", 0.0), ("bright", 0.0), (None, 600.0), (None, 12.0)])

    def ask(prompt):
        which, value = next(answers)
        if which:
            values = {**scene[which], 29: 26000}  # battery: 26000 * 3.3 / 65535 * 2 = 2.6 V
            (board.fs / "_fake.json").write_text(json.dumps(values))
        return value

    said = []
    calib = calibrate(board.port, ask, said.append)
    stored = json.loads((board.fs / "calib.json").read_text())
    assert stored == json.loads(json.dumps(calib))
    assert stored["light"]["dark"] == [900, 1100, 1000]
    assert stored["light"]["bright"] == [50000, 52000, 47000]
    assert stored["motor"]["trim"] == pytest.approx(list(trim_from_drift(600.0, 12.0, 29.0)))
    assert stored["robot"]["top_speed"] == pytest.approx(600.0 / 3.0 / 0.6)
    assert "battery 2.62 V" in said[0]


def test_trim_from_drift_cancels_the_arc():
    # a right wheel 2 % faster drifts left; the trims slow it and speed the left
    from thermoswarm.sim.robot_model import drive_arc

    vl, vr, track, t = 20.0, 20.4, 29.0, 30.0
    x, y, _ = drive_arc(0.0, 0.0, 0.0, vl, vr, track, t)
    trim_l, trim_r = trim_from_drift(x, y, track)
    assert vl / trim_l == pytest.approx(vr / trim_r, rel=2e-3)
    assert trim_r > 1 > trim_l


def test_calibrate_command_rejects_sensors_that_do_not_see_the_lamp(tmp_path, board):
    """The CLI's prompts, and a one-line error when bright is not above dark (a
    photoresistor wired wrong): nothing is written on the board."""
    _mpremote_installed()
    build = tmp_path / "build"
    CliRunner().invoke(main, ["robot", "build", "--board", "rp2040-zero", "--scenario",
                              "compression", "--out", str(build)])  # fmt: skip
    assert (
        CliRunner().invoke(main, ["robot", "deploy", str(build), "--port", board.port]).exit_code
        == 0
    )
    (board.fs / "_fake.json").write_text(json.dumps({26: 900, 27: 40000, 28: 41000}))
    res = CliRunner().invoke(main, ["robot", "calibrate", "--port", board.port], input="\n\n")
    assert res.exit_code == 2, res.output
    assert "Cover the robot" in res.output and "Shine the lamp" in res.output
    assert "error: photoresistor(s) [1, 2, 3]: bright" in res.output
    assert not (board.fs / "calib.json").exists()
