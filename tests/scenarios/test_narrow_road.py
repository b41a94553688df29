"""narrow-road: Algorithm 2's laws, the road, re-entry bookkeeping, metrics, the claim."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import xarray as xr
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from thermoswarm.errors import ConfigError
from thermoswarm.maxent import kT_for_mean_speed
from thermoswarm.policy import NarrowRoad, Observation
from thermoswarm.scenarios import runner
from thermoswarm.scenarios.narrow_road import (
    NarrowRoadParams,
    flow_series,
    longest_gap,
    road_geometry,
    road_n,
    section_index,
    section_samples,
    section_stats,
)

KT10 = kT_for_mean_speed(10.0)


def _obs(group, zero=0.0, tau=1.0):
    group = np.asarray(group)
    n = group.size
    return Observation(
        time=0.0,
        index=np.arange(n),
        tau=tau,
        group=group,
        zero_heading=np.full(n, zero),
        light=np.ones(n),
    )


def _wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


# ------------------------------------------------------------------ Algorithm 2 policy


def test_normal_law_heads_each_group_to_its_own_end():
    """Group 0: N(0, sigma) around heading 0; group 1: N(pi, sigma); Rayleigh speeds."""
    n = 20_000
    sigma = math.radians(30)
    zero = 0.7  # heading 0 need not be the world's +x: the law is relative to it
    pol = NarrowRoad(kT=KT10, sigma=sigma)
    group = np.repeat([0, 1], n // 2)
    a = pol.act(_obs(group, zero=zero), np.random.default_rng(5))
    for g, goal in ((0, 0.0), (1, math.pi)):
        dev = _wrap(a.heading[group == g] - zero - goal)
        m = dev.size
        # mean deviation 0 and spread sigma, within 4 standard errors
        assert abs(dev.mean()) < 4 * sigma / math.sqrt(m)
        assert abs(dev.std() - sigma) < 4 * sigma / math.sqrt(2 * m)
        assert stats.kstest(dev / sigma, "norm").pvalue > 1e-3
    # speed: energy v^2/2 exponential with mean kT (Rayleigh speeds)
    e = a.speed**2 / 2
    assert abs(e.mean() - KT10) < 4 * KT10 / math.sqrt(n)


def test_exponential_steering_law_is_laplace_with_speed_dependent_temperature():
    """delta / tau = w with |w| ~ Exp(T(v)), T(v) = Tmin + (Tmax - Tmin) exp(-v/vs)."""
    n = 40_000
    tau = 2.0
    pol = NarrowRoad(kT=KT10, steering="exponential", T_theta_max=1.5, T_theta_min=0.1,
                     v_scale=8.0)  # fmt: skip
    a = pol.act(_obs(np.zeros(n, int), tau=tau), np.random.default_rng(9))
    w = a.heading / tau  # goal 0, heading 0 = 0: the heading is delta (not wrapped)
    T = 0.1 + 1.4 * np.exp(-a.speed / 8.0)
    u = np.abs(w) / T  # Exp(1) if the law holds
    assert abs(u.mean() - 1) < 4 / math.sqrt(n)
    assert stats.kstest(u, "expon").pvalue > 1e-3
    # random sign
    assert abs((w > 0).mean() - 0.5) < 4 * 0.5 / math.sqrt(n)
    # slow robots steer more: mean |w| in the slowest quartile far above the fastest
    q = np.quantile(a.speed, [0.25, 0.75])
    slow, fast = np.abs(w[a.speed < q[0]]).mean(), np.abs(w[a.speed > q[1]]).mean()
    assert slow > 2 * fast


def test_policy_rejects_bad_groups_and_laws():
    with pytest.raises(ValueError, match="steering"):
        NarrowRoad(kT=KT10, steering="zigzag")
    with pytest.raises(ValueError, match="sigma"):
        NarrowRoad(kT=KT10, sigma=-1.0)
    with pytest.raises(ValueError, match="group 2"):
        NarrowRoad(kT=KT10).act(_obs([0, 2]), np.random.default_rng(0))


# ------------------------------------------------------------------ road geometry


def test_default_road_follows_the_paper_numbers():
    """381 mm long, 40:20 widths scaled by 3.81, N from the occupation ratio 80/448."""
    p = NarrowRoadParams()
    geo = road_geometry(p)
    wide, narrow = 40 * 3.81, 20 * 3.81
    area = 381 / 2 * wide + 381 / 2 * narrow
    assert geo.area == pytest.approx(area, rel=1e-12)
    assert list(geo.widths) == pytest.approx([wide, narrow])
    n = round(80 / 448 * area / (math.pi * 16.5**2))
    assert road_n(p) == n == 9
    # re-entry spots: inside the road, a radius from every wall, near their start wall
    for g, spots in enumerate(geo.entry_spots):
        assert spots.shape[0] > 100
        dist_to_start = spots[:, 0] if g == 0 else 381 - spots[:, 0]
        assert dist_to_start.min() >= 16.5 and dist_to_start.max() <= p.entry_depth
        half = (wide if g == 0 else narrow) / 2
        assert np.abs(spots[:, 1]).max() <= half - 16.5


def test_tapered_road_area_and_open_or_walled_ends():
    p = NarrowRoadParams(taper=40.0)
    geo = road_geometry(p)
    # a linear taper replaces two 20 mm strips of the step by a trapezoid of the same area
    assert geo.area == pytest.approx(190.5 * 152.4 + 190.5 * 76.2, rel=1e-12)
    # open ends: side walls and tapers only (2 x 3 segments); end walls add 2
    assert len(geo.segments) == 6
    assert not np.any((geo.segments[:, 0] == geo.segments[:, 2]) & (geo.segments[:, 0] == 0))
    walled = road_geometry(NarrowRoadParams(taper=40.0, ends="walls"))
    assert len(walled.segments) == 8
    assert walled.arrive_depth == 66.0 and geo.arrive_depth == 0.0


@pytest.mark.parametrize(
    ("key", "value", "named"),
    [
        ("section_widths", [152.4, 30.0], "section_widths"),
        ("section_fractions", [0.5, 0.6], "section_fractions"),
        ("steering", "zigzag", "steering"),
        ("kT", -1.0, "kT"),
        ("n", 1, "n"),
        ("arrive_depth", -1.0, "arrive_depth"),
        ("ends", "ajar", "ends"),
        ("sensing.mode", "psychic", "sensing.mode"),
        ("section_names", ["a", "a"], "section_names"),
    ],
)
def test_bad_config_is_one_line_error_naming_the_key(key, value, named):
    with pytest.raises(ConfigError) as exc:
        runner.resolve("narrow-road", overrides=[f"{key}={json.dumps(value)}"])
    msg = str(exc.value)
    assert named in msg and "\n" not in msg


def test_arrival_line_must_be_reachable_with_end_walls():
    # a centre cannot come closer than a radius to an end wall
    with pytest.raises(ConfigError, match="arrive_depth"):
        runner.resolve("narrow-road", overrides=["ends='walls'", "arrive_depth=10"])
    runner.resolve("narrow-road", overrides=["arrive_depth=10"])  # fine with open ends


# ------------------------------------------------------------------ metric functions


def test_longest_gap_counts_from_start_and_to_end():
    assert longest_gap(np.array([10.0, 20.0, 50.0]), 0.0, 100.0) == 50.0
    assert longest_gap(np.array([70.0, 20.0]), 0.0, 100.0) == 50.0  # unsorted input
    assert longest_gap(np.array([]), 0.0, 100.0) == 100.0
    assert longest_gap(np.array([5.0, 500.0]), 0.0, 100.0) == 95.0  # outside ignored


def test_flow_series_is_crossings_per_minute_per_whole_bin():
    starts, flow = flow_series(np.array([5.0, 10.0, 70.0, 130.0]), 150.0, 60.0)
    # 150 s hold two whole minutes; the last 30 s (and the crossing at 130 s) are not a bin
    assert starts.tolist() == [0.0, 60.0]
    assert flow.tolist() == pytest.approx([2.0, 1.0])
    # bins are half-open: a crossing at exactly 60 s is in the second minute
    assert flow_series(np.array([60.0]), 180.0, 60.0)[1].tolist() == [0.0, 1.0, 0.0]
    # shorter than one bin: no bins, not one bin over a few seconds
    starts, flow = flow_series(np.array([1.0]), 59.0, 60.0)
    assert starts.size == 0 and flow.size == 0


@settings(max_examples=60, deadline=None, derandomize=True)
@given(
    n_whole=st.integers(0, 20),
    tail=st.floats(0.0, 0.999),
    bin_s=st.sampled_from([10.0, 60.0, 90.0]),
    seed=st.integers(0, 2**32 - 1),
)
def test_flow_series_last_bin_is_never_partial(n_whole, tail, bin_s, seed):
    # a steady flow of crossings: every bin returned is whole, so every one shows it
    duration = (n_whole + tail) * bin_s
    rng = np.random.default_rng(seed)
    per_bin = 6
    t = (np.arange(int(np.ceil(duration / bin_s)) + 1)[:, None] + rng.random((1, per_bin))).ravel()
    starts, flow = flow_series(t * bin_s, duration, bin_s)
    assert starts.size == n_whole
    if n_whole:
        assert starts[-1] + bin_s <= duration + 1e-9
        assert flow == pytest.approx(np.full(n_whole, per_bin * 60.0 / bin_s))


def test_section_index():
    edges = np.array([0.0, 190.5, 381.0])
    x = np.array([0.0, 100.0, 190.5, 380.9, 381.0, 400.0, -5.0])
    assert section_index(x, edges).tolist() == [0, 0, 1, 1, 1, 1, 0]


def _tracks(pos, section, lap, group, speed, dt=1.0):
    """pos (time, individuals, 2) -> a minimal trajectory dataset."""
    pos = np.asarray(pos, float)
    t = np.arange(pos.shape[0]) * dt
    return xr.Dataset(
        {
            "position": (
                ("time", "space", "keypoints", "individuals"),
                pos.transpose(0, 2, 1)[:, :, None, :],
            ),
            "section": (("time", "individuals"), np.asarray(section, np.int8)),
            "lap": (("time", "individuals"), np.asarray(lap, np.int32)),
            "group": (("time", "individuals"), np.asarray(group, np.int8)),
            "speed": (("time", "individuals"), np.asarray(speed, float)),
        },
        coords={"time": t},
    )


def test_section_samples_drop_reentry_jumps_and_waits():
    # robot 0 moves 3 mm per 0.5 s along x (6 mm/s); robot 1 moves 4 mm, then jumps back
    # to the start (new lap), then waits off the road (section -1)
    pos = [
        [[10, 0], [300, 0]],
        [[13, 0], [296, 0]],
        [[16, 0], [20, 0]],
        [[19, 0], [20, -200]],
    ]
    section = [[0, 1], [0, 1], [0, 0], [0, -1]]
    lap = [[0, 0], [0, 0], [0, 1], [0, 1]]
    group = [[0, 1]] * 4
    tr = _tracks(pos, section, lap, group, np.full((4, 2), 7.0), dt=0.5)
    s = section_samples(tr)
    order = np.lexsort((s["time"], s["id"]))
    assert s["id"][order].tolist() == [0, 0, 0, 1]
    assert s["speed"][order] == pytest.approx([6.0, 6.0, 6.0, 8.0])
    assert s["energy"][order] == pytest.approx([18.0, 18.0, 18.0, 32.0])
    assert s["section"][order].tolist() == [0, 0, 0, 1]
    st = section_stats(tr, ("wide", "narrow"), np.array([100.0, 50.0]))
    # occupancy: section 0 holds 5 robot-frames in 4 frames, section 1 holds 2
    assert st["wide"]["occupancy_mean"] == pytest.approx(5 / 4)
    assert st["narrow"]["occupancy_mean"] == pytest.approx(2 / 4)
    assert st["narrow"]["density_per_mm2"] == pytest.approx(0.5 / 50)
    assert st["wide"]["measured"]["speed_mean"] == pytest.approx(6.0)
    assert st["narrow"]["by_direction"]["-x"]["measured"]["energy_mean"] == pytest.approx(32.0)
    assert st["narrow"]["by_direction"]["+x"]["measured"]["n"] == 0
    assert st["wide"]["commanded"]["speed_mean"] == pytest.approx(7.0)


def test_regions_file_matches_the_sections():
    import tomllib

    from thermoswarm.scenarios.narrow_road import regions_toml

    doc = tomllib.loads(regions_toml(road_geometry(NarrowRoadParams())))
    assert [r["name"] for r in doc["region"]] == ["wide", "narrow"]
    assert doc["region"][0]["rect"] == pytest.approx([0.0, -76.2, 190.5, 76.2])
    assert doc["region"][1]["rect"] == pytest.approx([190.5, -38.1, 381.0, 38.1])


def test_plot_frame_draws_robots_on_the_road_only():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from thermoswarm.scenarios.narrow_road import plot_frame

    pos = [[[50, 0], [300, 10], [20, -200]], [[53, 0], [297, 10], [20, -200]]]
    tr = _tracks(pos, [[0, 1, -1]] * 2, [[0, 0, 1]] * 2, [[0, 1, 0]] * 2, np.full((2, 3), 9.0))
    geo = road_geometry(NarrowRoadParams())
    fig, ax = plt.subplots()
    coll = plot_frame(ax, tr, 1.0, geo.info())
    assert np.asarray(coll.get_offsets()).tolist() == [[53.0, 0.0], [297.0, 10.0]]
    assert "1 waiting" in ax.get_title()
    coll = plot_frame(ax, tr, 0.0, geo, color_by="speed")
    assert np.asarray(coll.get_array()).tolist() == [9.0, 9.0]
    plt.close(fig)


def test_energy_standard_error_comes_from_time_blocks():
    from thermoswarm.scenarios.narrow_road.metrics import SE_BLOCKS, _speed_energy

    assert SE_BLOCKS == 20
    # 50 correlated samples of energy 2 in one block, 50 of energy 8 in another
    v = np.r_[np.full(50, 2.0), np.full(50, 4.0)]
    t = np.r_[np.full(50, 0.5), np.full(50, 10.5)]
    st = _speed_energy(v, t, (0.0, 20.0))
    assert st["energy_mean"] == pytest.approx(5.0)
    assert st["energy_se"] == pytest.approx(np.std([2.0, 8.0], ddof=1) / math.sqrt(2))
    assert _speed_energy(v[:50], t[:50], (0.0, 20.0))["energy_se"] is None


# ------------------------------------------------------------------ re-entry mechanics


def _built(**over):
    sets = [f"{k}={json.dumps(v)}" for k, v in over.items()]
    cfg = runner.resolve("narrow-road", overrides=sets, seed=3)
    scen, setup, sim, state = runner.build(cfg)
    acc = scen.init_acc(setup, sim, state)
    return scen, setup, sim, state, acc


def test_arrival_reenters_at_the_start_or_waits_and_counts():
    scen, setup, sim, state, acc = _built(n=4, ends="walls")
    geo = setup.info["geometry"]
    # ids 0, 1 are group 0 (toward +x), ids 2, 3 group 1
    assert state.by_id(state.group).tolist() == [0, 0, 1, 1]
    row = {int(a): i for i, a in enumerate(state.ids)}
    # robot 0 in its arrival zone (within 66 mm of x = 381); robot 1 near its start
    state.pos[row[0]] = (381 - 40.0, 0.0)
    state.pos[row[2]] = (300.0, 30.0)
    state.pos[row[3]] = (300.0, -30.0)
    state.pos[row[1]] = (33.0, 0.0)
    state.time = 12.0
    scen.observe(sim, state, acc)
    assert int(acc["n_events"]) == 1
    t, a, g, transit, kind = acc["events"][0]
    assert (t, a, g, kind) == (12.0, 0, 0, 1) and math.isnan(transit)  # first lap
    assert acc["lap"].tolist() == [1, 0, 0, 0]
    p0 = state.pos[row[0]]
    spots = geo.entry_spots[0]
    # a free spot existed: re-entered there at once, clear of robot 1
    assert p0[1] > geo.depot_line
    assert np.min(np.hypot(*(spots - p0).T)) < 1e-9
    assert np.hypot(*(p0 - state.pos[row[1]])) >= 33.0
    assert acc["entries"][0] == 1 and acc["waited"][0] == 0
    assert state.timer[row[0]] == 0  # decides at the next step
    # now fill the whole start zone: robot 0 must wait when it arrives again
    state.pos[row[0]] = (381 - 40.0, 0.0)
    blockers = [(33.0, 45.0), (33.0, -45.0), (33.0, 0.0)]
    for a, xy in zip((1, 2, 3), blockers, strict=True):
        state.pos[row[a]] = xy
    # robots 2 and 3 (group 1) sit at x = 33: they would arrive too; relabel them group 0
    state.group[row[2]] = 0
    state.group[row[3]] = 0
    # ... but group-0 robots at x = 33 are not arriving (their far end is x = 381)
    state.time = 40.0
    scen.observe(sim, state, acc)
    assert int(acc["n_events"]) == 2
    assert acc["events"][1][3] == pytest.approx(40.0 - 12.0)  # a complete lap
    assert state.pos[row[0]][1] < geo.depot_line  # waiting off the road
    assert state.speed[row[0]] == 0.0
    assert acc["park_since"][0] == 40.0
    # the spot frees up 5 s later: the robot re-enters, the wait is counted
    state.pos[row[1]] = (200.0, 0.0)
    state.pos[row[2]] = (250.0, 0.0)
    state.pos[row[3]] = (300.0, 0.0)
    state.time = 45.0
    scen.observe(sim, state, acc)
    assert state.pos[row[0]][1] > geo.depot_line
    assert acc["waited"][0] == 1 and acc["wait_total"][0] == pytest.approx(5.0)
    assert acc["wait_max"][0] == pytest.approx(5.0)
    assert math.isnan(acc["park_since"][0]) and acc["entry_time"][0] == 45.0


def test_open_ends_count_arrivals_and_robots_leaving_backward():
    scen, setup, sim, state, acc = _built(n=4)
    geo = setup.info["geometry"]
    row = {int(a): i for i, a in enumerate(state.ids)}
    for a, xy in zip(range(4), [(380.0, 0.0), (100.0, 0.0), (200.0, 0.0), (250.0, 0.0)],
                     strict=True):  # fmt: skip
        state.pos[row[a]] = xy
    state.time = 5.0
    scen.observe(sim, state, acc)
    assert int(acc["n_events"]) == 0  # centres still on the road: nobody left
    state.pos[row[0]] = (381.5, 0.0)  # group 0 crosses its far end line: a crossing
    state.pos[row[2]] = (381.2, 0.0)  # group 1 leaves across its own start end
    state.time = 6.0
    scen.observe(sim, state, acc)
    ev = acc["events"][: int(acc["n_events"])]
    kinds = {int(e[1]): int(e[4]) for e in ev}
    assert kinds == {0: 1, 2: 0}
    assert math.isnan(ev[ev[:, 1] == 2][0, 3])  # leaving backward has no transit time
    # both are back at their own start ends, on the road
    p0, p2 = state.pos[row[0]], state.pos[row[2]]
    assert p0[1] > geo.depot_line and p0[0] <= NarrowRoadParams().entry_depth
    assert p2[1] > geo.depot_line and p2[0] >= 381 - NarrowRoadParams().entry_depth
    assert acc["lap"].tolist() == [1, 0, 1, 0]


def test_waiting_robot_stands_still():
    """The policy wrapper stops robots in the depot."""
    scen, setup, sim, state, acc = _built(n=4)
    geo = setup.info["geometry"]
    i = 0
    a = int(state.ids[i])
    state.pos[i] = geo.depot_slots[a]
    state.timer[i] = 0
    before = state.pos[i].copy()
    sim.step(state)
    j = int(np.flatnonzero(state.ids == a)[0])
    assert state.speed[j] == 0.0
    assert np.array_equal(state.pos[j], before)


# ------------------------------------------------------------------ runs


def test_scenario_builds_runs_and_writes_its_metrics(tmp_path):
    cfg = runner.resolve("narrow-road", overrides=["duration=120", "record.interval=1.0"],
                         seed=2)  # fmt: skip
    m = runner.run(cfg, tmp_path / "run", progress=False)
    for key in ("flow_per_direction", "longest_zero_flow_s", "crossings", "flow_over_time",
                "transit_times", "sections", "waiting", "road"):  # fmt: skip
        assert key in m
    assert set(m["flow_per_direction"]) == {"+x", "-x"}
    assert set(m["longest_zero_flow_s"]) == {"+x", "-x", "overall"}
    assert set(m["left_backward"]) == {"+x", "-x"}
    tr = xr.open_dataset(tmp_path / "run" / "tracks.nc")
    on = tr["section"].values >= 0
    pos = tr["position"].isel(keypoints=0).values  # (time, space, individuals)
    x, y = pos[:, 0][on], pos[:, 1][on]
    # open ends: a robot is recorded on the road until its centre crosses an end line
    assert x.min() >= 0.0 and x.max() <= 381.0
    # recorded sections agree with x
    geo = road_geometry(NarrowRoadParams())
    assert np.array_equal(section_index(x, geo.edges), tr["section"].values[on])
    half = np.where(x < 190.5, 76.2, 38.1)
    assert np.all(np.abs(y) <= half - 16.5 + 0.7)
    assert m["max_overlap_fraction"] < 0.02
    # every lap ends in a crossing or in leaving backward
    laps = int(tr["lap"].values[-1].sum())
    assert m["crossings"]["total"] + sum(m["left_backward"].values()) == laps


def test_photoresistor_sensing_points_each_group_to_its_goal(tmp_path):
    """With simulated photoresistors and the stepwise turn, the commanded headings
    relative to each group's goal follow Algorithm 2's normal law as with exact sensing.

    For delta ~ N(0, sigma): E[cos delta] = exp(-sigma^2 / 2), E[sin delta] = 0, with
    variances (1 + e^(-2 sigma^2)) / 2 - e^(-sigma^2) and (1 - e^(-2 sigma^2)) / 2; one
    independent draw per robot and control period (recorded every tau = 1 s, the first
    frame, which holds the initial headings, left out).  Tolerance: 4 standard errors,
    plus what the turn may leave: it stops within 0.75 step (1.5 deg, no sensor noise) of
    the light's direction.  Reversed or random sensing gives E[cos] of -0.73 or 0."""
    sigma = math.radians(45.0)
    cfg = runner.resolve(
        "narrow-road",
        overrides=["duration=240", "sensing.mode='photoresistor'", "record.interval=1.0"],
        seed=1,
    )
    assert cfg.params.sensing.step_deg == 2.0 and cfg.params.sensing.noise_add == 0.0
    m = runner.run(cfg, tmp_path / "run", progress=False)
    assert m["max_overlap_fraction"] < 0.02
    tr = xr.open_dataset(tmp_path / "run" / "tracks.nc")
    heading = tr["heading"].values[1:].astype(float)
    group = tr["group"].values[1:]
    eps = math.radians(0.75 * 2.0)
    r = math.exp(-(sigma**2) / 2)
    var_cos = (1 + math.exp(-2 * sigma**2)) / 2 - math.exp(-(sigma**2))
    var_sin = (1 - math.exp(-2 * sigma**2)) / 2
    for g, goal in ((0, 0.0), (1, math.pi)):
        delta = heading[group == g] - goal
        n = delta.size
        assert n >= 900
        assert abs(np.cos(delta).mean() - r) <= 4 * math.sqrt(var_cos / n) + (1 - math.cos(eps))
        assert abs(np.sin(delta).mean()) <= 4 * math.sqrt(var_sin / n) + r * math.sin(eps)
    assert m["crossings"]["+x"] > 0 and m["crossings"]["-x"] > 0


def test_resume_gives_the_same_metrics(tmp_path, monkeypatch):
    """A run killed mid-way and resumed ends exactly as an uninterrupted one (the
    re-entry bookkeeping and its random draws are checkpointed)."""
    sets = ["duration=400", "record.interval=1.0", "record.block=50", "n=12"]
    cfg = runner.resolve("narrow-road", overrides=sets, seed=4)
    full = runner.run(cfg, tmp_path / "full", progress=False)
    from thermoswarm.scenarios.narrow_road import NarrowRoadScenario

    real = NarrowRoadScenario.observe

    def dying(self, sim, state, acc):
        real(self, sim, state, acc)
        if state.step == 2730:
            raise KeyboardInterrupt

    monkeypatch.setattr(NarrowRoadScenario, "observe", dying)
    with pytest.raises(KeyboardInterrupt):
        runner.run(cfg, tmp_path / "cut", progress=False)
    monkeypatch.setattr(NarrowRoadScenario, "observe", real)
    resumed = runner.resume(tmp_path / "cut", progress=False)
    full.pop("performance")
    resumed.pop("performance")
    assert full["crossings"]["total"] > 5  # something happened before and after the cut
    assert json.dumps(full, sort_keys=True) == json.dumps(resumed, sort_keys=True)


def test_both_directions_keep_flowing_for_5600_seconds(tmp_path):
    """The paper's long test at the default density (9 robots, occupation 0.177): no
    deadlock.

    Bounds on the longest zero-flow periods from the run's own flow: were the m
    crossings at rate lam = m / T a Poisson stream, the longest of its m gaps would
    exceed ln(m / alpha) / lam with probability about alpha; alpha = 1e-3.  For seed 0
    that is ~120 s per direction and ~63 s for the road (any direction).  A locked road
    (end walls with the arrival line one diameter in) has gaps of 950-3,900 s.  Traffic
    clusters a little more than Poisson: over seeds 0-9 the longest overall gap reached
    0.85 of its bound (docs/scenarios_road_compression.md)."""
    cfg = runner.resolve(
        "narrow-road", overrides=["record.interval=10.0", "record.netcdf=false"], seed=0
    )
    assert cfg.params.duration == 5600.0
    m = runner.run(cfg, tmp_path / "long", progress=False)
    assert m["n"] == 9
    T = m["duration"]
    alpha = 1e-3

    def bound(count):
        return math.log(count / alpha) / (count / T)

    z = m["longest_zero_flow_s"]
    c = m["crossings"]
    assert z["overall"] <= bound(c["total"])
    assert z["+x"] <= bound(c["+x"]) and z["-x"] <= bound(c["-x"])
    # flow all along: every 10-minute bin has crossings both ways, and the road is open
    # at least half the time (a free-flowing road carries ~11 crossings per minute each
    # way, 600-650 per direction over seeds 0-9)
    bins = runner.resolve("narrow-road").params.flow_bin
    assert bins == 60.0
    f = m["flow_over_time"]
    for d in ("+x", "-x"):
        per10 = np.add.reduceat(np.asarray(f[d]), np.arange(0, len(f[d]), 10))
        assert np.all(per10 > 0)
        assert c[d] > 300
    assert m["max_overlap_fraction"] < 0.02


def test_flow_plot_draws_whole_bins_and_marks_the_tail():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from thermoswarm.scenarios.narrow_road import plot_flow

    m = {
        "flow_over_time": {"bin_s": 60.0, "t_start": [0.0, 60.0], "+x": [2.0, 1.0],
                           "-x": [0.0, 3.0], "unbinned_tail_s": 30.0},
        "flow_per_direction": {"+x": 1.6, "-x": 1.2},
    }  # fmt: skip
    fig, ax = plt.subplots()
    plot_flow(ax, m)
    steps = [p for p in ax.patches if type(p).__name__ == "StepPatch"]
    assert len(steps) == 2
    for p in steps:  # each step spans its whole minute: the last ends at 120 s
        assert p.get_data().edges.tolist() == [0.0, 60.0, 120.0]
    assert ax.get_xlim() == (0.0, 150.0)  # the 30 s tail is shown, shaded, not a rate
    assert any("not a whole bin" in t.get_text() for t in ax.get_legend().get_texts())
    plt.close(fig)
