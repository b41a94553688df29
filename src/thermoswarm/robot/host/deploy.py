"""Copy a built robot to a board and calibrate it over USB serial, with mpremote.

mpremote (MicroPython's own tool, the ``robot`` extra) talks to the board's raw REPL;
:func:`deploy` writes each file of a built folder to the board's filesystem, and
:func:`calibrate` runs the measurements of the board's ``calibrate.py`` one by one,
asking the user to set the scene between them, and writes ``calib.json`` on the board.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from thermoswarm.errors import ConfigError, InputError

__all__ = ["connect", "deploy", "calibrate", "trim_from_drift"]

#: the files a built folder must hold
REQUIRED = ("controller.py", "hal.py", "main.py", "calibrate.py", "config.json")


def connect(port: str) -> Any:
    """An mpremote serial transport on ``port``, in the raw REPL (no soft reset)."""
    try:
        from mpremote.transport_serial import SerialTransport
    except ModuleNotFoundError:
        raise ConfigError("mpremote is not installed: pip install 'thermoswarm[robot]'") from None
    try:
        t = SerialTransport(port, baudrate=115200)
    except Exception as e:  # serial.SerialException and OSError, by port
        raise InputError(f"cannot open serial port {port!r}: {e}") from None
    t.enter_raw_repl(soft_reset=False)
    return t


def deploy(folder: str | Path, port: str) -> list[str]:
    """Copy the built ``folder`` to the board on ``port``; returns the files written.
    The board's own ``calib.json`` is left as it is."""
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"{folder}: no such folder; make one with `thermoswarm robot build`")
    missing = [f for f in REQUIRED if not (folder / f).is_file()]
    if missing:
        raise InputError(
            f"{folder}: not a built robot folder (missing {', '.join(missing)}); "
            "make one with `thermoswarm robot build`"
        )
    t = connect(port)
    try:
        written = []
        for f in sorted(folder.iterdir()):
            if f.is_file() and f.suffix in (".py", ".json", ".mpy") and f.name != "calib.json":
                t.fs_writefile(f.name, f.read_bytes())
                written.append(f.name)
        return written
    finally:
        t.exit_raw_repl()
        t.close()


def _call(t: Any, code: str) -> Any:
    out = t.exec(f"import calibrate\ncalibrate.{code}\n")
    return json.loads(out.decode().strip().splitlines()[-1])


def trim_from_drift(distance: float, drift: float, track: float) -> tuple[float, float]:
    """Motor trims from a straight drive that ended ``drift`` mm to the left (negative:
    right) after ``distance`` mm: the right wheel was faster by ``2 drift track /
    distance^2`` of the speed (a circular arc), so each wheel's trim takes half."""
    if not distance > 0:
        raise InputError(f"distance must be positive (mm), got {distance}")
    k = 2.0 * drift * track / distance**2
    return 1.0 - k / 2.0, 1.0 + k / 2.0


def calibrate(port: str, ask: Callable[[str], float], say: Callable[[str], None]) -> dict:
    """Measure the light sensors and the motors of the board on ``port`` and store the
    result in its ``calib.json``; returns it.

    ``ask(prompt) -> float`` asks the user for a number (after setting the scene);
    ``say(text)`` tells them something.
    """
    t = connect(port)
    try:
        cfg = json.loads(t.fs_readfile("config.json"))
        ask("Cover the robot (all three photoresistors dark), then press Enter")
        dark = _call(t, "light(64)")
        ask("Shine the lamp on the robot as in the experiment, then press Enter")
        bright = _call(t, "light(64)")
        bad = [k for k in range(3) if not bright[k] > dark[k] + 1000]
        if bad:
            raise InputError(
                f"photoresistor(s) {[k + 1 for k in bad]}: bright {bright} not above "
                f"dark {dark} (check the wiring)"
            )
        volts = _call(t, "battery()")
        say(f"light: dark {dark}, bright {bright}; battery {volts:.2f} V")
        track = cfg["robot"]["track"]
        ms = 3000
        _call(t, f"drive(0.6, {ms})")
        distance = ask("The robot drove straight for 3 s: how far did it go (mm)?")
        drift = ask("How far to the left did it end (mm; to the right: negative)?")
        trim = trim_from_drift(distance, drift, track)
        top = distance / (ms / 1000.0) / 0.6
        calib = {"light": {"dark": dark, "bright": bright}, "motor": {"trim": list(trim)},
                 "robot": {"top_speed": top}}  # fmt: skip
        t.fs_writefile("calib.json", json.dumps(calib).encode())
        say(f"trim {trim[0]:.3f} / {trim[1]:.3f}, top speed {top:.1f} mm/s: calib.json written")
        return calib
    finally:
        t.exit_raw_repl()
        t.close()
