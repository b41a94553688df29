"""Each individual on its own clock: the kinematics of a group equal those of each alone."""

from __future__ import annotations

import numpy as np
import pytest

from thermoswarm.analysis.kinematics import STEP_BUCKETS, compute_kinematics, data_quality
from thermoswarm.io import read_tracks
from thermoswarm.tracks import make_tracks

N_IND, N_SAMPLES, RATE = 50, 200, 10.0


def _own_clock_folder(folder, seed=0):
    """50 ants at 10 Hz: random offsets, +-2 ms jitter, 5 % of samples dropped."""
    rng = np.random.default_rng(seed)
    n_kept = []
    for i in range(N_IND):
        t = rng.uniform(0, 1 / RATE) + np.arange(N_SAMPLES) / RATE
        t += rng.uniform(-0.002, 0.002, N_SAMPLES)
        keep = rng.random(N_SAMPLES) >= 0.05
        steps = rng.normal(0, 1.5, (N_SAMPLES, 2))  # a random walk, mm
        xy = np.cumsum(steps, axis=0)[keep]
        n_kept.append(int(keep.sum()))
        np.savetxt(folder / f"ant{i}.txt", np.column_stack([t[keep], xy]), fmt="%.6f")
    return n_kept


VARS = ("step_time", "dt", "speed", "energy", "heading", "steering_rate", "step_class")


def test_fifty_ants_on_their_own_clocks_equal_each_ant_alone(tmp_path):
    n_kept = _own_clock_folder(tmp_path)
    group = read_tracks(tmp_path, units="mm")
    assert group.attrs["time_unit"] == "per_individual"
    assert group.sizes["time"] == max(n_kept)  # no union axis: rows are samples
    kin = compute_kinematics(group)
    dq = data_quality(kin)
    # no step lost: every pair of consecutive samples of an ant is a step, in a bucket
    assert dq["n_steps_total"] == sum(n - 1 for n in n_kept)
    assert sum(dq[k] for k in STEP_BUCKETS) == dq["n_steps_total"]
    # dropped samples make steps of about 0.2 s: gaps, the rest are used
    assert dq["n_steps_time_gap"] > 0 and dq["n_steps_used"] > 0.85 * dq["n_steps_total"]
    assert dq["n_irregular_steps"] == dq["n_steps_time_gap"]  # +-2 ms at 100 ms is regular
    for i in range(N_IND):
        alone = compute_kinematics(read_tracks(tmp_path / f"ant{i}.txt", units="mm"))
        n = n_kept[i]
        for v in VARS:
            a = kin[v].values[:n, i]
            b = alone[v].values[:n, 0]
            # the same arithmetic on the same numbers: equal to rounding
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=0, equal_nan=True, err_msg=v)
        assert np.isnan(kin["speed"].values[n:, i]).all()  # padding holds nothing


def test_two_offset_clocks_lose_no_step():
    # the symptom: two 10 Hz tracks offset by 50 ms gave no valid step on a union axis
    t = np.arange(50) / RATE
    clock = np.column_stack([t, t + 0.05])
    pos = np.zeros((50, 2, 2))
    pos[:, 0, :] = clock * 10.0
    kin = compute_kinematics(make_tracks(pos, time=clock))
    assert kin.attrs["n_steps_used"] == 98
    np.testing.assert_allclose(kin["speed"].values[:-1], 10.0)


def test_buckets_sum_to_the_total_on_messy_tracks():
    rng = np.random.default_rng(5)
    n, n_i = 300, 6
    t = np.cumsum(rng.choice([0.1, 0.1, 0.1, 0.25], size=(n, n_i)), axis=0)
    xy = np.cumsum(rng.normal(0, 1.0, (n, 2, n_i)), axis=0)
    xy[40:60, :, 1] = xy[39, :, 1]  # a rest
    xy[100, 0, 2] += 500.0  # an identity jump
    xy[:, :, 5] = 500.0 * (np.arange(n) % 2)[:, None]  # a track that is all glitch
    xy = np.where((rng.random((n, n_i)) < 0.05)[:, None, :], np.nan, xy)  # missed samples
    kin = compute_kinematics(make_tracks(xy, time=t), smooth=None)
    dq = data_quality(kin)
    assert sum(dq["step_buckets"].values()) == dq["n_steps_total"] == n_i * (n - 1)
    assert set(np.unique(kin["step_class"].values[:-1])) <= set(range(len(STEP_BUCKETS)))
    assert dq["n_steps_resting"] >= 10 and dq["n_steps_implausible"] >= 2
    assert dq["n_individuals_all_implausible"] == 1
    assert not kin["valid"].values[:, 5].any()


@pytest.mark.parametrize("rule", ["first", "mean"])
def test_conflicting_duplicates_need_a_rule(tmp_path, rule):
    (tmp_path / "a.txt").write_text("0 0 0\n0.1 1 0\n0.1 1.2 0\n0.2 2 0\n")
    with pytest.raises(Exception, match=r"a\.txt: individual 'a' at time 0.1 s"):
        read_tracks(tmp_path / "a.txt", units="mm")
    ds = read_tracks(tmp_path / "a.txt", units="mm", duplicates=rule)
    kin = compute_kinematics(ds)
    assert kin.attrs["n_conflicting_duplicates"] == 1
    assert kin.attrs["n_steps_total"] == 2
