"""``thermoswarm view PATH --screenshot FILE.png``: the page rendered by headless Chromium.

The same server and page as an interactive session; the frame, the colour variable
and a followed individual are set through the page's own controls, and the PNG is
written atomically once the frame (and, for ``track`` outputs, its video frame) is
drawn, as a 256-colour palette image (small enough for documentation).
"""

from __future__ import annotations

import base64
import io
import os
import time
from pathlib import Path

from thermoswarm.errors import InputError
from thermoswarm.fsutil import atomic_write_bytes
from thermoswarm.view.data import ViewData

__all__ = ["screenshot"]


def _index(data: ViewData, select: str) -> int:
    names = [str(x) for x in data.ds["individuals"].values]
    if select in names:
        return names.index(select)
    if select.isdigit() and int(select) < data.n:
        return int(select)
    raise InputError(f"--select {select!r}: no such individual (a name such as "
                     f"{names[0]!r}, or an index 0..{data.n - 1})")  # fmt: skip


def screenshot(
    data: ViewData,
    out: str | os.PathLike,
    *,
    frame: int = 0,
    select: str | None = None,
    color_by: str | None = None,
    size: tuple[int, int] = (1400, 900),
    trail: int = 0,
) -> Path:
    """Render the viewer of ``data`` at ``frame`` to the PNG ``out``.

    Parameters
    ----------
    frame
        Frame index (0-based; negative counts from the end).
    select
        Individual to follow (name or index); its panel and plots are shown.
    color_by
        Colour variable (default: the page's).
    size
        Window width and height (CSS px).
    trail
        Trail length (frames).
    """
    from thermoswarm.view.browser import Chromium
    from thermoswarm.view.server import serve_in_thread, start_server

    out = Path(out)
    if not out.absolute().parent.is_dir():
        raise InputError(f"{out}: parent directory does not exist")
    k = frame if frame >= 0 else data.n_frames + frame
    if not 0 <= k < data.n_frames:
        raise InputError(f"--frame {frame}: outside 0..{data.n_frames - 1}")
    if color_by is not None and color_by not in data.variables():
        raise InputError(f"--color-by {color_by!r}: expected one of {', '.join(data.variables())}")
    index = _index(data, select) if select is not None else -1
    server = start_server(data)
    serve_in_thread(server)
    try:
        with Chromium(*size) as browser:
            browser.goto(server.url)
            browser.wait_for("window.viewer && window.viewer.ready()", timeout=120)
            if color_by is not None:
                browser.evaluate(
                    "(() => { const s = document.getElementById('colorby');"
                    f" s.value = {color_by!r}; s.dispatchEvent(new Event('change')); }})()"
                )
            browser.evaluate(
                f"(() => {{ const t = document.getElementById('trail'); t.value = '{trail}';"
                " t.dispatchEvent(new Event('change')); })()"
            )
            browser.evaluate(f"window.viewer.setFrame({k})")
            if index >= 0:
                browser.evaluate(f"window.viewer.select({index})")
            ready = "window.viewer.ready() && !window.viewer.S.dirty"
            if index >= 0:
                ready += f" && window.viewer.S.series && window.viewer.S.series.index === {index}"
            if data.video is not None:
                ready += f" && window.viewer.videoReady({k})"
            browser.wait_for(ready, timeout=120)
            time.sleep(0.3 + 0.02 * trail)  # trail frames arrive after the current one
            browser.evaluate("window.viewer.S.dirty = true")
            browser.wait_for("!window.viewer.S.dirty")
            png = browser.call("Page.captureScreenshot", format="png")["data"]
    finally:
        server.shutdown()
        server.server_close()
    atomic_write_bytes(out, _palette_png(base64.b64decode(png)))
    return out


def _palette_png(png: bytes) -> bytes:
    """The screenshot as a 256-colour PNG: a third of the size, the page's colours kept."""
    from PIL import Image

    img = Image.open(io.BytesIO(png)).convert("RGB")
    pal = img.quantize(colors=256, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)
    buf = io.BytesIO()
    pal.save(buf, format="PNG", optimize=True)
    return buf.getvalue()
