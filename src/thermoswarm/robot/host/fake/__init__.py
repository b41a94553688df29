"""Fake ``machine`` and ``time`` modules for MicroPython's unix port (not imported by
CPython): the closed loop puts this folder first on MicroPython's path."""
