"""A run too large for the memory is refused in one line before anything is allocated
(issue 22: ``simulate box --set n=1e12`` died with a traceback allocating 132 TiB)."""

from __future__ import annotations

import math

import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from thermoswarm.cli import cli
from thermoswarm.errors import ConfigError
from thermoswarm.scenarios import runner

SETTINGS = dict(
    deadline=None,
    derandomize=True,
    database=None,
    max_examples=30,
    phases=[Phase.explicit, Phase.generate],  # no shrinking towards sizes that allocate
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)


@settings(**SETTINGS)
@given(exponent=st.floats(12.0, 18.0))
def test_simulate_more_robots_than_memory_is_one_line(tmp_path, exponent):
    n = int(10**exponent)
    out = tmp_path / f"run{n}"
    res = CliRunner().invoke(cli, ["simulate", "box", "--set", f"n={n}", "--out", str(out)])
    assert res.exit_code == 2, res.output
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    # names the key, the bytes needed and the memory there is
    assert lines[0].startswith(f"error: n = {n}: {n:,} robots need about ")
    assert "of memory available here" in lines[0]
    assert not out.exists()


@settings(**SETTINGS)
@given(
    n=st.integers(1, 10**9),
    n_frames=st.integers(1, 10**9),
    block=st.integers(1, 100_000),
    have=st.integers(10**6, 10**13),
)
def test_memory_check_refuses_exactly_the_runs_that_do_not_fit(
    monkeypatch, n, n_frames, block, have
):
    from thermoswarm.sim import memory

    monkeypatch.setattr(memory, "available_memory", lambda: have)
    per_robot = memory.BYTES_PER_ROBOT + memory.BYTES_PER_ROBOT_FRAME * block
    need = n * (per_robot + memory.BYTES_PER_ROBOT_FRAME * n_frames)
    if need <= have:
        assert memory.check_run_memory(n, n_frames, block) == need
        return
    with pytest.raises(ConfigError, match=r"need about .* memory available here") as err:
        memory.check_run_memory(n, n_frames, block)
    msg = str(err.value)
    # the key to change: the robot count when the robots alone do not fit, else duration
    assert msg.startswith(f"n = {n}:" if n * per_robot > have else "duration:")


@settings(**SETTINGS)
@given(duration_exp=st.floats(8.0, 15.0))
def test_run_recording_too_many_frames_is_refused_before_building(
    monkeypatch, tmp_path, duration_exp
):
    from thermoswarm.sim import memory

    monkeypatch.setattr(memory, "available_memory", lambda: 2**34)
    duration = 10**duration_exp
    cfg = runner.resolve("box", overrides=["n=50", f"duration={duration!r}"])
    out = tmp_path / f"run{duration_exp}"
    with pytest.raises(ConfigError, match=r"^duration: [\d,]+ recorded frames of 50 robots"):
        runner.run(cfg, out)
    assert not out.exists()


def test_a_run_that_fits_is_not_refused(tmp_path):
    from thermoswarm.sim import memory

    cfg = runner.resolve("box", overrides=["n=20", "duration=2"])
    need = memory.check_run_memory(20, 3, cfg.params.record.block)
    assert 0 < need < 2**20 and math.isfinite(need)
    metrics = runner.run(cfg, tmp_path / "ok", progress=False)
    assert metrics["n"] == 20
