"""What ``transport-free`` measures and draws: the phases by light region over time, the
object's displacement metrics, the temperature a capped speed law should show, and one
frame of a run.

Private to :mod:`thermoswarm.scenarios.transport_free`, which re-exports every public
name; pure functions of arrays (the tests check them on constructed cases).  Units: mm,
s, temperatures mm^2/s^2.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.policy import PHASE_HOT
from thermoswarm.scenarios._transport import draw_world, nearest_frame, shadow_polygon

__all__ = [
    "REGIONS",
    "phase_by_region",
    "summarize_phase_by_region",
    "capped_temperature",
    "transport_metrics",
    "plot_frame",
]


#: Regions of :func:`phase_by_region`, and the keys of its per-frame series.
REGIONS = ("lit", "shadow")


def phase_by_region(
    times: np.ndarray,
    positions: np.ndarray,
    phases: np.ndarray,
    lit: Any,
    grid_points: np.ndarray,
    grid_cell_area: float,
    grid_lit: Any,
) -> dict[str, Any]:
    """Phase separation over time: the robots of each phase in each light region.

    Parameters
    ----------
    times : (k,) s
    positions : (k, n, 2) mm
        Robot centres per frame.
    phases : (k, n)
        1 hot (gas-like), 0 cold (liquid-like).
    lit : callable ``(frame, points (m, 2)) -> bool (m,)``
        Whether points are lit (light level above the threshold, no sensor noise) in
        that frame (the object's shadow moves with it).
    grid_points : (g, 2) mm
        A regular grid over the region robots' centres can reach (at the start), of cell
        area ``grid_cell_area`` (mm^2): the areas of the regions are counted on it.
    grid_lit : callable ``(frame, grid_points) -> (lit bool (g,), reachable bool (g,))``
        The grid's light and whether each cell is still reachable in that frame (the
        object covers some).

    Returns
    -------
    dict of lists (one value per frame): ``time``; for ``region`` in ``lit``/``shadow``:
    ``n_<region>`` (robots), ``area_<region>`` (m^2), ``hot_fraction_<region>`` (the
    share of that region's robots that are hot; None when it holds none) and
    ``density_<phase>_<region>`` (robots of that phase per m^2 of the region).
    """
    k = len(times)
    out: dict[str, Any] = {"time": [float(t) for t in times]}
    for reg in REGIONS:
        for key in ("n", "area", "hot_fraction", "density_hot", "density_cold"):
            out[f"{key}_{reg}"] = []
    for f in range(k):
        pos = np.asarray(positions[f], dtype=np.float64)
        hot = np.asarray(phases[f]) == PHASE_HOT
        is_lit = np.asarray(lit(f, pos), dtype=bool)
        g_lit, g_ok = grid_lit(f, grid_points)
        for reg, sel, gsel in (
            ("lit", is_lit, g_lit & g_ok),
            ("shadow", ~is_lit, ~g_lit & g_ok),
        ):
            n_reg = int(np.count_nonzero(sel))
            n_hot = int(np.count_nonzero(sel & hot))
            area = float(np.count_nonzero(gsel)) * grid_cell_area / 1e6  # m^2
            out[f"n_{reg}"].append(n_reg)
            out[f"area_{reg}"].append(area)
            out[f"hot_fraction_{reg}"].append(n_hot / n_reg if n_reg else None)
            out[f"density_hot_{reg}"].append(n_hot / area if area > 0 else None)
            out[f"density_cold_{reg}"].append((n_reg - n_hot) / area if area > 0 else None)
    return out


def summarize_phase_by_region(series: dict[str, Any], since: float) -> dict[str, Any]:
    """Time means of :func:`phase_by_region`'s series over frames at ``time >= since``
    (None entries skipped; None when there are none)."""
    t = np.asarray(series["time"], dtype=np.float64)
    keep = t >= since
    out: dict[str, Any] = {"since": float(since), "frames": int(np.count_nonzero(keep))}
    for key, vals in series.items():
        if key == "time":
            continue
        v = [x for x, ok in zip(vals, keep, strict=True) if ok and x is not None]
        out[key] = float(np.mean(v)) if v else None
    return out


def capped_temperature(kT: float, v_max: float | None) -> float:
    """``<v^2> / 2`` (mm^2/s^2) of Rayleigh speeds at temperature ``kT`` cut at ``v_max``:
    ``kT (1 - exp(-v_max^2 / (2 kT)))`` (``kT`` without a cut), what ``speed_by_phase``
    should measure."""
    if v_max is None:
        return float(kT)
    return float(kT * -math.expm1(-(v_max**2) / (2 * kT)))


def transport_metrics(
    times: np.ndarray, progress: np.ndarray, target_distance: float
) -> dict[str, Any]:
    """Displacement metrics of one run from the object's progress toward the target.

    Parameters
    ----------
    times : (k,) s
    progress : (k,) mm
        Displacement of the object's centre along the target direction since the start
        (``progress[0]`` is normally 0).
    target_distance : float
        Progress (mm) at which the object is at the target.

    Returns
    -------
    dict with ``displacement_toward_target`` (the last progress, mm),
    ``max_displacement_toward_target`` (mm), ``time_to_target`` (s, the first sample at
    or beyond the target, None if never) and ``mean_velocity_toward_target`` (mm/s, last
    progress over elapsed time).
    """
    t = np.asarray(times, dtype=np.float64)
    d = np.asarray(progress, dtype=np.float64)
    hit = np.flatnonzero(d >= target_distance)
    elapsed = float(t[-1] - t[0])
    return {
        "displacement_toward_target": float(d[-1]),
        "max_displacement_toward_target": float(d.max()),
        "time_to_target": None if hit.size == 0 else float(t[hit[0]]),
        "mean_velocity_toward_target": float(d[-1] / elapsed) if elapsed > 0 else None,
    }


def plot_frame(ax: Any, tracks: xr.Dataset, t: float, setup_info: dict[str, Any]) -> Any:
    """Draw the frame of ``tracks`` nearest to time ``t`` (s) on matplotlib axes ``ax``.

    Walls, obstacles, the target line (dashed green), the object's shadow (grey), the
    object (white disc) and the robots coloured by phase (red hot/gas-like, blue
    cold/liquid-like).  ``setup_info`` is ``Setup.info`` of the run (``runner.build``).
    Returns the robots' scatter artist.
    """
    from matplotlib.patches import Circle, Polygon

    k = nearest_frame(tracks, t)
    info = setup_info
    draw_world(ax, info)
    obj = np.asarray(tracks["object_position"].values[k], dtype=np.float64)
    R = float(info["object_radius"])
    shade = shadow_polygon(obj, R, info["light"], info["bounds"])
    if shade.size:
        ax.add_patch(Polygon(shade, closed=True, facecolor="0.85", edgecolor="none", zorder=0))
    for x, y, ro in np.asarray(info.get("shadow_obstacles", []), dtype=float).reshape(-1, 3):
        s = shadow_polygon((x, y), ro, info["light"], info["bounds"])
        ax.add_patch(Polygon(s, closed=True, facecolor="0.85", edgecolor="none", zorder=0))
    ax.add_patch(Circle(tuple(obj), R, facecolor="white", edgecolor="k", lw=1.2, zorder=5))
    pos = tracks["position"].values[k, :, 0, :]  # (space, individuals)
    phase = tracks["phase"].values[k]
    colors = np.where(phase == PHASE_HOT, "tab:red", "tab:blue")
    r = float(tracks.attrs.get("radius", 16.5))
    # marker size in points^2 so that discs have their true size in data units
    fig = ax.figure
    x0, y0, x1, y1 = info["bounds"]
    bbox = ax.get_window_extent().transformed(fig.dpi_scale_trans.inverted())
    pts_per_mm = bbox.width * 72.0 / max(x1 - x0 + 40.0, 1e-9)
    sc = ax.scatter(pos[0], pos[1], s=(2 * r * pts_per_mm) ** 2, c=colors, lw=0, zorder=3)
    ax.set_title(f"t = {float(tracks['time'].values[k]):.0f} s")
    return sc
