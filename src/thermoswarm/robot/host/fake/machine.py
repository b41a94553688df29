# A fake `machine` module for MicroPython's unix port (the closed loop and the fake
# serial board of the tests; not a board file).  ADC and digital input values come from
# the host, PWM duties go to it; time passes only in sleeps (see time.py here).
#
# Linked (after link()): every sleep sends one line on stdout,
#   "\x1eS <microseconds> <pin>=<duty_u16> ..."   (the duties changed since the last)
# and blocks until the host answers with one line on stdin,
#   "<pin>=<value> ..."   (an ADC pin's read_u16, or a digital input's value).
# Unlinked: values from `_fake.json` in the current folder ({"26": 30000, ...}, read
# again whenever an ADC is made), else
# 32768 for ADC pins and 1 for inputs; sleeps only advance the clock.
import sys

_values = {}
_changed = {}
_linked = [False]
_now = [0]  # microseconds since start


def _load():
    """Unlinked: (re)read the values of `_fake.json`, if there is one."""
    if _linked[0]:
        return
    try:
        import json

        with open("_fake.json") as f:
            for k, v in json.load(f).items():
                _values[int(k)] = v
    except OSError:
        pass


_load()


def link():
    """Talk to a host over stdin/stdout from now on; read the first values."""
    _linked[0] = True
    sys.stdout.write("\x1eH\n")
    _read()


def _read():
    line = sys.stdin.readline()
    if not line:
        raise SystemExit  # the host closed the link: the run is over
    for item in line.split():
        k, v = item.split("=")
        _values[int(k)] = int(v)


def _sleep(us):
    us = int(us)
    if us < 0:
        us = 0
    _now[0] += us
    if _linked[0]:
        parts = ["\x1eS", str(us)]
        for k, v in _changed.items():
            parts.append(f"{k}={v}")
        _changed.clear()
        sys.stdout.write(" ".join(parts) + "\n")
        _read()


class Pin:
    IN = 0
    OUT = 1
    PULL_UP = 1
    PULL_DOWN = 2

    def __init__(self, id, mode=-1, pull=-1, value=None):
        self.id = id
        if value is not None:
            _values[id] = value

    def value(self, v=None):
        if v is None:
            return _values.get(self.id, 1)
        _values[self.id] = v


class ADC:
    ATTN_0DB = 0
    ATTN_2_5DB = 1
    ATTN_6DB = 2
    ATTN_11DB = 3

    def __init__(self, pin, atten=None):
        self.id = pin.id if isinstance(pin, Pin) else pin
        _load()

    def read_u16(self):
        return _values.get(self.id, 32768)


class PWM:
    def __init__(self, pin, freq=None, duty_u16=None):
        self.id = pin.id
        self._freq = freq or 1000
        self.duty_u16(duty_u16 or 0)

    def freq(self, f=None):
        if f is None:
            return self._freq
        self._freq = f

    def duty_u16(self, d=None):
        if d is None:
            return _values.get(self.id, 0)
        _values[self.id] = d
        _changed[self.id] = d

    def deinit(self):
        self.duty_u16(0)


def unique_id():
    return b"\x12\x34\x56\x78"


def reset():
    raise SystemExit
