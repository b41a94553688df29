"""Speed, energy, heading and steering-angle rate from positions, with messy data counted.

Input: the trajectory format (:mod:`thermoswarm.tracks`).  Output: an
:class:`xarray.Dataset` on ``(time, individuals)``, one row per *step*:

=================  ==========  =====================================================
variable           unit        meaning of row ``k``
=================  ==========  =====================================================
``dt``             s           duration of step ``k``: ``t[k+1] - t[k]``
``speed``          mm/s        ``|x[k+1] - x[k]| / dt[k]``
``energy``         mm^2/s^2    ``speed^2 / 2`` per unit mass, or ``m v^2 / 2`` in J
                               with ``mass`` (kg)
``heading``        rad         direction of step ``k``, ``atan2(dy, dx)`` in (-pi, pi]
``steering_rate``  rad/s       turn from step ``k-1`` to step ``k``, wrapped into
                               [-pi, pi), divided by the time between the steps'
                               midpoints ``(dt[k-1] + dt[k]) / 2``
``x_mid, y_mid``   mm          midpoint of step ``k`` (where regions are looked up)
``valid``          bool        the step's speed and energy are usable
``steering_valid`` bool        the steering rate is usable
``stationary``     bool        the step is part of a long stationary period
=================  ==========  =====================================================

The turn at row ``k`` is paired with the speed of the step that follows it (the
robots' algorithms sample a heading and a speed together, then turn and move), so
binning steering rates by ``energy`` uses the same row.  Velocities are differences of
consecutive (optionally smoothed) positions, not central differences: a central
difference averages two steps and would change the very distribution under test.

Messy data, each handled one way and counted in ``attrs`` (and in ``fits.json`` under
``data_quality``; see ``docs/analysis.md`` for every key):

- missing timestamps (NaN): the rows are dropped (``n_missing_timestamps``);
- decreasing timestamps: rows are sorted by time, stably (``n_decreasing_timestamps``
  counts the backward steps);
- repeated timestamps: rows with equal times are merged into one whose position is the
  mean of the rows' present positions (``n_repeated_timestamps`` rows merged);
- irregular steps: every step uses its own ``dt`` (``n_irregular_steps`` differ from
  the median step by more than 1 %);
- time gaps: a step longer than ``gap_factor`` median steps gives an average, not an
  instantaneous, velocity; it is not used (``n_time_gaps``);
- missing positions (NaN, inf, or ``confidence < min_confidence``): steps touching
  them are not used (``n_missing_positions``, ``n_gaps`` runs inside tracks);
  ``max_gap`` seconds bridges shorter gaps by linear interpolation
  (``n_interpolated_positions``);
- implausible speeds above ``max_speed``: not used (``n_steps_over_max_speed``);
- heading undefined at (near) zero speed: heading is NaN when ``speed <= min_speed``
  (``n_zero_speed``) and so are the steering rates on either side
  (``n_steering_undefined``);
- turns of nearly half a circle between two frames are ambiguous (the wrap cannot
  tell left from right): counted (``n_steering_near_wrap``);
- long stationary periods: runs of steps with ``speed <= stationary_speed`` lasting at
  least ``stationary_duration`` s are flagged (``n_stationary_periods``,
  ``n_stationary_steps``, ``stationary_seconds``) and, with ``drop_stationary``, not
  used for energies.

Smoothing (``smooth`` seconds) applies a Savitzky-Golay filter
(:func:`scipy.signal.savgol_filter`, ``polyorder``) to the positions of each
contiguous segment, the window being the odd number of samples nearest to ``smooth``
s; irregularly sampled segments are interpolated onto a regular grid at the median
step, filtered and interpolated back; segments shorter than the window get the
largest odd window that fits, and segments too short for any are left as they are
(``n_segments_unsmoothed``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr
from scipy.signal import savgol_filter

from thermoswarm.errors import ConfigError, InputError
from thermoswarm.tracks import centroid, times_seconds, validate_tracks

__all__ = ["compute_kinematics", "DATA_QUALITY_KEYS"]

#: The counters written to ``attrs`` and ``fits.json["data_quality"]``, in order.
DATA_QUALITY_KEYS = (
    "n_individuals",
    "n_times_input",
    "n_times",
    "n_position_samples",
    "n_missing_timestamps",
    "n_decreasing_timestamps",
    "n_repeated_timestamps",
    "median_dt",
    "n_irregular_steps",
    "n_time_gaps",
    "n_nonfinite_positions",
    "n_low_confidence",
    "n_missing_positions",
    "n_gaps",
    "n_interpolated_positions",
    "n_segments",
    "n_segments_smoothed",
    "n_segments_resampled",
    "n_segments_unsmoothed",
    "smooth_window_samples",
    "n_steps",
    "n_steps_missing_position",
    "n_steps_over_time_gap",
    "n_steps_over_max_speed",
    "n_steps_valid",
    "n_zero_speed",
    "n_steering_samples",
    "n_steering_undefined",
    "n_steering_near_wrap",
    "n_stationary_periods",
    "n_stationary_steps",
    "stationary_seconds",
    "n_steps_dropped_stationary",
)


def _check_param(name: str, value: Any, *, positive: bool = False, allow_none: bool = True):
    if value is None:
        if allow_none:
            return None
        raise ConfigError(f"{name} must be a number, got None")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v) or v < 0 or (positive and v == 0):
        kind = "a positive number" if positive else "a non-negative number"
        raise ConfigError(f"{name} must be {kind}, got {value!r}")
    return v


def _clean_times(t: np.ndarray, x: np.ndarray, y: np.ndarray, counts: dict[str, Any]):
    """Drop NaN times, sort, merge repeated times (mean of present positions).

    Also returns, for each kept row, the index of its first input row.
    """
    rows = np.arange(t.size)
    ok = np.isfinite(t)
    counts["n_missing_timestamps"] = int((~ok).sum())
    if not ok.all():
        t, x, y, rows = t[ok], x[ok], y[ok], rows[ok]
    back = np.diff(t) < 0
    counts["n_decreasing_timestamps"] = int(back.sum())
    if back.any():
        order = np.argsort(t, kind="stable")
        t, x, y, rows = t[order], x[order], y[order], rows[order]
    uniq, start = np.unique(t, return_index=True)
    counts["n_repeated_timestamps"] = int(t.size - uniq.size)
    if uniq.size < t.size:
        present = np.isfinite(x) & np.isfinite(y)
        n = np.add.reduceat(present.astype(np.int64), start, axis=0)
        sx = np.add.reduceat(np.where(present, x, 0.0), start, axis=0)
        sy = np.add.reduceat(np.where(present, y, 0.0), start, axis=0)
        with np.errstate(invalid="ignore", divide="ignore"):
            x = np.where(n > 0, sx / n, np.nan)
            y = np.where(n > 0, sy / n, np.nan)
        t = uniq
        rows = rows[start]
    return t, x, y, rows


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Runs of True along axis 0 of ``mask (time, individuals)``.

    Returns ``(individual, start, stop)`` arrays (``stop`` exclusive), ordered by
    individual then time.
    """
    n_t, n_i = mask.shape
    padded = np.zeros((n_i, n_t + 2), dtype=np.int8)
    padded[:, 1:-1] = mask.T
    d = np.diff(padded, axis=1)
    si, st = np.nonzero(d == 1)
    _, en = np.nonzero(d == -1)
    return si, st, en


def _interpolate_gaps(t, x, y, max_gap, counts):
    """Fill NaN runs inside tracks lasting at most ``max_gap`` s (linear in time)."""
    present = np.isfinite(x) & np.isfinite(y)
    n_t = t.size
    idx = np.arange(n_t)[:, None]
    prev = np.maximum.accumulate(np.where(present, idx, -1), axis=0)
    nxt = np.minimum.accumulate(np.where(present, idx, n_t)[::-1], axis=0)[::-1]
    inside = ~present & (prev >= 0) & (nxt < n_t)
    pc = np.clip(prev, 0, n_t - 1)
    nc = np.clip(nxt, 0, n_t - 1)
    fill = inside & (t[nc] - t[pc] <= max_gap)
    if fill.any():
        w = np.where(fill, (t[:, None] - t[pc]) / np.where(fill, t[nc] - t[pc], 1.0), 0.0)
        cols = np.broadcast_to(np.arange(x.shape[1]), x.shape)
        xi = x[pc, cols] + w * (x[nc, cols] - x[pc, cols])
        yi = y[pc, cols] + w * (y[nc, cols] - y[pc, cols])
        x = np.where(fill, xi, x)
        y = np.where(fill, yi, y)
    counts["n_interpolated_positions"] = int(fill.sum())
    return x, y


def _savgol(v: np.ndarray, window: int, polyorder: int) -> np.ndarray:
    return savgol_filter(v, window, polyorder, axis=0, mode="interp")


def _smooth(t, x, y, gap_step, smooth, polyorder, counts):
    """Savitzky-Golay smoothing of positions, segment by segment."""
    dt = np.diff(t)
    med = float(np.median(dt))
    window = int(round(smooth / med))
    if window % 2 == 0:
        window += 1
    if window <= polyorder:
        raise ConfigError(
            f"smoothing window {smooth:g} s is {window} samples at the median step "
            f"{med:g} s; it must exceed polyorder {polyorder}"
        )
    counts["smooth_window_samples"] = window
    present = np.isfinite(x) & np.isfinite(y)
    # A segment: present samples joined by steps that are not time gaps.
    link = present[:-1] & present[1:] & ~gap_step[:, None]
    start_new = np.ones_like(present)
    start_new[1:] = ~link
    seg_mask = present
    si, st, en = _runs(seg_mask)
    # split runs at time gaps
    segments = []
    for i, s, e in zip(si.tolist(), st.tolist(), en.tolist(), strict=True):
        cuts = np.nonzero(start_new[s + 1 : e, i])[0] + s + 1
        bounds = [s, *cuts.tolist(), e]
        segments.extend((i, a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True))
    counts["n_segments"] = len(segments)
    irregular = np.abs(dt - med) > 0.01 * med
    xs = x.copy()
    ys = y.copy()
    n_sm = n_rs = n_un = 0
    full = len(segments) == x.shape[1] and all(a == 0 and b == t.size for _, a, b in segments)
    if full and not irregular.any() and t.size >= window:
        counts.update(
            n_segments_smoothed=len(segments), n_segments_resampled=0, n_segments_unsmoothed=0
        )
        return _savgol(x, window, polyorder), _savgol(y, window, polyorder)
    for i, a, b in segments:
        length = b - a
        w = window if length >= window else (length if length % 2 else length - 1)
        if w <= polyorder:
            n_un += 1
            continue
        if irregular[a : b - 1].any():
            tt = t[a:b]
            n_grid = int(round((tt[-1] - tt[0]) / med)) + 1
            grid = np.linspace(tt[0], tt[-1], n_grid)  # about the median step, ends kept
            w = window if n_grid >= window else (n_grid if n_grid % 2 else n_grid - 1)
            if w <= polyorder:
                n_un += 1
                continue
            gx = _savgol(np.interp(grid, tt, x[a:b, i]), w, polyorder)
            gy = _savgol(np.interp(grid, tt, y[a:b, i]), w, polyorder)
            xs[a:b, i] = np.interp(tt, grid, gx)
            ys[a:b, i] = np.interp(tt, grid, gy)
            n_rs += 1
        else:
            xs[a:b, i] = _savgol(x[a:b, i], w, polyorder)
            ys[a:b, i] = _savgol(y[a:b, i], w, polyorder)
        n_sm += 1
    counts.update(n_segments_smoothed=n_sm, n_segments_resampled=n_rs, n_segments_unsmoothed=n_un)
    return xs, ys


def compute_kinematics(
    ds: xr.Dataset,
    *,
    fps: float | None = None,
    keypoint: str | None = None,
    smooth: float | None = None,
    polyorder: int = 2,
    mass: float | None = None,
    min_speed: float = 0.0,
    max_speed: float | None = None,
    gap_factor: float = 2.0,
    max_gap: float = 0.0,
    stationary_speed: float | None = None,
    stationary_duration: float = 1.0,
    drop_stationary: bool = False,
    min_confidence: float | None = None,
) -> xr.Dataset:
    """Kinematics of every step of every track.

    Parameters
    ----------
    ds
        Trajectories (positions in mm).
    fps
        Frame rate, needed when the time coordinate holds frame numbers.
    keypoint
        Keypoint to follow; default the centroid (:func:`thermoswarm.tracks.centroid`).
    smooth
        Savitzky-Golay window in seconds (``None``: no smoothing).
    polyorder
        Savitzky-Golay polynomial order.
    mass
        Mass in kg: energies ``m v^2 / 2`` in joules.  Default: per unit mass,
        ``v^2 / 2`` in mm^2/s^2.
    min_speed
        Heading is undefined for steps with ``speed <= min_speed`` (mm/s).
    max_speed
        Steps faster than this (mm/s) are discarded as tracking errors.
    gap_factor
        Steps longer than ``gap_factor`` times the median step are gaps.
    max_gap
        Missing-position gaps up to this long (s) are linearly interpolated.
    stationary_speed, stationary_duration
        A long stationary period: at least ``stationary_duration`` s of steps with
        ``speed <= stationary_speed`` (mm/s; default ``min_speed``).
    drop_stationary
        Exclude steps of long stationary periods from the energies.
    min_confidence
        Positions whose ``confidence`` is below this are treated as missing.

    Returns
    -------
    xarray.Dataset
        See the module docstring; the counts are in ``attrs``.
    """
    ds = validate_tracks(ds, source=ds.attrs.get("source_file"))
    smooth = _check_param("smooth", smooth, positive=True)
    mass = _check_param("mass", mass, positive=True)
    min_speed = _check_param("min_speed", min_speed, allow_none=False)
    max_speed = _check_param("max_speed", max_speed, positive=True)
    gap_factor = _check_param("gap_factor", gap_factor, positive=True, allow_none=False)
    max_gap = _check_param("max_gap", max_gap, allow_none=False)
    stationary_speed = _check_param("stationary_speed", stationary_speed)
    stationary_duration = _check_param(
        "stationary_duration", stationary_duration, allow_none=False
    )
    min_confidence = _check_param("min_confidence", min_confidence)
    if int(polyorder) != polyorder or polyorder < 1:
        raise ConfigError(f"polyorder must be an integer >= 1, got {polyorder!r}")
    if gap_factor < 1:
        raise ConfigError(f"gap_factor must be at least 1, got {gap_factor!r}")
    if stationary_speed is None:
        stationary_speed = min_speed

    counts: dict[str, Any] = dict.fromkeys(DATA_QUALITY_KEYS, 0)
    position = ds["position"]
    if min_confidence is not None and "confidence" in ds:
        low = (ds["confidence"] < min_confidence).values
        counts["n_low_confidence"] = int((low & np.isfinite(position.values).all(axis=1)).sum())
        position = position.where(~(ds["confidence"] < min_confidence))
    if keypoint is not None:
        kps = [str(k) for k in ds["keypoints"].values]
        if keypoint not in kps:
            raise InputError(f"keypoint {keypoint!r} not in the data; it has {kps}")
        pos = position.sel(keypoints=keypoint, drop=True)
    else:
        pos = centroid(ds.assign(position=position))
    pos = pos.transpose("time", "space", "individuals")
    t = times_seconds(ds, fps)
    x = np.asarray(pos.sel(space="x").values, dtype=np.float64)
    y = np.asarray(pos.sel(space="y").values, dtype=np.float64)
    n_i = x.shape[1]
    counts["n_individuals"] = n_i
    counts["n_times_input"] = int(t.size)
    counts["n_position_samples"] = int(t.size * n_i)
    nonfinite = (np.isinf(x) | np.isinf(y)) & ~(np.isnan(x) | np.isnan(y))
    counts["n_nonfinite_positions"] = int(nonfinite.sum())
    if nonfinite.any():
        x = np.where(nonfinite, np.nan, x)
        y = np.where(nonfinite, np.nan, y)
    t, x, y, input_rows = _clean_times(t, x, y, counts)
    n_t = t.size
    counts["n_times"] = int(n_t)
    if n_t < 2:
        src = ds.attrs.get("source_file", "the input")
        raise InputError(f"{src}: need at least 2 distinct time samples, got {n_t}")

    dt = np.diff(t)
    med = float(np.median(dt))
    counts["median_dt"] = med
    counts["n_irregular_steps"] = int((np.abs(dt - med) > 0.01 * med).sum())
    gap_step = dt > gap_factor * med
    counts["n_time_gaps"] = int(gap_step.sum())

    present = np.isfinite(x) & np.isfinite(y)
    holes = ~present
    # NaN runs strictly inside a track (between two present samples)
    idx = np.arange(n_t)[:, None]
    seen_before = np.maximum.accumulate(np.where(present, idx, -1), axis=0) >= 0
    seen_after = np.minimum.accumulate(np.where(present, idx, n_t)[::-1], axis=0)[::-1] < n_t
    inner = holes & seen_before & seen_after
    counts["n_missing_positions"] = int(holes.sum())
    counts["n_gaps"] = int(_runs(inner)[0].size)
    if max_gap > 0:
        x, y = _interpolate_gaps(t, x, y, max_gap, counts)
        present = np.isfinite(x) & np.isfinite(y)

    if smooth is not None:
        x, y = _smooth(t, x, y, gap_step, smooth, int(polyorder), counts)
    else:
        si, _, _ = _runs(present)
        counts["n_segments"] = int(si.size)  # refined below by time gaps
        counts["n_segments"] += int((present[:-1] & present[1:] & gap_step[:, None]).sum())

    # Steps
    dx = np.diff(x, axis=0)
    dy = np.diff(y, axis=0)
    both = present[:-1] & present[1:]
    counts["n_steps"] = int(both.sum())
    counts["n_steps_missing_position"] = int((~both).sum())
    counts["n_steps_over_time_gap"] = int((both & gap_step[:, None]).sum())
    ok = both & ~gap_step[:, None]
    with np.errstate(invalid="ignore"):
        speed_s = np.hypot(dx, dy) / dt[:, None]
    if max_speed is not None:
        fast = ok & (speed_s > max_speed)
        counts["n_steps_over_max_speed"] = int(fast.sum())
        ok &= ~fast
    speed_s = np.where(ok, speed_s, np.nan)

    # Long stationary periods
    still = ok & (speed_s <= stationary_speed)
    si, st, en = _runs(still)
    if si.size:
        dur = t[en] - t[st]
        long_ = dur >= stationary_duration
        counts["n_stationary_periods"] = int(long_.sum())
        counts["stationary_seconds"] = float(dur[long_].sum())
        stationary = np.zeros_like(still)
        for i, a, b in zip(
            si[long_].tolist(), st[long_].tolist(), en[long_].tolist(), strict=True
        ):
            stationary[a:b, i] = True
        counts["n_stationary_steps"] = int(stationary.sum())
    else:
        stationary = np.zeros_like(still)
    valid = ok.copy()
    if drop_stationary:
        valid &= ~stationary
        counts["n_steps_dropped_stationary"] = int(stationary.sum())
    counts["n_steps_valid"] = int(valid.sum())

    moving = ok & (speed_s > min_speed)
    counts["n_zero_speed"] = int((ok & ~moving).sum())
    heading_s = np.where(moving, np.arctan2(dy, dx), np.nan)
    # Turns: between step k-1 and step k, both usable, divided by the midpoint spacing.
    dh = heading_s[1:] - heading_s[:-1]
    dh = (dh + np.pi) % (2 * np.pi) - np.pi
    mid_dt = 0.5 * (dt[:-1] + dt[1:])
    steer_ok = moving[:-1] & moving[1:]
    counts["n_steering_samples"] = int(steer_ok.sum())
    counts["n_steering_undefined"] = int((ok[:-1] & ok[1:] & ~steer_ok).sum())
    counts["n_steering_near_wrap"] = int((steer_ok & (np.abs(dh) > 0.9 * np.pi)).sum())
    rate_s = np.where(steer_ok, dh / mid_dt[:, None], np.nan)

    def on_rows(a: np.ndarray, fill: Any, first: bool = False) -> np.ndarray:
        out = np.full((n_t, n_i), fill, dtype=a.dtype)
        if first:
            out[1:-1] = a
        else:
            out[:-1] = a
        return out

    speed = on_rows(speed_s, np.nan)
    if mass is None:
        energy = 0.5 * speed * speed
        e_unit = "mm^2/s^2"
    else:
        energy = 0.5 * mass * (speed * 1e-3) ** 2
        e_unit = "J"
    energy = np.where(on_rows(valid, False), energy, np.nan)
    dims = ("time", "individuals")
    out = xr.Dataset(
        {
            "dt": (("time",), np.append(dt, np.nan), {"units": "s"}),
            "speed": (dims, speed, {"units": "mm/s"}),
            "energy": (dims, energy, {"units": e_unit}),
            "heading": (dims, on_rows(heading_s, np.nan), {"units": "rad"}),
            "steering_rate": (dims, on_rows(rate_s, np.nan, first=True), {"units": "rad/s"}),
            "x_mid": (dims, on_rows(0.5 * (x[:-1] + x[1:]), np.nan), {"units": "mm"}),
            "y_mid": (dims, on_rows(0.5 * (y[:-1] + y[1:]), np.nan), {"units": "mm"}),
            "valid": (dims, on_rows(valid, False)),
            "steering_valid": (dims, on_rows(steer_ok, False, first=True)),
            "stationary": (dims, on_rows(stationary, False)),
        },
        coords={
            "time": t,
            "individuals": ds["individuals"].values,
            "input_row": ("time", input_rows),
        },
    )
    out["time"].attrs.update(units="s", convention="start of the step")
    out["input_row"].attrs.update(description="index of the (first) input row of this time")
    params = {
        "energy_unit": e_unit,
        "mass_kg": mass,
        "smooth_s": smooth,
        "polyorder": int(polyorder) if smooth is not None else None,
        "min_speed": min_speed,
        "max_speed": max_speed,
        "gap_factor": gap_factor,
        "max_gap_s": max_gap,
        "stationary_speed": stationary_speed,
        "stationary_duration_s": stationary_duration,
        "drop_stationary": int(bool(drop_stationary)),
        "min_confidence": min_confidence,
        "keypoint": keypoint,
        "source_file": ds.attrs.get("source_file"),
        "source_software": ds.attrs.get("source_software"),
    }
    out.attrs.update({k: v for k, v in params.items() if v is not None})
    out.attrs.update(counts)
    return out


def data_quality(kin: xr.Dataset) -> dict[str, Any]:
    """The data-quality counts of a kinematics dataset, as a plain dict."""
    out = {}
    for k in DATA_QUALITY_KEYS:
        v = kin.attrs.get(k, 0)
        out[k] = float(v) if isinstance(v, float | np.floating) else int(v)
    return out
