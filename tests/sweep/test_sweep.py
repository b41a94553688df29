"""Sweeps: every combination once, finished runs skipped, bad values rejected up front."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import pytest

from thermoswarm.errors import ConfigError
from thermoswarm.sweep import SweepSpec, expand, run_sweep

BASE = {"n": 30, "duration": 5.0, "packing_fraction": 0.05, "record": {"interval": 1.0}}


def test_expand_is_the_product_of_grid_and_seeds(tmp_path):
    spec = SweepSpec(
        "box", tmp_path / "s", BASE, {"kT": [10.0, 20.0], "tau": [0.5, 1.0, 2.0]}, seeds=[0, 1]
    )
    runs = expand(spec)
    assert len(runs) == 12
    assert {(p["kT"], p["tau"], s) for p, s, _ in runs} == {
        (k, t, s) for k in (10.0, 20.0) for t in (0.5, 1.0, 2.0) for s in (0, 1)
    }
    assert all(cfg.params.kT == p["kT"] and cfg.seed == s for p, s, cfg in runs)


def test_bad_value_anywhere_is_rejected_before_running(tmp_path):
    spec = SweepSpec("box", tmp_path / "s", BASE, {"kT": [10.0, -1.0]}, seeds=[0])
    with pytest.raises(ConfigError, match="kT must be a positive number"):
        run_sweep(spec, executor=ThreadPoolExecutor(1))
    assert not (tmp_path / "s").exists()


def test_runs_once_then_skips_finished_runs(tmp_path):
    spec = SweepSpec("box", tmp_path / "s", BASE, {"kT": [10.0, 40.0]}, seeds=[0, 1])
    with ThreadPoolExecutor(1) as ex:
        first = run_sweep(spec, executor=ex, progress=False)
    assert [r.status for r in first] == ["done"] * 4
    assert len({r.run_id for r in first}) == 4
    # a higher temperature means faster robots: the metrics are the runs' own
    by = {(r.params["kT"], r.seed): r.metrics["kT_measured"] for r in first}
    assert by[(40.0, 0)] > by[(10.0, 0)] and by[(40.0, 1)] > by[(10.0, 1)]
    with ThreadPoolExecutor(1) as ex:
        second = run_sweep(spec, executor=ex, progress=False)
    assert [r.status for r in second] == ["skipped"] * 4
    assert [r.metrics for r in second] == [r.metrics for r in first]
    assert (tmp_path / "s" / "sweep.json").is_file()


def test_each_distinct_configuration_is_compiled_once_in_the_parent(tmp_path, monkeypatch):
    from thermoswarm.scenarios import runner
    from thermoswarm.sweep import _compile_here

    built: list[tuple[float, int]] = []
    real_build = runner.build

    def counting_build(cfg):
        built.append((cfg.params.kT, cfg.seed))
        return real_build(cfg)

    monkeypatch.setattr(runner, "build", counting_build)
    spec = SweepSpec("box", tmp_path / "s", BASE, {"kT": [10.0, 40.0]}, seeds=[0, 1, 2])
    _compile_here([cfg for _, _, cfg in expand(spec)])
    assert built == [(10.0, 0), (40.0, 0)]  # seeds share their compiled kernels
    assert not (tmp_path / "s").exists()  # nothing written: the runs come later
