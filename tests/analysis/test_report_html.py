"""The self-contained HTML builder."""

from __future__ import annotations

import base64
import re

import numpy as np
import pytest
from matplotlib.figure import Figure

from thermoswarm.report.html import HtmlReport, format_value


def test_text_is_escaped_and_sections_are_listed():
    rep = HtmlReport("A <title>", subtitle="x & y")
    with rep.section("First"):
        rep.paragraph("<script>alert(1)</script>")
    with rep.section("Second"):
        rep.bullets(["a<b"]).code("if a < b:")
    html = rep.render()
    assert "<script>" not in html and "&lt;script&gt;" in html
    assert "A &lt;title&gt;" in html and "x &amp; y" in html
    assert '<a href="#s1">First</a>' in html and '<a href="#s2">Second</a>' in html
    assert html == rep.render()  # no time stamp: same input, same bytes


def test_tables_from_mapping_and_rows():
    rep = HtmlReport("t", toc=False)
    rep.table({"kT": 12.3456789, "n": 10, "p": None, "ok": True, "nan": float("nan")})
    rep.table([{"a": 1, "b": 2.5}, {"b": 3, "c": "x"}], caption="rows")
    html = rep.render()
    assert "<td>12.35</td>" in html and "<td>10</td>" in html and "<td>yes</td>" in html
    assert html.count("\u2013") >= 2  # None and NaN
    heads = re.findall(r"<th>(\w+)</th>", html.split("rows")[1])
    assert heads == ["a", "b", "c"]
    assert format_value(np.float64(0.5)) == "0.5" and format_value([1, 2]) == "1, 2"
    assert format_value({"+x": 627, "-x": 0.25}) == "+x: 627, -x: 0.25"  # never raw JSON


def test_figure_and_animations_are_embedded(tmp_path):
    fig = Figure()
    fig.subplots().plot([0, 1], [1, 0])
    gif = tmp_path / "a.gif"
    gif.write_bytes(b"GIF89a" + b"\0" * 20)
    mp4 = b"\0\0\0\x18ftypmp42"
    rep = HtmlReport("media").figure(fig, caption="line").animation(gif)
    rep.animation(mp4, "video/mp4", caption="clip")
    html = rep.render()
    png = re.search(r"data:image/png;base64,([A-Za-z0-9+/=]+)", html).group(1)
    assert base64.b64decode(png).startswith(b"\x89PNG")
    g = re.search(r"data:image/gif;base64,([A-Za-z0-9+/=]+)", html).group(1)
    assert base64.b64decode(g).startswith(b"GIF89a")
    assert "<video" in html and "data:video/mp4;base64," in html
    with pytest.raises(ValueError, match="unknown animation"):
        rep.animation(tmp_path / "x.avi")


def test_write_is_atomic_and_complete(tmp_path):
    path = HtmlReport("w").paragraph("hello").write(tmp_path / "r.html")
    text = path.read_text()
    assert text.startswith("<!DOCTYPE html>") and text.rstrip().endswith("</html>")
    assert [p.name for p in tmp_path.iterdir()] == ["r.html"]
