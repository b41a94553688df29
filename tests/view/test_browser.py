"""The viewer in a real browser: Debian's headless Chromium over the DevTools protocol.

Without chromium these tests FAIL (CI installs it); set THERMOSWARM_SKIP_BROWSER=1 to
skip them on a machine without it.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from thermoswarm.view.data import ViewData
from thermoswarm.view.server import serve_in_thread, start_server
from thermoswarm.view.source import open_source


@pytest.fixture
def serve():
    servers = []

    def _serve(data: ViewData):
        server = start_server(data)
        serve_in_thread(server)
        servers.append(server)
        return server

    yield _serve
    for server in servers:
        server.shutdown()
        server.server_close()


def _open(chromium, url: str) -> None:
    chromium.goto(url)
    chromium.wait_for("window.viewer && window.viewer.ready()", timeout=60)


def _notes(chromium) -> str:
    return chromium.evaluate("document.getElementById('notes').innerText")


def _canvas_point(chromium, x: float, y: float) -> tuple[float, float]:
    """Viewport coordinates (CSS px) of world point (x, y)."""
    return tuple(
        chromium.evaluate(
            "(() => { const r = document.getElementById('view').getBoundingClientRect();"
            f" const p = window.viewer.toScreen({x}, {y});"
            " return [r.left + p[0], r.top + p[1]]; })()"
        )
    )


def _pixel(chromium, x: float, y: float) -> list[int]:
    return chromium.evaluate(
        f"Array.from(document.getElementById('view').getContext('2d')"
        f".getImageData({int(x)}, {int(y)}, 1, 1).data)"
    )


def test_loads_plays_slides_and_selects(chromium, serve, small_run):
    data = open_source(small_run)
    server = serve(data)
    _open(chromium, server.url)
    assert "error" not in _notes(chromium)
    title = chromium.evaluate("document.getElementById('title').innerText")
    assert f"{data.n} individuals" in title and "transport-free" in title
    # the robots are drawn: the canvas holds the categorical colours of the phases
    nc = xr.open_dataset(small_run / "tracks.nc", engine="h5netcdf")
    x, y = nc["position"].values[0, :, 0, 0]
    px, py = chromium.evaluate(f"window.viewer.toScreen({x}, {y})")
    assert _pixel(chromium, px, py)[:3] != [247, 247, 245]

    # play: a real click on the button, frames advance, then pause
    bx, by = chromium.evaluate(
        "(() => { const r = document.getElementById('play').getBoundingClientRect();"
        " return [r.left + r.width / 2, r.top + r.height / 2]; })()"
    )
    chromium.click(bx, by)
    chromium.wait_for("window.viewer.S.k >= 3", timeout=30)
    chromium.click(bx, by)
    assert chromium.evaluate("window.viewer.S.playing") is False

    # the slider moves the frame
    k = 9
    chromium.evaluate(
        f"(() => {{ const s = document.getElementById('slider'); s.value = '{k}';"
        " s.dispatchEvent(new Event('input')); })()"
    )
    chromium.wait_for(f"window.viewer.S.k === {k} && window.viewer.ready()")
    assert chromium.evaluate("document.getElementById('clock').innerText").startswith(
        f"frame {k} / {data.n_frames - 1}"
    )

    # a click on a robot selects it; its panel shows the file's values at this frame
    i = 17
    x, y = nc["position"].values[k, :, 0, i]
    cx, cy = _canvas_point(chromium, x, y)
    chromium.click(cx, cy)
    chromium.wait_for("document.getElementById('sel-speed') !== null", timeout=30)
    shown = chromium.evaluate(
        "['id', 'x', 'y', 'speed', 'energy'].map("
        "(n) => document.getElementById('sel-' + n).innerText)"
    )
    speed = float(nc["speed"].values[k, i])
    assert shown[0] == str(nc["individuals"].values[i])
    assert float(shown[1].split()[0]) == pytest.approx(x, rel=5e-4)
    assert float(shown[2].split()[0]) == pytest.approx(y, rel=5e-4)
    assert float(shown[3].split()[0]) == pytest.approx(speed, rel=5e-4)
    assert shown[3].endswith("mm/s")
    assert float(shown[4].split()[0]) == pytest.approx(0.5 * speed**2, rel=5e-4)
    assert chromium.evaluate("window.viewer.S.series.speed.length") == data.n_frames
    nc.close()


def test_colour_by_changes_legend_with_units(chromium, serve, small_run):
    server = serve(open_source(small_run))
    _open(chromium, server.url)
    chromium.evaluate(
        "(() => { const s = document.getElementById('colorby'); s.value = 'energy';"
        " s.dispatchEvent(new Event('change')); })()"
    )
    chromium.wait_for("window.viewer.ready()")
    legend = chromium.evaluate("document.getElementById('legend').innerText")
    assert legend.startswith("energy (mm^2/s^2)")


def test_track_output_drawn_over_its_video(chromium, serve, track_output):
    data = open_source(track_output["out"])
    server = serve(data)
    _open(chromium, server.url)
    chromium.evaluate("window.viewer.setFrame(7)")
    chromium.wait_for("window.viewer.ready() && window.viewer.videoReady(7)")
    chromium.evaluate("window.viewer.S.dirty = true")
    chromium.wait_for("window.viewer.ready() && !window.viewer.S.dirty")
    # the video's white square (10..30 px) is under world point (20, 20)
    px, py = chromium.evaluate("window.viewer.toScreen(20, 20)")
    assert min(_pixel(chromium, px, py)[:3]) > 200
    px, py = chromium.evaluate("window.viewer.toScreen(5, 55)")
    assert max(_pixel(chromium, px, py)[:3]) < 80
    events = chromium.evaluate("document.getElementById('events').innerText")
    assert "frame 5: lost track_2" in events and "frame 7: switch? track_3" in events


def test_error_is_shown_in_the_page(chromium, serve, small_run):
    data = open_source(small_run)

    def broken(k, var):
        raise OSError("disk unplugged")

    data.frame_bytes = broken  # type: ignore[method-assign]
    server = serve(data)
    chromium.goto(server.url)
    chromium.wait_for("document.getElementById('notes').innerText.includes('error')", timeout=30)
    assert "OSError: disk unplugged" in _notes(chromium)


def test_run_being_written_is_said_in_the_page(chromium, serve, tmp_path):
    from thermoswarm.sim.recorder import ZarrRecorder

    rec = ZarrRecorder(tmp_path / "tracks.zarr", n=3, n_frames=8, block=2, attrs={"fps": 1.0})
    for f in range(2):
        rec.add(float(f), np.c_[np.arange(3.0), np.zeros(3) + f],
                {"heading": np.zeros(3), "speed": np.ones(3)})  # fmt: skip
    rec.flush()
    server = serve(open_source(tmp_path / "tracks.zarr"))
    _open(chromium, server.url)
    notes = _notes(chromium)
    assert "still being written (or was stopped): showing its 2 committed frames" in notes


def test_names_from_files_are_shown_as_text(chromium, serve, tmp_path):
    from thermoswarm.tracks import make_tracks
    from thermoswarm.view.data import from_dataset

    evil = "<img src=x onerror=window.__pwned=1>"
    pos = np.zeros((3, 2, 2))
    pos[:, 0, 1] = 100.0
    data = from_dataset(make_tracks(pos, fps=1.0, individuals=[evil, "b"]), "names")
    server = serve(data)
    _open(chromium, server.url)
    chromium.evaluate("window.viewer.select(0)")
    chromium.wait_for("document.getElementById('sel-id') !== null")
    assert chromium.evaluate("document.getElementById('sel-id').innerText") == evil
    assert chromium.evaluate("window.__pwned === undefined")


def test_self_contained_file_works_from_disk(chromium, small_run, tmp_path):
    from thermoswarm.view.page import write_html

    out = write_html(open_source(small_run), tmp_path / "run.html")
    chromium.goto(out.resolve().as_uri())
    chromium.wait_for("window.viewer && window.viewer.ready()", timeout=60)
    assert "self-contained file" in _notes(chromium)
    k, i = 5, 3
    chromium.evaluate(f"window.viewer.setFrame({k})")
    chromium.evaluate(f"window.viewer.select({i})")
    chromium.wait_for("document.getElementById('sel-speed') !== null", timeout=30)
    nc = xr.open_dataset(small_run / "tracks.nc", engine="h5netcdf")
    shown = chromium.evaluate("document.getElementById('sel-speed').innerText")
    assert float(shown.split()[0]) == pytest.approx(float(nc["speed"].values[k, i]), rel=5e-4)
    nc.close()


def test_wheel_zooms_about_the_cursor_and_drag_pans(chromium, serve, small_run):
    data = open_source(small_run)
    server = serve(data)
    _open(chromium, server.url)
    z0 = chromium.evaluate("window.viewer.S.zoom")
    cx, cy = _canvas_point(chromium, 600.0, 700.0)  # world point under the cursor
    chromium.call("Input.dispatchMouseEvent", type="mouseWheel", x=cx, y=cy, deltaX=0,
                  deltaY=-300)  # fmt: skip
    chromium.wait_for(f"window.viewer.S.zoom > {z0 * 1.3}")
    # the point under the cursor stays under it
    x2, y2 = _canvas_point(chromium, 600.0, 700.0)
    assert abs(x2 - cx) < 1.5 and abs(y2 - cy) < 1.5
    before = chromium.evaluate("[window.viewer.S.cx, window.viewer.S.cy]")
    chromium.call("Input.dispatchMouseEvent", type="mousePressed", x=cx, y=cy, button="left",
                  clickCount=1)  # fmt: skip
    chromium.call("Input.dispatchMouseEvent", type="mouseMoved", x=cx + 100, y=cy + 50,
                  button="left")  # fmt: skip
    chromium.call("Input.dispatchMouseEvent", type="mouseReleased", x=cx + 100, y=cy + 50,
                  button="left", clickCount=1)  # fmt: skip
    after = chromium.evaluate("[window.viewer.S.cx, window.viewer.S.cy]")
    zoom = chromium.evaluate("window.viewer.S.zoom")
    assert after[0] == pytest.approx(before[0] - 100 / zoom, rel=1e-6)
    assert after[1] == pytest.approx(before[1] + 50 / zoom, rel=1e-6)  # y up in a run
    assert chromium.evaluate("window.viewer.S.sel") == -1  # a drag is not a click


def test_cli_screenshot(chromium, small_run, tmp_path, capsys):
    from PIL import Image

    from thermoswarm.cli import main

    png = tmp_path / "run.png"
    with pytest.raises(SystemExit) as exc:
        main(["view", str(small_run), "--screenshot", str(png), "--frame", "-1",
              "--select", "id_3", "--color-by", "energy"])  # fmt: skip
    assert exc.value.code == 0
    with Image.open(png) as img:
        assert img.size == (1400, 900) and img.mode == "P"
        rgb = np.asarray(img.convert("RGB"))
    assert len(np.unique(rgb.reshape(-1, 3), axis=0)) > 8  # drawn, not blank
    for bad, what in ((["--select", "nobody"], "--select 'nobody'"),
                      (["--color-by", "mood"], "--color-by 'mood'"),
                      (["--frame", "999"], "--frame 999")):  # fmt: skip
        with pytest.raises(SystemExit) as exc:
            main(["view", str(small_run), "--screenshot", str(tmp_path / "x.png"), *bad])
        assert exc.value.code == 2
        err = capsys.readouterr().err
        assert err.startswith(f"error: {what}") and err.count("\n") == 1
    assert not (tmp_path / "x.png").exists()
