"""`thermoswarm scenarios NAME` lists every parameter with its unit; `--set` is checked
before the heavy modules are imported, with the same messages as the full check."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
import typing

import pytest
from click.testing import CliRunner

from thermoswarm.cli import cli
from thermoswarm.config import describe, from_mapping, parse_overrides
from thermoswarm.errors import ConfigError
from thermoswarm.scenarios import get, names, schema


def _all_keys(cls: type, prefix: str = "") -> list[str]:
    """Every field of a config class, nested sections as dotted keys (from the class)."""
    hints = typing.get_type_hints(cls)
    keys = []
    for f in dataclasses.fields(cls):
        keys.append(prefix + f.name)
        if dataclasses.is_dataclass(hints[f.name]):
            keys += _all_keys(hints[f.name], prefix + f.name + ".")
    return keys


@pytest.mark.parametrize("name", names())
def test_the_listing_shows_every_parameter_of_every_section(name):
    res = CliRunner().invoke(cli, ["scenarios", name])
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    listed = [ln.split()[0] for ln in lines
              if ln.startswith("  ") and not ln.startswith("  [") and " = " in ln]  # fmt: skip
    sections = [ln.strip().split()[0].strip("[]") for ln in res.output.splitlines()
                if ln.startswith("  [")]  # fmt: skip
    assert sorted(listed + sections) == sorted(_all_keys(get(name).Params))
    assert "engine.dt" in listed and "record.interval" in listed


@pytest.mark.parametrize("name", names())
def test_every_number_parameter_has_a_unit(name):
    """A float parameter without a unit in its docstring (or one the house's conventions
    give: lengths mm, times s, temperatures mm^2/s^2) fails here."""
    rows = describe(get(name).Params)
    missing = []
    for r in rows:
        spec = r["type"]
        kind = spec["of"]["kind"] if spec["kind"] == "optional" else spec["kind"]
        if kind == "float" and not r["unit"]:
            missing.append(r["key"])
    assert not missing, f"{name}: no unit stated for {missing}"
    by_key = {r["key"]: r for r in rows}
    assert by_key["engine.dt"]["unit"] == "s" and by_key["duration"]["unit"] == "s"


def test_listing_values_are_the_defaults_and_the_units_are_printed():
    res = CliRunner().invoke(cli, ["scenarios", "transport-free", "--json"])
    rows = {r["key"]: r for r in json.loads(res.output)["transport-free"]["params"]}
    defaults = get("transport-free").Params()
    assert rows["n"]["default"] == defaults.n
    assert rows["sensor.mode"]["default"] == defaults.sensor.mode
    assert rows["object_drag"]["unit"] == "robot drags"
    text = CliRunner().invoke(cli, ["scenarios", "compression"]).output
    line = next(ln for ln in text.splitlines() if ln.strip().startswith("kT "))
    assert "mm^2/s^2" in line


BAD = [
    ("box", ["engine.nope=1"]),
    ("box", ["dt=0.05"]),  # a key of a section, written at the top
    ("box", ["pakcing_fraction=0.2"]),
    ("box", ["n='ten'"]),
    ("box", ["mode='quantum'"]),
    ("transport-free", ["sensor.mdoe='ideal'"]),
    ("transport-free", ["variant=spiral"]),
    ("narrow-road", ["section_widths=[1, 'a']"]),
    ("compression", ["record.interval=true"]),
]


@pytest.mark.parametrize("name, sets", BAD)
def test_the_fast_check_says_what_the_full_check_says(name, sets):
    with pytest.raises(ConfigError) as fast:
        schema.precheck(name, overrides=sets)
    with pytest.raises(ConfigError) as full:
        from_mapping(get(name).Params, parse_overrides(sets), source="--set")
    assert str(fast.value) == str(full.value)


def test_suggestions_for_typos_and_misplaced_section_keys():
    with pytest.raises(ConfigError, match=r"did you mean 'engine\.dt'"):
        schema.precheck("box", overrides=["dt=0.05"])
    with pytest.raises(ConfigError, match="did you mean 'packing_fraction'"):
        schema.precheck("box", overrides=["pakcing_fraction=0.2"])
    with pytest.raises(ConfigError, match="did you mean 'transport-free'"):
        schema.precheck("transport-fre", overrides=[])
    # valid input passes, ranges are left to the full check
    schema.precheck("box", overrides=["n=10", "engine.dt=0.05", "record.netcdf=false"])
    schema.precheck("box", overrides=["n=-1"])
    schema.precheck("transport-free", overrides=[], grid={"n": [10, 20], "sensor.mode": ["ideal"]})
    with pytest.raises(ConfigError, match="grid sensor.mode: sensor.mode must be one of"):
        schema.precheck("transport-free", overrides=[], grid={"sensor.mode": ["ideal", "eye"]})


def _env(cache: str) -> dict[str, str]:
    env = dict(os.environ)
    env["THERMOSWARM_CACHE_DIR"] = cache
    return env


CHECK = """
import sys
from thermoswarm.scenarios.schema import precheck
try:
    precheck("box", overrides=["engine.nope=1"])
except Exception as exc:
    print(exc)
print(sorted(m for m in ("numba", "scipy", "xarray", "numpy", "zarr") if m in sys.modules))
"""


def test_a_bad_set_is_answered_without_importing_the_heavy_modules(tmp_path):
    cache = str(tmp_path / "cache")
    # the first call on a machine builds the listing (imports every scenario) ...
    first = subprocess.run([sys.executable, "-c", CHECK], env=_env(cache), text=True,
                           capture_output=True, check=True).stdout.splitlines()  # fmt: skip
    assert "unknown key 'engine.nope'" in first[0]
    assert list(tmp_path.glob("cache/params-*.json"))
    # ... every later one reads it and imports none of them
    again = subprocess.run([sys.executable, "-c", CHECK], env=_env(cache), text=True,
                           capture_output=True, check=True).stdout.splitlines()  # fmt: skip
    assert again[0] == first[0]
    assert again[1] == "[]"


def test_a_stale_or_broken_listing_is_rebuilt(tmp_path, monkeypatch):
    monkeypatch.setenv("THERMOSWARM_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(schema, "_MEMO", None)
    path = schema._cache_file()
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"fingerprint": "old", "scenarios": {"box": {}}}))
    got = schema.all_params()
    assert set(got) == set(names()) and got["box"]["params"]
    assert json.loads(path.read_text())["fingerprint"] == schema._fingerprint()
    monkeypatch.setattr(schema, "_MEMO", None)
    path.write_text("{not json")
    assert set(schema.all_params()) == set(names())
