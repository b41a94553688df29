"""The viewer's page: one HTML file with its script inline, served or self-contained.

:func:`page_html` gives the page the server sends (frames fetched on demand).
:func:`write_html` writes the same page with every frame embedded as base64 float32
(and, for ``track`` outputs, every video frame as JPEG): one file that works from disk
with no server and can be mailed.  It is meant for small data; above ``max_bytes`` it
refuses with a one-line error rather than write a file a browser cannot open.
"""

from __future__ import annotations

import base64
import os
from importlib import resources
from pathlib import Path

import numpy as np

from thermoswarm.errors import InputError
from thermoswarm.fsutil import atomic_write_text
from thermoswarm.view.data import ViewData, to_json

__all__ = ["page_html", "write_html"]


def _asset(name: str) -> str:
    return resources.files(__package__).joinpath(name).read_text(encoding="utf-8")


def page_html(embed: dict | None = None) -> str:
    """The page; with ``embed`` (meta, pos, vars, video), a self-contained one."""
    html = _asset("viewer.html")
    data = ""
    if embed is not None:
        # "</" cannot end the script element early: JSON escapes it as "<\/".
        data = "window.__EMBED__ = " + to_json(embed).replace("</", "<\\/") + ";"
    script = _asset("viewer.js")
    return html.replace("/*__DATA__*/", data, 1).replace("/*__SCRIPT__*/", script, 1)


def _b64(a: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype="<f4").tobytes()).decode("ascii")


def write_html(data: ViewData, out: str | os.PathLike, *, max_bytes: int = 200_000_000) -> Path:
    """Write the self-contained viewer of ``data`` to ``out`` (atomically).

    Parameters
    ----------
    data
        What to show (:func:`~thermoswarm.view.data.open_source`).
    out
        The ``.html`` file to write; its folder must exist.
    max_bytes
        Largest file written (bytes); more data is an :class:`InputError`.
    """
    out = Path(out)
    if not out.absolute().parent.is_dir():
        raise InputError(f"{out}: parent directory does not exist")
    names = data.variables()
    per_frame = 4 * data.n * (2 * len(data.keypoints) + len(names)) * 4 / 3
    video_each = 60_000 if data.video is not None else 0
    estimate = data.n_frames * (per_frame + video_each)
    if estimate > max_bytes:
        raise InputError(
            f"{data.title}: about {estimate / 1e6:.0f} MB of frames, too many for one HTML "
            f"file (limit {max_bytes / 1e6:.0f} MB); use `thermoswarm view` without --out, "
            "which streams frames"
        )
    meta = data.meta()
    meta["notes"] = [n for n in meta["notes"] if "still being written" not in n]
    if not data.complete:
        meta["notes"].append(f"a run being written: the {data.n_frames} frames committed so far")
    meta["complete"] = True
    pos = []
    for k in range(data.n_frames):
        p = data.ds["position"].isel(time=k).transpose("keypoints", "space", "individuals")
        pos.append(_b64(np.asarray(p.values, dtype=np.float64) * data.scale))
    values = {v: [_b64(data.values(k, v)) for k in range(data.n_frames)] for v in names}
    embed = {"meta": meta, "pos": pos, "vars": values}
    if data.video is not None:
        embed["video"] = [
            base64.b64encode(data.video.jpeg(k, quality=70)).decode("ascii")
            for k in range(data.n_frames)
        ]
    atomic_write_text(out, page_html(embed))
    return out
