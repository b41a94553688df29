"""The strict config loader."""

from __future__ import annotations

import dataclasses
from typing import Literal

import pytest

from thermoswarm.config import (
    apply_overrides,
    check,
    dumps_toml,
    from_mapping,
    load_toml,
    parse_overrides,
)
from thermoswarm.errors import ConfigError


@dataclasses.dataclass(frozen=True)
class Inner:
    dt: float = 0.1
    steps: int = 3


@dataclasses.dataclass(frozen=True)
class Outer:
    n: int = 10
    kT: float = 1.0
    mode: Literal["a", "b"] = "a"
    flag: bool = False
    pair: tuple[float, float] = (0.0, 1.0)
    name: str | None = None
    inner: Inner = Inner()

    def __post_init__(self):
        check(self.n > 0, "n", "positive", self.n)


def test_round_trip_through_toml(tmp_path):
    cfg = from_mapping(Outer, {"n": 5, "kT": 2, "inner": {"steps": 7}, "pair": [1, 2]})
    assert cfg == Outer(n=5, kT=2.0, pair=(1.0, 2.0), inner=Inner(steps=7))
    p = tmp_path / "c.toml"
    p.write_text(dumps_toml(cfg))
    assert from_mapping(Outer, load_toml(p)) == cfg


@pytest.mark.parametrize(
    "data, msg",
    [
        ({"m": 1}, "unknown key 'm'; expected one of"),
        ({"inner": {"dx": 1}}, "unknown key 'inner.dx'"),
        ({"n": "ten"}, "n must be an integer, got 'ten'"),
        ({"n": 1.5}, "n must be an integer"),
        ({"n": True}, "n must be an integer"),
        ({"kT": "hot"}, "kT must be a number"),
        ({"mode": "c"}, "mode must be one of 'a', 'b'"),
        ({"flag": 1}, "flag must be true or false"),
        ({"pair": [1, 2, 3]}, "pair must be a list of 2 items"),
        ({"inner": 3}, "inner must be a table"),
        ({"n": -1}, "n must be positive, got -1"),
        ({"inner": {"steps": "x"}}, "inner.steps must be an integer"),
    ],
)
def test_errors_name_the_key_and_the_source(data, msg):
    with pytest.raises(ConfigError) as e:
        from_mapping(Outer, data, source="my.toml")
    assert str(e.value).startswith("my.toml: ") and msg in str(e.value)
    assert "\n" not in str(e.value)


def test_overrides_parse_toml_values_and_dotted_keys():
    over = parse_overrides(["n=3", "inner.dt=0.5", "mode=b", "pair=[1, 2]", "name='x'"])
    assert over == {"n": 3, "inner": {"dt": 0.5}, "mode": "b", "pair": [1, 2], "name": "x"}
    merged = apply_overrides({"inner": {"steps": 9}, "n": 1}, over)
    assert from_mapping(Outer, merged) == Outer(
        n=3, mode="b", pair=(1.0, 2.0), name="x", inner=Inner(dt=0.5, steps=9)
    )
    with pytest.raises(ConfigError, match="expected key=value"):
        parse_overrides(["novalue"])


def test_load_toml_errors(tmp_path):
    with pytest.raises(ConfigError, match="does not exist"):
        load_toml(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("n = = 3")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_toml(bad)


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf")])
def test_check_positive_names_the_field_and_the_value(bad):
    from thermoswarm.config import check_positive

    with pytest.raises(ConfigError, match=r"^force must be a positive force, got "):
        check_positive("force", bad, "a positive force")
    check_positive("force", 1e-9, "a positive force")  # the smallest positive passes
