"""Calibration helpers the host calls over the REPL (``thermoswarm robot calibrate``).

Each function does one measurement and prints its result as one JSON line; the host
asks the user to set the scene between them and stores the result in ``calib.json``
on the board, which :func:`hal.load_config` lays over ``config.json``.
"""

import json
import time

from hal import BoardHAL, load_config


def _hal():
    return BoardHAL(load_config())


def light(samples=64):
    """Print the mean raw reading (0-65535) of each photoresistor."""
    print(json.dumps(_hal().raw_light(samples)))


def battery():
    """Print the battery voltage (V)."""
    print(json.dumps(_hal().battery_volts(16)))


def spin(side, duty, ms):
    """Drive one motor (0 left, 1 right) at a raw signed ``duty`` for ``ms`` ms (no
    dead band, trim or kick), then stop."""
    hal = _hal()
    hal.motors[side].set(duty)
    time.sleep_ms(ms)
    hal.stop()
    print(json.dumps(duty))


def drive(u, ms):
    """Drive straight at ``u`` (fraction of the top speed) for ``ms`` ms, then stop."""
    hal = _hal()
    hal.wheels(u, u)
    time.sleep_ms(ms)
    hal.stop()
    print(json.dumps(u))
