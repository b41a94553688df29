"""Regions: the TOML format, its errors, and point-in-polygon against ray casting."""

from __future__ import annotations

import numpy as np
import pytest

from thermoswarm.analysis.regions import (
    OUTSIDE,
    assign_regions,
    load_regions,
    regions_from_mapping,
)
from thermoswarm.errors import ConfigError

GOOD = """
[[region]]
name = "wide"
polygon = [[0, 0], [60, 0], [60, 40], [0, 40], [0, 0]]

[[region]]
name = "narrow"
rect = [60, 10, 100, 30]
"""


def test_load_regions_from_toml(tmp_path):
    p = tmp_path / "regions.toml"
    p.write_text(GOOD)
    wide, narrow = load_regions(p)
    assert (wide.name, narrow.name) == ("wide", "narrow")
    assert wide.vertices.shape == (4, 2)  # closing vertex dropped
    assert wide.area == pytest.approx(2400.0)
    assert narrow.area == pytest.approx(800.0)
    x = np.array([10.0, 70.0, 70.0, np.nan])
    y = np.array([10.0, 20.0, 5.0, 1.0])
    np.testing.assert_array_equal(assign_regions([wide, narrow], x, y), [0, 1, OUTSIDE, OUTSIDE])


def ray_cast(vx, vy, px, py):
    """Reference even-odd rule, written independently of matplotlib."""
    inside = np.zeros(px.shape, dtype=bool)
    n = len(vx)
    j = n - 1
    for i in range(n):
        cond = (vy[i] > py) != (vy[j] > py)
        xint = (vx[j] - vx[i]) * (py - vy[i]) / (vy[j] - vy[i] + 1e-300) + vx[i]
        inside ^= cond & (px < xint)
        j = i
    return inside


def test_concave_polygon_matches_ray_casting():
    poly = [[0, 0], [10, 0], [10, 10], [6, 10], [6, 3], [3, 3], [3, 10], [0, 10]]  # a U
    (reg,) = regions_from_mapping({"region": [{"name": "u", "polygon": poly}]})
    rng = np.random.default_rng(0)
    px, py = rng.uniform(-2, 12, 20000), rng.uniform(-2, 12, 20000)
    v = np.asarray(poly, dtype=float)
    np.testing.assert_array_equal(reg.contains(px, py), ray_cast(v[:, 0], v[:, 1], px, py))
    assert reg.area == pytest.approx(100 - 3 * 7)


def test_first_region_wins_where_they_overlap():
    regs = regions_from_mapping(
        {
            "region": [
                {"name": "inner", "rect": [2, 2, 4, 4]},
                {"name": "outer", "rect": [0, 0, 10, 10]},
            ]
        }
    )
    np.testing.assert_array_equal(
        assign_regions(regs, np.array([3.0, 8.0, 11.0]), np.array([3.0, 8.0, 1.0])), [0, 1, -1]
    )


@pytest.mark.parametrize(
    ("doc", "match"),
    [
        ({}, "no \\[\\[region\\]\\]"),
        ({"regions": []}, "unknown key 'regions'"),
        ({"region": [{"polygon": [[0, 0], [1, 0], [0, 1]]}]}, "name must be"),
        ({"region": [{"name": "a", "rect": [0, 0, 1, 1]}, {"name": "a", "rect": [2, 2, 3, 3]}]},
         "used twice"),
        ({"region": [{"name": "a"}]}, "exactly one of polygon or rect"),
        ({"region": [{"name": "a", "polygon": [[0, 0], [1, 0]]}]}, "at least 3"),
        ({"region": [{"name": "a", "polygon": [[0, 0], [1, "x"], [0, 1]]}]}, "polygon\\[1\\]"),
        ({"region": [{"name": "a", "polygon": [[0, 0], [1, 1], [2, 2]]}]}, "zero area"),
        ({"region": [{"name": "a", "polygon": [[0, 0], [2, 2], [2, 0], [0, 2]]}]}, "crosses"),
        ({"region": [{"name": "a", "rect": [1, 0, 0, 1]}]}, "x_max > x_min"),
        ({"region": [{"name": "a", "rect": [0, 0, 1, 1], "color": "red"}]}, "unknown key 'color'"),
        ({"region": [{"name": "outside", "rect": [0, 0, 1, 1]}]}, "reserved"),
    ],
)  # fmt: skip
def test_malformed_regions_name_the_problem(doc, match):
    with pytest.raises(ConfigError, match=match):
        regions_from_mapping(doc, source="r.toml")


def test_missing_or_invalid_file_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError, match="does not exist"):
        load_regions(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[[region]\nname=")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_regions(bad)
