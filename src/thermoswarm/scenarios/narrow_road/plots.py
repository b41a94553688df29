"""Drawing ``narrow-road``: a frame of the road and its robots, and the flow over time."""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
import xarray as xr

from thermoswarm.scenarios.narrow_road.geometry import RoadGeometry
from thermoswarm.scenarios.narrow_road.params import DIRECTIONS

__all__ = ["plot_frame", "plot_flow"]


def plot_frame(
    ax: Any,
    tracks: xr.Dataset,
    t: float,
    setup_info: dict[str, Any] | RoadGeometry,
    *,
    color_by: Literal["group", "speed"] = "group",
    cmap: str = "viridis",
) -> Any:
    """Draw the road and the robots at the recorded frame nearest ``t`` (s) on ``ax``.

    ``setup_info`` is ``metrics["road"]["geometry"]`` (or a :class:`RoadGeometry`).
    Robots are discs coloured by direction (``color_by="group"``: +x blue, -x orange) or
    by commanded speed; robots waiting off the road are not drawn but counted in the
    title.  Returns the collection of robot discs.
    """
    from matplotlib.collections import EllipseCollection, LineCollection

    info = setup_info.info() if isinstance(setup_info, RoadGeometry) else setup_info
    k = int(np.argmin(np.abs(tracks["time"].values - t)))
    fr = tracks.isel(time=k)
    pos = fr["position"].isel(keypoints=0).transpose("individuals", "space").values
    on = fr["section"].values >= 0 if "section" in fr else np.ones(pos.shape[0], bool)
    seg = np.asarray(info["segments"])
    ax.add_collection(LineCollection(seg.reshape(-1, 2, 2), colors="k", linewidths=1.5))
    r = float(info["radius"])
    for x in info["edges"][1:-1]:
        ax.axvline(x, color="0.8", lw=0.8, ls=":", zorder=0)
    d = np.full(int(on.sum()), 2 * r)
    coll = EllipseCollection(
        d, d, np.zeros_like(d), units="xy", offsets=pos[on], offset_transform=ax.transData
    )
    if color_by == "speed":
        coll.set_array(fr["speed"].values[on].astype(float))
        coll.set_cmap(cmap)
    else:
        g = fr["group"].values[on] if "group" in fr else np.zeros(int(on.sum()))
        coll.set_facecolor(np.where(g[:, None] == 0, [[0.12, 0.47, 0.71, 1]], [[1, 0.5, 0.05, 1]]))
    coll.set_edgecolor("k")
    coll.set_linewidth(0.5)
    ax.add_collection(coll)
    L = float(info["length"])
    wmax = max(info["widths"])
    ax.set_xlim(-0.05 * L, 1.05 * L)
    ax.set_ylim(-0.6 * wmax - 5, 0.6 * wmax + 5)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    waiting = int((~on).sum())
    title = f"t = {float(tracks['time'].values[k]):.0f} s"
    if waiting:
        title += f" ({waiting} waiting off the road)"
    ax.set_title(title)
    return coll


def plot_flow(ax: Any, metrics: dict[str, Any]) -> None:
    """Crossings per minute per direction over time (``metrics["flow_over_time"]``).

    One step per whole bin, drawn over the bin; the seconds after the last whole bin
    (``unbinned_tail_s``) are shaded and not drawn as a rate.
    """
    f = metrics["flow_over_time"]
    bin_s = float(f["bin_s"])
    starts = np.asarray(f["t_start"], dtype=float)
    edges = np.append(starts, starts[-1] + bin_s) if starts.size else np.zeros(1)
    for d in DIRECTIONS:
        label = f"{d} ({metrics['flow_per_direction'][d]:.2f}/min)"
        ax.stairs(np.asarray(f[d], dtype=float), edges, label=label, baseline=None)
    tail = float(f.get("unbinned_tail_s", 0.0) or 0.0)
    if tail > 0:
        ax.axvspan(edges[-1], edges[-1] + tail, color="0.85", lw=0,
                   label=f"last {tail:.0f} s: not a whole bin")  # fmt: skip
    ax.set_xlim(0.0, edges[-1] + tail)
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"crossings per minute ({bin_s:g} s bins)")
    ax.legend(
        fontsize="small", loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=3, frameon=False
    )
