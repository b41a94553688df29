"""The host side of the robot: build the board's files from a scenario (:mod:`.build`),
copy them and calibrate over USB with mpremote (:mod:`.deploy`), and run them on
MicroPython's unix port in closed loop with the simulator (:mod:`.loop`).

Unlike the rest of :mod:`thermoswarm.robot`, this runs on the host (CPython, NumPy).
"""
