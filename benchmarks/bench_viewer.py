"""Frame rate of ``thermoswarm view`` in headless Chromium, read from the page's own timings.

For each swarm size a synthetic run (random walks in a square, ``speed`` as the colour
variable) is served by the viewer's server exactly as ``thermoswarm view`` serves it;
headless Chromium (Debian's, the flags of :mod:`thermoswarm.view.browser`, a 1400 x 900
window) opens the page and plays at the "max" speed: each displayed frame is a new
frame fetched from the server as float32, decoded and drawn.  The page records
``performance.now()`` each time it shows a frame and how long each draw took; the
benchmark reads those arrays back and reports

- ``fps``: frames shown per second during playback (fetch + draw, pipelined; the
  browser's animation frames cap it at the display rate, 60/s);
- ``draw_ms``: median time of one draw (the Canvas 2D part alone);
- ``fetch_ms``: median time from request to a decoded frame.

The goal (issue 24): 30 frames/s or more at 100,000 robots, a few at 1,000,000.  Usage::

    .venv/bin/python benchmarks/bench_viewer.py [--sizes 10000,100000,1000000] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

from thermoswarm.tracks import make_tracks
from thermoswarm.view.browser import Chromium
from thermoswarm.view.data import from_dataset
from thermoswarm.view.server import serve_in_thread, start_server


def synthetic(n: int, frames: int, rng: np.random.Generator):
    """``n`` random walkers (mm) in a square of 20 robot diameters per sqrt(n)."""
    side = 33.0 * 3 * np.sqrt(n)
    pos = np.empty((frames, 2, n), dtype=np.float32)
    pos[0] = rng.uniform(0, side, (2, n))
    for k in range(1, frames):
        pos[k] = pos[k - 1] + rng.normal(0, 5.0, (2, n)).astype(np.float32)
    ds = make_tracks(pos, fps=10.0, attrs={"radius": 16.5})
    speed = rng.gamma(2.0, 8.0, (frames, n)).astype(np.float32)
    ds["speed"] = (("time", "individuals"), speed, {"units": "mm/s"})
    return ds


def measure(browser: Chromium, n: int, frames: int, seconds: float, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    data = from_dataset(synthetic(n, frames, rng), f"synthetic {n}")
    server = start_server(data)
    serve_in_thread(server)
    try:
        browser.goto(server.url)
        browser.wait_for("window.viewer && window.viewer.ready()", timeout=120)
        browser.evaluate(
            "(() => { const v = window.viewer; v.S.speed = 'max';"
            " v.S.stats.shown.length = 0; v.S.stats.drawMs.length = 0;"
            " v.S.stats.fetchMs.length = 0; v.setPlaying(true); })()"
        )
        t0 = time.monotonic()
        while time.monotonic() - t0 < seconds and browser.evaluate("window.viewer.S.playing"):
            time.sleep(0.2)
        stats = browser.evaluate(
            "(() => { const s = window.viewer.S.stats;"
            " return {shown: s.shown, draw: s.drawMs, fetch: s.fetchMs,"
            " mode: s.mode, k: window.viewer.S.k}; })()"
        )
        browser.evaluate("window.viewer.setPlaying(false)")
    finally:
        server.shutdown()
        server.server_close()
    shown = np.asarray(stats["shown"], dtype=float)
    fps = (shown.size - 1) / ((shown[-1] - shown[0]) / 1e3) if shown.size > 2 else float("nan")
    return {
        "robots": n,
        "frames_played": int(shown.size),
        "fps": round(float(fps), 1),
        "draw_ms": round(float(np.median(stats["draw"])), 2),
        "fetch_ms": round(float(np.median(stats["fetch"])), 1) if stats["fetch"] else None,
        "mode": stats["mode"],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="10000,100000,1000000")
    ap.add_argument("--seconds", type=float, default=6.0, help="playback time per size")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    rows = []
    with Chromium(1400, 900) as browser:
        for n in sizes:
            frames = 240 if n <= 100_000 else 24
            rows.append(measure(browser, n, frames, args.seconds, args.seed))
            if not args.json:
                r = rows[-1]
                print(f"{n:>9,} robots: {r['fps']:6.1f} frames/s  draw {r['draw_ms']:6.2f} ms"
                      f"  fetch {r['fetch_ms']} ms  ({r['mode']}, {r['frames_played']} frames)",
                      flush=True)  # fmt: skip
    load = os.getloadavg()
    if args.json:
        print(json.dumps({"results": rows, "load_average": load}))
    else:
        print(f"load average {load[0]:.1f} on {os.cpu_count()} cores", file=sys.stderr)


if __name__ == "__main__":
    main()
