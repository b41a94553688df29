"""The reference HAL: the paper's robot on a MicroPython board (see docs/robot.md).

Three photoresistors as voltage dividers on ADC pins (brighter: higher voltage), the
battery through a divider on a fourth ADC pin, two DC motors on a DRV8833 dual H-bridge
(IN1 PWM forward, IN2 PWM backward: fast decay), its nSLEEP and nFAULT on two pins.  The
pins and the board's ADC come from the board's pin map, the rest from ``config.json``
and the calibration the board stores in ``calib.json`` (``thermoswarm robot calibrate``).

- light: the mean of ``samples`` ADC reads per sensor, mapped to [0, 1] from the stored
  dark and bright readings;
- wheels: commands in [-1, 1] (fraction of top speed) become PWM duties through the dead
  band, a per-motor trim and the battery voltage (so that the motors see their rated
  voltage at most), and a wheel that starts from rest gets a full-voltage kick first;
- turn(angle) and drive(speed, seconds): timed, open loop (no encoders), from the top
  speed and the track; drive() ends each control period on a fixed-rate tick, so that a
  period lasts ``tau`` whatever the turning took (as the simulator's turn-time charge);
- a safe stop: the motors stop and :class:`SafeStop` is raised on low battery or on a
  driver fault, checked at least every ``check_ms``.

Runs on MicroPython (imports json, time, machine and the controller only).
"""

import json
import time

import machine
from controller import HAL


class SafeStop(Exception):
    """The robot stopped itself (low battery, driver fault); the motors are off."""


def merge(base, extra):
    """``base`` updated by ``extra``, nested dicts merged (new dict)."""
    out = dict(base)
    for k, v in extra.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = merge(out[k], v)
        else:
            out[k] = v
    return out


def load_config(path="config.json", calib="calib.json"):
    """The build's ``config.json`` with the board's own ``calib.json`` over it."""
    with open(path) as f:
        cfg = json.load(f)
    try:
        with open(calib) as f:
            cfg = merge(cfg, json.load(f))
    except OSError:
        pass  # not calibrated yet: the build's defaults
    return cfg


class Motor:
    """One DC motor on a DRV8833 channel."""

    def __init__(self, pin1, pin2, freq):
        self.pwm = []
        for p in (pin1, pin2):
            pwm = machine.PWM(machine.Pin(p))
            pwm.freq(freq)
            pwm.duty_u16(0)
            self.pwm.append(pwm)

    def set(self, duty):
        """Signed duty in [-1, 1]: IN1 carries a forward duty, IN2 a backward one."""
        d = int(min(abs(duty), 1.0) * 65535 + 0.5)
        fwd, back = self.pwm
        if duty >= 0:
            back.duty_u16(0)
            fwd.duty_u16(d)
        else:
            fwd.duty_u16(0)
            back.duty_u16(d)


class BoardHAL(HAL):
    """The controller's HAL on a board: ``cfg`` is :func:`load_config`'s dict."""

    def __init__(self, cfg):
        self.cfg = cfg
        b = cfg["board"]
        pins = b["pins"]
        atten = b.get("adc_atten")
        self.ldr = [self._adc(p, atten) for p in pins["ldr"]]
        self.vbat_adc = self._adc(pins["battery"], atten)
        self.adc_scale = b["adc_vref"] / 65535.0
        self.divider = b["battery_divider"]
        m = cfg["motor"]
        self.motors = (Motor(pins["ain1"], pins["ain2"], b["pwm_freq"]),
                       Motor(pins["bin1"], pins["bin2"], b["pwm_freq"]))  # fmt: skip
        self.nsleep = None
        if pins.get("nsleep") is not None:
            self.nsleep = machine.Pin(pins["nsleep"], machine.Pin.OUT, value=1)
        self.nfault = None
        if pins.get("nfault") is not None:
            self.nfault = machine.Pin(pins["nfault"], machine.Pin.IN, machine.Pin.PULL_UP)
        r = cfg["robot"]
        self.top_speed = r["top_speed"]  # mm/s, at the motors' rated voltage
        self.track = r["track"]  # mm
        self.motor_volts = m["motor_volts"]
        self.dead_band = m["dead_band"]
        self.trim = m["trim"]
        self.kick = m["kick"]  # voltage fraction of the kick
        self.kick_us = int(m["kick_ms"] * 1000)
        self.turn_speed = m["turn_speed"]
        li = cfg["light"]
        self.samples = li["samples"]
        self.dark = li["dark"]
        self.bright = li["bright"]
        bat = cfg["battery"]
        self.low_volts = bat["low_volts"]
        self.check_us = int(bat["check_ms"] * 1000)
        self.running = [False, False]
        self.vbat = self.battery_volts()
        self.period_start = time.ticks_us()

    @staticmethod
    def _adc(pin, atten):
        if atten is None:
            return machine.ADC(machine.Pin(pin))
        return machine.ADC(machine.Pin(pin), atten=getattr(machine.ADC, atten))

    # ---------------------------------------------------------------- sensors
    def raw_light(self, samples=None):
        """Mean ADC reading (0-65535) of each photoresistor over ``samples`` reads."""
        n = samples or self.samples
        out = []
        for adc in self.ldr:
            s = 0
            for _ in range(n):
                s += adc.read_u16()
            out.append(s / n)
        return out

    def light(self):
        """``(l1, l2, l3)`` in [0, 1]: 0 at the stored dark reading, 1 at the bright."""
        raw = self.raw_light()
        out = []
        for k in range(3):
            span = self.bright[k] - self.dark[k]
            x = (raw[k] - self.dark[k]) / span if span > 0 else 0.0
            out.append(0.0 if x < 0.0 else 1.0 if x > 1.0 else x)
        return out[0], out[1], out[2]

    def battery_volts(self, samples=4):
        s = 0
        for _ in range(samples):
            s += self.vbat_adc.read_u16()
        return s / samples * self.adc_scale * self.divider

    def check(self):
        """Stop and raise :class:`SafeStop` on a driver fault or a low battery."""
        if self.nfault is not None and self.nfault.value() == 0:
            self.stop()
            raise SafeStop("motor driver fault (nFAULT low)")
        self.vbat = self.battery_volts()
        if self.vbat < self.low_volts:
            self.stop()
            raise SafeStop(f"low battery: {self.vbat:.2f} V < {self.low_volts:.2f} V")

    # ---------------------------------------------------------------- motors
    def duty(self, side, u):
        """PWM duty in [-1, 1] that gives wheel ``side`` (0 left, 1 right) the speed
        ``u`` (fraction of the top speed, in [-1, 1])."""
        if u == 0:
            return 0.0
        a = abs(u)
        f = self.dead_band + (1.0 - self.dead_band) * (a if a < 1.0 else 1.0) / self.trim[side]
        d = f * self.motor_volts / self.vbat
        d = d if d < 1.0 else 1.0
        return d if u > 0 else -d

    def stop(self):
        for m in self.motors:
            m.set(0.0)
        self.running = [False, False]

    def wheels(self, left, right):
        """Set both wheels (fractions of the top speed); a wheel that starts from rest
        gets a ``kick_ms`` kick at the ``kick`` voltage fraction first.  Returns the
        microseconds the kick lasted (0: none)."""
        u = (left, right)
        kicked = False
        for k in (0, 1):
            if u[k] != 0 and not self.running[k]:
                kick = self.kick * self.motor_volts / self.vbat
                self.motors[k].set(kick if u[k] > 0 else -kick)
                kicked = True
        if kicked and self.kick_us > 0:
            time.sleep_us(self.kick_us)
        for k in (0, 1):
            self.motors[k].set(self.duty(k, u[k]))
            self.running[k] = u[k] != 0
        return self.kick_us if kicked else 0

    def sleep_us(self, us):
        """Sleep, checking the battery and the driver at least every ``check_ms``."""
        while us > 0:
            s = us if us < self.check_us else self.check_us
            time.sleep_us(s)
            us -= s
            self.check()

    # ---------------------------------------------------------------- the HAL
    def turn(self, angle):
        """Turn in place by ``angle`` rad (counter-clockwise > 0), open loop."""
        a = abs(angle)
        if a == 0:
            return
        s = 1.0 if angle > 0 else -1.0
        w_kick = 2.0 * self.kick * self.top_speed / self.track  # rad/s during the kick
        k = self.kick_us / 1e6
        if a <= w_kick * k:  # a short turn: a pulse at the kick level
            kick = self.kick * self.motor_volts / self.vbat
            self.motors[0].set(-s * kick)
            self.motors[1].set(s * kick)
            self.running = [True, True]
            self.sleep_us(int(a / w_kick * 1e6 + 0.5))
        else:
            u = self.turn_speed
            w = 2.0 * u * self.top_speed / self.track
            spent = self.wheels(-s * u, s * u)
            rest = (a - w_kick * spent / 1e6) / w
            self.sleep_us(int(rest * 1e6 + 0.5))
        self.stop()

    def drive(self, speed, seconds):
        """Drive straight at ``speed`` mm/s until the control period of ``seconds``,
        begun when the last drive ended, is over (the fixed-rate tick)."""
        deadline = time.ticks_add(self.period_start, int(seconds * 1e6))
        left = time.ticks_diff(deadline, time.ticks_us())
        if left > 0:
            u = speed / self.top_speed
            u = u if u < 1.0 else 1.0
            if u > 0 and left > self.kick_us:  # not worth a start in what is left
                self.wheels(u, u)
            self.sleep_us(time.ticks_diff(deadline, time.ticks_us()))
            self.stop()
        late = time.ticks_diff(time.ticks_us(), deadline)
        # on the tick; after an overrun (turning took longer), a new tick from now
        self.period_start = deadline if late <= 0 else time.ticks_us()
