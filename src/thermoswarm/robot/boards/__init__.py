"""The board's files: the reference HAL (:mod:`hal`), the entry point (``main.py``), the
calibration helpers (``calibrate.py``) and one pin map per board (``BOARD.json``).

Everything here runs on MicroPython and imports only what MicroPython has; ``thermoswarm
robot build`` copies it, with the controller and a ``config.json``, to a folder for the
board (``docs/robot.md``).
"""
