"""Animations of recorded runs: MP4 when the video extra is installed, else GIF.

Each frame is drawn with a scenario's ``plot_frame(ax, tracks, t, info)`` on a
Matplotlib figure (Agg, no display).  MP4 goes through the tracking package's video
writer (imageio-ffmpeg, libx264); the GIF fallback through Pillow, which Matplotlib
already needs.  Files are written atomically.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.fsutil import atomic_path

__all__ = ["animate", "video_format", "snapshot_strip"]


def video_format() -> str:
    """``"mp4"`` when imageio-ffmpeg (and OpenCV) are installed, else ``"gif"``."""
    have = all(importlib.util.find_spec(m) is not None for m in ("imageio_ffmpeg", "cv2"))
    return "mp4" if have else "gif"


def _frame_times(tracks: xr.Dataset, frames: int) -> np.ndarray:
    t = np.asarray(tracks["time"].values, dtype=float)
    t = t[np.isfinite(t)]
    if t.size == 0:
        return t
    idx = np.unique(np.linspace(0, t.size - 1, min(frames, t.size)).round().astype(int))
    return t[idx]


def animate(
    tracks: xr.Dataset,
    plot_frame: Callable[..., Any],
    info: Any,
    path: str | Path,
    *,
    frames: int = 60,
    fps: float = 12.0,
    size: tuple[float, float] = (5.0, 5.0),
    dpi: int = 80,
    title: str | None = None,
) -> Path:
    """Render ``frames`` evenly spaced recorded frames into ``path`` (.mp4 or .gif).

    The extension of ``path`` is replaced by :func:`video_format`'s; returns the path
    written.
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fmt = video_format()
    path = Path(path).with_suffix("." + fmt)
    times = _frame_times(tracks, frames)
    if times.size == 0:
        raise ValueError("no recorded frames to animate")
    fig, ax = plt.subplots(figsize=size, dpi=dpi)

    def images():
        for t in times:
            ax.clear()
            plot_frame(ax, tracks, float(t), info)
            ax.set_title(f"{title + ' -- ' if title else ''}t = {t:.0f} s", fontsize=9)
            fig.canvas.draw()
            buf = np.asarray(fig.canvas.buffer_rgba())[..., :3]
            h, w = buf.shape[0] // 2 * 2, buf.shape[1] // 2 * 2  # even sizes for H.264
            yield np.ascontiguousarray(buf[:h, :w])

    try:
        if fmt == "mp4":
            from thermoswarm.tracking.synth.clip import write_video

            write_video(images(), path, fps)
        else:
            from PIL import Image

            pics = [Image.fromarray(im) for im in images()]
            with atomic_path(path, suffix=".gif") as tmp:
                pics[0].save(tmp, format="GIF", save_all=True, append_images=pics[1:],
                             duration=int(1000 / fps), loop=0)  # fmt: skip
    finally:
        plt.close(fig)
    return path


def snapshot_strip(
    tracks: xr.Dataset,
    plot_frame: Callable[..., Any],
    info: Any,
    times: list[float] | None = None,
    *,
    panels: int = 5,
    size: float = 2.6,
) -> Any:
    """A row of snapshots at ``times`` (default evenly spaced), as the paper's figures,
    with axes in mm."""
    import matplotlib.pyplot as plt

    if times is None:
        times = list(_frame_times(tracks, panels))
    fig, axes = plt.subplots(1, len(times), figsize=(size * len(times), size + 0.6))
    for i, (ax, t) in enumerate(zip(np.atleast_1d(axes), times, strict=True)):
        plot_frame(ax, tracks, float(t), info)
        ax.set_title(f"{t:.0f} s", fontsize=9)
        # axes in mm, as the paper's snapshots: a few ticks, small labels
        ax.locator_params(nbins=4)
        ax.tick_params(labelsize=7, length=2, pad=1)
        ax.set_xlabel("x (mm)", fontsize=7, labelpad=1)
        ax.set_ylabel("y (mm)" if i == 0 else "", fontsize=7, labelpad=1)
    fig.tight_layout()
    return fig
