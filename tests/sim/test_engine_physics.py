"""The engine's physics: non-overlap, diffusion, force balance, elastic gas."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from thermoswarm.maxent import SpeedLaw, kT_for_mean_speed
from thermoswarm.policy import Action, BoltzmannUniform
from thermoswarm.sim import (
    Body,
    EngineParams,
    Piston,
    Simulator,
    World,
    box_world,
    place_lattice,
    polygon_segments,
)

R = 16.5
D = 2 * R
KT10 = kT_for_mean_speed(10.0)  # mean speed 10 mm/s


def _box(n, phi):
    side = math.sqrt(n * math.pi * R * R / phi)
    return box_world(side, side), side


@pytest.mark.parametrize("tau", [0.1, 1.0])
def test_dense_swarm_never_overlaps_nor_escapes(tau):
    """At packing fraction 0.5, overlaps stay below 2 % of the diameter at every step."""
    n = 600
    world, side = _box(n, 0.5)
    sim = Simulator(world, EngineParams(dt=0.1, tau=tau), BoltzmannUniform(KT10))
    rng = np.random.default_rng(11)
    state = sim.init(place_lattice(world.bounds, n, R, rng), rng)
    worst = 0.0
    for k in range(1500):
        sim.step(state)
        if k % 5 == 0:
            worst = max(worst, sim.max_overlap(state))
            # nobody outside the walls (beyond the 2 % tolerance)
            assert state.pos.min() > R - 0.02 * D
            assert state.pos.max() < side - R + 0.02 * D
    assert worst < 0.02 * D
    # the engine's own bookkeeping of the largest overlap left by any step agrees
    assert state.counters[1] / 1e6 < 0.02 * D


def test_projection_resolves_a_head_on_pair_exactly():
    """Two robots driven into each other stop at contact and share the push equally."""

    class Toward:
        def act(self, obs, rng):
            # robot with id 0 goes +x, id 1 goes -x
            h = np.where(obs.ids == 0, 0.0, np.pi)
            return Action(heading=h, speed=np.full(obs.n, 10.0))

    world = box_world(1000, 1000)
    sim = Simulator(world, EngineParams(dt=0.1, tau=0.1, desync=False), Toward())
    rng = np.random.default_rng(0)
    state = sim.init(np.array([[460.0, 500.0], [540.0, 500.0]]), rng)
    for _ in range(100):
        sim.step(state)
    p = state.by_id(state.pos)
    assert p[1, 0] - p[0, 0] == pytest.approx(D, abs=0.005 * D)
    # symmetric: the pair stays centred on x = 500
    assert (p[0, 0] + p[1, 0]) / 2 == pytest.approx(500.0, abs=1e-9)


def test_diffusion_matches_kT_tau_over_2():
    """Uniform headings re-drawn every tau: D = <v^2> tau / 4 = kT tau / 2 (2D)."""
    n, tau, kT = 150, 1.0, KT10
    side = 40_000.0
    world = box_world(side, side)
    params = EngineParams(dt=0.1, tau=tau)
    sim = Simulator(world, params, BoltzmannUniform(kT))
    rng = np.random.default_rng(3)
    # start in the middle so that no robot reaches a wall during the run
    pos = place_lattice((15_000, 15_000, 25_000, 25_000), n, R, rng)
    state = sim.init(pos, rng)
    window, gap = 40, 10  # steps: 4 tau windows separated by one tau
    sq = []
    start = state.by_id(state.pos).copy()
    t = 0
    for _ in range(100):
        for _ in range(window):
            sim.step(state)
        p = state.by_id(state.pos)
        sq.append(((p - start) ** 2).sum(axis=1))
        for _ in range(gap):
            sim.step(state)
        start = state.by_id(state.pos).copy()
        t += window + gap
    sq = np.concatenate(sq)
    T = window * params.dt
    # <|dr|^2> = 4 D T - <v^2> tau^2 / 3 for T >= tau (exact for fixed-length runs)
    est = (sq + 2 * kT * tau**2 / 3) / (4 * T)
    se = est.std(ddof=1) / math.sqrt(est.size)
    assert state.pos.min() > R and state.pos.max() < side - R  # walls never touched
    assert abs(est.mean() - kT * tau / 2) < 4 * se, (est.mean(), kT * tau / 2, se)
    # and the tolerance is a real constraint: 10 % off would be rejected
    assert 0.1 * kT * tau / 2 > 4 * se


def _batch_se(x, batches):
    m = np.array([c.mean() for c in np.array_split(np.asarray(x), batches)])
    return m.std(ddof=1) / math.sqrt(batches)


def _piston_column(n, width, F, kT, seed, y_start=400.0, height=1000.0):
    """Side walls static, a held piston at the bottom (a force gauge), a top piston
    pushed down by F."""
    seg = np.array([[0, 0, 0, height], [width, 0, width, height]], dtype=float)
    top = Piston(
        axis=1,
        position=y_start,
        side=-1,
        lo=0,
        hi=width,
        force=F,
        drag=20.0,
        limits=(50.0, height),
    )
    bottom = Piston(axis=1, position=0.0, side=+1, lo=0, hi=width, force=0.0, drag=math.inf)
    world = World((0.0, 0.0, width, height), seg, pistons=(top, bottom))
    params = EngineParams(dt=0.1, tau=1.0)
    sim = Simulator(world, params, BoltzmannUniform(kT))
    rng = np.random.default_rng(seed)
    state = sim.init(place_lattice((0, 0, width, y_start), n, R, rng), rng)
    return sim, state


def test_piston_under_force_settles_where_pressure_balances():
    """A wall pushed by F stops where the swarm's pressure, measured independently on
    the opposite (held) wall, balances F: the force is transmitted through the robots.

    The wall forces fluctuate with the swarm's density profile, which relaxes on the
    diffusive time h^2 / (pi^2 D) ~ 60 s here (h ~ 270 mm, D = kT tau / 2 ~ 127 mm^2/s);
    the standard error comes from batch means over batches five times longer."""
    F = 95.0
    sim, state = _piston_column(n=200, width=4000.0, F=F, kT=kT_for_mean_speed(20.0), seed=0)
    for _ in range(3000):  # settle (the wall moves at most F / drag = 4.75 mm/s)
        sim.step(state)
    f_top, f_bot, y_top = (np.empty(24000) for _ in range(3))
    for k in range(24000):
        sim.step(state)
        f_top[k], f_bot[k] = state.piston_force
        y_top[k] = state.piston_pos[0]
    batches = 8  # of 300 s
    # robots push the top wall up (+y) and the bottom wall down (-y)
    assert f_top.mean() > 0 > f_bot.mean()
    # the moving wall is in balance: mean contact force = F
    assert abs(f_top.mean() - F) < 4 * _batch_se(f_top, batches)
    # the held wall, an independent gauge, feels the same force: pressure balances F
    se = _batch_se(f_bot, batches)
    assert abs(-f_bot.mean() - F) < 4 * se
    assert 4 * se < 0.25 * F  # and the check is tight enough to mean something
    # the wall has settled: no drift between the two halves of the run.  The difference
    # of two means has the standard error sqrt(se1^2 + se2^2), each half's from its own
    # batch means (4 batches of 300 s each)
    half = y_top.size // 2
    se_diff = math.hypot(_batch_se(y_top[:half], 4), _batch_se(y_top[half:], 4))
    assert abs(y_top[:half].mean() - y_top[half:].mean()) < 4 * se_diff


def test_wall_forces_balance_momentum_exactly_each_step():
    """Bookkeeping of contact forces (Newton's third law), exact per step: the robots'
    total displacement is their commanded motion plus what the walls gave them."""
    sim, state = _piston_column(n=300, width=1500.0, F=40.0, kT=KT10, seed=1, y_start=600.0)
    for _ in range(200):
        sim.step(state)
    dt = sim.params.dt
    checked = 0
    for _ in range(100):
        y_before = state.pos[:, 1].sum()
        sim.step(state)
        # decisions happen at the start of a step and hold through it, so the arrays
        # after the step are the commands that moved the robots during it
        commanded = (state.speed * np.sin(state.heading)).sum() * dt
        dy = state.pos[:, 1].sum() - y_before
        on_robots = -state.piston_force.sum()  # forces on the pistons, reversed
        walls = on_robots * dt / sim.params.drag
        assert abs(state.piston_force[1]) > 0  # the gauge is in contact: not vacuous
        assert dy == pytest.approx(commanded + walls, abs=1e-7 * state.n)
        checked += 1
    assert checked == 100


@pytest.mark.parametrize("k", [1, 3])
def test_body_pushed_by_k_robots_moves_at_rigid_speed(k):
    """A column of k robots pushing a body of drag g_b moves it at k g_r v / (k g_r + g_b),
    and the reported contact force is g_b times the body's speed."""

    class Up:
        def act(self, obs, rng):
            return Action(heading=np.full(obs.n, np.pi / 2), speed=np.full(obs.n, 10.0))

    gb, v = 6.0, 10.0
    body = Body(x=500.0, y=600.0, radius=50.0, drag=gb)
    world = box_world(1000, 3000, bodies=(body,))
    sim = Simulator(world, EngineParams(dt=0.1, tau=0.1, desync=False), Up())
    rng = np.random.default_rng(0)
    ys = 600.0 - 50 - R - 0.5 - D * np.arange(k)  # a column touching the body
    state = sim.init(np.column_stack([np.full(k, 500.0), ys]), rng)
    for _ in range(20):
        sim.step(state)
    y0 = state.body_pos[0, 1]
    steps = 100
    force = 0.0
    for _ in range(steps):
        sim.step(state)
        force += state.body_force[0, 1] / steps
    speed = (state.body_pos[0, 1] - y0) / (steps * 0.1)
    expected = k * v / (k + gb)
    assert speed == pytest.approx(expected, rel=1e-3)
    assert force == pytest.approx(gb * speed, rel=1e-6)
    # straight ahead: the only sideways push comes from the float32 unit directions the
    # engine uses (error ~3e-8); a pushed column is an unstable equilibrium and amplifies
    # it, but over this run it stays straight to 1e-3 of the distance travelled
    travelled = state.body_pos[0, 1] - 600.0
    assert abs(state.body_pos[0, 0] - 500.0) < 1e-3 * travelled


def test_robots_stay_inside_a_polygon_road():
    """Static polygon walls (a channel with a narrow section) keep robots inside."""
    outline = [
        (0, 0),
        (800, 0),
        (800, 100),
        (500, 100),
        (500, 140),
        (300, 140),
        (300, 100),
        (0, 100),
    ]
    # a closed channel outline: the walls run along it
    pts = np.array(outline, dtype=float)
    world = World((0.0, 0.0, 800.0, 140.0), polygon_segments(pts))
    sim = Simulator(world, EngineParams(dt=0.1, tau=1.0), BoltzmannUniform(4 * KT10))
    rng = np.random.default_rng(2)
    pos = place_lattice((0, 0, 800, 100), 20, R, rng)
    state = sim.init(pos, rng)
    for _ in range(3000):
        sim.step(state)
        assert np.all(state.pos[:, 0] > R - 0.02 * D) and np.all(state.pos[:, 0] < 800 - R + 0.7)
        assert np.all(state.pos[:, 1] > R - 0.02 * D)
    assert sim.max_overlap(state) < 0.02 * D


def test_inertial_gas_conserves_energy_and_relaxes_to_maxwell_boltzmann():
    """Elastic discs: energy drift < 1e-6 over 1000 collisions per particle, and speeds
    that start all equal end Rayleigh-distributed (2D Maxwell-Boltzmann)."""
    n, phi = 200, 0.25
    world, side = _box(n, phi)
    params = EngineParams(dt=0.2, mode="inertial")
    sim = Simulator(world, params)
    rng = np.random.default_rng(7)
    pos = place_lattice(world.bounds, n, R, rng)
    th = rng.uniform(-np.pi, np.pi, n)
    v0 = 10.0  # every particle starts at the same speed: far from equilibrium
    state = sim.init(pos, rng, velocities=np.column_stack([v0 * np.cos(th), v0 * np.sin(th)]))
    e0 = 0.5 * np.sum(state.vel**2)
    speeds = []
    while 2 * state.counters[0] / n < 1000:
        for _ in range(200):
            sim.step(state)
        if 2 * state.counters[0] / n > 50:  # after relaxation: sample every ~1.5 collisions
            speeds.append(np.hypot(state.vel[:, 0], state.vel[:, 1]))
    e1 = 0.5 * np.sum(state.vel**2)
    assert abs(e1 - e0) / e0 < 1e-6
    kT = e0 / n  # per unit mass: <v^2>/2 = kT in 2D
    v = np.concatenate(speeds)
    # snapshots ~1.5 collision times apart are close to independent; use a thinned set
    v = v[:: max(1, v.size // 4000)]
    ks = stats.kstest(v, SpeedLaw(kT).cdf)
    assert ks.pvalue > 0.01, ks
    # the test has power: the initial (delta) law and a half-normal law are rejected
    assert (
        stats.kstest(np.full(v.size, v0) + 1e-9 * np.arange(v.size), SpeedLaw(kT).cdf).pvalue
        < 1e-6
    )
    from thermoswarm.maxent import HalfNormalSpeed

    assert stats.kstest(v, HalfNormalSpeed(kT).cdf).pvalue < 1e-6
    # no particle escaped
    assert state.pos.min() > 0 and state.pos.max() < side
