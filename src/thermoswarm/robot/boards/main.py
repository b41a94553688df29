"""The board's entry point: MicroPython runs ``main.py`` at boot.

Loads ``config.json`` (and the board's ``calib.json``), builds the HAL and the
controller, and runs control periods until a safe stop (low battery, driver fault) or
``periods`` periods; the motors are stopped whatever ends the run.  With ``log`` on, it
prints one line per period: ``period K THETA V CONVERGED PHASE PREVIOUS`` (floats as the hex of
their IEEE-754 double bits, so that a host can compare decisions exactly).
"""

import struct

import machine
from controller import Config, Controller
from hal import BoardHAL, SafeStop, load_config


def bits(x):
    return "{:016x}".format(struct.unpack("<Q", struct.pack("<d", x))[0])


def seed_of(cfg):
    """The configured seed, or one made from the chip's unique id."""
    if cfg.get("seed") is not None:
        return int(cfg["seed"])
    s = 0
    for b in machine.unique_id():
        s = (s * 31 + b) & 0xFFFFFFFF
    return s


def run(cfg=None):
    cfg = cfg or load_config()
    hal = BoardHAL(cfg)
    ctrl = Controller(Config(**cfg["controller"]), hal, seed_of(cfg))
    periods = cfg.get("periods")
    log = cfg.get("log", False)
    k = 0
    try:
        while periods is None or k < periods:
            theta, v, ok = ctrl.period()
            if log:
                print("period", k, bits(theta), bits(v), ok, ctrl.phase, bits(ctrl.previous))
            k += 1
    except SafeStop as e:
        print("safe stop:", e)
    finally:
        hal.stop()
    return k


if __name__ == "__main__":
    run()
