"""``thermoswarm view``: look at a run, a trajectory file or a ``track`` output in the browser.

- :mod:`~thermoswarm.view.source` opens the source; :mod:`~thermoswarm.view.data`
  reads it one frame at a time;
- :mod:`~thermoswarm.view.track_output` and :mod:`~thermoswarm.view.video` add a
  ``track`` output's boxes, events and source video frames;
- :mod:`~thermoswarm.view.server` serves it on 127.0.0.1 behind a random token;
- :mod:`~thermoswarm.view.page` builds the page (``viewer.html`` + ``viewer.js``, no
  library, nothing from the internet), served or self-contained (``--out FILE.html``).

Why Canvas 2D and not WebGL: the tests and the benchmark run headless Chromium with
``--disable-gpu``, where WebGL is software-rendered anyway; writing one pixel per robot
into an ``ImageData`` buffer draws 1,000,000 robots in a few milliseconds on the CPU,
works in every browser, and keeps the page one small file.  Circles (one ``Path2D`` per
colour bin) are used when robots are few or zoomed in.
"""

from __future__ import annotations

from thermoswarm.view.data import ViewData, from_dataset
from thermoswarm.view.page import page_html, write_html
from thermoswarm.view.server import start_server
from thermoswarm.view.source import open_source

__all__ = ["ViewData", "from_dataset", "open_source", "page_html", "write_html", "start_server"]
