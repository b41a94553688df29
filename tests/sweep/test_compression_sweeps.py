"""The compression experiment's sweeps: tables, restarts, the density search."""

from __future__ import annotations

import math

import numpy as np
import pytest

from thermoswarm.scenarios import compression as C
from thermoswarm.sweep import compression as CS


def _in_process():
    # the sweep's default is a pool of spawned processes; one thread keeps tests lean
    from concurrent.futures import ThreadPoolExecutor

    return ThreadPoolExecutor(max_workers=1)


def test_isotherm_table_and_restart_skips_finished_runs(tmp_path):
    base = {"n": 20, "width": 800.0, "duration": 60.0}
    with _in_process() as ex:
        t1 = CS.isotherm([10.0, 20.0], out=tmp_path / "iso", base=base, executor=ex)
        assert t1["force"].tolist() == [10.0, 20.0]
        assert t1["status"].tolist() == ["done", "done"]
        assert t1["pressure"].notna().all()
        assert (t1["pressure_applied"] == t1["force"] / (800.0 - 33.0)).all()
        runs = sorted(p.name for p in (tmp_path / "iso").iterdir() if p.is_dir())
        assert len(runs) == 2 and runs == sorted(t1["run_id"])
        t2 = CS.isotherm([10.0, 20.0], out=tmp_path / "iso", base=base, executor=ex)
    assert t2["status"].tolist() == ["skipped", "skipped"]
    assert t2["pressure"].tolist() == t1["pressure"].tolist()


def test_failed_runs_stop_the_density_search(tmp_path, monkeypatch):
    from thermoswarm.errors import ThermoswarmError

    def failing(base, grid, seeds, out, executor=None):
        return [{"run_id": "abc", "seed": 0, "status": "failed", "metrics": None,
                 "error": "worker process died"}]  # fmt: skip

    monkeypatch.setattr(CS, "_run_sweep", failing)
    with pytest.raises(ThermoswarmError, match="abc.*worker process died"):
        CS.temperature_for_density([5.0], packing_fraction=0.05, out=tmp_path / "w")


def test_temperature_for_density_iterates_to_the_target(tmp_path, monkeypatch):
    """With a gas whose Z is a constant 1.1 (an oracle in place of the runs), one
    correction after the ideal-gas guess lands exactly on the target density."""
    calls = []

    def oracle(base, grid, seeds, out, executor=None):
        p = C.CompressionParams(**{k: v for k, v in base.items() if k not in ("record",)})
        hf = 1.1 * p.n * p.kT_eff_theory / p.force
        h = hf + p.diameter
        calls.append((p.force, p.kT))
        m = {"force": p.force, "kT": p.kT, "n": p.n, "height": h, "pressure": 1.0,
             "packing_fraction": p.n * math.pi * p.radius**2 / (p.width * h)}  # fmt: skip
        return [{"run_id": str(len(calls)), "seed": 0, "status": "done", "metrics": m}]

    monkeypatch.setattr(CS, "_run_sweep", oracle)
    base = {"n": 100, "width": 2000.0}
    t = CS.temperature_for_density([5.0, 10.0, 20.0], packing_fraction=0.05,
                                  out=tmp_path / "w", base=base, iterations=2)  # fmt: skip
    assert t["packing_fraction"].to_numpy() == pytest.approx(np.full(3, 0.05))
    # at fixed density the temperature is proportional to the force
    assert (t["kT"] / t["force"]).to_numpy() == pytest.approx(np.full(3, t["kT"][0] / 5.0))
    # first guess: the ideal-gas temperature, 10 % too hot for a gas with Z = 1.1
    first = dict(calls[:3])
    assert first[10.0] == pytest.approx(t["kT"][1] * 1.1)


def test_temperature_series_holds_one_area_for_all_temperatures(tmp_path):
    base = {"n": 20, "width": 800.0, "duration": 60.0, "kT": 50.0}
    with _in_process() as ex:
        t = CS.temperature_series(
            [40.0, 90.0], force=10.0, out=tmp_path / "T", base=base, executor=ex
        )
    assert t["walls"].tolist() == ["held", "held"]
    assert t["kT"].tolist() == [40.0, 90.0]
    # one height for both: the ideal-gas height at the force and the first temperature
    h = C.ideal_height(20, 2 * 40.0 * 1.0 / 4, 10.0, 33.0)
    assert t["height"].to_numpy() == pytest.approx([h, h], abs=1e-9)
    assert t["pressure"].iloc[1] > t["pressure"].iloc[0]
