# The robot's controller driven through a scripted HAL, written to run unchanged under
# MicroPython and CPython: `python|micropython board_script.py DIR` with DIR holding
# controller.py.  It prints one line per decision, floats as the hex of their IEEE-754
# bits, so two interpreters that make the same decisions print the same lines.
import struct
import sys

sys.path.insert(0, sys.argv[1])

from controller import HAL, Config, Controller, Rng, wrap  # noqa: E402

PI = 3.141592653589793


def bits(x):
    return "{:016x}".format(struct.unpack("<Q", struct.pack("<d", x))[0])


def seen(angle):
    """A sensor's reading for the light at ``angle`` rad off its axis: a triangle of
    half-width pi/2 (only + - * / and %, so every interpreter rounds alike)."""
    a = abs(wrap(angle))
    return 1.0 - a / (0.5 * PI) if a < 0.5 * PI else 0.0


class ScriptedHAL(HAL):
    """A robot whose heading (rad, 0 = toward the light) moves only by its own turns,
    under a brightness that follows a script, one entry per period."""

    def __init__(self, heading, brightness):
        self.heading = heading
        self.brightness = brightness
        self.k = 0
        self.log = []

    def light(self):
        b = self.brightness[self.k % len(self.brightness)]
        h = self.heading
        return b * seen(h + 0.6), b * seen(h - 0.6), b * seen(h + PI)

    def turn(self, angle):
        self.heading = self.heading + angle

    def drive(self, speed, seconds):
        self.log.append((speed, seconds))
        self.k += 1


r = Rng(2024)
print("u32", " ".join(str(r.u32()) for _ in range(8)))
runs = (
    ("compression", {}),
    ("transport-connected", {}),
    ("transport-free", {}),
    ("transport-free", {"mapping": "lit_hot", "heading_law": "uniform"}),
    ("narrow-road", {"group": 0}),
    ("narrow-road", {"group": 1, "sigma": 0.3}),
)
script = (0.9, 0.2, 0.0, 0.7, 0.04, 1.0)  # 0.0 and 0.04: too dark, Algorithm 1 gives up
for algorithm, extra in runs:
    hal = ScriptedHAL(2.5, script)
    ctrl = Controller(Config(algorithm=algorithm, **extra), hal, seed=7)
    for _ in range(24):
        theta, v, ok = ctrl.period()
        print(algorithm, ctrl.phase, bits(theta), bits(v), ok, bits(hal.heading))
    for light in (0.1, 0.6, 0.95):
        theta, v = ctrl.decide(light, 1.0)
        print(algorithm, "decide", bits(theta), bits(v))
