"""The controller on a board whose MicroPython has single-precision floats.

Many ports (rp2, stm32, esp8266, nrf) build MicroPython with 32-bit floats.  We emulate
one on CPython: the controller's own source is loaded with every float literal made a
``numpy.float32`` and ``math`` replaced by functions that round to float32, so every
float operation rounds to float32 as on the board (NumPy 2 keeps float32 when it meets a
Python int or float).  The generator's integers are the same on every port, so each
decision is the double-precision one up to rounding; the tests bound that rounding from
an error analysis (unit roundoff u = 2^-24 of float32, each term below named) and check
the bound holds over many draws.
"""

from __future__ import annotations

import ast
import math
import sys
import types
from pathlib import Path

import numpy as np
import pytest

import thermoswarm.robot.controller as ctl

F32 = np.float32
U = 2.0**-24  # float32's unit roundoff: one rounding changes a value x by at most U * |x|
N = 20_000


class _Float32Math:
    """``math`` as a single-precision MicroPython has it (correctly rounded to float32;
    a board's libm may be 1 ulp off, which the bounds below allow for)."""

    pi = F32(math.pi)
    e = F32(math.e)

    @staticmethod
    def log(x):
        return F32(math.log(float(x)))

    @staticmethod
    def sqrt(x):
        return F32(math.sqrt(float(x)))

    @staticmethod
    def cos(x):
        return F32(math.cos(float(x)))

    @staticmethod
    def sin(x):
        return F32(math.sin(float(x)))


class _Float32Literals(ast.NodeTransformer):
    def visit_Constant(self, node):
        if isinstance(node.value, float):
            call = ast.Call(ast.Name("_f32", ast.Load()), [node], [])
            return ast.copy_location(call, node)
        return node


def single_precision_controller():
    """The controller module as a single-precision board runs it."""
    tree = ast.parse(Path(ctl.__file__).read_text())
    tree = ast.fix_missing_locations(_Float32Literals().visit(tree))
    # the module's `import math` binds our float32 math instead
    mod = types.ModuleType("controller_f32")
    mod.__dict__["_f32"] = F32
    code = compile(tree, ctl.__file__, "exec")
    saved = sys.modules["math"]
    try:
        sys.modules["math"] = _Float32Math
        exec(code, mod.__dict__)
    finally:
        sys.modules["math"] = saved
    return mod


@pytest.fixture(scope="module")
def c32():
    return single_precision_controller()


def test_the_emulation_is_single_precision(c32):
    r = c32.Rng(1)
    x = r.random()
    assert type(x) is np.float32
    assert type(c32.wrap(x + 4.0)) is np.float32
    assert type(c32.Controller(c32.Config(), seed=3).decide(F32(0.5))[1]) is np.float32
    # and it is not double precision in disguise
    assert type(c32.TWO_PI) is np.float32 and float(c32.TWO_PI) != 2 * math.pi
    assert c32.Config().kT + 2.0**-30 == c32.Config().kT
    # the integer stream does not depend on the floats
    a, b = c32.Rng(99), ctl.Rng(99)
    assert [a.u32() for _ in range(100)] == [b.u32() for _ in range(100)]


def _wrapped_gap(a, b):
    d = (float(a) - float(b) + math.pi) % (2 * math.pi) - math.pi
    return abs(d)


def _draws(module, algorithm, light, n, f=float, **settings):
    ctrl = module.Controller(module.Config(algorithm=algorithm, **settings), seed=17)
    out = np.empty((n, 2))
    for k in range(n):
        out[k] = [float(x) for x in ctrl.decide(f(light))]
    return out


def test_uniform_headings_within_rounding():
    """theta = a + (b - a) r, |a| = |b| = pi: a, b, b - a, the product and the sum each
    round once (a change of at most U * 2 pi each, five terms); r itself is the integer
    u + 0.5 rounded (1 ulp for the int's conversion, half for the sum: 3 U relative),
    times 2 pi.  Bound: (5 + 3) U 2 pi = 3.0e-6 rad."""
    bound = 8 * U * 2 * math.pi
    for algorithm, kw in (("compression", {}), ("transport-free", {"heading_law": "uniform"})):
        d64 = _draws(ctl, algorithm, 0.9, N, v_max=None, **kw)
        d32 = _draws(single_precision_controller(), algorithm, 0.9, N, F32, v_max=None, **kw)
        gaps = [_wrapped_gap(a, b) for a, b in zip(d32[:, 0], d64[:, 0], strict=True)]
        assert 0 < max(gaps) <= bound, (algorithm, max(gaps), bound)


def test_energies_within_rounding(c32):
    """E = -kT log r.  r is off by at most 3 U relative (previous test), so log r by
    3 U absolute, E by 3 U kT; kT, log, the product each round once (3 U E); v = sqrt(2E)
    rounds once, and e = v^2 / 2 (in double) doubles that relative error (2 U E).
    Bound: |e32 - e64| <= U (3 kT + 5 E) to first order; 1.25x for second-order terms."""
    kT = 63.66
    d64 = _draws(ctl, "compression", 0.9, N, kT=kT, v_max=None)
    d32 = _draws(c32, "compression", 0.9, N, F32, kT=kT, v_max=None)
    e64, e32 = d64[:, 1] ** 2 / 2, d32[:, 1] ** 2 / 2
    excess = np.abs(e32 - e64) / (1.25 * U * (3 * kT + 5 * e64))
    assert 0 < excess.max() <= 1.0, excess.max()
    # the law is unchanged: the mean energy is kT within its standard error (4 sigma)
    assert abs(e32.mean() - kT) < 4 * kT / math.sqrt(N)


def test_narrow_road_headings_within_rounding(c32):
    """theta = wrap(goal + sigma z), z = rho cos(phi), rho = sqrt(s), s = -2 log r1,
    phi = 2 pi r2 (Box-Muller).  With r off by 3 U relative: s by 6 U + U s (log's
    rounding), rho by ds / (2 rho) + U rho (or sqrt(ds) where rho^2 < ds), phi by
    5 U 2 pi, cos(phi) by that + U, z by d_rho + rho (d_phi + U) + U |z|; sigma, the
    product, goal, the sum and the wrap (two roundings and pi's twice, U (|x| + 6 pi))
    add U (4 sigma |z| + 9 pi).  First-order bound per draw, 1.25x for the rest."""
    sigma = 0.7854
    c64 = ctl.Controller(ctl.Config(algorithm="narrow-road", sigma=sigma), seed=23)
    b = c32.Controller(c32.Config(algorithm="narrow-road", sigma=F32(sigma)), seed=23)
    drawn = []
    draw = c64.rng.random
    c64.rng.random = lambda: drawn.append(draw()) or drawn[-1]
    worst = 0.0
    for _ in range(N):
        drawn.clear()
        t64, _ = c64.decide()
        t32, _ = b.decide()
        _, r1, r2 = drawn  # the energy's draw, then the normal's two
        s = -2 * math.log(r1)
        ds = 6 * U + U * s
        rho = math.sqrt(s)
        d_rho = math.sqrt(ds) if rho * rho < ds else ds / (2 * rho) + U * rho
        d_phi = 5 * U * 2 * math.pi
        z = rho * math.cos(2 * math.pi * r2)
        dz = d_rho + rho * (d_phi + U) + U * abs(z)
        bound = 1.25 * (sigma * dz + U * (4 * sigma * abs(z) + 9 * math.pi))
        gap = _wrapped_gap(t32, t64)
        assert gap <= bound, (gap, bound, r1, r2)
        worst = max(worst, gap / bound)
    assert worst > 0.0  # the two did differ: the emulation rounds


def test_persistent_heading_drift_stays_within_accumulated_rounding(c32):
    """The board keeps its own heading (Algorithm 5, persistent law): theta_k =
    wrap(theta_{k-1} + turn_k), so rounding accumulates.  Per period: the turn
    -s log r (s = kT_theta tau; as for energies, U (3 s + 3 |turn|)), the sum
    (U (pi + |turn|)) and the wrap (U (|x| + 6 pi), |x| <= pi + |turn|): in all
    U (3 s + 5 |turn| + 8 pi), 1.25x for second-order terms.  After n periods the gap is
    at most the sum of these; it grows like a random walk, far slower."""
    n = 5000
    s = 0.8  # kT_theta * tau, the defaults
    a = ctl.Controller(ctl.Config(algorithm="transport-free"), seed=5)
    b = c32.Controller(c32.Config(algorithm="transport-free"), seed=5)
    drawn = []
    draw = a.rng.random
    a.rng.random = lambda: drawn.append(draw()) or drawn[-1]
    budget = 8 * U * 2 * math.pi  # the first heading: uniform, bounded as above
    worst = 0.0
    for _ in range(n):
        drawn.clear()
        ta, _ = a.decide(0.2)
        tb, _ = b.decide(F32(0.2))
        turn = -s * math.log(drawn[1])  # the energy's draw, the turn's, the sign's
        budget += 1.25 * U * (3 * s + 5 * turn + 8 * math.pi)
        gap = _wrapped_gap(ta, tb)
        assert gap <= budget
        worst = max(worst, gap)
    # after 5,000 periods the board's heading is the reference's to microradians
    # (measured: 6.5e-6 rad after 5,000 periods, about sqrt(n) single roundings)
    assert 0 < worst < 1e-4


def test_a_draw_of_exactly_one_is_harmless(c32):
    """With 24-bit floats, u + 0.5 rounds up to 2^32 for the top 128 integers, so
    random() returns 1.0 (probability 2^-25): the energy is 0 and the robot stands still
    for a period; nothing divides by it and log(1) = 0."""
    r = c32.Rng(0)
    r.u32 = lambda: 2**32 - 1
    assert r.random() == 1.0
    assert r.exponential(F32(63.66)) == 0.0
    assert r.normal() == 0.0
    # the double-precision generator stays inside the open interval
    r64 = ctl.Rng(0)
    r64.u32 = lambda: 2**32 - 1
    assert r64.random() < 1.0
