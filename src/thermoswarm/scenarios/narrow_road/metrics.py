"""``narrow-road``'s metric functions: pure, on event times (s) and recorded tracks.

Speeds mm/s, energies ``v^2 / 2`` mm^2/s^2 per unit mass.  The keys they produce are
listed in ``docs/scenarios_road_compression.md``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.scenarios.narrow_road.params import DIRECTIONS

__all__ = ["longest_gap", "flow_series", "section_samples", "section_stats", "SE_BLOCKS"]


def longest_gap(times: np.ndarray, start: float, end: float) -> float:
    """Longest interval (s) in ``[start, end]`` containing none of ``times``."""
    t = np.sort(np.asarray(times, dtype=float).ravel())
    t = t[(t >= start) & (t <= end)]
    return float(np.diff(np.concatenate([[start], t, [end]])).max())


def flow_series(times: np.ndarray, duration: float, bin_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Crossings per minute in the whole bins of ``bin_s`` seconds that fit in ``[0, duration]``.

    Bins are half-open, ``[k bin_s, (k + 1) bin_s)``.  Only whole bins are returned: a
    last, partial bin (the ``duration mod bin_s`` seconds at the end) would be a rate
    over a few seconds, a spike or a drop that is noise, so its crossings are left out
    here (they still count in the totals).  A run shorter than one bin has no bins.

    Returns ``(bin_starts, flow)`` in s and crossings per minute.
    """
    n_bins = int(math.floor(duration / bin_s + 1e-9)) if duration > 0 else 0
    starts = np.arange(n_bins, dtype=float) * bin_s
    t = np.asarray(times, dtype=float).ravel()
    t = t[np.isfinite(t) & (t >= 0)]
    k = np.floor(t / bin_s).astype(np.int64)
    counts = np.bincount(k[k < n_bins], minlength=n_bins)
    return starts, counts * 60.0 / bin_s


def _summary(values: np.ndarray) -> dict[str, Any]:
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {"n": 0}
    q = np.quantile(v, [0.1, 0.5, 0.9])
    return {
        "n": int(v.size),
        "mean": float(v.mean()),
        "std": float(v.std(ddof=1)) if v.size > 1 else 0.0,
        "p10": float(q[0]),
        "median": float(q[1]),
        "p90": float(q[2]),
        "max": float(v.max()),
    }


def section_samples(tracks: xr.Dataset) -> dict[str, np.ndarray]:
    """Measured speed samples with their section, direction and time.

    The speed of a robot between consecutive frames is its displacement over the frame
    interval (mm/s), attributed to the section of the first frame; pairs that span a
    re-entry (``lap`` changes) or a wait off the road (``section`` -1) are dropped.

    Returns arrays ``time`` (s, first frame), ``id``, ``group``, ``section``, ``speed``
    (mm/s) and ``energy`` (``v^2 / 2``, mm^2/s^2), one entry per sample.
    """
    pos = tracks["position"].isel(keypoints=0).transpose("time", "space", "individuals").values
    t = tracks["time"].values.astype(float)
    sec = tracks["section"].values
    lap = tracks["lap"].values
    grp = tracks["group"].values
    if t.size < 2:
        empty = np.zeros(0)
        return {k: empty for k in ("time", "id", "group", "section", "speed", "energy")}
    dt = np.diff(t)[:, None]
    disp = np.hypot(pos[1:, 0] - pos[:-1, 0], pos[1:, 1] - pos[:-1, 1])
    v = disp / dt
    ok = (lap[1:] == lap[:-1]) & (sec[:-1] >= 0) & (sec[1:] >= 0) & np.isfinite(v)
    ti, ii = np.nonzero(ok)
    vv = v[ti, ii]
    return {
        "time": t[ti],
        "id": ii,
        "group": grp[ti, ii].astype(int),
        "section": sec[ti, ii].astype(int),
        "speed": vv,
        "energy": 0.5 * vv**2,
    }


def section_stats(
    tracks: xr.Dataset, names: tuple[str, ...] | list[str], areas: np.ndarray
) -> dict[str, Any]:
    """Per-section occupancy and speed/energy statistics (keys: ``metrics["sections"]``)."""
    s = section_samples(tracks)
    sec_all = tracks["section"].values
    cmd = tracks["speed"].values.astype(float)
    grp_all = tracks["group"].values
    t_all = np.broadcast_to(tracks["time"].values.astype(float)[:, None], sec_all.shape)
    nframes = max(sec_all.shape[0], 1)
    span = (float(t_all[0, 0]), float(t_all[-1, 0])) if sec_all.size else (0.0, 0.0)
    out: dict[str, Any] = {}
    for k, name in enumerate(names):
        here = s["section"] == k
        occ = float((sec_all == k).sum()) / nframes
        entry: dict[str, Any] = {
            "occupancy_mean": occ,
            "density_per_mm2": occ / float(areas[k]),
            "measured": _speed_energy(s["speed"][here], s["time"][here], span),
            "commanded": _speed_energy(cmd[sec_all == k], t_all[sec_all == k], span),
            "by_direction": {},
        }
        for g, d in enumerate(DIRECTIONS):
            sel = here & (s["group"] == g)
            sel_all = (sec_all == k) & (grp_all == g)
            entry["by_direction"][d] = {
                "measured": _speed_energy(s["speed"][sel], s["time"][sel], span),
                "commanded": _speed_energy(cmd[sel_all], t_all[sel_all], span),
            }
        out[name] = entry
    return out


#: Time blocks for the standard error of per-section energies.
SE_BLOCKS = 20


def _speed_energy(v: np.ndarray, t: np.ndarray, span: tuple[float, float]) -> dict[str, Any]:
    """Speed and energy statistics of samples ``v`` (mm/s) taken at times ``t`` (s).

    ``energy_se`` comes from the means of :data:`SE_BLOCKS` equal time blocks over
    ``span`` (samples a fraction of a control period apart are not independent); null
    with fewer than 2 blocks holding samples.
    """
    v = np.asarray(v, dtype=float)
    t = np.asarray(t, dtype=float)
    ok = np.isfinite(v)
    v, t = v[ok], t[ok]
    if v.size == 0:
        return {"n": 0}
    e = 0.5 * v**2
    edges = np.linspace(span[0], span[1], SE_BLOCKS + 1)
    blk = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, SE_BLOCKS - 1)
    cnt = np.bincount(blk, minlength=SE_BLOCKS)
    sums = np.bincount(blk, weights=e, minlength=SE_BLOCKS)
    means = sums[cnt > 0] / cnt[cnt > 0]
    se = float(means.std(ddof=1) / math.sqrt(means.size)) if means.size > 1 else None
    return {
        "n": int(v.size),
        "speed_mean": float(v.mean()),
        "speed_std": float(v.std(ddof=1)) if v.size > 1 else 0.0,
        "energy_mean": float(e.mean()),
        "energy_se": se,
        "stopped_fraction": float(np.mean(v < 0.5)),
    }
