"""Speed, energy, heading and steering-angle rate from positions, with messy data counted.

Input: the trajectory format (:mod:`thermoswarm.tracks`), on a shared clock or with
each individual on its own clock.  Output: an :class:`xarray.Dataset` on
``(time, individuals)`` where row ``k`` of an individual is the *step* from its
``k``-th sample to its ``k+1``-th, computed from that individual's own consecutive
samples and their real time difference (see ``docs/analysis.md`` for every key):

=================  ==========  =====================================================
variable           unit        meaning of row ``k``
=================  ==========  =====================================================
``step_time``      s           time of the step's first sample
``dt``             s           duration of the step: ``t[k+1] - t[k]``
``speed``          mm/s        ``|x[k+1] - x[k]| / dt`` (NaN: not measured)
``energy``         mm^2/s^2    ``speed^2 / 2`` per unit mass, or ``m v^2 / 2`` in J
                               with ``mass`` (kg); only for steps used in the fits
``heading``        rad         direction of the step, ``atan2(dy, dx)`` in (-pi, pi]
``steering_rate``  rad/s       turn from step ``k-1`` to step ``k``, wrapped into
                               [-pi, pi), divided by the time between the steps'
                               midpoints ``(dt[k-1] + dt[k]) / 2``
``x_mid, y_mid``   mm          midpoint of the step (where regions are looked up)
``step_class``     code        the one bucket the step falls in (``STEP_CLASSES``)
``valid``          bool        the step is used (its energy enters the fits)
``steering_valid`` bool        the steering rate is usable
``stationary``     bool        the step is part of a long stationary period
``input_row``      index       the input row of the step's first sample (-1: none)
=================  ==========  =====================================================

On a shared clock the ``time`` coordinate holds the seconds; with per-individual
clocks it is the sample index (each individual's times are in ``step_time``).

Every step lands in exactly one bucket (``step_class``, counted in ``data_quality``;
the counts sum to ``n_steps_total``), checked in this order:

``missing_position``
    an end's position is missing (NaN, inf, or ``confidence < min_confidence``);
``time_gap``
    longer than ``gap_factor`` times the individual's own median step: an average,
    not an instantaneous, velocity;
``static_track``
    the individual's positions stay within ``min_track_extent`` mm (bounding-box
    diagonal): a static object the tracker followed (debris, a shadow), not an
    animal; off unless ``min_track_extent`` is given;
``over_max_speed``
    faster than ``max_speed``;
``implausible``
    faster than the individual's implausible-motion threshold (identity swaps,
    tracker glitches; :func:`implausible_thresholds`); kept with
    ``keep_implausible``;
``resting``
    speed at or below ``resting_speed`` (default 0: the tracker reports no motion);
    the energy law is about moving animals, so resting steps are left out of the fits
    and their fraction reported; kept with ``keep_resting``;
``stationary_dropped``
    in a long stationary period, with ``drop_stationary``;
``used``
    everything else; ``n_steps_used_regular`` of them lie within
    ``regular_tolerance`` of the individual's median step, ``n_steps_used_irregular``
    do not (each uses its own duration either way).

Before the steps: samples without a time are dropped (``n_missing_timestamps``);
each individual's samples are sorted by time (``n_decreasing_timestamps`` counts the
backward steps); samples at equal times are exact duplicates (dropped,
``n_duplicate_rows``) or conflicts resolved by ``duplicates`` (``"error"``,
``"first"`` or ``"mean"``; ``n_conflicting_duplicates``; readers count theirs too);
missing-position gaps up to ``max_gap`` s are interpolated
(``n_interpolated_positions``); with ``held_positions="missing"``, a sample whose
position repeats the previous one exactly is taken as held by the tracker and missing.

The turn at row ``k`` is paired with the speed of the step that follows it (the
robots' algorithms sample a heading and a speed together, then turn and move).
Velocities are differences of consecutive (optionally smoothed) positions, not central
differences: a central difference averages two steps and would change the very
distribution under test.  Smoothing (``smooth`` seconds): a Savitzky-Golay filter
(:func:`scipy.signal.savgol_filter`) of each contiguous segment, the window the odd
number of samples nearest to ``smooth`` s at the individual's median step; irregular
segments are interpolated onto a regular grid, filtered and interpolated back.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.analysis.exclusions import (
    CODE,
    STEP_BUCKETS,
    STEP_CLASSES,
    excluded_summary,
    implausible_thresholds,
)
from thermoswarm.analysis.samples import (
    clean_columns,
    interpolate_gaps,
    runs,
    smooth_positions,
)
from thermoswarm.errors import ConfigError, InputError
from thermoswarm.tracks import (
    DUPLICATE_RULES,
    centroid,
    individual_times,
    per_individual,
    validate_tracks,
)

__all__ = [
    "compute_kinematics",
    "data_quality",
    "implausible_thresholds",
    "excluded_summary",
    "DATA_QUALITY_KEYS",
    "STEP_CLASSES",
    "STEP_BUCKETS",
]

#: Largest (samples x individuals) table the kinematics work on: about 170 bytes per
#: cell are held at the peak (positions, steps, energies, flags), so 5e7 cells is
#: about 8.5 GB; above it the analysis refuses at once instead of exhausting memory.
MAX_CELLS = 50_000_000

#: The counters written to ``attrs`` and ``fits.json["data_quality"]``, in order.
DATA_QUALITY_KEYS = (
    "n_individuals",
    "n_individuals_one_sample",
    "n_samples_input",
    "n_samples",
    "n_missing_timestamps",
    "n_decreasing_timestamps",
    "n_duplicate_rows",
    "n_conflicting_duplicates",
    "median_dt",
    "median_dt_min",
    "median_dt_max",
    "n_nonfinite_positions",
    "n_low_confidence",
    "n_held_positions",
    "n_missing_positions",
    "n_gaps",
    "n_interpolated_positions",
    "n_segments",
    "n_segments_smoothed",
    "n_segments_resampled",
    "n_segments_unsmoothed",
    "smooth_window_samples",
    "n_steps_total",
    *STEP_BUCKETS,
    "n_steps_used_regular",
    "n_steps_used_irregular",
    "n_irregular_steps",
    "n_implausible_kept",
    "n_resting_kept",
    "resting_fraction",
    "n_individuals_all_implausible",
    "n_static_tracks",
    "n_zero_speed",
    "n_steering_samples",
    "n_steering_undefined",
    "n_steering_near_wrap",
    "n_stationary_periods",
    "n_stationary_steps",
    "stationary_seconds",
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


# --------------------------------------------------------------------------------------
# Samples: each individual's own, sorted, duplicates resolved


# --------------------------------------------------------------------------------------
# Implausible motion


# --------------------------------------------------------------------------------------
# The kinematics


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
    gap_factor: float = 1.5,
    regular_tolerance: float = 0.1,
    max_gap: float = 0.0,
    stationary_speed: float | None = None,
    stationary_duration: float = 1.0,
    drop_stationary: bool = False,
    min_confidence: float | None = None,
    duplicates: str = "error",
    held_positions: str = "resting",
    resting_speed: float = 0.0,
    keep_resting: bool = False,
    implausible_factor: float = 5.0,
    body_length: float | None = None,
    max_body_lengths_per_s: float = 50.0,
    keep_implausible: bool = False,
    min_track_extent: float | None = None,
) -> xr.Dataset:
    """Kinematics of every step of every track.

    Parameters
    ----------
    ds
        Trajectories (positions in mm), on a shared clock or per-individual clocks.
    fps
        Frame rate, needed when the time coordinate holds frame numbers.
    keypoint
        Keypoint to follow; default the centroid (:func:`thermoswarm.tracks.centroid`).
    smooth, polyorder
        Savitzky-Golay window in seconds (``None``: no smoothing) and order.
    mass
        Mass in kg: energies ``m v^2 / 2`` in joules.  Default: per unit mass,
        ``v^2 / 2`` in mm^2/s^2.
    min_speed
        Heading is undefined for steps with ``speed <= min_speed`` (mm/s).
    max_speed
        Steps faster than this (mm/s) are not used.
    gap_factor
        Steps longer than ``gap_factor`` times the individual's median step are gaps
        (default 1.5: one missed sample makes a gap).
    regular_tolerance
        A step is regular within this fraction of the individual's median step
        (default 0.1: time stamps rounded to the millisecond at 10 Hz are regular).
    max_gap
        Missing-position gaps up to this long (s) are linearly interpolated.
    stationary_speed, stationary_duration, drop_stationary
        A long stationary period: at least ``stationary_duration`` s of steps with
        ``speed <= stationary_speed`` (mm/s; default ``min_speed``); flagged, and
        left out of the energies with ``drop_stationary``.
    min_confidence
        Positions whose ``confidence`` is below this are treated as missing.
    duplicates
        Two different samples of one individual at one time: ``"error"`` (default),
        ``"first"`` or ``"mean"``.  Exact duplicates are dropped and counted.
    held_positions
        ``"resting"`` (default): a repeated position is a step at zero speed;
        ``"missing"``: it was held by the tracker, the sample is missing.
    resting_speed, keep_resting
        Steps at or below ``resting_speed`` (mm/s) are resting: left out of the fits
        (counted, ``resting_fraction``) unless ``keep_resting``.
    implausible_factor, body_length, max_body_lengths_per_s, keep_implausible
        The implausible-motion rule (:func:`implausible_thresholds`); implausible
        steps are left out unless ``keep_implausible``.  ``body_length`` in mm.
    min_track_extent
        Individuals whose positions stay within this many mm (bounding-box diagonal)
        are static objects, not animals: their steps are left out (``static_track``).

    Returns
    -------
    xarray.Dataset
        See the module docstring; the counts are in ``attrs``.
    """
    ds = validate_tracks(ds, source=ds.attrs.get("source_file"))
    src = str(ds.attrs.get("source_file") or "the input")
    smooth = _check_param("smooth", smooth, positive=True)
    mass = _check_param("mass", mass, positive=True)
    min_speed = _check_param("min_speed", min_speed, allow_none=False)
    max_speed = _check_param("max_speed", max_speed, positive=True)
    gap_factor = _check_param("gap_factor", gap_factor, positive=True, allow_none=False)
    regular_tolerance = _check_param(
        "regular_tolerance", regular_tolerance, positive=True, allow_none=False
    )
    max_gap = _check_param("max_gap", max_gap, allow_none=False)
    stationary_speed = _check_param("stationary_speed", stationary_speed)
    stationary_duration = _check_param(
        "stationary_duration", stationary_duration, allow_none=False
    )
    min_confidence = _check_param("min_confidence", min_confidence)
    min_track_extent = _check_param("min_track_extent", min_track_extent, positive=True)
    resting_speed = _check_param("resting_speed", resting_speed, allow_none=False)
    implausible_factor = _check_param(
        "implausible_factor", implausible_factor, positive=True, allow_none=False
    )
    body_length = _check_param("body_length", body_length, positive=True)
    max_body_lengths_per_s = _check_param(
        "max_body_lengths_per_s", max_body_lengths_per_s, positive=True, allow_none=False
    )
    if int(polyorder) != polyorder or polyorder < 1:
        raise ConfigError(f"polyorder must be an integer >= 1, got {polyorder!r}")
    if gap_factor < 1:
        raise ConfigError(f"gap_factor must be at least 1, got {gap_factor!r}")
    if regular_tolerance >= 1:
        raise ConfigError(f"regular_tolerance must be below 1, got {regular_tolerance!r}")
    if implausible_factor <= 1:
        raise ConfigError(f"implausible_factor must exceed 1, got {implausible_factor!r}")
    if duplicates not in DUPLICATE_RULES:
        raise ConfigError(
            f"duplicates must be one of {', '.join(DUPLICATE_RULES)}, got {duplicates!r}"
        )
    if held_positions not in ("resting", "missing"):
        raise ConfigError(f"held_positions must be 'resting' or 'missing', got {held_positions!r}")
    if stationary_speed is None:
        stationary_speed = min_speed

    counts: dict[str, Any] = dict.fromkeys(DATA_QUALITY_KEYS, 0)
    for k in ("n_duplicate_rows", "n_conflicting_duplicates", "n_decreasing_timestamps"):
        counts[k] = int(ds.attrs.get(k, 0) or 0)  # what the reader sorted and resolved
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
    names = [str(v) for v in ds["individuals"].values]
    T0 = individual_times(ds, fps)
    X = np.asarray(pos.sel(space="x").values, dtype=np.float64)
    Y = np.asarray(pos.sel(space="y").values, dtype=np.float64)
    n_i = X.shape[1]
    counts["n_individuals"] = n_i
    # samples given: every (row, individual) of a shared axis; the timed rows otherwise
    counts["n_samples_input"] = int(np.isfinite(T0).sum() if per_individual(ds) else T0.size)
    nonfinite = (np.isinf(X) | np.isinf(Y)) & ~(np.isnan(X) | np.isnan(Y))
    # with those the reader found (infinite or beyond thermoswarm.io._common.MAX_ABS_MM)
    counts["n_nonfinite_positions"] = int(nonfinite.sum()) + int(
        ds.attrs.get("n_nonfinite_positions", 0) or 0
    )
    if nonfinite.any():
        X = np.where(nonfinite, np.nan, X)
        Y = np.where(nonfinite, np.nan, Y)
    if T0.shape[0] * n_i > MAX_CELLS:
        n_samples = int(np.isfinite(T0).sum())
        raise InputError(
            f"{src}: {n_i} individuals x {T0.shape[0]} samples (the longest track) is "
            f"{T0.shape[0] * n_i:.3g} cells, above the {MAX_CELLS:.0e} the analysis works "
            f"on ({100 * n_samples / (T0.shape[0] * n_i):.1f} % of them hold samples); "
            "merge fragmented track ids or analyse the recording in parts"
        )
    T, X, Y, input_row = clean_columns(
        T0, X, Y, duplicates, names, src, counts, per_individual(ds)
    )
    # One shared, clean time axis (the common case: a video's frames): every column of T
    # is the same view, so the steps and the median step are computed once.
    one_axis = T is T0 and not per_individual(ds)
    sample = np.isfinite(T)
    n_per = sample.sum(axis=0)
    counts["n_samples"] = int(n_per.sum())
    counts["n_individuals_one_sample"] = int((n_per == 1).sum())
    if not (n_per >= 2).any():
        raise InputError(
            f"{src}: need at least 2 samples of one individual to form a step; the most "
            f"any individual has is {int(n_per.max(initial=0))}"
        )
    if held_positions == "missing":
        held = np.zeros_like(sample)
        held[1:] = sample[1:] & (X[1:] == X[:-1]) & (Y[1:] == Y[:-1])
        counts["n_held_positions"] = int(held.sum())
        X = np.where(held, np.nan, X)
        Y = np.where(held, np.nan, Y)

    # Steps and each individual's own median step
    exists = sample[1:] & sample[:-1]
    has = exists.any(axis=0)
    med = np.full(n_i, np.nan)
    if one_axis:
        dt1 = np.diff(T[:, 0])
        dt = np.broadcast_to(dt1[:, None], exists.shape)
        med[:] = float(np.median(dt1))
    else:
        with np.errstate(invalid="ignore"):
            dt = np.diff(T, axis=0)
        if has.any():
            med[has] = np.nanmedian(np.where(exists[:, has], dt[:, has], np.nan), axis=0)
    meds = med[has]
    counts["median_dt"] = float(np.median(meds))
    counts["median_dt_min"] = float(meds.min())
    counts["median_dt_max"] = float(meds.max())
    with np.errstate(invalid="ignore"):
        regular = exists & (np.abs(dt - med) <= regular_tolerance * med)
        gap = exists & (dt > gap_factor * med)
    counts["n_irregular_steps"] = int((exists & ~regular).sum())
    counts["n_steps_total"] = int(exists.sum())

    present = sample & np.isfinite(X) & np.isfinite(Y)
    idx = np.arange(T.shape[0])[:, None]
    seen_before = np.maximum.accumulate(np.where(present, idx, -1), axis=0) >= 0
    seen_after = (
        np.minimum.accumulate(np.where(present, idx, T.shape[0])[::-1], axis=0)[::-1] < T.shape[0]
    )
    holes = sample & ~present
    counts["n_missing_positions"] = int(holes.sum())
    counts["n_gaps"] = int(runs(holes & seen_before & seen_after)[0].size)
    if max_gap > 0:
        X, Y = interpolate_gaps(T, X, Y, sample, max_gap, counts)
        present = sample & np.isfinite(X) & np.isfinite(Y)
    if smooth is not None:
        link = present[:-1] & present[1:] & exists & ~gap
        X, Y = smooth_positions(
            T, X, Y, link, med, smooth, int(polyorder), exists & ~regular, counts
        )
    else:
        si, _, _ = runs(present)
        counts["n_segments"] = int(si.size + (present[:-1] & present[1:] & gap).sum())

    # Buckets, in order
    both = exists & present[:-1] & present[1:]
    dx = np.diff(X, axis=0)
    dy = np.diff(Y, axis=0)
    cls = np.full(dt.shape, -1, dtype=np.int8)
    cls[exists & ~both] = CODE["missing_position"]
    cls[both & gap] = CODE["time_gap"]
    measured = both & ~gap
    if min_track_extent is not None:
        with np.errstate(invalid="ignore"):
            xs, ys = np.where(present, X, np.nan), np.where(present, Y, np.nan)
        ok_cols = present.any(axis=0)
        extent = np.zeros(n_i)
        if ok_cols.any():
            px, py = xs[:, ok_cols], ys[:, ok_cols]
            extent[ok_cols] = np.hypot(
                np.nanmax(px, axis=0) - np.nanmin(px, axis=0),
                np.nanmax(py, axis=0) - np.nanmin(py, axis=0),
            )
        static = ok_cols & (extent < min_track_extent)
        counts["n_static_tracks"] = int(static.sum())
        cls[measured & static[None, :]] = CODE["static_track"]
        measured &= ~static[None, :]
    with np.errstate(invalid="ignore", divide="ignore"):
        speed_s = np.where(measured, np.hypot(dx, dy) / np.where(measured, dt, 1.0), np.nan)
    cand = measured.copy()
    if max_speed is not None:
        fast = cand & (speed_s > max_speed)
        cls[fast] = CODE["over_max_speed"]
        cand &= ~fast
    resting = cand & (speed_s <= resting_speed)
    thr, rule = implausible_thresholds(
        speed_s, cand & ~resting, factor=implausible_factor, body_length=body_length,
        max_body_lengths_per_s=max_body_lengths_per_s,
    )  # fmt: skip
    implausible = cand & (speed_s > thr[None, :])
    moving_cand = (cand & ~resting).sum(axis=0)
    all_bad = (moving_cand > 0) & (implausible.sum(axis=0) == moving_cand)
    counts["n_individuals_all_implausible"] = int(all_bad.sum())
    if keep_implausible:
        counts["n_implausible_kept"] = int(implausible.sum())
    else:
        cls[implausible] = CODE["implausible"]
        cand &= ~implausible
    resting &= cand
    n_rest = int(resting.sum())
    if keep_resting:
        counts["n_resting_kept"] = n_rest
    else:
        cls[resting] = CODE["resting"]
        cand &= ~resting

    # Long stationary periods (among measured, plausible steps)
    still = (cand | resting) & (speed_s <= stationary_speed)
    stationary = np.zeros_like(still)
    si, st, en = runs(still)
    if si.size:
        dur = T[en, si] - T[st, si]  # a run of steps st..en-1 spans samples st..en
        long_ = dur >= stationary_duration
        counts["n_stationary_periods"] = int(long_.sum())
        counts["stationary_seconds"] = float(dur[long_].sum())
        for i, a, b in zip(si[long_].tolist(), st[long_].tolist(), en[long_].tolist(),
                           strict=True):  # fmt: skip
            stationary[a:b, i] = True
    counts["n_stationary_steps"] = int(stationary.sum())
    if drop_stationary:
        drop = cand & stationary
        cls[drop] = CODE["stationary_dropped"]
        cand &= ~drop
    used = cand
    cls[used] = CODE["used"]
    for c, key in zip(STEP_CLASSES, STEP_BUCKETS, strict=True):
        counts[key] = int((cls == CODE[c]).sum())
    counts["n_steps_used_regular"] = int((used & regular).sum())
    counts["n_steps_used_irregular"] = int((used & ~regular).sum())
    denom = int(used.sum()) + (0 if keep_resting else n_rest)  # plausible measured steps
    counts["resting_fraction"] = float(n_rest / denom) if denom else 0.0

    moving = used & (speed_s > min_speed)
    counts["n_zero_speed"] = int((used & ~moving).sum())
    heading_s = np.where(moving, np.arctan2(dy, dx), np.nan)
    dh = heading_s[1:] - heading_s[:-1]
    dh = (dh + np.pi) % (2 * np.pi) - np.pi
    mid_dt = 0.5 * (dt[:-1] + dt[1:])
    steer_ok = moving[:-1] & moving[1:]
    counts["n_steering_samples"] = int(steer_ok.sum())
    counts["n_steering_undefined"] = int((used[:-1] & used[1:] & ~steer_ok).sum())
    counts["n_steering_near_wrap"] = int((steer_ok & (np.abs(dh) > 0.9 * np.pi)).sum())
    with np.errstate(invalid="ignore", divide="ignore"):
        rate_s = np.where(steer_ok, dh / np.where(steer_ok, mid_dt, 1.0), np.nan)

    n_t = T.shape[0]

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
    energy = np.where(on_rows(used, False), energy, np.nan)
    dims = ("time", "individuals")
    shared = one_axis or bool(
        n_i == 1 or np.array_equal(T, np.broadcast_to(T[:, :1], T.shape), equal_nan=True)
    )
    time_coord = T[:, 0] if shared else np.arange(n_t, dtype=np.float64)
    out = xr.Dataset(
        {
            "step_time": (dims, T, {"units": "s", "description": "time of the step's start"}),
            "dt": (dims, on_rows(dt, np.nan), {"units": "s"}),
            "speed": (dims, speed, {"units": "mm/s"}),
            "energy": (dims, energy, {"units": e_unit}),
            "heading": (dims, on_rows(heading_s, np.nan), {"units": "rad"}),
            "steering_rate": (dims, on_rows(rate_s, np.nan, first=True), {"units": "rad/s"}),
            "x_mid": (dims, on_rows(0.5 * (X[:-1] + X[1:]), np.nan), {"units": "mm"}),
            "y_mid": (dims, on_rows(0.5 * (Y[:-1] + Y[1:]), np.nan), {"units": "mm"}),
            "step_class": (
                dims,
                on_rows(cls, np.int8(-1)),
                {"codes": ",".join(STEP_CLASSES), "no_step": -1},
            ),
            "valid": (dims, on_rows(used, False)),
            "steering_valid": (dims, on_rows(steer_ok, False, first=True)),
            "stationary": (dims, on_rows(stationary, False)),
            "input_row": (dims, input_row, {"description": "input row of the step's start"}),
            "implausible_threshold": (
                ("individuals",),
                np.where(np.isfinite(thr), thr, np.nan),
                {"units": "mm/s"},
            ),
            "median_dt": (("individuals",), med, {"units": "s"}),
        },
        coords={"time": time_coord, "individuals": ds["individuals"].values},
    )
    out["time"].attrs.update(
        {"units": "s", "convention": "start of the step"}
        if shared
        else {"description": "sample index; each individual's times are in step_time"}
    )
    params = {
        "energy_unit": e_unit,
        "clock": "shared" if shared else "per_individual",
        "mass_kg": mass,
        "smooth_s": smooth,
        "polyorder": int(polyorder) if smooth is not None else None,
        "min_speed": min_speed,
        "max_speed": max_speed,
        "gap_factor": gap_factor,
        "regular_tolerance": regular_tolerance,
        "max_gap_s": max_gap,
        "stationary_speed": stationary_speed,
        "stationary_duration_s": stationary_duration,
        "drop_stationary": int(bool(drop_stationary)),
        "min_confidence": min_confidence,
        "min_track_extent": min_track_extent,
        "duplicates": duplicates,
        "held_positions": held_positions,
        "resting_speed": resting_speed,
        "keep_resting": int(bool(keep_resting)),
        "keep_implausible": int(bool(keep_implausible)),
        "implausible_rule": json.dumps(rule),
        "keypoint": keypoint,
        "source_file": ds.attrs.get("source_file"),
        "source_software": ds.attrs.get("source_software"),
    }
    out.attrs.update({k: v for k, v in params.items() if v is not None})
    out.attrs.update(counts)
    return out


def data_quality(kin: xr.Dataset) -> dict[str, Any]:
    """The data-quality counts of a kinematics dataset, as a plain dict.

    ``step_buckets`` repeats the bucket counts by name; they sum to ``n_steps_total``.
    """
    out: dict[str, Any] = {}
    for k in DATA_QUALITY_KEYS:
        v = kin.attrs.get(k, 0)
        out[k] = float(v) if isinstance(v, float | np.floating) else int(v)
    out["step_buckets"] = {c: out[k] for c, k in zip(STEP_CLASSES, STEP_BUCKETS, strict=True)}
    return out
