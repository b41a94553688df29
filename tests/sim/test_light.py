"""Light, shadows, photoresistors and TurnToAngle on constructed cases with known answers."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import stats

from thermoswarm.config import from_mapping
from thermoswarm.errors import ConfigError, InputError
from thermoswarm.sim import light as light_mod
from thermoswarm.sim.geometry import Disc, Polygon, Polyline, Segment, Shapes
from thermoswarm.sim.light import (
    DirectionalLight,
    PointLight,
    SensingParams,
    direct_light,
    ideal_zero_heading,
    light_level,
    read_sensors,
    sense,
    turn_to_angle,
)

EPS = 1e-9
UP = DirectionalLight(direction=(0.0, -1.0))  # light from the +y side: heading 0 is +y


def unit(angle: float) -> np.ndarray:
    return np.array([math.cos(angle), math.sin(angle)])


def wrap_deg(a):
    return (np.asarray(a) + 180.0) % 360.0 - 180.0


# ----------------------------------------------------------------------------- shadows


@pytest.mark.parametrize("source_angle_deg", [90.0, 30.0, -135.0])
def test_disc_shadow_strip_tangent_boundary(source_angle_deg):
    # Points placed at depth t behind the disc (away from the source) and lateral offset q
    # from the axis: the shadow is exactly the strip |q| < r behind the disc.
    r = 50.0
    c = np.array([120.0, -40.0])
    u = unit(math.radians(source_angle_deg))  # toward the source
    n = np.array([-u[1], u[0]])
    light = DirectionalLight(direction=tuple(-u))
    q = np.array([0.0, r - 1e-6, -(r - 1e-6), r + 1e-6, -(r + 1e-6), 3 * r])
    expected_dark = np.abs(q) < r
    for t in (60.0, 500.0, 5000.0):
        pts = c - t * u + q[:, None] * n
        level = light_level(pts, light, [Disc(tuple(c), r)])
        np.testing.assert_array_equal(level, np.where(expected_dark, 0.0, 1.0))
    # In front of the disc (between it and the source) everything is lit.
    pts = c + 200.0 * u + q[:, None] * n
    np.testing.assert_array_equal(light_level(pts, light, [Disc(tuple(c), r)]), 1.0)
    # Inside the disc is dark.
    assert light_level(c + 0.5 * r * n, light, [Disc(tuple(c), r)])[0] == 0.0


def test_grazing_ray_is_not_blocked():
    # Exactly representable tangent: the ray from (+-50, -100) upward touches the disc.
    pts = [[50.0, -100.0], [-50.0, -100.0], [49.999999, -100.0]]
    np.testing.assert_array_equal(light_level(pts, UP, [Disc((0.0, 0.0), 50.0)]), [1, 1, 0])


def test_point_light_disc_shadow_cone():
    # Lamp at (0, 500), disc r = 50 at the origin: the shadow is the cone bounded by the
    # tangents from the lamp, half-angle asin(50 / 500) about the -y axis.
    lamp = PointLight(position=(0.0, 500.0), falloff="none")
    edge = 800.0 * math.tan(math.asin(50.0 / 500.0))  # tangent line at y = -300
    x = np.array([0.0, edge - 1e-6, -(edge - 1e-6), edge + 1e-6, -(edge + 1e-6)])
    pts = np.c_[x, np.full(x.size, -300.0)]
    level = light_level(pts, lamp, [Disc((0.0, 0.0), 50.0)])
    np.testing.assert_array_equal(level, [0, 0, 0, 1, 1])
    # The disc beyond the lamp casts no shadow toward the lamp's near side.
    assert light_level([[0.0, 800.0]], lamp, [Disc((0.0, 0.0), 50.0)])[0] == 1.0


def test_segment_occlusion_directional_and_point():
    wall = Segment((-100.0, 0.0), (100.0, 0.0))
    x = np.array([0.0, 100.0 - 1e-6, 100.0 + 1e-6, -100.0 + 1e-6, -100.0 - 1e-6])
    below = np.c_[x, np.full(x.size, -50.0)]
    np.testing.assert_array_equal(light_level(below, UP, [wall]), [0, 0, 1, 0, 1])
    np.testing.assert_array_equal(light_level(below + [0, 100], UP, [wall]), 1.0)
    # Light from the upper right at 45 deg: the ray from (x, -50) meets y = 0 at x + 50.
    diag = DirectionalLight(direction=(-1.0, -1.0))
    xs = np.array([-150.0 - 1e-6, -150.0 + 1e-6, 0.0, 50.0 - 1e-6, 50.0 + 1e-6])
    pts = np.c_[xs, np.full(xs.size, -50.0)]
    np.testing.assert_array_equal(light_level(pts, diag, [wall]), [1, 0, 0, 0, 1])
    # Lamp at (0, 100) above the wall: the segment from (x, -100) crosses y = 0 at x / 2.
    lamp = PointLight(position=(0.0, 100.0), falloff="none")
    xs = np.array([0.0, 200.0 - 1e-6, 200.0 + 1e-6, -200.0 + 1e-6, -200.0 - 1e-6])
    pts = np.c_[xs, np.full(xs.size, -100.0)]
    np.testing.assert_array_equal(light_level(pts, lamp, [wall]), [0, 0, 1, 0, 1])
    # The lamp between the point and the wall: nothing blocks.
    assert light_level([[0.0, 200.0]], lamp, [wall])[0] == 1.0


def test_polygon_and_polyline_occlusion():
    square = Polygon(((-40.0, -40.0), (40.0, -40.0), (40.0, 40.0), (-40.0, 40.0)))
    x = np.array([0.0, 39.9, -39.9, 40.1, -40.1])
    below = np.c_[x, np.full(x.size, -200.0)]
    np.testing.assert_array_equal(light_level(below, UP, [square]), [0, 0, 0, 1, 1])
    assert light_level([[0.0, 0.0]], UP, [square])[0] == 0.0  # inside
    assert light_level([[0.0, 41.0]], UP, [square])[0] == 1.0  # lit face
    # A closed triangle has the edge (50, 0)-(-50, 100); the open chain does not.
    verts = ((-50.0, 100.0), (-50.0, 0.0), (50.0, 0.0))
    p = [[0.0, 20.0]]  # inside the triangle: its ray up crosses the closing edge
    assert light_level(p, UP, [Polygon(verts)])[0] == 0.0
    assert light_level(p, UP, [Polyline(verts)])[0] == 1.0
    assert Polygon(verts).segments().shape == (3, 4)
    assert Polyline(verts).segments().shape == (2, 4)


def test_moving_object_moves_its_shadow():
    static = Shapes.from_shapes([Disc((0.0, 0.0), 50.0), Segment((500, 0), (600, 0))])
    p = [[0.0, -200.0], [300.0, -200.0]]
    np.testing.assert_array_equal(light_level(p, UP, static), [0, 1])
    moved = static.with_disc_centers([[300.0, 0.0]])
    np.testing.assert_array_equal(light_level(p, UP, moved), [1, 0])
    assert moved.n_segments == 1 and static.discs[0, 0] == 0.0


@pytest.mark.parametrize(
    "falloff, factor",
    [
        ("inverse_square", lambda r: np.minimum(1.0, (100.0 / r) ** 2)),
        ("inverse", lambda r: np.minimum(1.0, 100.0 / r)),
        ("none", lambda r: np.ones_like(r)),
    ],
)
def test_point_light_falloff_and_ambient(falloff, factor):
    lamp = PointLight(position=(10.0, -20.0), falloff=falloff, reference_distance=100.0)
    r = np.array([1e-3, 50.0, 100.0, 200.0, 400.0, 1000.0])
    ang = np.linspace(0, 5, r.size)
    pts = np.array([10.0, -20.0]) + r[:, None] * np.c_[np.cos(ang), np.sin(ang)]
    np.testing.assert_allclose(light_level(pts, lamp), factor(r), rtol=1e-12)
    np.testing.assert_allclose(
        light_level(pts, lamp, ambient=0.2), 0.2 + 0.8 * factor(r), rtol=1e-12
    )


def test_several_sources_are_weighted_by_intensity():
    left = DirectionalLight(direction=(1.0, 0.0), intensity=3.0)  # from -x
    up = DirectionalLight(direction=(0.0, -1.0), intensity=1.0)
    wall = Segment((-100.0, 10.0), (100.0, 10.0))  # blocks light from +y only
    w = direct_light([[0.0, 0.0], [0.0, 20.0]], [left, up], [wall])
    np.testing.assert_allclose(w, [[0.75, 0.0], [0.75, 0.25]])
    np.testing.assert_allclose(light_level([[0.0, 0.0]], [left, up], [wall]), [0.75])


def test_soft_shadow_known_fractions():
    alpha = math.radians(5.0)
    soft = DirectionalLight(direction=(0.0, -1.0), angular_radius_deg=5.0)
    # Behind a disc: it covers [-delta, delta] with delta = asin(r / d).
    d_pen = 50.0 / math.sin(math.radians(3.0))
    d_umb = 50.0 / math.sin(math.radians(10.0))
    lv = light_level([[0.0, -d_pen], [0.0, -d_umb]], soft, [Disc((0.0, 0.0), 50.0)])
    np.testing.assert_allclose(lv, [1 - 3.0 / 5.0, 0.0], atol=1e-12)
    # Below the end of a long wall reaching to -x: the blocked arc runs from the end's
    # direction atan(x / 100) to beyond +alpha, so s = (alpha + atan(x / 100)) / (2 alpha).
    wall = Segment((-1e6, 0.0), (0.0, 0.0))
    x = np.array([0.0, 100 * math.tan(alpha / 2), -100 * math.tan(alpha / 2), 20.0, -20.0])
    expected = np.clip((alpha + np.arctan(x / 100.0)) / (2 * alpha), 0, 1)
    np.testing.assert_allclose(
        light_level(np.c_[x, np.full(x.size, -100.0)], soft, [wall]), expected, atol=1e-12
    )
    assert expected[0] == 0.5 and expected[1] == pytest.approx(0.75)
    # A lamp of radius 200 mm at distance 1000 behind a disc of r = 50 at distance 500.
    lamp = PointLight(position=(0.0, 1000.0), falloff="none", radius=200.0)
    lv = light_level([[0.0, 0.0]], lamp, [Disc((0.0, 500.0), 50.0)])
    assert lv[0] == pytest.approx(1 - math.asin(0.1) / math.asin(0.2), abs=1e-12)
    assert light_level([[0.0, 0.0]], lamp, [Disc((0.0, 1200.0), 50.0)])[0] == 1.0


def _sampled_soft(points, occ, center_angle, alpha, dist, n_sub):
    """Average of hard visibility over sub-sources spread uniformly across the source."""
    phis = center_angle + alpha * ((np.arange(n_sub) + 0.5) / n_sub * 2 - 1)
    out = np.empty(len(points))
    for i, p in enumerate(points):
        if dist is None:
            subs = [DirectionalLight(direction=tuple(-unit(ph))) for ph in phis]
        else:
            subs = [PointLight(position=tuple(p + dist * unit(ph)), falloff="none") for ph in phis]
        out[i] = light_level([p], subs, occ)[0]
    return out


def test_soft_visibility_equals_average_over_the_extended_source(rng):
    # Independent check of the interval algebra (unions, depth clipping, wrap-around):
    # the analytic soft visibility must equal the share of hard sub-sources visible.
    occ = Shapes.from_shapes(
        [
            Disc((0.0, 150.0), 40.0),
            Disc((60.0, 260.0), 25.0),
            Segment((-120.0, 200.0), (10.0, 230.0)),
            Polyline(((30.0, 120.0), (90.0, 160.0), (40.0, 330.0))),
        ]
    )
    pts = np.c_[rng.uniform(-60, 100, 8), rng.uniform(-80, 60, 8)]
    n_sub = 1000
    n_edges = 2 * (occ.n_discs + occ.n_segments)
    tol = n_edges / n_sub  # each interval end shifts the midpoint-rule share by <= 1/n_sub
    alpha = math.radians(12.0)
    soft = DirectionalLight(direction=(0.0, -1.0), angular_radius_deg=12.0)
    got = light_level(pts, soft, occ)
    want = _sampled_soft(pts, occ, math.pi / 2, alpha, None, n_sub)
    np.testing.assert_allclose(got, want, atol=tol)
    assert np.ptp(got) > 0.3  # the points see different amounts of the source
    lamp_pos = np.array([20.0, 240.0])  # among the occluders: depth clipping matters
    lamp = PointLight(position=tuple(lamp_pos), falloff="none", radius=15.0)
    got = light_level(pts, lamp, occ)
    want = np.empty(len(pts))
    for i, p in enumerate(pts):
        v = lamp_pos - p
        dist = float(np.hypot(*v))
        want[i] = _sampled_soft(
            [p], occ, math.atan2(v[1], v[0]), math.asin(15.0 / dist), dist, n_sub
        )[0]
    np.testing.assert_allclose(got, want, atol=tol)


def _lattice(rng, n_side, spacing=40.0, jitter=3.0):
    g = np.arange(n_side) * spacing
    xy = np.array(np.meshgrid(g, g)).reshape(2, -1).T
    return xy + rng.uniform(-jitter, jitter, xy.shape)  # centres >= 34 mm apart


@pytest.mark.parametrize("layout", ["lattice", "overlapping"])
def test_robot_shadows_match_brute_force(rng, layout):
    r = 16.5
    if layout == "lattice":
        pos = _lattice(rng, 16)
        pos = pos[rng.random(len(pos)) < 0.4]  # a sparse swarm: some robots lit, some not
    else:
        pos = rng.uniform(0, 600, (150, 2))  # robots may overlap (soft contacts)
    wvec = pos[None, :, :] - pos[:, None, :]  # caster j minus query i
    # Directional light from the upper left.
    u = unit(math.radians(120.0))
    along = wvec @ u
    perp = wvec[..., 0] * u[1] - wvec[..., 1] * u[0]
    dark = ((along > 0) & (np.abs(perp) < r)).any(axis=1)  # a centre ahead, within r
    light = DirectionalLight(direction=tuple(-u))
    got = light_level(pos, light, None, casters=pos, caster_radius=r)
    np.testing.assert_array_equal(got, np.where(dark, 0.0, 1.0))
    assert 0.1 < dark.mean() < 0.95  # a non-trivial mix of lit and shadowed robots
    # A lamp just outside the swarm.
    lamp_pos = np.array([700.0, 300.0])
    v = lamp_pos - pos  # (n, 2)
    t = np.einsum("ijk,ik->ij", wvec, v) / (v * v).sum(1)[:, None]
    closest = wvec - np.minimum(t, 1)[..., None] * v[:, None, :]
    dark = ((np.hypot(closest[..., 0], closest[..., 1]) < r) & (t > 0)).any(axis=1)
    lamp = PointLight(position=tuple(lamp_pos), falloff="none")
    got = light_level(pos, lamp, None, casters=pos, caster_radius=r)
    np.testing.assert_array_equal(got, np.where(dark, 0.0, 1.0))
    assert 0.1 < dark.mean() < 0.95  # a non-trivial mix of lit and shadowed robots
    # Off by default.
    np.testing.assert_array_equal(light_level(pos, lamp), 1.0)


# ----------------------------------------------------------------------------- sensors


def test_sensors_facing_the_light_and_cosine_response():
    p = SensingParams()  # a = 30 deg, fov = 160 deg
    a = math.radians(30.0)
    pos = np.zeros((1, 2))
    r = read_sensors(pos, [math.pi / 2], UP, None, p)
    assert r[0, 0] == r[0, 1] > 0 and r[0, 2] == 0.0
    assert r[0, 0] == pytest.approx(math.cos(a), abs=1e-12)
    r = read_sensors(pos, [math.pi / 2], UP, None, p, ambient=0.02)
    np.testing.assert_allclose(r[0], [0.02 + 0.98 * math.cos(a)] * 2 + [0.02], atol=1e-12)
    # Light at relative angle psi (from the heading): l1 = cos(psi - a) within fov/2.
    psi = np.radians([0, 20, 45, 79, 95, 115, 170, -60, -100, -150])
    heading = math.pi / 2 - psi
    got = read_sensors(np.zeros((psi.size, 2)), heading, UP, None, p)

    def resp(gamma):
        gamma = np.abs(np.angle(np.exp(1j * gamma)))
        return np.where(gamma <= math.radians(80.0), np.cos(gamma), 0.0)

    want = np.c_[resp(psi - a), resp(psi + a), resp(psi - math.pi)]
    np.testing.assert_allclose(got, want, atol=1e-12)


def test_sensor_noise_moments(rng):
    p = SensingParams(noise_mult=0.05, noise_add=0.01)
    n = 40000
    r = read_sensors(np.zeros((n, 2)), np.full(n, math.pi / 2), UP, None, p, rng)
    mu = math.cos(math.radians(30.0))
    sd = math.hypot(0.05 * mu, 0.01)
    for k in (0, 1):
        assert abs(r[:, k].mean() - mu) < 4 * sd / math.sqrt(n)
        assert abs(r[:, k].std() / sd - 1) < 4 / math.sqrt(2 * n)
    assert np.corrcoef(r[:, 0], r[:, 1])[0, 1] == pytest.approx(0, abs=4 / math.sqrt(n))
    # l3 reads max(0, N(0, 0.01^2)): half the readings are exactly 0.
    assert abs((r[:, 2] == 0).mean() - 0.5) < 4 * 0.5 / math.sqrt(n)


# ------------------------------------------------------------------------ TurnToAngle


def _random_lit_robots(rng, n):
    pos = np.c_[rng.uniform(-400, 400, n), rng.uniform(100, 400, n)]
    return pos, rng.uniform(-math.pi, math.pi, n)


@pytest.mark.parametrize("turn", ["toward", "fixed"])
@pytest.mark.parametrize(
    "light", [UP, PointLight(position=(150.0, 900.0)), DirectionalLight((1.0, 0.3))]
)
def test_turn_to_angle_noise_free_ends_within_a_step(rng, turn, light):
    p = SensingParams(turn=turn)
    pos, h0 = _random_lit_robots(rng, 3000)
    occ = [Disc((0.0, 0.0), 50.0)]
    res = turn_to_angle(pos, h0, light, occ, p)
    if isinstance(light, DirectionalLight):
        true = np.full(len(pos), light.source_angle)
    else:
        true = np.arctan2(light.position[1] - pos[:, 1], light.position[0] - pos[:, 0])
    lit = light_level(pos, light, occ) > 0
    assert 0.5 < lit.mean()
    np.testing.assert_array_equal(res.converged, lit)
    err = np.abs(wrap_deg(np.degrees(res.heading - true)))[lit]
    assert err.max() <= math.degrees(p.balance_window) + 1e-9
    assert math.degrees(p.balance_window) <= p.step_deg
    # "toward" never turns through the arc the front pair covers (+-(a + fov/2)) the
    # wrong way; "fixed" turns at most once round.
    arc = 360 - (p.sensor_angle_deg + p.fov_deg / 2) if turn == "toward" else 360
    assert res.steps.max() <= arc / p.step_deg + 1
    assert (res.steps[~lit] == 0).all()
    np.testing.assert_array_equal(res.heading[~lit], h0[~lit])
    # The heading moved by whole steps.
    moved = wrap_deg(np.degrees(res.heading - h0)) / p.step_deg
    np.testing.assert_allclose(moved, np.round(moved), atol=1e-6)


def test_turn_toward_takes_the_fewest_steps(rng):
    # With the light within +-100 deg the sign of l1 - l2 points the short way, so the
    # robot stops at the first grid heading inside the balance window.
    p = SensingParams()
    n = 2000
    phi0 = rng.uniform(-100, 100, n)  # initial heading error (deg)
    res = turn_to_angle(np.zeros((n, 2)), np.radians(90 + phi0), UP, None, p)
    win = math.degrees(p.balance_window)
    want = np.where(np.abs(phi0) > win, np.ceil((np.abs(phi0) - win) / p.step_deg), 0)
    np.testing.assert_array_equal(res.steps, want)
    np.testing.assert_allclose(p.turn_time(res.steps), want * 2.0 / 130.0)


def _chain_prediction(p: SensingParams, phi0_deg: float, lo: float, hi: float):
    """Absorption distribution of TurnToAngle as a Markov chain on the heading grid.

    State: heading error phi (heading minus light direction).  One reading each: l1 ~
    N(cos(phi + a), s1^2), l2 ~ N(cos(phi - a), s2^2), s_k^2 = (m mu_k)^2 + add^2,
    l3 ~ max(0, N(0, add^2)).  Stop if rho l1 <= l2 <= l1 / rho (rho = 1 - tol) and
    l3 <= dark; otherwise turn +step if l1 >= l2, else -step.  The differences of the
    readings are Gaussian, so every transition probability is a normal cdf.
    """
    a = math.radians(p.sensor_angle_deg)
    rho = 1 - p.balance_tolerance
    m, add = p.noise_mult, p.noise_add
    k = np.arange(
        math.ceil((phi0_deg - hi) / p.step_deg), math.floor((phi0_deg - lo) / p.step_deg) + 1
    )
    phi = phi0_deg - k * p.step_deg  # states, decreasing
    ph = np.radians(phi)
    mu1, mu2 = np.cos(ph + a), np.cos(ph - a)
    v1, v2 = (m * mu1) ** 2 + add**2, (m * mu2) ** 2 + add**2
    F = stats.norm.cdf
    below = F((rho * mu1 - mu2) / np.sqrt(v2 + rho**2 * v1))  # l2 < rho l1
    le = F((mu1 - mu2) / np.sqrt(v1 + v2))  # l2 <= l1
    upto = F((mu1 - rho * mu2) / np.sqrt(v1 + rho**2 * v2))  # l2 <= l1 / rho
    q3 = F(p.dark_threshold / add)
    stop = (upto - below) * q3
    ccw = below + (le - below) * (1 - q3)  # phi -> phi + step: state index - 1
    cw = (1 - upto) + (upto - le) * (1 - q3)
    ns = phi.size
    Q = np.zeros((ns, ns))
    Q[np.arange(1, ns), np.arange(ns - 1)] = ccw[1:]
    Q[np.arange(ns - 1), np.arange(1, ns)] = cw[:-1]
    escape = max(ccw[0], cw[-1])
    N = np.linalg.inv(np.eye(ns) - Q)
    start = int(np.argmin(np.abs(phi - phi0_deg)))
    absorb = N[start] * stop
    mean_steps = N[start].sum() - 1
    return phi, absorb, mean_steps, escape


def test_turn_to_angle_noise_error_distribution_matches_markov_chain(rng):
    p = SensingParams(noise_mult=0.02, noise_add=0.02, max_steps=5000)
    phi0 = 37.3
    n = 20000
    res = turn_to_angle(np.zeros((n, 2)), np.full(n, math.radians(90 + phi0)), UP, None, p, rng)
    phi, absorb, mean_steps, escape = _chain_prediction(p, phi0, -49.0, 49.0)
    assert escape < 1e-12 and abs(absorb.sum() - 1) < 1e-9
    assert res.converged.all()
    err = wrap_deg(np.degrees(res.heading) - 90.0)
    idx = np.round((phi0 - err) / p.step_deg).astype(int) - round((phi0 - phi[0]) / p.step_deg)
    counts = np.bincount(idx, minlength=phi.size)
    assert counts.size == phi.size
    # Pool states with fewer than 5 expected robots, then a chi-square goodness of fit.
    expected = absorb * n
    big = expected >= 5
    obs = np.r_[counts[big], counts[~big].sum()]
    exp = np.r_[expected[big], expected[~big].sum()]
    chi2 = ((obs - exp) ** 2 / exp).sum()
    pval = stats.chi2.sf(chi2, obs.size - 1)
    assert pval > 1e-3, (chi2, obs.size)
    # The width: noise widens the error beyond the noise-free window.
    mean = (absorb * phi).sum()
    sd = math.sqrt((absorb * (phi - mean) ** 2).sum())
    assert sd > 1.0  # degrees; without noise every robot ends at one grid heading
    assert abs(err.mean() - mean) < 4 * sd / math.sqrt(n)
    assert abs(err.std() / sd - 1) < 4 * math.sqrt(2 / n)
    steps_sd = res.steps.std()
    assert abs(res.steps.mean() - mean_steps) < 4 * steps_sd / math.sqrt(n)


def test_noisy_robots_with_the_light_behind_still_converge(rng):
    # Both front sensors read noisy darkness when the light is behind; turning by the
    # sign of that noise would random-walk (~1.7 % of robots ran out of 360 steps).
    p = SensingParams(noise_mult=0.02, noise_add=0.02)
    n = 5000
    h0 = rng.uniform(-math.pi, math.pi, n)
    res = turn_to_angle(np.zeros((n, 2)), h0, UP, None, p, rng)
    assert res.converged.all()
    arc = 360 - (p.sensor_angle_deg + p.fov_deg / 2)  # the longest way round
    assert res.steps.max() <= arc / p.step_deg + 20
    assert np.abs(wrap_deg(np.degrees(res.heading) - 90)).max() < 15  # ~7 sd of the noise


def test_full_shadow_ends_at_once(rng):
    occ = [Disc((0.0, 0.0), 50.0)]
    n = 500
    pos = np.c_[rng.uniform(-40, 40, n), rng.uniform(-600, -60, n)]  # behind the object
    h0 = rng.uniform(-math.pi, math.pi, n)
    noisy = SensingParams(noise_mult=0.05, noise_add=0.02)
    for params in (noisy, SensingParams(turn="fixed"), SensingParams(mode="ideal")):
        res = turn_to_angle(pos, h0, UP, occ, params, rng)
        np.testing.assert_array_equal(res.heading, h0)
        assert (res.steps == 0).all() and not res.converged.any()
    # A lamp too dim to read (front reading below the dark threshold) counts as no light.
    dim = PointLight(position=(0.0, 5000.0), reference_distance=500.0)  # 1 / 100 at 5 m
    res = turn_to_angle([[0.0, 0.0]], [0.3], dim, None, SensingParams())
    assert res.steps[0] == 0 and not res.converged[0] and res.heading[0] == 0.3


def test_ideal_mode_equals_analytic_direction(rng):
    n = 400
    pos = np.c_[rng.uniform(-300, 300, n), rng.uniform(-300, 300, n)]
    h0 = rng.uniform(-math.pi, math.pi, n)
    ideal = SensingParams(mode="ideal")
    res = turn_to_angle(pos, h0, DirectionalLight((1.0, 2.0)), None, ideal)
    np.testing.assert_allclose(res.heading, math.atan2(-2.0, -1.0), atol=1e-12)
    lamp = PointLight(position=(1000.0, -50.0))
    res = turn_to_angle(pos, h0, lamp, None, ideal)
    want = np.arctan2(-50.0 - pos[:, 1], 1000.0 - pos[:, 0])
    np.testing.assert_allclose(res.heading, want, atol=1e-12)
    turn = np.abs(np.angle(np.exp(1j * (want - h0))))
    np.testing.assert_array_equal(res.steps, np.ceil(turn / ideal.step - 1e-9))
    # Two sources: the brighter one where it is visible, the other in its shadow.
    bright = DirectionalLight((0.0, -1.0), intensity=2.0)  # from +y
    dim = DirectionalLight((-1.0, 0.0), intensity=1.0)  # from +x
    wall = Segment((-1000.0, 400.0), (1000.0, 400.0))  # shadows the +y source below it
    pts = [[0.0, 500.0], [0.0, 0.0]]
    np.testing.assert_allclose(
        ideal_zero_heading(pts, [bright, dim], [wall]), [math.pi / 2, 0.0], atol=1e-12
    )
    both_dark = [wall, Segment((300.0, -1000.0), (300.0, 1000.0))]
    out = ideal_zero_heading(pts, [bright, dim], both_dark, fallback=[1.0, 2.0])
    np.testing.assert_allclose(out, [math.pi / 2, 2.0])
    assert np.isnan(ideal_zero_heading(pts, [bright, dim], both_dark)[1])


def test_ideal_mode_noise_width(rng):
    n = 20000
    p = SensingParams(mode="ideal", ideal_noise_deg=3.0)
    res = turn_to_angle(np.zeros((n, 2)), np.zeros(n), UP, None, p, rng)
    err = wrap_deg(np.degrees(res.heading) - 90.0)
    assert abs(err.mean()) < 4 * 3.0 / math.sqrt(n)
    assert abs(err.std() / 3.0 - 1) < 4 * math.sqrt(1 / (2 * n))


def test_sense_combines_light_and_turn(rng):
    occ = [Disc((0.0, 0.0), 50.0)]
    pos = np.array([[0.0, -200.0], [0.0, 200.0], [300.0, -10.0]])
    h0 = np.array([0.0, 0.0, 3.0])
    p = SensingParams()
    s = sense(pos, h0, UP, occ, p, rng, ambient=0.01)
    np.testing.assert_allclose(s.light, [0.01, 1.0, 1.0])
    t = turn_to_angle(pos, h0, UP, occ, p, rng, ambient=0.01)
    np.testing.assert_array_equal(s.zero_heading, t.heading)
    np.testing.assert_array_equal(s.steps, t.steps)
    np.testing.assert_allclose(s.turn_time, t.steps * p.step_deg / p.turn_rate_deg)
    assert list(s.converged) == [False, True, True]


def test_parallel_kernels_agree_with_serial(rng):
    # At and above _PARALLEL_MIN robots the shadow and noise-free turning kernels run in
    # parallel chunks; the same robots in small batches take the serial kernels.
    n = light_mod._PARALLEL_MIN + 1000
    pos = rng.uniform(-500, 500, (n, 2))
    h0 = rng.uniform(-math.pi, math.pi, n)
    occ = [Disc((0.0, 0.0), 50.0), Polygon(((200, 200), (300, 200), (250, 300)))]
    lights = [UP, PointLight((600.0, 100.0), radius=20.0)]
    p = SensingParams()
    full_level = light_level(pos, lights, occ)
    full = turn_to_angle(pos, h0, lights, occ, p)
    parts = np.array_split(np.arange(n), 4)
    np.testing.assert_array_equal(
        full_level, np.concatenate([light_level(pos[i], lights, occ) for i in parts])
    )
    batches = [turn_to_angle(pos[i], h0[i], lights, occ, p) for i in parts]
    np.testing.assert_array_equal(full.heading, np.concatenate([b.heading for b in batches]))
    np.testing.assert_array_equal(full.steps, np.concatenate([b.steps for b in batches]))
    assert 0.5 < full.converged.mean() < 1.0


def test_same_seed_same_result():
    p = SensingParams(noise_mult=0.05, noise_add=0.02)
    pos, h0 = _random_lit_robots(np.random.default_rng(1), 300)
    a = turn_to_angle(pos, h0, UP, None, p, np.random.default_rng(7))
    b = turn_to_angle(pos, h0, UP, None, p, np.random.default_rng(7))
    c = turn_to_angle(pos, h0, UP, None, p, np.random.default_rng(8))
    np.testing.assert_array_equal(a.heading, b.heading)
    np.testing.assert_array_equal(a.steps, b.steps)
    assert not np.array_equal(a.steps, c.steps)


# ------------------------------------------------------------------------ bad input


def test_params_range_checks_name_the_field():
    with pytest.raises(ConfigError, match="fov_deg"):
        SensingParams(fov_deg=50.0)  # narrower than 2a: front sensors cannot both see
    with pytest.raises(ConfigError, match="tolerance"):
        SensingParams(tolerance=0.001)  # window narrower than a step without noise
    SensingParams(tolerance=0.001, noise_add=0.01)  # with noise it is the user's choice
    with pytest.raises(ConfigError, match="back_angle_deg"):
        SensingParams(back_angle_deg=60.0)
    with pytest.raises(ConfigError, match="step_deg"):
        SensingParams(step_deg=0.0)
    with pytest.raises(ConfigError, match="sensors.toml: unknown key 'fov'"):
        from_mapping(SensingParams, {"fov": 100}, source="sensors.toml")
    with pytest.raises(ConfigError, match="mode"):
        from_mapping(SensingParams, {"mode": "magic"})
    got = from_mapping(SensingParams, {"mode": "ideal", "step_deg": 5, "max_steps": 10})
    assert got.step_deg == 5.0 and got.steps_limit == 10
    assert dataclasses.replace(got, max_steps=None).steps_limit == 144
    with pytest.raises(ConfigError, match="dark_threshold"):
        turn_to_angle([[0, 0]], [0.0], UP, None, SensingParams(), ambient=0.1)
    with pytest.raises(ConfigError, match="rng"):
        read_sensors([[0, 0]], [0.0], UP, None, SensingParams(noise_add=0.1))


def test_bad_geometry_and_arguments():
    with pytest.raises(ConfigError, match="radius"):
        Disc((0.0, 0.0), -1.0)
    with pytest.raises(ConfigError, match="vertices"):
        Polygon(((0.0, 0.0), (1.0, 0.0)))
    with pytest.raises(ConfigError, match="direction"):
        DirectionalLight(direction=(0.0, 0.0))
    with pytest.raises(ConfigError, match="falloff"):
        PointLight(position=(0.0, 0.0), falloff="cubic")
    with pytest.raises(InputError, match="argument order"):
        light_level([[0, 0]], [Disc((0.0, 0.0), 1.0)], UP)
    with pytest.raises(InputError, match="points must have shape"):
        light_level(np.zeros((3, 3)), UP)
    with pytest.raises(InputError, match="heading must have shape"):
        turn_to_angle(np.zeros((3, 2)), np.zeros(2), UP, None, SensingParams())
    with pytest.raises(InputError, match="finite"):
        light_level([[np.nan, 0.0]], UP)
    with pytest.raises(InputError, match="shape 1"):
        light_level([[0, 0]], UP, [Disc((0.0, 0.0), 1.0), "wall"])
    assert light_level(np.zeros((0, 2)), UP).shape == (0,)
    assert turn_to_angle(np.zeros((0, 2)), np.zeros(0), UP, None, SensingParams()).steps.size == 0
    light = from_mapping(PointLight, {"position": [1, 2], "falloff": "none"})
    assert light.position == (1.0, 2.0)


def test_shapes_packing():
    user = np.array([[1.0, 2.0, 3.0]])
    packed = Shapes(discs=user, segments=[[0, 0, 1, 0]])
    assert user.flags.writeable and not packed.discs.flags.writeable  # copied, then frozen
    both = packed + Shapes.from_shapes([Polygon(((0, 0), (1, 0), (0, 1), (0, 1)))])
    assert both.n_discs == 1 and both.n_segments == 1 + 3  # repeated vertex dropped
    with pytest.raises(InputError, match="centers must have 1 rows"):
        packed.with_disc_centers([[0, 0], [1, 1]])
    with pytest.raises(InputError, match="radii"):
        Shapes(discs=[[0, 0, -1]])
    with pytest.raises(InputError, match=r"segments must have shape \(k, 4\)"):
        Shapes(segments=[[0, 0, 1]])
    disc = from_mapping(Disc, {"center": [0, 1], "radius": 5}, source="world.toml")
    assert disc == Disc((0.0, 1.0), 5.0)
    with pytest.raises(ConfigError, match="world.toml: radius"):
        from_mapping(Disc, {"center": [0, 1], "radius": 0}, source="world.toml")
