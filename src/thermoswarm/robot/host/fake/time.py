# A fake `time` module for MicroPython's unix port: virtual time that passes only in
# sleeps (machine._sleep), with MicroPython's wrapping ticks.
import machine

_PERIOD = 1 << 30


def sleep_us(us):
    machine._sleep(us)


def sleep_ms(ms):
    machine._sleep(ms * 1000)


def sleep(s):
    machine._sleep(int(s * 1000000))


def ticks_us():
    return machine._now[0] % _PERIOD


def ticks_ms():
    return (machine._now[0] // 1000) % _PERIOD


def ticks_add(t, delta):
    return (t + delta) % _PERIOD


def ticks_diff(a, b):
    return ((a - b + _PERIOD // 2) % _PERIOD) - _PERIOD // 2


def time():
    return machine._now[0] // 1000000


def time_ns():
    return machine._now[0] * 1000
